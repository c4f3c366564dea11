"""URDF import: a robot description as a gpmegen :class:`~gpmegen.model.chain.Model`.

Without ``tip`` the whole tree is the model: its coordinates are every revolute, continuous (as
revolute) and prismatic joint, depth first from the base (each link's child joints in file
order, a joint's whole subtree before its next sibling), and a joint that does not hang from the
joint before it starts a :class:`~gpmegen.model.chain.Branch` from its parent link's group. With
``tip`` (a link) one branch is the model, the joints from the base to the tip, and the joints of
every other branch are held at their zero position. Each moving link carries one body: its own
inertial and those of every link fixed to it (fixed joints, and held joints), combined rigidly
by adding pseudo-inertias. Every link's frame origin is a point named after the link. A joint's
``<dynamics damping>`` is its viscous damper (``<gpmegen:spring stiffness damping>``, which
``gpmegen export`` writes, gives a spring and damper); limits, effort and friction are kept as data
(:class:`~gpmegen.model.urdf_tree.UrdfJoint`) and do not act (runs are checked against them
afterwards: :mod:`gpmegen.analysis.joint_limits`). A ``<mimic>`` joint of the chain follows its
leader by a position constraint. Inertias no body has are refused; names that cannot be code are
renamed, with a warning. Gravity is ``-g`` along z of the base (``g`` a parameter, 9.81 m/s²), as
URDF robots are described z up.

A model file may name a URDF and make links flexible (:class:`FlexibleUrdfLink`): the link's own
inertial gives way to the beam, which starts at the link's frame and extends ``along`` a
direction of that frame; whatever is fixed to the link, and the joints that hang from it, follow
the beam's tip (branches after the first start from the point ``<link>_tip``).
"""

from __future__ import annotations

import difflib
import math
import re
import warnings
from dataclasses import dataclass

import numpy as np
import sympy as sp

from ..errors import ModelError, ModelWarning
from . import shapes
from .chain import (
    GROUND_NAME,
    Body,
    Branch,
    Constraint,
    FlexibleLink,
    Joint,
    Model,
    Offset,
    Parameter,
    Point,
    check_model_name,
    check_name,
    symbol,
)
from .expand import AXIS_TOLERANCE
from .urdf_tree import UrdfJoint, UrdfTree, read_tree, rpy

