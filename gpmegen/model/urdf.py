"""URDF import: a robot description as a gpmegen :class:`~gpmegen.model.chain.Model`.

gpmegen chains are serial, so one branch of the URDF tree becomes the chain: the branch from
the base to ``tip`` (a link), or, when no tip is named, the one branch that holds every moving
joint (a tree whose moving joints branch is refused, naming the link where they do). The
coordinates are the branch's revolute, continuous (as revolute) and prismatic joints, base
first. Each moving link carries one body: its own inertial and those of every link fixed to it
(fixed joints, and the joints of other branches held at their zero position), combined rigidly
by adding pseudo-inertias. Every link's frame origin is a point named after the link. A joint's
``<dynamics damping>`` is its viscous damper (``<gpmegen:spring stiffness damping>``, which
``gpmegen export`` writes, gives a spring and damper); limits, effort and friction are kept as data
(:class:`~gpmegen.model.urdf_tree.UrdfJoint`) and do not act. Gravity is ``-g`` along z of the
base (``g`` a parameter, 9.81 m/s²), as URDF robots are described z up.

A model file may name a URDF and make links flexible (:class:`FlexibleUrdfLink`): the link's own
inertial gives way to the beam, which starts at the link's frame and extends ``along`` a
direction of that frame; whatever is fixed to the link, and the next joint, follow the beam's tip.
"""

from __future__ import annotations

import difflib
import math
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..errors import ModelError
from . import shapes
from .chain import Body, FlexibleLink, Joint, Model, Offset, Parameter, Point, check_name
from .expand import AXIS_TOLERANCE
from .urdf_tree import UrdfJoint, UrdfTree, read_tree, rpy

GRAVITY = Parameter("g", 9.81, "m/s²", "gravitational acceleration, along -z of the base")
BODY_SUFFIX = "_body"


@dataclass(frozen=True)
class FlexibleUrdfLink:
    """A URDF link made flexible: ``beam`` (its label, length, section, material, n_rfe) starts at
    the link's frame and extends along the unit vector ``along`` of that frame."""

    link: str
    along: tuple
    beam: FlexibleLink


@dataclass(frozen=True)
class ImportedRobot:
    """A URDF read as a model: the ``model``, the ``tree`` it came from, the URDF joints of its
    coordinates in the order of ``q`` (their limits and friction as data) and the ``tip`` link."""

    model: Model
    tree: UrdfTree
    joints: tuple
    tip: str


def import_urdf(path, tip: str | None = None, flexible: tuple = (), extra: tuple = (),
                parameters: tuple = (GRAVITY,), gravity=None, name: str | None = None, **model) -> ImportedRobot:
    """The URDF at ``path`` (or its :class:`UrdfTree`) as a model (see the module's docstring).

    ``tip``: the link the chain ends at (None: the one branch of all moving joints);
    ``flexible``: :class:`FlexibleUrdfLink` s; ``extra``: ``(link, element)`` pairs of chain
    elements (points) to attach to a link's frame; ``parameters``, ``gravity`` (default
    ``(0, 0, -g)``), ``name`` (default the robot's) and any other :class:`Model` fields replace
    the defaults. Raises ModelError naming the URDF element and the fix."""
    tree = path if isinstance(path, UrdfTree) else read_tree(path)
    branch = serial_branch(tree, tip)
    moving = [j for j in branch if j.type != "fixed"]
    if not moving:
        raise tree.error("the URDF has no revolute, continuous or prismatic joint on the chain; a model needs one")
    flex = {f.link: f for f in flexible}
    for link in list(flex) + [link for link, _ in extra]:
        _check_link_named(tree, link)
    chain = _chain(tree, moving, flex, extra)
    name = name if name is not None else tree.name
    _check_names(tree, name, moving)
    g = sp.Symbol("g", real=True)
    built = Model(name=name, parameters=tuple(parameters), chain=tuple(chain),
                  gravity=gravity if gravity is not None else (0, 0, -g), **model)
    end = moving[-1].child if tip is None else tip
    return ImportedRobot(built, tree, tuple(moving), end)


