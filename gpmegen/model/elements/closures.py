"""The loops closed between two points of the chain, ``[[closures]]``
(:class:`~gpmegen.model.chain.Closure`, ``Model.closures``): read here, checked by
:func:`gpmegen.model.law_checks.check_closures`; their rows are position constraints of
``Model.constraints`` (:meth:`~gpmegen.model.chain.Closure.constraints`), derived as every
constraint is (:mod:`gpmegen.symbolic.constraints`)."""

from __future__ import annotations

import difflib

from ...errors import ModelError
from ..chain import AXES, CLOSURE_TYPES, Closure, check_name, closure_rows
from ..requirements import evaluate
from .registry import ElementKind, register


@register
class Closures(ElementKind):
    table = "closures"
    keys = ("name", "points", "type", "axis", "alpha", "beta")
    required = ("name", "points")
    what = "closure"
    field = "closures"

    def read_all(self, reader, items) -> tuple:
        """The closures with all the rows of their type (the ones that vanish identically are
        dropped by :meth:`finish`); each name, and the names of the rows it writes, checked
        against every name of the file read before (the programmed constraints among them)."""
        reader.array(items, ("closures",), what="list of [[closures]] tables")
        taken = reader.taken_names([c.name for c in reader.constraints])
        closures = []
        for k, item in enumerate(items):
            path = ("closures", k)
            reader.entry(item, path, self)
            closure = _closure(reader, item, path)
            named = [(f"closure {closure.name!r}", closure.name)]
            named += [(f"the row {label!r} of closure {closure.name!r}", closure.row_name(label))
                      for label in closure.rows]
            for what, text in named:
                if text in taken:
                    reader.fail(path + ("name",), f"{what} is named {text!r}, and that name is already taken by a "
                                                  f"{taken[text]}; rename the closure")
                try:
                    check_name(text, "closure row")
                except ModelError as exc:
                    raise reader.error(path + ("name",), f"{exc}: shorten the closure's name") from None
                taken[text] = "closure" if text == closure.name else "closure row"
            closures.append(closure)
        return tuple(closures)

    def rows(self, entries) -> tuple:
        return tuple(row for closure in entries for row in closure.constraints())

    def finish(self, reader, model):
        """``model`` without its closures' rows that vanish identically
        (:meth:`gpmegen.model.file.constraint_reading.ConstraintReading.drop_vanishing`)."""
        return reader.drop_vanishing(model) if model.closures else model


def _closure(reader, item, path) -> Closure:
    """The closure of the entry ``item`` at ``path``: its type with its axis, two points of the
    chain, its Baumgarte gains of parameters."""
    name = reader.name(item["name"], path + ("name",), "closure")
    kind = item.get("type", "point")
    if kind not in CLOSURE_TYPES:
        close = difflib.get_close_matches(str(kind), CLOSURE_TYPES, 1)
        hint = f"did you mean {close[0]!r}? " if close else ""
        reader.fail(path + ("type",), f"closure {name!r}: unknown type {kind!r}; {hint}use "
                                      + ", ".join(f'"{t}"' for t in CLOSURE_TYPES))
    axis = item.get("axis")
    if kind == "point" and axis is not None:
        reader.fail(path + ("axis",), f"closure {name!r}: a point closure takes no axis; remove it, or use "
                                      f"type = \"revolute\" or \"prismatic\"")
    if kind != "point" and axis is None:
        reader.fail(path, f"closure {name!r}: a {kind} closure needs its axis; add axis = \"x\", \"y\" or "
                          f"\"z\" (of the frame of its first point)")
    if kind != "point":
        reader.choice(axis, path + ("axis",), AXES, "closure axis")
    points = reader.point_pair(item["points"], path + ("points",), f"closure {name!r}")
    gains = {}
    for key in ("alpha", "beta"):
        if key in item:
            gains[key] = reader.quantity(item[key], path + (key,), reader.params)
            value = evaluate(gains[key], reader.defaults)
            if value is not None and value < 0:
                reader.fail(path + (key,), f"closure {name!r}: negative {key} {value:g}; Baumgarte gains must "
                                           f"be zero or positive")
    return Closure(name, points, kind, axis, closure_rows(kind, axis), **gains)
