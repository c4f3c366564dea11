"""Validation of a Model and its expansion into a flat chain of joints, offsets, bodies, points
and branch starts (flexible links discretized by RFEM), with its tree (:mod:`.topology`)."""

from __future__ import annotations

import dataclasses
import difflib
import math
from dataclasses import dataclass

import sympy as sp

from ..errors import ModelError
from .chain import (
    AXES,
    CLOSURE_TYPES,
    FORCE_TYPES,
    GROUND_NAME,
    JOINT_KINDS,
    MAX_SIGNALS,
    MOTOR_SUFFIX,
    TIME,
    Body,
    Branch,
    Controller,
    FlexibleLink,
    Joint,
    Model,
    Motor,
    Offset,
    Point,
    SeriesElastic,
    Signal,
    acceleration_symbol,
    axis_symbols,
    check_model_name,
    check_name,
    closure_rows,
    point_acceleration_symbols,
    point_symbols,
    point_velocity_symbols,
    symbol,
    velocity_symbol,
)
from .computed_torque import check as check_computed_torque
from .rfem import MATERIAL, check_link, discretize
from .topology import GROUND, Topology


@dataclass(frozen=True)
class FlatChain:
    """A validated model with its flexible links expanded.

    ``elements``: Joint, Offset, Body, Point and Branch only, base first (a Branch: the elements
    after it start from its parent point's frame). ``coordinates``: the joint names in chain
    order (the order of ``q``), the motor coordinates of series-elastic joints last.
    ``topology``: the tree of the joints, bodies and points. ``couplings``: per series-elastic
    joint, the :class:`Coupling` between it and its motor coordinate."""

    model: Model
    elements: tuple
    coordinates: tuple
    topology: Topology
    couplings: tuple = ()

    @property
    def n_dof(self) -> int:
        return len(self.coordinates)

    @property
    def points(self) -> tuple:
        return tuple(e.name for e in self.elements if isinstance(e, Point))

    @property
    def bodies(self) -> tuple:
        return tuple(e.name for e in self.elements if isinstance(e, Body))


@dataclass(frozen=True)
class Coupling:
    """The spring ``stiffness`` and damper ``damping`` between coordinate ``joint`` (the link
    side) and coordinate ``motor`` (indices into ``q``) of a series-elastic joint."""

    joint: int
    motor: int
    stiffness: sp.Expr
    damping: sp.Expr


def _motor_joints(flattened) -> list:
    """The flat elements that give each series-elastic joint's motor a coordinate of its own:
    a branch from the ground and a joint ``<joint>_motor`` of the same kind and axis that moves
    no body, so that it adds only the motor's inertia to ``M`` (its row and column hold nothing
    else). A motor named like another joint is refused in one line."""
    taken = {e.name: path for path, e in flattened if isinstance(e, Joint)}
    out = []
    for path, joint in flattened:
        if not isinstance(joint, Joint) or joint.series_elastic is None:
            continue
        here = path[:-1] + ("series_elastic",)
        if joint.motor is None:
            raise ModelError(f"joint {joint.name!r} is series-elastic but has no motor; add motor = {{ inertia = "
                             f"..., gear = ... }} to it", here)
        name = joint.name + MOTOR_SUFFIX
        if name in taken:
            raise ModelError(f"joint {joint.name!r} is series-elastic, so its motor is the coordinate {name!r}, "
                             f"which another joint already names; rename that joint", taken[name], here)
        motor = Joint(name, joint.kind, joint.axis, motor=joint.motor)
        out += [(here, Branch(GROUND_NAME)), (here + ("motor",), motor)]
    return out


def _couplings(elements, coordinates) -> tuple:
    """The :class:`Coupling` of each series-elastic joint among the flat ``elements``."""
    index = {name: k for k, name in enumerate(coordinates)}
    return tuple(Coupling(index[e.name], index[e.name + MOTOR_SUFFIX], sp.sympify(e.series_elastic.stiffness),
                          sp.sympify(e.series_elastic.damping))
                 for e in elements if isinstance(e, Joint) and e.series_elastic is not None)


def _free_symbols(expr) -> set:
    """The free symbols of ``expr``, none when it is not an expression (:func:`_check_expression`
    says so)."""
    try:
        return sp.sympify(expr).free_symbols
    except (sp.SympifyError, TypeError):
        return set()


