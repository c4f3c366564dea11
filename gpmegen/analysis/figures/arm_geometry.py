"""What a picture of the arm shows, computed from the generated body transforms ``T``: the
skeleton (lines from the base through the origin of every body's frame to the tool: each body's
frame joined to the frame of the body it hangs from, so a tree is drawn branch by branch and a
serial chain as one line in chain order), each rigid body as the box of its inertia (on
request), the rfes of each flexible link as a chain of segments, the named points, with the
elastic deformation optionally magnified. Pure NumPy; drawing is
:mod:`gpmegen.analysis.figures.animation`.

A body's frame is where the chain puts its joint (a URDF link's frame is its joint's), so the
skeleton is the drawing robotics users read: it shows the joints and the links between them
whatever the inertial data say.

A body's box is the uniform box with the body's mass, centre of mass and second moments (its
pseudo-inertia ``H``): along each principal axis of the second moments ``σ²`` about the centre,
the half-size ``√(3σ²)``. A bar is drawn as itself, a cylinder as the box around it (½√3 of its
radius), a point mass as a point: one rule for every body, also those given by an inertia tensor
alone.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import sympy as sp

from ...model.chain import Body, FlexibleLink, Model, Point
from ...model.expand import expand
from ...model.rfem import discretize
from ...model.topology import GROUND
from ..post.coordinates import elastic_coordinates
from ..post.driving import point_constraints

# The 12 edges of a box, as pairs of its corners (corner k has signs from the bits of k).
_CORNERS = np.array([[(k >> a) & 1 for a in range(3)] for k in range(8)]) * 2.0 - 1.0
_EDGES = [(a, b) for a in range(8) for b in range(a + 1, 8) if bin(a ^ b).count("1") == 1]


@dataclass(frozen=True)
class Box:
    """A body's box in its own frame: ``center`` (3,) m, ``axes`` (3, 3) unit columns,
    ``half`` (3,) half-sizes in m along them."""

    center: np.ndarray
    axes: np.ndarray
    half: np.ndarray


def inertia_box(H) -> Box:
    """The uniform box with the mass, centre and second moments of the pseudo-inertia ``H`` (4x4)."""
    H = np.asarray(H, dtype=float)
    mass = H[3, 3]
    center = H[:3, 3] / mass
    spread = H[:3, :3] / mass - np.outer(center, center)
    variances, axes = np.linalg.eigh((spread + spread.T) / 2)
    return Box(center, axes, np.sqrt(3.0 * np.clip(variances, 0.0, None)))


@dataclass(frozen=True)
class Scene:
    """The drawn parts of a model: ``bodies`` in the order of the generated transforms, with
    their ``boxes`` (None for an rfe: rfes are drawn as segments); ``links``: the indices of the
    rfes of each flexible link, base first, and their far ends in their own frames (3,);
    ``points`` named points; ``traced``: the points whose path is drawn (those the programmed
    constraints hold, see :func:`gpmegen.analysis.post.driving.point_constraints`); ``elastic``:
    indices of the flexible links' sde coordinates (the deformation; a sprung joint is a joint);
    ``tool``: the index in
    ``points`` of the point that ends the skeleton (None when no point lies beyond the last body);
    ``parents``: for each node of the skeleton after the base, the node it is drawn from
    (:func:`skeleton_parents`)."""

    bodies: tuple
    boxes: tuple
    links: tuple
    ends: dict
    points: tuple
    traced: tuple
    elastic: np.ndarray
    tool: int | None = None
    parents: tuple = ()


def scene(model: Model, loaded) -> Scene:
    """The scene of the symbolic ``model`` as ``loaded`` (its generated code bound to parameter
    values, whose transforms and points are drawn)."""
    values = {p.symbol: loaded.params[p.name] for p in model.parameters}
    inertias = {e.name: e.pseudo_inertia for e in expand(model).elements if isinstance(e, Body)}
    rfes = [[part.name for part in discretize(link) if isinstance(part, Body)]
            for link in model.chain if isinstance(link, FlexibleLink)]
    flexible = {name for link in rfes for name in link}
    boxes, ends = [], {}
    for name in loaded.bodies:
        box = inertia_box(sp.Matrix(inertias[name]).subs(values).evalf())
        if name in flexible:  # an rfe is uniform along its x from its origin: its far end is twice its centre
            ends[loaded.bodies.index(name)] = 2.0 * box.center
            boxes.append(None)
        else:
            boxes.append(box)
    links = tuple(tuple(loaded.bodies.index(name) for name in link) for link in rfes)
    traced = tuple(point for point in loaded.points if point in point_constraints(model))
    elastic = elastic_coordinates(model, loaded)
    tool = tool_point(model, traced)
    return Scene(tuple(loaded.bodies), tuple(boxes), links, ends, tuple(loaded.points), traced, elastic,
                 None if tool is None else loaded.points.index(tool), skeleton_parents(model, loaded.bodies, tool))


def _moves(topology, mover: int, joint: int) -> bool:
    """Whether what ``joint`` moves is carried by ``mover`` (the ground carries everything)."""
    return mover == GROUND or (joint != GROUND and mover in topology.supports[joint])


def tool_point(model: Model, traced) -> str | None:
    """The point that ends the skeleton: of the points beyond the last body of their branch (no
    body after them in chain order is moved by what moves them), the last that the programmed
    constraints hold (the tool the task moves), else the last in chain order; None when there is
    none. For a serial chain: the points beyond its last body."""
    flat = expand(model)
    topology, elements = flat.topology, flat.elements
    joint = dict(zip([e.name for e in elements if isinstance(e, Point)], topology.point_joint))
    bodies = list(zip([k for k, e in enumerate(elements) if isinstance(e, Body)], topology.body_joint))
    beyond = [e.name for k, e in enumerate(elements) if isinstance(e, Point)
              and not any(at > k and _moves(topology, joint[e.name], j) for at, j in bodies)]
    held = [name for name in beyond if name in traced]
    return (held or beyond or [None])[-1]


def skeleton_parents(model: Model, bodies, tool: str | None) -> tuple:
    """For each node of the skeleton after the base (node 0: the origin of {0}; then the frames
    of ``bodies``, in that order; then the ``tool`` point when there is one), the node it is
    drawn from: the last body before it whose joint moves it (a body of the ground moves every
    body), else the base. A serial chain gives ``(0, 1, 2, ...)``: one line in chain order."""
    flat = expand(model)
    topology = flat.topology
    body_joint = dict(zip([e.name for e in flat.elements if isinstance(e, Body)], topology.body_joint))
    joints = [body_joint[name] for name in bodies]
    if tool is not None:
        joints.append(dict(zip([e.name for e in flat.elements if isinstance(e, Point)], topology.point_joint))[tool])
    parents = []
    for k, joint in enumerate(joints):
        before = [i for i in range(min(k, len(bodies))) if _moves(topology, joints[i], joint)]
        parents.append(before[-1] + 1 if before else 0)
    return tuple(parents)


def skeleton_lines(skeleton, parents) -> np.ndarray:
    """The ``skeleton`` nodes (k, 3) as lines, with a NaN row between two lines: a node drawn
    from the node before it continues the line, any other starts a new line at its parent. A
    serial chain is one line, the nodes themselves."""
    rows = [skeleton[:1]]
    for k, parent in enumerate(parents, start=1):
        if parent != k - 1:
            rows += [np.full((1, 3), np.nan), skeleton[parent:parent + 1]]
        rows.append(skeleton[k:k + 1])
    return np.vstack(rows)


def magnified(q, elastic, factor: float) -> np.ndarray:
    """``q`` (k, n) with the ``elastic`` coordinates scaled by ``factor`` about zero (the rigid arm
    at the same joint coordinates): ``factor`` 1 the motion itself, 0 the rigid arm."""
    q = np.array(q, dtype=float)
    q[..., elastic] *= factor
    return q


@dataclass(frozen=True)
class Pose:
    """The drawn geometry at one state, in {0} (m): ``skeleton`` (n_bodies + 1 or + 2, 3) the
    origin of {0}, of every body's frame in the order of the transforms and the tool point;
    ``lines``: the skeleton as drawn, each node joined to its parent (:func:`skeleton_lines`);
    ``edges`` (n_edges, 2, 3) of the bodies' boxes (none when they are not drawn); ``chains``
    one (n_rfe + 1, 3) polyline per flexible link, through the rfes' origins to the link's far
    end; ``points`` (n_points, 3)."""

    skeleton: np.ndarray
    edges: np.ndarray
    chains: tuple
    points: np.ndarray
    lines: np.ndarray


def pose(s: Scene, loaded, q, boxes: bool = False) -> Pose:
    """The geometry of the scene at the coordinates ``q`` (n,), as drawn (magnify first); the
    bodies' boxes only with ``boxes``."""
    T = loaded.transforms(q)
    points = loaded.point_positions(q).reshape(-1, 3)
    tool = points[[s.tool]] if s.tool is not None else np.empty((0, 3))
    skeleton = np.vstack([np.zeros((1, 3)), T[:, :3, 3], tool])
    edges = []
    for b, box in enumerate(s.boxes):
        if box is None or not boxes:
            continue
        corners = box.center + (_CORNERS * box.half) @ box.axes.T  # (8, 3) in the body frame
        world = corners @ T[b, :3, :3].T + T[b, :3, 3]
        edges += [(world[i], world[j]) for i, j in _EDGES]
    chains = tuple(np.vstack([T[link, :3, 3], T[link[-1], :3, :3] @ s.ends[link[-1]] + T[link[-1], :3, 3]])
                   for link in s.links)
    edges = np.array(edges).reshape(-1, 2, 3)
    parents = s.parents or tuple(range(len(skeleton) - 1))
    return Pose(skeleton, edges, chains, points, skeleton_lines(skeleton, parents))


