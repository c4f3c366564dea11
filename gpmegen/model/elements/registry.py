"""The registry of element kinds: each kind of element a model file may hold beside its chain is
one :class:`ElementKind` (its table, its keys, how an entry is read), registered here under its
table. The file reader takes the tables it accepts from here and reads each registered kind's
entries; the derivation takes what an element adds to the equations of motion from the
element itself (:class:`Element`), through expressions of the state as a model file names it,
so that the model layer never sees the derivation.

The built-in kinds (:mod:`.forces`, :mod:`.closures`, :mod:`.controllers`) keep their
:class:`~gpmegen.model.Model` fields and their own terms in the derivation; a kind registered
from outside holds its entries in ``Model.elements`` and adds its terms by :class:`Element`."""

from __future__ import annotations

import sympy as sp


class Element:
    """An element of a registered kind, held in ``Model.elements``: what it adds to the
    equations of motion, as expressions of parameters, ``t`` and the state as a model file
    names it (coordinates ``q``, velocities ``q_dot``). The derivation calls these and nothing
    else; a subclass overrides the ones it has."""

    def potential(self) -> sp.Expr:
        """Its potential energy (J), of parameters and coordinates: its gradient joins the
        springs' slot of ``f`` (subtracted), its Hessian the statics' stiffness, and itself the
        spring energy."""
        return sp.S.Zero

    def applied(self) -> dict:
        """Its generalized forces that are not potential (N or N·m), coordinate name -> law of
        ``t``, parameters and the state: they join the drives' ``Q``."""
        return {}


class ElementKind:
    """A kind of element of a model file: ``table`` its top-level array of tables
    (``[[table]]``), ``keys`` the keys an entry may hold and ``required`` those it must, ``what``
    its name in messages, ``field`` the :class:`~gpmegen.model.Model` field that holds its
    entries (a built-in kind's; None: ``Model.elements``). :meth:`read` reads one entry."""

    table: str = ""
    keys: tuple = ()
    required: tuple = ()
    what: str = ""
    field: str | None = None

    def read(self, reader, item, path):
        """The element of the table ``item`` at ``path`` (``(table, k)``), its keys already
        checked, read with ``reader`` (:class:`gpmegen.model.file.reader.Reader`: its
        ``quantity``, ``law``, ``string``, ``check_coordinate``, ``fail``, ...)."""
        raise NotImplementedError


_KINDS: dict[str, ElementKind] = {}

#: The top-level keys of a model file that are its own, not an element kind's table: no kind may
#: take one (its entries would be read as the file's).
FILE_KEYS = ("schema", "name", "description", "nrfe", "gravity", "dependent", "parameters", "chain", "drives",
             "constraints", "initial", "actuators", "urdf", "signals", "controller", "presentation")


def register(kind):
    """Register ``kind`` (an :class:`ElementKind` subclass or instance) under its table; returns
    it (a class decorator). A table taken by another kind, or a top-level key of the file, is
    refused."""
    instance = kind() if isinstance(kind, type) else kind
    if not instance.table or instance.table in _KINDS or instance.table in FILE_KEYS:
        raise ValueError(f"element kind {type(instance).__name__}: the table {instance.table!r} is empty, "
                         f"another kind's or a model file's own key; give the kind a table of its own")
    _KINDS[instance.table] = instance
    return kind


def unregister(table: str) -> None:
    """Remove the kind of ``table``."""
    del _KINDS[table]


def get(table: str) -> ElementKind:
    return _KINDS[table]


def kinds() -> tuple[ElementKind, ...]:
    """The kinds registered, built-in first, in the order they were registered."""
    return tuple(_KINDS.values())


def tables() -> tuple[str, ...]:
    """The top-level tables of the kinds registered."""
    return tuple(_KINDS)
