"""DOP853 (Dormand–Prince 8(5,3), adaptive, explicit) in the compiled loop."""

from __future__ import annotations

import math

from ... import limits
from .adaptive import CompiledAdaptive, compiled_adaptive
from .base import ATOL, RTOL
from .registry import register


def dop853(model, q0, qd0, t_end, save_dt, t0=0.0, rtol=RTOL, atol=ATOL, progress=None, max_violation=None,
           watch=None, steps_per_call=None):
    """DOP853 (Dormand–Prince 8(5,3), adaptive) in the compiled loop, from ``t0`` to ``t_end`` (s),
    saving on :func:`gpmegen.runtime.integrators.loop.grid` with interval ``save_dt`` (s) by its
    dense output of order 7, driven by :func:`gpmegen.runtime.integrators.loop.chunked`
    (``steps_per_call``: see there). ``rtol``, ``atol``: the tolerances of each step's error in
    ``q`` and ``q̇``. Returns ``(t, y, outcome, effort)``, ``effort`` an
    :class:`gpmegen.runtime.integrators.base.Effort`."""
    return compiled_adaptive(DOP853(), model, q0, qd0, t_end, save_dt, t0, rtol, atol, progress,
                             max_violation, watch, steps_per_call)


@register
class DOP853(CompiledAdaptive):
    """DOP853 in C, for the ideal or the actuated realization: its steps bound by the stable step
    of the stiffest mode."""

    name = entry = "dop853"
    summary = "dop853 (adaptive, order 8, in C)"
    frequency = "highest"
    actuated_loop = True   # its stages solve the actuated realization where the model has actuators

    def estimate(self, n_dof, t_end, dt, omega, backend):
        if omega is None or not omega > 0:
            return None
        stable = limits.DOP853_STABILITY_RADIUS / omega
        n = math.ceil(t_end / stable)
        return limits.Integration(
            n, n * limits.DOP853_SOLVES_PER_STEP * limits.solve_seconds(n_dof), True,
            f"at least {n:.3g} DOP853 steps of n_dof = {n_dof} (its stable step {stable:.2g} s for the "
            f"highest natural frequency {omega / (2 * math.pi):.4g} Hz at the start)")
