"""Series-elastic joints: the motor's coordinate ``<joint>_motor`` with its reflected inertia,
the spring and damper between it and the link, the two-mass frequency against the closed form,
the approach to the rigid geared pendulum as the spring stiffens, the momentum a motor torque
gives the pair, the energy with the spring's, and the refusals."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from refusals import refused_in_one_line

import gpmegen
from gpmegen.analysis.run import linear

ROOT = Path(__file__).resolve().parents[1]
TWO_MASS = ROOT / "tests" / "models" / "series_elastic.toml"
PENDULUM = ROOT / "tests" / "models" / "geared_pendulum.toml"
# the two-mass model's parameters, as its file gives them
J_L, J_M, GEAR, K = 0.05, 2e-5, 50.0, 40.0
J_MOTOR = GEAR ** 2 * J_M
# the geared pendulum's
G, MASS, LENGTH, PJ_M, PGEAR = 9.81, 1.5, 0.8, 2e-4, 30.0


@pytest.fixture(scope="module")
def two_mass(env):
    return gpmegen.load(model=gpmegen.load_model_file(TWO_MASS), backend="numpy", jacobians=True)


def _elastic_pendulum(tmp_path) -> Path:
    """The geared pendulum with its gear series-elastic, of stiffness k."""
    text = PENDULUM.read_text().replace('motor = { inertia = "J_m", gear = "n" }',
                                        'motor = { inertia = "J_m", gear = "n" }\nseries_elastic = { stiffness = "k" }')
    text = text.replace('name = "geared_pendulum"', 'name = "elastic_pendulum"')
    text = text.replace("[parameters]", '[parameters]\nk = { value = 100.0, unit = "N m/rad" }')
    path = tmp_path / "elastic_pendulum.toml"
    path.write_text(text)
    return path


def test_the_motor_is_a_coordinate_with_the_reflected_inertia_and_the_spring_between(two_mass):
    assert two_mass.coordinates == ("theta", "theta_motor")
    q, qd = np.array([0.3, -0.2]), np.array([1.0, 4.0])
    np.testing.assert_allclose(two_mass.mass_matrix(q), np.diag([J_L, J_MOTOR]), rtol=1e-15, atol=0)
    damped = two_mass.with_params(c=0.7)
    torque = K * (-0.2 - 0.3) + 0.7 * (4.0 - 1.0)   # on the link: k (θ_m - q) + c (θ̇_m - q̇)
    np.testing.assert_allclose(damped.forces(0.0, q, qd), [torque, -torque], rtol=1e-14)
    np.testing.assert_allclose(two_mass.stiffness_jacobian(q), [[K, -K], [-K, K]], rtol=1e-15)


def test_the_two_masses_oscillate_at_the_closed_form_frequency(two_mass):
    lin = linear.linearize(two_mass, 0.0, np.zeros(2), np.zeros(2))
    frequency = math.sqrt(K * (1 / J_L + 1 / J_MOTOR))
    moving = np.sort(lin.eigenvalues.imag[np.abs(lin.eigenvalues) > 1e-6])
    np.testing.assert_allclose(moving, [-frequency, frequency], rtol=1e-10)
    assert np.abs(lin.eigenvalues).min() < 1e-9      # the pair turning freely together


def test_a_motor_torque_spins_the_pair_up_and_the_spring_energy_is_balanced(env, tmp_path):
    # a constant torque u on the motor: the pair's momentum J_l q̇ + n² J_m θ̇_m grows as u t
    text = TWO_MASS.read_text() + '\n[[drives]]\ncoordinate = "theta_motor"\nexpression = "0.5"\n'
    text = text.replace("[initial]", '[[chain]]\npoint = "P"\nposition = [0.1, 0, 0]\n\n[initial]')
    path = tmp_path / "spun.toml"
    path.write_text(text)
    run = gpmegen.simulate(str(path), t_end=0.5, dt=1e-4, backend="numpy")
    momentum = J_L * run.velocity("theta") + J_MOTOR * run.velocity("theta_motor")
    np.testing.assert_allclose(momentum, 0.5 * run.t, rtol=0, atol=1e-10)
    stretch = run.coordinate("theta") - run.coordinate("theta_motor")
    np.testing.assert_allclose(run["spring_energy"], K * stretch ** 2 / 2, rtol=1e-12, atol=1e-15)
    kinetic = (J_L * run.velocity("theta") ** 2 + J_MOTOR * run.velocity("theta_motor") ** 2) / 2
    np.testing.assert_allclose(run["kinetic_energy"], kinetic, rtol=1e-12, atol=1e-15)
    assert np.ptp(run["spring_energy"]) > 1e-3       # the spring did work back and forth
    np.testing.assert_allclose(kinetic + run["spring_energy"] - run["spring_energy"][0], run["work_drive"],
                               rtol=0, atol=1e-8 * np.abs(run["work_drive"]).max())


@pytest.mark.parametrize("stiffness", [1e2, 1e4, 1e6])
def test_the_elastic_pendulum_has_the_closed_form_frequencies_and_a_stiff_spring_the_rigid_one(env, tmp_path,
                                                                                                  stiffness):
    model = gpmegen.load(model=gpmegen.load_model_file(_elastic_pendulum(tmp_path)), backend="numpy",
                         jacobians=True, params={"k": stiffness})
    lin = linear.linearize(model, 0.0, np.array([-math.pi / 2] * 2), np.zeros(2))
    # J_l q̈ = -m g l q - k (q - θ), J θ̈ = -k (θ - q) about the hanging rest: ω² solves
    # J_l J ω⁴ - (J_l k + J (m g l + k)) ω² + m g l k = 0
    link, motor, weight = MASS * LENGTH ** 2, PGEAR ** 2 * PJ_M, MASS * G * LENGTH
    squares = np.sort(np.roots([link * motor, -(link * stiffness + motor * (weight + stiffness)), weight * stiffness]))
    found = np.sort(lin.eigenvalues.imag[lin.eigenvalues.imag > 0])
    np.testing.assert_allclose(found, np.sqrt(squares), rtol=1e-9)
    rigid = math.sqrt(weight / (link + motor))
    # the slow mode tends to the rigidly geared pendulum's as 1/k
    assert abs(found[0] - rigid) / rigid < 2 * weight / stiffness


@pytest.mark.requires_cc
def test_the_c_recursion_moves_the_motor_as_numpy_does(env):
    model = gpmegen.load_model_file(TWO_MASS)
    numpy_model, c_model = (gpmegen.load(model=model, backend=b, params={"c": 0.3}) for b in ("numpy", "c"))
    rng = np.random.default_rng(2)
    for _ in range(3):
        q, qd = rng.uniform(-1, 1, 2), rng.uniform(-3, 3, 2)
        np.testing.assert_allclose(c_model.accelerations(0.0, q, qd), numpy_model.accelerations(0.0, q, qd),
                                   rtol=1e-12)
        np.testing.assert_allclose(c_model.mass_matrix(q), np.diag([J_L, J_MOTOR]), rtol=1e-15)


@pytest.mark.parametrize("change, field, message", [
    (('series_elastic = { stiffness = "k", damping = "c" }', 'series_elastic = { stiffness = "k", spring = "c" }'),
     "chain[0].series_elastic.spring", "unknown key 'spring'; did you mean"),
    (('k = { value = 40.0', 'k = { value = -40.0'), "chain[0].series_elastic.stiffness",
     "stiffnesses must be positive"),
    (('J_m = { value = 2e-5', 'J_m = { value = 0.0'), "chain[0].motor.inertia",
     "moments of inertia must be positive"),
    (('motor = { inertia = "J_m", gear = "n" }\n', ''), "chain[0].series_elastic",
     "joint 'theta' is series-elastic but has no motor"),
    (('[[chain]]\nbody = "link"', '[[chain]]\njoint = "theta_motor"\ntype = "revolute"\naxis = "x"\n\n'
                                  '[[chain]]\nbody = "link"'), "chain[1].joint",
     "joint 'theta' is series-elastic, so its motor is the coordinate 'theta_motor', which another joint already "
     "names; rename that joint"),
])
def test_a_faulty_series_elastic_joint_is_refused_in_one_line(tmp_path, capsys, change, field, message):
    refused_in_one_line(tmp_path / "faulty.toml", TWO_MASS.read_text(), change, field, message, capsys)
