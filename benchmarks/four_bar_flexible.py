"""The flexible four-bar: gpmegen at several n_rfe, extrapolated, against Exudyn's ANCF coupler.

examples/four_bar_flexible.toml: a crank (0.1 m) turned at a constant rate, an aluminium coupler
(0.3 m, 20 x 4 mm, E = 7e10 Pa, ρ = 2700 kg/m³) that bends in the plane, a rocker (0.25 m,
0.8 kg) pivoted at (0.3, 0), gravity along -y; here undamped (d_sde = 0) and driven at
--rate (default 20 rad/s, where the coupler's inertia bends it more than its weight). Both start
assembled with the coupler straight and moving as a rigid body (gpmegen's start, --statics none:
its consistent velocities are given to Exudyn), so both ring alike.

- gpmegen: the model file at several n_rfe (even: an sde at the coupler's midpoint) with its
  coupler stretching too (freedoms u and psi, written into results/; --inextensible: the example
  as it is, bending only, which differs from Exudyn's extensible cable by 2.7 % of the deflection's
  peak over 0.1 s at the limit, where the axial variant comes within 0.9 %), Radau IIA in C, the
  rocker angle θ3 and the coupler's midpoint deflection from its chord over time, extrapolated to
  n_rfe → ∞ (gpmegen.analysis.post.richardson), the observed order;
- Exudyn: the coupler as ObjectANCFCable2D elements (its axial stiffness E·A: it stretches,
  gpmegen's coupler does not), the crank and the rocker rigid bodies, revolute joints
  (RevoluteJoint2D), the crank's angle held to rate·t by a coordinate constraint; generalized-α at
  the spin-up benchmark's tuned settings (ρ∞ 0.9, Newton to a relative 1e-8 and an absolute 1e-6,
  the sparse solver): an absolute 1e-7 makes its Newton iteration fail with 32 elements at
  2.5e-5 s, where 1e-6 and 1e-5 give the same deflection to 1e-5 of its peak;
- the reference: the finer of the two engines' converged runs (Exudyn at --elements and --step,
  checked against half its elements and half its step; and gpmegen's limit): every run's
  error against both, over time, relative to the peak of the quantity.

Wall times: each engine's solve only (gpmegen's runs after its levels are built; Exudyn's
SolveDynamic after its assembly), best of --repeat, alternated.

    .venv/bin/python -m pip install exudyn      # the compared engine: a benchmark dependency only
    .venv/bin/python benchmarks/four_bar_flexible.py
    .venv/bin/python benchmarks/four_bar_flexible.py --nrfe 4 8 --compare 4 --repeat 1
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from slider_crank import midpoint_deflection, rod_geometry  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "examples" / "four_bar_flexible.toml"
L1, L2, L3, D = 0.1, 0.3, 0.25, 0.3
M3, B, H, G = 0.8, 0.02, 0.01, 9.81
RHO, E, B2, T2 = 2700.0, 7.0e10, 0.02, 0.004
RHOA, EI, EA = RHO * B2 * T2, E * B2 * T2**3 / 12, E * B2 * T2
QUANTITIES = ("rocker angle", "midpoint deflection")
UNITS = {"rocker angle": "rad", "midpoint deflection": "m"}


def params(rate: float) -> dict:
    """The benchmark's parameters of the model file: the crank rate, no damping."""
    return {"w": rate, "d_sde": 0.0}


def axial_variant(folder: Path) -> Path:
    """The example with a coupler that also stretches (freedoms u and psi, the sdes' axial springs
    E·A/Δ), as Exudyn's cable does, written into ``folder``."""
    text = MODEL.read_text()
    for old, new in (('\nfreedoms = ["psi"]', '\nfreedoms = ["u", "psi"]'),
                     ('name = "four_bar_flexible_nrfe{nrfe}"', 'name = "four_bar_flexible_axial_nrfe{nrfe}"')):
        if text.count(old) != 1:
            raise SystemExit(f"{MODEL} no longer holds {old!r} once: update axial_variant")
        text = text.replace(old, new)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "four_bar_flexible_axial.toml"
    path.write_text(text)
    return path


