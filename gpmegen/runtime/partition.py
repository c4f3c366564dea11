"""Choice of dependent coordinates for the GPME, and a watch on its conditioning.

The dependent block ``D_dc`` of the constraint Jacobian must stay well conditioned for
``∂q̇_dc/∂q̇_ic = -D_dc⁻¹ D_ic`` to be accurate. Columns chosen by QR with column pivoting are the
best-conditioned choice at the configuration where it is made.
"""

from __future__ import annotations

import numpy as np

from ..errors import SimulationError
from . import gpme
from .gpme import choose_dependent

# Above this condition number of D_dc the partition is reported as ill-conditioned.
ILL_CONDITIONED = 1e8


def condition(D, dependent) -> float:
    """Condition number of the dependent block ``D[:, dependent]`` (inf when singular)."""
    if len(dependent) == 0:
        return 1.0
    block = np.asarray(D)[:, dependent]
    if block.shape == (1, 1) and np.isfinite(block[0, 0]):  # one constraint, looked at between every chunk
        return 1.0 if block[0, 0] != 0 else float("inf")   # of a run: its SVD's answer without one
    with np.errstate(all="ignore"):
        c = np.linalg.cond(block)
    return float(c) if np.isfinite(c) else float("inf")


def partition_at(model, q, t=0.0, qd=None):
    """``model`` with its dependent coordinates chosen from the constraint Jacobian at ``(q, qd)``
    (``qd`` default: at rest; the rows of second-order constraints may depend on it). Raises
    SimulationError naming the second-order constraints whose rows vanish there (no choice helps)."""
    qd = np.zeros(model.n_dof) if qd is None else qd
    _, _, D, _ = model.constraint_terms(t, q, qd)
    check_second_order_rows(model, D, t, qd)
    return model.with_partition(choose_dependent(D, gpme.rank(D) if model.redundant else None))


def check_second_order_rows(model, D, t, qd):
    """Raise SimulationError naming the second-order constraints whose rows of ``D`` (m, n) are
    zero at time ``t`` and velocities ``qd``: their acceleration terms carry the velocities (a path
    curvature), so no motion can hold them there, whatever the dependent coordinates."""
    second = np.asarray(model.constraint_orders) == 2
    if not np.any(second) or not np.all(np.isfinite(D)):
        return   # a D not finite: the run reports it at its first step
    size = max(float(np.max(np.abs(D))), 1.0)
    zero = [name for name, row, order2 in zip(model.constraint_names, D, second)
            if order2 and np.max(np.abs(row)) <= 1e-12 * size]
    if zero:
        state = "at rest" if not np.any(qd) else "with these velocities"
        raise SimulationError(
            f"model {model.module.MODEL}: at t = {t:.6g} s {state} the rows of D of the second-order constraints "
            f"{', '.join(map(repr, zero))} are zero, so no motion can be chosen to hold them; their acceleration "
            f"terms vanish with the velocities there: start in motion")


class Watch:
    """The partition's part of a run: watches the condition number of ``D_dc``, tells
    ``notify`` once when it passes :data:`ILL_CONDITIONED`, and with ``repartition`` goes on
    with the dependent coordinates chosen anew. ``model`` is the model the run goes on with
    (``model`` given at the start, or its repartitioned copy); each change is recorded in
    ``events`` as ``(t, old names, new names)``."""

    def __init__(self, model, repartition=False, notify=None, limit=ILL_CONDITIONED):
        self.model, self.repartition, self.limit = model, repartition, limit
        self.notify = notify or (lambda message: None)
        self.warned = False
        self.events: list = []

    def check(self, t, q, qd=None, D=None):
        """Looks at the partition of :attr:`model` at ``(t, q, qd)`` (``qd`` default: at rest;
        ``D``: its constraint Jacobian there where the caller has it); returns the model to go
        on with."""
        model = self.model
        if not len(model.constraint_names) or model.dependent is None:
            return model
        if D is None:
            _, _, D, _ = model.constraint_terms(t, q, np.zeros(model.n_dof) if qd is None else qd)
        c = condition(D, model.dependent)
        if c <= self.limit:
            return model
        names = tuple(model.coordinates[k] for k in model.dependent)
        if self.repartition:
            self.model = model.with_partition(choose_dependent(D, gpme.rank(D) if model.redundant else None))
            new = tuple(model.coordinates[k] for k in self.model.dependent)
            if new != names:
                self.events.append((float(t), names, new))
                self.notify(f"t = {t:.6g} s: D_dc of {', '.join(names)} has condition number {c:.2e}; "
                            f"dependent coordinates are now {', '.join(new)}")
        elif not self.warned:
            self.warned = True
            self.notify(f"warning: t = {t:.6g} s: the dependent block D_dc ({', '.join(names)}) has condition "
                        f"number {c:.2e}; the GPME lose accuracy near this configuration: rerun with "
                        f"--repartition or choose other dependent coordinates")
        return self.model
