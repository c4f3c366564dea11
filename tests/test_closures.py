"""Closed loops ([[closures]]): a planar four-bar against its exact position analysis and the
power balance of its crank, spatial loops at random consistent states against a KKT solve on
Pinocchio's M and nonlinear effects, the rows that vanish identically, redundant rows solved
(the four-bar in a turned plane, closed by a revolute), and the closures refused in one line."""

from __future__ import annotations

import math
import sys
import warnings
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.figures.figure_list import stems
from gpmegen.analysis.post import closures as closure_reactions
from gpmegen.analysis.post import energy
from gpmegen.analysis.post import results as results_io
from gpmegen.analysis.run.model_files import read_model_file
from gpmegen.cli import main
from gpmegen.errors import ModelWarning, SimulationError
from gpmegen.model import shapes
from gpmegen.model.chain import Body, Branch, Closure, Joint, Model, Offset, Parameter, Point, closure_rows
from gpmegen.runtime import consistent, gpme, partition
from gpmegen.runtime.evaluator import redundant_acceleration_jacobians

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)

import oracle  # noqa: E402  (tests/oracle.py)

ROOT = Path(__file__).resolve().parents[1]
FOUR_BAR = ROOT / "examples" / "four_bar.toml"
# the example's dimensions, as its [parameters] give them
L1, L2, L3, D, W = 0.1, 0.3, 0.25, 0.3, 2 * math.pi


def four_bar_text(**replace) -> str:
    """The example's text with lines replaced (``old=new`` pairs given as a dict of strings)."""
    text = FOUR_BAR.read_text()
    for old, new in replace.items():
        assert text.count(old) == 1
        text = text.replace(old, new)
    return text


def exact_four_bar(theta1):
    """The coupler's angle relative to the crank and the rocker's absolute angle for the crank
    at ``theta1``, on the branch with the coupler's tip above the line from B to the rocker's
    pivot: the two circles about B (radius L2) and D = (d, 0) (radius L3) intersected."""
    bx, by = L1 * np.cos(theta1), L1 * np.sin(theta1)
    ex, ey = D - bx, -by
    s = np.hypot(ex, ey)
    ux, uy = ex / s, ey / s
    along = (L2 ** 2 - L3 ** 2 + s ** 2) / (2 * s)
    across = np.sqrt(L2 ** 2 - along ** 2)
    cx, cy = bx + along * ux - across * uy, by + along * uy + across * ux
    return np.arctan2(cy - by, cx - bx) - theta1, np.arctan2(cy, cx - D)


def wrapped(a):
    return (np.asarray(a) + np.pi) % (2 * np.pi) - np.pi


@pytest.fixture(scope="module", params=["revolute", "point"])
def four_bar_run(request, env, tmp_path_factory):
    """0.5 s of the four-bar (crank at 2π rad/s), closed by a revolute joint about z (the
    example) or by a point closure, on the NumPy backend."""
    path = tmp_path_factory.mktemp("four_bar") / "four_bar.toml"
    if request.param == "point":
        path.write_text(four_bar_text(**{'["C1", "C2"]\ntype = "revolute"\naxis = "z"': '["C1", "C2"]\ntype = "point"',
                                         'name = "four_bar"': 'name = "four_bar_point"'}))
    else:
        path.write_text(FOUR_BAR.read_text())
    run = gpmegen.simulate(str(path), t_end=0.5, dt=1e-3, save_every=10, backend="numpy", directory=env[0])
    return path, run


def test_four_bar_follows_its_exact_position_analysis(four_bar_run):
    """The crank turns at w, and the coupler and rocker angles along the run are the closed-form
    four-bar's at the crank's angle, to 1e-8 rad."""
    _, run = four_bar_run
    assert run.status == "complete"
    t, theta1 = run.t, run.coordinate("theta1")
    np.testing.assert_allclose(theta1, W * t, rtol=0, atol=1e-10)
    coupler, rocker = exact_four_bar(theta1)
    assert np.max(np.abs(wrapped(run.coordinate("theta2") - coupler))) < 1e-8
    assert np.max(np.abs(wrapped(run.coordinate("theta3") - rocker))) < 1e-8
    assert np.ptp(run.coordinate("theta3")) > 0.3   # the rocker rocks


def test_four_bar_crank_torque_balances_the_power(four_bar_run, env):
    """The crank's torque (the prescribed constraint's multiplier) times its rate is the rate of
    the kinetic and gravity energy at every saved state: d/dt (T + V) along the motion, by central
    differences of the generated energies along (q̇, q̈); the closure does no work."""
    path, run = four_bar_run
    loaded = gpmegen.load(model=read_model_file(path).model, backend="numpy", directory=env[0])
    names = list(run["constraint_names"])
    torque = run["lambda"][:, names.index("prescribed_theta1")]
    eps = 1e-6
    rates = []
    for q, qd, qdd in zip(run["q"], run["qd"], run["qdd"]):
        ahead, behind = loaded.energies(q + eps * qd, qd + eps * qdd), loaded.energies(q - eps * qd, qd - eps * qdd)
        rates.append((ahead[0] + ahead[1] - behind[0] - behind[1]) / (2 * eps))
    power = torque * run["qd"][:, list(run["coordinates"]).index("theta1")]
    scale = np.max(np.abs(power))
    assert scale > 0.1
    np.testing.assert_allclose(power, rates, rtol=0, atol=1e-7 * scale)