def gpmegen_level(nrfe: int, rate: float, t_end: float, save_dt: float, rtol: float, atol: float, model=MODEL):
    """One level's run of ``model`` (Radau IIA in C): (results, quantities over time, wall s of the run)."""
    from gpmegen.analysis.run import opening, runs
    from gpmegen.analysis.run.runspec import RunSpec

    spec = RunSpec(start="none", t_end=t_end, dt=save_dt, save_every=1, method="radau", save_dt=save_dt, rtol=rtol,
                   atol=atol)
    run = runs.run(opening.case_for(str(model), nrfe), spec, "c", params(rate), None, lambda message: None)
    res = run.results
    names = [str(c) for c in res["coordinates"]]
    theta3 = res["q"][:, names.index("theta3")]
    middle = []
    for q in res["q"]:
        g = rod_geometry(names, q, nrfe, length=L2, crank=L1)
        middle.append(midpoint_deflection(g["B"], g["R"], g["M"]))
    return res, {"rocker angle": theta3, "midpoint deflection": np.array(middle)}, run.wall


def rigid_start(res) -> dict:
    """The consistent start of gpmegen's run (all levels alike: the coupler straight): θ1, the
    coupler's absolute angle and rate, the rocker's angle and rate."""
    names = [str(c) for c in res["coordinates"]]
    q, qd = res["q"][0], res["qd"][0]
    value, rate = dict(zip(names, q)), dict(zip(names, qd))
    return {"theta1": value["theta1"], "coupler": value["theta1"] + value["theta2"],
            "coupler_rate": rate["theta1"] + rate["theta2"], "theta3": value["theta3"], "theta3_rate": rate["theta3"]}


#: Exudyn's generalized-α and Newton settings as tuned for the spin-up beam (benchmarks/spinup.py).
EXUDYN_RHO_INF, EXUDYN_RTOL = 0.9, 1e-8


def exudyn_crank(mbs, ground, rate: float, length: float):
    """A rigid crank in an Exudyn system, its centre at the pivot (the origin), turning about z
    with its angle held to rate·t by a coordinate constraint (its inertia only loads the drive);
    returns its body number."""
    from exudyn import utilities as xu

    crank = mbs.CreateRigidBody(referencePosition=[0, 0, 0], inertia=xu.InertiaCuboid(1000, [length, H, B]),
                                initialAngularVelocity=[0, 0, rate], create2D=True, returnDict=True)
    mbs.AddObject(xu.RevoluteJoint2D(markerNumbers=[mbs.AddMarker(xu.MarkerBodyPosition(bodyNumber=ground)),
                                                    mbs.AddMarker(xu.MarkerBodyPosition(bodyNumber=crank["bodyNumber"]))]))
    fixed = mbs.AddMarker(xu.MarkerNodeCoordinate(nodeNumber=mbs.AddNode(xu.NodePointGround()), coordinate=0))
    angle = mbs.AddMarker(xu.MarkerNodeCoordinate(nodeNumber=crank["nodeNumber"], coordinate=2))

    from exudyn.advancedUtilities import CreateSymbolicUserFunction

    def law(mbs, now, item, offset):
        return rate * now

    held = mbs.AddObject(xu.CoordinateConstraint(markerNumbers=[fixed, angle], offset=0.0))
    # the law as Exudyn's symbolic user function (evaluated in C++, not called back in Python: its
    # best setting); kept alive with the system, which holds the returned object
    _KEPT.append(CreateSymbolicUserFunction(mbs, law, "offsetUserFunction", held))
    mbs.SetObjectParameter(held, "offsetUserFunction", _KEPT[-1])
    return crank["bodyNumber"]


#: Exudyn's symbolic user functions must outlive the systems that call them.
_KEPT: list = []


def exudyn_solve(mbs, step: float, t_end: float, atol: float):
    """Assemble and solve with Exudyn's generalized-α at the settings above, fixed steps: the wall
    seconds of the solve, None when its Newton iteration gave up."""
    import exudyn

    mbs.Assemble()
    settings = exudyn.SimulationSettings()
    settings.timeIntegration.numberOfSteps = int(round(t_end / step))
    settings.timeIntegration.endTime = t_end
    settings.timeIntegration.generalizedAlpha.spectralRadius = EXUDYN_RHO_INF
    settings.timeIntegration.newton.relativeTolerance = EXUDYN_RTOL
    settings.timeIntegration.newton.absoluteTolerance = atol
    settings.timeIntegration.adaptiveStep = False
    settings.timeIntegration.verboseMode = 0
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = step
    settings.linearSolver.solverType = exudyn.LinearSolverType.EigenSparse
    start_time = time.perf_counter()
    try:
        mbs.SolveDynamic(settings)
    except exudyn.SolverError:
        return None
    return time.perf_counter() - start_time


