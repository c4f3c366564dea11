"""The kinds of element a model file holds beside its chain, each in a top-level array of tables
(``[[forces]]``, ``[[closures]]``, ``[[controllers]]``, and any kind registered), in
:mod:`.registry`; one module per built-in kind."""

from . import closures, controllers, forces  # noqa: F401  (the built-in kinds, registered in this order)
from .registry import Element, ElementKind, check, get, kinds, register, tables, unregister

__all__ = ["Element", "ElementKind", "check", "get", "kinds", "register", "tables", "unregister"]
