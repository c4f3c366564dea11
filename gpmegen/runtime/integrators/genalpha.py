"""Generalized-α (Chung–Hulbert: implicit, second order, numerically damped) with a fixed step
in the compiled loop, projected onto the constraints at each step's end."""

from __future__ import annotations

import numpy as np

from ... import limits
from .base import COUNTS, Effort, Integrator, Option
from .loop import CHUNK_SECONDS, check_start, chunked, grid, start_state
from .registry import register

#: Default numerical damping of generalized-α: the spectral radius at h ω → ∞. 0.9 damps what the
#: step cannot resolve (the sdes' kHz modes at h = 1e-3 s lose 10 % a step) and leaves the motion
#: below 0.1/h almost untouched, as flexible multibody codes default to (0.8-0.9).
RHO_INF = 0.9


def genalpha(model, q0, qd0, t_end, dt, save_dt, rho_inf=RHO_INF, t0=0.0, progress=None, max_violation=None,
             watch=None, project=True, steps_per_call=None):
    """Generalized-α (Chung–Hulbert, second order, numerical damping ``rho_inf``) in the compiled
    loop with step ``dt`` (s) on :func:`grid`, modified Newton on q̈ with the GPME's Jacobians,
    saving on the grid of interval ``save_dt`` (s) (cubic Hermite between steps), driven by
    :func:`chunked`. With ``project`` (every run of ``simulate``; False only to measure what it
    does), each step's end is put back onto the position constraints (Newton on Φ = 0 to 1e-12)
    and q̇ onto ``D q̇ + Φ_t = 0`` and first-order ``Ψ = 0``: the Baumgarte-stabilized GPME
    alone drifts to 1e-5 at the steps this method is for. ``steps_per_call``: see :func:`chunked`.
    Returns ``(t, y, outcome, effort)``."""
    GenAlpha().check_model(model)
    check_start(model, t0, q0, qd0)
    if not 0.0 <= rho_inf <= 1.0:
        raise ValueError(f"need 0 <= rho_inf <= 1, got {rho_inf}")
    g, saves = grid(t0, t_end, dt), grid(t0, t_end, save_dt)
    save_times = np.array([saves.time(k) for k in range(1, saves.n_steps + 1)])
    chunk = max(1, int(round(CHUNK_SECONDS / dt)))
    n = model.n_dof
    counts = np.zeros(COUNTS, dtype=np.int64)
    n_r = n + len(model.controller_names)   # Newton's unknowns: q̈ and the controller states
    memory = {"a": np.full(2 * n, np.nan), "S": np.zeros((n_r, n_r)), "pivot": np.zeros(n_r, dtype=np.intc),
              "have": np.zeros(1, dtype=np.intc)}

    def advance(model, y, k_from, k_to):
        carry, place = np.array(y, dtype=float), [k_from]

        def more(max_steps):
            a = place[0]
            b = min(k_to, a + max_steps)
            inside = save_times[(save_times > g.time(a)) & (save_times <= g.time(b))]
            rows, status = model.genalpha(g, a, b, rho_inf, project, carry, memory, inside, counts)
            place[0] = b
            return inside[:len(rows)], rows, status, b - a, carry if b == k_to else None

        return more

    y0 = start_state(model, q0, qd0)
    t, y, outcome = chunked(model, y0, g, chunk, advance, progress, max_violation, watch, steps_per_call)
    return t, y, outcome, Effort(*(int(c) for c in counts))



@register
class GenAlpha(Integrator):
    """Generalized-α in C: step ``dt``, damping ``rho_inf``; no controller states yet."""

    name = entry = "genalpha"
    summary = "genalpha (implicit, order 2, numerically damped, step --dt, in C)"
    compiled = c_loop = chunked = True
    options = (Option("rho_inf", RHO_INF, "", lambda v: 0 <= v <= 1, "must be a number from 0 to 1", "fraction",
                      "genalpha's numerical damping: its spectral radius at large steps, 0 (most damped) to 1 "
                      "(none; default 0.9)"),)
    stiff = True

    def run(self, model, q0, qd0, spec, progress=None, watch=None):
        return genalpha(model, q0, qd0, spec.t_end, spec.dt, spec.save_interval, spec.rho_inf, progress=progress,
                        max_violation=spec.max_violation, watch=watch)

    def estimate(self, n_dof, t_end, dt, omega, backend):
        n = limits.steps(t_end, dt)
        step = limits.interpolate(limits.GENALPHA_SOLVES_PER_STEP, n_dof) * limits.solve_seconds(n_dof)
        jacobian = limits.jacobian_seconds(n_dof)
        return limits.Integration(n, n * step + limits.JACOBIANS_PER_RUN * jacobian, False,
                                  f"{n:.3g} generalized-α steps of n_dof = {n_dof} ({step:.2g} s each, and "
                                  f"{limits.JACOBIANS_PER_RUN} Jacobians with their LU of {jacobian:.2g} s)")
