"""The consistent start of a loaded model: ``q`` moved onto the position constraints (Φ = 0),
``qd`` onto the constraint velocities (Φ̇ = 0, Ψ = 0), how far each moved (:class:`Start`), and
the model marked where the constraint rows are redundant at the start. Pure numerics on a loaded
model; the scenarios that choose the start are :mod:`gpmegen.analysis.run`'s."""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ..errors import ModelWarning, SimulationError
from . import gpme, partition, redundancy

# Above this move (rad or m, rad/s or m/s) of a coordinate, making the start consistent is
# reported as a warning: the start given was not one the programmed constraints allow.
MOVE_WARNING = 1e-6


def project_onto_constraints(model, q, t=0.0, tol=1e-12, max_iter=50, hint=None, closures=None):
    """Move the dependent coordinates so that the position constraints (order 0) hold,
    Φ(q, t) = 0 (Newton on their block of D; least squares when first-order constraints take
    some dependent coordinates). When it fails, the message names the model's constraints left
    violated, with their values at the closest configuration found, and ends with ``hint``
    (default: a generic one); a closure among them (``closures``: closure name -> its row names)
    is named with its residual, the norm of its rows."""
    q = np.array(q, dtype=float)
    dep = model.dependent
    rows = np.flatnonzero(np.asarray(model.constraint_orders) == 0)
    qd = np.zeros_like(q)
    closest = None
    for _ in range(max_iter):
        phi, _, D, _ = model.constraint_terms(t, q, qd)
        phi = np.where(np.asarray(model.constraint_orders) == 0, phi, 0.0)
        worst = np.max(np.abs(phi), initial=0.0)
        if worst <= tol:
            return q
        if closest is None or worst < np.max(np.abs(closest)):
            closest = phi
        try:
            block = D[np.ix_(rows, dep)]
            if block.shape[0] == block.shape[1]:
                q[dep] -= np.linalg.solve(block, phi[rows])
            else:
                q[dep] -= np.linalg.lstsq(block, phi[rows], rcond=None)[0]
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(q)):
            break
    violated = ", ".join(f"{name} = {value:.3e}" for name, value in zip(model.constraint_names, closest)
                         if abs(value) > tol)
    moved = ", ".join(model.coordinates[k] for k in dep)
    value_of = dict(zip(model.constraint_names, closest))
    open_loops = {name: float(np.linalg.norm([value_of[row] for row in rows]))
                  for name, rows in (closures or {}).items()
                  if any(abs(value_of[row]) > tol for row in rows)}
    if open_loops:
        loops = " and ".join(f"closure {name!r} (residual {value:.3e}, the norm of its rows)"
                             for name, value in open_loops.items())
        raise SimulationError(
            f"model {model.module.MODEL}: {loops} cannot be closed from the start configuration by moving {moved} "
            f"(at best {violated}); give [initial] q nearer to a configuration where the loop closes, or dimensions "
            f"that let it close (docs/model-file.md, 'Closures')", partial={"phi": closest})
    raise SimulationError(
        f"model {model.module.MODEL}: the programmed constraints cannot be met from the start configuration by "
        f"moving {moved}: at best {violated}; "
        + (hint or "is the prescribed position within the chain's reach with these parameter values and this "
                   "start ([initial] q)?"), partial={"phi": closest})


def velocity_residual(model, t, q, qd):
    """What the velocity ``qd`` (n,) leaves of the constraints at ``(t, q)``, (m,): Φ̇ of the
    position constraints, Ψ of the first-order ones. Both are affine in ``qd`` with slope D."""
    phi, phi_rate, D, _ = model.constraint_terms(t, q, qd)
    return np.where(np.asarray(model.constraint_orders) == 0, phi_rate, phi), D


def project_velocities(model, q, qd, t=0.0):
    """``qd`` (n,) with the dependent velocities solved from the constraints (Φ̇ = 0 for position
    constraints, Ψ = 0 for first-order ones) for the independent velocities given."""
    qd = np.array(qd, dtype=float)
    dep = model.dependent
    if not len(model.constraint_names):
        return qd
    for _ in range(2):  # affine in qd: one step solves it, the second removes round-off
        r, D = velocity_residual(model, t, q, qd)
        try:
            if len(dep) == D.shape[0]:
                qd[dep] -= np.linalg.solve(D[:, dep], r)
            else:   # redundant rows: the dependent coordinates of the independent ones
                qd[dep] -= np.linalg.lstsq(D[:, dep], r, rcond=None)[0]
        except np.linalg.LinAlgError:
            raise SimulationError(
                f"model {model.module.MODEL}: the dependent block D_dc of the constraint Jacobian is singular at the "
                f"start, so the dependent velocities cannot be solved; choose other dependent coordinates "
                f"(model 'dependent') or another start ([initial] q)") from None
    return qd


