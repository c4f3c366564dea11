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
    GROUND_NAME,
    JOINT_KINDS,
    MOTOR_SUFFIX,
    Body,
    Branch,
    FlexibleLink,
    Joint,
    Model,
    Motor,
    Offset,
    Point,
    SeriesElastic,
    check_model_name,
)
from .computed_torque import check as check_computed_torque
from .elements import check as check_elements
from .law_checks import (
    check_closures,
    check_constraints,
    check_controllers,
    check_dependent,
    check_drives,
    check_forces,
    check_signals,
)
from .names import Names, check_expression
from .rfem import MATERIAL, check_link, discretize
from .task_torque import check as check_task_torque
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
                    check_expression(value, constant, f"flexible link {element.label!r} {attr}",
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


def _check_branch(branch: Branch, path, names: Names, points: list):
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


def _check_element(element, path, names: Names, constant: set, points: list = ()):
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
            check_expression(getattr(element, key), constant, f"joint {element.name!r} {key}", table + (key,))
        for key, part, kind in (("motor", element.motor, Motor), ("series_elastic", element.series_elastic,
                                                                  SeriesElastic)):
            if part is None:
                continue
            if not isinstance(part, kind):
                raise ModelError(f"joint {element.name!r}: its {key} is a {type(part).__name__}, not a "
                                 f"{kind.__name__}", table + (key,))
            for f in dataclasses.fields(part):
                check_expression(getattr(part, f.name), constant, f"joint {element.name!r} {key} {f.name}",
                                  table + (key, f.name))
        return dataclasses.replace(element, axis=joint_axis(element, table + ("axis",)))
    elif isinstance(element, Body):
        names.claim(element.name, "body", path)
        h = sp.ImmutableMatrix(element.pseudo_inertia)
        if h.shape != (4, 4) or h != h.T:
            raise ModelError(f"body {element.name!r}: the pseudo-inertia must be a symmetric 4x4 matrix", table)
        for v in h:
            check_expression(v, constant, f"body {element.name!r} pseudo-inertia", table)
    elif isinstance(element, Point):
        names.claim(element.name, "point", path)
        for i, v in enumerate(element.position):
            check_expression(v, constant, f"point {element.name!r} position", table + ("position", i))
    else:
        for i, v in enumerate(element.translation):
            check_expression(v, constant, "offset translation", table + ("translation", i))
        for i, (axis, angle) in enumerate(element.rotations):
            if axis not in AXES:
                raise ModelError(f"offset rotation about unknown axis {axis!r}; use x, y or z",
                                 table + ("rotations", i, 0))
            check_expression(angle, constant, "offset rotation angle", table + ("rotations", i, 1))
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


def _check_derived_names(flat, names: Names):
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


def expand(model: Model) -> FlatChain:
    """Validate ``model`` and expand its flexible links; raise ModelError naming the fault, with
    the path of its field as ``subject``."""
    check_model_name(model.name, subject=("name",))
    names = Names()
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
    check_signals(model, coordinates, points, names)
    for i, v in enumerate(model.gravity):
        check_expression(v, constant, "gravity", ("gravity", i))
    controllers = check_controllers(model, coordinates, points, names, constant)
    check_drives(model, coordinates, points, constant, controllers)
    check_constraints(model, flat, coordinates, names)
    elements = tuple(e for _, e in flat)
    tree = topology(elements)
    check_closures(model, points, tree, names)
    check_forces(model, coordinates, points, tree, names)
    check_elements(model)
    check_dependent(model, coordinates)
    if model.computed_torque is not None:
        check_computed_torque(model.computed_torque, coordinates, constant)
    if model.task_torque is not None:
        check_task_torque(model.task_torque, coordinates, constant, model.computed_torque)
    if model.start_constants is not None:
        model.start_constants.check(model, coordinates, points)
    return FlatChain(model, elements, tuple(coordinates), tree, _couplings(elements, coordinates))


