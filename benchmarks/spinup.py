"""The spin-up benchmark: gpmegen's extrapolated tip deflection against an independent reference.

A beam clamped to a hub whose angle is prescribed (Kane, Ryan & Banerjee 1987, with the data of
Simo & Vu-Quoc 1988: L = 10 m, EI = 1.4e4 N·m², EA = 2.8e7 N, ρA = 1.2 kg/m;
θ(t) = (Ωs/T)[t²/2 + (T/2π)²(cos(2πt/T) - 1)] for t ≤ T = 15 s, then Ωs(t - T/2)), 20 s, for
Ωs = 4, 6 and 10 rad/s. Output: the tip's deflection in the hub frame.

- gpmegen: examples/spinup_axial.toml (sdes that bend and stretch; --model bending:
  examples/spinup.toml, inextensible) at several n_rfe (generalized-α at 1e-3 s by default, or
  RK4 with --method rk4 --dt 1e-4), extrapolated to n_rfe → ∞ (gpmegen.analysis.discretization.extrapolate),
  refined with the levels of --refine one at a time while the limit's own estimate of its error
  is above --tolerance;
- reference: Exudyn (geometrically exact ANCF cable elements, ObjectANCFCable2D, extensible,
  generalized-α) at high resolution, clamped to a rigid hub whose angle is prescribed;
- Exudyn as its users would tune it (EXUDYN_RHO_INF, EXUDYN_RTOL, EXUDYN_ATOL, EXUDYN_SOLVER) at
  each of --compare elements and each --compare-step, timed against gpmegen at each of its --dt;
  the last lines name, per Ωs, each engine's fastest run within --tolerance of the reference and
  the ratio of the two (so that the peer is compared at the best of the settings tried, not at
  one chosen beforehand);
- the conventional linear modal model (clamped-free modes in the hub frame, no geometric
  stiffening), which loses stability once the hub turns faster than the first bending frequency.

Builds the levels first (the time printed: from an empty cache the derivation and compile, else
the loading). Then per Ωs, --repeat times alternately so that both see the same load: gpmegen's
levels at once on the cores (threads of this process: the compiled loops release Python's lock)
and one after the other, each with its extrapolations and refinement, and each compared Exudyn run.
Prints the reference's own convergence (how much it changes with half its elements and with half
its step), where gpmegen's time goes per level (steps, Newton iterations, Jacobians, LU
factorizations, the projection's constraint evaluations, the run's seconds and those of the
compiled loop alone), and at the end one table: per run the best wall time (and all), the error
against the reference relative to its peak and for gpmegen the estimated error; writes
figures/spinup.png.

    .venv/bin/python -m pip install exudyn      # the reference engine: a benchmark dependency only
    .venv/bin/python benchmarks/spinup.py                        # Ωs = 4, 6, 10
    .venv/bin/python benchmarks/spinup.py --omega 4 --repeat 1 --no-reference-check --compare 8
    .venv/bin/python benchmarks/spinup.py --omega 10 --nrfe 10 20 30 40
    .venv/bin/python benchmarks/spinup.py --method rk4 --dt 1e-4 --repeat 1
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MODELS = {"axial": ROOT / "examples" / "spinup_axial.toml", "bending": ROOT / "examples" / "spinup.toml"}
L, EI, EA, RHOA, T, T_END = 10.0, 1.4e4, 2.8e7, 1.2, 15.0, 20.0
SAVED = 0.01  # s between compared samples


def hub_angle(t, omega):
    """θ(t) (rad) of the spin-up law, and its first two derivatives."""
    t = np.asarray(t, dtype=float)
    w = 2 * math.pi / T
    up = t <= T
    theta = np.where(up, omega / T * (t**2 / 2 + (np.cos(w * t) - 1) / w**2), omega * (t - T / 2))
    rate = np.where(up, omega / T * (t - np.sin(w * t) / w), omega)
    acceleration = np.where(up, omega / T * (1 - np.cos(w * t)), 0.0)
    return theta, rate, acceleration


def in_hub_frame(t, points, omega):
    """The y coordinate in the hub frame of points (N, 3) given in the base frame."""
    theta = hub_angle(t, omega)[0]
    return -np.sin(theta) * points[:, 0] + np.cos(theta) * points[:, 1]


def gpmegen_build(model_file, nrfe, dt):
    """Build, compile and load every level (in the pool's processes, as the run does); returns the
    wall seconds (from an empty cache: the derivation, emission and compile; else the loading)."""
    from gpmegen.analysis.discretization.levels import simulate_levels
    from gpmegen.analysis.run.runspec import RunSpec

    start = time.perf_counter()
    simulate_levels(model_file, nrfe, RunSpec(t_end=0.0, dt=dt, save_every=1, start="none"), backend="c")
    return time.perf_counter() - start


def gpmegen_runs(model_file, omega, nrfe, dt, method="rk4", workers=None, refine=(), tolerance=None, loops=True):
    """The tip's deflection in the hub frame at each n_rfe and extrapolated: (t, data, seconds of
    each level's run, wall seconds of all (the runs, the extrapolations and any refinement),
    the levels run at once on the cores, and each level's effort: the counts of its integrator
    and, for generalized-α, the seconds of its compiled loop alone); ``workers``: processes or
    threads (default one per core). While the limit of two terms estimates its error above
    ``tolerance`` (relative to its peak), the next level of ``refine`` is run and the levels
    extrapolated again (``data["nrfe"]``: the levels used); ``loops``: time each level's compiled
    loop alone, after the wall (:func:`integration_seconds`). Build the levels first
    (:func:`gpmegen_build`)."""
    from gpmegen.analysis.discretization import extrapolate
    from gpmegen.analysis.discretization.levels import simulate_levels
    from gpmegen.analysis.post.results import metadata
    from gpmegen.analysis.run.runspec import RunSpec

    def run(levels_nrfe):
        spec = RunSpec(t_end=T_END, dt=dt, save_every=int(round(SAVED / dt)), method=method, start="none")
        return simulate_levels(model_file, levels_nrfe, spec, backend="c", params={"Omega": omega}, workers=workers)

    start = time.perf_counter()
    levels, more = run(nrfe), list(refine)
    while True:
        tip = in_hub(extrapolate.extrapolate(levels, ["points"]), omega)
        if len(levels) >= 3:
            tip["even"] = in_hub(extrapolate.extrapolate(levels, ["points"], terms=2), omega)
        estimated = (np.max(np.abs(tip["even"]["limit_error"])) / np.max(np.abs(tip["even"]["limit"]))
                     if "even" in tip else np.inf)
        if not more or tolerance is None or estimated <= tolerance:
            break
        levels = levels + run([more.pop(0)])
    wall = time.perf_counter() - start
    seconds = [level.seconds for level in levels]
    efforts = [dict(metadata(level.results)["settings"]["effort"], n_dof=level.loaded.n_dof) for level in levels]
    if method == "genalpha" and loops:
        for effort, level in zip(efforts, levels):
            effort["integration"], effort["difference"] = integration_seconds(level, dt)
    tip["nrfe"] = [level.nrfe for level in levels]
    return tip["t"], tip, seconds, wall, efforts


def integration_seconds(level, dt):
    """The wall seconds of the compiled generalized-α loop alone on ``level``'s loaded model from
    its run's start (in this process), and the largest difference of its final q from the run's
    (0: the same integration)."""
    from gpmegen.runtime import integrators

    q, qd = level.results["q"], level.results["qd"]
    start = time.perf_counter()
    y = integrators.genalpha.genalpha(level.loaded, q[0], qd[0], T_END, dt, SAVED)[1]
    seconds = time.perf_counter() - start
    return seconds, float(np.max(np.abs(y[-1, :q.shape[1]] - q[-1])))


def in_hub(data, omega):
    """The tip's deflection in the hub frame from an extrapolation of the points: ``levels``,
    ``errors``, ``limit``, ``limit_error``, ``order``, ``t``."""
    t = data["t"]
    tip = {"t": t, "levels": np.array([in_hub_frame(t, p[:, 0], omega) for p in data["points"]])}
    # θ is prescribed, so the rotation into the hub frame is exact and linear in the point: the
    # limit and the errors rotate like the values
    theta = hub_angle(t, omega)[0]
    rotate = np.stack([-np.sin(theta), np.cos(theta)], axis=-1)
    tip["errors"] = np.einsum("nk,lnk->ln", rotate, data["points_error"][:, :, 0, :2])
    tip["limit"] = np.einsum("nk,nk->n", rotate, data["points_limit"][:, 0, :2])
    tip["limit_error"] = np.einsum("nk,nk->n", rotate, data["points_limit_error"][:, 0, :2])
    tip["order"] = float(data["points_order"])
    return tip


#: Exudyn's settings as its users would tune them for this beam: generalized-α of spectral radius
#: 0.9 (1.0 does not converge: index-3 constraints), Newton to a relative 1e-8 and an absolute 1e-6
#: (its default absolute tolerance is below the round-off of the axial forces, EA = 2.8e7 N, and
#: makes it cut its step thousands of times), and the dense LU (EigenDense): at these sizes (8 to 16
#: elements, 36 to 68 coordinates) faster than its sparse solver, with the same results to the
#: digits printed (8 elements at 2e-3 s, Ωs = 4: 3.73 s against 5.87 s; 12 at 1e-3 s: 9.38 s
#: against 13.56 s, at load 2.4). ``--exudyn-solver`` times the other.
EXUDYN_RHO_INF, EXUDYN_RTOL, EXUDYN_ATOL = 0.9, 1e-8, 1e-6
EXUDYN_SOLVER = "EigenDense"


def _symbolic_hub_law(mbs, item, omega):
    """θ(t) of :func:`hub_angle` as an Exudyn symbolic user function of the constraint ``item``
    (keep the returned object alive while the system runs)."""
    import exudyn
    from exudyn.advancedUtilities import CreateSymbolicUserFunction

    esym, w = exudyn.symbolic, 2 * math.pi / T

    def law(mbs, time, item_number, offset):
        up = omega / T * (time * time / 2 + (esym.cos(w * time) - 1) / w**2)
        return esym.IfThenElse(time <= T, up, omega * (time - T / 2))

    return CreateSymbolicUserFunction(mbs, law, "offsetUserFunction", item)


def exudyn_run(omega, elements, step, t, modified=False, solver=None):
    """The tip's deflection in the hub frame by Exudyn's ANCF cable elements, at the instants
    ``t``, with the settings above and full Newton (``modified``: Exudyn's modified Newton, its
    Jacobian kept while the iteration converges); returns (values, wall seconds of its solve);
    values None when its solver gave up; ``solver``: its linear solver (default EXUDYN_SOLVER)."""
    import exudyn
    from exudyn import utilities as xu
    from exudyn.beams import GenerateBeamElementsAlongLine

    container = exudyn.SystemContainer()
    mbs = container.AddSystem()
    ground = mbs.AddObject(xu.ObjectGround())
    cable = xu.ObjectANCFCable2D(massPerLength=RHOA, bendingStiffness=EI, axialStiffness=EA)
    nodes = GenerateBeamElementsAlongLine(mbs, [0, 0, 0], [L, 0, 0], elements, cable)["nodes"]
    # a rigid hub turning about z, its angle held to θ(t); the cable's first node clamped to it
    hub = mbs.CreateRigidBody(referencePosition=[0, 0, 0], inertia=xu.InertiaCuboid(1000, [0.1, 0.1, 0.1]),
                              create2D=True, returnDict=True)
    hub_marker = mbs.AddMarker(xu.MarkerBodyRigid(bodyNumber=hub["bodyNumber"], localPosition=[0, 0, 0]))
    root = mbs.AddMarker(xu.MarkerNodeRigid(nodeNumber=nodes[0]))
    mbs.AddObject(xu.GenericJoint(markerNumbers=[root, hub_marker], constrainedAxes=[1, 1, 0, 0, 0, 1]))
    mbs.AddObject(xu.RevoluteJoint2D(markerNumbers=[hub_marker, mbs.AddMarker(xu.MarkerBodyRigid(bodyNumber=ground))]))
    fixed = mbs.AddMarker(xu.MarkerNodeCoordinate(nodeNumber=mbs.AddNode(xu.NodePointGround()), coordinate=0))
    angle = mbs.AddMarker(xu.MarkerNodeCoordinate(nodeNumber=hub["nodeNumber"], coordinate=2))
    held = mbs.AddObject(xu.CoordinateConstraint(markerNumbers=[fixed, angle], offset=0.0))
    # the hub's law as Exudyn's symbolic user function (an expression tree evaluated in C++): a
    # Python function, called back at every evaluation, took 6.1 s of a 6.2 s run where this
    # takes 2.7 s, with the same results to the last bit (8 elements, Ωs = 4, load 0.04)
    law = _symbolic_hub_law(mbs, held, omega)
    mbs.SetObjectParameter(held, "offsetUserFunction", law)
    sensor = mbs.AddSensor(xu.SensorNode(nodeNumber=nodes[-1], storeInternal=True,
                                      outputVariableType=exudyn.OutputVariableType.Position))
    mbs.Assemble()
    settings = exudyn.SimulationSettings()
    settings.timeIntegration.numberOfSteps = int(round(T_END / step))
    settings.timeIntegration.endTime = T_END
    settings.timeIntegration.generalizedAlpha.spectralRadius = EXUDYN_RHO_INF
    settings.timeIntegration.newton.relativeTolerance = EXUDYN_RTOL
    settings.timeIntegration.newton.absoluteTolerance = EXUDYN_ATOL
    settings.timeIntegration.newton.useModifiedNewton = modified
    settings.timeIntegration.adaptiveStep = False
    settings.timeIntegration.verboseMode = 0
    settings.solution.file.write = False
    settings.solution.sensors.writePeriod = step  # every step: interpolated onto t below
    settings.linearSolver.solverType = getattr(exudyn.LinearSolverType, solver or EXUDYN_SOLVER)
    start = time.perf_counter()
    try:
        mbs.SolveDynamic(settings)
    except exudyn.SolverError:  # its Newton iteration stalls on finer meshes and steps
        return None, time.perf_counter() - start
    wall = time.perf_counter() - start
    stored = mbs.GetSensorStoredData(sensor)
    y = in_hub_frame(stored[:, 0], stored[:, 1:4], omega)
    return np.interp(t, stored[:, 0], y), wall


def modal_run(omega, t, modes=4):
    """The conventional linear model: clamped-free Euler–Bernoulli modes φᵢ in the hub frame,
    ``q̈ᵢ + (ωᵢ² - θ̇²) qᵢ = -θ̈ ∫ρA x φᵢ dx`` (mass-normalized modes, no geometric stiffening);
    the tip's deflection Σ φᵢ(L) qᵢ at ``t``. None where it overflows."""
    from scipy.integrate import solve_ivp

    from gpmegen.analysis.post.beam import CLAMPED_FREE_LAMBDA

    x = np.linspace(0.0, L, 4001)
    shapes, omegas = [], []
    for lam in CLAMPED_FREE_LAMBDA[:modes]:
        sigma = (math.cosh(lam) + math.cos(lam)) / (math.sinh(lam) + math.sin(lam))
        z = lam * x / L
        phi = np.cosh(z) - np.cos(z) - sigma * (np.sinh(z) - np.sin(z))
        shapes.append(phi / math.sqrt(np.trapezoid(RHOA * phi**2, x)))
        omegas.append(lam**2 / L**2 * math.sqrt(EI / RHOA))
    shapes, omegas = np.array(shapes), np.array(omegas)
    load = np.trapezoid(RHOA * x * shapes, x, axis=1)

    def rhs(time, y):
        _, rate, acceleration = hub_angle(time, omega)
        q, qd = y[:modes], y[modes:]
        return np.concatenate([qd, -(omegas**2 - rate**2) * q - acceleration * load])

    sol = solve_ivp(rhs, (0.0, T_END), np.zeros(2 * modes), t_eval=t, method="DOP853", rtol=1e-10, atol=1e-12)
    tip = np.full(len(t), np.nan)
    tip[: sol.y.shape[1]] = shapes[:, -1] @ sol.y[:modes]
    return tip


