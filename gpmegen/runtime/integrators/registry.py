"""The integrators by ``--method`` name, filled by their modules as they are imported (the
package imports the built-in ones), in that order: what the command line's choices, a run's
specification, the run estimates and the levels read."""

from __future__ import annotations

from ...errors import RunSpecError
from ...limits import ESTIMATORS

#: name -> the integrator (an :class:`gpmegen.runtime.integrators.base.Integrator`), in the order
#: registered.
INTEGRATORS: dict = {}


def register(cls):
    """Register ``cls`` (an Integrator subclass) under its ``name``, and its run estimate with
    :data:`gpmegen.limits.ESTIMATORS`; returns ``cls``, so that it decorates the class."""
    integrator = cls()
    INTEGRATORS[cls.name] = integrator
    ESTIMATORS[cls.name] = integrator
    return cls


def unregister(name: str) -> None:
    """Take the integrator ``name`` out again (a test's own)."""
    INTEGRATORS.pop(name, None)
    ESTIMATORS.pop(name, None)


def names() -> tuple[str, ...]:
    """The ``--method`` names, in the order registered."""
    return tuple(INTEGRATORS)


def get(name: str):
    """The integrator ``name``; :class:`gpmegen.errors.RunSpecError` in one line with the known
    names when there is none."""
    try:
        return INTEGRATORS[name]
    except (KeyError, TypeError):
        raise RunSpecError(f"{name!r} is not an integrator (choose from {', '.join(INTEGRATORS)})") from None


def spoken(names_: list[str]) -> str:
    """``a, b or c``."""
    return names_[0] if len(names_) == 1 else f"{', '.join(names_[:-1])} or {names_[-1]}"


def carrying_controller_states() -> str:
    """The integrators that integrate controller states, as a refusal names them (``a, b or c``)."""
    return spoken([name for name, i in INTEGRATORS.items() if i.controller_states])


def carrying_actuated() -> str:
    """The integrators whose loop runs the actuated realization, as a refusal names them."""
    return spoken([name for name, i in INTEGRATORS.items() if i.actuated_loop])


def options() -> list:
    """Every registered integrator's options, each once (the first of its name), in the order
    registered."""
    seen: dict = {}
    for integrator in INTEGRATORS.values():
        for option in integrator.options:
            seen.setdefault(option.name, option)
    return list(seen.values())