def exudyn_run(elements: int, step: float, rate: float, t_end: float, start: dict, t, atol: float):
    """The four-bar in Exudyn: ``elements`` ANCF cable elements for the coupler, generalized-α at
    ``step``; the quantities at the instants ``t`` and the wall seconds of its solve (values None
    when its solver gave up)."""
    import exudyn
    from exudyn import utilities as xu
    from exudyn.beams import GenerateBeamElementsAlongLine

    container = exudyn.SystemContainer()
    mbs = container.AddSystem()
    ground = mbs.AddObject(xu.ObjectGround())
    crank = exudyn_crank(mbs, ground, rate, L1)
    # the rocker: a bar pivoted at (D, 0), its centre at L3/2 along it
    c3, s3 = math.cos(start["theta3"]), math.sin(start["theta3"])
    centre = np.array([D + L3 / 2 * c3, L3 / 2 * s3, 0.0])
    w3 = start["theta3_rate"]
    rocker = mbs.CreateRigidBody(referencePosition=list(centre),
                                 referenceRotationMatrix=xu.RotationMatrixZ(start["theta3"]),
                                 inertia=xu.RigidBodyInertia(mass=M3, inertiaTensor=np.diag(
                                     [M3 * (H**2 + B**2) / 12, M3 * (L3**2 + B**2) / 12, M3 * (L3**2 + H**2) / 12])),
                                 initialVelocity=[-w3 * L3 / 2 * s3, w3 * L3 / 2 * c3, 0],
                                 initialAngularVelocity=[0, 0, w3], gravity=[0, -G, 0], create2D=True, returnDict=True)
    mbs.AddObject(xu.RevoluteJoint2D(markerNumbers=[
        mbs.AddMarker(xu.MarkerBodyPosition(bodyNumber=ground, localPosition=[D, 0, 0])),
        mbs.AddMarker(xu.MarkerBodyPosition(bodyNumber=rocker["bodyNumber"], localPosition=[-L3 / 2, 0, 0]))]))
    # the coupler: straight from the crank's tip to the rocker's, moving as a rigid body at the start
    c1, s1 = math.cos(start["theta1"]), math.sin(start["theta1"])
    base = np.array([L1 * c1, L1 * s1, 0.0])
    direction = np.array([math.cos(start["coupler"]), math.sin(start["coupler"]), 0.0])
    cable = xu.ObjectANCFCable2D(massPerLength=RHOA, bendingStiffness=EI, axialStiffness=EA)
    nodes = GenerateBeamElementsAlongLine(mbs, list(base), list(base + L2 * direction), elements, cable,
                                          gravity=[0, -G, 0])["nodes"]
    w2, base_velocity = start["coupler_rate"], rate * L1 * np.array([-s1, c1])
    for k, node in enumerate(nodes):
        r = L2 * k / elements * direction[:2]
        velocity = base_velocity + w2 * np.array([-r[1], r[0]])
        mbs.SetNodeParameter(node, "initialVelocities", [*velocity, -w2 * direction[1], w2 * direction[0]])
    mbs.AddObject(xu.RevoluteJoint2D(markerNumbers=[
        mbs.AddMarker(xu.MarkerBodyPosition(bodyNumber=crank, localPosition=[L1, 0, 0])),
        mbs.AddMarker(xu.MarkerNodePosition(nodeNumber=nodes[0]))]))
    mbs.AddObject(xu.RevoluteJoint2D(markerNumbers=[
        mbs.AddMarker(xu.MarkerBodyPosition(bodyNumber=rocker["bodyNumber"], localPosition=[L3 / 2, 0, 0])),
        mbs.AddMarker(xu.MarkerNodePosition(nodeNumber=nodes[-1]))]))
    sensors = [mbs.AddSensor(xu.SensorNode(nodeNumber=nodes[k], storeInternal=True,
                                           outputVariableType=exudyn.OutputVariableType.Position))
               for k in (0, elements // 2, elements)]
    wall = exudyn_solve(mbs, step, t_end, atol)
    if wall is None:
        return None, float("nan")
    base_s, middle_s, tip_s = (mbs.GetSensorStoredData(s) for s in sensors)
    times = base_s[:, 0]
    rocker_angle = np.unwrap(np.arctan2(tip_s[:, 2], tip_s[:, 1] - D))
    middle = np.array([midpoint_deflection(b[1:3], c[1:3], m[1:3]) for b, m, c in zip(base_s, middle_s, tip_s)])
    return {"rocker angle": np.interp(t, times, rocker_angle), "midpoint deflection": np.interp(t, times, middle)}, wall


def figure(t, limit, exudyn_fine, levels, nrfe, path):
    """The midpoint deflection over time (gpmegen's limit and Exudyn's finest run) and each
    level's error against Exudyn."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 5.6), sharex=True)
    top.plot(t, exudyn_fine["midpoint deflection"] * 1e3, "k", lw=2.5, alpha=0.4, label="Exudyn ANCF (finest)")
    top.plot(t, limit["midpoint deflection"] * 1e3, "C0", lw=0.9, label="gpmegen, extrapolated")
    top.set_ylabel("coupler midpoint deflection (mm)")
    top.legend(fontsize=7)
    scale = np.max(np.abs(exudyn_fine["midpoint deflection"]))
    for n, level in zip(nrfe, levels):
        bottom.semilogy(t, np.abs(level["midpoint deflection"] - exudyn_fine["midpoint deflection"]) / scale, lw=0.7,
                        label=f"n_rfe = {n}")
    bottom.semilogy(t, np.abs(limit["midpoint deflection"] - exudyn_fine["midpoint deflection"]) / scale, "k",
                    lw=0.9, label="gpmegen limit")
    bottom.set_ylim(bottom=1e-5)
    bottom.set_ylabel("|difference| / peak (Exudyn)")
    bottom.set_xlabel("t (s)")
    bottom.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path


def load() -> str:
    """The load averages over 1, 5 and 15 minutes."""
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def exudyn_changes(run, args, fine, scale, quantities) -> None:
    """Print how much Exudyn's finest run ``fine`` changes with half its elements and with half its
    step (``run(elements, step)``: (values or None, wall s)), relative to ``scale`` (each
    quantity's peak)."""
    for label, (elements, step) in (("half the elements", (args.elements // 2, args.step)),
                                    ("half the step", (args.elements, args.step / 2))):
        other, seconds = run(elements, step)
        change = "its solver gave up" if other is None else ", ".join(
            f"{key} {np.max(np.abs(other[key] - fine[key])) / scale[key]:.2e}" for key in quantities)
        print(f"  with {label} ({elements} elements, step {step:g} s): changes by {change} ({seconds:.1f} s)")


def comparison(quantities, nrfe, levels, walls, compared, fine, fine_wall, scale, args, legend) -> dict:
    """Extrapolate gpmegen's ``levels`` (n_rfe → quantity → values) and print RFEM's observed
    order, the ``legend`` line and the table of every run's error against Exudyn's finest run ``fine`` and against
    gpmegen's limit, relative to ``scale``, with its wall times (``walls``: n_rfe or ("exudyn",
    elements) → seconds of each repeat; ``compared``: elements → values, None where Exudyn gave
    up). Returns the limit (quantity → values)."""
    from gpmegen.analysis.post import richardson

    n_sde = np.array(nrfe) - 1
    estimates = {key: richardson.richardson(n_sde, np.array([levels[n][key] for n in nrfe])) for key in quantities}
    limit = {key: estimates[key].limit for key in quantities}
    print("gpmegen's observed order: " + ", ".join(f"{key} {estimates[key].order:.2f}" for key in quantities))
    print(legend)
    print("| run | wall [s] | " + " | ".join(f"{key} vs Exudyn | vs gpmegen limit" for key in quantities) + " |")
    print("|---|---|" + "---|---|" * len(quantities))

    def row(label, values, seconds):
        cells = []
        for key in quantities:
            cells += [f"{np.max(np.abs(values[key] - fine[key])) / scale[key]:.2e}",
                      f"{np.max(np.abs(values[key] - limit[key])) / scale[key]:.2e}"]
        wall = "" if not seconds else f"**{min(seconds):.2f}** ({', '.join(f'{s:.2f}' for s in seconds)})"
        print(f"| {label} | {wall} | " + " | ".join(cells) + " |")

    for n in nrfe:
        row(f"gpmegen n_rfe {n} (Radau rtol {args.rtol:g})", levels[n], walls[n])
    row(f"gpmegen limit (n_rfe {' '.join(map(str, nrfe))})", limit, [sum(w) for w in zip(*(walls[n] for n in nrfe))])
    for elements in args.compare:
        if compared[elements] is None:
            print(f"| Exudyn {elements} elements | its solver gave up |" + " |" * (2 * len(quantities)))
        else:
            row(f"Exudyn {elements} elements (step {args.compare_step:g} s)", compared[elements],
                walls[("exudyn", elements)])
    row(f"Exudyn {args.elements} elements (step {args.step:g} s)", fine, [fine_wall])
    return limit


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nrfe", type=int, nargs="+", default=[4, 8, 16], help="gpmegen's levels (even)")
    parser.add_argument("--rate", type=float, default=20.0, help="crank rate (rad/s)")
    parser.add_argument("--t-end", type=float, default=0.1, help="simulated time (s)")
    parser.add_argument("--save-dt", type=float, default=5e-4, help="compared interval (s)")
    parser.add_argument("--rtol", type=float, default=1e-8, help="gpmegen's Radau relative tolerance")
    parser.add_argument("--atol", type=float, default=1e-10, help="gpmegen's Radau absolute tolerance")
    parser.add_argument("--elements", type=int, default=32, help="ANCF elements of Exudyn's finest run")
    parser.add_argument("--step", type=float, default=5e-6, help="step of Exudyn's finest run (s)")
    parser.add_argument("--compare", type=int, nargs="*", default=[4, 8, 16], help="Exudyn runs timed (elements)")
    parser.add_argument("--compare-step", type=float, default=1e-5, help="their step (s)")
    parser.add_argument("--exudyn-atol", type=float, default=1e-6, help="Exudyn's absolute Newton tolerance")
    parser.add_argument("--repeat", type=int, default=2, help="timed runs of each, alternated; the best counts")
    parser.add_argument("--inextensible", action="store_true",
                        help="gpmegen's coupler as the example has it, bending only (default: it also stretches, "
                             "as Exudyn's cable does)")
    parser.add_argument("--figure", type=Path, default=ROOT / "figures" / "four_bar_flexible.png")
    args = parser.parse_args(argv)
    nrfe = sorted(set(args.nrfe))
    if len(nrfe) < 2 or any(n < 2 or n % 2 for n in nrfe) or any(e % 2 for e in [args.elements, *args.compare]):
        parser.error("--nrfe needs two or more even levels (an sde at the midpoint), --elements and --compare "
                     "even numbers (a node at the midpoint)")
    model = MODEL if args.inextensible else axial_variant(ROOT / "results")
    print(f"load average {load()} on {os.cpu_count()} cores; crank rate {args.rate:g} rad/s, {args.t_end:g} s; "
          f"gpmegen's coupler {'bends only' if args.inextensible else 'bends and stretches'} ({model})")
    walls = {n: [] for n in nrfe} | {("exudyn", e): [] for e in args.compare}
    levels, compared, t, start = {}, {}, None, None
    for _ in range(args.repeat):
        for n in nrfe:
            res, over_time, wall = gpmegen_level(n, args.rate, args.t_end, args.save_dt, args.rtol, args.atol, model)
            if str(res["status"]) != "complete":
                print(f"n_rfe {n}: the run did not finish ({res['status']})")
                return 1
            levels[n], t, start = over_time, res["t"], start or rigid_start(res)
            walls[n].append(wall)
        for elements in args.compare:
            values, wall = exudyn_run(elements, args.compare_step, args.rate, args.t_end, start, t, args.exudyn_atol)
            compared[elements] = values
            walls[("exudyn", elements)].append(wall)
    fine, fine_wall = exudyn_run(args.elements, args.step, args.rate, args.t_end, start, t, args.exudyn_atol)
    if fine is None:
        print("Exudyn's finest run: its solver gave up; try another --step")
        return 1
    scale = {key: float(np.max(np.abs(fine[key] - (fine[key][0] if key == "rocker angle" else 0.0))))
             for key in QUANTITIES}
    print(f"Exudyn's finest run ({args.elements} elements, step {args.step:g} s): {fine_wall:.1f} s; "
          f"peaks: rocker swing {scale['rocker angle']:.4f} rad, "
          f"midpoint deflection {scale['midpoint deflection']:.3e} m")
    exudyn_changes(lambda elements, step: exudyn_run(elements, step, args.rate, args.t_end, start, t,
                                                     args.exudyn_atol), args, fine, scale, QUANTITIES)
    limit = comparison(QUANTITIES, nrfe, levels, walls, compared, fine, fine_wall, scale, args,
                       "\nerror: max over t of |value - reference| / the reference's peak (the rocker's swing, the "
                       "deflection's peak); wall: best of the runs (all)")
    print(f"load average {load()}")
    print(f"\nfigure: {figure(t, limit, fine, [levels[n] for n in nrfe], nrfe, args.figure)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