def figure(cases, path):
    """Tip deflection in the hub frame for each Ωs: reference, gpmegen's limit, linear model."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(2, len(cases), figsize=(5.2 * len(cases), 6.8), squeeze=False)
    for j, (omega, c) in enumerate(cases.items()):
        top, bottom = axes[0, j], axes[1, j]
        top.plot(c["t"], c["reference"], "k", lw=2.5, alpha=0.4, label="reference (Exudyn ANCF)")
        top.plot(c["t"], c["tip"]["limit"], "C0", lw=1, label="gpmegen, extrapolated")
        linear = np.where(np.abs(c["linear"]) < 3 * np.max(np.abs(c["reference"])), c["linear"], np.nan)
        top.plot(c["t"], linear, "C3--", lw=1, label="linear modal model (no geometric stiffening)")
        top.set_title(f"Ωs = {omega:g} rad/s")
        top.set_ylabel("tip deflection in the hub frame (m)")
        top.legend(fontsize=7)
        scale = np.max(np.abs(c["reference"]))
        for n, e in zip(c["nrfe"], c["tip"]["levels"]):
            bottom.semilogy(c["t"], np.abs(e - c["reference"]) / scale, lw=0.7, label=f"n_rfe = {n}")
        bottom.semilogy(c["t"], np.abs(c["tip"]["limit"] - c["reference"]) / scale, "k", lw=1, label="limit")
        bottom.semilogy(c["t"], np.abs(c["tip"]["limit_error"]) / scale, "k:", lw=1, label="limit, estimated")
        bottom.set_ylabel("|error| / peak of the reference")
        bottom.set_xlabel("t (s)")
        bottom.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=120)
    return path


def load() -> str:
    """The load averages over 1, 5 and 15 minutes."""
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def effort_rows(nrfe, efforts, seconds):
    """Where a level's time goes, one line per level: steps, Newton iterations, Jacobians,
    factorizations, the projection's constraint evaluations and the run's seconds."""
    lines = []
    for n, effort, s in zip(nrfe, efforts, seconds):
        steps, jacobians = effort["steps"], effort["jacobians"]
        # each step: its Newton iterations (one GPME solve each) and the rates at its end (one);
        # each Jacobian 4 n_dof + 1 solves; each call of the compiled loop one more at its start
        iterations = effort["solves"] - (4 * effort["n_dof"] + 1) * jacobians - steps
        lines.append(f"    n_rfe {n:3d} ({effort['n_dof']:3d} dof): {steps} steps, ≤ {iterations} Newton iterations "
                     f"({iterations / max(steps, 1):.2f} a step), {jacobians} Jacobians, {effort['factorizations']} "
                     f"LU factorizations, {effort['projections']} constraint evaluations projecting; run {s:.2f} s"
                     + (f", of it the compiled loop {effort['integration']:.2f} s (again in this process, final q "
                        f"within {effort['difference']:.1e})" if "integration" in effort else ""))
    return lines


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--omega", type=float, nargs="+", default=[4.0, 6.0, 10.0], help="final hub speeds (rad/s)")
    parser.add_argument("--nrfe", type=int, nargs="+", default=[5, 10, 20, 30], help="gpmegen's levels")
    parser.add_argument("--refine", type=int, nargs="*", default=[40],
                        help="levels added one at a time while the limit's estimated error is above --tolerance")
    parser.add_argument("--tolerance", type=float, default=2e-5,
                        help="the error asked of gpmegen's limit (n^-2 and n^-4), estimated, relative to its peak")
    parser.add_argument("--model", choices=tuple(MODELS), default="axial",
                        help="gpmegen's beam: stretching and bending like the reference (default), or bending only")
    parser.add_argument("--dt", type=float, nargs="+", default=[1e-3, 2e-3],
                        help="gpmegen's steps (s), each run in turn; RK4 needs 1e-4 (axial modes)")
    parser.add_argument("--method", choices=("rk4", "genalpha"), default="genalpha",
                        help="gpmegen's integrator: generalized-α, whose step the first bending mode alone bounds "
                             "(1e-3 s), or RK4 (its step bound by the axial modes' stability)")
    parser.add_argument("--elements", type=int, default=32, help="ANCF elements of the reference")
    parser.add_argument("--step", type=float, default=5e-4, help="the reference's step (s)")
    parser.add_argument("--no-reference-check", action="store_true",
                        help="skip the reference's runs with half its elements and half its step")
    parser.add_argument("--compare", type=int, nargs="*", default=[8, 12, 16],
                        help="Exudyn runs timed against gpmegen (elements, at each --compare-step)")
    parser.add_argument("--compare-step", type=float, nargs="+", default=[1e-3, 2e-3], help="their steps (s)")
    parser.add_argument("--exudyn-solver", choices=("EigenDense", "EigenSparse"), default=EXUDYN_SOLVER,
                        help="Exudyn's linear solver in the compared runs")
    parser.add_argument("--modified-newton", action="store_true",
                        help="also time the compared Exudyn runs with its modified Newton")
    parser.add_argument("--repeat", type=int, default=3,
                        help="timed runs of each, gpmegen and Exudyn alternately; the best counts")
    parser.add_argument("--figure", type=Path, default=ROOT / "figures" / "spinup.png")
    args = parser.parse_args(argv)
    if args.repeat < 1:
        parser.error(f"--repeat must be at least 1, got {args.repeat}")
    for dt in args.dt:  # every run is compared at the same instants
        if abs(SAVED / dt - round(SAVED / dt)) > 1e-9:
            parser.error(f"--dt {dt:g}: the runs are compared every {SAVED:g} s, so each step must divide it")

    from gpmegen.analysis.discretization.levels import pool_size

    model_file, processes = MODELS[args.model], pool_size(len(set(args.nrfe)))
    print(f"load average {load()} on {os.cpu_count()} cores")
    build = gpmegen_build(model_file, args.nrfe + args.refine, args.dt[0])
    print(f"gpmegen: n_rfe {' '.join(map(str, args.nrfe + args.refine))} built, compiled and loaded in {build:.1f} s "
          f"wall (from the cache when it holds them)")
    pools = sorted({processes, 1}, reverse=True)  # the levels at once, and one after the other
    compared = [(elements, step, modified) for elements in args.compare for step in args.compare_step
                for modified in ((False, True) if args.modified_newton else (False,))]
    cases, table, best_of = {}, [], []
    for omega in args.omega:
        # per gpmegen step: its first run (the tip, the efforts) and, per pool, each repeat's times
        first, walls = {}, {(dt, w): [] for dt in args.dt for w in pools}
        exudyn_walls, loads = {key: [] for key in compared}, []
        for _ in range(args.repeat):  # alternately, so that both see the same load
            loads.append(os.getloadavg()[0])
            for dt, workers in walls:
                got = gpmegen_runs(model_file, omega, args.nrfe, dt, args.method, workers, args.refine,
                                   args.tolerance, loops=dt not in first)
                walls[dt, workers].append((got[3], got[2], got[4]))
                first.setdefault(dt, got)
            t = first[args.dt[0]][0]
            for key in compared:
                values, seconds = exudyn_run(omega, key[0], key[1], t, modified=key[2], solver=args.exudyn_solver)
                exudyn_walls[key].append((seconds, values))
        reference, seconds_reference = exudyn_run(omega, args.elements, args.step, t)
        if reference is None:
            print(f"\nΩs = {omega:g} rad/s: the reference's solver gave up; try another --step or --elements")
            continue
        scale = np.max(np.abs(reference))
        print(f"\nΩs = {omega:g} rad/s: reference peak {scale:.6f} m (Exudyn, {args.elements} ANCF elements, "
              f"step {args.step:g} s, {seconds_reference:.1f} s); load {' '.join(f'{x:.2f}' for x in loads)} "
              f"at the start of each repeat")
        if not args.no_reference_check:
            for label, (elements, step) in (("half the elements", (args.elements // 2, args.step)),
                                            ("half the step", (args.elements, args.step / 2))):
                other, seconds_other = exudyn_run(omega, elements, step, t)
                change = "its solver gave up" if other is None else f"{np.max(np.abs(other - reference)) / scale:.2e}"
                print(f"  reference with {label} ({elements} elements, step {step:g} s): changes by {change} "
                      f"({seconds_other:.1f} s)")
        within = []  # (best wall, label) of every run whose error is within the tolerance
        for dt in args.dt:
            tip = first[dt][1]
            used = tip["nrfe"]
            for workers in pools:
                best = min(walls[dt, workers], key=lambda w: w[0])
                print(f"  gpmegen's levels n_rfe {' '.join(map(str, used))} ({args.method}, dt {dt:g} s) "
                      f"{workers} at once, the fastest of {args.repeat}: wall {best[0]:.2f} s (runs and "
                      f"extrapolations), its levels' runs {sum(best[1]):.2f} s in all (longest {max(best[1]):.2f} s)")
                # the counts are those of every repeat; the compiled loops were timed after the first run
                for line in effort_rows(used, first[dt][4], best[1]):
                    print(line)
            for n, values, estimated in zip(used, tip["levels"], tip["errors"]):
                table.append((omega, f"gpmegen n_rfe {n}, dt {dt:g} s", None,
                              np.max(np.abs(values - reference)) / scale, np.max(np.abs(estimated)) / scale))
            limits = [("gpmegen limit, term n^-2", tip)] + ([("gpmegen limit, n^-2 and n^-4", tip["even"])]
                                                            if "even" in tip else [])
            for (label, data), workers in ((limit, workers) for limit in limits for workers in pools):
                row = (omega, f"{label}, n_rfe {' '.join(map(str, used))}, dt {dt:g} s, {workers} at once",
                       [w[0] for w in walls[dt, workers]], np.max(np.abs(data["limit"] - reference)) / scale,
                       np.max(np.abs(data["limit_error"])) / scale)
                table.append(row)
                if row[3] <= args.tolerance:
                    within.append((min(row[2]), row[1], workers))
            print(f"  observed order (dt {dt:g} s) {tip['order']:.2f}")
        for (elements, step, modified), runs in exudyn_walls.items():
            values = runs[0][1]
            error = np.nan if values is None else np.max(np.abs(values - reference)) / scale
            label = f"Exudyn {elements} elements, step {step:g} s{', modified Newton' if modified else ''}"
            table.append((omega, label, [r[0] for r in runs], error, None))
            if error <= args.tolerance:
                within.append((min(r[0] for r in runs), label, None))
        best_of.append((omega, within))
        tip = first[args.dt[0]][1]
        linear = modal_run(omega, t)
        print(f"  linear modal model: peak |tip| {np.nanmax(np.abs(linear)):.3g} m")
        cases[omega] = {"t": t, "tip": tip, "reference": reference, "linear": linear, "nrfe": tip["nrfe"]}
    print(f"\nerror: max over t of |tip deflection - reference| / the reference's peak; reference: Exudyn "
          f"{args.elements} ANCF elements, step {args.step:g} s; gpmegen {args.method}; Exudyn "
          f"ρ∞ {EXUDYN_RHO_INF:g}, Newton rtol {EXUDYN_RTOL:g} atol {EXUDYN_ATOL:g}, "
          f"{args.exudyn_solver}; wall: best of {args.repeat} (all)")
    print("| Ωs [rad/s] | run | wall [s] | error | estimated error |")
    print("|---|---|---|---|---|")
    for omega, label, seconds, error, estimated in table:
        wall = "" if seconds is None else f"**{min(seconds):.2f}** ({', '.join(f'{s:.2f}' for s in seconds)})"
        print(f"| {omega:g} | {label} | {wall} | {error:.2e} | {'' if estimated is None else f'{estimated:.2e}'} |")
    print(f"\nthe fastest run within {args.tolerance:g} of the reference, per engine (gpmegen per number of threads)")
    for omega, within in best_of:
        peer = min((w for w in within if w[2] is None), default=None)
        for workers in pools:
            ours = min((w for w in within if w[2] == workers), default=None)
            ratio = f"{ours[0] / peer[0]:.2f}" if ours and peer else "-"
            print(f"  Ωs = {omega:g}: gpmegen, {workers} at once: {ours[1] + f' {ours[0]:.2f} s' if ours else 'none'}; "
                  f"Exudyn: {peer[1] + f' {peer[0]:.2f} s' if peer else 'none'}; gpmegen / Exudyn {ratio}")
    print(f"load average {load()}")
    if cases:
        print(f"\nfigure: {figure(cases, args.figure)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
