"""URDF export: a model's discretized chain as a URDF robot, for URDF viewers and other engines.

The expanded chain (:func:`gpmegen.model.expand.expand`: flexible links already cut into rfes and
sdes) is walked at the parameter defaults. Each joint starts a new link, a child of the link it
hangs from (a branch starts from its parent point's frame, so a tree is written as the URDF tree
it is); the offsets before it are its ``<origin>``; the bodies between two joints make that
link's ``<inertial>`` (their pseudo-inertias added) and a visual box of the same mass and
principal moments; an sde's rotations are consecutive joints, so the links between them have
zero mass. Named points are links fixed to theirs. A joint's spring and damper, which URDF cannot
hold, are written in the extension element ``<gpmegen:spring stiffness="..." damping="..."
rest="..."/>`` (namespace :data:`NAMESPACE`; N·m/rad and N·m·s/rad, or N/m and N·s/m) inside the
``<joint>``, the damper also as URDF's own ``<dynamics damping>``. Gravity, constraints and forces
between points are not exported. A model with geared motors (``motor`` on a joint) is refused:
URDF has no rotor inertia behind a gear, and a series-elastic motor's coordinate would be a free
joint of no mass.
"""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import sympy as sp

from ..errors import ModelError
from .chain import AXES, GROUND_NAME, Body, Branch, Joint, Model, Offset, Point
from .expand import expand
from .urdf_tree import NAMESPACE, SPRING, rpy

ET.register_namespace("gpmegen", NAMESPACE)


def urdf_text(model: Model) -> str:
    """The URDF of ``model`` at its parameter defaults (see the module's docstring)."""
    values = {p.symbol: p.default for p in model.parameters}
    flat = expand(model)
    geared = [e.name for e in model.chain if isinstance(e, Joint) and e.motor is not None]
    if geared:
        raise ModelError(f"model {model.name}: the motors of {', '.join(geared)} have no URDF form (a rotor's "
                         f"inertia behind a gear); export it as CasADi or an FMU, which hold them, or remove "
                         f"the motors")
    robot = ET.Element("robot", {"name": model.name})
    links = [_Link(f"{model.name}_base")]
    joints = []   # (parent link, child link, joint, its origin in the parent link's frame)
    current, T = 0, np.eye(4)   # the current link, and the current frame in its frame
    frames = {}   # point -> (its link, the frame a branch from it starts from)
    for element in flat.elements:
        if isinstance(element, Offset):
            T = T @ _offset(element, values)
        elif isinstance(element, Body):
            links[current].add(T @ _number_matrix(element.pseudo_inertia, values) @ T.T, element.name)
        elif isinstance(element, Point):
            position = (T @ [*(_value(v, values) for v in element.position), 1.0])[:3]
            links[current].points.append((element.name, position))
            start = T.copy()
            start[:3, 3] = position
            frames[element.name] = (current, start)
        elif isinstance(element, Branch):
            current, T = (0, np.eye(4)) if element.parent == GROUND_NAME else frames[element.parent]
        else:
            links.append(_Link(f"{element.name}_link"))
            joints.append((current, len(links) - 1, element, T))
            current, T = len(links) - 1, np.eye(4)
    for link in links:
        link.write(robot)
    for parent, child, joint, origin in joints:
        _joint(robot, links[parent].name, links[child].name, joint, origin, values)
    ET.indent(robot, space="  ")
    return ET.tostring(robot, encoding="unicode", xml_declaration=True) + "\n"


class _Link:
    """A link being made: the pseudo-inertia of its bodies in its frame, their names, its points
    and the joint that leaves it."""

    def __init__(self, name: str):
        self.name = name
        self.H = np.zeros((4, 4))
        self.bodies: list[str] = []
        self.points: list = []
        self.joint_out = None

    def add(self, H, body: str):
        self.H += H
        self.bodies.append(body)
        if len(self.bodies) == 1:
            self.name = body   # a link is named after its (first) body

    def write(self, robot):
        link = ET.SubElement(robot, "link", {"name": self.name})
        mass, centre, inertia = _inertial(self.H)
        inertial = ET.SubElement(link, "inertial")
        ET.SubElement(inertial, "origin", {"xyz": _vector(centre), "rpy": "0 0 0"})
        ET.SubElement(inertial, "mass", {"value": _number(mass)})
        ET.SubElement(inertial, "inertia", {key: _number(inertia[i, j]) for key, (i, j) in
                                            (("ixx", (0, 0)), ("ixy", (0, 1)), ("ixz", (0, 2)),
                                             ("iyy", (1, 1)), ("iyz", (1, 2)), ("izz", (2, 2)))})
        if mass > 0:
            _visual_box(link, mass, centre, inertia)
        for name, position in self.points:
            ET.SubElement(robot, "link", {"name": name})
            joint = ET.SubElement(robot, "joint", {"name": f"{name}_fixed", "type": "fixed"})
            ET.SubElement(joint, "parent", {"link": self.name})
            ET.SubElement(joint, "child", {"link": name})
            ET.SubElement(joint, "origin", {"xyz": _vector(position), "rpy": "0 0 0"})


