"""The first-order controller states the drives may read, ``[[controllers]]``
(:class:`~gpmegen.model.chain.Controller`, ``Model.controllers``): read here (before the drives,
which read their states), checked by :func:`gpmegen.model.law_checks.check_controllers`, their
rates derived by :func:`gpmegen.symbolic.derive` (``Derivation.controller_rates``)."""

from __future__ import annotations

from ..chain import Controller, symbol
from ..law_checks import RATE_OF_ACCELERATIONS
from .registry import ElementKind, register


@register
class Controllers(ElementKind):
    table = "controllers"
    keys = ("state", "rate", "initial")
    required = ("state", "rate")
    what = "controller"
    field = "controllers"

    def read_all(self, reader, items) -> tuple:
        """Each state a name of its own among the file's names, its ``rate`` a law of t,
        parameters, positions and velocities, signals and the controller states (any of them:
        every state is named before the rates are read), ``initial`` of parameters. The states
        are left in ``reader.controller_states`` for the drives."""
        reader.array(items, ("controllers",), what="list of [[controllers]] tables")
        taken = {**reader.taken_names(), **reader.expression_names(),
                 **{name: "a signal" for name in reader.signal_scope()}}
        states: dict[str, tuple] = {}
        for k, item in enumerate(items):
            path = ("controllers", k)
            reader.entry(item, path, self)
            name = reader.name(item["state"], path + ("state",), "controller state", bare=True)
            reader.fresh_name(name, path + ("state",), "controller state", taken, states)
        reader.controller_states = {name: symbol(name) for name in states}
        scope = {**reader.constraint_scope(1), **reader.signal_scope(), **reader.controller_states}
        controllers = []
        for k, item in enumerate(items):
            path = ("controllers", k)
            rate = reader.law(item["rate"], path + ("rate",), "a controller state's rate", scope,
                              RATE_OF_ACCELERATIONS)
            initial = reader.quantity(item.get("initial", 0), path + ("initial",), reader.params)
            controllers.append(Controller(item["state"], rate, initial))
        return tuple(controllers)
