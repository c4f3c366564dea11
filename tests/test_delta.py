"""examples/delta_flexible.toml, a Delta robot whose platform follows a programmed arc: the rigid
Delta (n_rfe 1) against its closed-form inverse kinematics, its statics at rest (forearms as
two-force rods with their weight, solved by hand) and the power balance of its motor torques;
the flexible Delta (n_rfe 2) holding its constraints and its energy balance, and its motor
torques tending to the rigid Delta's as the forearms' stiffness grows."""

from __future__ import annotations

import math
import sys
import tomllib
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.post import energy

ROOT = Path(__file__).resolve().parents[1]
sys.path.insert(0, str(ROOT / "benchmarks"))

import delta  # noqa: E402  (benchmarks/delta.py: the motor torques of a state)

EXAMPLE = ROOT / "examples" / "delta_flexible.toml"
P = {k: float(v["value"]) for k, v in tomllib.loads(EXAMPLE.read_text())["parameters"].items()}
ANGLES = (0.0, 2 * math.pi / 3, 4 * math.pi / 3)     # the legs about z0
T_END, DT = 0.4, 5e-4                                 # the move (0.25 s) and 0.15 s at rest
EZ = np.array([0.0, 0.0, 1.0])


def path(t):
    """The platform centre's programmed position (k, 3): the half circle of the file, by the
    cycloidal law of u = min(t/T, 1)."""
    u = np.minimum(np.asarray(t) / P["T"], 1.0)
    s = math.pi * (u - np.sin(2 * math.pi * u) / (2 * math.pi))
    return np.column_stack([P["R_arc"] * np.cos(s), P["R_arc"] * np.sin(s), np.full_like(s, P["z_0"])])


def leg_axes(angle):
    """(u radial, w along the motor axis) of the leg at ``angle``."""
    return np.array([math.cos(angle), math.sin(angle), 0.0]), np.array([-math.sin(angle), math.cos(angle), 0.0])


def inverse_kinematics(p):
    """The motor angles (3,) of platform position ``p``, positive downwards, the elbows out: the
    elbow's circle about the motor axis met by the sphere of radius L_f about the forearm's
    platform joint, A cos θ + B sin θ = C in the leg's plane."""
    L, Lf = P["L_u"], P["L_f"]
    angles = []
    for angle in ANGLES:
        u, w = leg_axes(angle)
        px, py, pz = p @ u - (P["r_b"] - P["r_p"]), p @ w, p[2]
        A, B, C = -2 * L * px, 2 * L * pz, Lf ** 2 - L ** 2 - px ** 2 - py ** 2 - pz ** 2
        angles.append(math.atan2(B, A) + math.acos(C / math.hypot(A, B)))
    return np.array(angles)


def static_torques(p):
    """The motor torques (3,) that hold the rigid Delta at rest with its platform at ``p``, by
    hand: each forearm a rod with ball ends, so that it pushes on the platform along itself and
    with half its weight; the platform's balance gives the three axial forces, each upper arm's
    balance about its motor axis the torque."""
    g, m_u, L, Lf, m_p = P["g"], P["m_u"], P["L_u"], P["L_f"], P["m_p"]
    W = P["rhoA_f"] * Lf * g                      # a forearm's weight
    theta = inverse_kinematics(p)
    elbows, along = [], []
    for angle, th in zip(ANGLES, theta):
        u, _ = leg_axes(angle)
        d = math.cos(th) * u - math.sin(th) * EZ
        elbow = P["r_b"] * u + L * d
        elbows.append((u, d, elbow))
        along.append((p + P["r_p"] * u - elbow) / Lf)
    N = np.column_stack(along)
    c = np.linalg.solve(N, (m_p * g + 1.5 * W) * EZ)    # Σ c_i n_i - (3W/2 + m_p g) e_z = 0
    torques = []
    for (_, d, _), angle, n, ci in zip(elbows, ANGLES, along, c):
        _, w = leg_axes(angle)
        on_arm = -ci * n - 0.5 * W * EZ              # from the forearm, at the elbow
        moment = np.cross(0.5 * L * d, -m_u * g * EZ) + np.cross(L * d, on_arm)
        torques.append(-w @ moment)
    return np.array(torques)


@pytest.fixture(scope="module")
def rigid(env):
    """The rigid Delta's run (NumPy backend) and its model, with the motor torques of each saved
    state and the accelerations they give."""
    model = gpmegen.load(model=gpmegen.load_model_file(EXAMPLE, nrfe=1), backend="numpy", directory=env[0])
    run = gpmegen.simulate(str(EXAMPLE), nrfe=1, t_end=T_END, dt=DT, save_every=2, backend="numpy",
                           directory=env[0])
    assert run.status == "complete"
    tau, qdd = delta.motor_torques(model, run["t"], run["q"], run["qd"])
    return run, model, tau, qdd


def test_rigid_delta_follows_its_closed_form_inverse_kinematics(rigid):
    run, _, _, _ = rigid
    expected = path(run["t"])
    np.testing.assert_allclose(run.coordinate("X"), expected[:, 0], rtol=0, atol=1e-9)
    np.testing.assert_allclose(run.coordinate("Y"), expected[:, 1], rtol=0, atol=1e-9)
    motors = np.column_stack([run.coordinate(name) for name in delta.MOTORS])
    exact = np.array([inverse_kinematics(p) for p in expected])
    assert np.ptp(exact, axis=0).min() > 0.1          # every motor turns by more than 0.1 rad
    np.testing.assert_allclose(motors, exact, rtol=0, atol=1e-8)


