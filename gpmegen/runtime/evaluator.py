"""What a loaded model evaluates, and on what: the :class:`Evaluator` protocol its backends follow,
the generated functions over the NumPy module (:class:`NumpyEvaluator`; the compiled library's is
:class:`gpmegen.runtime.cmodel.CEvaluator`), and the array types of their arguments and results."""

from __future__ import annotations

from collections.abc import Callable, Sequence
from types import ModuleType
from typing import TYPE_CHECKING, Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..errors import EvaluationError, SimulationError
from ..status import SolveStatus
from ..symbolic.names import SIGNAL_FUNCTION
from . import gpme, integrators, jacobians, signals
from .batch import stacked
from .integrators import loop
from .integrators.rk4 import rk4_steps
from .signals import Table

if TYPE_CHECKING:
    from .model import LoadedModel


#: A float array, its shape as each function's docstring says.
Array = NDArray[np.float64]


#: Indices into q (int).
Indices = NDArray[np.int_]


#: (Φ, Φ̇, D, γ) of the programmed constraints: (m,), (m,), (m, n), (m,).
ConstraintTerms = tuple[Array, Array, Array, Array]


#: (M, f, Φ, Φ̇, D, γ): the terms of the GPME.
GpmeTerms = tuple[Array, Array, Array, Array, Array, Array]


#: Three arrays: (q̈, M, f), or (q̈, ∂q̈/∂q, ∂q̈/∂q̇).
Three = tuple[Array, Array, Array]


#: Four arrays: (∂F/∂q, ∂F/∂q̇, ∂C/∂q, ∂C/∂q̇), or (q̈, u, M, f).
Four = tuple[Array, Array, Array, Array]


# What a failing generated function did, by the exception Python's math raised.
ARITHMETIC = {ZeroDivisionError: "divides by zero", OverflowError: "overflows a double",
              ValueError: "takes a root or logarithm of a negative number"}


def vector(x: ArrayLike | None, n: int, what: str) -> Array:
    """``x`` as a contiguous float array of shape (n,), else ValueError naming ``what``."""
    if x is None:  # NumPy would make it [nan], of shape (1,): a state of one coordinate
        raise ValueError(f"{what} is missing: give an array of shape ({n},), or (N, {n}) for N states")
    a = np.ascontiguousarray(x, dtype=float)
    if a.shape != (n,):
        raise ValueError(f"{what} must have shape ({n},), or (N, {n}) for N states, got {a.shape}")
    return a


def frozen(a: ArrayLike) -> np.ndarray:
    """``a`` as an array that cannot be written to (a model's arrays are shared by its copies)."""
    a = np.array(a)
    a.flags.writeable = False
    return a


def call(module: ModuleType, function: str, *args: Any) -> Any:
    """The generated ``function`` of the NumPy ``module`` at ``args``; an arithmetic failure in
    it (Python's math raises where C gives inf or nan) becomes one EvaluationError."""
    try:
        return getattr(module, function)(*args)
    except (ArithmeticError, ValueError) as exc:
        if isinstance(exc, ValueError) and "math domain error" not in str(exc):
            raise
        what = next((text for kind, text in ARITHMETIC.items() if isinstance(exc, kind)), "fails")
        raise EvaluationError(
            f"model {module.MODEL}: {function} {what} ({exc}) at these parameter values and this state; "
            f"check the parameters its expressions divide by or raise (--param), and the start "
            f"configuration") from None


#: The generated function of each body transform (:data:`gpmegen.symbolic.transforms.KINDS`).
TRANSFORM_FUNCTIONS = {"T": "transforms", "T_i": "transform_derivatives", "T_ij": "transform_second_derivatives"}


