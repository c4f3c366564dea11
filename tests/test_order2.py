"""Second-order programmed constraints (``order = 2``, linear in the accelerations).

- A position constraint and the same constraint written by hand as ``Φ̈ = 0`` (expanded in
  ``tests/models/reaching_arm_ddot.toml``, not by gpmegen) give the same motion from the same consistent start, and the
  second-order rows hold along the run.
- The curvature example's path has the prescribed curvature, computed from positions alone.
- Wrong second-order constraints and the starts they have none of are refused in one line.
"""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import gpmegen
from gpmegen.analysis.post import modes, point_motion
from gpmegen.analysis.run import study
from gpmegen.analysis.run.model_files import read_model_file
from gpmegen.cli import main
from gpmegen.errors import ModelError, SimulationError, StaticsError
from gpmegen.model.chain import TIME
from gpmegen.model.expand import expand
from gpmegen.runtime import integrators, partition, statics

ROOT = Path(__file__).resolve().parents[1]
REACHING = ROOT / "tests" / "models" / "reaching_arm.toml"
REACHING_DDOT = ROOT / "tests" / "models" / "reaching_arm_ddot.toml"
CURVATURE = ROOT / "examples" / "curvature_arm.toml"
TANGENTIAL = ROOT / "examples" / "manipulator_tangential.toml"

# The reaching arm's position constraints, as in its file, and their gains (left out in a
# second-order constraint); reaching_arm_ddot.toml holds the same constraints as Φ̈ = 0, by hand.
REACH = '"x_E^2 + y_E^2 - (r0 + A*(1 - cos(w*t)))^2"\nalpha = "alpha_c"\nbeta = "beta_c"'
SHOULDER = '"theta1 - B*(1 - cos(w*t))"\nalpha = "alpha_c"\nbeta = "beta_c"'


def _variant(tmp_path, name, *replacements):
    """A copy of the reaching arm's file named ``name``, with text replaced."""
    text = REACHING.read_text().replace('name = "reaching_arm_nrfe{nrfe}"', f'name = "{name}_nrfe{{nrfe}}"')
    for old, new in replacements:
        assert old in text, old
        text = text.replace(old, new)
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def _load(path, backend="c"):
    file = read_model_file(path)
    model = gpmegen.load(model=file.model, backend=backend)
    return model, file.initial_values(model.params)


def _residuals(model, t, y):
    """max |D q̈ + γ| at each saved state, q̈ from the GPME (computed here, beside
    ``constraint_values``, which must give the same)."""
    n = model.n_dof
    out = []
    for k, tk in enumerate(t):
        q, qd = y[k, :n], y[k, n:2 * n]
        _, _, D, gamma = model.constraint_terms(tk, q, qd)
        residual = D @ model.accelerations(tk, q, qd) + gamma
        assert np.array_equal(model.constraint_values(tk, q, qd), residual)
        out.append(np.max(np.abs(residual)))
    return np.array(out)


# make check-c: two models derived and run (a constraint of the second order on an example:
# test_tangential_example_follows_its_speed_law_on_the_circle)
@pytest.mark.long
@pytest.mark.requires_cc
def test_position_constraint_and_its_second_derivative_give_the_same_motion(env):
    position, initial = _load(REACHING)
    second, _ = _load(REACHING_DDOT)
    assert tuple(second.constraint_orders) == (2, 2)
    begun = study.file_start(position, initial, "none")
    position, q0 = begun.model, begun.q
    qd0 = np.zeros(position.n_dof)   # Φ = 0 (moved there) and Φ̇ = 0: both laws start at rest
    assert np.max(np.abs(position.constraint_terms(0.0, q0, qd0)[0])) <= 1e-12
    n = position.n_dof
    t, y0, end0 = integrators.rk4.rk4(position, q0, qd0, 1.0, 1e-4, 100)
    _, y2, end2 = integrators.rk4.rk4(second, q0, qd0, 1.0, 1e-4, 100)
    assert str(end0) == str(end2) == "complete"
    assert np.max(np.abs(y0[:, :2 * n] - y2[:, :2 * n])) <= 1e-8
    assert np.max(_residuals(second, t, y2)) <= 1e-10
    # the motion did move: the reach changed by A and the shoulder by B
    E = np.array([second.end_effector(q) for q in y2[:, :n]])
    p = second.params
    assert np.ptp(np.hypot(E[:, 0], E[:, 1])) > 0.9 * 2 * p["A"] * (1 - np.cos(p["w"])) / 2
    # a second-order constraint has no value of its own at a state
    assert np.all(second.constraint_terms(0.5, q0, qd0)[0] == 0)