GROUNDED = """
schema = 1
name = "four_bar_grounded"
gravity = [0, "-g", 0]
dependent = ["theta2", "theta3"]

[parameters]
g = 9.81
L1 = 0.1
L2 = 0.3
L3 = 0.25
d = 0.3
w = 6.283185307179586

[[chain]]
point = "D"                 # the rocker's pivot, on the ground: defined before any joint
position = ["d", 0, 0]

[[chain]]
joint = "theta1"
type = "revolute"
axis = "z"
prescribed = "w*t"

[[chain]]
body = "crank"
shape = { type = "bar", mass = 0.5, length = "L1", width = 0.02, thickness = 0.01 }

[[chain]]
translation = ["L1", 0, 0]

[[chain]]
joint = "theta2"
type = "revolute"
axis = "z"

[[chain]]
body = "coupler"
shape = { type = "bar", mass = 1.0, length = "L2", width = 0.02, thickness = 0.01 }

[[chain]]
translation = ["L2", 0, 0]

[[chain]]
point = "C"

[[chain]]
joint = "theta3"
type = "revolute"
axis = "z"

[[chain]]
body = "rocker"
shape = { type = "bar", mass = 0.8, length = "L3", width = 0.02, thickness = 0.01 }

[[chain]]
point = "R"
position = ["L3", 0, 0]

[[closures]]
name = "pin"
points = ["R", "D"]
type = "point"

[initial]
q = { theta2 = 1.0, theta3 = 3.8 }
"""


def test_a_serial_chain_pinned_to_a_ground_point_is_the_same_four_bar(tmp_path, env):
    """The four-bar as one serial chain (crank, coupler, rocker) whose tip is pinned to the
    rocker's pivot, a point on the ground: the coupler's tip follows the closed-form analysis
    to 1e-8 m, and the reaction on the ground (the second point's body) is the force that holds
    the pin."""
    path = tmp_path / "grounded.toml"
    path.write_text(GROUNDED)
    run = gpmegen.simulate(str(path), t_end=0.3, dt=1e-3, save_every=10, backend="numpy", directory=env[0])
    assert run.status == "complete"
    theta1, theta2 = run.coordinate("theta1"), run.coordinate("theta2")
    coupler, rocker = exact_four_bar(theta1)
    tip = np.column_stack([L1 * np.cos(theta1) + L2 * np.cos(theta1 + theta2),
                           L1 * np.sin(theta1) + L2 * np.sin(theta1 + theta2)])
    exact = np.column_stack([D + L3 * np.cos(rocker), L3 * np.sin(rocker)])
    assert np.max(np.abs(tip - exact)) < 1e-8
    names = list(run["constraint_names"])
    assert names == ["pin_x", "pin_y", "prescribed_theta1"]
    np.testing.assert_array_equal(run["closure_pin_force"][:, :2], run["lambda"][:, :2])


@pytest.mark.requires_cc
def test_four_bar_on_the_c_backend_saves_its_reactions(env, tmp_path):
    """The example on the C backend (its O(n) solve) follows the same exact position analysis;
    its results file and CSV hold the closure's reaction apart from λ, with units, and its
    figures include the reactions'."""
    run = gpmegen.simulate(str(FOUR_BAR), t_end=0.3, dt=1e-3, save_every=10, backend="c", directory=env[0])
    coupler, rocker = exact_four_bar(run.coordinate("theta1"))
    assert np.max(np.abs(wrapped(run.coordinate("theta2") - coupler))) < 1e-8
    assert np.max(np.abs(wrapped(run.coordinate("theta3") - rocker))) < 1e-8
    names = list(run["constraint_names"])
    lam = run["lambda"]
    force = run["closure_C_force"]
    np.testing.assert_array_equal(force[:, 0], lam[:, names.index("C_x")])   # a coincidence row's λ is the force
    np.testing.assert_array_equal(force[:, 1], lam[:, names.index("C_y")])
    assert not force[:, 2].any() and not run["closure_C_moment"].any()     # the dropped rows carry nothing
    path = tmp_path / "four_bar.npz"
    run.save(path)
    loaded = results_io.load(path)
    np.testing.assert_array_equal(loaded["closure_C_force"], force)
    meta = results_io.metadata(loaded)
    assert meta["lambda_units"] == {"C_x": "N", "C_y": "N", "prescribed_theta1": "N·m"}
    assert meta["closures"] == [{"name": "C", "points": ["C1", "C2"], "type": "revolute", "axis": "z",
                                 "rows": ["C_x", "C_y"], "moment": True, "acting": {"force": ["x", "y"], "moment": []}}]
    header = path.with_suffix(".csv").read_text().splitlines()[1].split(",")
    assert header[-6:] == [f"{a}_closure_C [{unit}]" for a, unit in (("Fx", "N"), ("Fy", "N"), ("Fz", "N"),
                                                                      ("Mx", "N·m"), ("My", "N·m"), ("Mz", "N·m"))]
    assert stems([loaded])[-2:] == ["constraint_multipliers", "closure_reactions"]


@pytest.mark.requires_cc
def test_flexible_coupler_holds_its_loop_and_its_energy_balance(env):
    """examples/four_bar_flexible.toml: the coupler's rfes bend, the loop holds and the energy
    balance ΔE - W stays at the integration's error, far below the energy exchanged."""
    run = gpmegen.simulate(str(ROOT / "examples" / "four_bar_flexible.toml"), t_end=0.3, dt=1e-4, save_every=10,
                           backend="c", directory=env[0])
    assert run.status == "complete"
    assert np.max(np.abs(run["phi"])) < 1e-10
    bend = np.abs(run.coordinate("psi2_1")).max()
    assert 1e-5 < bend < 1e-2
    exchanged = np.abs(run["work_constraints"]).max()
    assert exchanged > 0.1
    assert np.abs(energy.balance_residual(run.arrays)).max() < 1e-6 * exchanged


# ---- spatial loops against Pinocchio ----------------------------------------------------------

try:
    import pinocchio as pin
except ImportError:   # the spatial tests skip without it
    pin = None

