"""The checks of what acts on a model's chain, each refusal naming its field: signals,
controllers, drives and their laws, programmed constraints and the dependent coordinates,
closures and force elements (called by :func:`gpmegen.model.expand.expand`)."""

from __future__ import annotations

import difflib

import sympy as sp

from ..errors import ModelError
from .chain import (
    AXES,
    CLOSURE_TYPES,
    FORCE_TYPES,
    MAX_SIGNALS,
    TIME,
    Controller,
    Model,
    Point,
    Signal,
    acceleration_symbol,
    axis_symbols,
    closure_rows,
    point_acceleration_symbols,
    point_symbols,
    point_velocity_symbols,
    symbol,
    velocity_symbol,
)
from .names import Names, check_expression, free_symbols


def derived_names(coordinates: list, points: list) -> set:
    """The names expressions give to time, velocities, accelerations and points' coordinates,
    which a signal or a controller state may not take."""
    derived = {"t"} | {f"{c}{suffix}" for c in coordinates for suffix in ("_dot", "_ddot")}
    derived |= {s.name for name in points
                for f in (point_symbols, point_velocity_symbols, point_acceleration_symbols) for s in f(name)}
    return derived


def _claim_in_expressions(element, kind: type, make: str, field: str, what: str, path: tuple, names: Names,
                          derived: set) -> None:
    """``element`` (at ``path``, e.g. ``("signals", 0)``) of type ``kind`` (``make``: how to make
    one), its name (``field``) one of its own among ``names`` and not one of the ``derived``
    names expressions give (:func:`derived_names`)."""
    if not isinstance(element, kind):
        raise ModelError(f"{path[0]}[{path[1]}] is a {type(element).__name__}, not a {kind.__name__}; make it "
                         f"gpmegen.{make}", path)
    name = getattr(element, field)
    if name in derived:
        raise ModelError(f"{what} {name!r} has the name of a time, velocity, acceleration or point coordinate in "
                         f"expressions; choose another name", path + (field,))
    names.claim(name, what, path + (field,))


def check_signals(model: Model, coordinates: list, points: list, names: Names) -> set:
    """The table signals: at most :data:`MAX_SIGNALS`, each a name of its own in expressions (no
    parameter's, coordinate's, point's or other model name, not ``t`` nor a name expressions give
    to velocities, accelerations and points' coordinates), a table path and a column. Returns
    their symbols."""
    if len(model.signals) > MAX_SIGNALS:
        raise ModelError(f"{len(model.signals)} signals read from tables, at most {MAX_SIGNALS}; join runs into "
                         f"fewer", ("signals",))
    derived = derived_names(coordinates, points)
    for k, signal in enumerate(model.signals):
        path = ("signals", k)
        _claim_in_expressions(signal, Signal, "Signal(name, table, column)", "name", "signal", path, names, derived)
        for key in ("table", "column"):
            value = getattr(signal, key)
            if not isinstance(value, str) or not value:
                raise ModelError(f"signal {signal.name!r}: its {key} must be a non-empty string, got {value!r}",
                                 path + (key,))
    return {s.symbol for s in model.signals}


def _state_symbols(coordinates: list, points: list) -> tuple[set, set]:
    """The symbols a feedback law may name (coordinates, their velocities, points' positions and
    velocities) and the accelerations it may not."""
    state = {f(c) for c in coordinates for f in (symbol, velocity_symbol)}
    state |= {s for name in points for f in (point_symbols, point_velocity_symbols) for s in f(name)}
    accelerations = {acceleration_symbol(c) for c in coordinates}
    accelerations |= {s for name in points for s in point_acceleration_symbols(name)}
    return state, accelerations


#: Why a feedback law may not read accelerations, and why a controller state's rate may not.
FORCE_OF_ACCELERATIONS = "a force that depends on the accelerations changes the mass matrix"


RATE_OF_ACCELERATIONS = "the accelerations are solved from the drives, which read the state"