def poses(s: Scene, loaded, q, factor: float = 1.0, boxes: bool = False) -> list[Pose]:
    """The poses at the samples ``q`` (k, n) with the deformation magnified by ``factor``; the
    bodies' boxes only with ``boxes``."""
    return [pose(s, loaded, x, boxes) for x in magnified(q, s.elastic, factor)]


def everything(drawn: list[Pose], paths) -> np.ndarray:
    """Every point (k, 3) of ``drawn``, the boxes' corners included, and of the ``paths`` (k, j, 3)
    of traced points: what fixed axes for all frames hold."""
    return np.vstack([np.vstack([p.skeleton, p.edges.reshape(-1, 3), *p.chains, p.points]) for p in drawn]
                     + [np.asarray(paths).reshape(-1, 3)])


# A drawing lies in a plane when no point of it is farther from the plane than this fraction of
# its size: a thousandth of a pixel of a 1000-pixel image, far below anything a view could show,
# and far above the rounding of the transforms (1e-16 of the size).
FLAT = 1e-6


def drawn_points(drawn: list[Pose], paths) -> np.ndarray:
    """Every point (k, 3) of ``drawn`` that a line or marker passes through, and of the ``paths``
    (k, j, 3) of traced points: the skeleton, the rfe chains and the named points (the boxes are
    left out: a body's box has a thickness whatever the motion)."""
    return np.vstack([np.vstack([p.skeleton, *p.chains, p.points]) for p in drawn]
                     + [np.asarray(paths).reshape(-1, 3)])


