"""The integrators on the paper's study: wall time, the error of q(t_end) and the constraint
violation of each, for the reference arm at several n_rfe.

Run: ``.venv/bin/python benchmarks/integrators.py [t_end] [n_rfe ...]`` (default 10 s, n_rfe 5);
``--reference FILE.npz`` takes the converged run from a file holding its ``t`` and ``q`` (one
n_rfe; e.g. a DOP853 run at rtol 1e-11 saved with numpy.savez) instead of running it, or
``--reference-rtol 1e-10`` makes the one it runs looser (for n_rfe 20, where 1e-12 takes long);
``--methods radau dop853`` runs only the rows whose label starts so, and ``--scipy 0.1`` adds the
comparison of radau in C with scipy-radau (the model's right-hand side from Python, the Jacobian
by its differences) over that many seconds, both at rtol 1e-6.
Every method runs in C from the locked start through the same chunked driver a simulate run uses,
saving every 1 ms; the wall time is that of the integration alone (the model is loaded, compiled
and started before). The reference is the compiled DOP853 at rtol = atol = 1e-12 (the tests
check it against SciPy's DOP853 to its tolerance; atol 1e-14 took 5.3 million steps at n_rfe 5,
the round-off of the solve then bounding the error estimate); for each n_rfe its own q(t_end) is the
converged run the others are measured against. max|Φ| is the largest constraint violation at the
saved instants. The load of the machine is printed, since the wall times depend on it.
"""

from __future__ import annotations

import argparse
import os
import time

import numpy as np

import gpmegen
from gpmegen.analysis.run import reference_case
from gpmegen.runtime import integrators

SAVE_DT = 1e-3
#: (label, method, options): the paper's RK4, DOP853 at two tolerances, generalized-α at three
#: steps (projected onto the constraints, as simulate runs it) and once without the projection,
#: Radau IIA at three tolerances.
METHODS = (
    ("rk4 dt 1e-5", "rk4", {"dt": 1e-5}),
    ("dop853 rtol 1e-6", "dop853", {"rtol": 1e-6, "atol": 1e-8}),
    ("dop853 rtol 1e-8", "dop853", {"rtol": 1e-8, "atol": 1e-10}),
    ("genalpha dt 1e-4", "genalpha", {"dt": 1e-4}),
    ("genalpha dt 1e-4 unprojected", "genalpha", {"dt": 1e-4, "project": False}),
    ("genalpha dt 5e-5", "genalpha", {"dt": 5e-5}),
    ("genalpha dt 2.5e-5", "genalpha", {"dt": 2.5e-5}),
    ("radau rtol 1e-4", "radau", {"rtol": 1e-4, "atol": 1e-6}),
    ("radau rtol 1e-6", "radau", {"rtol": 1e-6, "atol": 1e-8}),
    ("radau rtol 1e-8", "radau", {"rtol": 1e-8, "atol": 1e-10}),
)

#: The adaptive methods in the compiled loop, by name.
ADAPTIVE = {"dop853": integrators.dop853.dop853, "radau": integrators.radau.radau}


def run(model, q0, t_end, method, options):
    """``(wall s, t, y, effort)`` of one integration from ``q0`` at rest."""
    qd0 = np.zeros(model.n_dof)
    start = time.perf_counter()
    if method == "rk4":
        dt = options["dt"]
        t, y, outcome = integrators.rk4.rk4(model, q0, qd0, t_end, dt, save_every=round(SAVE_DT / dt))
        effort = integrators.rk4.rk4_effort(t, 0.0, dt)
    elif method in ADAPTIVE:
        t, y, outcome, effort = ADAPTIVE[method](model, q0, qd0, t_end, SAVE_DT, **options)
    elif method in integrators.scipy_radau.SCIPY:
        times = integrators.loop.grid(0.0, t_end, SAVE_DT)
        t_eval = np.array([times.time(k) for k in range(times.n_steps + 1)])
        t, y, outcome, effort = integrators.scipy_radau.scipy_solve(model, q0, qd0, t_end,
                                                                    method=integrators.scipy_radau.SCIPY[method],
                                                                    t_eval=t_eval, **options)
    else:
        t, y, outcome, effort = integrators.genalpha.genalpha(model, q0, qd0, t_end, options["dt"], SAVE_DT,
                                                              project=options.get("project", True))
    wall = time.perf_counter() - start
    if not outcome.complete:
        raise SystemExit(f"{method} {options}: {outcome}")
    return wall, t, y, effort


