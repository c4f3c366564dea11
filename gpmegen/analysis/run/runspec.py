"""One run's specification: how a run integrates, saves and starts, built once (by the command
line from its options, by :func:`gpmegen.simulate` from its keywords) and passed down through
:func:`gpmegen.analysis.run.runs.run`, :func:`gpmegen.analysis.run.study.simulate`, the levels of
:mod:`gpmegen.analysis.discretization.levels`, a sweep's runs and :mod:`gpmegen.limits`, which read its fields
and neither check nor default them again.

Its rules are checked once, in :class:`RunSpec` itself (:class:`gpmegen.errors.RunSpecError`,
one line naming the field and the fix), and its defaults are set there, the method-dependent
ones included: what a layer below receives is complete. What a run also needs but a spec does not
say (the model and its parameter values, the backend, where the results go) travels beside it.
"""

from __future__ import annotations

import math
import numbers
from collections.abc import Callable
from dataclasses import dataclass, field, fields
from typing import Any, cast

from ...errors import RunSpecError
from ...runtime import integrators
from ...runtime.integrators import registry
from ...runtime.integrators.loop import default_save_every, save_steps

#: The built-in integrators, as ``--method`` names them (:func:`gpmegen.runtime.integrators.names`
#: lists those registered now).
METHODS = integrators.names()
#: The starts a case may take (each case takes some: :attr:`gpmegen.analysis.run.cases.Case.starts`).
STARTS = ("locked", "constrained", "none")


def _number(name: str, value: object, accept: Callable[[float], bool], problem: str) -> float:
    """``value`` as a float when it is a real number for which ``accept`` holds, else one line."""
    if isinstance(value, bool) or not isinstance(value, numbers.Real):
        raise RunSpecError(f"{name} {value!r} is not a number; give it as a float")
    value = float(value)
    if not (accept(value) and math.isfinite(value)):
        raise RunSpecError(f"{name} {value:g} {problem}")
    return value


def _positive(name: str, value: object) -> float:
    return _number(name, value, lambda v: v > 0, "must be a positive finite number")


