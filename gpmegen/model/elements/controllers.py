"""The first-order controller states the drives may read, ``[[controllers]]``
(:class:`~gpmegen.model.chain.Controller`, ``Model.controllers``): read by
:meth:`gpmegen.model.file.element_reading.ElementReading.read_controllers`, their rates derived by
:func:`gpmegen.symbolic.derive` (``Derivation.controller_rates``)."""

from __future__ import annotations

from .registry import ElementKind, register


@register
class Controllers(ElementKind):
    table = "controllers"
    keys = ("state", "rate", "initial")
    required = ("state", "rate")
    what = "controller"
    field = "controllers"
