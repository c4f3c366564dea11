"""A URDF file read into plain data: its links, its joints in file order and the tree they make,
checked for what a gpmegen chain can hold (one tree fixed to the world; revolute, continuous,
prismatic and fixed joints).

The XML is parsed strictly first (lxml, which the URDF parser uses itself), because the parser,
yourdfpy, falls back to a forgiving mode that would read a broken file silently; yourdfpy then
reads the elements. Meshes and visuals are never loaded: the dynamics does not need them.
"""

from __future__ import annotations

import difflib
import functools
import io
import logging
import math
from dataclasses import dataclass

import numpy as np

from ..errors import ModelError
from ..user_files import read_user_file

SUPPORTED = ("revolute", "continuous", "prismatic", "fixed")
# gpmegen's URDF extension: <gpmegen:spring stiffness="..." damping="..." rest="..."/> in a <joint>, the
# spring to q = 0 and the viscous damper that URDF cannot hold (gpmegen export writes it).
NAMESPACE = "urn:gpmegen:urdf:1"
SPRING = f"{{{NAMESPACE}}}spring"
# Joints URDF knows that a chain fixed to the world cannot hold, with what to do instead.
UNSUPPORTED = {
    "floating": "a floating base is not a chain fixed to the world; make the joint fixed (or remove it and "
                "its parent link)",
    "planar": "a planar joint has three freedoms; replace it by two prismatic joints and a revolute joint",
}


@dataclass(frozen=True)
class Inertial:
    """A link's ``<inertial>``: mass (kg), the centre-of-mass frame as a 4x4 transform in the
    link frame, the inertia tensor about the centre in that frame (3x3, kg·m²)."""

    mass: float
    origin: np.ndarray
    inertia: np.ndarray


@dataclass(frozen=True)
class UrdfJoint:
    """A ``<joint>``: its origin (4x4 transform of the child frame in the parent frame), unit
    axis in the joint frame, and the data gpmegen keeps but does not use for the dynamics
    (``limit``: lower, upper (rad or m), effort (N·m or N), velocity (rad/s or m/s), None where
    the file gives none; ``friction``). ``damping`` (N·m·s/rad or N·s/m) acts as a viscous
    damper on the coordinate, ``stiffness`` (N·m/rad or N/m) as a spring to ``q = rest`` (rad or
    m, default 0); they come from ``<gpmegen:spring>`` when the joint has one, the damping else
    from ``<dynamics>``."""

    name: str
    type: str
    parent: str
    child: str
    origin: np.ndarray
    axis: tuple
    limit: tuple
    damping: float
    friction: float
    stiffness: float = 0.0
    mimic: tuple | None = None   # <mimic>: (leader joint, multiplier, offset), q = multiplier·q_leader + offset
    rest: float = 0.0


@dataclass(frozen=True)
class UrdfTree:
    """The file's links (name -> Inertial or None), its joints in file order, the root link."""

    path: str
    name: str
    links: dict
    joints: tuple
    root: str

    def children(self, link: str) -> list[UrdfJoint]:
        """The joints whose parent is ``link``, in file order."""
        return self._children.get(link, [])

    @functools.cached_property
    def _children(self) -> dict:
        # indexed once: a scan of every joint per link made long chains quadratic
        out: dict[str, list] = {}
        for j in self.joints:
            out.setdefault(j.parent, []).append(j)
        return out

    def error(self, message: str) -> ModelError:
        return ModelError(f"{self.path}: {message}")


def rpy(R) -> tuple[float, float, float]:
    """URDF's roll, pitch, yaw of a rotation matrix, ``R = Rz(yaw) Ry(pitch) Rx(roll)``."""
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) > 1e-12:
        return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])
    # pitch ±π/2: only yaw ∓ roll is defined; yaw 0 keeps R
    return math.atan2(math.copysign(1.0, pitch) * R[0, 1], R[1, 1]), pitch, 0.0


