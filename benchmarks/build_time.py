"""From a model to a loaded C library: derive, emit and compile, against the model's size.

Run: ``.venv/bin/python benchmarks/build_time.py [--nrfe 1 5 10] [--full]``. Each model is built
in a fresh process (no warm SymPy caches) into a temporary generated folder and a temporary, empty
C cache, and loaded on the C backend. Phases, from the progress lines of the build:

- derive: the symbolic derivation; emit: common subexpressions, printing both backends and
  writing the folder (and the CPU time of both, beside them); solver: the solver library's
  one-time compile (gpmegen/csrc, once per machine and flags: the empty cache pays it, every
  later model reuses it; wall and compilers' CPU time); compile: the model's own compiler runs
  (wall time, and the compilers' CPU time, which a busy machine does not inflate); load: the test run
  of the library in a child process and its loading (with the fast-call extension's compile and
  test run, here in the empty cache, elsewhere once per Python and NumPy).
- peak memory: of the building process, and of the largest child (a compiler, or the test run).

``--full`` runs n_rfe 1, 5, 10, 20, 30, 50 of the reference arm and
``examples/spatial_six_joint.toml`` at nrfe 10 (many minutes; ``--spatial`` adds the latter to the
sizes asked); the default stops at 10. The growth
exponents are least-squares slopes of log(time or size) against log(n_dof) over the reference
arm's rows. The load average is printed before and after: the machine may be shared.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
SPATIAL = ROOT / "examples" / "spatial_six_joint.toml"

CODE = r"""
import json, os, resource, shutil, sys, tempfile, time
from pathlib import Path

kind, nrfe = sys.argv[1], int(sys.argv[2])
tmp = tempfile.mkdtemp(prefix="gpmegen-build-time-")
os.environ["GPMEGEN_GENERATED"] = os.path.join(tmp, "generated")
os.environ["GPMEGEN_CACHE"] = os.path.join(tmp, "cache")
import gpmegen
from gpmegen import limits


def clock():
    child = resource.getrusage(resource.RUSAGE_CHILDREN)
    return time.perf_counter(), time.process_time(), child.ru_utime + child.ru_stime


marks = {"start": clock()}
self_peak = []


def progress(line):
    # the model's own lines: the fast-call extension's compile (once per Python and NumPy) comes
    # after them and counts in the load
    for name, prefix in (("derived", "derived "), ("solver", "compiling the solver library"),
                         ("solver_done", "compiled the solver library"), ("compile", "compiling model.c"),
                         ("compiled", "compiled model.c")):
        if line.startswith(prefix) and name not in marks:
            marks[name] = clock()
            if name == "compile":
                self_peak.append(resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024)


with limits.lifted():
    if kind == "nrfe":
        model = gpmegen.load("manipulator", nrfe=nrfe, backend="c", progress=progress)
    else:
        model = gpmegen.load(model=gpmegen.load_model_file(kind, nrfe), backend="c", progress=progress)
marks["end"] = clock()
files = {p.name: p.stat().st_size for p in Path(model.folder).iterdir() if p.is_file()}
child_peak = resource.getrusage(resource.RUSAGE_CHILDREN).ru_maxrss * 1024
print(json.dumps({"name": model.module.MODEL, "n_dof": model.n_dof, "marks": marks, "files": files,
                  "self_peak": self_peak[0], "child_peak": child_peak}))
