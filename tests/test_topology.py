"""Trees: the flattened model's topology, and the derivation on real branching.

Random rigid trees (6-15 joints, random parents, revolute and prismatic joints about principal
and oblique axes, random inertias, bodies and points off their joints' frames, offsets, random
gravity) are described once (:func:`random_tree`) and built twice from that description: as a
gpmegen Model whose branches start with Branch elements, and as a Pinocchio model joint by joint
(``addJoint`` under the described parent). M is checked against ``pinocchio.crba``, the velocity
and gravity parts of f against ``rnea`` (``M q̈ = f``, ``f = Q + h - g - C q - D q̇``, so
without springs and drives ``f = -nonLinearEffects``), and the C backend's O(n) recursion
against ``pinocchio.aba``. A programmed constraint between points on two branches is checked
against a KKT solve of Pinocchio's terms (tests/precise_solve.py), and a flexible link in a
branch against the dense solves.
"""

from __future__ import annotations

import random
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import gpmegen
from gpmegen.errors import ModelError
from gpmegen.model import shapes
from gpmegen.model.chain import (
    Body,
    Branch,
    Constraint,
    Drive,
    FlexibleLink,
    Joint,
    Model,
    Offset,
    Parameter,
    Point,
    RectangularSection,
)
from gpmegen.model.expand import expand
from gpmegen.model.topology import Topology
from gpmegen.symbolic import derive

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)

import oracle  # noqa: E402  (tests/oracle.py)
from precise_solve import extended_accelerations  # noqa: E402

pin = pytest.importorskip("pinocchio")

REL_TOL = 1e-10


