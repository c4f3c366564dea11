"""Per-step speed of the C integrators on the reference arm, against another checkout's library.

Run: ``.venv/bin/python benchmarks/step_speed.py [--nrfe 5] [--rounds 7] [--other DIR]``.
Measured: RK4 (the model library's ``rk4``, 20 000 steps of 1e-5 s) and generalized-α
(``gpmegen.runtime.integrators.genalpha.genalpha``, 2 000 steps of 1e-4 s with projection, the Newton matrix
kept across steps), from the paper's start with the flexible coordinates zero, in CPU time (the
process's own: on a shared machine its wall time counts the other processes' turns), the best of
3 runs per round.

With ``--other DIR`` (a checkout of another commit, e.g. a ``git worktree`` of it), DIR's gpmegen
first builds the same model into a library of its own (imported with this environment's Python
through ``PYTHONPATH``; its ``templates/`` must then be importable as ``gpmegen.templates`` from
DIR: link it once with ``ln -s ../templates DIR/gpmegen/templates``, the script refuses
otherwise). Then one process loads both libraries (the same exported functions: model.h does not
change) and times them in alternation, round after round, so that both see the same load, the
same Python and the same driver. Each checkout builds into a temporary generated folder and C
cache (the compile is not timed here: benchmarks/build_time.py times it). The load average is
printed before and after.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

BUILD = r"""
import json, sys
from pathlib import Path
from importlib import resources
import gpmegen

root, nrfe = Path(sys.argv[1]).resolve(), int(sys.argv[2])
templates = Path(str(resources.files("gpmegen.templates"))).resolve()
if root not in Path(gpmegen.__file__).resolve().parents or root not in templates.parents:
    raise SystemExit(f"gpmegen or its templates do not come from {root} ({gpmegen.__file__}, {templates})")
model = gpmegen.load("manipulator", nrfe=nrfe, backend="c")
print(json.dumps({"library": str(model.evaluator.library.path)}))
"""

COMPARE = r"""
import copy, json, sys, time
from pathlib import Path
import numpy as np
import gpmegen
from gpmegen.runtime import ccompile, integrators

nrfe, rounds, other = int(sys.argv[1]), int(sys.argv[2]), sys.argv[3]
model = gpmegen.load("manipulator", nrfe=nrfe, backend="c")
models = {"this": model}
if other:
    twin = copy.copy(model.evaluator)
    header = (Path(model.folder) / ccompile.HEADER).read_text()
    twin.ffi, twin.lib = ccompile.open_library(Path(other), header)
    models["other"] = copy.copy(model)
    models["other"].evaluator = twin
q = np.zeros(model.n_dof)
q[model.index("psi2")] = np.pi / 4
qd = np.zeros(model.n_dof)


def best(run, n_steps, repeat=3):
    run()
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        run()
        times.append(time.process_time() - t0)
    return min(times) / n_steps


def rk4(m):
    *_, status = m.rk4(q, qd, 20000 * 1e-5, 1e-5, save_every=20000)
    assert status == 0, status


def genalpha(m):
    *_, outcome, effort = integrators.genalpha.genalpha(m, q, qd, 2000 * 1e-4, 1e-4, 1e-2, project=True)
    assert outcome.complete, outcome


final = {name: m.rk4(q, qd, 0.01, 1e-5, save_every=1000)[1][-1] for name, m in models.items()}
assert all(np.array_equal(final["this"], y) for y in final.values()), "the libraries' runs differ"
for k in range(rounds):
    row = {name: {"rk4": best(lambda: rk4(m), 20000), "genalpha": best(lambda: genalpha(m), 2000)}
           for name, m in models.items()}
    print(json.dumps(row), flush=True)
"""


def load() -> str:
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def child(code: str, root: Path, folder: Path, *args) -> subprocess.Popen:
    env = {**os.environ, "PYTHONPATH": str(root), "GPMEGEN_GENERATED": str(folder / "generated"),
           "GPMEGEN_CACHE": str(folder / "cache")}
    return subprocess.Popen([sys.executable, "-c", code, *map(str, args)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=folder)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--nrfe", type=int, default=5)
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--other", type=Path, help="another checkout, its library measured beside this one's")
    args = parser.parse_args()
    print(f"load average before: {load()}")
    rows = []
    with tempfile.TemporaryDirectory(prefix="gpmegen-step-speed-") as tmp:
        other = ""
        if args.other:
            Path(tmp, "other").mkdir()
            run = child(BUILD, args.other.resolve(), Path(tmp, "other"), args.other.resolve(), args.nrfe)
            out, err = run.communicate()
            if run.returncode != 0:
                raise SystemExit(f"{args.other}: {err.strip().splitlines()[-1] if err.strip() else run.returncode}")
            other = json.loads(out.strip().splitlines()[-1])["library"]
        Path(tmp, "this").mkdir()
        run = child(COMPARE, ROOT, Path(tmp, "this"), args.nrfe, args.rounds, other)
        for line in run.stdout:
            rows.append(json.loads(line))
            print(f"round {len(rows)}: " + "; ".join(f"{name} rk4 {r['rk4'] * 1e6:.2f} µs, genalpha "
                                                     f"{r['genalpha'] * 1e6:.2f} µs" for name, r in rows[-1].items()),
                  flush=True)
        if run.wait() != 0:
            raise SystemExit(run.stderr.read().strip()[-2000:])
    print(f"load average after: {load()}")
    print(f"n_rfe = {args.nrfe}: µs of CPU per step, best and median of {args.rounds} rounds (steps per second of "
          f"the best)")
    for name in rows[0]:
        for method in ("rk4", "genalpha"):
            values = [row[name][method] for row in rows]
            print(f"  {name:5s} {method:8s} best {min(values) * 1e6:7.2f}  median "
                  f"{statistics.median(values) * 1e6:7.2f}  ({1 / min(values):,.0f} steps/s)")
    if len(rows[0]) == 2:
        for method in ("rk4", "genalpha"):
            ratios = [row["this"][method] / row["other"][method] for row in rows]
            print(f"  {method}: this / other per round, median {statistics.median(ratios):.3f} "
                  f"(range {min(ratios):.3f}-{max(ratios):.3f})")


if __name__ == "__main__":
    main()