def _check_law(expr, allowed: set, accelerations: set, where: str, subject: tuple, whose="a drive's",
               why=FORCE_OF_ACCELERATIONS):
    """A feedback law (a drive's, an actuator's, a controller state's rate): of ``allowed``, never
    of ``accelerations`` (``why``: the reason the message gives)."""
    used = sorted(str(s) for s in free_symbols(expr) & accelerations)
    if used:
        raise ModelError(f"{where}: {whose} law may use positions and velocities, not the acceleration {used[0]} "
                         f"({why}); remove it", subject)
    check_expression(expr, allowed, where, subject)


def check_controllers(model: Model, coordinates: list, points: list, names: Names, constant: set) -> set:
    """Each controller state: a name of its own in expressions (as a signal's), its rate a law of
    t, parameters, the state, signals and the controller states, never of accelerations, its
    initial value of parameters. Returns their symbols."""
    derived = derived_names(coordinates, points)
    for k, controller in enumerate(model.controllers):
        _claim_in_expressions(controller, Controller, "Controller(state, rate, initial)", "state", "controller state",
                              ("controllers", k), names, derived)
    state, accelerations = _state_symbols(coordinates, points)
    allowed = constant | {TIME} | state | {s.symbol for s in model.signals} | {c.symbol for c in model.controllers}
    for k, controller in enumerate(model.controllers):
        path = ("controllers", k)
        _check_law(controller.rate, allowed, accelerations, f"controller state {controller.state!r}",
                   path + ("rate",), "a controller state's rate", RATE_OF_ACCELERATIONS)
        check_expression(controller.initial, constant, f"controller state {controller.state!r} initial",
                          path + ("initial",))
    return {c.symbol for c in model.controllers}


