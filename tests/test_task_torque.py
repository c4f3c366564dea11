"""Task-space computed torque with a controller model (docs/model-file.md "Task space"): a
perfect model's tip on its path and its error against the closed-form error dynamics, the tip's
acceleration against the commanded one by hand-written planar kinematics, the two backends' laws
against each other, the spatial arm in three components, and the refusals, one line each."""

from pathlib import Path

import numpy as np
import pytest
from backends import each_backend, on

import gpmegen
from gpmegen.errors import ModelError
from gpmegen.symbolic import derive

ARM = Path(__file__).parent / "models" / "ct_task_arm.toml"
SPATIAL = Path(__file__).parents[1] / "examples" / "manipulator_task_space.toml"
L1, L2, A, W, WN = 0.5, 0.4, 0.1, 2.0, 10.0   # ct_task_arm.toml's lengths, path and kp = wn², kd = 2 wn


def tip(q1, q2):
    """E of the planar two-link arm, (len, 2): x = L1 cos q1 + L2 cos(q1 + q2), likewise y."""
    return np.stack([L1 * np.cos(q1) + L2 * np.cos(q1 + q2), L1 * np.sin(q1) + L2 * np.sin(q1 + q2)], axis=-1)


def path(t):
    """``(x_r, ẋ_r, ẍ_r)`` of ct_task_arm.toml's signals at times ``t``, (len(t), 2) each."""
    x = np.stack([L1 - A * (1 - np.cos(W * t)), L2 - A * np.sin(W * t) ** 2], axis=-1)
    xd = np.stack([-A * W * np.sin(W * t), -A * W * np.sin(2 * W * t)], axis=-1)
    xdd = np.stack([-A * W**2 * np.cos(W * t), -2 * A * W**2 * np.cos(2 * W * t)], axis=-1)
    return x, xd, xdd


def test_perfect_model_tracks_the_path():
    """Started on the path (at rest at its start), E follows it to 1e-8 over 3 s (RK4, 1 ms)."""
    run = gpmegen.simulate(ARM, t_end=3.0, dt=1e-3, backend="c")
    x, _, _ = path(run.t)
    assert run.status == "complete"
    assert np.abs(tip(run.coordinate("theta1"), run.coordinate("theta2")) - x).max() < 1e-8


def test_perfect_model_task_error_is_critically_damped():
    """Started with the first joint d1 off (so E off its path by e0 at rest), each component of
    e = x_r - x follows ë + 2ω ė + ω² e = 0 from e(0) = e0, ė(0) = 0: e0 (1 + ω t) exp(-ω t)."""
    d1 = 0.05
    run = gpmegen.simulate(ARM, t_end=2.0, dt=1e-3, backend="c", params={"d1": d1})
    x, _, _ = path(run.t)
    e0 = np.array([L1, L2]) - tip(np.array([-d1]), np.array([np.pi / 2]))[0]
    error = x - tip(run.coordinate("theta1"), run.coordinate("theta2"))
    closed = e0 * ((1 + WN * run.t) * np.exp(-WN * run.t))[:, None]
    assert np.abs(e0).min() > 0.01   # both components start off the path
    assert np.abs(error - closed).max() < 1e-6


@pytest.fixture(scope="module")
def loaded():
    return each_backend(gpmegen.load_model_file(ARM))


def test_tip_acceleration_is_the_commanded_one(loaded, rng):
    """With the plant its own controller model, J q̈ + J̇ q̇ = ẍ_r + kd (ẋ_r - ẋ) + kp (x_r - x) at
    any regular state, J and J̇ q̇ written out by hand for the two links."""
    model = on(loaded, "numpy")
    for _ in range(5):
        t = rng.uniform(0, 3)
        q = np.array([rng.uniform(-2, 2), rng.uniform(0.5, 2.5)])   # sin q2 > 0.47: J regular
        qd = rng.uniform(-2, 2, 2)
        s1, c1, s12, c12 = np.sin(q[0]), np.cos(q[0]), np.sin(q.sum()), np.cos(q.sum())
        jacobian = np.array([[-L1 * s1 - L2 * s12, -L2 * s12], [L1 * c1 + L2 * c12, L2 * c12]])
        w1, w12 = qd[0], qd.sum()
        bias = np.array([-L1 * c1 * w1**2 - L2 * c12 * w12**2, -L1 * s1 * w1**2 - L2 * s12 * w12**2])
        x, xd = tip(q[:1], q[1:])[0], jacobian @ qd
        r, rd, rdd = (v[0] for v in path(np.array([t])))
        commanded = rdd + 2 * WN * (rd - xd) + WN**2 * (r - x)
        got = jacobian @ model.accelerations(t, q, qd) + bias
        assert np.abs(got - commanded).max() < 1e-9 * max(1.0, np.abs(commanded).max())


