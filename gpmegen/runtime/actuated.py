"""The actuated realization (servo-constraints, :func:`gpmegen.runtime.gpme.actuated`) on a
loaded model: its inputs and checks. Each evaluator solves it at one state and runs its RK4 loop
(``actuated_motion``, ``actuated_rk4``): the C one in the model's library
(``gpmegen/csrc/actuated.c``, :mod:`gpmegen.runtime.cactuated`), the NumPy one by
:func:`gpmegen.runtime.gpme.actuated` and :func:`gpmegen.runtime.integrators.rk4.rk4_steps`, the
check of the compiled loop.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike

from ..errors import ModelError, SimulationError
from . import gpme

if TYPE_CHECKING:
    from .evaluator import Array, Four


# Above this condition number of D M⁻¹ S the actuated coordinates are refused at the start.
UNCONTROLLABLE = 1e10


class Actuation:
    """The actuated realization's inputs and checks on a :class:`~gpmegen.runtime.model.LoadedModel` (a mixin
    of it)."""

    def actuation(self, t: float, q: ArrayLike, qd: ArrayLike) -> Four:
        """(q̈ (n,), u (m,), M, f) of the actuated realization on :attr:`actuators`: the inputs
        ``u`` (N·m on a rotation, N on a translation) that alone hold the programmed
        constraints (in C on the C backend). SimulationError (:meth:`uncontrollable`) where
        ``D M⁻¹ S`` is singular."""
        motion = self.evaluator.actuated_motion(t, q, qd, self)
        if motion is None:
            raise SimulationError(self.uncontrollable(t, self.constraint_terms(t, q, qd)[2]))
        return motion

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
