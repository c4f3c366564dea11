"""The loops closed between two points of the chain, ``[[closures]]``
(:class:`~gpmegen.model.chain.Closure`, ``Model.closures``): read by
:meth:`gpmegen.model.file.constraint_reading.ConstraintReading.read_closures`, checked by
:func:`gpmegen.model.law_checks.check_closures`; their rows are position constraints of
``Model.constraints`` (:meth:`~gpmegen.model.chain.Closure.constraints`), derived as every
constraint is (:mod:`gpmegen.symbolic.constraints`)."""

from __future__ import annotations

from .registry import ElementKind, register


@register
class Closures(ElementKind):
    table = "closures"
    keys = ("name", "points", "type", "axis", "alpha", "beta")
    required = ("name", "points")
    what = "closure"
    field = "closures"