def check_drives(model: Model, coordinates: list, points: list, constant: set, controllers: set = frozenset()):
    """Each drive on a known coordinate, once; its law of t, parameters and the state a
    first-order constraint may name (coordinates, their velocities, points' positions and
    velocities) and the controller states (``controllers``: their symbols), never of
    accelerations."""
    state, accelerations = _state_symbols(coordinates, points)
    state = state | controllers
    first: dict[str, tuple] = {}
    for k, drive in enumerate(model.drives):
        path = ("drives", k)
        if drive.coordinate not in coordinates:
            close = difflib.get_close_matches(str(drive.coordinate), coordinates, 1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise ModelError(f"drive on unknown coordinate {drive.coordinate!r}; {hint}the coordinates are "
                             f"{', '.join(coordinates)}", path + ("coordinate",))
        if drive.coordinate in first:
            raise ModelError(f"a second drive on {drive.coordinate!r}; add the two expressions in one drive",
                             path + ("coordinate",), first[drive.coordinate])
        first[drive.coordinate] = path + ("coordinate",)
        signals = {s.symbol for s in model.signals}
        _check_law(drive.expression, constant | {TIME} | state | signals, accelerations,
                   f"drive on {drive.coordinate!r}", path + ("expression",))
        if drive.limit is not None:
            check_expression(drive.limit, constant, f"drive on {drive.coordinate!r} limit", path + ("limit",))


ORDERS = {0: "position", 1: "first order, linear in velocities", 2: "second order, linear in accelerations"}


def check_constraints(model: Model, flat, coordinates: list, names: Names):
    constant = {p.symbol for p in model.parameters}
    points = [e.name for _, e in flat if isinstance(e, Point)]
    kinematic = constant | {TIME} | {symbol(c) for c in coordinates}
    rates = {velocity_symbol(c) for c in coordinates}
    accelerations = {acceleration_symbol(c) for c in coordinates}
    for name in points:
        kinematic |= set(point_symbols(name))
        if model.closures:   # a closure's orientation rows name the axes of its points' frames
            kinematic |= {s for axis in AXES for s in axis_symbols(name, axis)}
        rates |= set(point_velocity_symbols(name))
        accelerations |= set(point_acceleration_symbols(name))
    for k, c in enumerate(model.constraints):
        path = ("constraints", k)
        names.claim(c.name, "constraint", path + ("name",))
        if isinstance(c.order, bool) or c.order not in tuple(ORDERS):   # a tuple: order may be unhashable
            raise ModelError(f"constraint {c.name!r}: order must be "
                             + ", ".join(f"{o} ({what})" for o, what in ORDERS.items()) + f", got {c.order!r}",
                             path + ("order",))
        allowed = kinematic | (rates if c.order >= 1 else set()) | (accelerations if c.order == 2 else set())
        where = path + ("expression",)
        expr = check_expression(c.expression, allowed, f"constraint {c.name!r}", where)
        highest, kind = {1: (rates, "velocities"), 2: (accelerations, "accelerations")}.get(c.order, (None, ""))
        if highest is not None and not (expr.free_symbols & highest):
            raise ModelError(f"constraint {c.name!r}: a {('first', 'second')[c.order - 1]}-order constraint must "
                             f"involve {kind}", where)
        if highest is not None:
            term = nonlinear_term(expr, highest)
            if term is not None:
                raise ModelError(f"constraint {c.name!r}: the term {term} is not linear in the {kind}; write "
                                 f"the constraint as a sum of {kind} times factors free of them", where)
        for key in ("alpha", "beta"):
            check_expression(getattr(c, key), constant, f"constraint {c.name!r} {key}", path + (key,))


def nonlinear_term(expr, variables) -> sp.Expr | None:
    """The first term of ``expr`` (a sum) that is not linear in ``variables`` (symbols), or
    ``expr`` itself when only the sum is not; None when ``expr`` is linear in them."""
    def linear(e):
        used = sorted(e.free_symbols & variables, key=str)
        return all(not (sp.diff(e, a).free_symbols & variables) for a in used)

    if linear(expr):
        return None
    return next((term for term in sp.Add.make_args(expr) if not linear(term)), expr)


def check_dependent(model: Model, coordinates: list):
    if model.dependent is None:
        return
    for k, name in enumerate(model.dependent):
        if name not in coordinates:
            raise ModelError(f"dependent coordinate {name!r} is not a coordinate; the coordinates are "
                             f"{', '.join(coordinates)}", ("dependent", k))
        if name in model.dependent[:k]:
            raise ModelError(f"dependent coordinate {name!r} is listed twice; name each dependent coordinate once",
                             ("dependent", k))
    # a closure's rows may be redundant (found at the start): then one per independent row, fewer
    fewer = bool(model.closures) and len(model.dependent) < len(model.constraints)
    if len(model.dependent) != len(model.constraints) and not fewer:
        raise ModelError(f"{len(model.constraints)} constraint(s) need as many dependent coordinates, "
                         f"{len(model.dependent)} given; list one per constraint or write \"auto\"", ("dependent",))


def check_closures(model: Model, points: list, tree, names: Names):
    """Each closure: a free name, a known type with its axis, two points on different bodies
    (one may be on the ground: moved by no joint), its rows among the model's constraints as
    :meth:`Closure.constraints` writes them."""
    held = {c.name: c for c in model.constraints}
    for k, closure in enumerate(model.closures):
        path = ("closures", k)
        names.claim(closure.name, "closure", path + ("name",))
        if closure.kind not in CLOSURE_TYPES:
            raise ModelError(f"closure {closure.name!r}: unknown type {closure.kind!r}; use "
                             + ", ".join(f'"{kind}"' for kind in CLOSURE_TYPES), path + ("type",))
        if closure.kind == "point" and closure.axis is not None:
            raise ModelError(f"closure {closure.name!r}: a point closure takes no axis; remove it, or use "
                             f"type = \"revolute\" or \"prismatic\"", path + ("axis",))
        if closure.kind != "point" and closure.axis not in AXES:
            raise ModelError(f"closure {closure.name!r}: a {closure.kind} closure needs its axis, \"x\", \"y\" or "
                             f"\"z\" of the first point's frame; add axis = \"z\"", path + ("axis",))
        if len(closure.points) != 2:
            raise ModelError(f"closure {closure.name!r}: give two points, got {len(closure.points)}; write "
                             f"points = [\"C1\", \"C2\"]", path + ("points",))
        for j, point in enumerate(closure.points):
            if point not in points:
                raise ModelError(f"closure {closure.name!r}: no point {point!r} (points: {', '.join(points)}); "
                                 f"declare it with a [[chain]] point element or fix the name", path + ("points", j))
        moved = [tree.point_joint[points.index(point)] for point in closure.points]
        if moved[0] == moved[1]:
            where = "the ground" if moved[0] < 0 else "the same body"
            raise ModelError(f"closure {closure.name!r}: points {closure.points[0]!r} and {closure.points[1]!r} are "
                             f"both on {where}, so the closure holds nothing; close the loop between points on two "
                             f"different bodies", path + ("points",))
        allowed = closure_rows(closure.kind, closure.axis)
        for label, row in zip(closure.rows, closure.constraints()):
            if label not in allowed or held.get(row.name) != row:
                raise ModelError(f"closure {closure.name!r}: its row {label!r} is not among the model's constraints "
                                 f"as the closure writes it; make the model with Closure.constraints()",
                                 path + ("rows",))


#: The keys each type of force element needs (one of them at least) and may have.
FORCE_KEYS = {"spring-damper": (("stiffness", "damping"), ("stiffness", "rest_length", "damping")),
              "actuator": (("force",), ("force",))}


def check_forces(model: Model, coordinates: list, points: list, tree, names: Names):
    """Each force element: a free name, a known type, two points of the chain on different bodies
    (one may be on the ground), its quantities of parameters (an actuator's law also of t and
    the state, never of accelerations)."""
    constant = {p.symbol for p in model.parameters}
    state, accelerations = _state_symbols(coordinates, points)
    for k, element in enumerate(model.forces):
        path = ("forces", k)
        names.claim(element.name, "force", path + ("name",))
        where = f"force {element.name!r}"
        if element.kind not in FORCE_TYPES:
            close = difflib.get_close_matches(str(element.kind), FORCE_TYPES, 1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise ModelError(f"{where}: unknown type {element.kind!r}; {hint}use "
                             + ", ".join(f'"{kind}"' for kind in FORCE_TYPES), path + ("type",))
        if len(element.points) != 2:
            raise ModelError(f"{where}: give two points, got {len(element.points)}; write points = [\"A\", \"B\"]",
                             path + ("points",))
        for j, point in enumerate(element.points):
            if point not in points:
                close = difflib.get_close_matches(str(point), points, 1)
                hint = f"did you mean {close[0]!r}? or " if close else ""
                raise ModelError(f"{where}: no point {point!r} (points: {', '.join(points) or 'none'}); {hint}declare "
                                 f"it with a [[chain]] point element", path + ("points", j))
        if element.points[0] == element.points[1]:
            raise ModelError(f"{where}: the point {element.points[0]!r} is named twice, so the force has no line; "
                             f"name two different points", path + ("points", 1))
        moved = [tree.point_joint[points.index(point)] for point in element.points]
        if moved[0] == moved[1]:
            on = "the ground" if moved[0] < 0 else "the same body"
            raise ModelError(f"{where}: points {element.points[0]!r} and {element.points[1]!r} are both on {on}, so "
                             f"its length never changes and its force does no work; put the points on two different "
                             f"bodies", path + ("points",))
        for key in ("stiffness", "rest_length", "damping"):
            check_expression(getattr(element, key), constant, f"{where} {key}", path + (key,))
        _check_law(element.force, constant | {TIME} | state, accelerations, where, path + ("force",),
                   "an actuator's")