def serial_branch(tree: UrdfTree, tip: str | None) -> list[UrdfJoint]:
    """The joints from the base to ``tip``, or (``tip`` None) to the last moving joint of the one
    branch that holds them all; ModelError when moving joints branch and no tip is named."""
    if tip is not None:
        _check_link_named(tree, tip)
        parent = {j.child: j for j in tree.joints}
        branch, link = [], tip
        while link != tree.root:
            branch.append(parent[link])
            link = parent[link].parent
        return branch[::-1]
    branch, link = [], tree.root
    while True:
        ahead = [j for j in tree.children(link) if _moves(tree, j)]
        if len(ahead) > 1:
            raise tree.error(f"<link name=\"{link}\"> branches into the moving joints {ahead[0].name!r} and "
                             f"{ahead[1].name!r}, and gpmegen chains are serial; import the branch to one tip link "
                             f"from a model file, urdf = {{ file = \"...\", tip = \"<link>\" }} (the joints of the "
                             f"other branches are held at zero)")
        if not ahead:
            return branch
        branch.append(ahead[0])
        link = ahead[0].child


def _moves(tree: UrdfTree, joint: UrdfJoint) -> bool:
    """Whether ``joint`` or a joint after it moves."""
    return joint.type != "fixed" or any(_moves(tree, j) for j in tree.children(joint.child))


def _check_link_named(tree: UrdfTree, link: str):
    if link not in tree.links:
        close = difflib.get_close_matches(str(link), list(tree.links), 1)
        hint = f"did you mean {close[0]!r}? " if close else ""
        raise tree.error(f"there is no <link name=\"{link}\">; {hint}the links are {', '.join(tree.links)}")


def _check_names(tree: UrdfTree, name: str, moving: list):
    """URDF names become names of generated code: the rules of model files, each refusal
    naming the element."""
    checks = [(name, "robot name", "<robot name>", False)]
    checks += [(j.name, "coordinate", f"<joint name=\"{j.name}\">", True) for j in moving]
    checks += [(link, "point", f"<link name=\"{link}\">", False) for link in tree.links]
    for value, what, element, bare in checks:
        try:
            check_name(value, what, bare=bare)
        except ModelError as exc:
            raise tree.error(f"{element}: {exc}; rename it in the URDF") from None


def _chain(tree: UrdfTree, moving: list, flex: dict, extra: tuple) -> list:
    """The chain: the base's group, then for each moving joint its offset, the joint and the
    group of links that moves with it."""
    held = {j.name for j in moving}
    chain, head = [], tree.root
    for joint in [None, *moving]:
        if joint is not None:
            chain += _offset(_frame(tree, head, held, joint.parent) @ joint.origin)
            kind = "prismatic" if joint.type == "prismatic" else "revolute"
            chain.append(Joint(joint.name, kind, joint.axis, stiffness=joint.stiffness, damping=joint.damping))
            head = joint.child
        chain += _group(tree, head, held, flex.get(head), extra, joint)
    return chain


def _members(tree: UrdfTree, head: str, held: set) -> list[tuple[str, np.ndarray]]:
    """The links that move with ``head`` (joined to it by joints not in ``held``, at their zero
    position), each with its frame in ``head``'s, depth first, children in file order."""
    out, todo = [], [(head, np.eye(4))]
    while todo:
        link, T = todo.pop()
        out.append((link, T))
        todo += [(j.child, T @ j.origin) for j in reversed(tree.children(link)) if j.name not in held]
    return out


def _frame(tree, head, held, link) -> np.ndarray:
    return dict(_members(tree, head, held))[link]


