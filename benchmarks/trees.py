"""Trees: the cold build against the number of coordinates, and q̈ against ``pinocchio.aba``.

Run: ``.venv/bin/python benchmarks/trees.py [--sizes 10 25 50 100] [--robots solo12 baxter icub]
[--rounds 4] [--skip-build] [--skip-versus]`` (the ``[test]`` extras: ``pin`` and
``example-robot-data``). Two parts, in one process:

1. The cold build, in one table: random serial chains and random trees (``Branch`` elements) of
   ``--sizes`` rigid joints (revolute and prismatic about random axes, bodies with random
   inertias), and branched URDF robots of ``example-robot-data`` imported whole: Solo-12 (12
   coordinates), Baxter (19), the reduced iCub (29), and the iCub with its longest links made
   flexible (:class:`~gpmegen.model.urdf.FlexibleUrdfLink`, each beam along its link's frame to
   the joint it carries, its rfes adding 3 coordinates an sde) to about 50 and 100 coordinates.
   Each is built in a fresh process into an empty generated folder and an empty C cache
   (``GPMEGEN_GENERATED``, ``GPMEGEN_CACHE``) and loaded on the C backend; the phases are those
   of ``benchmarks/build_time.py`` (derive; emit: common subexpressions, printing, writing;
   solver: the solver library's one-time compile, which the empty cache makes every row pay;
   compile: the model's compilers run; load: the library's test run and loading, with the fast-call
   extension's compile in the empty cache), each row with its wall and CPU time (the building
   process's and its children's: the compilers run two at once) and the 1-minute load average
   after it.
2. One ``accelerations`` call from Python (C backend) of each URDF tree, rigid and without its
   mimic constraints, against ``pinocchio.aba`` on Pinocchio's model of the same URDF, called
   from Python in the same process, interleaved, best of ``--rounds`` rounds (each a best of
   repeats); beside it the bare C call as ``benchmarks/runtime.py`` measures it (the library's
   ``gpme_accelerations`` through cffi with its arguments prepared), so that the Python side is
   visible. The two q̈ are compared at the state timed (Pinocchio's torque is the URDF's joint
   damping, which gpmegen's model includes). These models are loaded the usual way
   (``GPMEGEN_GENERATED`` / ``GPMEGEN_CACHE`` choose the folders): built once, cached after.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import os
import random
import resource
import shutil
import subprocess
import sys
import tempfile
import time
from importlib import metadata
from pathlib import Path

import numpy as np
from build_time import phases
from runtime import per_call, raw_call

ROBOTS = {
    "solo12": "robots/solo_description/robots/solo12.urdf",
    "baxter": "robots/baxter_description/urdf/baxter.urdf",
    "icub": "robots/icub_description/robots/icub_reduced.urdf",
}
# the iCub with its K longest links flexible, of N rfes each: 29 + K·3(N - 1) coordinates
FLEXIBLE_ICUB = ("icub:3:3", "icub:4:7")
BEAM = {"section": (0.04, 0.01), "density": 2700.0, "young_modulus": 7e10, "shear_modulus": 2.6e10,
        "damping": (0.02, 0.02, 0.02)}


def robot_file(key: str) -> Path:
    try:
        files = metadata.files("example-robot-data") or []
    except metadata.PackageNotFoundError:
        raise SystemExit("example-robot-data is not installed; install the test extras: "
                         "pip install -e '.[test]'") from None
    return Path(next(f for f in files if str(f).endswith(ROBOTS[key])).locate())


# ============================================================================================
# The models
# ============================================================================================


def random_model(n: int, branched: bool, seed: int = 1):
    """``n`` rigid joints, each after an offset (random translation and turn) from a point of its
    parent's frame: the joint before it (``branched`` False: a serial chain), or (True) the joint
    before it two times in three and otherwise any earlier joint or the ground, each joint a
    ``Branch`` from its parent's point. Revolute two times in three, else prismatic, about
    x, y, z or a random unit axis; each carries a body of random mass, centre and inertia."""
    from gpmegen.model import shapes
    from gpmegen.model.chain import Body, Branch, Joint, Model, Offset, Parameter, Point

    rnd = random.Random(seed)
    parents = [j - 1 if not branched or j == 0 or rnd.random() < 2 / 3 else rnd.randint(-1, j - 2)
               for j in range(n)]
    chain = []
    for j, parent in enumerate(parents):
        if branched:
            chain.append(Branch("ground" if parent < 0 else f"P{parent}_{j}"))
        rotations = tuple((rnd.choice("xyz"), round(rnd.uniform(-1.5, 1.5), 4)) for _ in range(rnd.randint(0, 2)))
        chain.append(Offset(tuple(round(rnd.uniform(-0.3, 0.3), 4) for _ in range(3)), rotations))
        axis = rnd.choice(["x", "y", "z", tuple(float(a) for a in _unit(rnd))])
        chain.append(Joint(f"q{j}", "revolute" if rnd.random() < 2 / 3 else "prismatic", axis))
        chain += [Point(f"P{j}_{k}", tuple(round(rnd.uniform(-0.3, 0.3), 4) for _ in range(3)))
                  for k in range(j + 1, n) if branched and parents[k] == j]
        a, b = rnd.uniform(0.005, 0.05), rnd.uniform(0.005, 0.05)
        inertia = np.diag([a, b, rnd.uniform(abs(a - b) + 1e-3, a + b)])
        centre = tuple(round(rnd.uniform(-0.2, 0.2), 4) for _ in range(3))
        chain.append(Body(f"b{j}", shapes.from_inertia_tensor(round(rnd.uniform(0.3, 5.0), 4), centre,
                                                              inertia.tolist())))
    name = f"{'tree' if branched else 'serial'}{n}"
    return Model(name, (Parameter("unused", 1.0),), tuple(chain), gravity=(0.0, 0.0, -9.81))


def _unit(rnd):
    v = np.array([rnd.gauss(0, 1) for _ in range(3)])
    return v / np.linalg.norm(v)


def longest_links(tree, count: int) -> list:
    """``(link, unit direction, length)`` of the ``count`` links whose moving child joint lies
    farthest from the link's frame (the longest first; ties by name)."""
    found = {}
    for joint in tree.joints:
        offset = np.asarray(joint.origin)[:3, 3]
        length = float(np.linalg.norm(offset))
        if joint.type != "fixed" and length > found.get(joint.parent, (None, 0.0))[1]:
            found[joint.parent] = (tuple(float(x) for x in offset / length), length)
    ranked = sorted(found.items(), key=lambda item: (-item[1][1], item[0]))
    return [(link, along, length) for link, (along, length) in ranked[:count]]


