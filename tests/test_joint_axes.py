"""Joints about and along any constant unit vector: the derivation against Pinocchio's own
unaligned joints (``JointModelRevoluteUnaligned``, ``JointModelPrismaticUnaligned``), the
vector's one form (a principal vector derives as its letter), and the refusals of vectors that
are no unit vectors, from Python and from a model file."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import gpmegen
from gpmegen.analysis.run.model_files import load_model_file
from gpmegen.errors import ModelError
from gpmegen.model import shapes
from gpmegen.model.chain import Body, Joint, Model, Offset, Parameter, Point
from gpmegen.model.expand import expand

pin = pytest.importorskip("pinocchio")


def unit(v):
    v = np.asarray(v, float)
    return v / np.linalg.norm(v)


def rotation(axis, angle):
    c, s = np.cos(angle), np.sin(angle)
    k = "xyz".index(axis)
    i, j = (k + 1) % 3, (k + 2) % 3
    R = np.eye(3)
    R[i, i] = R[j, j] = c
    R[i, j], R[j, i] = -s, s
    return R


# (kind, axis) of each joint, with the offset before it and the body after it: (mass, centre,
# inertia tensor about the centre as (Ixx, Iyy, Izz, Ixy, Ixz, Iyz)).
JOINTS = (
    ("revolute", unit([0.3, -0.5, 0.8])),
    ("prismatic", unit([0.2, 0.9, -0.4])),
    ("revolute", unit([-0.7, 0.1, 0.7])),
    ("prismatic", unit([0.0, 0.6, 0.8])),
    ("revolute", "y"),
)
OFFSETS = (((0.1, 0.2, -0.05), (("z", 0.3), ("x", -0.4))), ((0.3, 0.0, 0.1), (("y", 0.7),)),
           ((0.0, -0.2, 0.25), ()), ((0.15, 0.1, 0.0), (("x", 1.1),)), ((0.2, 0.0, 0.0), (("z", -0.5),)))
BODIES = ((1.5, (0.1, 0.02, -0.03), (0.02, 0.03, 0.025, 0.001, -0.002, 0.0015)),
          (0.8, (0.0, 0.05, 0.04), (0.01, 0.012, 0.009, 0.0, 0.001, -0.001)),
          (2.2, (0.2, -0.01, 0.0), (0.03, 0.05, 0.04, 0.002, 0.0, 0.001)),
          (0.5, (-0.02, 0.0, 0.06), (0.004, 0.005, 0.006, 0.0, 0.0, 0.0005)),
          (1.1, (0.12, 0.03, 0.01), (0.007, 0.02, 0.018, -0.001, 0.0005, 0.0)))
GRAVITY = (0.3, -9.81, 1.2)
TIP = (0.1, -0.05, 0.2)


def inertia_tensor(moments):
    xx, yy, zz, xy, xz, yz = moments
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def gpmegen_model(axes=None) -> Model:
    chain = []
    for k, ((kind, axis), (t, rots), (m, c, moments)) in enumerate(zip(JOINTS, OFFSETS, BODIES)):
        axis = axes[k] if axes else (axis if isinstance(axis, str) else tuple(float(a) for a in axis))
        chain += [Offset(t, rots), Joint(f"q{k}", kind, axis),
                  Body(f"b{k}", shapes.from_inertia_tensor(m, c, inertia_tensor(moments).tolist()))]
    chain.append(Point("tip", TIP))
    return Model("unaligned", (Parameter("unused", 1.0),), tuple(chain), gravity=GRAVITY)


def pinocchio_model():
    model, parent = pin.Model(), 0
    for k, ((kind, axis), (t, rots), (m, c, moments)) in enumerate(zip(JOINTS, OFFSETS, BODIES)):
        R = np.eye(3)
        for a, angle in rots:
            R = R @ rotation(a, angle)
        if isinstance(axis, str):
            joint = pin.JointModelRY()
        elif kind == "revolute":
            joint = pin.JointModelRevoluteUnaligned(axis)
        else:
            joint = pin.JointModelPrismaticUnaligned(axis)
        parent = model.addJoint(parent, joint, pin.SE3(R, np.array(t)), f"q{k}")
        model.appendBodyToJoint(parent, pin.Inertia(m, np.array(c), inertia_tensor(moments)), pin.SE3.Identity())
    tip = model.addFrame(pin.Frame("tip", parent, 0, pin.SE3(np.eye(3), np.array(TIP)), pin.FrameType.OP_FRAME))
    model.gravity.linear = np.array(GRAVITY)
    return model, tip


@pytest.fixture(scope="module")
def loaded(env):
    return gpmegen.load(model=gpmegen_model(), directory=env[0], backend="numpy")


def test_unaligned_joints_agree_with_pinocchio(loaded, rng):
    """M, the velocity terms, the gravity terms and a point at random states, to 1e-10: Pinocchio
    builds the same chain from its own unaligned joint models."""
    model, tip = pinocchio_model()
    data = model.createData()
    n = len(JOINTS)
    for _ in range(5):
        q, qd = rng.uniform(-1.5, 1.5, n), rng.uniform(-2, 2, n)
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(loaded.mass_matrix(q), M, rtol=0, atol=1e-10 * np.abs(M).max())
        gravity = pin.computeGeneralizedGravity(model, data, q)
        velocity = pin.rnea(model, data, q, qd, np.zeros(n)) - gravity
        f_gravity = loaded.forces(0.0, q, np.zeros(n))
        f = loaded.forces(0.0, q, qd)
        np.testing.assert_allclose(f_gravity, -gravity, rtol=0, atol=1e-10 * np.abs(gravity).max())
        np.testing.assert_allclose(f - f_gravity, -velocity, rtol=0, atol=1e-10 * np.abs(velocity).max())
        pin.framesForwardKinematics(model, data, q)
        np.testing.assert_allclose(loaded.point_positions(q)[0], data.oMf[tip].translation, rtol=0, atol=1e-12)


def test_principal_vector_derives_as_its_letter():
    """[0, 0, 1] is the z axis: the expanded joint carries the letter, so the generated code is
    that of a joint given as "z"; other vectors are normalized to unit length."""
    model = gpmegen_model(axes=[(0, 0, 1), (0.0, 1.0, 0.0), (0.6, 0.0, 0.8000001), "x", (1, 0, 0)])
    axes = [e.axis for e in expand(model).elements if isinstance(e, Joint)]
    assert axes[:2] == ["z", "y"] and axes[3:] == ["x", "x"]
    assert all(isinstance(a, sp.Float) for a in axes[2])
    assert sum(float(a) ** 2 for a in axes[2]) == pytest.approx(1, abs=1e-15)


@pytest.mark.parametrize("axis, problem", [
    ((0, 0, 2), "has length 2, not 1"),
    ((0, 0, 0), "has length 0, not 1"),
    ((0.0, 1.0), "neither x, y, z nor three numbers"),
    ((sp.Symbol("a", real=True), 0, 1), "neither x, y, z nor three numbers"),
    ((float("nan"), 0, 1), "neither x, y, z nor three numbers"),
    ("w", "unknown axis 'w'"),
])
def test_bad_axes_are_refused(axis, problem):
    model = gpmegen_model(axes=[axis, "x", "y", "z", "x"])
    with pytest.raises(ModelError, match=problem) as info:
        expand(model)
    assert "joint 'q0'" in str(info.value) and "\n" not in str(info.value)


MODEL_FILE = """
schema = 1
name = "tilted"
[[chain]]
joint = "q1"
type = "revolute"
axis = {axis}
[[chain]]
body = "arm"
mass = 1.0
center = [0.2, 0, 0]
"""


def test_model_file_axis_vector(tmp_path):
    """A model file writes the vector as [ax, ay, az]; a wrong one is refused at its line."""
    path = tmp_path / "tilted.toml"
    path.write_text(MODEL_FILE.format(axis="[0, 0.6, 0.8]"))
    (joint,) = [e for e in expand(load_model_file(path)).elements if isinstance(e, Joint)]
    assert [float(a) for a in joint.axis] == pytest.approx([0, 0.6, 0.8], abs=1e-15)
    path.write_text(MODEL_FILE.format(axis="[0, 1, 1]"))
    with pytest.raises(ModelError, match=r"tilted.toml:7: chain\[0\].axis: .*length 1.41421, not 1") as info:
        load_model_file(path)
    assert "\n" not in str(info.value)