class Evaluator(Protocol):
    """The generated functions of one model on one backend. ``p`` (n_p,): the parameter values;
    ``model``: the :class:`LoadedModel` whose parameters, gains and partition the GPME use.
    Shapes and units as in :class:`LoadedModel`."""

    def mass_matrix(self, q: ArrayLike, p: np.ndarray) -> Array: ...
    def forces(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> Array: ...
    def static_residual(self, q: ArrayLike, p: np.ndarray) -> Array: ...
    def stiffness_jacobian(self, q: ArrayLike, p: np.ndarray) -> Array: ...
    def drive_forces(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> Array: ...
    def force_elements(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> Array: ...
    def drive_limits(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> Array: ...
    def controller_rates(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> Array: ...
    def controller_initial(self, p: np.ndarray) -> Array: ...
    def points(self, q: ArrayLike, p: np.ndarray) -> Array: ...
    def transforms(self, q: ArrayLike, p: np.ndarray, kind: str) -> Array: ...
    def constraint_terms(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> ConstraintTerms: ...
    def energies(self, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> Array: ...
    def gpme_terms(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> GpmeTerms: ...
    def set_signals(self, tables: Sequence[Table]) -> None: ...

    def motion(self, t: float, q: ArrayLike, qd: ArrayLike, model: LoadedModel) -> Three:
        """(q̈, M, f): the GPME solution with the terms it was solved from."""

    def accelerations(self, t: float, q: ArrayLike, qd: ArrayLike, model: LoadedModel) -> Array:
        """q̈ (n,) of the GPME."""

    def accelerations_call(self, model: LoadedModel,
                           checked: Callable[..., Array]) -> Callable[..., Array] | None:
        """A callable ``(t, q, qd) -> q̈`` of ``model`` cheaper than :meth:`accelerations` for one
        state, handing every call it does not take itself to ``checked``; or None."""

    def mass_matrix_batch(self, q: Array, p: np.ndarray) -> Array:
        """M at each of the N states q (N, n): (N, n, n), bit for bit as N calls."""

    def forces_batch(self, t: Array, q: Array, qd: Array, p: np.ndarray) -> Array:
        """f at each state (t (N,), q, qd (N, n)): (N, n), bit for bit as N calls."""

    def constraint_terms_batch(self, t: Array, q: Array, qd: Array, p: np.ndarray) -> ConstraintTerms:
        """(Φ, Φ̇, D, γ) at each state: (N, m), (N, m), (N, m, n), (N, m), bit for bit as N calls."""

    def accelerations_batch(self, t: Array, q: Array, qd: Array, model: LoadedModel) -> Array:
        """q̈ at each state: (N, n), bit for bit as N calls."""

    def points_batch(self, q: Array, p: np.ndarray) -> Array:
        """The named points at each of the N states q (N, n): (N, n_points, 3), bit for bit as N calls."""

    def energies_batch(self, q: Array, qd: Array, p: np.ndarray) -> Array:
        """The energies at each state: (N, 3), bit for bit as N calls."""

    def drive_forces_batch(self, t: Array, q: Array, qd: Array, p: np.ndarray) -> Array:
        """Q at each state: (N, n), bit for bit as N calls."""

    def residual_jacobians(self, t: float, q: ArrayLike, qd: ArrayLike, a: ArrayLike, lam: ArrayLike,
                           p: np.ndarray) -> Four:
        """(∂F/∂q, ∂F/∂q̇ (n, n), ∂C/∂q, ∂C/∂q̇ (m, n)) of the GPME residuals at accelerations
        ``a`` (n,) and multipliers ``lam`` (m,) (:mod:`gpmegen.runtime.jacobians`)."""

    def acceleration_jacobians(self, t: float, q: ArrayLike, qd: ArrayLike, model: LoadedModel) -> Three:
        """(q̈ (n,), ∂q̈/∂q, ∂q̈/∂q̇ (n, n)) of the GPME."""

    def rk4(self, model: LoadedModel, g: loop.Grid, k_from: int, k_to: int, save_every: int,
            y0: Array) -> tuple[Array, Array, SolveStatus]:
        """Steps ``k_from + 1 … k_to`` of RK4 on ``g`` from the augmented state ``y0``
        (``[q, q̇, W_drive, W_constraint]``): ``(t, y, status)`` as
        :func:`gpmegen.runtime.integrators.rk4.rk4_steps`."""

    def actuated_motion(self, t: float, q: ArrayLike, qd: ArrayLike, model: LoadedModel) -> Four | None:
        """(q̈ (n,), u (m,), M (n, n), f (n,)) of ``model``'s actuated realization on its
        ``actuators`` (:func:`gpmegen.runtime.gpme.actuated`); None where ``D M⁻¹ S`` is singular."""

    def actuated_rk4(self, model: LoadedModel, g: loop.Grid, k_from: int, k_to: int, save_every: int,
                     y0: Array) -> tuple[Array, Array, SolveStatus]:
        """:meth:`rk4` of ``model``'s actuated realization, ``y0`` ending with the inputs' work."""

    def dop853(self, model: LoadedModel, t_a: float, y_a: ArrayLike, t_save: Array, rtol: float, atol: float,
               step: Array, counts: NDArray[np.int64], memory: NDArray[np.uint8] | None = None, max_steps: int = 0,
               first: int = 0) -> tuple[Array, SolveStatus]:
        """See :meth:`LoadedModel.dop853` (compiled backends only)."""

    def radau(self, model: LoadedModel, t_a: float, y_a: ArrayLike, t_save: Array, rtol: float, atol: float,
              step: Array, counts: NDArray[np.int64], memory: NDArray[np.uint8] | None = None, max_steps: int = 0,
              first: int = 0) -> tuple[Array, SolveStatus]:
        """See :meth:`LoadedModel.radau` (compiled backends only)."""

    def genalpha(self, model: LoadedModel, g: loop.Grid, k_from: int, k_to: int, rho_inf: float, project: bool,
                 y: Array, memory: dict[str, np.ndarray], t_save: Array,
                 counts: NDArray[np.int64]) -> tuple[Array, SolveStatus]:
        """See :meth:`LoadedModel.genalpha` (compiled backends only)."""

    def loop_memory(self, method: str) -> NDArray[np.uint8]:
        """See :meth:`LoadedModel.loop_memory` (compiled backends only)."""


def redundant_acceleration_jacobians(evaluator: Evaluator, t: float, q: ArrayLike, qd: ArrayLike,
                                     model: LoadedModel) -> Three:
    """(q̈, ∂q̈/∂q, ∂q̈/∂q̇) of a model whose constraint rows are redundant (``model.redundant``),
    from ``evaluator``'s generated functions: the rows independent at the state, with their
    multipliers (unique there), the others' zero; near the state those rows hold the same
    motions as all of them."""
    qdd, M, f = evaluator.motion(t, q, qd, model)
    D = evaluator.constraint_terms(t, q, qd, model.p)[2]
    rows = gpme.independent_rows(D)
    lam = np.zeros(len(D))
    lam[rows] = gpme.multipliers(M, f, qdd, D[rows])
    F_q, F_qd, C_q, C_qd = evaluator.residual_jacobians(t, q, qd, qdd, lam, model.p)
    return qdd, *jacobians.acceleration_jacobians(M, D[rows].T, D[rows], F_q, F_qd, C_q[rows], C_qd[rows])


class NumpyEvaluator:
    """:class:`Evaluator` over a generated NumPy module; the GPME solved by :mod:`.gpme`."""

    def __init__(self, module: ModuleType) -> None:
        self.module = module
        self.n = len(module.COORDINATES)

    def _q(self, q: ArrayLike) -> Array:
        return vector(q, self.n, "q")

    def _qd(self, qd: ArrayLike) -> Array:
        return vector(qd, self.n, "qd")

    def mass_matrix(self, q: ArrayLike, p: np.ndarray) -> Array:
        return call(self.module, "mass_matrix", self._q(q), p)

    def forces(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> Array:
        return call(self.module, "forces", t, self._q(q), self._qd(qd), p)

    def static_residual(self, q: ArrayLike, p: np.ndarray) -> Array:
        return call(self.module, "static_residual", self._q(q), p)

    def stiffness_jacobian(self, q: ArrayLike, p: np.ndarray) -> Array:
        return call(self.module, "stiffness_jacobian", self._q(q), p)

    def drive_forces(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> Array:
        return call(self.module, "drive_forces", t, self._q(q), self._qd(qd), p)

    def force_elements(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> Array:
        return call(self.module, "force_elements", t, self._q(q), self._qd(qd), p)

    def drive_limits(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> Array:
        return call(self.module, "drive_limits", t, self._q(q), self._qd(qd), p)

    def controller_rates(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> Array:
        return np.asarray(call(self.module, "controller_rates", t, self._q(q), self._qd(qd), p), float)

    def controller_initial(self, p: np.ndarray) -> Array:
        return np.asarray(call(self.module, "controller_initial", p), float)

    def points(self, q: ArrayLike, p: np.ndarray) -> Array:
        return call(self.module, "points", self._q(q), p)

    def transforms(self, q: ArrayLike, p: np.ndarray, kind: str) -> Array:
        return call(self.module, TRANSFORM_FUNCTIONS[kind], self._q(q), p)

    def constraint_terms(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> ConstraintTerms:
        return call(self.module, "constraint_terms", t, self._q(q), self._qd(qd), p)

    def energies(self, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> Array:
        return call(self.module, "energies", self._q(q), self._qd(qd), p)

    def gpme_terms(self, t: float, q: ArrayLike, qd: ArrayLike, p: np.ndarray) -> GpmeTerms:
        return call(self.module, "gpme_terms", t, self._q(q), self._qd(qd), p)

    def motion(self, t: float, q: ArrayLike, qd: ArrayLike, model: LoadedModel) -> Three:
        M, f, phi, phid, D, gamma = self.gpme_terms(t, q, qd, model.p)
        qdd = gpme.accelerations(M, f, phi, phid, D, gamma, model.alpha, model.beta, model.constraint_orders,
                                 model.dependent, model.independent, model.redundant)
        return qdd, M, f

    def accelerations(self, t: float, q: ArrayLike, qd: ArrayLike, model: LoadedModel) -> Array:
        return self.motion(t, q, qd, model)[0]

    def accelerations_call(self, model: LoadedModel,
                           checked: Callable[..., Array]) -> Callable[..., Array] | None:
        return None  # a Python call costs little beside the NumPy evaluation

    # a loop over the states: the generated functions take one state (plain floats, like C)
    def mass_matrix_batch(self, q: Array, p: np.ndarray) -> Array:
        return stacked([self.mass_matrix(x, p) for x in q])

    def forces_batch(self, t: Array, q: Array, qd: Array, p: np.ndarray) -> Array:
        return stacked([self.forces(*state, p) for state in zip(t.tolist(), q, qd)])

    def constraint_terms_batch(self, t: Array, q: Array, qd: Array, p: np.ndarray) -> ConstraintTerms:
        return stacked([self.constraint_terms(*state, p) for state in zip(t.tolist(), q, qd)])

    def accelerations_batch(self, t: Array, q: Array, qd: Array, model: LoadedModel) -> Array:
        return stacked([self.accelerations(*state, model) for state in zip(t.tolist(), q, qd)])

    def points_batch(self, q: Array, p: np.ndarray) -> Array:
        return np.reshape(stacked([self.points(x, p) for x in q]), (len(q), len(self.module.POINTS), 3))

    def energies_batch(self, q: Array, qd: Array, p: np.ndarray) -> Array:
        return stacked([self.energies(x, xd, p) for x, xd in zip(q, qd)])

    def drive_forces_batch(self, t: Array, q: Array, qd: Array, p: np.ndarray) -> Array:
        return stacked([self.drive_forces(*state, p) for state in zip(t.tolist(), q, qd)])

    def residual_jacobians(self, t: float, q: ArrayLike, qd: ArrayLike, a: ArrayLike, lam: ArrayLike,
                           p: np.ndarray) -> Four:
        return call(self.module, "gpme_residual_jacobians", t, self._q(q), self._qd(qd), a, lam, p)

    def acceleration_jacobians(self, t: float, q: ArrayLike, qd: ArrayLike, model: LoadedModel) -> Three:
        if model.redundant:
            return redundant_acceleration_jacobians(self, t, q, qd, model)
        qdd, M, f = self.motion(t, q, qd, model)
        D = self.constraint_terms(t, q, qd, model.p)[2]
        lam = gpme.multipliers(M, f, qdd, D)
        return qdd, *jacobians.acceleration_jacobians(M, D.T, D, *self.residual_jacobians(t, q, qd, qdd, lam, model.p))

    def set_signals(self, tables: Sequence[Table]) -> None:
        """Set the module's signal function to the linear interpolation of ``tables``."""
        setattr(self.module, SIGNAL_FUNCTION, signals.numpy_function(tables))

    def rk4(self, model: LoadedModel, g: loop.Grid, k_from: int, k_to: int, save_every: int,
            y0: Array) -> tuple[Array, Array, SolveStatus]:
        return rk4_steps(loop.state_derivative(model), y0, g, k_from, k_to, save_every)

    def actuated_motion(self, t: float, q: ArrayLike, qd: ArrayLike, model: LoadedModel) -> Four | None:
        M, f, phi, phid, D, gamma = self.gpme_terms(t, q, qd, model.p)
        try:
            qdd, u = gpme.actuated(M, f, phi, phid, D, gamma, model.alpha, model.beta, model.constraint_orders,
                                   model.actuators)
        except np.linalg.LinAlgError:
            return None
        return qdd, u, M, f

    def actuated_rk4(self, model: LoadedModel, g: loop.Grid, k_from: int, k_to: int, save_every: int,
                     y0: Array) -> tuple[Array, Array, SolveStatus]:
        return rk4_steps(loop.state_derivative(model), y0, g, k_from, k_to, save_every)

    def dop853(self, model: LoadedModel, t_a: float, y_a: ArrayLike, t_save: Array, rtol: float, atol: float,
               step: Array, counts: NDArray[np.int64], memory: NDArray[np.uint8] | None = None, max_steps: int = 0,
               first: int = 0) -> tuple[Array, SolveStatus]:
        raise SimulationError(integrators.get("dop853").refusal("numpy", False))

    def radau(self, model: LoadedModel, t_a: float, y_a: ArrayLike, t_save: Array, rtol: float, atol: float,
              step: Array, counts: NDArray[np.int64], memory: NDArray[np.uint8] | None = None, max_steps: int = 0,
              first: int = 0) -> tuple[Array, SolveStatus]:
        raise SimulationError(integrators.get("radau").refusal("numpy", False))

    def genalpha(self, model: LoadedModel, g: loop.Grid, k_from: int, k_to: int, rho_inf: float, project: bool,
                 y: Array, memory: dict[str, np.ndarray], t_save: Array,
                 counts: NDArray[np.int64]) -> tuple[Array, SolveStatus]:
        raise SimulationError(integrators.get("genalpha").refusal("numpy", False))

    def loop_memory(self, method: str) -> NDArray[np.uint8]:
        raise SimulationError(integrators.get(method).refusal("numpy", False))
