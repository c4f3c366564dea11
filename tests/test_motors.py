"""Geared motors on joints and drives with torque limits: the reflected inertia n² J_m in every
mass matrix (NumPy, C, and the C's articulated-body recursion, which forms none), a geared
pendulum's small-oscillation frequency and its energy against the closed form, a clipped law's
force and the reported time at the limit against the law's own closed form, the refusals."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
from refusals import refused_in_one_line

import gpmegen
from gpmegen.analysis.post import energy
from gpmegen.analysis.run import linear
from gpmegen.cli import main

ROOT = Path(__file__).resolve().parents[1]
PENDULUM = ROOT / "tests" / "models" / "geared_pendulum.toml"
ARM = ROOT / "examples" / "geared_arm.toml"
# the pendulum's parameters, as its file gives them
G, MASS, LENGTH, J_M, GEAR = 9.81, 1.5, 0.8, 2e-4, 30.0
INERTIA = MASS * LENGTH ** 2 + GEAR ** 2 * J_M   # about the joint: the bob's and the reflected rotor's

CART = ROOT / "tests" / "models" / "cart.toml"
# the free cart (m = 2 kg) pushed along x by A sin(w t), clipped at u_max
SLIDER = CART.read_text().replace('name = "cart"', 'name = "clipped_slider"').replace(
    "[parameters]", "[parameters]\nA = 2.0\nw = 6.283185307179586\nu_max = 1.0") + """