def _relative(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def _rotation(axis, angle):
    """The 3x3 elementary rotation of the tests' oracle."""
    return oracle.rotation(axis, angle)[:3, :3]


def _offset_se3(translation, rotations):
    """The transform of ``Offset(translation, rotations)``: translate, then rotate in turn."""
    R = np.eye(3)
    for axis, angle in rotations:
        R = R @ _rotation(axis, angle)
    return pin.SE3(R, np.array(translation, float))


@dataclass
class TreeJoint:
    """One joint of a random tree: its parent (-1: the ground), the point of the parent's frame
    it starts from and the offset after that point, its kind and axis, its body (mass, centre,
    inertia tensor about the centre, offset of the body's frame) and its point."""

    parent: int
    kind: str
    axis: object                 # "x", "y", "z" or a unit 3-tuple
    start: tuple                 # position in the parent's frame of the point the joint hangs from
    offset: tuple                # (translation, rotations) after that point
    body: tuple                  # (mass, centre, inertia 3x3, (translation, rotations) of its frame)


def _unit(rnd):
    v = np.array([rnd.gauss(0, 1) for _ in range(3)])
    return tuple(float(a) for a in v / np.linalg.norm(v))


def _rotations(rnd):
    return tuple((rnd.choice("xyz"), round(rnd.uniform(-1.5, 1.5), 4)) for _ in range(rnd.randint(0, 2)))


def _inertia(rnd):
    """A physically valid inertia tensor about the centre: principal moments satisfying the
    triangle inequality, turned by a random rotation."""
    a, b = rnd.uniform(0.005, 0.05), rnd.uniform(0.005, 0.05)
    moments = np.array([a, b, rnd.uniform(abs(a - b) + 1e-3, a + b)])
    R = _rotation("z", rnd.uniform(-3, 3)) @ _rotation("y", rnd.uniform(-3, 3)) @ _rotation("x", rnd.uniform(-3, 3))
    return R @ np.diag(moments) @ R.T


def random_tree(seed) -> list[TreeJoint]:
    """6-15 joints, each hanging from the ground or an earlier joint (at least one joint with
    two children, so the tree branches)."""
    rnd = random.Random(seed)
    while True:
        n = rnd.randint(6, 15)
        parents = [-1] + [rnd.choice([j - 1, j - 1, rnd.randint(-1, j - 1)]) for j in range(1, n)]
        if len(set(parents)) < n:   # a parent shared by two joints: a branch
            break
    joints = []
    for parent in parents:
        kind = rnd.choice(["revolute", "revolute", "prismatic"])
        axis = rnd.choice(["x", "y", "z", _unit(rnd)])
        start = tuple(round(rnd.uniform(-0.3, 0.3), 4) for _ in range(3)) if rnd.random() < 0.6 else (0, 0, 0)
        offset = (tuple(round(rnd.uniform(-0.4, 0.4), 4) for _ in range(3)), _rotations(rnd))
        centre = tuple(round(rnd.uniform(-0.2, 0.2), 4) for _ in range(3))
        frame = ((tuple(round(rnd.uniform(-0.2, 0.2), 4) for _ in range(3)), _rotations(rnd))
                 if rnd.random() < 0.5 else ((0, 0, 0), ()))
        body = (round(rnd.uniform(0.3, 5.0), 4), centre, _inertia(rnd), frame)
        joints.append(TreeJoint(parent, kind, axis, start, offset, body))
    return joints


def gpmegen_tree(tree, name="tree", gravity=(0.0, -9.81, 0.0), extra=()) -> Model:
    """The tree as one chain: each joint's elements in joint order, each after a Branch from the
    point it starts from: ``P<parent>_<j>``, defined in the parent's frame right after the
    parent's joint, or for a joint on the ground ``G<j>``, fixed to the ground (``"ground"``
    itself where the start is {0}'s origin)."""
    chain = [Body("base", shapes.point_mass(2.0, (0.1, 0.0, 0.0)))]   # fixed to the ground: no term
    chain += [Point(f"G{j}", joint.start) for j, joint in enumerate(tree) if joint.parent < 0 and any(joint.start)]
    for j, joint in enumerate(tree):
        if joint.parent >= 0:
            chain.append(Branch(f"P{joint.parent}_{j}"))
        else:
            chain.append(Branch(f"G{j}" if any(joint.start) else "ground"))
        translation, rotations = joint.offset
        chain += [Offset(translation, rotations), Joint(f"q{j}", joint.kind, joint.axis)]
        # the points the children start from, in this joint's frame
        chain += [Point(f"P{j}_{k}", tree[k].start) for k in range(j + 1, len(tree)) if tree[k].parent == j]
        chain.append(Point(f"tip{j}", (0.05, -0.02, 0.03)))
        mass, centre, inertia, (t, rots) = joint.body
        chain += [Offset(t, rots), Body(f"b{j}", shapes.from_inertia_tensor(mass, centre, inertia.tolist()))]
    chain += list(extra)
    return Model(name, (Parameter("unused", 1.0),), tuple(chain), gravity=gravity)


def depth_first(tree) -> list:
    """The joints in depth-first order (children in increasing order): the order Pinocchio's
    algorithms need, where each subtree is a contiguous range of joints. A random tree's chain
    order is only topological (a parent before its children), which gpmegen takes as it is."""
    order = []

    def visit(j):
        order.append(j)
        for k, joint in enumerate(tree):
            if joint.parent == j:
                visit(k)

    visit(-1)
    return order[1:]


def pinocchio_tree(tree, gravity=(0.0, -9.81, 0.0)):
    """The same tree built joint by joint with Pinocchio's own joint models, in depth-first
    order; with the frames of the points ``tip<j>`` (by gpmegen's joint index) and that order:
    Pinocchio's coordinate ``k`` is gpmegen's ``order[k]``."""
    model = pin.Model()
    order = depth_first(tree)
    ids, tips = {}, {}
    for j in order:
        joint = tree[j]
        parent = 0 if joint.parent < 0 else ids[joint.parent]
        start = pin.SE3(np.eye(3), np.array(joint.start, float))
        placement = start * _offset_se3(*joint.offset)
        if isinstance(joint.axis, str):
            model_of = {("revolute", "x"): pin.JointModelRX, ("revolute", "y"): pin.JointModelRY,
                        ("revolute", "z"): pin.JointModelRZ, ("prismatic", "x"): pin.JointModelPX,
                        ("prismatic", "y"): pin.JointModelPY, ("prismatic", "z"): pin.JointModelPZ}
            jm = model_of[joint.kind, joint.axis]()
        elif joint.kind == "revolute":
            jm = pin.JointModelRevoluteUnaligned(np.array(joint.axis))
        else:
            jm = pin.JointModelPrismaticUnaligned(np.array(joint.axis))
        ids[j] = model.addJoint(parent, jm, placement, f"q{j}")
        mass, centre, inertia, frame = joint.body
        model.appendBodyToJoint(ids[j], pin.Inertia(mass, np.array(centre, float), inertia), _offset_se3(*frame))
        tips[j] = model.addFrame(pin.Frame(f"tip{j}", ids[j], 0, pin.SE3(np.eye(3), np.array([0.05, -0.02, 0.03])),
                                           pin.FrameType.OP_FRAME))
    model.gravity.linear = np.array(gravity, float)
    return model, tips, order


SEEDS = [1, 2, 3, 4, 5, 6]
GRAVITY = (0.4, -9.81, -1.3)


# ============================================================================================
# The topology itself
# ============================================================================================


def test_a_serial_chain_is_parent_j_minus_1():
    import test_joint_axes as serial

    topology = expand(serial.gpmegen_model()).topology
    n = topology.n_dof
    assert topology.parent == tuple(range(-1, n - 1)) and topology.is_serial
    assert topology.supports == tuple(tuple(range(j + 1)) for j in range(n))
    assert topology.subtree == tuple(tuple(range(j, n)) for j in range(n))
    assert topology.body_joint == tuple(range(n)) and topology.point_joint == (n - 1,)
    assert topology.parent == Topology.serial(n).parent


def test_the_flexible_reference_arm_is_serial():
    from gpmegen.model.reference import reference_model

    topology = expand(reference_model(3)).topology
    assert topology.is_serial and topology.parent == tuple(range(-1, topology.n_dof - 1))


@pytest.mark.parametrize("seed", SEEDS)
def test_the_tree_of_a_model_is_the_one_described(seed):
    tree = random_tree(seed)
    topology = expand(gpmegen_tree(tree)).topology
    assert topology.parent == tuple(joint.parent for joint in tree)
    assert topology.body_joint == (-1, *range(len(tree)))
    for j in range(len(tree)):
        ancestors, k = [], j
        while k >= 0:
            ancestors.append(k)
            k = tree[k].parent
        assert topology.supports[j] == tuple(sorted(ancestors))
        assert topology.subtree[j] == tuple(k for k in range(len(tree)) if j in topology.supports[k])
        assert topology.children[j] == tuple(k for k in range(len(tree)) if tree[k].parent == j)


def test_topology_refuses_a_parent_after_its_child():
    with pytest.raises(ValueError, match="joint 1: parent 2"):
        Topology.of((-1, 2, 0))


# ============================================================================================
# Refusals of bad branches: one line each, naming the fix
# ============================================================================================


def _chain_with(*elements):
    body = Body("b", shapes.point_mass(1.0, (0.5, 0, 0)))
    return Model("bad", (Parameter("k", 1.0),),
                 (Joint("a", "revolute", "z"), body, Point("P", (1, 0, 0)), *elements,
                  Joint("c", "revolute", "z"), Body("d", shapes.point_mass(1.0, (0.5, 0, 0)))))


@pytest.mark.parametrize("elements, problem", [
    ((Branch("Q"),), "branch parent 'Q' names no point; name a point defined before the branch, or 'ground'"),
    ((Branch("PP"),), "branch parent 'PP' names no point; did you mean 'P'?"),
    ((Branch("later"), Point("later", (0, 0, 0))), "branch parent 'later' is defined later in the chain; move the "
                                                    "branch after the point 'later'"),
    ((Branch("b"),), "branch parent 'b' is a body, not a point; add a point where the branch starts"),
    ((Branch("a"),), "branch parent 'a' is a coordinate, not a point"),
    ((Branch("k"),), "branch parent 'k' is a parameter, not a point"),
    ((Branch(3),), "branch parent 3 is not a name"),
    ((Point("ground", (0, 0, 0)), Branch("ground")), "a branch from 'ground' is ambiguous"),
])
def test_bad_branches_are_refused_in_one_line(elements, problem):
    with pytest.raises(ModelError) as info:
        expand(_chain_with(*elements))
    message = str(info.value)
    assert problem in message and "\n" not in message, message


def test_a_branch_names_its_field():
    with pytest.raises(ModelError) as info:
        expand(_chain_with(Branch("Q")))
    assert info.value.subject == ("chain", 3, "parent")


# ============================================================================================
# The derivation on trees against Pinocchio
# ============================================================================================


def _states(n, rng, count=4):
    for _ in range(count):
        yield rng.uniform(-1.5, 1.5, n), rng.uniform(-2.0, 2.0, n)


# seeds 0 and 1 in make test (a few seconds of CPU each: a derivation and a build), the rest in make check-c
@pytest.mark.parametrize("seed", [pytest.param(s, marks=[pytest.mark.long] if s > 1 else []) for s in SEEDS])
def test_random_trees_agree_with_pinocchio(env, seed):
    """M against crba, the gravity and velocity parts of f against rnea, the points against
    Pinocchio's frames, and M_ij exactly 0 where neither joint supports the other."""
    tree = random_tree(seed)
    loaded = gpmegen.load(model=gpmegen_tree(tree, f"tree{seed}", GRAVITY), directory=env[0], backend="numpy")
    model, tips, order = pinocchio_tree(tree, GRAVITY)
    data = model.createData()
    topology = expand(gpmegen_tree(tree, gravity=GRAVITY)).topology
    n = len(tree)
    unrelated = [(i, j) for i in range(n) for j in range(n) if not topology.related(i, j)]
    assert unrelated   # the tree branches
    rng = np.random.default_rng(seed)
    for q, qd in _states(n, rng):
        qp, qdp = q[order], qd[order]
        M = pin.crba(model, data, qp)
        M = np.triu(M) + np.triu(M, 1).T
        mass = loaded.mass_matrix(q)
        assert _relative(mass[np.ix_(order, order)], M) <= REL_TOL
        assert all(mass[i, j] == 0.0 for i, j in unrelated)
        gravity = pin.computeGeneralizedGravity(model, data, qp)
        velocity = pin.rnea(model, data, qp, qdp, np.zeros(n)) - gravity
        f_gravity = loaded.forces(0.0, q, np.zeros(n))[order]
        f = loaded.forces(0.0, q, qd)[order]
        assert _relative(f_gravity, -gravity) <= REL_TOL
        assert _relative(f - f_gravity, -velocity) <= REL_TOL
        assert _relative(f, -pin.nonLinearEffects(model, data, qp, qdp)) <= REL_TOL
        pin.framesForwardKinematics(model, data, qp)
        positions = loaded.point_positions(q)
        tip_rows = [loaded.points.index(f"tip{j}") for j in range(n)]
        expected = np.array([data.oMf[tips[j]].translation for j in range(n)])
        np.testing.assert_allclose(positions[tip_rows], expected, rtol=0, atol=1e-12)


@pytest.mark.parametrize("seed", SEEDS[:3])
def test_the_symbolic_mass_matrix_and_stiffness_jacobian_are_sparse(seed):
    """Entries of M and K where neither joint supports the other are not even defined: exact
    zeros of the derivation, as are the point Jacobian columns of joints that do not move the
    point and the body transforms' derivatives by them."""
    from gpmegen.symbolic import transforms

    tree = random_tree(seed)
    d = derive(gpmegen_tree(tree, gravity=GRAVITY))
    topology = d.chain.topology
    n = len(tree)
    for i in range(n):
        for j in range(n):
            if not topology.related(i, j):
                assert d.dynamics.mass_matrix[i, j] == 0 and d.dynamics.stiffness_jacobian[i, j] == 0
    assert sum(topology.related(i, j) for i in range(n) for j in range(n)) < n * n
    for point in d.kinematics.points.values():
        moving = topology.moved_by(point.joint)
        assert all(point.jacobian[j] == sp.zeros(3, 1) for j in range(n) if j not in moving)
    first = transforms.first_derivatives(d.kinematics)
    for b, body in enumerate(d.kinematics.bodies):
        moving = topology.moved_by(body.joint)
        assert [i for i in range(n) if first[b][i] != sp.zeros(4, 4)] == list(moving)


def _evaluate(program, outputs, values):
    """``outputs`` (expressions of ``program``'s intermediates) as floats, with ``values`` for
    the coordinates and velocities."""
    values = dict(values)
    for symbol, expression in program.closure(outputs):
        values[symbol] = sp.Float(expression.xreplace(values))
    return np.array([float(sp.sympify(e).xreplace(values)) for e in outputs])


@pytest.mark.parametrize("seed", SEEDS[:2])
def test_the_mass_product_over_subtrees_and_ancestors_is_m_times_a(seed):
    """``mass_product`` (the O(n) M a the acceleration Jacobians differentiate) against M a."""
    tree = random_tree(seed)
    d = derive(gpmegen_tree(tree, gravity=GRAVITY))
    n = len(tree)
    rng = np.random.default_rng(seed)
    a = rng.standard_normal(n)
    product = d.dynamics.mass_product(d.kinematics, sp.Matrix([sp.Float(v) for v in a]), d.program.define_all)
    values = dict(zip(d.kinematics.q, map(sp.Float, rng.uniform(-1.5, 1.5, n))))
    mass = _evaluate(d.program, list(d.dynamics.mass_matrix), values).reshape(n, n)
    assert _relative(_evaluate(d.program, list(product), values), mass @ a) <= 1e-12


@pytest.mark.requires_cc
@pytest.mark.parametrize("seed", [pytest.param(s, marks=[pytest.mark.long] if s > 0 else []) for s in SEEDS[:4]])
def test_the_c_recursion_on_trees_agrees_with_pinocchio_aba(env, seed):
    """The articulated-body recursion of the C backend, walking the parent array, against
    pinocchio.aba and against the dense C solve."""
    tree = random_tree(seed)
    c_model = gpmegen.load(model=gpmegen_tree(tree, f"ctree{seed}", GRAVITY), directory=env[0], backend="c")
    model, _, order = pinocchio_tree(tree, GRAVITY)
    data = model.createData()
    n = len(tree)
    rng = np.random.default_rng(100 + seed)
    for q, qd in _states(n, rng):
        expected = np.empty(n)
        expected[order] = pin.aba(model, data, q[order], qd[order], np.zeros(n))
        assert _relative(c_model.accelerations(0.0, q, qd), expected) <= REL_TOL
        assert _relative(c_model.motion(0.0, q, qd)[0], expected) <= REL_TOL


# ============================================================================================
# A constraint between two branches; a flexible link in a branch
# ============================================================================================


def _two_branch_tree():
    """A base joint with two branches of three joints each (seeded), tips ``tip3`` and
    ``tip6``."""
    rnd = random.Random(77)
    parents = [-1, 0, 1, 2, 0, 4, 5]
    tree = []
    for parent in parents:
        kind = "prismatic" if parent in (1, 4) else "revolute"
        axis = rnd.choice(["x", "y", "z", _unit(rnd)])
        body = (round(rnd.uniform(0.5, 3.0), 3), (0.1, 0.02, -0.03), _inertia(rnd), ((0.05, 0, 0), ()))
        tree.append(TreeJoint(parent, kind, axis, (0.2, 0.0, 0.05) if parent == 0 else (0.0, 0.0, 0.0),
                              ((0.3, 0.0, 0.0), _rotations(rnd)), body))
    return tree


@pytest.mark.requires_cc
def test_a_constraint_between_two_branches_agrees_with_a_kkt_solve_of_pinocchio_terms(env, rng):
    """Φ = x_tip3 - x_tip6 - 0.1 (a point of each branch, both moved by joint 0) with Baumgarte
    gains: q̈ of the NumPy and C backends against the 50-digit KKT solve of Pinocchio's M and
    nonLinearEffects, the constraint row from Pinocchio's frame Jacobians and γ from its frame
    accelerations at q̈ = 0."""
    tree = _two_branch_tree()
    alpha, beta = 3.0, 5.0
    constraint = Constraint("gap", sp.Symbol("x_tip3", real=True) - sp.Symbol("x_tip6", real=True) - 0.1,
                            alpha=alpha, beta=beta)
    base = gpmegen_tree(tree, "branches", GRAVITY)
    model_g = Model(base.name, base.parameters, base.chain, gravity=GRAVITY, constraints=(constraint,))
    loaded = [gpmegen.load(model=model_g, directory=env[0], backend=b) for b in ("numpy", "c")]
    model, tips, order = pinocchio_tree(tree, GRAVITY)
    assert order == list(range(len(tree)))   # built depth first: no reordering
    data = model.createData()
    n = len(tree)
    frame = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    for q, qd in _states(n, rng, count=5):
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        f = -pin.nonLinearEffects(model, data, q, qd)
        pin.computeJointJacobians(model, data, q)
        pin.forwardKinematics(model, data, q, qd, np.zeros(n))
        pin.updateFramePlacements(model, data)
        a3, a6 = tips[3], tips[6]
        D = (pin.getFrameJacobian(model, data, a3, frame) - pin.getFrameJacobian(model, data, a6, frame))[0:1]
        phi = data.oMf[a3].translation[0] - data.oMf[a6].translation[0] - 0.1
        phi_rate = float(D[0] @ qd)
        gamma = (pin.getFrameClassicalAcceleration(model, data, a3, frame).linear
                 - pin.getFrameClassicalAcceleration(model, data, a6, frame).linear)[0]
        c = np.array([-gamma - 2 * alpha * phi_rate - beta ** 2 * phi])
        expected = extended_accelerations(M, f, D, c)
        for backend in loaded:
            assert _relative(backend.accelerations(0.0, q, qd), expected) <= REL_TOL, backend


def _flexible_branch_model():
    """A revolute base with two branches: a flexible link (n_rfe 3) ending in a hub, and a
    rigid two-joint arm; a third branch on the flexible link's tip point."""
    tree = _two_branch_tree()[:4]
    base = gpmegen_tree(tree, "flexbranch", GRAVITY)
    link = FlexibleLink("f", 0.8, RectangularSection(0.04, 0.01), density=2700.0, young_modulus=7e10,
                        shear_modulus=2.6e10, n_rfe=3, damping=(0.01, 0.01, 0.01))
    extra = (Branch("P0_1"), Offset((0, 0.1, 0), (("z", 0.4),)), link, Point("end", (0, 0, 0)),
             Body("hub", shapes.point_mass(0.5, (0.02, 0, 0))),
             Branch("end"), Joint("wrist", "revolute", "y"), Body("hand", shapes.point_mass(0.3, (0.1, 0, 0.02))))
    return Model(base.name, base.parameters, base.chain + extra, gravity=GRAVITY)


def test_a_flexible_link_in_a_branch_hangs_where_it_is_defined():
    flat = expand(_flexible_branch_model())
    topology, coordinates = flat.topology, flat.coordinates
    first_sde = coordinates.index("psif_1")
    assert topology.parent[first_sde] == 0   # the branch from P0_1, a point of joint 0's frame
    wrist = coordinates.index("wrist")
    assert topology.parent[wrist] == n_last_sde(coordinates) and len(topology.children[0]) == 2


def n_last_sde(coordinates):
    return max(k for k, name in enumerate(coordinates) if name.startswith(("psif_", "thetaf_", "phif_")))


# make check-c: a flexible branch against the oracle stays (test_trees_with_flexible_branches_agree_with_the_oracle[0])
@pytest.mark.long
@pytest.mark.requires_cc
def test_a_flexible_link_in_a_branch_agrees_with_the_dense_solves(env, rng):
    """Springs, dampers and a flexible link's frames without mass in a branch: the C recursion
    against the dense C solve and the NumPy backend (whose M and f the Pinocchio tests above
    check on rigid trees)."""
    model = _flexible_branch_model()
    c_model = gpmegen.load(model=model, directory=env[0], backend="c")
    numpy_model = gpmegen.load(model=model, directory=env[0], backend="numpy")
    n = c_model.n_dof
    for _ in range(5):
        q, qd = 0.3 * rng.standard_normal(n), rng.standard_normal(n)
        recursive = c_model.accelerations(0.0, q, qd)
        for reference in (c_model.motion(0.0, q, qd)[0], numpy_model.accelerations(0.0, q, qd)):
            assert _relative(recursive, reference) <= 1e-9


# ============================================================================================
# Branches in a model file
# ============================================================================================

TREE_FILE = """
schema = 1
name = "file_tree"
gravity = [0, -9.81, 0]

[parameters]
m = { value = 1.5, unit = "kg", doc = "mass of each arm" }

[[chain]]
joint = "base"
type = "revolute"
axis = "y"

[[chain]]
body = "torso"
shape = { type = "point_mass", mass = 4.0, position = [0, 0.5, 0] }

[[chain]]
point = "shoulder"
position = [0, 0.5, 0]

[[chain]]
parent = "shoulder"
joint = "left"
type = "revolute"
axis = "z"

[[chain]]
body = "left_arm"
shape = { type = "point_mass", mass = "m", position = [0.4, 0, 0] }

[[chain]]
point = "left_hand"
position = [0.4, 0, 0]

[[chain]]
parent = "shoulder"
translation = [0, 0, 0.1]

[[chain]]
joint = "right"
type = "prismatic"
axis = "x"

[[chain]]
body = "right_arm"
shape = { type = "point_mass", mass = "m", position = [0.3, 0, 0] }

[[constraints]]
name = "hand_height"
expression = "y_left_hand - 0.4"
"""


def test_a_model_file_branches_with_parent_keys(tmp_path):
    from gpmegen.analysis.run.model_files import load_model_file

    path = tmp_path / "tree.toml"
    path.write_text(TREE_FILE)
    model = load_model_file(path)
    branches = [e for e in model.chain if isinstance(e, Branch)]
    assert branches == [Branch("shoulder"), Branch("shoulder")]
    topology = expand(model).topology
    assert topology.parent == (-1, 0, 0) and topology.point_joint == (0, 1)
    assert not topology.related(1, 2)


@pytest.mark.parametrize("change, problem", [
    (('parent = "shoulder"\njoint = "left"', 'parent = "elbow"\njoint = "left"'),
     "chain[3].parent: branch parent 'elbow' names no point"),
    (('parent = "shoulder"\ntranslation', 'parent = "left_arm"\ntranslation'),
     "chain[6].parent: branch parent 'left_arm' is a body, not a point"),
    (('parent = "shoulder"\ntranslation', 'parent = 3\ntranslation'), "chain[6].parent"),
    (('mass = 4.0', 'mass = -4.0'), "chain[1].shape.mass"),
    (('mass = "m", position = [0.3', 'mass = -2.0, position = [0.3'), "chain[8].shape.mass"),
    (('body = "right_arm"', 'body = "left"'), "chain[8].body"),
    (('axis = "x"', 'axis = "w"'), "chain[7].axis"),
])
def test_model_file_errors_after_a_branch_name_their_line(tmp_path, change, problem):
    """The Branch a parent key makes is no [[chain]] table of its own: errors about the
    elements after it still name their table and the line of the changed text."""
    from gpmegen.analysis.run.model_files import load_model_file

    old, new = change
    assert TREE_FILE.count(old) == 1
    text = TREE_FILE.replace(old, new)
    line = text[:text.index(new)].count("\n") + 1
    path = tmp_path / "tree.toml"
    path.write_text(text)
    with pytest.raises(ModelError) as info:
        load_model_file(path)
    message = str(info.value)
    assert f"tree.toml:{line}: {problem}" in message and "\n" not in message, message


def test_transform_derivatives_on_a_tree_agree_with_central_differences(env, rng):
    """T_i and T_ij of the bodies of a tree (numpy backend) against central differences of T
    and T_i, and zero for the joints of the other branch."""
    import test_transforms as transforms_test

    tree = _two_branch_tree()
    model = gpmegen_tree(tree, "tree_transforms", GRAVITY)
    loaded = gpmegen.load(model=model, backend="numpy", transforms=("T", "T_i", "T_ij"))
    topology = expand(model).topology
    for _ in range(2):
        q = rng.uniform(-1.0, 1.0, len(tree))
        for kind, lower in (("T_i", "T"), ("T_ij", "T_i")):
            exact = loaded.transforms(q, kind)
            numeric = transforms_test.central(lambda x, lower=lower: loaded.transforms(x, lower), q, 1e-4)
            np.testing.assert_allclose(exact, numeric, rtol=0, atol=1e-6 * np.abs(exact).max())
        first = loaded.transforms(q, "T_i")
        for j in range(len(tree)):   # body b<j> is moved by joint j and its supports alone
            body = loaded.bodies.index(f"b{j}")
            moving = [i for i in range(len(tree)) if np.abs(first[body, i]).max() > 0]
            assert moving == list(topology.supports[j])


# ============================================================================================
# Trees with flexible links, springs, dampers and drives against the brute-force oracle
# ============================================================================================


def _oracle_trees():
    """A flexible link in a branch with a drive; random rigid trees with a flexible branch from a
    tip and a sprung, damped slider hanging from the ground."""
    t = sp.Symbol("t", real=True)
    flexible = _flexible_branch_model()
    yield Model(flexible.name, flexible.parameters, flexible.chain, gravity=GRAVITY,
                drives=(Drive("wrist", 0.3 * sp.sin(2 * t)), Drive("q1", 1.5)))
    for seed in (4, 5):
        base = gpmegen_tree(random_tree(seed), f"oracle_tree{seed}", GRAVITY)
        link = FlexibleLink("g", 0.6, RectangularSection(0.03, 0.01), density=2700.0, young_modulus=7e10,
                            shear_modulus=2.6e10, n_rfe=2)
        extra = (Branch("tip2"), Offset((0.1, 0, 0), (("y", 0.3),)), link, Point("gtip", (0, 0, 0)),
                 Body("gload", shapes.point_mass(0.4, (0.01, 0, 0))),
                 Branch("ground"), Offset((0, 0, 0.5)), Joint("slide", "prismatic", "y", stiffness=40.0, damping=0.5),
                 Body("slider", shapes.point_mass(1.2, (0.05, 0, 0))))
        yield Model(base.name, base.parameters, base.chain + extra, gravity=GRAVITY,
                    drives=(Drive("slide", sp.cos(t)),))


@pytest.mark.parametrize("index", [0, pytest.param(1, marks=pytest.mark.long), pytest.param(2, marks=pytest.mark.long)])
def test_trees_with_flexible_branches_agree_with_the_oracle(env, rng, index):
    """M, f (drives, springs, dampers, gravity, velocity terms), the points and the energies of
    the NumPy backend against tests/oracle.py, which multiplies the elementary matrices on each
    body's path from the ground."""
    import test_random_chains as chains

    model = list(_oracle_trees())[index]
    loaded = gpmegen.load(model=model, directory=env[0], backend="numpy")
    chain, R0 = chains.to_oracle(model, model.defaults)
    assert chain.coordinates == loaded.coordinates
    n = chain.n_dof
    for _ in range(3):
        t, q, qd = float(rng.uniform(0, 3)), 0.4 * rng.standard_normal(n), rng.standard_normal(n)
        assert _relative(loaded.mass_matrix(q), chain.mass_matrix(q)) <= REL_TOL
        assert _relative(loaded.forces(t, q, qd), chain.forces(t, q, qd)) <= REL_TOL
        assert _relative(loaded.forces(t, q, qd) - loaded.forces(t, q, -qd), 2 * (-chain.damping() @ qd)) <= 1e-9
        expected = np.array([R0.T @ chain.point(name, q) for name in loaded.points])
        np.testing.assert_allclose(loaded.point_positions(q), expected, rtol=0, atol=1e-12)
        kinetic = float(loaded.energies(q, qd)[0])
        assert abs(kinetic - chain.kinetic_energy(q, qd)) <= REL_TOL * chain.kinetic_energy(q, qd)
