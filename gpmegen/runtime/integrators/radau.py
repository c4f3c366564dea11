"""Radau IIA of order 5 (implicit, adaptive) in the compiled loop, and the run estimate it
shares with SciPy's Radau."""

from __future__ import annotations

import math

from ... import limits
from .adaptive import CompiledAdaptive, compiled_adaptive
from .base import ATOL, RTOL
from .registry import register


def radau(model, q0, qd0, t_end, save_dt, t0=0.0, rtol=RTOL, atol=ATOL, progress=None, max_violation=None,
          watch=None, steps_per_call=None):
    """Radau IIA of order 5 (implicit, Hairer's RADAU5, with the GPME's Jacobians) in the compiled
    loop, as :func:`gpmegen.runtime.integrators.dop853.dop853` (same arguments and results),
    saving between steps by the polynomial of degree 4 whose derivative passes through the rates
    at the step's start and its three stages. Its steps are not bound by the stiff modes."""
    return compiled_adaptive(Radau(), model, q0, qd0, t_end, save_dt, t0, rtol, atol, progress,
                             max_violation, watch, steps_per_call)


def radau_estimate(n_dof, t_end, omega, name) -> limits.Integration | None:
    """At least the steps of a Radau IIA method ``name`` to ``t_end`` (s): those in
    :data:`gpmegen.limits.STEPS_PER_LOWEST_PERIOD` a period of the lowest natural frequency
    ``omega`` (rad/s) at the start; None without it."""
    if omega is None or not omega > 0:
        return None
    period = 2 * math.pi / omega
    n = math.ceil(t_end / period * limits.STEPS_PER_LOWEST_PERIOD)
    return limits.Integration(
        n, n * limits.RADAU_SOLVES_PER_STEP * limits.solve_seconds(n_dof), True,
        f"at least {n:.3g} {name} steps of n_dof = {n_dof} ({limits.STEPS_PER_LOWEST_PERIOD} a period, "
        f"{period:.2g} s, of the lowest natural frequency {omega / (2 * math.pi):.4g} Hz at the start)")


@register
class Radau(CompiledAdaptive):
    """Radau IIA in C: implicit, for stiff, finely divided links; no controller states yet."""

    name = entry = "radau"
    summary = "radau (implicit, adaptive, order 5, in C: for stiff, finely divided links)"
    frequency = "lowest"
    stiff = True

    def estimate(self, n_dof, t_end, dt, omega, backend):
        return radau_estimate(n_dof, t_end, omega, "Radau IIA")