shutil.rmtree(tmp, ignore_errors=True)
"""


def measure(kind: str, nrfe: int) -> dict:
    run = subprocess.run([sys.executable, "-c", CODE, kind, str(nrfe)], capture_output=True, text=True)
    if run.returncode != 0:
        raise SystemExit(f"{kind} {nrfe}: {run.stderr.strip()[-2000:]}")
    return phases(json.loads(run.stdout.strip().splitlines()[-1]))


def phases(r: dict) -> dict:
    """The phases' wall and CPU times (s) added to a child's record from its clock marks."""
    m = r["marks"]
    r["derive"] = m["derived"][0] - m["start"][0]
    r["derive_cpu"] = m["derived"][1] - m["start"][1]
    # the solver library's one-time compile (an empty cache: every build here pays it), apart
    r["solver"] = m["solver_done"][0] - m["solver"][0] if "solver" in m else 0.0
    r["solver_cpu"] = m["solver_done"][2] - m["solver"][2] if "solver" in m else 0.0
    r["emit"] = m["compile"][0] - m["derived"][0] - r["solver"]
    r["build_cpu"] = m["compile"][1] - m["start"][1]
    r["compile"] = m["compiled"][0] - m["compile"][0]
    r["compile_cpu"] = m["compiled"][2] - m["compile"][2]
    r["load"] = m["end"][0] - m["compiled"][0]
    r["total"] = m["end"][0] - m["start"][0]
    return r


def slope(xs, ys) -> float:
    """Least-squares slope of log(ys) against log(xs)."""
    lx, ly = [math.log(x) for x in xs], [math.log(max(y, 1e-9)) for y in ys]
    mx, my = sum(lx) / len(lx), sum(ly) / len(ly)
    return sum((a - mx) * (b - my) for a, b in zip(lx, ly)) / sum((a - mx) ** 2 for a in lx)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nrfe", type=int, nargs="+", default=[1, 5, 10])
    ap.add_argument("--full", action="store_true", help="n_rfe 1 5 10 20 30 50 and the spatial example")
    ap.add_argument("--spatial", action="store_true", help="also examples/spatial_six_joint.toml at nrfe 10")
    args = ap.parse_args()
    values = [1, 5, 10, 20, 30, 50] if args.full else args.nrfe
    print(f"load average before: {' '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} cores")
    header = (f"{'model':>26} {'n_dof':>5} {'derive':>7} {'emit':>7} {'(CPU)':>7} {'solver':>7} {'(CPU)':>7} "
              f"{'compile':>8} {'(CPU)':>7} {'load':>6} "
              f"{'total [s]':>9} {'model.c':>8} {'numpy':>7} {'build':>6} {'cc peak':>7}")
    print(header)
    print(f"{'':>26} {'':>5} {'[s]':>7} {'[s]':>7} {'[s]':>7} {'[s]':>7} {'[s]':>7} {'[s]':>8} {'[s]':>7} {'[s]':>6} "
          f"{'':>9} {'[KiB]':>8} "
          f"{'[KiB]':>7} {'[MB]':>6} {'[MB]':>7}")
    rows = []
    cases = [("nrfe", n) for n in values] + ([(str(SPATIAL), 10)] if args.full or args.spatial else [])
    for kind, n in cases:
        r = measure(kind, n)
        if kind == "nrfe":
            rows.append(r)
        print(f"{r['name']:>26} {r['n_dof']:>5} {r['derive']:>7.1f} {r['emit']:>7.1f} {r['build_cpu']:>7.1f} "
              f"{r['solver']:>7.1f} {r['solver_cpu']:>7.1f} {r['compile']:>8.1f} "
              f"{r['compile_cpu']:>7.1f} {r['load']:>6.1f} {r['total']:>9.1f} {r['files']['model.c'] / 1024:>8.0f} "
              f"{r['files']['model_numpy.py'] / 1024:>7.0f} {r['self_peak'] / 1e6:>6.0f} {r['child_peak'] / 1e6:>7.0f}",
              flush=True)
    print(f"load average after: {' '.join(f'{x:.1f}' for x in os.getloadavg())}")
    if len(rows) >= 2:
        n = [r["n_dof"] for r in rows]
        print("growth exponents against n_dof: " + ", ".join(
            f"{label} {slope(n, [r[key] for r in rows]):.2f}" for label, key in (
                ("derive+emit CPU", "build_cpu"), ("compile CPU", "compile_cpu"), ("total wall", "total"))) +
            f", model.c size {slope(n, [r['files']['model.c'] for r in rows]):.2f}")


if __name__ == "__main__":
    main()