def urdf_model(spec: str):
    """``ROBOT`` or ``ROBOT:K:N`` (its K longest links flexible, N rfes each): the URDF tree
    imported whole, without its mimic constraints."""
    from gpmegen.model.chain import FlexibleLink, RectangularSection
    from gpmegen.model.urdf import FlexibleUrdfLink, import_urdf
    from gpmegen.model.urdf_tree import read_tree

    key, *rest = spec.split(":")
    tree = read_tree(robot_file(key))
    flexible = ()
    if rest:
        count, n_rfe = (int(x) for x in rest)
        flexible = tuple(FlexibleUrdfLink(link, along, FlexibleLink(
            f"f{k}", round(length, 4), RectangularSection(*BEAM["section"]), density=BEAM["density"],
            young_modulus=BEAM["young_modulus"], shear_modulus=BEAM["shear_modulus"], n_rfe=n_rfe,
            damping=BEAM["damping"])) for k, (link, along, length) in enumerate(longest_links(tree, count)))
    imported = import_urdf(tree, flexible=flexible)
    name = f"tree_{key}" + (f"_{rest[0]}x{rest[1]}" if rest else "")
    return imported, dataclasses.replace(imported.model, name=name, constraints=(), dependent=None)


def model_of(spec: str):
    kind, _, rest = spec.partition(":")
    if kind in ("serial", "tree"):
        return random_model(int(rest), kind == "tree")
    return urdf_model(rest)[1]