GRAVITY = (0.4, -9.81, 1.3)
# each joint: (translation, rotations of the offset before it, kind, axis, body (mass, centre,
# inertia (Ixx, Iyy, Izz, Ixy, Ixz, Iyz) about the centre))
BRANCH_A = (
    ((0.0, 0.0, 0.1), (("x", 0.2),), "revolute", "z", (1.2, (0.1, 0.02, 0.0), (0.02, 0.03, 0.025, 0.001, 0.0, 0.002))),
    ((0.3, 0.0, 0.0), (("y", 0.5),), "revolute", "y", (0.9, (0.15, 0.0, 0.03), (0.01, 0.02, 0.015, 0.0, 0.001, 0.0))),
    ((0.1, 0.05, 0.0), (), "prismatic", "x", (0.6, (0.05, 0.01, 0.0), (0.004, 0.006, 0.005, 0.0, 0.0, 0.0005))),
    ((0.25, 0.0, 0.05), (("z", -0.3),), "revolute", "x", (0.7, (0.08, -0.02, 0.01), (0.005, 0.004, 0.006, 0, 0, 0))),
)
BRANCH_B = (
    ((0.4, 0.3, 0.0), (("z", 1.0),), "revolute", "y", (1.0, (0.0, 0.1, 0.02), (0.02, 0.01, 0.02, 0.0, 0.0, 0.001))),
    ((0.2, 0.0, 0.1), (), "revolute", "z", (0.8, (0.1, 0.0, 0.0), (0.003, 0.01, 0.01, 0.0, 0.0, 0.0))),
    ((0.15, 0.0, 0.0), (("x", 0.4),), "revolute", "x", (0.5, (0.05, 0.02, -0.01), (0.002, 0.003, 0.004, 0, 0, 0))),
)
POINT_A = (0.1, 0.02, -0.03)


def placement(t, rotations):
    """The 4x4 transform of an offset: its translation, then its rotations in order."""
    T = oracle.translation(*t)
    for axis, angle in rotations:
        T = T @ oracle.rotation(axis, angle)
    return T


def closing_offset():
    """The offset from the last joint of branch B to the point CB that puts CB on CA, its frame
    on CA's, at q = 0: (translation, ZYX rotations)."""
    A = np.eye(4)
    for t, rotations, *_ in BRANCH_A:
        A = A @ placement(t, rotations)
    A = A @ placement(POINT_A, ())
    B = np.eye(4)
    for t, rotations, *_ in BRANCH_B:
        B = B @ placement(t, rotations)
    rel = np.linalg.solve(B, A)
    R = rel[:3, :3]
    angles = (("z", math.atan2(R[1, 0], R[0, 0])), ("y", -math.asin(R[2, 0])), ("x", math.atan2(R[2, 1], R[2, 2])))
    assert np.allclose(placement((0, 0, 0), angles)[:3, :3], R, atol=1e-14)
    return tuple(rel[:3, 3]), angles


def tensor(moments):
    xx, yy, zz, xy, xz, yz = moments
    return np.array([[xx, xy, xz], [xy, yy, yz], [xz, yz, zz]])


def spatial_model(kind, axis) -> Model:
    chain = []
    for label, branch in (("a", BRANCH_A), ("b", BRANCH_B)):
        if label == "b":
            chain.append(Branch("ground"))
        for k, (t, rotations, joint, joint_axis, (m, c, moments)) in enumerate(branch):
            chain += [Offset(t, rotations), Joint(f"{label}{k}", joint, joint_axis),
                      Body(f"{label}{k}_body", shapes.from_inertia_tensor(m, c, tensor(moments).tolist()))]
        if label == "a":
            chain.append(Point("CA", POINT_A))
        else:
            t, angles = closing_offset()
            chain += [Offset(t, angles), Point("CB")]
    closure = Closure("L", ("CA", "CB"), kind, axis, closure_rows(kind, axis))
    return Model(f"loop_{kind}", (Parameter("unused", 1.0),), tuple(chain), gravity=GRAVITY,
                 constraints=closure.constraints(), closures=(closure,))


PIN_JOINTS = {("revolute", "x"): "JointModelRX", ("revolute", "y"): "JointModelRY", ("revolute", "z"): "JointModelRZ",
              ("prismatic", "x"): "JointModelPX"}


def pinocchio_model():
    model = pin.Model()
    frames = {}
    for label, branch in (("a", BRANCH_A), ("b", BRANCH_B)):
        parent = 0
        for k, (t, rotations, joint, joint_axis, (m, c, moments)) in enumerate(branch):
            T = placement(t, rotations)
            parent = model.addJoint(parent, getattr(pin, PIN_JOINTS[joint, joint_axis])(), pin.SE3(T[:3, :3], T[:3, 3]),
                                    f"{label}{k}")
            model.appendBodyToJoint(parent, pin.Inertia(m, np.array(c), tensor(moments)), pin.SE3.Identity())
        if label == "a":
            where = pin.SE3(np.eye(3), np.array(POINT_A))
        else:
            t, angles = closing_offset()
            T = placement(t, angles)
            where = pin.SE3(T[:3, :3], T[:3, 3])
        name = "CA" if label == "a" else "CB"
        frames[name] = model.addFrame(pin.Frame(name, parent, 0, where, pin.FrameType.OP_FRAME))
    model.gravity.linear = np.array(GRAVITY)
    return model, frames


