"""Feedback laws in drives: a drive's expression of the state (coordinates, velocities, points'
positions and velocities), derived into the generated NumPy and C like every other force, with
its derivatives in the acceleration Jacobians the implicit integrators use.

The models are one slider (tests/models/pd_slider.toml: a cart on a prismatic joint, no
gravity) under a saturated PD law, whose response is known in closed form, and a pendulum
without gravity whose law reads its tip's position and velocity; each is built once for the
module."""

from __future__ import annotations

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import gpmegen
from gpmegen.analysis.post import energy
from gpmegen.errors import ModelError
from gpmegen.model.expand import expand
from gpmegen.runtime import integrators
from tests.backends import each_backend, on

TIP = """schema = 1
name = "tip_feedback"
gravity = [0, 0, 0]

[parameters]
L = 0.8
kp = 30.0
kd = 3.0

[[chain]]
joint = "theta"
type = "revolute"
axis = "z"

[[chain]]
body = "bob"
shape = { type = "point_mass", mass = 1.5, position = ["L", 0, 0] }

[[chain]]
translation = ["L", 0, 0]

[[chain]]
point = "E"

[[drives]]
coordinate = "theta"
expression = "-L*(kp*y_E + kd*vy_E)"

[initial]
q = { theta = 0.4 }
"""

MODELS = Path(__file__).parent / "models"
BACKENDS = ["numpy", pytest.param("c", marks=pytest.mark.requires_cc)]


def pd_response(t, m, kp, kd, x_ref):
    """x(t) of m ẍ = kp (x_ref - x) - kd ẋ from rest at 0, underdamped."""
    s = kd / (2 * m)
    w = np.sqrt(kp / m - s * s)
    return x_ref - x_ref * np.exp(-s * t) * (np.cos(w * t) + s / w * np.sin(w * t))


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("control")
    (folder / "tip.toml").write_text(TIP)
    return folder


@pytest.fixture(scope="module")
def slider(env):
    """The slider on each backend, with the generated Jacobians, its limit out of reach (a plain
    PD law)."""
    return each_backend(gpmegen.load_model_file(MODELS / "pd_slider.toml"), jacobians=True, params={"u_max": 1e9})


@pytest.fixture(scope="module")
def tip(env, files):
    return gpmegen.load(model=gpmegen.load_model_file(files / "tip.toml"), backend="numpy", jacobians=True)




@pytest.mark.parametrize("backend", BACKENDS)
def test_drive_force_is_the_law_at_the_state(slider, backend):
    model = on(slider, backend)
    q, qd = np.array([0.1]), np.array([0.5])
    assert model.drive_forces(0.0, q, qd) == pytest.approx([50.0 * (0.3 - 0.1) - 4.0 * 0.5], rel=1e-15)
    assert model.accelerations(0.0, q, qd) == pytest.approx([8.0 / 2.0], rel=1e-15)
    capped = model.with_params(u_max=5.0)
    assert capped.drive_forces(0.0, np.zeros(1), np.zeros(1))[0] == 5.0     # 15 N asked
    assert capped.drive_forces(0.0, np.array([0.6]), np.zeros(1))[0] == -5.0


@pytest.mark.parametrize("backend", BACKENDS)
def test_jacobians_hold_the_law_derivatives(slider, backend):
    model = on(slider, backend).with_params(kp=1e6, kd=2e3)
    A_q, A_qd = model.acceleration_jacobians(0.0, np.array([0.1]), np.array([0.2]))
    assert A_q[0, 0] == pytest.approx(-1e6 / 2.0, rel=1e-14)
    assert A_qd[0, 0] == pytest.approx(-2e3 / 2.0, rel=1e-14)


def test_pd_on_a_slider_matches_its_closed_form_with_rk4(slider):
    model = slider["numpy"]
    t, y, outcome = integrators.rk4.rk4(model, np.zeros(1), np.zeros(1), 1.0, 1e-3, save_every=10)
    assert outcome.complete
    assert np.abs(y[:, 0] - pd_response(t, 2.0, 50.0, 4.0, 0.3)).max() < 1e-8


@pytest.mark.requires_cc
@pytest.mark.parametrize("kp, kd", [(50.0, 4.0), (1e6, 2e3)])   # the second stiff: ω = 707 rad/s
def test_each_compiled_integrator_follows_the_closed_form(slider, kp, kd):
    model = on(slider, "c").with_params(kp=kp, kd=kd)
    zero = np.zeros(1)
    runs = {
        "rk4": (integrators.rk4.rk4(model, zero, zero, 0.5, 1e-5, save_every=500), 1e-8),
        "dop853": (integrators.dop853.dop853(model, zero, zero, 0.5, 5e-3, rtol=1e-12, atol=1e-14), 1e-8),
        "radau": (integrators.radau.radau(model, zero, zero, 0.5, 5e-3, rtol=1e-12, atol=1e-14), 1e-8),
        # second order in its step, (ω h)² at most 5e-5 of the 0.3 m travel
        "genalpha": (integrators.genalpha.genalpha(model, zero, zero, 0.5, 1e-5 if kp > 1e3 else 1e-4, 5e-3), 1e-6),
    }
    for method, ((t, y, outcome, *_), tolerance) in runs.items():
        assert outcome.complete, (method, str(outcome))
        error = np.abs(y[:, 0] - pd_response(t, 2.0, kp, kd, 0.3)).max()
        assert error < tolerance, (method, error)   # m


