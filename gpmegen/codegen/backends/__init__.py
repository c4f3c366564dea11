"""The backends, one class each (:class:`Backend`), registered by name: NumPy and C, rendered into
a model's folder and opened by the runtime; CasADi and FMU, the exports.

Adding a backend is one class: a subclass of :class:`Backend` in a module of this folder (its
files, printer, templates, refusals), registered below (or by :func:`register` from outside the
package); see docs/architecture.md, "Where to add".
"""

from __future__ import annotations

from ...errors import ModelError
from .base import Backend
from .c import CBackend
from .casadi import CasadiBackend
from .fmu import FmuBackend
from .numpy import NumpyBackend

_REGISTRY: dict[str, Backend] = {}


def register(backend: Backend) -> Backend:
    """Make ``backend`` known by its name (a name taken is refused); returns it."""
    if not backend.name or backend.name in _REGISTRY:
        raise ValueError(f"a backend needs a name of its own; {backend.name!r} is empty or taken")
    _REGISTRY[backend.name] = backend
    return backend


def unregister(name: str) -> None:
    """Forget the backend ``name`` (a test's own backend, once it is done)."""
    _REGISTRY.pop(name, None)


def names() -> tuple[str, ...]:
    """The known backends' names, in the order they were registered."""
    return tuple(_REGISTRY)


def get(name: str) -> Backend:
    """The backend ``name``; ModelError in one line listing the known names otherwise."""
    try:
        return _REGISTRY[name]
    except KeyError:
        raise ModelError(f"unknown backend {name!r}; known backends: {', '.join(_REGISTRY)}") from None


def folder_files() -> frozenset[str]:
    """Every file a backend renders into a model's folder."""
    return frozenset(name for b in _REGISTRY.values() if b.folder for name in b.files)


for _backend in (NumpyBackend(), CBackend(), CasadiBackend(), FmuBackend()):
    register(_backend)

__all__ = ["Backend", "folder_files", "get", "names", "register", "unregister"]