def _check_expression(expr, allowed: set, where: str, subject: tuple):
    try:
        expr = sp.sympify(expr)
    except (sp.SympifyError, TypeError) as exc:
        raise ModelError(f"{where}: not a valid expression ({exc})", subject) from None
    if expr.has(sp.DiracDelta):
        raise ModelError(f"{where}: DiracDelta is an impulse, which generated code cannot evaluate; prescribe the "
                         f"motion it causes instead (a jump with Heaviside or Piecewise)", subject)
    if any(pw.args[-1].cond != sp.true for pw in expr.atoms(sp.Piecewise)):
        raise ModelError(f"{where}: a Piecewise has no last pair (value, True), so its value is undefined where "
                         f"no condition holds; end it with (value, True)", subject)
    unknown = sorted(str(s) for s in expr.free_symbols if s not in allowed)
    unreal = [name for name in unknown if name in {str(s) for s in allowed}]
    if unreal:   # SymPy holds Symbol('x') and Symbol('x', real=True) as two symbols
        raise ModelError(f"{where}: the symbol {unreal[0]} is not declared real; make it "
                         f"sympy.Symbol({unreal[0]!r}, real=True), as gpmegen's own names are", subject)
    if unknown:
        raise ModelError(f"{where}: unknown name(s) {', '.join(unknown)}; declare them as parameters or use "
                         f"names defined in the model", subject)
    return expr


class _Names:
    """The one namespace of parameters, coordinates, bodies, points and constraints, with the
    path of each name's field (see :class:`gpmegen.errors.ModelError`)."""

    def __init__(self):
        self.seen: dict[str, tuple[str, tuple]] = {}

    def claim(self, name, what, path):
        check_name(name, what, bare=what in ("parameter", "coordinate", "signal", "controller state"), subject=path)
        if name in self.seen:
            other, other_path = self.seen[name]
            raise ModelError(f"{what} {name!r} duplicates the {other} of the same name; rename one", path,
                             other_path)
        self.seen[name] = (what, path)


def _flatten(model: Model):
    """The chain's elements with flexible links expanded, each with the path of the field that
    names it (``("chain", k, "joint")``; offsets: the element's path)."""
    constant = {p.symbol for p in model.parameters}   # chain quantities may use parameters only
    out = []
    for k, element in enumerate(model.chain):
        path = ("chain", k)
        if isinstance(element, FlexibleLink):
            check_link(element, path)
            quantities = [(attr, getattr(element, attr)) for attr in ("length", *MATERIAL)]
            quantities += [(f"section.{f.name}", getattr(element.section, f.name))
                           for f in dataclasses.fields(element.section)]
            for attr, value in quantities:
                if value is not None:
                    _check_expression(value, constant, f"flexible link {element.label!r} {attr}",
                                      path + tuple(attr.split(".")))
            out += [(path + ("flexible",), part) for part in discretize(element)]
        elif isinstance(element, (Joint, Body, Point)):
            out.append((path + (_NAME_KEY[type(element)],), element))
        elif isinstance(element, Offset):
            out.append((path, element))
        elif isinstance(element, Branch):
            out.append((path + ("parent",), element))
        else:
            raise ModelError(f"chain element {k + 1}: unknown element {type(element).__name__}", path)
    return out


_NAME_KEY = {Joint: "joint", Body: "body", Point: "point"}


def _check_branch(branch: Branch, path, names: _Names, points: list):
    """A branch's parent: ``"ground"`` or a point defined before it (``points``: all the points
    of the chain); ModelError naming the fix otherwise."""
    parent = branch.parent
    if parent == GROUND_NAME:
        if GROUND_NAME in points:
            raise ModelError(f"a branch from {GROUND_NAME!r} is ambiguous: a point has that name, which a branch "
                             f"reads as the base frame; rename the point", path)
        return
    if not isinstance(parent, str):
        raise ModelError(f"branch parent {parent!r} is not a name; name a point defined before the branch, or "
                         f"{GROUND_NAME!r}", path)
    if parent in names.seen:
        what, _ = names.seen[parent]
        if what != "point":
            raise ModelError(f"branch parent {parent!r} is a {what}, not a point; add a point where the branch "
                             f"starts and name it", path)
        return
    if parent in points:
        raise ModelError(f"branch parent {parent!r} is defined later in the chain; move the branch after the point "
                         f"{parent!r} (each branch follows the point it starts from)", path)
    close = difflib.get_close_matches(parent, [p for p in points if p in names.seen], 1)
    hint = f"did you mean {close[0]!r}? " if close else ""
    raise ModelError(f"branch parent {parent!r} names no point; {hint}name a point defined before the branch, or "
                     f"{GROUND_NAME!r}", path)