def test_c_law_is_the_numpy_law(loaded, rng):
    numpy_model, c_model = on(loaded, "numpy"), on(loaded, "c")
    p = numpy_model.p
    for _ in range(10):
        t, q, qd = rng.uniform(0, 3), np.array([rng.uniform(-3, 3), rng.uniform(0.3, 2.8)]), rng.uniform(-3, 3, 2)
        expected = numpy_model.evaluator.drive_forces(t, q, qd, p)
        got = c_model.evaluator.drive_forces(t, q, qd, p)
        assert np.abs(got - expected).max() <= 1e-12 * max(1.0, np.abs(expected).max())


def test_spatial_arm_tracks_the_papers_path():
    """The example's plant at n_rfe 1 is its own (rigid) controller model: E, moved by a
    revolute column, a revolute arm and a slider, follows the path in x, y and z to 1e-8."""
    run = gpmegen.simulate(SPATIAL, nrfe=1, t_end=2.5, dt=1e-3, backend="c")
    t = run.t
    phi = 0.5 * (1 - np.cos(np.pi * t / 2.5)) / 2
    r_e, y_c = 1.5 * np.cos(np.pi / 4), 0.6 + 1.5 * np.sin(np.pi / 4) - 0.5
    x = np.stack([r_e * np.cos(phi), y_c + 0.5 * np.cos(2 * np.pi * t / 2.5), -r_e * np.sin(phi)], axis=-1)
    assert run.status == "complete"
    assert np.abs(run["end_effector"] - x).max() < 1e-8


def _law(body):
    return ARM.read_text().split("[[controller.task_space]]")[0] + body + '\n[initial]\nq = { theta2 = "pi/2" }\n'


LAW = ('[[controller.task_space]]\npoint = "E"\ncomponents = ["x", "y"]\nreference = ["xE_ref", "yE_ref"]\n'
       'kp = "wn^2"\nkd = "2*wn"\n')
REFUSALS = [
    ("tracks 3 components of E (x, y, z) with the controller's 2 joints (theta1, theta2), and J_c must be square",
     LAW.replace('components = ["x", "y"]\n', "").replace('"yE_ref"]', '"yE_ref", "yE_ref"]')),
    ("no point 'F' in the controller model (its points: E)", LAW.replace('point = "E"', 'point = "F"')),
    ("components ['x', 'w'] are not distinct axes", LAW.replace('["x", "y"]', '["x", "w"]')),
    ("components ['x', 'x'] are not distinct axes", LAW.replace('["x", "y"]', '["x", "x"]')),
    ("1 reference for the 2 components", LAW.replace(', "yE_ref"]', "]")),
    ("no signal 'zE_ref'", LAW.replace('"yE_ref"]', '"zE_ref"]')),
    ("2 task-space laws", LAW + "\n" + LAW),
    ("both act on theta1, theta2; give one of the two",
     LAW + "".join(f'\n[[controller.computed_torque]]\ncoordinate = "{c}"\nreference = "xE_ref"\nkp = 1\nkd = 1\n'
                   for c in ("theta1", "theta2"))),
    ("no law: add [[controller.computed_torque]]", ""),
    ("kp: time t may appear only in drives", LAW.replace('kp = "wn^2"', 'kp = "wn^2*t"')),
]


@pytest.mark.parametrize("message, body", REFUSALS)
def test_refusals(tmp_path, message, body):
    (tmp_path / "ct_task_arm.toml").write_text(ARM.read_text())   # the controller model
    plant = tmp_path / "plant.toml"
    plant.write_text(_law(body))
    with pytest.raises(ModelError) as caught:
        gpmegen.load_model_file(plant)
    text = str(caught.value)
    assert message in text and "\n" not in text and "plant.toml:" in text


def test_controller_with_more_joints_than_a_point_has_components_refused(tmp_path):
    six = Path(__file__).parents[1] / "examples" / "spatial_six_joint.toml"
    plant = tmp_path / "plant.toml"
    plant.write_text(_law(LAW.replace('components = ["x", "y"]\n', "")).replace('model = "ct_task_arm.toml"',
                                                                               f"model = {str(six)!r}"))
    with pytest.raises(ModelError) as caught:
        gpmegen.load_model_file(plant)
    text = str(caught.value)
    assert "has 6 joints" in text and "so J_c cannot be square; use a joint law" in text and "\n" not in text