def _joint(robot, parent: str, child: str, joint: Joint, T, values):
    kind = "continuous" if joint.kind == "revolute" else "prismatic"
    element = ET.SubElement(robot, "joint", {"name": joint.name, "type": kind})
    ET.SubElement(element, "parent", {"link": parent})
    ET.SubElement(element, "child", {"link": child})
    ET.SubElement(element, "origin", {"xyz": _vector(T[:3, 3]), "rpy": _vector(rpy(T[:3, :3]))})
    axis = np.eye(3)[AXES.index(joint.axis)] if isinstance(joint.axis, str) else np.array(joint.axis, float)
    ET.SubElement(element, "axis", {"xyz": _vector(axis)})
    if kind == "prismatic":   # URDF requires limits on a prismatic joint; gpmegen has none
        ET.SubElement(element, "limit", {"lower": "-1e3", "upper": "1e3", "effort": "0", "velocity": "0"})
    stiffness, damping, rest = (_value(getattr(joint, key), values) for key in ("stiffness", "damping", "rest"))
    if damping:
        ET.SubElement(element, "dynamics", {"damping": _number(damping)})
    if stiffness or damping:
        spring = {"stiffness": _number(stiffness), "damping": _number(damping)}
        ET.SubElement(element, SPRING, {**spring, "rest": _number(rest)} if rest else spring)


def _value(expr, values) -> float:
    number = sp.sympify(expr).subs(values)
    try:
        return float(number)
    except TypeError:
        raise ModelError(f"cannot export a value that depends on more than the parameters: {expr}") from None


def _number_matrix(matrix, values) -> np.ndarray:
    return np.array([[_value(v, values) for v in row] for row in sp.Matrix(matrix).tolist()])


def _offset(offset: Offset, values) -> np.ndarray:
    """The 4x4 transform of an offset: translation, then the rotations in order."""
    T = np.eye(4)
    T[:3, 3] = [_value(v, values) for v in offset.translation]
    for axis, angle in offset.rotations:
        c, s = math.cos(_value(angle, values)), math.sin(_value(angle, values))
        k = AXES.index(axis)
        i, j = (k + 1) % 3, (k + 2) % 3
        R = np.eye(3)
        R[i, i] = R[j, j] = c
        R[i, j], R[j, i] = -s, s
        T[:3, :3] = T[:3, :3] @ R
    return T


def _inertial(H):
    """Mass (kg), centre of mass (m) and the inertia tensor about it (kg·m²) of a pseudo-inertia."""
    mass = H[3, 3]
    if mass <= 0:
        return 0.0, np.zeros(3), np.zeros((3, 3))
    centre = H[:3, 3] / mass
    second = H[:3, :3] - mass * np.outer(centre, centre)   # ∫ r rᵀ dm about the centre
    return mass, centre, np.trace(second) * np.eye(3) - second


def _visual_box(link, mass, centre, inertia):
    """A box of the body's mass and principal moments, along its principal axes."""
    moments, axes = np.linalg.eigh(inertia)
    if np.linalg.det(axes) < 0:
        axes[:, 2] = -axes[:, 2]
    a, b, c = moments
    sides = [math.sqrt(max(6 * (y + z - x) / mass, 0.0)) for x, y, z in ((a, b, c), (b, c, a), (c, a, b))]
    visual = ET.SubElement(link, "visual")
    ET.SubElement(visual, "origin", {"xyz": _vector(centre), "rpy": _vector(rpy(axes))})
    geometry = ET.SubElement(visual, "geometry")
    ET.SubElement(geometry, "box", {"size": _vector(np.maximum(sides, 1e-3))})


def _number(x) -> str:
    return repr(float(x))


def _vector(v) -> str:
    return " ".join(_number(x) for x in v)
