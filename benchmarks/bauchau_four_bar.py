"""Bauchau's spatial four-bar: gpmegen at several n_rfe, extrapolated, against Exudyn's 3-D beams.

examples/bauchau_four_bar.toml: a parallelogram of three flexible steel beams (crank 0.12 m and
coupler 0.24 m of 16 x 16 mm, follower 0.12 m of 8 x 8 mm; the section data of Bauchau et al.
2016, see docs/benchmarks.md), the joint at C tilted by 5 degrees about the follower's axis, so
that the links bend and twist out of their plane as the crank turns; the crank driven about -z at
0.6 rad/s after a smooth start from rest (T_r = 0.2 s), no gravity, no damping. Both engines start
at rest and undeformed, where the mechanism is assembled: the same start, exactly.

- gpmegen: the model file at several n_rfe (even: an sde at each link's midpoint), Radau IIA in
  C; the compared quantities: the out-of-plane displacement of C (the coupler's tip)
  and the out-of-plane bending moments at the coupler's and the follower's mid-span (EI/Δ times
  the midpoint sde's rotation theta about the link's y axis) and the crank's torque (the
  multiplier of its prescribed angle), over time, extrapolated to
  n_rfe → ∞ (gpmegen.analysis.post.richardson) with the observed order;
- Exudyn: each link as ObjectBeamGeometricallyExact elements (3-D, shear-deformable, the source's
  EA, GA, GJ, EI and rotary inertias; crank and follower N elements, coupler 2N) on
  Tait-Bryan rigid-body nodes, the revolute joints as GenericJoint (the one at C about the tilted
  axis), the crank's root node clamped to its prescribed angle by coordinate constraints (the law
  as Exudyn's symbolic user function); generalized-α at the four-bar benchmark's tuned settings
  (benchmarks/four_bar_flexible.py: ρ∞ 0.9, Newton to a relative 1e-8 and --exudyn-atol, the
  sparse solver); the mid-span moment is the mean of the TorqueLocal of the two elements that
  meet there, the crank's torque the multiplier of its angle's constraint (with the sign of a
  torque on the crank);
- the reference: the finer of the two engines' converged runs (Exudyn at --elements and --step,
  checked against half its elements and half its step; and gpmegen's limit): every run's error
  against both, over time, relative to the peak of the quantity.

The engines' beam models differ by what RFEM leaves out: shear (the source's GA: for the follower
EI/(GA L²/4) = 1.2e-3, the shear part of its mid-span flexibility) and the axial stretch (EA).

Wall times: each engine's solve only (gpmegen's runs after its levels are built; Exudyn's
SolveDynamic after its assembly), best of --repeat, alternated.

    .venv/bin/python -m pip install exudyn      # the compared engine: a benchmark dependency only
    .venv/bin/python benchmarks/bauchau_four_bar.py
    .venv/bin/python benchmarks/bauchau_four_bar.py --nrfe 2 4 --compare 4 --repeat 1
"""

from __future__ import annotations

import argparse
import math
import os
import sys
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from four_bar_flexible import _KEPT, comparison, exudyn_changes, exudyn_solve, load  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "examples" / "bauchau_four_bar.toml"
L1, L2, L3 = 0.12, 0.24, 0.12
TILT, RATE, RAMP = math.radians(5.0), 0.6, 0.2
#: The source's sections (Bauchau et al. 2016): EA, GA (both), GJ, EI (both) in N and N·m²,
#: mass per length kg/m, rotary inertia per length about each bending axis kg·m.
SECTIONS = {"a": {"EA": 52.99e6, "GA": 16.88e6, "GJ": 733.5, "EI": 1131.0, "m": 1.997, "mI": 42.6e-6},
            "b": {"EA": 13.25e6, "GA": 4.22e6, "GJ": 45.84, "EI": 70.66, "m": 0.4992, "mI": 2.662e-6}}
QUANTITIES = ("C out of plane", "coupler moment", "follower moment", "crank torque")
UNITS = {"C out of plane": "m", "coupler moment": "N·m", "follower moment": "N·m", "crank torque": "N·m"}


def crank_angle(t):
    """The crank's prescribed angle (rad, about z): -w (t - T_r tanh(t/T_r)), the model file's law."""
    return -RATE * (t - RAMP * np.tanh(np.asarray(t) / RAMP))