[[drives]]
coordinate = "x"
expression = "A*sin(w*t)"
limit = "u_max"
"""


@pytest.fixture(scope="module")
def pendulum(env):
    model = gpmegen.load_model_file(PENDULUM)
    loaded = {"numpy": gpmegen.load(model=model, backend="numpy", jacobians=True)}
    try:
        loaded["c"] = gpmegen.load(model=model, backend="c")
    except gpmegen.errors.BuildError:
        pass
    return loaded


def _backends(models):
    return [models[b] for b in ("numpy", "c") if b in models]


def test_the_pendulums_mass_matrix_holds_the_reflected_inertia_exactly(pendulum):
    for model in _backends(pendulum):
        for q in (-1.5, 0.0, 2.0):
            M = model.mass_matrix(np.array([q]))
            assert M[0, 0] == pytest.approx(INERTIA, rel=1e-15)
            without = model.with_params(J_m=0.0).mass_matrix(np.array([q]))
            assert M[0, 0] - without[0, 0] == pytest.approx(GEAR ** 2 * J_M, rel=1e-12)


def test_the_pendulums_accelerations_divide_by_the_geared_inertia(pendulum):
    # C: the articulated-body recursion (gpme_recursive), which never forms M
    for model in _backends(pendulum):
        for q, qd in ((-1.2, 0.7), (0.4, -2.0)):
            expected = -MASS * G * LENGTH * math.cos(q) / INERTIA
            assert model.accelerations(0.0, np.array([q]), np.array([qd]))[0] == pytest.approx(expected, rel=1e-12)


def test_the_pendulum_swings_at_the_geared_frequency(pendulum):
    model = pendulum["numpy"]
    lin = linear.linearize(model, 0.0, np.array([-math.pi / 2]), np.zeros(1))
    frequency = math.sqrt(MASS * G * LENGTH / INERTIA)
    np.testing.assert_allclose(np.sort(lin.eigenvalues.imag), [-frequency, frequency], rtol=1e-10)
    # without the gear the frequency is the bare pendulum's sqrt(g / l): the motor made the difference
    assert abs(frequency - math.sqrt(G / LENGTH)) > 0.05 * frequency


def test_the_geared_pendulum_conserves_its_energy_motor_included(env, pendulum):
    backend = "c" if "c" in pendulum else "numpy"
    run = gpmegen.simulate(str(PENDULUM), t_end=2.0, dt=1e-3, backend=backend)
    theta, rate = run.coordinate("theta"), run.velocity("theta")
    # kinetic energy of the bob and of the rotor (turning n times as fast), and the bob's weight
    kinetic = (MASS * LENGTH ** 2 + J_M * GEAR ** 2) * rate ** 2 / 2
    potential = MASS * G * LENGTH * np.sin(theta)
    np.testing.assert_allclose(run["kinetic_energy"], kinetic, rtol=1e-10, atol=1e-12)
    total = kinetic + potential
    assert np.ptp(total) < 1e-8 * np.ptp(kinetic) and np.ptp(kinetic) > 1.0
    assert np.abs(energy.balance_residual(run.arrays)).max() < 1e-8 * np.ptp(kinetic)


@pytest.mark.requires_cc
def test_the_arms_recursion_agrees_with_the_dense_mass_matrix(env):
    # two motors on a two-link arm (one series-elastic): the C recursion's accelerations against
    # NumPy's solve with the SymPy M, and the C's M against NumPy's
    model = gpmegen.load_model_file(ARM)
    numpy_model, c_model = (gpmegen.load(model=model, backend=b) for b in ("numpy", "c"))
    rng = np.random.default_rng(5)
    for _ in range(4):
        q, qd = rng.uniform(-1.5, 1.5, 3), rng.uniform(-2, 2, 3)
        np.testing.assert_allclose(c_model.mass_matrix(q), numpy_model.mass_matrix(q), rtol=1e-14, atol=1e-15)
        expected = numpy_model.accelerations(0.0, q, qd)
        np.testing.assert_allclose(c_model.accelerations(0.0, q, qd), expected, rtol=1e-10,
                                   atol=1e-10 * np.abs(expected).max())
        # the rigid motor's n1² J_m1 on theta1's diagonal: M less it is the motorless arm's
        bare = numpy_model.with_params(J_m1=0.0).mass_matrix(q)
        reflected = numpy_model.mass_matrix(q) - bare
        assert reflected[0, 0] == pytest.approx(100.0 ** 2 * 3e-5, rel=1e-12)
        reflected[0, 0] = 0.0
        assert np.abs(reflected).max() < 1e-15


def test_a_clipped_law_never_passes_its_limit_and_its_time_there_is_reported(env, tmp_path, capsys):
    path = tmp_path / "clipped_slider.toml"
    path.write_text(SLIDER)
    out = tmp_path / "run.npz"
    assert main(["simulate", str(path), "--t-end", "1", "--dt", "1e-3", "--backend", "numpy", "--out",
                 str(out)]) == 0
    err = capsys.readouterr().err
    run = gpmegen.Results.load(out)
    force = run["drive_forces"][:, 0]
    assert np.abs(force).max() == 1.0                      # clipped at u_max, reached
    law = 2.0 * np.sin(2 * np.pi * run.t)                  # the law, before its clip
    np.testing.assert_allclose(run["drive_laws"][:, 0], law, rtol=0, atol=1e-12)
    np.testing.assert_allclose(force, np.clip(law, -1.0, 1.0), rtol=0, atol=1e-12)
    # |2 sin(2 pi t)| >= 1 for 2/3 of each period, here the run's one second, to a save interval
    assert list(run["limited_drives"]) == ["x"]
    assert run["time_at_limit"][0] == pytest.approx(2 / 3, abs=2e-3)
    assert f"drive on x: at its limit for {run['time_at_limit'][0]:.6g} s of 1 s" in err
    # the cart moves as the clipped force says: x(1) from the trapezoid of F/m twice integrated
    acc = force / 2.0
    rate = np.concatenate([[0.0], np.cumsum(np.diff(run.t) * (acc[1:] + acc[:-1]) / 2)])
    np.testing.assert_allclose(run.velocity("x"), rate, atol=1e-5)


@pytest.mark.parametrize("change, field, message", [
    (('motor = { inertia = "J_m", gear = "n" }', 'motor = { inertia = "J_m", ratio = "n" }'), "chain[0].motor.ratio",
     "unknown key 'ratio'"),
    (('J_m = { value = 2e-4', 'J_m = { value = -2e-4'), "chain[0].motor.inertia",
     "the moment of inertia of joint 'theta' is -0.0002 with the parameter defaults (J_m = -0.0002); moments of "
     "inertia must be zero or positive"),
    (('gear = "n"', 'gear = 0'), "chain[0].motor.gear", "zero value 0; gear ratios must be positive"),
    (('motor = { inertia = "J_m", gear = "n" }', 'motor = "J_m"'), "chain[0].motor", "expected a motor"),
    (('[initial]', '[[drives]]\ncoordinate = "theta"\nexpression = "1"\nlimit = "-n"\n\n[initial]'),
     "drives[0].limit", "drive limits must be positive"),
])
def test_a_faulty_motor_or_limit_is_refused_in_one_line(tmp_path, capsys, change, field, message):
    refused_in_one_line(tmp_path / "faulty.toml", PENDULUM.read_text(), change, field, message, capsys)


@pytest.mark.requires_cc
def test_the_geared_arm_example_simulates_within_its_limits(env, tmp_path, capsys):
    out = tmp_path / "arm.npz"
    assert main(["simulate", str(ARM), "--t-end", "1", "--backend", "c", "--out", str(out)]) == 0
    err = capsys.readouterr().err
    run = gpmegen.Results.load(out)
    assert run.status == "complete" and run.coordinates == ("theta1", "theta2", "theta2_motor")
    limits = {"theta1": 40.0, "theta2_motor": 15.0}
    for k, name in enumerate(run["limited_drives"]):
        column = run.coordinates.index(name)
        assert np.abs(run["drive_forces"][:, column]).max() <= limits[name]
        assert 0 < run["time_at_limit"][k] < 1.0
        assert f"drive on {name}: at its limit for {run['time_at_limit'][k]:.6g} s of 1 s" in err
    swing = np.ptp(run["kinetic_energy"])
    assert np.abs(energy.balance_residual(run.arrays)).max() < 1e-6 * swing


def test_a_model_with_motors_is_no_urdf(tmp_path, capsys):
    assert main(["export", str(ARM), "--format", "urdf", "--out", str(tmp_path / "arm.urdf")]) == 2
    err = capsys.readouterr().err
    assert "the motors of theta1, theta2 have no URDF form" in err and err.count("\n") == 1


def test_the_generated_jacobians_of_a_geared_arm_with_a_clipped_law(env):
    # against central differences, at a state where the elbow motor's law (150 (0.8 - 0.1) - 10 · 0.5
    # = 100 N m) is clipped at 15 N m: the clip's derivative is zero there, the shoulder's law's not
    model = gpmegen.load(model=gpmegen.load_model_file(ARM), backend="numpy", jacobians=True)
    q, qd, h = np.array([0.3, -0.5, 0.1]), np.array([1.0, -2.0, 0.5]), 1e-6
    A_q, A_qd = model.acceleration_jacobians(0.0, q, qd)
    for exact, shift in ((A_q, lambda e: (q + h * e, qd)), (A_qd, lambda e: (q, qd + h * e))):
        differenced = np.array([(model.accelerations(0.0, *shift(e)) - model.accelerations(0.0, *shift(-e))) / (2 * h)
                                for e in np.eye(3)]).T
        np.testing.assert_allclose(exact, differenced, rtol=0, atol=1e-7 * np.abs(exact).max())
