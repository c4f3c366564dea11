"""Choice of dependent coordinates for the GPME, and a watch on its conditioning.

The dependent block ``D_dc`` of the constraint Jacobian must stay well conditioned for
``∂q̇_dc/∂q̇_ic = -D_dc⁻¹ D_ic`` to be accurate. Columns chosen by QR with column pivoting are the
best-conditioned choice at the configuration where it is made.
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

# Above this condition number of D_dc the partition is reported as ill-conditioned.
ILL_CONDITIONED = 1e8


def choose_dependent(D) -> np.ndarray:
    """Indices (sorted) of the dependent coordinates: the first ``m`` pivots of a QR
    factorization with column pivoting of ``D`` (m, n)."""
    D = np.asarray(D, dtype=float)
    m = D.shape[0]
    if m == 0:
        return np.arange(0)
    _, _, pivots = scipy.linalg.qr(D, mode="economic", pivoting=True)
    return np.sort(pivots[:m])


def condition(D, dependent) -> float:
    """Condition number of the dependent block ``D[:, dependent]`` (inf when singular)."""
    if len(dependent) == 0:
        return 1.0
    block = np.asarray(D)[:, dependent]
    with np.errstate(all="ignore"):
        c = np.linalg.cond(block)
    return float(c) if np.isfinite(c) else float("inf")


def partition_at(model, q, t=0.0):
    """``model`` with its dependent coordinates chosen from the constraint Jacobian at ``q``."""
    _, _, D, _ = model.constraint_terms(t, q, np.zeros(model.n_dof))
    return model.with_partition(choose_dependent(D))


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

    def check(self, t, q):
        """Looks at the partition of :attr:`model` at ``(t, q)``; returns the model to go on with."""
        model = self.model
        if not len(model.constraint_names) or model.dependent is None:
            return model
        _, _, D, _ = model.constraint_terms(t, q, np.zeros(model.n_dof))
        c = condition(D, model.dependent)
        if c <= self.limit:
            return model
        names = tuple(model.coordinates[k] for k in model.dependent)
        if self.repartition:
            self.model = model.with_partition(choose_dependent(D))
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