def test_a_reference_that_switches_is_tracked(tmp_path):
    """x_r written with Min (a quintic move of D m in T0 s, then at rest) is differentiated branch
    by branch as the joint law's references are: the perfect model's E follows it to 1e-8
    through the switch at T0 and after it."""
    d, t0 = 0.05, 0.5
    s = f"Min(t/{t0}, 1)"
    text = ARM.read_text().replace('expression = "L1 - A*(1 - cos(w*t))"',
                                   f'expression = "L1 - {d}*{s}^3*(10 - 15*{s} + 6*{s}^2)"')
    assert text != ARM.read_text()
    path_file = tmp_path / "ct_task_arm.toml"
    path_file.write_text(text)
    run = gpmegen.simulate(path_file, t_end=1.0, dt=1e-3, backend="c")
    u = np.minimum(run.t / t0, 1.0)
    x_r = L1 - d * u**3 * (10 - 15 * u + 6 * u**2)
    y_r = path(run.t)[0][:, 1]   # the y reference is the file's, unchanged
    x = tip(run.coordinate("theta1"), run.coordinate("theta2"))
    assert run.status == "complete"
    assert np.abs(x[:, 0] - x_r).max() < 1e-8
    assert np.abs(x[:, 1] - y_r).max() < 1e-8


def test_run_saves_the_task_reference_and_error():
    """The results hold x_r of each component and x_r - x of the controller model's E at the
    saved states (here the plant itself): against the path and the tip written by hand."""
    run = gpmegen.simulate(ARM, t_end=0.5, dt=1e-3, backend="c", params={"d1": 0.05})
    x_r, _, _ = path(run.t)
    x = tip(run.coordinate("theta1"), run.coordinate("theta2"))
    assert [str(c) for c in run["reference_coordinates"]] == ["x_E", "y_E"]
    assert [str(u) for u in run["reference_units"]] == ["m", "m"]
    assert np.abs(run["q_reference"] - x_r).max() < 1e-12
    assert np.abs(run["tracking_error"] - (x_r - x)).max() < 1e-12
    assert np.abs(run["tracking_error"][0]).min() > 0.01   # started off the path: the error is seen


def test_the_saved_task_error_is_the_controller_models_point():
    """With the plant's first link 0.6 m and the controller model's 0.5 m (its default), the
    saved error is x_r less the controller's E at the plant's joints, not the plant's E."""
    run = gpmegen.simulate(ARM, t_end=0.2, dt=1e-3, backend="numpy", params={"L1": 0.6})
    q1, q2 = run.coordinate("theta1"), run.coordinate("theta2")
    x_r = np.stack([0.6 - A * (1 - np.cos(W * run.t)), L2 - A * np.sin(W * run.t) ** 2], axis=-1)
    believed = tip(q1, q2)   # L1 = 0.5
    plant = believed + 0.1 * np.stack([np.cos(q1), np.sin(q1)], axis=-1)
    assert np.abs(run["q_reference"] - x_r).max() < 1e-12
    assert np.abs(run["tracking_error"] - (x_r - believed)).max() < 1e-12
    assert np.abs(run["tracking_error"] - (x_r - plant)).max() > 0.05


def test_a_task_reference_that_jumps_is_warned_about(tmp_path):
    """A component's reference with a kink (ẋ_r jumps) is warned about in one line naming the
    field, as a joint law's; the smooth path is not."""
    assert derive(gpmegen.load_model_file(ARM)).warnings == ()
    text = ARM.read_text().replace('expression = "L1 - A*(1 - cos(w*t))"', 'expression = "L1 - A*Min(t, 0.5)"')
    text = text.replace('expression = "L2 - A*sin(w*t)^2"', 'expression = "L2 - A*Heaviside(t - 0.25)"')
    (tmp_path / "ct_task_arm.toml").write_text(text)
    warnings = derive(gpmegen.load_model_file(tmp_path / "ct_task_arm.toml")).warnings
    assert len(warnings) == 2 and not any("\n" in w for w in warnings), warnings
    assert warnings[0].startswith("controller.task_space.reference[0] (x): ẋ_r jumps at t = 0.5"), warnings
    assert warnings[1].startswith("controller.task_space.reference[1] (y): y_r jumps at t = 0.25"), warnings


def test_a_point_no_joint_motion_moves_along_every_component_is_refused_in_one_line(tmp_path, capsys):
    """A point on the first link (before theta2) moves with theta1 alone: J_c is singular at every
    pose, and 1/det(J_c) was printed as ComplexInfinity (an internal error). Refused at the law's
    line instead."""
    from gpmegen import cli

    theta2 = '[[chain]]\njoint = "theta2"'
    text = ARM.read_text().replace(theta2, '[[chain]]\npoint = "B"\n\n' + theta2)
    text = text.replace('[[controller.task_space]]\npoint = "E"', '[[controller.task_space]]\npoint = "B"')
    assert text.count('point = "B"') == 2
    (tmp_path / "ct_task_arm.toml").write_text(text)
    assert cli.main(["simulate", str(tmp_path / "ct_task_arm.toml"), "--backend", "numpy", "--t-end", "0.01",
                     "--out", str(tmp_path / "run.npz")]) != 0
    errors = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(errors) == 1 and "is singular at every pose (its determinant is 0)" in errors[0], errors
    assert "ct_task_arm.toml:" in errors[0] and "internal error" not in errors[0]