def topology(elements) -> Topology:
    """The tree of checked flat ``elements``: each joint hangs from the joint that moves the
    frame it is defined in, and a Branch restarts from its parent point's joint."""
    current = GROUND
    parent, body_joint, point_joint, joint_of_point = [], [], [], {}
    for element in elements:
        if isinstance(element, Joint):
            parent.append(current)
            current = len(parent) - 1
        elif isinstance(element, Body):
            body_joint.append(current)
        elif isinstance(element, Point):
            point_joint.append(current)
            joint_of_point[element.name] = current
        elif isinstance(element, Branch):
            current = GROUND if element.parent == GROUND_NAME else joint_of_point[element.parent]
    return Topology.of(parent, body_joint, point_joint)


def _check_element(element, path, names: _Names, constant: set, points: list = ()):
    """Names, kinds, axes and expressions of one expanded chain element at ``path``; the element
    as the derivation takes it (a joint's axis in its one form: :func:`joint_axis`). ``points``:
    the names of all the chain's points, for a Branch's parent."""
    if isinstance(element, Branch):
        _check_branch(element, path, names, list(points))
        return element
    table = path[:-1] if isinstance(element, (Joint, Body, Point)) else path
    if isinstance(element, Joint):
        names.claim(element.name, "coordinate", path)
        if element.kind not in JOINT_KINDS:
            raise ModelError(f"joint {element.name!r}: unknown kind {element.kind!r}; use one of "
                             f"{', '.join(JOINT_KINDS)}", table + ("type",))
        for key in ("stiffness", "rest", "damping"):
            _check_expression(getattr(element, key), constant, f"joint {element.name!r} {key}", table + (key,))
        for key, part, kind in (("motor", element.motor, Motor), ("series_elastic", element.series_elastic,
                                                                  SeriesElastic)):
            if part is None:
                continue
            if not isinstance(part, kind):
                raise ModelError(f"joint {element.name!r}: its {key} is a {type(part).__name__}, not a "
                                 f"{kind.__name__}", table + (key,))
            for f in dataclasses.fields(part):
                _check_expression(getattr(part, f.name), constant, f"joint {element.name!r} {key} {f.name}",
                                  table + (key, f.name))
        return dataclasses.replace(element, axis=joint_axis(element, table + ("axis",)))
    elif isinstance(element, Body):
        names.claim(element.name, "body", path)
        h = sp.ImmutableMatrix(element.pseudo_inertia)
        if h.shape != (4, 4) or h != h.T:
            raise ModelError(f"body {element.name!r}: the pseudo-inertia must be a symmetric 4x4 matrix", table)
        for v in h:
            _check_expression(v, constant, f"body {element.name!r} pseudo-inertia", table)
    elif isinstance(element, Point):
        names.claim(element.name, "point", path)
        for i, v in enumerate(element.position):
            _check_expression(v, constant, f"point {element.name!r} position", table + ("position", i))
    else:
        for i, v in enumerate(element.translation):
            _check_expression(v, constant, "offset translation", table + ("translation", i))
        for i, (axis, angle) in enumerate(element.rotations):
            if axis not in AXES:
                raise ModelError(f"offset rotation about unknown axis {axis!r}; use x, y or z",
                                 table + ("rotations", i, 0))
            _check_expression(angle, constant, "offset rotation angle", table + ("rotations", i, 1))
    return element


# URDF files and hand-typed vectors round unit axes to a few digits; a longer or shorter vector is
# a mistake rather than rounding.
AXIS_TOLERANCE = 1e-6


def joint_axis(joint: Joint, subject: tuple):
    """``joint.axis`` as the letter of a principal axis (a unit vector along +x, +y or +z becomes
    its letter, so that such a joint derives exactly as one given by letter) or else as a unit
    vector of three SymPy Floats; ModelError naming the joint when it is neither."""
    axis = joint.axis
    if isinstance(axis, str):
        if axis not in AXES:
            raise ModelError(f"joint {joint.name!r}: unknown axis {axis!r}; use x, y, z or a unit vector "
                             f"[ax, ay, az]", subject)
        return axis
    try:
        vector = [float(a) for a in axis] if len(axis) == 3 else None
    except (TypeError, ValueError):
        vector = None
    if vector is None or not all(map(math.isfinite, vector)):
        raise ModelError(f"joint {joint.name!r}: the axis {axis!r} is neither x, y, z nor three numbers; write a "
                         f"unit vector such as [0, 0.6, 0.8]", subject)
    norm = math.sqrt(sum(a * a for a in vector))
    if abs(norm - 1) > AXIS_TOLERANCE:
        raise ModelError(f"joint {joint.name!r}: the axis {vector} has length {norm:.6g}, not 1; give a unit "
                         f"vector (each component divided by {norm:.6g})", subject)
    unit = tuple(a / norm for a in vector)
    for k, letter in enumerate(AXES):
        if unit == tuple(float(i == k) for i in range(3)):
            return letter
    return tuple(sp.Float(a) for a in unit)