@dataclass
class Start:
    """A consistent start: the ``model`` (with its partition), ``q`` and ``qd`` (n,) on the
    programmed constraints at t = 0, and ``moved``: for "q" and "qd", the largest change that
    putting them there made (rad or m, rad/s or m/s) and the coordinate it was made on;
    ``overridden``: the same, over the values the user gave only (all of ``q``; of ``qd``, the
    velocities given: the others are the constraints' to solve, so changing them is no warning)."""

    model: object
    q: np.ndarray
    qd: np.ndarray
    moved: dict = field(default_factory=dict)
    overridden: dict = field(default_factory=dict)
    assembled: dict | None = None   # with closures: coordinate -> (before, after), for those moved

    def report(self) -> str:
        """One line: how far the start was moved onto the constraints (with closures: each
        coordinate the assembly of the loops moved, and by how much)."""
        line = "start moved onto the constraints by " + "; ".join(
            f"max|Δ{key}| = {value:.3e}" + (f" ({name})" if value else "") for key, (value, name) in self.moved.items())
        if self.assembled:
            line += "; the loops assembled by moving " + ", ".join(
                f"{name} from {before:.6g} to {after:.6g} ({after - before:+.3e})"
                for name, (before, after) in self.assembled.items())
        return line

    def warning(self) -> str | None:
        """One line when a value the user gave was changed by more than :data:`MOVE_WARNING`, else None
        (with closures, ``q`` is assembled from a rough guess: moving it is reported, not warned of)."""
        far = {key: (value, name) for key, (value, name) in self.overridden.items() if value > MOVE_WARNING
               and not (key == "q" and self.assembled is not None)}
        if not far:
            return None
        given = " and ".join(f"[initial] {key}" for key in far)
        changes = ", ".join(f"{key} of {name} by {value:.3e}" for key, (value, name) in far.items())
        return (f"warning: the start (as given, or after the statics) was off the programmed constraints: putting "
                f"it on them changed {changes}"
                + f"; give {given} that meet them, or constraint constants that the start meets (docs/model-file.md, "
                  f"'Starts')")

    def meta(self) -> dict:
        """The report as results metadata."""
        return {key: {"max_change": float(value), "coordinate": name} for key, (value, name) in self.moved.items()}


def largest_change(model, before, after, among=None):
    """(largest |after - before|, the coordinate it is on), over the coordinates named in
    ``among`` (default: all)."""
    change = np.abs(np.asarray(after) - np.asarray(before))
    if among is not None:
        change = np.where([name in among for name in model.coordinates], change, 0.0)
    if not change.size or not change.any():
        return 0.0, ""
    k = int(np.argmax(change))
    return float(change[k]), model.coordinates[k]


def consistent(model, q, qd, t=0.0, hint=None, given_qd=None, closures=None) -> Start:
    """``q`` moved onto Φ = 0, then ``qd`` onto the constraint velocities, with the report of
    how far each moved (see :class:`Start`). ``given_qd``: the coordinates whose velocity the
    user gave (default: all of them). ``closures`` (closure name -> its row names): the model
    closes loops, whose assembly from a rough ``q`` is reported coordinate by coordinate."""
    q_on = (project_onto_constraints(model, q, t, hint=hint, closures=closures) if len(model.constraint_names)
            else np.array(q, float))
    qd_on = project_velocities(model, q_on, qd, t)
    q_moved = largest_change(model, q, q_on)
    assembled = None if not closures else {
        name: (float(before), float(after)) for name, before, after in zip(model.coordinates, q, q_on)
        if abs(after - before) > 0.0}
    return Start(model, q_on, qd_on, {"q": q_moved, "qd": largest_change(model, qd, qd_on)},
                 {"q": q_moved, "qd": largest_change(model, qd, qd_on, given_qd)}, assembled)


def check_redundant(model, q, closures, t=0.0, warn=True):
    """``model`` as it solves at a start ``q`` where the constraint rows are redundant: the
    constraint Jacobian ``D`` has a rank below its number of rows
    (:func:`gpmegen.runtime.gpme.rank`, relative to D's scale), as where a loop is closed more often
    than its motion needs. Then (with ``warn``) one :class:`ModelWarning` line names the rows that take part in
    a combination that vanishes (each closure's by the closure; ``closures``: closure name -> its
    row names) and says that the reactions shown are the minimum-norm ones, and the model is
    returned marked (:meth:`gpmegen.runtime.model.LoadedModel.with_redundant_rows`), its dependent
    coordinates those it has when they are one per independent row and regular there, else chosen
    on the independent rows at ``q``. Rows that cannot hold together (a loop
    that cannot close) are refused where the start moves ``q`` onto them. Otherwise ``model``."""
    if not len(model.constraint_names) or len(model.actuators):
        return model
    _, _, D, _ = model.constraint_terms(t, q, np.zeros(model.n_dof))
    if not np.all(np.isfinite(D)) or not D.size:
        return model
    rank = gpme.rank(D)
    if rank == D.shape[0]:
        return model
    chosen = gpme.choose_dependent(D, rank)
    if model.dependent is not None and len(model.dependent) == rank:   # the model's own, where regular
        kept = D[gpme.independent_rows(D)]
        if partition.condition(kept, model.dependent) <= partition.ILL_CONDITIONED:
            chosen = model.dependent
    if not warn:
        return model.with_redundant_rows(chosen)
    import warnings

    warnings.warn(
        f"{redundancy.taking_part(model.constraint_names, D, rank, closures)} are redundant at the start (the "
        f"constraint Jacobian has rank {rank} for {D.shape[0]} rows): the accelerations come from the independent "
        f"rows; the reactions are not unique, and those shown are the minimum-norm ones", ModelWarning, stacklevel=2)
    return model.with_redundant_rows(chosen)
