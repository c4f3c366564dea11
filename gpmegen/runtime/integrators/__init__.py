"""The integrators, one module each (rk4, genalpha, dop853, radau, scipy_radau), each defining one
:class:`~gpmegen.runtime.integrators.base.Integrator` that registers itself as it is imported; the
machinery they share is in :mod:`gpmegen.runtime.integrators.loop`. ``get(name)`` gives one by its
``--method`` name; ``names()`` lists them in the order registered, the command line's."""

from __future__ import annotations

# isort: off
# imported in the order of the command line's choices, which is the order they register in
from . import rk4, genalpha, dop853, radau, scipy_radau  # noqa: F401
# isort: on
from .base import Effort, Integrator, Option
from .registry import get, names, register, unregister

__all__ = ["Effort", "Integrator", "Option", "get", "names", "register", "unregister"]