@pytest.mark.requires_cc
def test_curvature_example_keeps_its_curvature_and_speed(env):
    file = read_model_file(CURVATURE)
    model = gpmegen.load(model=file.model, backend="c")
    begun = study.file_start(model, file.initial_values(model.params), "locked",
                             file.initial_velocities(model.params))
    model, q0, qd0 = begun.model, begun.q, begun.qd
    assert qd0[model.index("theta1")] == model.params["w0"]     # the file's [initial] qd
    t, y, end = integrators.rk4.rk4(model, q0, qd0, 1.0, 1e-4, 50)
    assert str(end) == "complete"
    n, p = model.n_dof, model.params
    v, a = np.zeros((len(t), 3)), np.zeros((len(t), 3))
    for k, tk in enumerate(t):
        q, qd = y[k, :n], y[k, n:2 * n]
        _, v[k], a[k] = point_motion.point_motion(model, "P", q, qd, model.accelerations(tk, q, qd))
    kappa = p["k0"] * (1 + p["k1"] * np.sin(2 * np.pi * t / p["Tk"]))
    assert np.max(np.abs(point_motion.curvature(v, a) - kappa)) <= 1e-6
    speed = np.hypot(v[:, 0], v[:, 1])
    assert np.max(np.abs(speed - speed[0])) <= 1e-8 * speed[0]
    # P turned through about the angle the curvature prescribes: ∫ κ |v| dt
    heading = np.unwrap(np.arctan2(v[:, 1], v[:, 0]))
    assert abs((heading[-1] - heading[0]) - np.trapezoid(kappa * speed, t)) <= 1e-4


