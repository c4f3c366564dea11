"""The actuated realization (servo-constraints, :func:`gpmegen.runtime.gpme.actuated`) on either
backend: its solve at one state and its RK4 loop, and on the C backend its DOP853 loop. On the C
backend they run in the model's library (``gpmegen/csrc/actuated.c``: the ``(n + m)``-row system
by dense LU in every stage); on the NumPy backend the solve is :func:`gpmegen.runtime.gpme.actuated` and the loop
:func:`gpmegen.runtime.integrators.rk4.rk4_steps`, the check of the compiled one.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ModelError, SimulationError
from ..status import SolveStatus
from . import gpme
from .integrators.loop import Grid, state_derivative
from .integrators.rk4 import rk4_steps

if TYPE_CHECKING:
    from .evaluator import Array, Four


def actuation(model, t: float, q, qd) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(q̈ (n,), u (m,), M (n, n), f (n,)) of ``model``'s actuated realization on its
    ``actuators`` at ``(t, q, qd)``: the inputs ``u`` (N·m on a rotation, N on a translation)
    that alone hold the programmed constraints. SimulationError (the model's
    :meth:`~gpmegen.runtime.model.LoadedModel.uncontrollable` line) where ``D M⁻¹ S`` is singular."""
    if model.backend == "c":
        return _compiled_actuation(model, t, q, qd)
    M, f, phi, phid, D, gamma = model.gpme_terms(t, q, qd)
    try:
        qdd, u = gpme.actuated(M, f, phi, phid, D, gamma, model.alpha, model.beta, model.constraint_orders,
                               model.actuators)
    except np.linalg.LinAlgError:
        raise SimulationError(model.uncontrollable(t, D)) from None
    return qdd, u, M, f


def _compiled_actuation(model, t, q, qd):
    evaluator = model.evaluator
    evaluator._check_stack("actuated")
    n, m = model.n_dof, len(model.constraint_names)
    scratch, q_c, qd_c = evaluator._state(q, qd)
    qdd, u, M, f = np.empty(n), np.empty(max(m, 1)), np.empty((n, n)), np.empty(n)
    ptr = evaluator._ptr
    status = evaluator.lib.actuated_motion(float(t), q_c, qd_c, evaluator._params(model.p), _indices(model),
                                           ptr(qdd), ptr(u), ptr(M), ptr(f))
    if status == SolveStatus.SINGULAR:
        raise SimulationError(model.uncontrollable(t, model.constraint_terms(t, q, qd)[2]))
    if status:
        raise evaluator._failure(status, t)
    return qdd, u[:m], M, f


def _indices(model):
    """The model's actuated coordinates as C ints (one at least: C has no empty arrays)."""
    return model.evaluator.ffi.from_buffer("int[]", np.array(list(model.actuators) or [0], dtype=np.intc))


def rk4(model, g: Grid, k_from: int, k_to: int, save_every: int, y0: np.ndarray):
    """Steps ``k_from + 1 … k_to`` of classical RK4 on grid ``g`` of ``model``'s actuated
    realization from the augmented state ``y0`` (``[q, q̇, w, z]``, the second work that of the
    inputs), in the compiled loop on the C backend and in Python on the NumPy one. Returns
    ``(t, y, status)`` as :func:`gpmegen.runtime.integrators.rk4.rk4_steps`."""
    if model.backend != "c":
        return rk4_steps(state_derivative(model), y0, g, k_from, k_to, save_every)
    evaluator = model.evaluator
    evaluator._check_stack("actuated_rk4")
    n = model.n_dof
    q0, qd0, w0 = (np.ascontiguousarray(part) for part in (y0[:n], y0[n:2 * n], y0[2 * n:]))
    n_save = k_to // save_every - k_from // save_every + 2
    t_out, y_out = np.empty(n_save), [np.empty((n_save, n)), np.empty((n_save, n)), np.empty((n_save, len(w0)))]
    n_saved = evaluator.ffi.new("long *")
    ptr = evaluator._ptr
    status = evaluator.lib.rk4_actuated(g.t0, g.dt, g.n_steps, g.t_end, k_from, k_to, save_every, ptr(q0), ptr(qd0),
                                        ptr(w0), evaluator._params(model.p), _indices(model), ptr(t_out),
                                        *(ptr(part) for part in y_out), n_saved)
    k = int(n_saved[0])
    return t_out[:k].copy(), np.column_stack([part[:k] for part in y_out]), SolveStatus(status)


def dop853(model, t_a, y_a, t_save, rtol, atol, step, counts, memory, max_steps, first):
    """:meth:`~gpmegen.runtime.model.LoadedModel.dop853` of ``model``'s actuated realization, in
    the compiled loop (the C backend's; its arguments and results)."""
    evaluator = model.evaluator
    evaluator._check_stack("actuated_dop853")

    def entry(*arguments):   # the ideal entry's arguments, the actuators in place of the partition's two
        return evaluator.lib.dop853_actuated(*arguments[:10], _indices(model), *arguments[12:])

    return evaluator._adaptive(entry, model, t_a, y_a, t_save, rtol, atol, step, counts, memory, max_steps, first,
                               partitioned=False)


# Above this condition number of D M⁻¹ S the actuated coordinates are refused at the start.
UNCONTROLLABLE = 1e10


class Actuation:
    """The actuated realization's inputs and checks on a :class:`~gpmegen.runtime.model.LoadedModel` (a mixin
    of it)."""

    def actuation(self, t: float, q: ArrayLike, qd: ArrayLike) -> Four:
        """(q̈ (n,), u (m,), M, f) of the actuated realization on :attr:`actuators`: the inputs
        ``u`` (N·m on a rotation, N on a translation) that alone hold the programmed
        constraints (in C on the C backend, :mod:`gpmegen.runtime.actuated`). SimulationError where
        ``D M⁻¹ S`` is singular."""
        return actuation(self, t, q, qd)

    def uncontrollable(self, t: float, D: Array, condition: float = np.inf) -> str:
        """Why the actuated realization fails at ``t``: its inputs cannot move the constraints
        (``D`` (m, n) their Jacobian there; ``condition`` that of ``D M⁻¹ S``)."""
        names = ", ".join(self.coordinates[k] for k in self.actuators)
        moved = ", ".join(self.coordinates[k] for k in np.flatnonzero(np.any(D != 0, axis=0)))
        return (f"at t = {t:.6g} s the inputs on {names} cannot hold the constraints "
                f"{', '.join(self.constraint_names)} (D M⁻¹ S is singular, condition number {condition:.2e}); "
                f"actuate coordinates the constraints depend on ({moved}) with --actuated")

    def check_actuators(self, t: float, q: ArrayLike) -> None:
        """ModelError naming the actuated coordinates when their inputs cannot hold the
        constraints at ``(t, q)`` from rest: ``D M⁻¹ S`` singular (condition above
        :data:`UNCONTROLLABLE`), e.g. an input on a coordinate no constraint depends on."""
        if not len(self.actuators):
            return
        M, _, _, _, D, _ = self.gpme_terms(t, q, np.zeros(self.n_dof))
        with np.errstate(all="ignore"):
            c = np.linalg.cond(gpme.input_coupling(M, D, self.actuators))
        if not c <= UNCONTROLLABLE:
            raise ModelError(self.uncontrollable(t, D, c))
