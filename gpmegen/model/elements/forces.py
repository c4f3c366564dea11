"""The force elements between two points of the chain, ``[[forces]]``
(:class:`~gpmegen.model.chain.ForceElement`, ``Model.forces``): read by
:meth:`gpmegen.model.file.element_reading.ElementReading.read_forces`, checked by
:func:`gpmegen.model.law_checks.check_forces`, derived by :mod:`gpmegen.symbolic.forces`."""

from __future__ import annotations

from .registry import ElementKind, register


@register
class Forces(ElementKind):
    table = "forces"
    keys = ("name", "points", "type", "stiffness", "rest_length", "damping", "force")
    required = ("name", "points", "type")
    what = "force"
    field = "forces"