def violation(model, t, y) -> float:
    """max|Φ| over the saved states ``y`` at ``t``."""
    n = model.n_dof
    return max(float(np.abs(model.constraint_terms(tk, yk[:n], yk[n:2 * n])[0]).max(initial=0.0))
               for tk, yk in zip(t, y))


def main(t_end=10.0, levels=(5,), methods=None, reference_rtol=1e-12, reference_file=None, scipy_span=None):
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores; t_end = {t_end:g} s, saved every "
          f"{SAVE_DT:g} s")
    for nrfe in levels:
        model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=nrfe, backend="c"))
        n = model.n_dof
        if reference_file:
            stored = np.load(reference_file)
            if not (len(stored["q"][-1]) == n and abs(float(stored["t"][-1]) - t_end) < 1e-12):
                raise SystemExit(f"{reference_file} does not hold q({t_end:g} s) of n_dof = {n}")
            reference = stored["q"][-1]
            print(f"\nn_rfe = {nrfe} ({n} coordinates): reference q({t_end:g} s) from {reference_file}")
        else:
            wall, t, y, effort = run(model, q0, t_end, "dop853", {"rtol": reference_rtol, "atol": reference_rtol})
            reference = y[-1, :n]
            print(f"\nn_rfe = {nrfe} ({n} coordinates): reference dop853 rtol = atol = {reference_rtol:g} in "
                  f"{wall:.1f} s, {effort.describe()}, max|Φ| = {violation(model, t, y):.1e}")
        print(f"{'method':>28} {'wall [s]':>9} {'load':>5} {'max|Δq(t_end)|':>15} {'max|Φ|':>8} {'steps':>9} "
              f"{'rejected':>8} {'solves':>10} {'Jacobians':>9} {'LUs':>8} {'projecting':>10}")
        for label, method, options in METHODS:
            if methods and not label.startswith(tuple(methods)):
                continue
            wall, t, y, effort = run(model, q0, t_end, method, options)
            error = np.abs(y[-1, :n] - reference).max()
            print(f"{label:>28} {wall:>9.2f} {os.getloadavg()[0]:>5.2f} {error:>15.2e} {violation(model, t, y):>8.1e} "
                  f"{effort.steps:>9} {effort.rejected:>8} {effort.solves:>10} {effort.jacobians:>9} "
                  f"{effort.factorizations:>8} {effort.projections:>10}", flush=True)
        if scipy_span:
            compare_scipy(model, q0, scipy_span)


def compare_scipy(model, q0, span, rtol=1e-6):
    """Radau IIA in C against SciPy's Radau on the same model over ``span`` s at ``rtol``: wall
    times, their ratio and the largest error of each in the saved ``q``, ``q̇`` against DOP853 at
    rtol = atol = 1e-12."""
    n = model.n_dof
    options = {"rtol": rtol, "atol": rtol * 1e-2}
    y_ref = run(model, q0, span, "dop853", {"rtol": 1e-12, "atol": 1e-12})[2][:, :2 * n]
    wall_c, _, y_c, effort_c = run(model, q0, span, "radau", options)
    wall_s, _, y_s, effort_s = run(model, q0, span, "scipy-radau", options)
    print(f"over {span:g} s at rtol {rtol:g}: radau (C) {wall_c:.3f} s ({effort_c.describe()}), error "
          f"{np.abs(y_c[:, :2 * n] - y_ref).max():.1e}; scipy-radau {wall_s:.2f} s ({effort_s.describe()}), error "
          f"{np.abs(y_s[:, :2 * n] - y_ref).max():.1e}; {wall_s / wall_c:.0f} times faster in C "
          f"(load {os.getloadavg()[0]:.2f})", flush=True)


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("t_end", type=float, nargs="?", default=10.0)
    parser.add_argument("levels", type=int, nargs="*", default=[5])
    parser.add_argument("--methods", nargs="+", default=None, help="labels' beginnings (rk4, dop853, radau, ...)")
    parser.add_argument("--reference", help="a .npz with the converged run's t and q (one n_rfe)")
    parser.add_argument("--reference-rtol", type=float, default=1e-12)
    parser.add_argument("--scipy", type=float, default=None, metavar="SECONDS")
    args = parser.parse_args()
    if args.reference and len(args.levels) != 1:
        parser.error("--reference holds one n_rfe's run: give one n_rfe")
    main(args.t_end, tuple(args.levels), args.methods, args.reference_rtol, args.reference, args.scipy)