def _group(tree, head, held, flexible, attached, joint) -> list:
    """The elements of the links moving with ``head``: one body of their combined inertials (or
    the beam of a flexible link, after which the links fixed to it follow its tip), a point at
    each link's frame, then the points ``attached`` (``(link, Point)`` pairs) to any of them."""
    members = _members(tree, head, held)
    out = [Point(head, (0, 0, 0))]
    weighed = members
    if flexible is not None:
        out += _beam(flexible)
        weighed = members[1:]   # the link's own inertial gives way to the beam
    with_inertial = [(tree.links[link], T) for link, T in weighed if tree.links[link]]
    if joint is not None and flexible is None and not with_inertial:
        raise tree.error(f"<link name=\"{head}\">, moved by <joint name=\"{joint.name}\">, has no <inertial> (nor "
                         f"has any link fixed to it); add <inertial> with its mass, origin and inertia (a mass of 0 "
                         f"for a massless link)")
    H = sum((T @ _pseudo_inertia(inertial) @ T.T for inertial, T in with_inertial), np.zeros((4, 4)))
    if H[3, 3] > 0:
        H = (H + H.T) / 2   # exactly symmetric, as a pseudo-inertia must be
        out.append(Body(head + BODY_SUFFIX, sp.ImmutableMatrix(H.tolist())))
    out += [Point(link, tuple(float(v) for v in T[:3, 3])) for link, T in members[1:]]
    frames = dict(members)
    return out + [Point(point.name, _placed(frames[link], point.position)) for link, point in attached
                  if link in frames]


def _placed(T: np.ndarray, position) -> tuple:
    """``position`` (m, numbers or expressions) given in a link's frame, in the frame ``T`` holds
    that link in."""
    if np.array_equal(T, np.eye(4)):
        return tuple(position)
    r = sp.Matrix([sp.sympify(v) for v in position])
    return tuple(sp.Matrix(T[:3, :3].tolist()) * r + sp.Matrix(T[:3, 3].tolist()))


def _pseudo_inertia(inertial) -> np.ndarray:
    """The 4x4 pseudo-inertia of a URDF ``<inertial>`` in its link's frame."""
    R, c = inertial.origin[:3, :3], inertial.origin[:3, 3]
    return np.array(shapes.from_inertia_tensor(inertial.mass, c.tolist(), (R @ inertial.inertia @ R.T).tolist()),
                    dtype=float)


def unit_direction(along, what: str) -> np.ndarray:
    """``along`` as a unit 3-vector; ModelError naming ``what`` when it is not one (to 1e-6, the
    rule of joint axes)."""
    a = np.asarray(along, float)
    norm = float(np.linalg.norm(a)) if a.shape == (3,) else float("nan")
    if not np.isfinite(norm) or abs(norm - 1) > AXIS_TOLERANCE:
        raise ModelError(f"{what}: the direction {list(along)} is not a unit vector; give a unit vector of the "
                         f"link's frame")
    return a / norm


def _beam(flexible: FlexibleUrdfLink) -> list:
    """The flexible link turned from the link's x axis to ``along``, and the offset from its tip
    back to the link's frame as it is when undeformed."""
    a = unit_direction(flexible.along, f"flexible link {flexible.beam.label!r} on URDF link {flexible.link!r}")
    yaw, pitch = math.atan2(a[1], a[0]), math.atan2(-a[2], math.hypot(a[0], a[1]))
    turn = tuple((axis, angle) for axis, angle in (("z", yaw), ("y", pitch)) if angle != 0)
    back = tuple((axis, -angle) for axis, angle in reversed(turn))
    return [Offset((0, 0, 0), turn), flexible.beam, Offset((-flexible.beam.length, 0, 0), back)]


def _offset(T: np.ndarray) -> list:
    """A 4x4 transform as an Offset: its translation, then rotations about z, y, x (the URDF's
    roll-pitch-yaw, ``R = Rz(yaw) Ry(pitch) Rx(roll)``); none for the identity."""
    roll, pitch, yaw = rpy(T[:3, :3])
    rotations = tuple((axis, angle) for axis, angle in (("z", yaw), ("y", pitch), ("x", roll)) if angle != 0)
    translation = tuple(float(v) for v in T[:3, 3])
    if not any(translation) and not rotations:
        return []
    return [Offset(translation, rotations)]