def pinocchio_rows(model, data, frames, closure, q, qd):
    """The closure's rows at (q, q̇) from Pinocchio's frames: values Φ, Jacobian J and the
    velocity-product part γ of Φ̈, by the rows' formulas (coincidence x_B - x_A; orientation
    a_A·b_B; slide (p_B - p_A)·e_A)."""
    n = model.nv
    pin.forwardKinematics(model, data, q, qd, np.zeros(n))
    pin.computeJointJacobians(model, data, q)
    pin.updateFramePlacements(model, data)
    world = pin.ReferenceFrame.LOCAL_WORLD_ALIGNED
    got = {}
    for name, fid in frames.items():
        J = pin.getFrameJacobian(model, data, fid, world)
        v = pin.getFrameVelocity(model, data, fid, world)
        a = pin.getFrameClassicalAcceleration(model, data, fid, world)
        got[name] = dict(p=data.oMf[fid].translation.copy(), R=data.oMf[fid].rotation.copy(), Jv=J[:3], Jw=J[3:],
                         v=v.linear.copy(), w=v.angular.copy(), a=a.linear.copy(), dw=a.angular.copy())
    A, B = got["CA"], got["CB"]
    values, rows, gammas = [], [], []
    for label in closure.rows:
        if label in ("x", "y", "z"):
            k = "xyz".index(label)
            values.append(B["p"][k] - A["p"][k])
            rows.append(B["Jv"][k] - A["Jv"][k])
            gammas.append(B["a"][k] - A["a"][k])
        elif label.endswith("1"):
            e = A["R"][:, "xyz".index(label[0])]
            r, dv = B["p"] - A["p"], B["v"] - A["v"]
            values.append(r @ e)
            rows.append(e @ (B["Jv"] - A["Jv"]) + np.cross(e, r) @ A["Jw"])
            gammas.append((B["a"] - A["a"]) @ e + 2 * dv @ np.cross(A["w"], e)
                          + r @ (np.cross(A["dw"], e) + np.cross(A["w"], np.cross(A["w"], e))))
        else:
            a1, b2 = A["R"][:, "xyz".index(label[0])], B["R"][:, "xyz".index(label[1])]
            axis = np.cross(b2, a1)
            values.append(a1 @ b2)
            rows.append(axis @ (B["Jw"] - A["Jw"]))
            gammas.append((B["dw"] - A["dw"]) @ axis + (B["w"] - A["w"]) @ (
                np.cross(np.cross(B["w"], b2), a1) + np.cross(b2, np.cross(A["w"], a1))))
    return np.array(values), np.array(rows), np.array(gammas), got


def expected_reaction(closure, lam, got):
    """Force and moment on CB's body from λ by the rows' virtual work, with Pinocchio's frames."""
    force, moment = np.zeros(3), np.zeros(3)
    for label, value in zip(closure.rows, lam):
        if label in ("x", "y", "z"):
            force["xyz".index(label)] += value
        elif label.endswith("1"):
            force += value * got["CA"]["R"][:, "xyz".index(label[0])]
        else:
            a1, b2 = got["CA"]["R"][:, "xyz".index(label[0])], got["CB"]["R"][:, "xyz".index(label[1])]
            moment += value * np.cross(b2, a1)
    return force, moment