@dataclass(frozen=True)
class RunSpec:
    """How one run integrates, saves and starts; immutable and complete once made.

    - ``t_end``: the end time, s (from t = 0; 0 runs no step); default 10.
    - ``dt``: the step of rk4 and genalpha, s; with ``save_every``, the save interval of every
      method; default 1e-5 (the paper's).
    - ``method``: the integrator, one of :func:`gpmegen.runtime.integrators.names`; default "rk4".
    - ``save_every``: the steps of ``dt`` between saved states (a count); default those in 1 ms
      (:func:`gpmegen.runtime.integrators.loop.default_save_every`); for rk4 with ``save_dt``, the steps
      in ``save_dt``.
    - ``save_dt``: the save interval, s, or None: ``dt`` x ``save_every`` (:attr:`save_interval`);
      for rk4 a whole number of steps.
    - ``rtol``, ``atol``: the adaptive methods' tolerances, relative and absolute (in the units
      of q and q̇: rad, m, rad/s, m/s); default :data:`gpmegen.runtime.integrators.base.RTOL`, ``ATOL``.
    - ``rho_inf``: genalpha's numerical damping, its spectral radius at large steps, from 0 to 1
      (dimensionless); default :data:`gpmegen.runtime.integrators.genalpha.RHO_INF`.
    - the integrators' options (:func:`integrator_options`) are checked and defaulted by the
      integrators' own rules, whatever the method.
    - ``start``: the start, one of :data:`STARTS` ("locked" or "constrained" statics, or "none":
      the configuration as given), or None: the case's own (its first in ``case.starts``; the
      case refuses a start it does not take).
    - ``repartition``: choose the dependent coordinates anew when their block of D becomes
      ill-conditioned.
    - ``actuated``: the coordinates whose inputs realize the constraints, one per constraint
      (names, a tuple); None: the case's own (a model file's ``actuators``); ``()``: ideally.
    - ``internal_dynamics``: with an actuated realization, its internal dynamics' eigenvalues
      saved at every saved sample.
    - ``max_violation``: the largest constraint violation |Φ| a run goes on with (rad or m), or
      None: no bound; default 1e-2.

    Equal specs are the same run: a default and the same value given compare equal. Make one
    from keywords with :meth:`of`, which refuses a name that is no field in one line.
    """

    t_end: float = 10.0
    dt: float = 1e-5
    method: str = "rk4"
    save_every: int | None = None
    save_dt: float | None = None
    rtol: float | None = None
    atol: float | None = None
    rho_inf: float | None = None
    start: str | None = None
    repartition: bool = False
    actuated: tuple[str, ...] | None = None
    internal_dynamics: bool = False
    max_violation: float | None = 1e-2
    #: the fields set from a default here, not given (made anew from the others by :meth:`of`)
    defaulted: frozenset[str] = field(default=frozenset(), init=False, compare=False, repr=False)

    def __post_init__(self) -> None:
        value: dict[str, object] = {}
        integrators.get(self.method)  # an unknown method refused in one line
        value["t_end"] = _number("t_end", self.t_end, lambda v: v >= 0,
                                 "is below zero or not finite; give the end time in seconds")
        value["dt"] = dt = _positive("dt", self.dt)
        if self.save_dt is not None:
            value["save_dt"] = _positive("save_dt", self.save_dt)
        options = integrator_options()
        for option in options:
            if getattr(self, option.name) is not None:
                value[option.name] = _number(option.name, getattr(self, option.name), option.accept, option.problem)
        if self.max_violation is not None:
            value["max_violation"] = _positive("max_violation", self.max_violation)
        if self.save_every is not None:
            if isinstance(self.save_every, bool) or not isinstance(self.save_every, numbers.Integral) \
                    or self.save_every < 1:
                raise RunSpecError(f"save_every {self.save_every!r}: give a count of 1 or more")
            value["save_every"] = int(self.save_every)
        if self.start is not None and not isinstance(self.start, str):
            raise RunSpecError(f"start {self.start!r}: give one of {', '.join(STARTS)}, or None for the case's own")
        for name in ("repartition", "internal_dynamics"):
            if not isinstance(getattr(self, name), bool):
                raise RunSpecError(f"{name} {getattr(self, name)!r}: give True or False")
        if self.actuated is not None:
            names = (self.actuated,) if isinstance(self.actuated, str) else tuple(self.actuated)
            if not all(isinstance(name, str) and name for name in names):
                raise RunSpecError(f"actuated {self.actuated!r}: give coordinate names, () for an ideal "
                                   f"realization or None for the case's own")
            value["actuated"] = names
        defaulted = set()
        save_dt = cast(float | None, value.get("save_dt"))
        if integrators.get(self.method).saves_on_steps and save_dt is not None:
            value["save_every"] = save_steps(dt, save_dt)
            if value["save_every"] is None:
                raise RunSpecError(f"--save-dt {save_dt:g} s is not a whole number of RK4 steps --dt {dt:g} s; make "
                                   f"it a multiple of --dt, or use --save-every")
            defaulted.add("save_every")
        elif self.save_every is None:
            value["save_every"] = default_save_every(dt)
            defaulted.add("save_every")
        for option in options:
            if getattr(self, option.name) is None:
                value[option.name] = option.default
                defaulted.add(option.name)
        value["defaulted"] = frozenset(defaulted)
        for name, v in value.items():
            object.__setattr__(self, name, v)

    @property
    def save_interval(self) -> float:
        """The time between saved states, s: ``save_dt``, or ``dt`` x ``save_every``."""
        # save_every is a count once made (__post_init__ sets it)
        return self.dt * cast(int, self.save_every) if self.save_dt is None else self.save_dt

    @property
    def adaptive(self) -> bool:
        """Whether the method chooses its own steps (and takes ``rtol``, ``atol``)."""
        return not integrators.get(self.method).fixed_step

    def given(self) -> dict[str, Any]:
        """The fields as given (those set from a default here left out)."""
        return {name: getattr(self, name) for name in NAMES if name not in self.defaulted}

    @classmethod
    def of(cls, spec: RunSpec | None = None, **options: Any) -> RunSpec:
        """A spec from keyword ``options`` (the fields' names), or ``spec`` with the fields
        ``options`` give changed (the defaults made anew from the result: ``save_every`` from a
        new ``dt``). A name that is no field is refused in one line with the valid ones."""
        unknown = [name for name in options if name not in NAMES]
        if unknown:
            raise TypeError(f"unknown run option {', '.join(map(repr, unknown))}; the options of a run are "
                            f"{', '.join(NAMES)}")
        return cls(**{**(spec.given() if spec is not None else {}), **options})

    def with_start(self, start: str) -> RunSpec:
        """The same run from ``start``."""
        return RunSpec.of(self, start=start)


#: The fields of a :class:`RunSpec`, in order.
NAMES = tuple(f.name for f in fields(RunSpec) if f.name != "defaulted")


def integrator_options() -> list:
    """The registered integrators' options (:class:`gpmegen.runtime.integrators.Option`), each a
    field of :class:`RunSpec`, in the fields' order."""
    return sorted(registry.options(), key=lambda option: NAMES.index(option.name))


def split_options(spec: RunSpec | None, options: dict[str, Any], others: dict[str, Any],
                  refusal: Callable[[str], str]) -> tuple[RunSpec, dict[str, Any]]:
    """A function's keyword ``options`` parted: the run's fields over ``spec`` (:meth:`RunSpec.of`)
    and its own ``others`` (name -> default) with those given over their defaults. A name that is
    neither is refused with ``refusal(names)`` (the unknown names quoted, comma-separated), the
    function's one line."""
    unknown = [name for name in options if name not in NAMES and name not in others]
    if unknown:
        raise TypeError(refusal(", ".join(map(repr, unknown))))
    run = RunSpec.of(spec, **{name: value for name, value in options.items() if name in NAMES})
    return run, {**others, **{name: value for name, value in options.items() if name in others}}