# ============================================================================================
# 1. The cold build, in a fresh process
# ============================================================================================


def child(spec: str):
    """Build ``spec`` on the C backend (the folders are the empty ones the parent chose) and print
    the clock marks, as benchmarks/build_time.py's child does."""
    import gpmegen
    from gpmegen import limits

    def clock():
        used = resource.getrusage(resource.RUSAGE_CHILDREN)
        return time.perf_counter(), time.process_time(), used.ru_utime + used.ru_stime

    marks = {"start": clock()}
    prefixes = (("derived", "derived "), ("solver", "compiling the solver library"),
                ("solver_done", "compiled the solver library"), ("compile", "compiling model.c"),
                ("compiled", "compiled model.c"))

    def progress(line):
        for name, prefix in prefixes:
            if line.startswith(prefix) and name not in marks:
                marks[name] = clock()

    model = model_of(spec)
    with limits.lifted():
        loaded = gpmegen.load(model=model, backend="c", progress=progress)
    marks["end"] = clock()
    files = {p.name: p.stat().st_size for p in Path(loaded.folder).iterdir() if p.is_file()}
    print(json.dumps({"name": model.name, "n_dof": loaded.n_dof, "marks": marks, "files": files,
                      "peak": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss * 1024}))


def measure(spec: str) -> dict:
    tmp = tempfile.mkdtemp(prefix="gpmegen-trees-")
    env = dict(os.environ, GPMEGEN_GENERATED=os.path.join(tmp, "generated"), GPMEGEN_CACHE=os.path.join(tmp, "cache"))
    try:
        run = subprocess.run([sys.executable, __file__, "--child", spec], capture_output=True, text=True, env=env)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if run.returncode != 0:
        raise SystemExit(f"{spec}: {run.stderr.strip()[-2000:]}")
    r = phases(json.loads(run.stdout.strip().splitlines()[-1]))
    start, end = r["marks"]["start"], r["marks"]["end"]
    r["cpu"] = (end[1] - start[1]) + (end[2] - start[2])
    return r


def build_table(specs):
    print(f"load average before: {' '.join(f'{x:.1f}' for x in os.getloadavg())} on {os.cpu_count()} cores")
    print(f"{'model':>18} {'n_dof':>5} {'derive':>7} {'emit':>6} {'(CPU)':>6} {'solver':>7} {'(CPU)':>6} "
          f"{'compile':>8} {'(CPU)':>6} {'load':>5} {'total':>6} {'CPU':>6} {'model.c':>8} {'peak':>5} {'load avg':>8}")
    print(f"{'':>18} {'':>5} {'[s]':>7} {'[s]':>6} {'[s]':>6} {'[s]':>7} {'[s]':>6} {'[s]':>8} {'[s]':>6} {'[s]':>5} "
          f"{'[s]':>6} {'[s]':>6} {'[KiB]':>8} {'[MB]':>5} {'':>8}")
    for spec in specs:
        r = measure(spec)
        print(f"{r['name']:>18} {r['n_dof']:>5} {r['derive']:>7.1f} {r['emit']:>6.1f} {r['build_cpu']:>6.1f} "
              f"{r['solver']:>7.1f} {r['solver_cpu']:>6.1f} {r['compile']:>8.1f} "
              f"{r['compile_cpu']:>6.1f} {r['load']:>5.1f} {r['total']:>6.1f} {r['cpu']:>6.1f} "
              f"{r['files']['model.c'] / 1024:>8.0f} {r['peak'] / 1e6:>5.0f} {os.getloadavg()[0]:>8.1f}", flush=True)
    print("derive, emit, solver, compile, load, total: wall; (CPU) after emit: the building process's up to the "
          "compile; solver: the solver library's one-time compile (the cache is empty), its compiler's CPU after "
          "it;\n(CPU) after compile: the model's compilers'; CPU: the building process's and its children's, all "
          "phases; peak: the building process's memory; load avg: the 1-minute load average after the row.")


