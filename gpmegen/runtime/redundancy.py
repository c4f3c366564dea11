"""Redundant constraint rows along a run: their rank and their consistency, watched.

A loop closed more often than its motion needs (an over-constrained linkage) has constraint rows
whose gradients are combinations of the others': the constraint Jacobian ``D`` (m, n) has a rank
below m. Every solve keeps the rows independent at its state (:func:`gpme.independent_rows`,
the C solve's elimination stopped at the rank), so the rows left out are never held themselves:
the accelerations are right as long as they follow from the kept ones. Two things can change
that along a run, and :class:`RowWatch` says each in one line naming the closure and the time:

- the rank changes (the linkage passes into a configuration where it is over- or
  under-constrained otherwise than at the start);
- the rows left out drift from the kept ones: where ``D_J = C D_K`` (rows ``J`` left out,
  ``K`` kept), a motion changes ``Φ_J`` and ``C Φ_K`` alike to first order, so
  ``e = Φ_J - C Φ_K`` is what the kept rows cannot see and the run cannot correct; it stays at
  round-off on a linkage whose rows are redundant by its geometry, and grows where they are not
  (dimensions that close only nearly).
"""

from __future__ import annotations

import warnings

import numpy as np

from ..errors import ModelWarning
from . import gpme

#: Largest ``|Φ_J - C Φ_K|`` of the rows left out (in the units of the rows: m for a coincidence
#: or slide row, 1 for an orientation row) that a run takes for rows that follow from the kept
#: ones: far above the round-off of a linkage redundant by its geometry (1e-15 to 1e-12), far
#: below the violation that stops a run (1e-2 by default); the start's moves are warned of at
#: the same 1e-6.
DRIFT = 1e-6


def taking_part(names, D, rank, closures) -> str:
    """The rows of ``D`` (m, n) of rank ``rank`` that take part in a combination whose gradients
    cancel (the left null space of D), named by closure (``closures``: closure name -> its row
    names, ``names``: the m row names), the others as constraints: ``"closure 'C': its rows C_y,
    C_z"``, parts joined by "and"."""
    U = np.linalg.svd(np.asarray(D, dtype=float))[0]
    taking = np.linalg.norm(U[:, rank:], axis=1) > 1e-6
    names = list(names)
    parts, named = [], set()
    for name, rows in (closures or {}).items():
        involved = [row for row in rows if row in names and taking[names.index(row)]]
        named.update(rows)
        if involved:
            parts.append(f"closure {name!r}: its rows {', '.join(involved)}")
    others = [row for row, takes in zip(names, taking) if takes and row not in named]
    if others:
        parts.append(f"the constraints {', '.join(others)}")
    return " and ".join(parts)


def drift(phi, D, orders) -> tuple[np.ndarray, np.ndarray]:
    """``(J, e)``: the position rows ``J`` of ``D`` (m, n) that the solve leaves out (not among
    :func:`gpme.independent_rows`) and ``e = Φ_J - C Φ_K`` (len(J),), what their values ``phi``
    hold beyond the combination ``C`` of the kept rows ``K`` that gives their gradients
    (``D_J = C D_K``, least squares); zero where the rows left out follow from the kept ones."""
    D, phi = np.asarray(D, dtype=float), np.asarray(phi, dtype=float)
    kept = gpme.independent_rows(D)
    out = np.setdiff1d(np.arange(D.shape[0]), kept)
    out = out[np.asarray(orders)[out] == 0]
    if not len(out):
        return out, np.zeros(0)
    C = np.linalg.lstsq(D[kept].T, D[out].T, rcond=None)[0].T
    return out, phi[out] - C @ phi[kept]


class RowWatch:
    """A run's look at the rank of a model's constraint rows and at its redundant rows, at the
    instants :func:`gpmegen.runtime.integrators.loop.chunked` checks the constraints (the chunks' ends,
    about every 0.05 s of simulated time, the same on both backends). For a model that closes
    loops (``model.closure_rows``) or whose rows are redundant at the start (``model.redundant``):
    one :class:`ModelWarning` line when the rank first differs from the start's ``D0``, one when
    the rows left out first drift from the kept ones by more than :data:`DRIFT`; each names the
    closure and the time. ``events`` records them as ``(t, kind, rank)``."""

    def __init__(self, model, D0):
        self.model = model
        self.active = bool(model.closure_rows) or bool(model.redundant)
        self.rank0 = gpme.rank(D0) if self.active else 0
        self.D0 = np.array(D0, dtype=float)
        self.said: set = set()
        self.events: list = []

    def check(self, t, phi, D) -> None:
        """Look at the rows at time ``t`` (s), their values ``phi`` (m,) and Jacobian ``D`` (m, n)."""
        if not self.active or not np.all(np.isfinite(D)) or not np.all(np.isfinite(phi)):
            return
        model = self.model
        m = D.shape[0]
        rank = gpme.rank(D)
        if rank != self.rank0 and "rank" not in self.said:
            self.said.add("rank")
            self.events.append((float(t), "rank", rank))
            if rank < self.rank0:
                rows = taking_part(model.constraint_names, D, rank, model.closure_rows)
                how = (f"{rows} became redundant at t = {t:.6g} s (the constraint Jacobian has rank {rank} for {m} "
                       f"rows, {self.rank0} at the start): the accelerations come from the rows independent there; the "
                       f"reactions there are not unique, and those shown are the minimum-norm ones")
            else:
                rows = taking_part(model.constraint_names, self.D0, self.rank0, model.closure_rows)
                how = (f"{rows}, redundant at the start, are independent again at t = {t:.6g} s (the constraint "
                       f"Jacobian has rank {rank} for {m} rows, {self.rank0} at the start): the accelerations come "
                       f"from the rows independent there")
            warnings.warn(how, ModelWarning, stacklevel=2)
        if rank < m and "drift" not in self.said:
            out, e = drift(phi, D, model.constraint_orders)
            worst = float(np.max(np.abs(e), initial=0.0))
            if worst > DRIFT:
                self.said.add("drift")
                self.events.append((float(t), "drift", rank))
                names = [model.constraint_names[k] for k in out[np.abs(e) > DRIFT]]
                closure = next((name for name, rows in model.closure_rows.items() if set(names) & set(rows)), None)
                whose = f"closure {closure!r}: its redundant rows" if closure else "the redundant constraints"
                warnings.warn(
                    f"{whose} {', '.join(names)} drift from the rows kept at t = {t:.6g} s: they differ from the "
                    f"combination of the kept rows by {worst:.3e} (above {DRIFT:.0e}), which the solve, taking the "
                    f"kept rows only, cannot correct; the loop's dimensions close only nearly: make them close "
                    f"exactly, or the rows independent", ModelWarning, stacklevel=2)
