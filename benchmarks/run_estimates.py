"""The run estimates of gpmegen.limits against measured runs: RK4 and generalized-α (estimates
of fixed-step runs) and DOP853 (a lower bound from its stable step), for the reference arm at
several n_rfe, on the paper's study from the locked start.

Run: ``.venv/bin/python benchmarks/run_estimates.py [t_end] [n_rfe ...]`` (default 0.5 s, n_rfe
1 5 10 20). Per n_rfe it prints the cost of one GPME solve (a quarter of an RK4 step) and of one
Jacobian with its LU factorization, measured and as limits.py has them, then per method the
wall time of the integration (compiled before the clock starts), what it took, limits.py's
estimate or bound for the same run and their ratio. The load of the machine is printed, since
the wall times depend on it; limits.py is calibrated on a quiet machine, so its estimates are
below the wall times of a busy one.
"""

from __future__ import annotations

import os
import sys
import time

import numpy as np
import scipy.linalg

import gpmegen
from gpmegen import limits
from gpmegen.analysis.post import modes
from gpmegen.analysis.run import reference_case
from gpmegen.runtime import integrators

SAVE_DT = 1e-3
RK4_DT, GENALPHA_DT = 1e-5, 1e-4


def _best(f, repeat=5, number=20) -> float:
    """The least time of ``number`` calls of ``f`` over ``repeat`` tries (s per call)."""
    best = np.inf
    for _ in range(repeat):
        start = time.perf_counter()
        for _ in range(number):
            f()
        best = min(best, (time.perf_counter() - start) / number)
    return best


def _timed(f):
    start = time.perf_counter()
    out = f()
    return time.perf_counter() - start, out


def main(t_end=0.5, levels=(1, 5, 10, 20)):
    print(f"load average {os.getloadavg()[0]:.2f} on {os.cpu_count()} cores; t_end = {t_end:g} s")
    for nrfe in levels:
        model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=nrfe, backend="c"))
        n = model.n_dof
        qd0 = np.zeros(n)
        omega = modes.highest_frequency(model, 0.0, q0, qd0)
        # the compiled gpme_jacobian generalized-α calls (central differences of the solve in a model
        # built without --jacobians), reached below LoadedModel, which offers only exact ones
        jacobian = _best(lambda: scipy.linalg.lu_factor(
            np.eye(n) - model.evaluator.acceleration_jacobians(0.0, q0, qd0, model)[1]))

        def rk4():
            return (*integrators.rk4.rk4(model, q0, qd0, t_end, RK4_DT, save_every=round(SAVE_DT / RK4_DT)), None)

        wall, (t, *_) = _timed(rk4)
        solve = wall / integrators.rk4.rk4_effort(t, 0.0, RK4_DT).solves
        print(f"\nn_rfe = {nrfe} (n_dof {n}, highest natural frequency {omega / (2 * np.pi):.4g} Hz): one GPME solve "
              f"{solve * 1e6:.3g} µs (limits {limits.solve_seconds(n) * 1e6:.3g}), one Jacobian with its LU "
              f"{jacobian * 1e3:.3g} ms (limits {limits.jacobian_seconds(n) * 1e3:.3g}); load "
              f"{os.getloadavg()[0]:.2f}")
        print(f"{'method':>20} {'wall [s]':>9} {'limits [s]':>10} {'ratio':>6} {'steps':>8} {'solves/step':>11} "
              f"{'Jacobians':>9}")
        runs = (("rk4 dt 1e-5", "rk4", RK4_DT, rk4),
                ("genalpha dt 1e-4", "genalpha", GENALPHA_DT,
                 lambda: integrators.genalpha.genalpha(model, q0, qd0, t_end, GENALPHA_DT, SAVE_DT)),
                ("dop853 rtol 1e-8", "dop853", SAVE_DT,
                 lambda: integrators.dop853.dop853(model, q0, qd0, t_end, SAVE_DT)))
        for label, method, dt, call in runs:
            wall, (t, y, outcome, effort) = _timed(call)
            effort = effort or integrators.rk4.rk4_effort(t, 0.0, dt)
            estimate = limits.integration_estimate(n, t_end, dt, method, "c", omega)
            bound = "≥" if estimate.at_least else ""
            print(f"{label:>20} {wall:>9.3f} {bound:>1}{estimate.seconds:>9.3f} {estimate.seconds / wall:>6.2f} "
                  f"{effort.steps:>8} {effort.solves / max(1, effort.steps):>11.2f} {effort.jacobians:>9}", flush=True)


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 0.5,
         tuple(int(a) for a in sys.argv[2:]) or (1, 5, 10, 20))