def _check_derived_names(flat, names: _Names):
    """The names constraint expressions give to velocities and accelerations of coordinates
    (``<coordinate>_dot``, ``<coordinate>_ddot``) and to points (``x_P``, ``vx_P``, ``ax_P``) must
    not be a parameter's or a coordinate's, nor made twice, else an expression would silently
    mean one of the two."""
    made: dict[str, tuple[str, str, tuple]] = {}   # name -> (owner, meaning, owner's path)
    for path, element in flat:
        if isinstance(element, Joint):
            owner = f"coordinate {element.name!r}"
            derived = [(f"{element.name}_dot", f"velocity of {owner}"),
                       (f"{element.name}_ddot", f"acceleration of {owner}")]
        elif isinstance(element, Point):
            owner = f"point {element.name!r}"
            derived = [(f"{prefix}{a}_{element.name}", f"{quantity} {a} of {owner}")
                       for prefix, quantity in (("", "coordinate"), ("v", "velocity"), ("a", "acceleration"))
                       for a in AXES]
        else:
            continue
        for name, meaning in derived:
            if name in names.seen and names.seen[name][0] in ("parameter", "coordinate"):
                other, other_path = names.seen[name]
                raise ModelError(f"{owner} makes the name {name}, and {other} {name!r} has the name of the {meaning} "
                                 f"in constraint expressions; rename one", path, other_path)
            if name in made and made[name][0] != owner:
                raise ModelError(f"{owner} makes the name {name}, the {meaning} in constraint expressions, which "
                                 f"is also the {made[name][1]}; rename one", path, made[name][2])
            made[name] = (owner, meaning, path)


def _derived_names(coordinates: list, points: list) -> set:
    """The names expressions give to time, velocities, accelerations and points' coordinates,
    which a signal or a controller state may not take."""
    derived = {"t"} | {f"{c}{suffix}" for c in coordinates for suffix in ("_dot", "_ddot")}
    derived |= {s.name for name in points
                for f in (point_symbols, point_velocity_symbols, point_acceleration_symbols) for s in f(name)}
    return derived


def _claim_in_expressions(element, kind: type, make: str, field: str, what: str, path: tuple, names: _Names,
                          derived: set) -> None:
    """``element`` (at ``path``, e.g. ``("signals", 0)``) of type ``kind`` (``make``: how to make
    one), its name (``field``) one of its own among ``names`` and not one of the ``derived``
    names expressions give (:func:`_derived_names`)."""
    if not isinstance(element, kind):
        raise ModelError(f"{path[0]}[{path[1]}] is a {type(element).__name__}, not a {kind.__name__}; make it "
                         f"gpmegen.{make}", path)
    name = getattr(element, field)
    if name in derived:
        raise ModelError(f"{what} {name!r} has the name of a time, velocity, acceleration or point coordinate in "
                         f"expressions; choose another name", path + (field,))
    names.claim(name, what, path + (field,))


def _check_signals(model: Model, coordinates: list, points: list, names: _Names) -> set:
    """The table signals: at most :data:`MAX_SIGNALS`, each a name of its own in expressions (no
    parameter's, coordinate's, point's or other model name, not ``t`` nor a name expressions give
    to velocities, accelerations and points' coordinates), a table path and a column. Returns
    their symbols."""
    if len(model.signals) > MAX_SIGNALS:
        raise ModelError(f"{len(model.signals)} signals read from tables, at most {MAX_SIGNALS}; join runs into "
                         f"fewer", ("signals",))
    derived = _derived_names(coordinates, points)
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
    used = sorted(str(s) for s in _free_symbols(expr) & accelerations)
    if used:
        raise ModelError(f"{where}: {whose} law may use positions and velocities, not the acceleration {used[0]} "
                         f"({why}); remove it", subject)
    _check_expression(expr, allowed, where, subject)