@pytest.mark.requires_cc
def test_results_hold_the_second_order_residual(env, tmp_path):
    """The results' phi column holds each constraint as written: D q̈ + γ for a second-order one."""
    out = tmp_path / "run.npz"
    assert main(["simulate", str(TANGENTIAL), "--nrfe", "1", "--t-end", "0.05", "--dt", "1e-4", "--out",
                 str(out)]) == 0
    res = np.load(out)
    model = gpmegen.load(model=read_model_file(TANGENTIAL, 1).model, backend="c")
    for k in (0, len(res["t"]) // 2, -1):
        t, q, qd = res["t"][k], res["q"][k], res["qd"][k]
        _, _, D, gamma = model.constraint_terms(t, q, qd)
        assert res["phi"][k, 2] == (D @ model.accelerations(t, q, qd) + gamma)[2]
    assert np.max(np.abs(res["phi"])) <= 1e-10


@pytest.mark.requires_cc
def test_tangential_example_follows_its_speed_law_on_the_circle(env):
    """On the circle the tangent's rate is normal to the velocity, so the speed along the circle
    is the integral of the tangential acceleration the constraint prescribes."""
    file = read_model_file(TANGENTIAL, 2)
    model = gpmegen.load(model=file.model, backend="c")
    begun = study.file_start(model, file.initial_values(model.params), "locked")
    model, q0 = begun.model, begun.q
    n, p = model.n_dof, model.params
    t, y, end = integrators.rk4.rk4(model, q0, np.zeros(n), 1.0, 1e-5, 2000)
    assert str(end) == "complete"
    speed, along = np.zeros(len(t)), np.zeros(len(t))
    for k, tk in enumerate(t):
        q, qd = y[k, :n], y[k, n:2 * n]
        E, v, a = point_motion.point_motion(model, "E", q, qd, model.accelerations(tk, q, qd))
        tangent = np.array([E[2], 0.0, -E[0]]) / p["r_Ea"]
        speed[k], along[k] = v @ tangent, a @ tangent
        assert np.max(np.abs(model.constraint_terms(tk, q, qd)[0])) <= 1e-10   # circle and height
    omega = 2 * np.pi / p["Ta"]
    assert np.max(np.abs(along - p["a0"] * np.sin(omega * t))) <= 1e-6
    assert np.max(np.abs(speed - p["a0"] / omega * (1 - np.cos(omega * t)))) <= 1e-8
    assert speed[-1] > 0.1   # E did move along the circle


def test_curvature_rows_vanish_at_rest_and_runs_and_partitions_say_so(env):
    file = read_model_file(CURVATURE)
    model = gpmegen.load(model=file.model, backend="numpy")
    q = np.zeros(model.n_dof)
    q[model.index("theta2")] = np.pi / 2
    at_rest = "second-order constraints 'curvature', 'speed' are zero, so no motion can be chosen to hold them"
    with pytest.raises(SimulationError, match=at_rest):
        partition.partition_at(model, q)
    with pytest.raises(SimulationError, match=at_rest):
        integrators.rk4.rk4(model, q, np.zeros(model.n_dof), 0.01, 1e-3)
    qd = np.zeros(model.n_dof)
    qd[model.index("theta1")] = 0.5
    chosen = partition.partition_at(model, q, qd=qd)
    assert [model.coordinates[k] for k in chosen.dependent] == ["theta1", "theta2"]
    with pytest.raises(StaticsError, match="'curvature', 'speed' are of second order.*--statics locked or initial"):
        statics.constrained(model, q)
    with pytest.raises(StaticsError, match="modes with the constraints holding: the constraints 'curvature', 'speed'"):
        modes.constrained_modes(model, q)


def test_python_constraint_of_second_order_gives_the_files_accelerations(env, rng):
    """The hand-expanded Φ̈ = 0 of reaching_arm_ddot.toml, built in Python as Constraint(order=2)."""
    base = read_model_file(REACHING).model
    s = {p.name: p.symbol for p in base.parameters}
    x, y, vx, vy, ax, ay, theta1_ddot = sp.symbols("x_E y_E vx_E vy_E ax_E ay_E theta1_ddot", real=True)
    w, t = s["w"], TIME
    R = s["r0"] + s["A"] * (1 - sp.cos(w * t))
    reach = 2 * (vx**2 + vy**2 + x * ax + y * ay) - 2 * ((s["A"] * w * sp.sin(w * t))**2
                                                         + R * s["A"] * w**2 * sp.cos(w * t))
    shoulder = theta1_ddot - s["B"] * w**2 * sp.cos(w * t)
    python = replace(base, name="reaching_arm_python_nrfe2", constraints=(
        gpmegen.Constraint("reach", reach, order=2), gpmegen.Constraint("shoulder", shoulder, order=2)))
    built = gpmegen.load(model=python, backend="numpy")
    filed = gpmegen.load(model=read_model_file(REACHING_DDOT).model, backend="numpy")
    for _ in range(3):
        q, qd, tk = rng.normal(0, 0.3, built.n_dof), rng.normal(0, 1.0, built.n_dof), rng.uniform(0, 2)
        q[built.index("theta2")] += 1.2
        np.testing.assert_allclose(built.accelerations(tk, q, qd), filed.accelerations(tk, q, qd), rtol=1e-12,
                                   atol=1e-12)
    # a symbol without real=True is another symbol to SymPy: the error says so
    with pytest.raises(ModelError, match="ax_E is not declared real"):
        expand(replace(python, constraints=(gpmegen.Constraint("reach", sp.Symbol("ax_E") + theta1_ddot, order=2),
                                            python.constraints[1])))


@pytest.mark.parametrize("expression, message", [
    ('"ax_E^2 + theta1_ddot"', "constraint 'reach': the term ax_E**2 is not linear in the accelerations"),
    ('"vx_E*sin(ay_E) + theta1_ddot"', "the term vx_E*sin(ay_E) is not linear in the accelerations"),
    ('"ax_E*ay_E + theta1_ddot"', "the term ax_E*ay_E is not linear in the accelerations"),
    ('"vx_E^2 + x_E"', "a second-order constraint must involve accelerations"),
])
def test_second_order_constraint_must_be_linear_in_accelerations(tmp_path, expression, message):
    path = _variant(tmp_path, "bad", (REACH, expression + "\norder = 2"))
    with pytest.raises(ModelError, match="reaching_arm|bad") as info:
        read_model_file(path)
    assert message in str(info.value) and "\n" not in str(info.value)
    assert "constraints[0].expression" in str(info.value)


@pytest.mark.parametrize("replacement, message", [
    (('"theta1 - B*(1 - cos(w*t))"', '"theta1 - ax_E"'),
     "the point acceleration ax_E may appear only in second-order constraints; set order = 2 or remove it"),
    (('"theta1 - B*(1 - cos(w*t))"', '"theta1_ddot"\norder = 1'),
     "the acceleration theta1_ddot may appear only in second-order constraints; set order = 2"),
    (('"theta1 - B*(1 - cos(w*t))"', '"theta1_ddot"\norder = 2'),
     "alpha applies to position and first-order constraints only"),
])
def test_accelerations_and_gains_out_of_place_are_refused(tmp_path, replacement, message):
    with pytest.raises(ModelError) as info:
        read_model_file(_variant(tmp_path, "bad", replacement))
    assert message in str(info.value) and "\n" not in str(info.value)


def test_cli_refuses_a_nonlinear_second_order_constraint_in_one_line(tmp_path, capsys):
    path = _variant(tmp_path, "bad", (REACH, '"ax_E^2 + theta1_ddot"\norder = 2'))
    assert main(["build", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "ax_E**2 is not linear in the accelerations" in err


def test_first_order_constraint_must_be_linear_in_velocities_mixed_products_too(tmp_path):
    path = _variant(tmp_path, "bad", (SHOULDER, '"vx_E*vy_E - 0.1"\norder = 1'))
    with pytest.raises(ModelError, match="the term vx_E\\*vy_E is not linear in the velocities"):
        read_model_file(path)