def test_rigid_delta_motor_torques_are_its_statics_at_rest(rigid):
    """At the start and after the move the platform rests: the motor torques are the statics
    solved by hand, at both ends of the arc."""
    run, _, tau, _ = rigid
    t = run["t"]
    for k in (0, int(np.argmin(np.abs(t - T_END)))):
        expected = static_torques(path(t[k:k + 1])[0])
        assert np.abs(expected).min() > 0.05
        np.testing.assert_allclose(tau[k], expected, rtol=1e-7)


def test_rigid_delta_motor_torques_balance_the_power(rigid):
    """Realized by the motors, the rigid Delta moves as the run does (the same q̈), and the motors'
    power Σ τ_i θ̇_i is the rate of its kinetic and gravity energy, by central differences of the
    generated energies along (q̇, q̈): the platform joints do no work."""
    run, model, tau, qdd = rigid
    np.testing.assert_allclose(qdd, run["qdd"], rtol=0, atol=1e-9 * np.abs(run["qdd"]).max())
    eps = 1e-6
    rates = []
    for q, qd, a in zip(run["q"], run["qd"], run["qdd"]):
        ahead, behind = model.energies(q + eps * qd, qd + eps * a), model.energies(q - eps * qd, qd - eps * a)
        rates.append((ahead[0] + ahead[1] - behind[0] - behind[1]) / (2 * eps))
    rates = np.array(rates)
    coordinates = list(run["coordinates"])
    rates_of_motors = run["qd"][:, [coordinates.index(name) for name in delta.MOTORS]]
    power = np.sum(tau * rates_of_motors, axis=1)
    scale = np.abs(power).max()
    assert scale > 1.0
    np.testing.assert_allclose(power, rates, rtol=0, atol=1e-7 * scale)


@pytest.mark.long
def test_rigid_delta_driven_by_its_motors_has_those_torques_as_multipliers(rigid, env, tmp_path):
    """The example with its motors following the closed-form inverse kinematics instead of its
    platform following the path (benchmarks/delta.py, 15 s of derivation): the rigid Delta's
    platform stays on the path, and the multipliers of the motors' rows, its driving functions,
    are the motor torques computed from the path-driven model at the same states."""
    run0, model, tau0, _ = rigid
    path_file = tmp_path / "delta_motors.toml"
    path_file.write_text(delta.motor_driven_text())
    run = gpmegen.simulate(str(path_file), nrfe=1, t_end=T_END, dt=DT, save_every=2, backend="numpy",
                           directory=env[0])
    assert run.status == "complete"
    np.testing.assert_allclose(run["end_effector"], path(run["t"]), rtol=0, atol=1e-9)
    names = list(run["constraint_names"])
    multipliers = run["lambda"][:, [names.index(f"motor{leg}") for leg in (1, 2, 3)]]
    tau, _ = delta.motor_torques(model, run["t"], run["q"], run["qd"])
    scale = np.abs(tau0).max()
    np.testing.assert_allclose(multipliers, tau, rtol=0, atol=1e-8 * scale)
    np.testing.assert_allclose(multipliers, tau0, rtol=0, atol=1e-6 * scale)


# ---- the flexible Delta ------------------------------------------------------------------------

STIFFNESS = (0.01, 0.1, 1.0)   # factors on the forearms' bending stiffness (parameter k_EI)


@pytest.fixture(scope="module")
def flexible(env):
    """n_rfe 2 (one sde in each forearm, bending both ways) on the C backend from its constrained
    equilibrium, at each factor in STIFFNESS: {factor: (run, motor torques)}."""
    model = gpmegen.load(model=gpmegen.load_model_file(EXAMPLE, nrfe=2), backend="numpy", directory=env[0])
    runs = {}
    for k in STIFFNESS:
        run = gpmegen.simulate(str(EXAMPLE), nrfe=2, t_end=T_END, dt=1e-4, save_every=10, backend="c",
                               directory=env[0], params={"k_EI": k}, start="constrained")
        assert run.status == "complete"
        runs[k] = run, delta.motor_torques(model.with_params(k_EI=k), run["t"], run["q"], run["qd"])[0]
    return runs


# make check-c: the flexible Delta built and compiled: about 11 s of CPU
@pytest.mark.long
@pytest.mark.requires_cc
def test_flexible_delta_holds_its_constraints_and_its_energy_balance(flexible):
    for k, (run, _) in flexible.items():
        assert np.abs(run["phi"]).max() < 1e-10
        np.testing.assert_allclose(run.coordinate("X"), path(run["t"])[:, 0], rtol=0, atol=1e-10)
        bend = max(np.abs(run.coordinate(f"{kind}{leg}_1")).max() for kind in ("psi", "theta") for leg in (1, 2, 3))
        assert bend > 1e-6 / k
        exchanged = np.abs(run["work_constraints"]).max()
        assert exchanged > 0.1
        assert np.abs(energy.balance_residual(run.arrays)).max() < 1e-6 * exchanged


# make check-c: the flexible Delta at three stiffnesses
@pytest.mark.long
@pytest.mark.requires_cc
def test_flexible_delta_motor_torques_tend_to_the_rigid_ones(flexible, rigid):
    """On the same saved times, the largest difference between the flexible and the rigid Delta's
    motor torques falls with each tenfold stiffer forearm (as 1/k for small deflections: by more
    than 3 each time), and at the example's stiffness it is below 1e-3 of the peak torque."""
    run0, _, tau0, _ = rigid
    differences = []
    for k in STIFFNESS:
        run, tau = flexible[k]
        np.testing.assert_allclose(run["t"], run0["t"], rtol=0, atol=1e-12)
        differences.append(np.abs(tau - tau0).max())
    assert all(a > 3 * b for a, b in zip(differences, differences[1:]))
    assert differences[-1] < 1e-3 * np.abs(tau0).max()