GRAVITY = Parameter("g", 9.81, "m/s²", "gravitational acceleration, along -z of the base")
BODY_SUFFIX = "_body"
# The point at a flexible link's frame as its beam's tip carries it, where the branches that hang
# from the link start: <link>_tip (<link>_tip2, ... when a URDF name has it; within the names'
# limit, as a link's name leaves room for <link>_body).
TIP_SUFFIX = "_tip"
MIMIC_PREFIX = "mimic_"
# An inertia tensor is refused when a principal moment is below zero, or one exceeds the sum of
# the other two, by more than this part of the largest moment: the rounding of the digits a
# URDF writes, not a fault of the body.
INERTIA_TOLERANCE = 1e-6
# ... and by more than the mass times this area (m²): tensors written as zeros with rounding
# noise (1e-20 kg·m² entries) have no largest moment to scale by.
INERTIA_FLOOR = 1e-12


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
    coordinates in the order of ``q`` (their limits and friction as data, their URDF names as
    ``name``) and the ``tip`` link (of a tree imported whole: the last joint's child link);
    ``renamed``: ``(kind, URDF name, name in the model)`` for each robot, joint or link name that
    was not a valid name; ``constraints``: the position constraints that make each ``<mimic>``
    joint follow its leader, the mimic joints ``dependent``."""

    model: Model
    tree: UrdfTree
    joints: tuple
    tip: str
    renamed: tuple = ()
    constraints: tuple = ()
    dependent: tuple = ()

    @property
    def coordinates(self) -> tuple:
        """The model's names of the coordinates, in the order of ``joints``."""
        names = {old: new for kind, old, new in self.renamed if kind == "joint"}
        return tuple(names.get(j.name, j.name) for j in self.joints)

    @property
    def start(self) -> dict:
        """Coordinate -> its position where the robot starts (0 rad or m), for each mimic joint
        the one its leader's start puts it at, so that the start meets the mimic constraints."""
        if not self.constraints:
            return {}
        solved = sp.solve([c.expression for c in self.constraints], [symbol(d) for d in self.dependent], dict=True)
        zero = {symbol(name): 0 for name in self.coordinates if name not in self.dependent}
        return {str(s): sp.sympify(v).subs(zero) for s, v in solved[0].items()} if solved else {}

    @property
    def limits(self) -> dict:
        """Coordinate name -> the URDF ``(lower, upper, velocity, unit)`` limits of its joint
        (None where the file gives none; a continuous joint has no position limits; unit "rad"
        or "m")."""
        out = {}
        for name, joint in zip(self.coordinates, self.joints):
            lower, upper, _, velocity = joint.limit
            if joint.type == "continuous":
                lower = upper = None
            out[name] = (lower, upper, velocity, "m" if joint.type == "prismatic" else "rad")
        return out


def import_urdf(path, tip: str | None = None, flexible: tuple = (), extra: tuple = (),
                parameters: tuple = (GRAVITY,), gravity=None, name: str | None = None, **model) -> ImportedRobot:
    """The URDF at ``path`` (or its :class:`UrdfTree`) as a model (see the module's docstring).

    ``tip``: the link the chain ends at (None: the whole tree, coordinates depth first);
    ``flexible``: :class:`FlexibleUrdfLink` s; ``extra``: ``(link, element)`` pairs of chain
    elements (points) to attach to a link's frame; ``parameters``, ``gravity`` (default
    ``(0, 0, -g)``), ``name`` (default the robot's) and any other :class:`Model` fields replace
    the defaults; the constraints of ``<mimic>`` joints come after any ``constraints`` given.
    Names that are not valid names are renamed (a :class:`ModelWarning` lists them). Raises
    ModelError naming the URDF element and the fix."""
    tree = path if isinstance(path, UrdfTree) else read_tree(path)
    branch = serial_branch(tree, tip)
    moving = [j for j in branch if j.type != "fixed"]
    if not moving:
        raise tree.error("the URDF has no revolute, continuous or prismatic joint on the chain; a model needs one")
    flex = {f.link: f for f in flexible}
    for link in list(flex) + [link for link, _ in extra]:
        _check_link_named(tree, link)
    own = name is None
    # a branch from the root link starts from its point, which must not read as the ground
    _, _, hanging = _groups(tree, moving)
    renamed = valid_names(tree, tree.name if own else None, moving,
                          (GROUND_NAME,) if hanging[tree.root] > 1 else ())
    if renamed:
        warnings.warn(f"{tree.path}: names that cannot stand in generated code renamed: "
                      + ", ".join(f"{kind} {old!r} -> {new}" for kind, old, new in renamed), ModelWarning,
                      stacklevel=2)
    new = {(kind, old): value for kind, old, value in renamed}
    joints = {j.name: new.get(("joint", j.name), j.name) for j in moving}
    links = {link: new.get(("link", link), link) for link in tree.links}
    chain = _chain(tree, moving, flex, extra, joints, links)
    if not flex and not any(isinstance(e, Body) for e in chain):
        raise tree.error("every link of the chain is massless (no <inertial> has a mass above 0), so no joint "
                         "moves any mass and the motion is undefined; give the links their masses")
    name = new.get(("robot", tree.name), tree.name) if own else name
    if not own:
        _check_names(tree, name)
    mimic = mimic_constraints(tree, moving, joints)
    g = sp.Symbol("g", real=True)
    model["constraints"] = tuple(model.get("constraints", ())) + tuple(c for c, _ in mimic)
    if mimic and model.get("dependent") is not None:
        model["dependent"] = tuple(model["dependent"]) + tuple(d for _, d in mimic)
    built = Model(name=name, parameters=tuple(parameters), chain=tuple(chain),
                  gravity=gravity if gravity is not None else (0, 0, -g), **model)
    end = moving[-1].child if tip is None else tip
    return ImportedRobot(built, tree, tuple(moving), end, renamed, tuple(c for c, _ in mimic),
                         tuple(d for _, d in mimic))


def serial_branch(tree: UrdfTree, tip: str | None) -> list[UrdfJoint]:
    """The joints from the base to ``tip``, or (``tip`` None) every joint of the tree, depth
    first (each link's child joints in file order, a joint's whole subtree before its next
    sibling), so that each joint comes after the joint it hangs from."""
    if tip is not None:
        _check_link_named(tree, tip)
        parent = {j.child: j for j in tree.joints}
        branch, link = [], tip
        while link != tree.root:
            branch.append(parent[link])
            link = parent[link].parent
        return branch[::-1]
    order, todo = [], list(reversed(tree.children(tree.root)))
    while todo:   # without recursion, so that a branch of any length is read
        joint = todo.pop()
        order.append(joint)
        todo += reversed(tree.children(joint.child))
    return order


def _check_link_named(tree: UrdfTree, link: str):
    if link not in tree.links:
        close = difflib.get_close_matches(str(link), list(tree.links), 1)
        hint = f"did you mean {close[0]!r}? " if close else ""
        raise tree.error(f"there is no <link name=\"{link}\">; {hint}the links are {', '.join(tree.links)}")


def _check_names(tree: UrdfTree, name: str):
    """A model name given in place of the robot's: the rules of model files."""
    try:
        check_model_name(name)
    except ModelError as exc:
        raise tree.error(f"{exc}") from None


def _valid(name: str, bare: bool, kind: str = "") -> bool:
    try:
        check_model_name(name) if kind == "robot" else check_name(name, "", bare=bare)
    except ModelError:
        return False
    return True


def valid_names(tree: UrdfTree, robot: str | None, moving: list, reserved: tuple = ()) -> tuple:
    """``(kind, URDF name, new name)`` for each name that cannot stand in generated code (the
    robot's unless ``robot`` is None, the coordinates' and the links'; a link named in
    ``reserved`` too), in file order: the characters outside letters, digits and ``_`` become
    ``_``, a name that does not start with a letter or is reserved gets its kind in front, and
    one that would meet a name already taken (or ``reserved``) gets ``_2``, ``_3``, ...; so the
    same file always gives the same names."""
    wanted = [("joint", j.name, True, 48) for j in moving]
    # a link's body is named <link>_body, which must be a name too
    wanted += [("link", link, False, 48 - len(BODY_SUFFIX)) for link in tree.links]
    if robot is not None:
        wanted.insert(0, ("robot", robot, False, 48))
    taken = {old for kind, old, bare, _ in wanted if kind != "robot" and _valid(old, bare)} | set(reserved)
    renamed = []
    for kind, old, bare, longest in wanted:
        if _valid(old, bare, kind) and len(old) <= longest and not (kind == "link" and old in reserved):
            continue
        stem = re.sub(r"[^A-Za-z0-9_]+", "_", str(old)).strip("_")
        if not stem[:1].isalpha() or not _valid(stem[:longest], bare, kind):
            stem = f"{kind}_{stem}".rstrip("_")
        new, k = stem[:longest], 1
        while new in taken or not _valid(new, bare, kind):
            k += 1
            new = f"{stem[:longest - len(str(k)) - 1]}_{k}"
        taken.add(new)
        renamed.append((kind, old, new))
    return tuple(renamed)


def mimic_constraints(tree: UrdfTree, moving: list, names: dict) -> list:
    """``(constraint, coordinate)`` for each ``<mimic>`` joint of the model: the position
    constraint ``mimic_<q>: q - (multiplier·q_leader + offset) = 0`` (no gains: it is linear in
    the coordinates, as the prescribed joints' are), the mimic joint dependent. A leader off the
    branch imported with ``tip`` is held at its zero position, as its branch is. ModelError for a
    leader the file does not define, or joints that mimic each other round a loop."""
    joints = {j.name: j for j in tree.joints}
    out = []
    for joint in moving:
        if joint.mimic is None:
            continue
        leader, multiplier, offset = joint.mimic
        where = f"<joint name=\"{joint.name}\"> <mimic joint=\"{leader}\">"
        seen, at = [joint.name], leader
        while at in joints:
            if at in seen:
                raise tree.error(f"{where}: the joints {' -> '.join(seen + [at])} mimic each other round a loop, so "
                                 f"none of them leads; remove one <mimic>")
            seen.append(at)
            at = joints[at].mimic[0] if joints[at].mimic is not None else None
        if leader not in joints:
            close = difflib.get_close_matches(str(leader), list(joints), 1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise tree.error(f"{where} names a joint the file does not define; {hint}name the joint it follows")
        q = symbol(names[joint.name])
        lead = symbol(names[leader]) if leader in names else sp.S.Zero
        name = MIMIC_PREFIX + names[joint.name]
        if not _valid(name, False):
            name = MIMIC_PREFIX + f"{len(out) + 1}"
        law = sp.Float(multiplier) * lead + sp.Float(offset) if multiplier != 1 or offset != 0 else lead
        out.append((Constraint(name, q - law), names[joint.name]))
    return out


def _chain(tree: UrdfTree, moving: list, flex: dict, extra: tuple, joints: dict, links: dict) -> list:
    """The chain: the base's group, then for each moving joint its offset, the joint and the
    group of links that moves with it; ``joints`` and ``links`` give the model's names. A joint
    that does not hang from the group just written starts a branch (:class:`Branch`) from the
    frame of the group it hangs from: the point at its head link's frame, or for a flexible
    head link the point ``<link>_tip`` at that frame as the beam's tip carries it."""
    held = {j.name for j in moving}
    heads, group, hanging = _groups(tree, moving)
    taken = {*links.values(), *joints.values(), *(link + BODY_SUFFIX for link in links.values()),
             *(point.name for _, point in extra)}
    anchor = {head: links[head] if head not in flex else _unique(links[head] + TIP_SUFFIX, taken) for head in heads}
    chain, head = [], tree.root
    for joint in [None, *moving]:
        if joint is not None:
            if group[joint.parent] != head:
                chain.append(Branch(anchor[group[joint.parent]]))
            chain += _offset(_frame(tree, group[joint.parent], held, joint.parent) @ joint.origin)
            kind = "prismatic" if joint.type == "prismatic" else "revolute"
            chain.append(Joint(joints[joint.name], kind, joint.axis, stiffness=joint.stiffness,
                               damping=joint.damping, rest=joint.rest))
            head = joint.child
        tip = anchor[head] if head in flex and hanging[head] > 1 else None
        chain += _group(tree, head, held, flex.get(head), extra, joint, links, tip)
    return chain


def _unique(name: str, taken: set) -> str:
    """``name``, or when it is taken ``name2``, ``name3``, ... (the first one free)."""
    out, k = name, 1
    while out in taken:
        k += 1
        out = f"{name}{k}"
    taken.add(out)
    return out


def _groups(tree: UrdfTree, moving: list) -> tuple:
    """The head links (the root, then each moving joint's child), the head of each link's group
    (the links that move with it) and the number of moving joints that hang from each group."""
    held = {j.name for j in moving}
    heads = [tree.root] + [j.child for j in moving]
    group = {link: head for head in heads for link, _ in _members(tree, head, held)}
    return heads, group, {head: sum(group[j.parent] == head for j in moving) for head in heads}


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


def _group(tree, head, held, flexible, attached, joint, names, tip=None) -> list:
    """The elements of the links moving with ``head``: one body of their combined inertials (or
    the beam of a flexible link, after which the links fixed to it follow its tip, and the point
    ``tip`` when one is named), a point at each link's frame (named as ``names`` says), then the
    points ``attached`` (``(link, Point)`` pairs) to any of them."""
    members = _members(tree, head, held)
    out = [Point(names[head], (0, 0, 0))]
    weighed = members
    if flexible is not None:
        out += _beam(flexible) + ([Point(tip)] if tip is not None else [])
        weighed = members[1:]   # the link's own inertial gives way to the beam
    with_inertial = [(tree.links[link], T) for link, T in weighed if tree.links[link]]
    if joint is not None:   # the base's links never move, so their inertia cannot act: not checked
        for link, _ in weighed:
            if tree.links[link]:
                _check_inertia(tree, link, tree.links[link])
    if joint is not None and flexible is None and not with_inertial:
        raise tree.error(f"<link name=\"{head}\">, moved by <joint name=\"{joint.name}\">, has no <inertial> (nor "
                         f"has any link fixed to it); add <inertial> with its mass, origin and inertia (a mass of 0 "
                         f"for a massless link)")
    H = sum((T @ _pseudo_inertia(inertial) @ T.T for inertial, T in with_inertial), np.zeros((4, 4)))
    if H[3, 3] > 0:
        H = (H + H.T) / 2   # exactly symmetric, as a pseudo-inertia must be
        out.append(Body(names[head] + BODY_SUFFIX, sp.ImmutableMatrix(H.tolist())))
    out += [Point(names[link], tuple(float(v) for v in T[:3, 3])) for link, T in members[1:]]
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


def _check_inertia(tree: UrdfTree, link: str, inertial):
    """Refuse an inertia tensor no body has: a principal moment below zero (the tensor is not
    positive semi-definite), or one larger than the sum of the other two (the triangle
    inequality I1 + I2 >= I3, which ∫(y² + z²) dm etc. obey), beyond INERTIA_TOLERANCE."""
    tensor = inertial.inertia
    moments = np.linalg.eigvalsh((tensor + tensor.T) / 2)
    slack = INERTIA_TOLERANCE * float(np.abs(moments).max()) + INERTIA_FLOOR * inertial.mass
    where = f"<link name=\"{link}\"> <inertia>"
    shown = ", ".join(f"{m:.6g}" for m in moments)
    if moments[0] < -slack:
        raise tree.error(f"{where} is not positive semi-definite: its principal moments are {shown} kg·m², one "
                         f"below zero, which no body has; correct ixx ... iyz (a diagonal term below zero, or "
                         f"off-diagonal terms too large for the diagonal)")
    if moments[0] + moments[1] < moments[2] - slack:
        raise tree.error(f"{where} breaks the triangle inequality of principal moments: {moments[0]:.6g} + "
                         f"{moments[1]:.6g} < {moments[2]:.6g} kg·m², which no body has (each moment is at most "
                         f"the sum of the other two); correct ixx ... iyz")


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
