"""The registry of element kinds: each kind of element a model file may hold beside its chain is
one :class:`ElementKind` (its table, its keys, how its entries are read, the
:class:`~gpmegen.model.Model` field they fill), registered here under its table. The file reader
takes the tables it accepts from here and reads every kind's entries through the kind, in the
order the kinds were registered; the derivation takes what an element of ``Model.elements`` adds
to the equations of motion from the element itself (:class:`Element`), through expressions of the
state as a model file names it, so that the model layer never sees the derivation.

The built-in kinds (:mod:`.closures`, :mod:`.controllers`, :mod:`.forces`) fill fields of their
own and keep their own terms in the derivation; a kind registered from outside fills
``Model.elements`` (by default) and adds its terms by :class:`Element`."""

from __future__ import annotations

import dataclasses

import sympy as sp

from ...errors import ModelError
from ..chain import Model


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
    its name in messages, ``field`` the :class:`~gpmegen.model.Model` field its entries fill
    (:data:`FIELDS`; the kinds of one field fill it in the registry's order).

    The reader (:class:`gpmegen.model.file.reader.Reader`) calls :meth:`read_all` once per
    file with the table's array (``[]`` when the file has none), after the file's parameters,
    chain, signals and programmed constraints and before its drives; then the constraint rows of
    :meth:`rows` join ``Model.constraints`` and :meth:`finish` may amend the model read."""

    table: str = ""
    keys: tuple = ()
    required: tuple = ()
    what: str = ""
    field: str = "elements"

    def read(self, reader, item, path):
        """The element of the table ``item`` at ``path`` (``(table, k)``), its keys already
        checked, read with ``reader`` (:class:`gpmegen.model.file.reader.Reader`: its
        ``quantity``, ``law``, ``string``, ``check_coordinate``, ``fail``, ...)."""
        raise NotImplementedError

    def read_all(self, reader, items) -> tuple:
        """The elements of the array ``items``: each entry a table of the kind's keys, read by
        :meth:`read`. A kind that reads its entries together (names unique among them, names
        that all its entries may read) overrides this."""
        reader.array(items, (self.table,), what=f"list of [[{self.table}]] tables")
        elements = []
        for k, item in enumerate(items):
            reader.entry(item, (self.table, k), self)
            elements.append(self.read(reader, item, (self.table, k)))
        return tuple(elements)

    def rows(self, entries) -> tuple:
        """The position constraints (:class:`~gpmegen.model.chain.Constraint`) that ``entries``
        add to ``Model.constraints``, after the file's own (a closure's rows); none by default."""
        return ()

    def finish(self, reader, model: Model) -> Model:
        """``model``, read whole, as this kind leaves it (closures drop their rows that vanish
        identically); unchanged by default."""
        return model


_KINDS: dict[str, ElementKind] = {}

#: The top-level keys of a model file that are its own, not an element kind's table: no kind may
#: take one (its entries would be read as the file's).
FILE_KEYS = ("schema", "name", "description", "nrfe", "gravity", "dependent", "parameters", "chain", "drives",
             "constraints", "initial", "actuators", "urdf", "signals", "controller", "presentation")

#: The :class:`~gpmegen.model.Model` fields a kind may fill: the tuples of entries that none of the
#: file's own keys fills.
FIELDS = tuple(f.name for f in dataclasses.fields(Model) if f.default == () and f.name not in FILE_KEYS)


def register(kind):
    """Register ``kind`` (an :class:`ElementKind` subclass or instance) under its table; returns
    it (a class decorator). A table taken by another kind, or a top-level key of the file, and a
    field no kind may fill are refused."""
    instance = kind() if isinstance(kind, type) else kind
    if not instance.table or instance.table in _KINDS or instance.table in FILE_KEYS:
        raise ValueError(f"element kind {type(instance).__name__}: the table {instance.table!r} is empty, "
                         f"another kind's or a model file's own key; give the kind a table of its own")
    if instance.field not in FIELDS:
        raise ValueError(f"element kind {type(instance).__name__}: field {instance.field!r} is no Model field a kind "
                         f"fills; use one of {', '.join(FIELDS)} (a kind registered from outside: \"elements\")")
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


def check(model: Model) -> None:
    """Refuse an entry of ``model.elements`` that is no :class:`Element` (a ModelError about
    ``("elements", k)``), which the derivation could not ask for its terms."""
    if not isinstance(model.elements, (tuple, list)):
        raise ModelError(f"Model.elements is a {type(model.elements).__name__}, not a tuple; give the elements as a "
                         f"tuple, (element,) for one", ("elements",))
    for k, element in enumerate(model.elements):
        if not isinstance(element, Element):
            raise ModelError(f"Model.elements[{k}] is a {type(element).__name__}, not an element: its entries are "
                             f"instances of subclasses of gpmegen.model.elements.Element (a force element, closure "
                             f"or controller goes in Model.forces, closures or controllers)", ("elements", k))
