"""RK4 at the paper's step against an adaptive integrator at tight tolerance: q(t_end) of the
paper's study for the rigid and the flexible arm.

Run: ``.venv/bin/python benchmarks/integrator_agreement.py [t_end]``. RK4 runs in C; the
adaptive integrator (scipy's solve_ivp) calls the C model's GPME from Python: DOP853 for the
rigid arm, Radau for the flexible arm (its stiff sde modes make explicit adaptive steps tiny).
Measured here over 10 s: 4.8e-13 (rigid, 4 s) and 3.5e-8 (flexible; Radau takes about 20 min).
"""

from __future__ import annotations

import sys
import time

import numpy as np

import gpmegen
from gpmegen.analysis.run import reference_case, study
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.runtime import integrators


def main(t_end=10.0):
    print(f"{'n_rfe':>5} {'adaptive':>8} {'rtol':>7} {'RK4 [s]':>8} {'adaptive [s]':>12} "
          f"{'max|Δq| joints':>15} {'max|Δq| all':>12}  q(t_end) RK4: theta1, psi2, x3")
    for nrfe, method, rtol in ((1, "DOP853", 1e-12), (5, "Radau", 1e-10)):
        model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=nrfe, backend="c"))
        qd0 = np.zeros(model.n_dof)
        t0 = time.perf_counter()
        res = study.simulate(model, q0, RunSpec(t_end=t_end, dt=1e-5, save_every=100000))
        t_rk4 = time.perf_counter() - t0
        t0 = time.perf_counter()
        t, y, status = integrators.scipy_radau.adaptive(model, q0, qd0, t_end, method=method, rtol=rtol,
                                                        atol=rtol * 1e-2,
                                                        t_eval=[t_end])
        t_ad = time.perf_counter() - t0
        q_rk4, q_ad = res["q"][-1], y[-1, :model.n_dof]
        joints = [model.index(c) for c in ("theta1", "psi2", "x3")]
        d = np.abs(q_rk4 - q_ad)
        print(f"{nrfe:>5} {method:>8} {rtol:>7.0e} {t_rk4:>8.1f} {t_ad:>12.1f} {d[joints].max():>15.3e} "
              f"{d.max():>12.3e}  {', '.join(f'{q_rk4[j]:.9f}' for j in joints)}  ({status})", flush=True)


if __name__ == "__main__":
    main(float(sys.argv[1]) if len(sys.argv) > 1 else 10.0)