def gpmegen_outputs(model, names, q, nrfe: int) -> dict:
    """The compared quantities along a run's states ``q`` (k, n) of the model at ``nrfe``."""
    points = list(model.module.POINTS)
    positions = model.point_positions(q)
    delta = {"2": L2 / (nrfe - 1), "3": L3 / (nrfe - 1)}
    middle = nrfe // 2
    stiffness = {"2": SECTIONS["a"]["EI"] / delta["2"], "3": SECTIONS["b"]["EI"] / delta["3"]}
    moment = {link: stiffness[link] * q[:, names.index(f"theta{link}_{middle}")] for link in ("2", "3")}
    return {"C out of plane": positions[:, points.index("C1"), 2], "coupler moment": moment["2"],
            "follower moment": moment["3"]}


def gpmegen_level(nrfe: int, t_end: float, save_dt: float, rtol: float, atol: float, model=MODEL):
    """One level's run of ``model`` (Radau IIA in C): (results, quantities over time, wall s of the run)."""
    from gpmegen.analysis.run import opening, runs
    from gpmegen.analysis.run.runspec import RunSpec

    if nrfe < 2 or nrfe % 2:
        raise ValueError(f"n_rfe must be even and at least 2 (an sde at each link's midpoint), got {nrfe}")
    spec = RunSpec(t_end=t_end, dt=save_dt, save_every=1, method="radau", start="none", save_dt=save_dt, rtol=rtol,
                   atol=atol)
    run = runs.run(opening.case_for(str(model), nrfe), spec, "c", {}, None, lambda message: None)
    res = run.results
    names = [str(c) for c in res["coordinates"]]
    outputs = gpmegen_outputs(run.model, names, res["q"], nrfe)
    outputs["crank torque"] = res["lambda"][:, list(map(str, res["constraint_names"])).index("prescribed_alpha1")]
    return res, outputs, run.wall


def _section(data: dict):
    import exudyn

    section = exudyn.BeamSection()
    section.stiffnessMatrix = np.diag([data["EA"], data["GA"], data["GA"], data["GJ"], data["EI"], data["EI"]])
    section.inertia = np.diag([2 * data["mI"], data["mI"], data["mI"]])
    section.massPerLength = data["m"]
    return section


