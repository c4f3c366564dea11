"""A loaded generated model with the public contract of gpmegen (see README).

A :class:`LoadedModel` is immutable: its parameter values and its partition of the coordinates
are fixed when it is made, and :meth:`~LoadedModel.with_params` and
:meth:`~LoadedModel.with_partition` return new models. What it evaluates it asks of an
:class:`Evaluator`: the generated functions over the NumPy module (:class:`NumpyEvaluator`) or
over the compiled C library (:class:`gpmegen.runtime.cmodel.CEvaluator`).
"""

from __future__ import annotations

import copy
from collections.abc import Callable, Iterable, Mapping, Sequence
from functools import cached_property
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any, cast

import numpy as np
from numpy.typing import ArrayLike

from ..errors import BuildError, ModelError, SimulationError
from ..model.requirements import first_violation
from . import finite, gpme, jacobians, signals
from .actuated import Actuation
from .batch import is_batch, rows, stacked, states
from .evaluator import (
    TRANSFORM_FUNCTIONS,
    Array,
    ConstraintTerms,
    Evaluator,
    Four,
    GpmeTerms,
    Indices,
    NumpyEvaluator,
    Three,
    call,
    frozen,
    vector,
)
from .loop_entries import CompiledLoops
from .partition import partition_at
from .signals import Table

if TYPE_CHECKING:
    from ..model.requirements import Requirement


#: What a model's fast call (:attr:`LoadedModel._accelerations_call`) is made from.
MADE_FROM = frozenset({"evaluator", "p", "dependent", "independent", "actuators"})