@pytest.mark.requires_cc
def test_numpy_and_c_give_the_same_run(slider):
    zero = np.zeros(1)
    runs = [integrators.rk4.rk4(on(slider, b).with_params(u_max=5.0), zero, zero, 0.5, 1e-3, save_every=10)
            for b in ("numpy", "c")]
    np.testing.assert_allclose(runs[0][1], runs[1][1], rtol=0, atol=1e-13)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_saturated_law_never_exceeds_its_limit_and_counts_as_input_work(env, backend):
    run = gpmegen.simulate(str(MODELS / "pd_slider.toml"), t_end=1.0, dt=1e-3, backend=backend)
    drive = run["drive_forces"][:, 0]
    assert np.abs(drive).max() <= 5.0 and drive[0] == 5.0
    # while at the limit the cart moves at the limit's constant acceleration
    held = np.flatnonzero(drive == 5.0)
    assert len(held) > 10 and np.all(np.diff(held) == 1)
    np.testing.assert_allclose(run["q"][held, 0], 5.0 / (2 * 2.0) * run.t[held] ** 2, rtol=0, atol=1e-12)
    assert drive.min() < 0   # and leaves it to brake
    # the drive's power q̇ Q, integrated with the state, is the kinetic energy gained
    gained = run["kinetic_energy"] - run["kinetic_energy"][0]
    np.testing.assert_allclose(run["work_drive"], gained, rtol=0, atol=1e-10)


def test_a_law_of_a_point_reads_its_position_and_velocity(tip):
    theta, rate = 0.4, -1.3
    L, kp, kd, m = 0.8, 30.0, 3.0, 1.5
    y, vy = L * np.sin(theta), L * np.cos(theta) * rate
    torque = -L * (kp * y + kd * vy)
    q, qd = np.array([theta]), np.array([rate])
    assert tip.drive_forces(0.0, q, qd)[0] == pytest.approx(torque, rel=1e-14)
    A_q, A_qd = tip.acceleration_jacobians(0.0, q, qd)
    inertia = m * L * L
    assert A_q[0, 0] == pytest.approx(-L * (kp * L * np.cos(theta) - kd * L * np.sin(theta) * rate) / inertia,
                                      rel=1e-12)
    assert A_qd[0, 0] == pytest.approx(-L * kd * L * np.cos(theta) / inertia, rel=1e-12)


def test_a_drive_of_an_acceleration_is_refused_from_python():
    model = gpmegen.load_model_file(MODELS / "pd_slider.toml")
    accelerated = dataclasses.replace(model, drives=(gpmegen.Drive("x", -sp.Symbol("x_ddot", real=True)),))
    with pytest.raises(ModelError, match="drive on 'x': a drive's law may use positions and velocities, not the "
                                         "acceleration x_ddot") as caught:
        expand(accelerated)
    assert "\n" not in str(caught.value)


def test_the_casadi_export_carries_the_law():
    casadi = pytest.importorskip("casadi")
    from gpmegen.codegen.backends import casadi as casadi_export

    model = gpmegen.load_model_file(MODELS / "pd_slider.toml")
    qdd = casadi_export.module_of(casadi_export.render_casadi(model, ())).functions()["qdd"]
    T, Q, QD, U = casadi.SX.sym("t"), casadi.SX.sym("q"), casadi.SX.sym("qd"), casadi.SX.sym("u", 0)
    p = [2.0, 50.0, 4.0, 0.3, 1e9]   # m, kp, kd, x_ref, u_max
    rate = casadi.Function("rate", [T, Q, QD, U], [casadi.jacobian(qdd(T, Q, QD, U, p), casadi.vertcat(Q, QD))])
    assert float(qdd(0.0, 0.1, 0.5, [], p)) == pytest.approx(4.0, rel=1e-15)
    np.testing.assert_allclose(np.asarray(rate(0.0, 0.1, 0.5, [])), [[-25.0, -2.0]], rtol=1e-15)


def test_the_linear_model_is_the_closed_loop(env):
    linear = gpmegen.linearize(str(MODELS / "pd_slider.toml"), backend="numpy", params={"u_max": 1e9})
    np.testing.assert_allclose(linear.A, [[0.0, 1.0], [-50.0 / 2.0, -4.0 / 2.0]], rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(linear.B, [[0.0], [1.0 / 2.0]], rtol=1e-12, atol=1e-12)   # the input on top of the law
    poles = np.sort_complex(linear.eigenvalues)
    np.testing.assert_allclose(poles, [-1.0 - 24 ** 0.5 * 1j, -1.0 + 24 ** 0.5 * 1j], rtol=1e-12)


def test_a_laws_velocity_gain_is_counted_once_in_the_energy_balance(env):
    # The dampers' matrix, -∂f/∂q̇, took the law's -kd q̇ for a damper: its work was counted in
    # work_dampers and again in work_drive, which integrates the law's power with the state.
    run = gpmegen.simulate(str(MODELS / "pd_slider.toml"), t_end=1.0, dt=1e-3, backend="numpy",
                           params={"u_max": 1e9})
    assert np.abs(run["work_dampers"]).max() == 0.0
    assert np.abs(run["work_drive"]).max() > 0.5   # J: the law's work, its braking included
    residual = energy.balance_residual(run.arrays)
    assert np.abs(residual).max() < 1e-9 * np.abs(run["work_drive"]).max()