def read_tree(path) -> UrdfTree:
    """The URDF file at ``path`` as a checked tree; ModelError naming the element and the fix."""
    file = str(path)
    # every reader of URDFs (model files, `gpmegen build robot.urdf`, import_urdf from Python)
    # comes through here: a device, FIFO or huge file is refused before it is read
    raw = read_user_file(path, "the URDF file", ModelError)
    robot, root = _parse(file, raw)
    elements = {kind: {e.get("name"): e for e in root.findall(kind)} for kind in ("link", "joint")}
    links = {}
    for link in robot.links:
        if link.name in links:
            raise ModelError(f"{file}: <link name=\"{link.name}\"> appears twice; give each link its own name")
        links[link.name] = _inertial(file, link, elements["link"].get(link.name))
    joints = tuple(_joint(file, j, links, elements["joint"].get(j.name)) for j in robot.joints)
    names = [j.name for j in joints]
    for k, name in enumerate(names):
        if name in names[:k]:
            raise ModelError(f"{file}: <joint name=\"{name}\"> appears twice; give each joint its own name")
    return UrdfTree(file, robot.name, links, joints, _root(file, links, joints))


def _parse(file: str, raw: bytes):
    import yourdfpy
    from lxml import etree

    try:
        root = etree.fromstring(raw)
    except etree.XMLSyntaxError as exc:
        line = exc.lineno or 1
        raise ModelError(f"{file}:{line}: the URDF is not well-formed XML ({exc.msg}); fix the XML") from None
    quiet = logging.getLogger("yourdfpy")   # it logs what it tolerates; errors here are raised
    level = quiet.level
    quiet.setLevel(logging.CRITICAL)
    try:
        with np.errstate(invalid="ignore"):   # an inf angle: its transform is checked after
            robot = yourdfpy.URDF.load(io.BytesIO(raw), build_scene_graph=False, load_meshes=False,
                                       build_collision_scene_graph=False, load_collision_meshes=False).robot
    except Exception as exc:  # the parser's own errors have no common type
        raise ModelError(f"{file}: the URDF cannot be read ({type(exc).__name__}: {exc}); fix the element it "
                         f"names") from None
    finally:
        quiet.setLevel(level)
    return robot, root


def _number(file, value, what, default=0.0) -> float:
    if value is None:
        return default
    try:
        number = float(value)
    except (TypeError, ValueError):
        number = float("nan")
    if not np.isfinite(number):
        raise ModelError(f"{file}: {what} is {value!r}, not a finite number; write a number")
    return number


def _floats(text) -> list[float]:
    """The numbers of an attribute such as ``xyz="0 0 1"``, nan for any that is not one."""
    out = []
    for word in str(text).split():
        try:
            out.append(float(word))
        except ValueError:
            out.append(float("nan"))
    return out


def _finite_origin(file, where, element, matrix) -> np.ndarray:
    """``matrix`` (the parser's transform of ``element``'s ``<origin>``) when finite; else
    ModelError naming the attribute that is not, with its text."""
    if np.all(np.isfinite(matrix)):
        return matrix
    origin = element.find("origin") if element is not None else None
    for key in ("xyz", "rpy"):
        text = origin.get(key) if origin is not None else None
        if text is not None and not np.all(np.isfinite(_floats(text))):
            raise ModelError(f"{file}: {where} <origin {key}> is {text!r}, not three finite numbers; write numbers "
                             f"({'m' if key == 'xyz' else 'rad'})")
    raise ModelError(f"{file}: {where} <origin> is not a finite transform; write finite numbers in its xyz and rpy")


def _inertial(file, link, element) -> Inertial | None:
    inertial = link.inertial
    if inertial is None:
        return None
    where = f"<link name=\"{link.name}\"> <inertial>"
    mass = _number(file, inertial.mass, f"{where} <mass value>", default=float("nan"))
    if mass < 0:
        raise ModelError(f"{file}: {where} has the mass {mass:g} kg; give a mass of 0 or more")
    inertia = np.zeros((3, 3)) if inertial.inertia is None else np.asarray(inertial.inertia, float)
    if not np.all(np.isfinite(inertia)):
        raise ModelError(f"{file}: {where} <inertia> holds a value that is not a finite number; write numbers")
    origin = np.eye(4) if inertial.origin is None else np.asarray(inertial.origin, float)
    origin = _finite_origin(file, where, element.find("inertial") if element is not None else None, origin)
    return Inertial(mass, origin, inertia)