class LoadedModel(CompiledLoops, Actuation):
    """A generated model bound to parameter values.

    Shapes: ``q``, ``qd`` (n_dof,); time ``t`` in s; SI units throughout. :meth:`mass_matrix`,
    :meth:`forces`, :meth:`constraint_terms` and :meth:`accelerations` also take a batch of N
    states, ``q``, ``qd`` (N, n_dof) and ``t`` a scalar or (N,), and return their results with a
    leading axis N, bit for bit those of N single calls (one call into C on the C backend); so do
    :meth:`point_positions`, :meth:`end_effector`, :meth:`energies` and :meth:`drive_forces`
    (on the C backend one call per state from one view of each array). ``requirements``: the
    model's physical bounds (:func:`gpmegen.model.requirements.requirements`), checked whenever
    parameter values are bound.
    """

    def __init__(self, module: ModuleType, params: Mapping[str, float] | None = None, backend: str = "numpy",
                 folder: Path | None = None, requirements: Iterable[Requirement] = (),
                 evaluator: Evaluator | None = None) -> None:
        self.module = module
        self.evaluator: Evaluator = evaluator or NumpyEvaluator(module)
        self.requirements = tuple(requirements)
        self.backend = backend
        self.folder = folder
        self.coordinates: tuple = tuple(module.COORDINATES)
        self.n_dof: int = len(self.coordinates)
        self.parameter_names: tuple = tuple(module.PARAMETERS)
        self.points: tuple = tuple(module.POINTS)
        # folders generated before the transforms existed have neither constant: nothing was built
        self.bodies: tuple = tuple(getattr(module, "BODIES", ()))
        self.transforms_built: tuple = tuple(getattr(module, "TRANSFORMS", ()))
        self.constraint_names: tuple = tuple(module.CONSTRAINTS)
        # the force elements between points (a model without has no FORCES)
        self.force_names: tuple = tuple(getattr(module, "FORCES", ()))
        self.force_points: tuple = tuple(tuple(p) for p in getattr(module, "FORCE_POINTS", ()))
        # the coordinates of the drives with a limit (a model without has no LIMITED_DRIVES)
        self.limited_drives: tuple = tuple(getattr(module, "LIMITED_DRIVES", ()))
        # the controller states (a model without has no CONTROLLERS): the last entries of p
        self.controller_names: tuple = tuple(getattr(module, "CONTROLLERS", ()))
        self.constraint_orders = frozen(np.array(module.CONSTRAINT_ORDERS, dtype=int))
        self.dependent, self.independent = self._partition(module.DEPENDENT)
        self.actuators = frozen(np.arange(0))  # none: the constraints are realized ideally
        self.signal_names: tuple = tuple(getattr(module, "SIGNALS", ()))
        self.signal_tables: tuple = ()  # the tables of the signals, once bound (with_signals)
        # True: the constraint rows may be redundant (with_redundant_rows); a model file that closes
        # loops lists fewer dependent coordinates than rows when it knows some are
        self.redundant = self.dependent is not None and len(self.dependent) < len(self.constraint_names)
        # the loops the model closes, closure name -> its row names (with_closure_rows): a run
        # watches their rank and their redundant rows (gpmegen.runtime.redundancy)
        self.closure_rows: dict[str, tuple[str, ...]] = {}
        self._bind(dict(zip(self.parameter_names, module.DEFAULTS)), params or {}, check_all=True)

    def _bind(self, values: Mapping[str, float], overrides: Mapping[str, Any], check_all: bool = False) -> None:
        """Set the parameter values (defaults ``values`` changed by ``overrides``), checked: the
        requirements that involve an overridden parameter, or all with ``check_all``."""
        values = dict(values)
        for name, value in overrides.items():
            if name not in values:
                raise ModelError(
                    f"unknown parameter {name!r}; the model's parameters are {', '.join(self.parameter_names)}"
                )
            try:
                values[name] = float(value)
            except (TypeError, ValueError):
                raise ModelError(f"parameter {name!r} must be a number, got {value!r}") from None
            if not np.isfinite(values[name]):
                raise ModelError(f"parameter {name!r} must be finite, got {value!r}")
        problem = first_violation(self.requirements, values, None if check_all else overrides)
        if problem:
            raise ModelError(f"model {self.module.MODEL}: {problem}")
        self.params: dict[str, float] = values
        p = np.array([values[k] for k in self.parameter_names], dtype=float)
        if self.controller_names:   # p ends with the controller states, at the start until a run sets them
            z0 = self.evaluator.controller_initial(np.concatenate([p, np.zeros(len(self.controller_names))]))
            p = np.concatenate([p, z0])
        self.p = frozen(p)
        alpha, beta = call(self.module, "baumgarte_gains", self.p)
        self.alpha, self.beta = frozen(np.asarray(alpha, float)), frozen(np.asarray(beta, float))

    def _partition(self, dependent: Sequence[str] | None) -> tuple[Indices | None, Indices | None]:
        if not self.constraint_names:
            return frozen(np.arange(0)), frozen(np.arange(self.n_dof))
        if dependent is None:
            return None, None  # chosen from the constraint Jacobian at the start of a run
        dep = [self.coordinates.index(name) for name in dependent]
        ind = [k for k in range(self.n_dof) if k not in dep]
        return frozen(np.array(dep, dtype=int)), frozen(np.array(ind, dtype=int))

    def with_partition(self, dependent: Iterable[int]) -> LoadedModel:
        """The same model with the coordinates at indices ``dependent`` (one per constraint; with
        redundant rows, :meth:`with_redundant_rows`, one per independent row) as the dependent
        ones."""
        dep = sorted(int(k) for k in dependent)
        distinct = len(set(dep)) == len(dep) and all(0 <= k < self.n_dof for k in dep)
        count_ok = len(dep) <= len(self.constraint_names) if self.redundant else len(dep) == len(self.constraint_names)
        if not count_ok or not distinct:
            raise ModelError(
                f"need {len(self.constraint_names)} distinct dependent coordinate indices below {self.n_dof}, "
                f"got {dependent!r}"
            )
        other = copy.copy(self)
        other.dependent = frozen(np.array(dep, dtype=int))
        other.independent = frozen(np.array([k for k in range(self.n_dof) if k not in set(dep)], dtype=int))
        return other

    def with_redundant_rows(self, dependent: Iterable[int]) -> LoadedModel:
        """The same model for constraint rows that are redundant (``D`` of rank below its number
        of rows, the rows consistent): each solve keeps the independent rows at its state
        (:func:`gpmegen.runtime.gpme.independent_rows`), the multipliers are the minimum-norm
        ones, and ``dependent`` (indices, one per independent row) is the partition."""
        other = copy.copy(self)
        other.redundant = True
        other.__dict__.pop("_accelerations_call", None)
        return other.with_partition(dependent)

    def with_closure_rows(self, closures: Mapping[str, Iterable[str]] | None) -> LoadedModel:
        """The same model knowing the loops it closes (``closures``: closure name -> the names of
        its constraint rows), which a run's messages on its redundant rows name."""
        other = copy.copy(self)
        other.closure_rows = {name: tuple(rows) for name, rows in (closures or {}).items()}
        return other

    def with_actuators(self, names: Iterable[str]) -> LoadedModel:
        """The same model with the programmed constraints realized by inputs ``u`` on the named
        coordinates (one per constraint; see :func:`gpmegen.runtime.gpme.actuated`) instead of
        ideally; ``()`` returns to the ideal realization."""
        names = tuple(names)
        unknown = [name for name in names if name not in self.coordinates]
        if unknown:
            raise ModelError(f"unknown actuated coordinate {', '.join(map(repr, unknown))}; the model's coordinates "
                             f"are {', '.join(self.coordinates)}")
        m = len(self.constraint_names)
        if names and (len(names) != m or len(set(names)) != m):
            raise ModelError(f"model {self.module.MODEL} has {m} programmed constraint(s) "
                             f"({', '.join(self.constraint_names) or 'none'}): name as many distinct actuated "
                             f"coordinates, one input per constraint, got {', '.join(names)}")
        other = copy.copy(self)
        other.actuators = frozen(np.array([self.coordinates.index(name) for name in names], dtype=int))
        return other

    def with_signals(self, tables: Iterable[Table]) -> LoadedModel:
        """The same model with its table signals (:attr:`signal_names`) read from ``tables``
        (:class:`gpmegen.runtime.signals.Table`, one per signal in that order), which the generated
        functions then call. The tables are set in the loaded module and library themselves: for
        every model of this folder in the process, until other tables are bound."""
        tables = tuple(tables)
        names = tuple(t.name for t in tables)
        if names != self.signal_names:
            raise ModelError(f"model {self.module.MODEL} has the signals {', '.join(self.signal_names) or 'none'}; "
                             f"give one table for each, in that order (got {', '.join(names) or 'none'})")
        if tables:
            self.evaluator.set_signals(tables)
        other = copy.copy(self)
        other.signal_tables = tables
        return other

    def check_signal_span(self, t0: float, t_end: float) -> None:
        """Refuse, in one line, a run over ``[t0, t_end]`` that leaves a signal's table."""
        if self.signal_names and not self.signal_tables:
            raise SimulationError(f"model {self.module.MODEL}'s signals {', '.join(self.signal_names)} have no tables; "
                                  f"load it with gpmegen.load(model=...) or bind them with with_signals()")
        signals.check_span(self.signal_tables, t0, t_end)

    @property
    def controller_initial(self) -> Array:
        """The controller states at the start (n_z,), from the parameter values bound."""
        return self.p[len(self.parameter_names):]

    def at_controller_states(self, z: ArrayLike) -> LoadedModel:
        """The same model with the controller states (:attr:`controller_names`) at ``z`` (n_z,):
        what its drives and rates read; the integrators take one per stage. A model without
        controller states is itself (no copy on the paths every model takes)."""
        if not self.controller_names and np.size(z) == 0:
            return self
        other = copy.copy(self)
        other.p = frozen(np.concatenate([self.p[:len(self.parameter_names)], vector(z, len(self.controller_names),
                                                                                     "z")]))
        return other

    def controller_rates(self, t: float, q: ArrayLike, qd: ArrayLike) -> Array:
        """dz/dt (n_z,) of the controller states at the state ``(t, q, qd)`` and the states this
        model holds (:meth:`at_controller_states`)."""
        return self.evaluator.controller_rates(t, vector(q, self.n_dof, "q"), vector(qd, self.n_dof, "qd"), self.p)

    def with_params(self, **overrides: float) -> LoadedModel:
        """The same model (same generated code, compiled library and partition) with some
        parameter values changed; nothing is rebuilt or reloaded."""
        other = copy.copy(self)
        other._bind(self.params, overrides)
        return other

    def _state(self, t: ArrayLike, q: ArrayLike, qd: ArrayLike) -> tuple[bool, tuple[Any, Array, Array]]:
        """``(batch, (t, q, qd))``: one state or a batch of them, converted and checked (shapes,
        and :func:`gpmegen.runtime.finite.check`)."""
        batch = is_batch(q)
        state = states(t, q, qd, self.n_dof) if batch else (t, vector(q, self.n_dof, "q"),
                                                              vector(qd, self.n_dof, "qd"))
        finite.check(*state)
        return batch, state

    def index(self, coordinate: str) -> int:
        """Position of a coordinate in ``q``."""
        return self.coordinates.index(coordinate)

    # --- the generated functions, bound to the parameter values -----------------------------
    def mass_matrix(self, q: ArrayLike) -> Array:
        """M(q), (n, n), kg·m² / kg."""
        q = rows(q, self.n_dof, "q") if is_batch(q) else vector(q, self.n_dof, "q")
        finite.check(None, q)
        if q.ndim == 2:
            return self.evaluator.mass_matrix_batch(q, self.p)
        return self.evaluator.mass_matrix(q, self.p)

    def forces(self, t: ArrayLike, q: ArrayLike, qd: ArrayLike) -> Array:
        """f = Q(t, q, qd) + h(q, qd) - g(q) - C q - damping, (n,)."""
        batch, state = self._state(t, q, qd)
        if batch:
            return self.evaluator.forces_batch(*state, self.p)
        return self.evaluator.forces(*state, self.p)

    def static_residual(self, q: ArrayLike) -> Array:
        """g(q) + C q, (n,): zero at an equilibrium with no drive."""
        return self.evaluator.static_residual(q, self.p)

    def stiffness_jacobian(self, q: ArrayLike) -> Array:
        """K = ∂(g + C q)/∂q, (n, n)."""
        return self.evaluator.stiffness_jacobian(q, self.p)

    def drive_forces(self, t: ArrayLike, q: ArrayLike, qd: ArrayLike) -> Array:
        """Q(t, q, q̇), (n,): the drives' laws at the state, feedback included; a batch gives (N, n)."""
        if is_batch(q):
            times, qs, qds = states(t, q, qd, self.n_dof)
            return self.evaluator.drive_forces_batch(times, qs, qds, self.p)
        return self.evaluator.drive_forces(cast(float, t), q, qd, self.p)  # one state: one time

    def force_elements(self, t: float, q: ArrayLike, qd: ArrayLike) -> Array:
        """Each force element's length (m), rate (m/s) and force (N, positive pushing its two
        points apart) at the state, (n_forces, 3) in :attr:`force_names` order; (0, 3) for a
        model without force elements."""
        if not self.force_names:
            return np.zeros((0, 3))
        return np.asarray(self.evaluator.force_elements(t, q, qd, self.p), float).reshape(len(self.force_names), 3)

    def drive_limits(self, t: float, q: ArrayLike, qd: ArrayLike) -> Array:
        """Each limited drive's law before its clip (N·m or N) and its limit, (n_limited, 2) in
        :attr:`limited_drives` order; (0, 2) for a model without limited drives."""
        if not self.limited_drives:
            return np.zeros((0, 2))
        return np.asarray(self.evaluator.drive_limits(t, q, qd, self.p), float).reshape(len(self.limited_drives), 2)

    def check_forces_apart(self, q: ArrayLike) -> None:
        """Refuse, with one SimulationError line, a configuration ``q`` where a force element's two
        points meet (length 0: its line, and so its force, is undefined there)."""
        if not self.force_names:
            return
        position = dict(zip(self.points, self.point_positions(q)))
        for name, (a, b) in zip(self.force_names, self.force_points):
            length = float(np.linalg.norm(position[b] - position[a]))
            if not length > 0:
                raise SimulationError(f"force element {name!r} has length {length:g} at the start: its points {a!r} "
                                      f"and {b!r} meet, where its line and its force are undefined; start with them "
                                      f"apart")

    def point_positions(self, q: ArrayLike) -> Array:
        """Positions of the named points in {0}, (n_points, 3), m; a batch ``q`` (N, n) gives
        (N, n_points, 3)."""
        if is_batch(q):
            return self.evaluator.points_batch(rows(q, self.n_dof, "q"), self.p)
        return self.evaluator.points(q, self.p)

    def transforms(self, q: ArrayLike, kind: str = "T") -> Array:
        """The body transforms in BODIES order (:attr:`bodies`), built on request (``gpmegen build
        --transforms``): ``kind`` "T" (n_bodies, 4, 4), ``T = [R p; 0 1]`` from each body's frame
        to {0}, p in m; "T_i" (n_bodies, n, 4, 4), ``∂T/∂q_i``; "T_ij" (n_bodies, n, n, 4, 4),
        ``∂²T/∂q_i∂q_j``."""
        if kind not in TRANSFORM_FUNCTIONS:
            raise ValueError(f"unknown transform {kind!r}; choose among {', '.join(TRANSFORM_FUNCTIONS)}")
        if kind not in self.transforms_built:
            built = ", ".join(self.transforms_built) or "none"
            wanted = tuple(k for k in TRANSFORM_FUNCTIONS if k in self.transforms_built or k == kind)
            raise BuildError(f"model {self.module.MODEL} was generated without the transforms {kind} (built: {built}); "
                             f"build it with 'gpmegen build --transforms {','.join(wanted)}' (from Python: "
                             f"gpmegen.load(..., transforms={wanted!r}))")
        return self.evaluator.transforms(q, self.p, kind)

    def end_effector(self, q: ArrayLike) -> Array:
        """Position of the end-effector (the first named point) in {0}, (3,), m; a batch ``q``
        (N, n) gives (N, 3)."""
        if not self.points:
            raise ModelError("the model names no point, so it has no end-effector")
        return self.point_positions(q)[..., 0, :]

    def constraint_terms(self, t: ArrayLike, q: ArrayLike, qd: ArrayLike) -> ConstraintTerms:
        """(Φ, Φ̇, D, γ) of the programmed constraints: (m,), (m,), (m, n), (m,)."""
        batch, state = self._state(t, q, qd)
        if batch:
            return self.evaluator.constraint_terms_batch(*state, self.p)
        return self.evaluator.constraint_terms(*state, self.p)

    def constraint_values(self, t: float, q: ArrayLike, qd: ArrayLike) -> Array:
        """Each constraint's value as written, (m,): Φ, Ψ, and for a second-order constraint
        (which has no value at a state) ``D q̈ + γ`` with q̈ from the GPME, NaN where they have
        no solution."""
        phi, _, D, gamma = self.constraint_terms(t, q, qd)
        second = self.constraint_orders == 2
        if not np.any(second):
            return phi
        try:
            qdd = self.accelerations(t, q, qd)
        except SimulationError:   # a diverged or singular state of a run that failed
            qdd = np.full(self.n_dof, np.nan)
        return np.where(second, D @ qdd + gamma, phi)

    def energies(self, q: ArrayLike, qd: ArrayLike) -> Array:
        """(kinetic, gravity potential, spring) energy in J; a batch ``q``, ``qd`` (N, n) gives (N, 3)."""
        if is_batch(q):
            q = rows(q, self.n_dof, "q")
            return self.evaluator.energies_batch(q, rows(qd, self.n_dof, "qd", len(q)), self.p)
        return self.evaluator.energies(q, qd, self.p)

    def gpme_terms(self, t: float, q: ArrayLike, qd: ArrayLike) -> GpmeTerms:
        """(M, f, Φ, Φ̇, D, γ) in one pass over the kinematics."""
        return self.evaluator.gpme_terms(t, q, qd, self.p)

    def partitioned(self, t: float, q: ArrayLike) -> LoadedModel:
        """This model, or when its dependent coordinates are "auto" and not chosen yet, a copy
        with them chosen at ``(t, q)`` (pivoted QR of D there, :mod:`gpmegen.runtime.partition`)."""
        if self.dependent is not None:
            return self
        return partition_at(self, vector(q, self.n_dof, "q"), t)

    def motion(self, t: float, q: ArrayLike, qd: ArrayLike) -> Three:
        """(q̈, M, f): the GPME solution (or, with :attr:`actuators`, the actuated realization's)
        with the terms it was solved from. With "auto" dependent coordinates not chosen yet, they
        are chosen at this state (:meth:`partitioned`)."""
        if len(self.actuators):
            qdd, _, M, f = self.actuation(t, q, qd)
            return qdd, M, f
        model = self.partitioned(t, q)
        return model.evaluator.motion(t, q, qd, model)

    def accelerations(self, t: ArrayLike, q: ArrayLike, qd: ArrayLike) -> Array:
        """q̈ (n,) from the GPME with Baumgarte terms (eq. 16), or of the actuated realization; the
        partition as :meth:`motion`. A batch (``q``, ``qd`` (N, n), ``t`` scalar or (N,)) gives
        (N, n), in one call into C where the GPME alone is solved."""
        return self._accelerations_call(t, q, qd)

    @cached_property
    def _accelerations_call(self) -> Callable[..., Array]:
        """What :meth:`accelerations` calls: the backend's fast single-state call for this model
        where it has one (it hands every other call to :meth:`_checked_accelerations`), else that."""
        fast = None
        if not len(self.actuators) and self.dependent is not None:
            fast = self.evaluator.accelerations_call(self, self._checked_accelerations)
        return self._checked_accelerations if fast is None else fast

    def __setattr__(self, name: str, value: object) -> None:
        # The calls made for this model's values are made again when one of them is set: by
        # with_params, with_partition, with_actuators on their copy, or by hand.
        if name in MADE_FROM:
            self.__dict__.pop("_accelerations_call", None)
        object.__setattr__(self, name, value)

    def _checked_accelerations(self, t: Any, q: Any, qd: Any) -> Array:
        """:meth:`accelerations` with its inputs checked and converted in Python."""
        batch, (t, q, qd) = self._state(t, q, qd)
        if batch:
            if len(self.actuators) or self.dependent is None:  # per state: the realization or partition
                return stacked([self.accelerations(tk, qk, qdk) for tk, qk, qdk in zip(t, q, qd)])
            return self.evaluator.accelerations_batch(t, q, qd, self)
        if len(self.actuators):
            return self.actuation(t, q, qd)[0]
        model = self.partitioned(t, q)
        return model.evaluator.accelerations(t, q, qd, model)

    def residual_jacobians(self, t: float, q: ArrayLike, qd: ArrayLike, a: ArrayLike, lam: ArrayLike) -> Four:
        """(∂F/∂q, ∂F/∂q̇ (n, n), ∂C/∂q, ∂C/∂q̇ (m, n)) of the GPME residuals ``F = f - M a + Dᵀλ``
        and ``C = c - D a`` (``c`` the constraint rows' right sides) at given accelerations ``a``
        (n,) and multipliers ``lam`` (m,) (:mod:`gpmegen.runtime.jacobians`); built on request."""
        self._require_jacobians()
        return self.evaluator.residual_jacobians(t, q, qd, a, lam, self.p)

    @property
    def jacobians_built(self) -> bool:
        """Whether the model was generated with the derivatives of the GPME (``gpmegen build
        --jacobians``)."""
        return hasattr(self.module, "gpme_residual_jacobians")

    def _require_jacobians(self) -> None:
        if not self.jacobians_built:
            raise BuildError(f"model {self.module.MODEL} was generated without its Jacobians; build it with "
                             "'gpmegen build --jacobians' (from Python: gpmegen.load(..., jacobians=True))")

    def acceleration_jacobians(self, t: ArrayLike, q: ArrayLike, qd: ArrayLike) -> tuple[Array, Array]:
        """``(∂q̈/∂q, ∂q̈/∂q̇)``, each (n, n) (``[i, j] = ∂q̈_i/∂q_j``), of the GPME with Baumgarte
        terms or of the actuated realization (:mod:`gpmegen.runtime.jacobians`); the partition as
        :meth:`motion`. A batch (``q``, ``qd`` (N, n), ``t`` scalar or (N,)) gives two (N, n, n).
        Exact, from the derivatives generated on request (``gpmegen build --jacobians``)."""
        self._require_jacobians()
        if is_batch(q):
            times, qs, qds = states(t, q, qd, self.n_dof)
            return stacked([self.acceleration_jacobians(tk, qk, qdk) for tk, qk, qdk in zip(times, qs, qds)])
        time = cast(float, t)  # one state: one time
        if len(self.actuators):
            qdd, _, M, _ = self.actuation(time, q, qd)
            D = self.constraint_terms(time, q, qd)[2]
            derivatives = self.residual_jacobians(time, q, qd, qdd, np.zeros(len(D)))
            return jacobians.acceleration_jacobians(M, gpme.selection(self.n_dof, self.actuators), D, *derivatives)
        model = self.partitioned(time, q)
        return model.evaluator.acceleration_jacobians(time, q, qd, model)[1:]

    def multipliers(self, t: float, q: ArrayLike, qd: ArrayLike) -> Array:
        """λ (m,) of the ideal realization at ``(t, q, qd)`` (:func:`gpmegen.runtime.gpme.multipliers`)."""
        qdd, M, f = self.motion(t, q, qd)
        D = self.constraint_terms(t, q, qd)[2]
        return gpme.multipliers(M, f, qdd, D, self.redundant)

    def constraint_forces(self, t: float, q: ArrayLike, qd: ArrayLike) -> Array:
        """Generalized forces that realize the constraints, ``M q̈ - f`` (n,): ``Dᵀλ`` in the ideal
        realization, ``S u`` (the inputs on :attr:`actuators`) in the actuated one."""
        qdd, M, f = self.motion(t, q, qd)
        return M @ qdd - f

    def __repr__(self) -> str:
        return f"<gpmegen model {self.module.MODEL} ({self.backend}), n_dof={self.n_dof}>"