def _check_controllers(model: Model, coordinates: list, points: list, names: _Names, constant: set) -> set:
    """Each controller state: a name of its own in expressions (as a signal's), its rate a law of
    t, parameters, the state, signals and the controller states, never of accelerations, its
    initial value of parameters. Returns their symbols."""
    derived = _derived_names(coordinates, points)
    for k, controller in enumerate(model.controllers):
        _claim_in_expressions(controller, Controller, "Controller(state, rate, initial)", "state", "controller state",
                              ("controllers", k), names, derived)
    state, accelerations = _state_symbols(coordinates, points)
    allowed = constant | {TIME} | state | {s.symbol for s in model.signals} | {c.symbol for c in model.controllers}
    for k, controller in enumerate(model.controllers):
        path = ("controllers", k)
        _check_law(controller.rate, allowed, accelerations, f"controller state {controller.state!r}",
                   path + ("rate",), "a controller state's rate", RATE_OF_ACCELERATIONS)
        _check_expression(controller.initial, constant, f"controller state {controller.state!r} initial",
                          path + ("initial",))
    return {c.symbol for c in model.controllers}


def _check_drives(model: Model, coordinates: list, points: list, constant: set, controllers: set = frozenset()):
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
            _check_expression(drive.limit, constant, f"drive on {drive.coordinate!r} limit", path + ("limit",))


ORDERS = {0: "position", 1: "first order, linear in velocities", 2: "second order, linear in accelerations"}


def _check_constraints(model: Model, flat, coordinates: list, names: _Names):
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
        expr = _check_expression(c.expression, allowed, f"constraint {c.name!r}", where)
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
            _check_expression(getattr(c, key), constant, f"constraint {c.name!r} {key}", path + (key,))


def nonlinear_term(expr, variables) -> sp.Expr | None:
    """The first term of ``expr`` (a sum) that is not linear in ``variables`` (symbols), or
    ``expr`` itself when only the sum is not; None when ``expr`` is linear in them."""
    def linear(e):
        used = sorted(e.free_symbols & variables, key=str)
        return all(not (sp.diff(e, a).free_symbols & variables) for a in used)

    if linear(expr):
        return None
    return next((term for term in sp.Add.make_args(expr) if not linear(term)), expr)


def _check_dependent(model: Model, coordinates: list):
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


def expand(model: Model) -> FlatChain:
    """Validate ``model`` and expand its flexible links; raise ModelError naming the fault, with
    the path of its field as ``subject``."""
    check_model_name(model.name, subject=("name",))
    names = _Names()
    for p in model.parameters:
        names.claim(p.name, "parameter", ("parameters", p.name))
        if not math.isfinite(float(p.default)):
            raise ModelError(f"parameter {p.name!r} has the default {p.default}, not a finite number; give a "
                             f"value below 1e308 in size", ("parameters", p.name))
    constant = {p.symbol for p in model.parameters}   # expressions of the chain may use parameters only
    flattened = _flatten(model)
    flattened += _motor_joints(flattened)
    points = [e.name for _, e in flattened if isinstance(e, Point)]
    flat = [(path, _check_element(element, path, names, constant, points)) for path, element in flattened]
    coordinates = [e.name for _, e in flat if isinstance(e, Joint)]
    if not coordinates:
        raise ModelError(f"model {model.name!r} has no joints: add at least one joint", ("chain",))
    _check_derived_names(flat, names)
    _check_signals(model, coordinates, points, names)
    for i, v in enumerate(model.gravity):
        _check_expression(v, constant, "gravity", ("gravity", i))
    controllers = _check_controllers(model, coordinates, points, names, constant)
    _check_drives(model, coordinates, points, constant, controllers)
    _check_constraints(model, flat, coordinates, names)
    elements = tuple(e for _, e in flat)
    tree = topology(elements)
    _check_closures(model, points, tree, names)
    _check_forces(model, coordinates, points, tree, names)
    _check_dependent(model, coordinates)
    if model.computed_torque is not None:
        check_computed_torque(model.computed_torque, coordinates, constant)
    return FlatChain(model, elements, tuple(coordinates), tree, _couplings(elements, coordinates))


def _check_closures(model: Model, points: list, tree, names: _Names):
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


def _check_forces(model: Model, coordinates: list, points: list, tree, names: _Names):
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
            _check_expression(getattr(element, key), constant, f"{where} {key}", path + (key,))
        _check_law(element.force, constant | {TIME} | state, accelerations, where, path + ("force",),
                   "an actuator's")