@pytest.mark.parametrize("kind, axis", [("point", None), ("revolute", "z"), ("prismatic", "x")])
def test_spatial_loop_matches_kkt_on_pinocchio(env, rng, kind, axis):
    """At random consistent states (assembled from random guesses near the closed q = 0), q̈ and
    λ of the GPME against the KKT system of Pinocchio's M and nonlinear effects with the
    closure's rows from Pinocchio's frames, to 1e-10 of their size; the generated D against
    central differences of Pinocchio's row values; the reported reaction against λ's."""
    if pin is None:
        pytest.skip("pinocchio is not installed")
    model = spatial_model(kind, axis)
    closure = model.closures[0]
    assert len(closure.rows) == {"point": 3, "revolute": 5, "prismatic": 5}[kind]
    loaded = gpmegen.load(model=model, backend="numpy", directory=env[0])
    pmodel, frames = pinocchio_model()
    data = pmodel.createData()
    n = loaded.n_dof
    checked = 0
    while checked < 3:
        guess = rng.uniform(-0.3, 0.3, n)
        at = partition.partition_at(loaded, guess)
        try:
            q = consistent.project_onto_constraints(at, guess)
        except SimulationError:
            continue
        qd = consistent.project_velocities(at, q, rng.uniform(-1.5, 1.5, n))
        values, J, gamma, got = pinocchio_rows(pmodel, data, frames, closure, q, qd)
        assert np.max(np.abs(values)) < 1e-11
        phi, _, D, _ = loaded.constraint_terms(0.0, q, qd)
        np.testing.assert_allclose(D, J, rtol=0, atol=1e-12 * np.abs(J).max())
        eps, fd = 1e-6, np.zeros_like(J)
        for j in range(n):
            step = np.zeros(n)
            step[j] = eps
            fd[:, j] = (pinocchio_rows(pmodel, data, frames, closure, q + step, qd)[0]
                        - pinocchio_rows(pmodel, data, frames, closure, q - step, qd)[0]) / (2 * eps)
        np.testing.assert_allclose(D, fd, rtol=0, atol=1e-8)
        M = pin.crba(pmodel, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        nle = pin.rnea(pmodel, data, q, qd, np.zeros(n))
        m = len(closure.rows)
        kkt = np.block([[M, -J.T], [J, np.zeros((m, m))]])
        solution = np.linalg.solve(kkt, np.concatenate([-nle, -gamma]))
        qdd_ref, lam_ref = solution[:n], solution[n:]
        qdd, M_ours, f = loaded.motion(0.0, q, qd)
        lam = gpme.multipliers(M_ours, f, qdd, D)
        np.testing.assert_allclose(qdd, qdd_ref, rtol=0, atol=1e-10 * np.abs(qdd_ref).max())
        np.testing.assert_allclose(lam, lam_ref, rtol=0, atol=1e-10 * np.abs(lam_ref).max())
        reaction = closure_reactions.reactions(model, q[None], lam[None], loaded.p)["L"]
        force, moment = expected_reaction(closure, lam_ref, got)
        size = max(np.abs(force).max(), np.abs(moment).max())
        np.testing.assert_allclose(reaction["force"][0], force, rtol=0, atol=1e-10 * size)
        if kind == "point":
            assert "moment" not in reaction
        else:
            np.testing.assert_allclose(reaction["moment"][0], moment, rtol=0, atol=1e-10 * size)
            assert np.abs(moment).max() > 1e-3 * size   # a moment is carried
        checked += 1


# ---- rows that vanish, redundant rows, refusals, assembly -------------------------------------

@pytest.mark.parametrize("kind, kept, dropped", [
    ('type = "revolute"\naxis = "z"', ("x", "y"), ("z", "zx", "zy")),
    ('type = "point"', ("x", "y"), ("z",)),
    ('type = "prismatic"\naxis = "x"', ("y1", "xy"), ("z1", "xz", "yz")),
], ids=["revolute", "point", "prismatic"])
def test_rows_that_vanish_identically_are_dropped_by_name(tmp_path, kind, kept, dropped):
    """With every joint axis along z and every offset in the plane, the closure's out-of-plane
    coincidence row and the orientation rows about axes in the plane vanish identically: exactly
    those are dropped, each with one warning line naming the closure and the row, and the
    constraints hold the others. A prismatic closure along the coupler's x keeps its in-plane
    slide row and the row that holds the relative turn about z (x₁·y₂)."""
    path = tmp_path / "four_bar.toml"
    text = four_bar_text(**{'["C1", "C2"]\ntype = "revolute"\naxis = "z"': f'["C1", "C2"]\n{kind}'})
    path.write_text(text)
    with pytest.warns(ModelWarning) as caught:
        model = read_model_file(path).model
    lines = [str(w.message) for w in caught]
    assert lines == [f"closure 'C': row {label!r} ({model.closures[0].describe(label)}) vanishes identically on this "
                     f"chain and is dropped" for label in dropped]
    assert model.closures[0].rows == kept
    assert [c.name for c in model.constraints] == [f"C_{label}" for label in kept] + ["prescribed_theta1"]


# the four-bar in a plane turned about x0 by tilt, gravity turned with it: the closure's rows x, y,
# z and its orientation rows are written in 3-D and none vanishes by its form (tilt is a
# parameter), but the loop moves in its plane: D has rank 3 for its 6 rows everywhere
TILTED = {
    'gravity = [0, "-g", 0]': 'gravity = [0, "-g*cos(tilt)", "-g*sin(tilt)"]',
    'w = {': 'tilt = { value = 0.3, unit = "rad", doc = "turn of the plane about x0" }\nw = {',
    '[[chain]]\njoint = "theta1"': '[[chain]]\nrotations = [["x", "tilt"]]\n\n[[chain]]\njoint = "theta1"',
    'translation = ["d", 0, 0]': 'translation = ["d", 0, 0]\nrotations = [["x", "tilt"]]',
    'name = "four_bar"': 'name = "four_bar_tilted"'}
REDUNDANT_WARNING = ("closure 'C': its rows C_y, C_z, C_zx, C_zy are redundant at the start (the constraint Jacobian "
                     "has rank 3 for 6 rows): the accelerations come from the independent rows; the reactions are "
                     "not unique, and those shown are the minimum-norm ones")


@pytest.fixture(scope="module")
def tilted_path(tmp_path_factory):
    path = tmp_path_factory.mktemp("tilted") / "four_bar_tilted.toml"
    path.write_text(four_bar_text(**TILTED))
    return path


@pytest.fixture(scope="module")
def tilted_run(tilted_path, env):
    """0.5 s of the tilted four-bar on the NumPy backend, with the warnings it gave."""
    with pytest.warns(ModelWarning) as caught:
        run = gpmegen.simulate(str(tilted_path), t_end=0.5, dt=1e-3, save_every=10, backend="numpy",
                               directory=env[0])
    return run, [str(w.message) for w in caught]


def test_redundant_rows_run_with_one_warning_and_follow_the_exact_analysis(tilted_run):
    """The tilted four-bar closed by a revolute: its rows are consistent and redundant (rank 3 of
    6): the run completes, one warning names the closure and its redundant rows, and the coupler
    and rocker follow the closed-form four-bar to 1e-8 rad, the loop held to round-off."""
    run, warned = tilted_run
    assert warned == [REDUNDANT_WARNING]
    assert run.status == "complete"
    assert list(run["constraint_names"]) == ["C_x", "C_y", "C_z", "C_zx", "C_zy", "prescribed_theta1"]
    coupler, rocker = exact_four_bar(run.coordinate("theta1"))
    assert np.max(np.abs(wrapped(run.coordinate("theta2") - coupler))) < 1e-8
    assert np.max(np.abs(wrapped(run.coordinate("theta3") - rocker))) < 1e-8
    assert np.max(np.abs(run["phi"])) < 1e-9


def test_redundant_rows_give_the_point_closed_accelerations_and_minimum_norm_reactions(tilted_run, tilted_path, env):
    """At every saved state of the tilted run, q̈ equals that of the planar four-bar closed by a
    point (rows x, y, independent) at the same coordinates, to round-off; λ satisfies
    M q̈ - f = Dᵀλ to round-off and is the minimum-norm one (orthogonal to the combinations of
    rows that vanish: λ in the range of D)."""
    run, _ = tilted_run
    tilted = gpmegen.load(model=read_model_file(tilted_path).model, backend="numpy", directory=env[0])
    path = tilted_path.parent / "four_bar_point.toml"
    path.write_text(four_bar_text(**{'["C1", "C2"]\ntype = "revolute"\naxis = "z"': '["C1", "C2"]\ntype = "point"',
                                     'name = "four_bar"': 'name = "four_bar_point"'}))
    with pytest.warns(ModelWarning):   # the z row vanishes identically
        point = gpmegen.load(model=read_model_file(path).model, backend="numpy", directory=env[0])
    for q, qd, qdd, lam in zip(run["q"], run["qd"], run["qdd"], run["lambda"]):
        expected = point.accelerations(0.0, q, qd)
        np.testing.assert_allclose(qdd, expected, rtol=0, atol=1e-10 * np.abs(expected).max())
        M, f = tilted.mass_matrix(q), tilted.forces(0.0, q, qd)
        D = tilted.constraint_terms(0.0, q, qd)[2]
        residual = M @ qdd - f
        np.testing.assert_allclose(D.T @ lam, residual, rtol=0, atol=1e-10 * np.abs(residual).max())
        U, sigma, _ = np.linalg.svd(D)
        null = U[:, int(np.sum(sigma > 1e-9 * sigma[0])):]
        assert null.shape[1] == 3
        assert np.abs(null.T @ lam).max() < 1e-10 * np.abs(lam).max()


@pytest.mark.long   # a model of its own compiled (about 12 s); the NumPy solve is checked above
@pytest.mark.requires_cc
@pytest.mark.parametrize("method", ["rk4", "genalpha", "dop853", "radau"])
def test_redundant_rows_run_on_the_c_backend(tilted_run, tilted_path, env, method):
    """The same run on the C backend, by each integrator: complete, the exact four-bar to 1e-8
    rad, the same reactions as the NumPy run (RK4: the same steps, to 1e-9 of their size)."""
    with pytest.warns(ModelWarning):
        run = gpmegen.simulate(str(tilted_path), t_end=0.5, dt=1e-3, save_every=10, backend="c", method=method,
                               directory=env[0])
    assert run.status == "complete"
    coupler, rocker = exact_four_bar(run.coordinate("theta1"))
    assert np.max(np.abs(wrapped(run.coordinate("theta2") - coupler))) < 1e-8
    assert np.max(np.abs(wrapped(run.coordinate("theta3") - rocker))) < 1e-8
    if method == "rk4":
        lam = tilted_run[0]["lambda"]
        np.testing.assert_allclose(run["lambda"], lam, rtol=0, atol=1e-9 * np.abs(lam).max())


@pytest.fixture(scope="module")
def tilted_jacobians(tilted_path, tmp_path_factory):
    """The folder of the tilted four-bar compiled with its generated Jacobians, and the model."""
    folder = tmp_path_factory.mktemp("jacobians")
    loaded = gpmegen.load(model=read_model_file(tilted_path).model, backend="c", jacobians=True, directory=folder)
    assert loaded.jacobians_built
    return folder, loaded


@pytest.mark.long   # a model of its own compiled with its Jacobians (about 20 s)
@pytest.mark.requires_cc
def test_generated_c_jacobians_of_redundant_rows_are_those_of_the_independent_rows(tilted_run, tilted_jacobians):
    """At saved states of the tilted four-bar, moving, the C library's exact acceleration
    Jacobians (their KKT system on the rows independent at the state) equal the NumPy ones on the
    same rows to 1e-10 of their size, and central differences of the accelerations to 1e-6."""
    run, _ = tilted_run
    loaded = consistent.check_redundant(tilted_jacobians[1], run["q"][0], {}, warn=False)
    assert loaded.redundant
    for k in (0, 20, 45):
        t, q, qd = run["t"][k], run["q"][k], run["qd"][k]
        qdd, A_q, A_qd = loaded.evaluator.acceleration_jacobians(t, q, qd, loaded)
        expected = redundant_acceleration_jacobians(loaded.evaluator, t, q, qd, loaded)
        np.testing.assert_allclose(qdd, expected[0], rtol=0, atol=1e-12 * np.abs(qdd).max())
        for got, want in zip((A_q, A_qd), expected[1:]):
            np.testing.assert_allclose(got, want, rtol=0, atol=1e-10 * np.abs(want).max())
        h = 1e-6
        for j in range(loaded.n_dof):
            step = h * (np.arange(loaded.n_dof) == j)
            column_q = (loaded.accelerations(t, q + step, qd) - loaded.accelerations(t, q - step, qd)) / (2 * h)
            column_qd = (loaded.accelerations(t, q, qd + step) - loaded.accelerations(t, q, qd - step)) / (2 * h)
            np.testing.assert_allclose(A_q[:, j], column_q, rtol=0, atol=1e-6 * np.abs(A_q).max())
            np.testing.assert_allclose(A_qd[:, j], column_qd, rtol=0, atol=1e-6 * np.abs(A_qd).max())


@pytest.mark.long   # the model compiled with its Jacobians (about 20 s, shared with the test above)
@pytest.mark.requires_cc
def test_radau_with_generated_jacobians_runs_redundant_rows_as_rk4(tilted_run, tilted_path, tilted_jacobians):
    """Radau IIA with the generated Jacobians (gpmegen build --jacobians), whose system takes the
    rows independent at each state: the tilted four-bar runs to its end, no singular stop, and
    follows the NumPy RK4 run of the same model (1e-3 s steps, error about 1e-11) and the
    closed-form four-bar to 1e-8 rad."""
    folder = tilted_jacobians[0]
    with pytest.warns(ModelWarning) as caught:
        run = gpmegen.simulate(str(tilted_path), t_end=0.5, dt=1e-3, save_every=10, backend="c", method="radau",
                               directory=folder, rtol=1e-10, atol=1e-12)
    assert [str(w.message) for w in caught] == [REDUNDANT_WARNING]
    assert run.status == "complete"
    assert run.meta["settings"]["effort"]["jacobians"] >= 1
    reference = tilted_run[0]
    np.testing.assert_allclose(run["t"], reference["t"], rtol=0, atol=1e-12)
    assert np.max(np.abs(run["q"] - reference["q"])) < 1e-8
    coupler, rocker = exact_four_bar(run.coordinate("theta1"))
    assert np.max(np.abs(wrapped(run.coordinate("theta2") - coupler))) < 1e-8
    assert np.max(np.abs(wrapped(run.coordinate("theta3") - rocker))) < 1e-8


# the four-bar with L1 = L3 and L2 = d (a parallelogram) started folded flat (every link along
# x0): its closure's rows x and y are dependent there (rank 2 of 3 with the crank's), and
# independent as soon as the crank has turned
FOLDED = {'["C1", "C2"]\ntype = "revolute"\naxis = "z"': '["C1", "C2"]\ntype = "point"',
          'name = "four_bar"': 'name = "four_bar_folded"', 'L1 = { value = 0.1': 'L1 = { value = 0.25',
          'q = { theta1 = 0, theta2 = 1.0, theta3 = 1.7 }': 'q = { theta1 = 0, theta2 = 0, theta3 = 0 }'}


def test_a_rank_that_changes_along_a_run_is_said_once_with_the_closure_and_the_time(tmp_path, env):
    """Started where its rows are redundant, the folded parallelogram runs on, and one line (after
    the start's) names the closure and the first instant the run looks at (0.05 s) where its
    rows are independent again; the run completes."""
    path = tmp_path / "four_bar_folded.toml"
    path.write_text(four_bar_text(**FOLDED))
    with pytest.warns(ModelWarning) as caught:
        run = gpmegen.simulate(str(path), t_end=0.2, dt=1e-3, save_every=10, backend="numpy", directory=env[0])
    lines = [str(w.message) for w in caught if "vanishes identically" not in str(w.message)]
    assert lines == [
        "closure 'C': its rows C_x are redundant at the start (the constraint Jacobian has rank 2 for 3 rows): the "
        "accelerations come from the independent rows; the reactions are not unique, and those shown are the "
        "minimum-norm ones",
        "closure 'C': its rows C_x, redundant at the start, are independent again at t = 0.05 s (the constraint "
        "Jacobian has rank 3 for 3 rows, 2 at the start): the accelerations come from the rows independent there"]
    assert run.status == "complete"


def test_redundant_rows_that_drift_from_the_kept_ones_are_said_once_with_the_closure_and_the_time(tilted_run,
                                                                                                  tilted_path, env):
    """At the tilted run's saved states the rows left out follow from the kept ones to round-off
    (Φ_J - C Φ_K below 1e-12) and nothing is said; a value of a row left out moved by 1e-5 (a
    loop whose dimensions close only nearly) is that difference, said once naming the closure,
    its row and the time; a move of 1e-8, below the threshold, is not."""
    from gpmegen.runtime import redundancy

    run, _ = tilted_run
    loaded = gpmegen.load(model=read_model_file(tilted_path).model, backend="numpy", directory=env[0])
    loaded = loaded.with_closure_rows({"C": ["C_x", "C_y", "C_z", "C_zx", "C_zy"]})
    terms = [loaded.constraint_terms(t, q, qd) for t, q, qd in zip(run["t"], run["q"], run["qd"])]
    for phi, _, D, _ in terms:
        out, e = redundancy.drift(phi, D, loaded.constraint_orders)
        assert len(out) == 3 and np.max(np.abs(e)) < 1e-12
    phi, _, D, _ = terms[10]
    out, e0 = redundancy.drift(phi, D, loaded.constraint_orders)
    row = int(out[0])
    watch = redundancy.RowWatch(loaded, terms[0][2])
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        watch.check(run["t"][10], phi + 1e-8 * (np.arange(len(phi)) == row), D)
    moved = phi + 1e-5 * (np.arange(len(phi)) == row)
    out, e = redundancy.drift(moved, D, loaded.constraint_orders)
    np.testing.assert_allclose(e - e0, 1e-5 * (out == row), rtol=0, atol=1e-14)
    with pytest.warns(ModelWarning) as caught:
        watch.check(run["t"][10], moved, D)
        watch.check(run["t"][11], moved, D)   # said once
    assert [str(w.message) for w in caught] == [
        f"closure 'C': its redundant rows {loaded.constraint_names[row]} drift from the rows kept at "
        f"t = {run['t'][10]:.6g} s: they differ from the combination of the kept rows by {abs(e[out == row][0]):.3e} "
        f"(above 1e-06), which the solve, taking the kept rows only, cannot correct; the loop's dimensions close "
        f"only nearly: make them close exactly, or the rows independent"]


BRICARD = ROOT / "tests" / "models" / "bricard.toml"


@pytest.fixture(scope="module")
def bricard_run(env):
    """0.5 s of Bricard's threefold-symmetric 6R loop swinging from rest under gravity (NumPy
    backend, RK4 at 1e-3 s), with the warnings it gave."""
    with pytest.warns(ModelWarning) as caught:
        run = gpmegen.simulate(str(BRICARD), t_end=0.5, dt=1e-3, save_every=10, backend="numpy", directory=env[0])
    return run, [str(w.message) for w in caught]


def test_bricard_linkage_moves_with_one_warning_on_its_redundant_row(bricard_run):
    """Six links and six revolute joints in a loop (Grübler: no motion) move with one degree of
    freedom: the closure's five rows have rank four with the five joints. The run completes,
    with one warning naming the closure, and no other line along it (the rank stays four)."""
    run, warned = bricard_run
    assert warned == [
        "closure 'C': its rows C_x, C_y, C_z, C_zx, C_zy are redundant at the start (the constraint Jacobian has "
        "rank 4 for 5 rows): the accelerations come from the independent rows; the reactions are not unique, and "
        "those shown are the minimum-norm ones"]
    assert run.status == "complete"
    assert list(run["constraint_names"]) == ["C_x", "C_y", "C_z", "C_zx", "C_zy"]


def test_bricard_linkage_follows_its_closed_form_and_closes_its_energy_balance(bricard_run):
    """Along the swing, which passes the turn where theta2 changes sign (x = -2π/3, from one
    half of the loop's curve to the other), the joint angles keep theta1 = theta3 = theta5,
    theta2 = theta4 and (1 + cos theta1)(1 + cos theta2) = 1 to 1e-8; the loop holds to 1e-8
    (m, and for the orientation rows, the sine of the angle between the axes); kinetic and
    gravity energy exchange with a balance that closes to 1e-7 of the energy exchanged."""
    run, _ = bricard_run
    x, y = run.coordinate("theta1"), run.coordinate("theta2")
    assert y[0] > 1.0 and y.min() < -0.5   # both halves of the curve
    assert np.max(np.abs(run.coordinate("theta3") - x)) < 1e-8
    assert np.max(np.abs(run.coordinate("theta5") - x)) < 1e-8
    assert np.max(np.abs(run.coordinate("theta4") - y)) < 1e-8
    assert np.max(np.abs((1 + np.cos(x)) * (1 + np.cos(y)) - 1)) < 1e-8
    assert np.max(np.abs(run["phi"])) < 1e-8
    exchanged = np.ptp(run["kinetic_energy"])
    assert exchanged > 0.05
    assert np.abs(energy.balance_residual(run.arrays)).max() < 1e-7 * exchanged


@pytest.mark.long   # the linkage compiled with its Jacobians (about 25 s)
@pytest.mark.requires_cc
def test_bricard_linkage_runs_by_radau_with_generated_jacobians_as_by_rk4(bricard_run, tmp_path_factory):
    """On the C backend, built with its Jacobians: RK4 gives the NumPy run's states to 1e-12;
    Radau IIA (tolerances 1e-10, 1e-12) completes with the one warning, follows the RK4 run to
    1e-8 and the closed form to 1e-8."""
    folder = tmp_path_factory.mktemp("bricard")
    gpmegen.load(model=read_model_file(BRICARD).model, backend="c", jacobians=True, directory=folder)
    reference, warned = bricard_run
    for method in ("rk4", "radau"):
        with pytest.warns(ModelWarning) as caught:
            run = gpmegen.simulate(str(BRICARD), t_end=0.5, dt=1e-3, save_every=10, backend="c", method=method,
                                   directory=folder, rtol=1e-10, atol=1e-12)
        assert [str(w.message) for w in caught] == warned
        assert run.status == "complete"
        assert run.meta["settings"]["effort"]["jacobians"] >= (1 if method == "radau" else 0)
        np.testing.assert_allclose(run["t"], reference["t"], rtol=0, atol=1e-12)
        assert np.max(np.abs(run["q"] - reference["q"])) < (1e-12 if method == "rk4" else 1e-8)
        x, y = run.coordinate("theta1"), run.coordinate("theta2")
        assert np.max(np.abs((1 + np.cos(x)) * (1 + np.cos(y)) - 1)) < 1e-8


def test_redundant_rows_warn_once_on_the_command_line_and_a_loop_that_cannot_close_stops(tilted_path, capsys):
    """gpmegen simulate prints the warning on the redundant rows once, and no singular stop;
    with a ground link too long for the loop, its redundant rows cannot hold together and the
    start is refused in one line naming the closure."""
    assert main(["simulate", str(tilted_path), "--t-end", "0.01", "--dt", "1e-3", "--backend", "numpy",
                 "--out", str(tilted_path.parent / "tilted.npz")]) == 0
    err = capsys.readouterr().err
    assert err.count("are redundant at the start") == 1 and REDUNDANT_WARNING in err
    assert "singular" not in err
    assert main(["statics", str(tilted_path), "--param", "d=1.0"]) == 1
    err = capsys.readouterr().err
    line = [line for line in err.splitlines() if "error" in line]
    assert len(line) == 1 and "closure 'C' (residual " in line[0] and "cannot be closed" in line[0]
    assert "Traceback" not in err


def test_assembly_reports_what_moved_and_names_a_loop_that_cannot_close(tmp_path, env, capsys):
    """From the example's rough [initial] q the start moves theta2 and theta3 onto the loop and
    says by how much (no warning); with a ground link longer than the other three together the
    loop cannot close, and the refusal names the closure and its residual."""
    assert main(["statics", str(FOUR_BAR)]) == 0
    err = capsys.readouterr().err
    coupler, rocker = exact_four_bar(0.0)
    assert (f"the loops assembled by moving theta2 from 1 to {coupler:.6g} ({coupler - 1.0:+.3e}), "
            f"theta3 from 1.7 to {rocker:.6g} ({rocker - 1.7:+.3e})") in err
    assert "warning: the start" not in err
    assert main(["statics", str(FOUR_BAR), "--param", "d=1.0"]) == 1
    err = capsys.readouterr().err
    line = [line for line in err.splitlines() if "error" in line]
    assert len(line) == 1 and "closure 'C' (residual " in line[0] and "cannot be closed" in line[0]
    assert "Traceback" not in err


@pytest.mark.parametrize("change, message", [
    ({'points = ["C1", "C2"]': 'points = ["C1", "C1b"]',
      '[[chain]]\npoint = "C1"': '[[chain]]\npoint = "C1b"\n\n[[chain]]\npoint = "C1"'},
     "closure 'C': points 'C1' and 'C1b' are both on the same body, so the closure holds nothing; close the loop "
     "between points on two different bodies"),
    ({'points = ["C1", "C2"]': 'points = ["C1", "C3"]'},
     "closures[0].points[1]: closure 'C': no point 'C3'; declare it with a [[chain]] point = \"C3\" element"),
    ({'type = "revolute"\naxis = "z"\nalpha': 'type = "revolute"\nalpha'},
     "closures[0]: closure 'C': a revolute closure needs its axis; add axis = \"x\", \"y\" or \"z\""),
    ({'type = "revolute"\naxis = "z"\nalpha': 'type = "hinge"\naxis = "z"\nalpha'},
     "closures[0].type: closure 'C': unknown type 'hinge'; use \"point\", \"revolute\", \"prismatic\""),
    ({'name = "C"\npoints': 'name = "B"\npoints'},
     "closures[0].name: closure 'B' is named 'B', and that name is already taken by a point; rename the closure"),
    ({'name = "C"\npoints': 'name = "theta1"\npoints'},
     "closures[0].name: the row 'x' of closure 'theta1' is named 'theta1_x'"),
], ids=["same_body", "missing_point", "no_axis", "unknown_type", "name_taken", "row_name_taken"])
def test_bad_closures_are_refused_in_one_line(tmp_path, capsys, change, message):
    """gpmegen build refuses each bad closure with exit status 2 and one line naming it and the
    fix, before anything is derived."""
    path = tmp_path / "four_bar.toml"
    path.write_text(four_bar_text(**change))
    if "theta1_x" in message:   # a row's name taken by a coordinate: give the crank that name
        path.write_text(path.read_text().replace('joint = "theta1"', 'joint = "theta1_x"')
                        .replace("theta1 = 0", "theta1_x = 0"))
        message = "closures[0].name: the row 'x' of closure 'theta1' is named 'theta1_x', and that name is already " \
                  "taken by a coordinate; rename the closure"
    assert main(["build", str(path), "--out", str(tmp_path / "built")]) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err
    errors = [line for line in err.splitlines() if "error" in line]
    assert len(errors) == 1 and message in errors[0], err
    assert not (tmp_path / "built").exists()