def _joint(file, joint, links, element) -> UrdfJoint:
    where = f"<joint name=\"{joint.name}\">"
    if joint.type in UNSUPPORTED:
        raise ModelError(f"{file}: {where} is {joint.type}: {UNSUPPORTED[joint.type]}")
    if joint.type not in SUPPORTED:
        raise ModelError(f"{file}: {where} has the unknown type {joint.type!r}; use one of {', '.join(SUPPORTED)}")
    for role in ("parent", "child"):
        link = getattr(joint, role)
        if link not in links:
            close = difflib.get_close_matches(str(link), list(links), 1)
            hint = f" (did you mean {close[0]!r}?)" if close else ""
            raise ModelError(f"{file}: {where} names the {role} link {link!r}, which the file does not "
                             f"define{hint}; add <link name=\"{link}\"> or correct the name")
    limit = joint.limit
    numbers = tuple(None if limit is None or getattr(limit, key) is None
                    else _number(file, getattr(limit, key), f"{where} <limit {key}>")
                    for key in ("lower", "upper", "effort", "velocity"))
    dynamics = joint.dynamics
    damping = _number(file, getattr(dynamics, "damping", None), f"{where} <dynamics damping>")
    friction = _number(file, getattr(dynamics, "friction", None), f"{where} <dynamics friction>")
    if damping < 0:
        raise ModelError(f"{file}: {where} <dynamics damping> is {damping:g}; give a damping of 0 or more")
    axis = (1.0, 0.0, 0.0) if joint.axis is None else tuple(float(a) for a in joint.axis)
    if not np.all(np.isfinite(axis)):
        text = element.find("axis").get("xyz") if element is not None and element.find("axis") is not None else axis
        raise ModelError(f"{file}: {where} <axis xyz> is {text!r}, not three finite numbers; write a unit vector")
    origin = np.eye(4) if joint.origin is None else np.asarray(joint.origin, float)
    origin = _finite_origin(file, where, element, origin)
    spring = element.find(SPRING) if element is not None else None
    stiffness = rest = 0.0
    if spring is not None:
        here = f"{where} <gpmegen:spring"
        stiffness = _number(file, spring.get("stiffness"), f"{here} stiffness>")
        rest = _number(file, spring.get("rest"), f"{here} rest>")
        damping = _number(file, spring.get("damping"), f"{here} damping>")
        if stiffness < 0 or damping < 0:
            raise ModelError(f"{file}: {here}> has a negative stiffness or damping; give values of 0 or more")
    mimic = None
    if joint.mimic is not None:
        raw = element.find("mimic") if element is not None else None
        mimic = (joint.mimic.joint,) + tuple(
            _number(file, raw.get(key) if raw is not None else value, f"{where} <mimic {key}>", default)
            for key, value, default in (("multiplier", joint.mimic.multiplier, 1.0),
                                        ("offset", joint.mimic.offset, 0.0)))
    return UrdfJoint(joint.name, joint.type, joint.parent, joint.child, origin, axis, numbers, damping, friction,
                     stiffness, mimic, rest)


def _root(file, links, joints) -> str:
    parent_joint: dict[str, str] = {}
    for j in joints:
        if j.child in parent_joint:
            raise ModelError(f"{file}: <link name=\"{j.child}\"> is the child of both <joint name="
                             f"\"{parent_joint[j.child]}\"> and <joint name=\"{j.name}\">, a closed loop, which a "
                             f"URDF tree cannot hold; remove one of the two joints")
        parent_joint[j.child] = j.name
    roots = [name for name in links if name not in parent_joint]
    if len(roots) > 1:
        raise ModelError(f"{file}: the links {roots[0]!r} and {roots[1]!r} both have no parent joint; a URDF is one "
                         f"tree: join them by a joint")
    if not roots:
        raise ModelError(f"{file}: every link is the child of a joint, so the joints close a loop; remove a joint "
                         f"so that one link (the base) has no parent")
    reached, todo = {roots[0]}, [roots[0]]
    while todo:
        link = todo.pop()
        for j in joints:
            if j.parent == link and j.child not in reached:
                reached.add(j.child)
                todo.append(j.child)
    lost = [name for name in links if name not in reached]
    if lost:
        raise ModelError(f"{file}: <link name=\"{lost[0]}\"> cannot be reached from the base {roots[0]!r}: its joints "
                         f"close a loop; remove one of them")
    return roots[0]