# ============================================================================================
# 2. One accelerations call against pinocchio.aba
# ============================================================================================


def versus_aba(robots, rounds):
    import pinocchio as pin

    import gpmegen

    print(f"\n{'robot':>8} {'n_dof':>5} {'C q̈ [µs]':>9} {'raw C [µs]':>10} {'aba [µs]':>9} {'ratio':>6} "
          f"{'raw/aba':>7} {'|Δq̈|/|q̈|':>10} {'load':>5}")
    for key in robots:
        imported, model = urdf_model(key)
        loaded = gpmegen.load(model=model, backend="c")
        if loaded.evaluator.fastcall_unavailable:
            print(f"(single calls go through cffi: {loaded.evaluator.fastcall_unavailable})")
        pin_model = pin.buildModelFromUrdf(str(robot_file(key)))
        pin_data = pin_model.createData()
        assert pin_model.nq == pin_model.nv == loaded.n_dof, "a continuous joint: q and v differ in Pinocchio"
        index = np.array([pin_model.idx_vs[pin_model.getJointId(j.name)] for j in imported.joints])
        rng = np.random.default_rng(1)
        q, qd = rng.uniform(-1.0, 1.0, loaded.n_dof), rng.uniform(-1.0, 1.0, loaded.n_dof)
        pq, pv = np.zeros(loaded.n_dof), np.zeros(loaded.n_dof)
        pq[index], pv[index] = q, qd
        tau = -pin_model.damping * pv
        qdd = loaded.accelerations(0.1, q, qd)
        expected = pin.aba(pin_model, pin_data, pq, pv, tau)[index]
        deviation = float(np.max(np.abs(qdd - expected)) / np.max(np.abs(expected)))
        raw = raw_call(loaded, q, qd)
        best = [float("inf")] * 3
        for _ in range(rounds):
            figures = (per_call(lambda: loaded.accelerations(0.1, q, qd), 0.2), per_call(raw, 0.2),
                       per_call(lambda: pin.aba(pin_model, pin_data, pq, pv, tau), 0.2))
            best = [min(a, b) for a, b in zip(best, figures)]
        ours, bare, aba = best
        print(f"{key:>8} {loaded.n_dof:>5} {ours * 1e6:>9.2f} {bare * 1e6:>10.2f} {aba * 1e6:>9.2f} "
              f"{ours / aba:>5.2f}× {bare / aba:>6.2f}× {deviation:>10.1e} {os.getloadavg()[0]:>5.1f}", flush=True)
    print(f"C q̈: model.accelerations(t, q, qd) from Python; raw C: gpme_accelerations through cffi with its "
          f"arguments prepared; aba: pinocchio.aba(model, data, q, v, tau) from Python; ratios against aba (best of "
          f"{rounds} interleaved rounds); |Δq̈|/|q̈|: the two q̈ at the state timed; load: after the row.")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--sizes", type=int, nargs="*", default=[10, 25, 50, 100],
                    help="joints of the random serial chains and trees")
    ap.add_argument("--robots", nargs="*", default=list(ROBOTS), choices=list(ROBOTS),
                    help="the URDF trees built and compared with pinocchio.aba")
    ap.add_argument("--flexible", nargs="*", default=list(FLEXIBLE_ICUB), metavar="ROBOT:K:N",
                    help="URDF trees with their K longest links flexible, N rfes each")
    ap.add_argument("--rounds", type=int, default=4, help="interleaved measuring rounds (best kept)")
    ap.add_argument("--skip-build", action="store_true", help="only the comparison with pinocchio.aba")
    ap.add_argument("--skip-versus", action="store_true", help="only the build table")
    ap.add_argument("--child", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.child:
        child(args.child)
        return
    if not args.skip_build:
        specs = ([f"{kind}:{n}" for n in args.sizes for kind in ("serial", "tree")]
                 + [f"urdf:{key}" for key in args.robots] + [f"urdf:{spec}" for spec in args.flexible])
        build_table(specs)
    if not args.skip_versus:
        versus_aba(args.robots, args.rounds)


if __name__ == "__main__":
    main()