@dataclass(frozen=True)
class Plane:
    """A plane of {0} seen face-on: ``across`` (3,) the unit vector drawn rightwards, ``up`` (3,)
    the unit vector drawn upwards, ``normal`` = across × up (towards the viewer); ``above``
    whether gravity is along -``normal`` (the plane seen from above, gravity into the page)."""

    across: np.ndarray
    up: np.ndarray
    normal: np.ndarray
    above: bool = False


def flatness(points) -> tuple[np.ndarray, float, float, np.ndarray | None]:
    """The plane nearest to ``points`` (k, 3) in least squares: its unit normal, the largest
    distance of a point from it (m), the size of the points (the largest of their extents along
    x, y, z, m) and, when they lie on one line (within :data:`FLAT` of their size), its
    direction (None otherwise; the plane is then any through the line, the normal one of them)."""
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    points = points[np.isfinite(points).all(axis=1)]
    if not len(points):
        return np.array([0.0, 0.0, 1.0]), 0.0, 0.0, np.array([1.0, 0.0, 0.0])
    size = float(np.max(points.max(axis=0) - points.min(axis=0)))
    centred = points - points.mean(axis=0)
    _, axes = np.linalg.eigh(centred.T @ centred)  # principal directions, the least spread first
    spread = np.abs(centred @ axes).max(axis=0)
    return axes[:, 0], float(spread[0]), size, axes[:, 2] if spread[1] <= FLAT * size else None


def _unit(v) -> np.ndarray:
    v = np.asarray(v, dtype=float)
    return v / np.linalg.norm(v)


def _snapped(v) -> np.ndarray:
    """The unit vector ``v`` made exactly an axis of {0} when it is one but for rounding."""
    k = int(np.argmax(np.abs(v)))
    return np.eye(3)[k] * np.sign(v[k]) if abs(v[k]) > 1.0 - 1e-9 else v


def plane_of(points, against_gravity) -> tuple[Plane | None, float, float]:
    """The plane the ``points`` (k, 3) lie in, seen face-on with ``against_gravity`` (3,: a unit
    vector, +z when there is no gravity) drawn upwards as far as the plane holds it; None when the
    points leave every plane by more than :data:`FLAT` of their size. Returns it with the largest
    distance of a point from the nearest plane (m) and the size of the points (m).

    Points on one line lie in many planes: the one through the line and the vertical is taken
    (or, for a vertical line, through it and the first of x, y, z across it). When gravity lies
    in the plane, its direction is drawn downwards; when it is normal to it, the plane is seen
    from above (gravity into the page) with the {0} axis nearest to it drawn rightwards."""
    normal, off, size, along = flatness(points)
    if off > FLAT * size:
        return None, off, size
    up = _unit(against_gravity)
    if along is not None:
        for other in (up, *np.eye(3)):
            if np.linalg.norm(np.cross(along, other)) > 0.1:
                normal = _unit(np.cross(along, other))
                break
    normal = _snapped(normal)
    in_plane = up - (up @ normal) * normal
    if np.linalg.norm(in_plane) > 1e-6:  # gravity (partly) in the plane: drawn downwards
        vertical = _snapped(_unit(in_plane))
        across = np.cross(vertical, normal)
        if across[np.argmax(np.abs(across))] < 0:  # the side that draws the plane's main axis rightwards
            normal, across = -normal, -across
        return Plane(_snapped(across), vertical, normal), off, size
    normal = normal if normal @ up > 0 else -normal  # gravity normal to the plane: seen from above
    k = int(np.argmin(np.abs(normal)))  # the axis of {0} nearest to the plane
    across = _snapped(_unit(np.eye(3)[k] - normal[k] * normal))
    return Plane(across, _snapped(np.cross(normal, across)), normal, above=True), off, size