def exudyn_run(elements: int, step: float, t_end: float, t, atol: float):
    """The four-bar in Exudyn: crank and follower ``elements`` geometrically exact beam elements
    each, the coupler twice as many; generalized-α at ``step``. The quantities at the instants
    ``t`` and the wall seconds of its solve (values None when its solver gave up)."""
    import exudyn
    from exudyn import symbolic
    from exudyn import utilities as xu
    from exudyn.advancedUtilities import CreateSymbolicUserFunction

    if elements < 1:
        raise ValueError(f"elements must be at least 1, got {elements}")
    mbs = exudyn.SystemContainer().AddSystem()
    ground = mbs.AddObject(xu.ObjectGround())
    fixed = mbs.AddMarker(xu.MarkerNodeCoordinate(nodeNumber=mbs.AddNode(xu.NodePointGround()), coordinate=0))

    def beam(start, direction, angle, count, data):
        """Nodes along a straight link from ``start`` (its frame turned by ``angle`` about z) and
        its elements: (nodes, elements)."""
        length = np.linalg.norm(direction)
        nodes = [mbs.AddNode(xu.NodeRigidBodyRxyz(referenceCoordinates=[*(np.asarray(start) + direction * k / count),
                                                                         0.0, 0.0, angle]))
                 for k in range(count + 1)]
        section = _section(data)
        return nodes, [mbs.AddObject(xu.ObjectBeamGeometricallyExact(nodeNumbers=[nodes[k], nodes[k + 1]],
                                                                     length=length / count, sectionData=section))
                       for k in range(count)]

    crank, _ = beam([0, 0, 0], np.array([0, L1, 0]), math.pi / 2, elements, SECTIONS["a"])
    coupler, coupler_elements = beam([0, L1, 0], np.array([L2, 0, 0]), 0.0, 2 * elements, SECTIONS["a"])
    follower, follower_elements = beam([L2, 0, 0], np.array([0, L3, 0]), math.pi / 2, elements, SECTIONS["b"])
    turned = xu.RotationMatrixZ(math.pi / 2)
    tilted = xu.RotationMatrixY(TILT)

    def revolute(marker0, marker1):
        """A revolute joint about the z axis of the markers' frames (aligned at the start)."""
        mbs.AddObject(xu.GenericJoint(markerNumbers=[marker0, marker1], constrainedAxes=[1, 1, 1, 1, 1, 0]))

    def node_marker(node, frame):
        """A marker on ``node`` whose frame is turned by ``frame`` from the node's."""
        return mbs.AddMarker(xu.MarkerNodeRigid(nodeNumber=node, localHT=exudyn.HT(rotation=frame)))

    # the crank's root clamped to the hub's prescribed angle: its six coordinates held, the
    # rotation about z to the law, tanh written with exp (the symbolic user function, evaluated in C++)
    def law(mbs, now, item, offset):
        decay = symbolic.exp(-2 * now / RAMP)
        return -RATE * (now - RAMP * (1 - decay) / (1 + decay))

    for coordinate in range(6):
        held = mbs.AddObject(xu.CoordinateConstraint(markerNumbers=[
            fixed, mbs.AddMarker(xu.MarkerNodeCoordinate(nodeNumber=crank[0], coordinate=coordinate))]))
        if coordinate == 5:
            _KEPT.append(CreateSymbolicUserFunction(mbs, law, "offsetUserFunction", held))
            mbs.SetObjectParameter(held, "offsetUserFunction", _KEPT[-1])
            drive = mbs.AddSensor(xu.SensorObject(objectNumber=held, storeInternal=True,
                                                  outputVariableType=exudyn.OutputVariableType.Force))
    identity = np.eye(3)
    revolute(node_marker(crank[-1], turned.T), node_marker(coupler[0], identity))             # B, about z
    revolute(node_marker(coupler[-1], tilted), node_marker(follower[-1], turned.T @ tilted))  # C, tilted
    revolute(mbs.AddMarker(xu.MarkerBodyRigid(bodyNumber=ground, localHT=exudyn.HT(translation=[L2, 0, 0]))),
             node_marker(follower[0], turned.T))                                              # D, about z
    point = mbs.AddSensor(xu.SensorNode(nodeNumber=coupler[-1], storeInternal=True,
                                        outputVariableType=exudyn.OutputVariableType.Position))
    torques = {key: [mbs.AddSensor(xu.SensorBody(bodyNumber=elements_[k], storeInternal=True,
                                                 outputVariableType=exudyn.OutputVariableType.TorqueLocal))
                     for k in (len(elements_) // 2 - 1, len(elements_) // 2)]
               for key, elements_ in (("coupler moment", coupler_elements), ("follower moment", follower_elements))}
    wall = exudyn_solve(mbs, step, t_end, atol)
    if wall is None:
        return None, float("nan")
    position = mbs.GetSensorStoredData(point)
    times = position[:, 0]
    # the constraint's multiplier λ acts on the crank's angle as -λ: the motor's torque about z
    values = {"C out of plane": position[:, 3], "crank torque": -mbs.GetSensorStoredData(drive)[:, 1]}
    for key, sensors in torques.items():
        values[key] = np.mean([mbs.GetSensorStoredData(s)[:, 2] for s in sensors], axis=0)
    return {key: np.interp(t, times, v) for key, v in values.items()}, wall


def figure(t, limit, exudyn_fine, levels, nrfe, path):
    """The compared quantities over time (gpmegen's limit and Exudyn's finest run), and each
    level's error in the follower's moment against Exudyn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(5, 1, figsize=(7, 10.5), sharex=True)
    scales = {"C out of plane": 1e3, "coupler moment": 1.0, "follower moment": 1.0, "crank torque": 1.0}
    labels = {"C out of plane": "z of C (mm)", "coupler moment": "coupler mid-span\nmoment (N·m)",
              "follower moment": "follower mid-span\nmoment (N·m)", "crank torque": "crank torque\n(N·m, about z)"}
    for ax, key in zip(axes, QUANTITIES):
        ax.plot(t, exudyn_fine[key] * scales[key], "k", lw=2.5, alpha=0.4, label="Exudyn 3-D beams (finest)")
        ax.plot(t, limit[key] * scales[key], "C0", lw=0.9, label="gpmegen, extrapolated")
        ax.set_ylabel(labels[key])
    axes[0].legend(fontsize=7)
    axes[0].set_title("Bauchau's spatial four-bar (joint at C tilted by 5°)")
    bottom = axes[-1]
    key = "follower moment"
    scale = np.max(np.abs(exudyn_fine[key]))
    for n, level in zip(nrfe, levels):
        bottom.semilogy(t, np.abs(level[key] - exudyn_fine[key]) / scale, lw=0.7, label=f"n_rfe = {n}")
    bottom.semilogy(t, np.abs(limit[key] - exudyn_fine[key]) / scale, "k", lw=0.9, label="gpmegen limit")
    bottom.set_ylim(bottom=1e-5)
    bottom.set_ylabel("follower moment:\n|difference| / peak")
    bottom.set_xlabel("t (s)")
    bottom.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nrfe", type=int, nargs="+", default=[4, 8, 16], help="gpmegen's levels (even)")
    parser.add_argument("--t-end", type=float, default=2.0, help="simulated time (s; the parallelogram's "
                        "singular configuration is at 2.8 s)")
    parser.add_argument("--save-dt", type=float, default=0.01, help="compared interval (s)")
    parser.add_argument("--rtol", type=float, default=1e-8, help="gpmegen's Radau relative tolerance")
    parser.add_argument("--atol", type=float, default=1e-10, help="gpmegen's Radau absolute tolerance")
    parser.add_argument("--elements", type=int, default=32, help="elements of the crank (and the follower; the "
                        "coupler twice as many) in Exudyn's finest run")
    parser.add_argument("--step", type=float, default=1e-3, help="step of Exudyn's finest run (s)")
    parser.add_argument("--compare", type=int, nargs="*", default=[4, 8, 16], help="Exudyn runs timed (elements)")
    parser.add_argument("--compare-step", type=float, default=2e-3, help="their step (s)")
    parser.add_argument("--exudyn-atol", type=float, default=1e-5, help="Exudyn's absolute Newton tolerance")
    parser.add_argument("--repeat", type=int, default=2, help="timed runs of each, alternated; the best counts")
    parser.add_argument("--figure", type=Path, default=ROOT / "figures" / "bauchau_four_bar.png")
    args = parser.parse_args(argv)
    nrfe = sorted(set(args.nrfe))
    if len(nrfe) < 2 or any(n < 2 or n % 2 for n in nrfe) or any(e % 2 for e in [args.elements, *args.compare]):
        parser.error("--nrfe needs two or more even levels (an sde at each midpoint), --elements and --compare "
                     "even numbers (a node at each midpoint)")
    print(f"load average {load()} on {os.cpu_count()} cores; {args.t_end:g} s from rest ({MODEL})")
    walls = {n: [] for n in nrfe} | {("exudyn", e): [] for e in args.compare}
    levels, compared, t = {}, {}, None
    for _ in range(args.repeat):
        for n in nrfe:
            res, over_time, wall = gpmegen_level(n, args.t_end, args.save_dt, args.rtol, args.atol)
            if str(res["status"]) != "complete":
                print(f"n_rfe {n}: the run did not finish ({res['status']})")
                return 1
            levels[n], t = over_time, res["t"]
            walls[n].append(wall)
        for elements in args.compare:
            values, wall = exudyn_run(elements, args.compare_step, args.t_end, t, args.exudyn_atol)
            compared[elements] = values
            walls[("exudyn", elements)].append(wall)
    fine, fine_wall = exudyn_run(args.elements, args.step, args.t_end, t, args.exudyn_atol)
    if fine is None:
        print("Exudyn's finest run: its solver gave up; try another --step")
        return 1
    scale = {key: float(np.max(np.abs(fine[key]))) for key in QUANTITIES}
    print(f"Exudyn's finest run ({args.elements}/{2 * args.elements}/{args.elements} elements, step {args.step:g} s): "
          f"{fine_wall:.1f} s; peaks: " + ", ".join(f"{key} {scale[key]:.4e} {UNITS[key]}" for key in QUANTITIES))
    exudyn_changes(lambda elements, step: exudyn_run(elements, step, args.t_end, t, args.exudyn_atol), args, fine,
                   scale, QUANTITIES)
    limit = comparison(QUANTITIES, nrfe, levels, walls, compared, fine, fine_wall, scale, args,
                       "\nerror: max over t of |value - reference| / the reference's peak; wall: best of the runs "
                       "(all)")
    print(f"load average {load()}")
    print(f"\nfigure: {figure(t, limit, fine, [levels[n] for n in nrfe], nrfe, args.figure)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
