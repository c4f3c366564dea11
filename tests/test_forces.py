"""Forces between points ([[forces]]): a mass hung from a spring element against the closed
form (static deflection m g / k, frequency sqrt(k/m), the damped linear model), the generalized
force and stiffness of springs across a spatial arm against finite differences of the
potential (an independent computation), the energy balance with springs, dampers and an
actuator, a PD law on an element's length, a four-bar closed with a spring between its
branches, the refusals, and the generated code's determinism."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.figures.figure_list import stems
from gpmegen.analysis.post import energy
from gpmegen.analysis.post import results as results_io
from gpmegen.analysis.post.modes import natural_frequencies
from gpmegen.cli import main
from gpmegen.codegen.render import render
from gpmegen.errors import ModelError
from gpmegen.model.chain import Point
from gpmegen.model.expand import expand
from gpmegen.runtime import integrators
from tests.backends import each_backend, on

ROOT = Path(__file__).resolve().parents[1]
HANGER = ROOT / "tests" / "models" / "spring_hanger.toml"
# the hanger's parameters, as its file gives them
G, MASS, K, H = 9.81, 2.0, 800.0, 0.5

ARM = """schema = 1
name = "sprung_arm"
gravity = [0, "-g", 0]

[parameters]
g = 9.81
k = 300.0
L0 = 0.4
k2 = 150.0
L2 = 0.3
c = 0.0

[[chain]]
point = "A"                      # on the ground
position = [0.3, 0.5, 0.1]

[[chain]]
joint = "theta1"
type = "revolute"
axis = "z"

[[chain]]
body = "upper"
shape = { type = "bar", mass = 1.0, length = 0.5, width = 0.04, thickness = 0.02 }

[[chain]]
point = "U"
position = [0.25, 0.03, 0.02]

[[chain]]
translation = [0.5, 0, 0]

[[chain]]
joint = "theta2"
type = "revolute"
axis = "y"

[[chain]]
body = "lower"
shape = { type = "rod", mass = 0.6, length = 0.4, radius = 0.01 }

[[chain]]
joint = "s"
type = "prismatic"
axis = "x"

[[chain]]
body = "slider"
shape = { type = "point_mass", mass = 0.3, position = [0.4, 0, 0] }

[[chain]]
point = "P"
position = [0.4, 0.05, 0]

[[forces]]
name = "spring"
points = ["A", "P"]
type = "spring-damper"
stiffness = "k"
rest_length = "L0"
damping = "c"

[[forces]]
name = "inner"
points = ["U", "P"]
type = "spring-damper"
stiffness = "k2"
rest_length = "L2"
damping = "c"

[initial]
q = { theta1 = 0.3, theta2 = -0.4, s = 0.05 }
"""

FOUR_BAR = (ROOT / "examples" / "four_bar.toml").read_text()


def sprung_four_bar() -> str:
    """The example's four-bar with its crank free (not prescribed) and a spring-damper from the
    crank's tip B to the rocker's middle R: across the tree's two branches."""
    text = FOUR_BAR.replace('prescribed = "w*t"\n', "").replace('name = "four_bar"', 'name = "sprung_four_bar"')
    text = text.replace('[[chain]]\npoint = "C2"', '[[chain]]\npoint = "R"\nposition = ["L3/2", 0, 0]\n\n'
                                                   '[[chain]]\npoint = "C2"')
    return text + """
[[forces]]
name = "spring"
points = ["B", "R"]
type = "spring-damper"
stiffness = 60.0
rest_length = 0.2
damping = 0.3
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("forces")
    (folder / "arm.toml").write_text(ARM)
    (folder / "four_bar.toml").write_text(sprung_four_bar())
    return folder


@pytest.fixture(scope="module")
def arm(env, files):
    return gpmegen.load(model=gpmegen.load_model_file(files / "arm.toml"), backend="numpy")


@pytest.fixture(scope="module")
def hanger(env):
    """The hanger on each backend (C where there is a compiler), with the generated Jacobians."""
    return each_backend(gpmegen.load_model_file(HANGER), jacobians=True)


BACKENDS = ["numpy", pytest.param("c", marks=pytest.mark.requires_cc)]


# --- a mass hung from a spring -------------------------------------------------------------

@pytest.mark.parametrize("backend", BACKENDS)
def test_hanger_readings_and_force_are_the_spring_law(hanger, backend):
    model = on(hanger, backend).with_params(c=3.0)
    y, rate = -0.01, 0.3
    q, qd = np.array([y]), np.array([rate])
    L, Ldot = H - y, -rate                         # A is H above the mass
    F = K * (H - L) - 3.0 * Ldot                   # pushes apart when positive: -8 N of spring, +0.9 of damper
    np.testing.assert_allclose(model.force_elements(0.0, q, qd), [[L, Ldot, F]], rtol=1e-14)
    # on B the force F e, e = (B - A)/L pointing down: -F along y, with the weight
    assert model.forces(0.0, q, qd) == pytest.approx([-MASS * G - F], rel=1e-14)
    assert model.energies(q, qd)[2] == pytest.approx(K * y * y / 2, rel=1e-14)


def test_hanger_static_deflection_and_frequency_are_the_closed_form(env, hanger):
    start = gpmegen.statics(str(HANGER), start="locked", backend="numpy")
    assert start.q[0] == pytest.approx(-MASS * G / K, rel=1e-12)
    modes = natural_frequencies(hanger["numpy"], start.q)
    assert modes.frequencies == pytest.approx([math.sqrt(K / MASS) / (2 * math.pi)], rel=1e-12)


@pytest.mark.parametrize("backend", BACKENDS)
def test_hanger_oscillates_about_its_deflection_at_sqrt_k_over_m(hanger, backend):
    model = on(hanger, backend)
    t, y, outcome = integrators.rk4.rk4(model, np.zeros(1), np.zeros(1), 0.3, 2e-4, save_every=50)
    assert outcome.complete
    sag, omega = MASS * G / K, math.sqrt(K / MASS)
    np.testing.assert_allclose(y[:, 0], -sag + sag * np.cos(omega * t), rtol=0, atol=1e-10)


def test_the_damped_hanger_linearizes_to_its_closed_form(env):
    linear = gpmegen.linearize(str(HANGER), backend="numpy", params={"c": 5.0}, start="locked")
    np.testing.assert_allclose(linear.A, [[0.0, 1.0], [-K / MASS, -5.0 / MASS]], rtol=1e-12, atol=1e-12)


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_jacobians_hold_the_element(hanger, backend):
    model = on(hanger, backend).with_params(c=7.0)
    A_q, A_qd = model.acceleration_jacobians(0.0, np.array([-0.02]), np.array([0.4]))
    assert A_q[0, 0] == pytest.approx(-K / MASS, rel=1e-13)
    assert A_qd[0, 0] == pytest.approx(-7.0 / MASS, rel=1e-13)


def test_a_damped_run_balances_its_energy_while_the_damper_takes_much(env, tmp_path):
    run = gpmegen.simulate(str(HANGER), t_end=1.0, dt=1e-3, params={"c": 8.0}, backend="numpy")
    L, Ldot, F = (run.force("spring")[:, i] for i in range(3))
    assert np.all(L > 0) and np.all(np.isfinite(F))
    # the damper's work, -∫ c L̇² dt by the trapezoid rule over the samples: an independent
    # estimate of what the integrator integrated with the state
    lost = np.concatenate([[0.0], np.cumsum(np.diff(run.t) * -8.0 * (Ldot[1:] ** 2 + Ldot[:-1] ** 2) / 2)])
    assert lost[-1] < -0.1                                       # J: much of the 0.12 J sag released
    np.testing.assert_allclose(run["work_drive"], lost, rtol=0, atol=2e-3 * abs(lost[-1]))
    assert np.abs(run["work_dampers"]).max() == 0.0             # no joint damper: not counted twice
    assert np.abs(energy.balance_residual(run.arrays)).max() < 1e-8 * abs(lost[-1])
    # the readings in the CSV, and the figure
    paths = run.save(tmp_path / "hanger.npz")
    header = paths[-1].read_text().splitlines()[1].split(",") if paths[-1].suffix == ".csv" else None
    header = header or (tmp_path / "hanger.csv").read_text().splitlines()[1].split(",")
    assert header[-3:] == ["L_spring [m]", "Ldot_spring [m/s]", "F_spring [N]"]
    back = results_io.load(tmp_path / "hanger.npz")
    assert "force_elements" in stems([back])
    np.testing.assert_array_equal(back["force_elements"], run["force_elements"])


# --- springs across a spatial arm -----------------------------------------------------------

def _states(model, count=4, seed=3):
    rng = np.random.default_rng(seed)
    return [(rng.uniform(-1.2, 1.2, model.n_dof), rng.uniform(-2, 2, model.n_dof)) for _ in range(count)]


def test_springs_generalized_force_is_minus_the_gradient_of_their_potential(arm):
    h = 1e-6
    free = arm.with_params(k=0.0, k2=0.0)
    for q, _ in _states(arm):
        springs = arm.static_residual(q) - free.static_residual(q)   # ∂V/∂q of the elements
        gradient = np.array([(arm.energies(q + h * e, 0 * q)[2] - arm.energies(q - h * e, 0 * q)[2]) / (2 * h)
                             for e in np.eye(arm.n_dof)])
        np.testing.assert_allclose(springs, gradient, rtol=1e-7, atol=1e-7 * np.abs(gradient).max())
        # in f with the opposite sign
        np.testing.assert_allclose(arm.forces(0.0, q, 0 * q) - free.forces(0.0, q, 0 * q), -springs, rtol=1e-12,
                                   atol=1e-12 * np.abs(springs).max())


def test_the_stiffness_is_the_derivative_of_the_static_residual(arm):
    h = 1e-6
    for q, _ in _states(arm, seed=5):
        K_fd = np.column_stack([(arm.static_residual(q + h * e) - arm.static_residual(q - h * e)) / (2 * h)
                                for e in np.eye(arm.n_dof)])
        K_gen = arm.stiffness_jacobian(q)
        np.testing.assert_allclose(K_gen, K_fd, rtol=1e-6, atol=1e-6 * np.abs(K_fd).max())
        np.testing.assert_allclose(K_gen, K_gen.T, rtol=0, atol=1e-12 * np.abs(K_gen).max())


def test_the_dampers_force_is_their_rate_along_the_line(arm):
    h = 1e-6
    damped = arm.with_params(c=2.5)
    for q, qd in _states(arm, seed=7):
        readings = arm.force_elements(0.0, q, qd)
        step = [(arm.force_elements(0.0, q + h * e, qd)[:, 0] - arm.force_elements(0.0, q - h * e, qd)[:, 0]) / (2 * h)
                for e in np.eye(arm.n_dof)]
        gradients = np.column_stack(step)   # ∂L/∂q, one row per element
        np.testing.assert_allclose(readings[:, 1], gradients @ qd, rtol=1e-7)
        expected = -2.5 * (readings[:, 1] @ gradients)                  # Σ (-c L̇) ∂L/∂q
        np.testing.assert_allclose(damped.forces(0.0, q, qd) - arm.forces(0.0, q, qd), expected, rtol=1e-7,
                                   atol=1e-9)


def test_with_springs_only_the_energy_is_conserved(env, files):
    run = gpmegen.simulate(str(files / "arm.toml"), t_end=0.3, dt=2e-4, save_every=25, backend="numpy")
    assert run.status == "complete"
    swing = np.ptp(run["spring_energy"])
    assert swing > 0.05                                   # J exchanged with the springs
    total = run["kinetic_energy"] + run["gravity_energy"] + run["spring_energy"]
    assert np.ptp(total) < 1e-9 * swing
    assert run["work_drive"][-1] == 0.0


# --- an actuator with a feedback law ---------------------------------------------------------

def test_an_actuator_holding_its_length_by_a_pd_law_settles_where_the_law_says(env, tmp_path):
    text = HANGER.read_text().replace('''type = "spring-damper"
stiffness = "k"
rest_length = "H"                  # at rest where y = 0
damping = "c"''', '''type = "actuator"
force = "kp*(L_ref - (y_A - y_B)) + kd*vy_B"   # kp (L_ref - L) - kd L̇, with L = y_A - y_B''')
    text = text.replace("[[chain]]\npoint = \"A\"", 'kp = 2000.0\nkd = 60.0\nL_ref = 0.45\n\n[[chain]]\npoint = "A"')
    path = tmp_path / "held.toml"
    path.write_text(text)
    run = gpmegen.simulate(str(path), t_end=1.5, dt=1e-3, backend="numpy")
    kp, L_ref = 2000.0, 0.45
    L, Ldot, F = run.force("spring")[-1]
    # at rest the actuator carries the weight, F = -m g (it pulls the mass up), so L = L_ref + m g / kp
    assert L == pytest.approx(L_ref + MASS * G / kp, rel=1e-6)
    assert F == pytest.approx(-MASS * G, rel=1e-4) and abs(Ldot) < 1e-4
    # the balance holds to RK4's error, (ω h)⁴ = 1e-6 of the work at ω = sqrt(kp/m) = 31.6 rad/s
    assert np.abs(energy.balance_residual(run.arrays)).max() < 1e-6 * np.abs(run["work_drive"]).max()


# --- a closed loop ---------------------------------------------------------------------------

def test_a_four_bar_with_a_spring_between_its_branches_runs_and_balances(env, files):
    model = gpmegen.load(model=gpmegen.load_model_file(files / "four_bar.toml"), backend="numpy")
    h = 1e-6
    for q, _ in _states(model, seed=11):   # the stiffness across branches, where M has zeros
        K_fd = np.column_stack([(model.static_residual(q + h * e) - model.static_residual(q - h * e)) / (2 * h)
                                for e in np.eye(model.n_dof)])
        np.testing.assert_allclose(model.stiffness_jacobian(q), K_fd, rtol=1e-6, atol=1e-6 * np.abs(K_fd).max())
    run = gpmegen.simulate(str(files / "four_bar.toml"), t_end=0.4, dt=1e-3, backend="numpy")
    assert run.status == "complete" and np.abs(run["phi"]).max() < 1e-6
    work = np.abs(run["work_drive"]).max()                 # the damper's
    assert work > 1e-3
    scale = np.ptp(run["kinetic_energy"]) + np.ptp(run["spring_energy"])
    assert np.abs(energy.balance_residual(run.arrays)).max() < 1e-7 * scale


# --- refusals --------------------------------------------------------------------------------

SPRING = '''[[forces]]
name = "spring"
points = ["A", "B"]
type = "spring-damper"
stiffness = "k"
rest_length = "H"                  # at rest where y = 0
damping = "c"'''


@pytest.mark.parametrize("element, field, message", [
    (SPRING.replace('"A", "B"', '"A", "Q"'), "forces[0].points[1]", "force 'spring': no point 'Q'"),
    (SPRING.replace('"A", "B"', '"B", "B"'), "forces[0].points[1]", "the point 'B' is named twice"),
    (SPRING.replace('rest_length = "H"                  # at rest where y = 0\n', ""), "forces[0]",
     "a spring needs its rest_length (m) with its stiffness; add rest_length = ..."),
    (SPRING.replace("spring-damper", "spring").replace('damping = "c"', ""), "forces[0].type",
     "unknown force type 'spring'; did you mean 'spring-damper'?"),
    ('[[forces]]\nname = "push"\npoints = ["A", "B"]\ntype = "actuator"', "forces[0]",
     "force 'push': an actuator needs force; add force = ..."),
    ('[[forces]]\nname = "push"\npoints = ["A", "B"]\ntype = "actuator"\nforce = "-k*y_ddot"',
     "forces[0].force", "an actuator's law may use positions and velocities, not the acceleration y_ddot"),
    ('[[forces]]\nname = "push"\npoints = ["A", "B"]\ntype = "actuator"\nforce = "-k*ay_B"',
     "forces[0].force", "an actuator's law may use positions and velocities, not the point acceleration ay_B"),
    (SPRING.replace('damping = "c"', 'force = "1"'), "forces[0].force", "a spring-damper takes no force"),
    (SPRING.replace('name = "spring"', 'name = "mass"'), "forces[0].name",
     "force 'mass': the name is already taken by a body"),
    (SPRING.replace('name = "spring"', 'name = "_x1"'), "forces[0].name", "'_x1' is not a valid name"),
])
def test_a_faulty_force_is_refused_in_one_line(tmp_path, capsys, element, field, message):
    path = tmp_path / "faulty.toml"
    path.write_text(HANGER.read_text().replace(SPRING, element))
    assert main(["build", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "faulty.toml:" in err and f": {field}: " in err and message in err, err
    assert err.count("\n") == 1 and not (tmp_path / "out").exists()


def test_points_that_always_coincide_are_refused(tmp_path, capsys):
    # B at the origin of the prismatic slider's frame ... and a point D right after a revolute
    # joint at its axis, with C on the ground there: they meet in every configuration
    text = HANGER.read_text() + '''
[[chain]]
parent = "ground"
point = "C"

[[chain]]
joint = "turn"
type = "revolute"
axis = "z"

[[chain]]
body = "wheel"
mass = 1.0

[[chain]]
point = "D"

[[forces]]
name = "idle"
points = ["C", "D"]
type = "spring-damper"
damping = 1.0
'''
    path = tmp_path / "coincide.toml"
    path.write_text(text)
    assert main(["build", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err
    assert "forces[1].points: force 'idle': points 'C' and 'D' coincide in every configuration" in err
    assert err.count("\n") == 1


def test_two_points_on_the_ground_are_refused_from_python():
    model = gpmegen.load_model_file(HANGER)
    grounded = dataclasses.replace(model, chain=(Point("A2", (0, 0, 0)),) + model.chain,
                                   forces=(dataclasses.replace(model.forces[0], points=("A", "A2")),))
    with pytest.raises(ModelError, match="force 'spring': points 'A' and 'A2' are both on the ground") as caught:
        expand(grounded)
    assert caught.value.subject == ("forces", 0, "points")


# --- the generated code -------------------------------------------------------------------

def test_generated_code_is_deterministic(env):
    model = gpmegen.load_model_file(HANGER)
    first, second = render(model, ("numpy", "c")), render(model, ("numpy", "c"))
    assert first == second
    assert "force_elements" in first["model.h"] and "FORCES = ('spring',)" in first["model_numpy.py"]


# --- where the points meet ---------------------------------------------------------------------

@pytest.mark.parametrize("backend", BACKENDS)
def test_points_meeting_in_a_run_stop_it_naming_the_element(hanger, backend):
    # no gravity, no spring: the mass rises at 1 m/s and meets A (0.5 m up) exactly in the last
    # stage of the fourth step of 0.125 s (all binary fractions), where e = d/L is 0/0
    model = on(hanger, backend).with_params(g=0.0, k=0.0)
    t, y, outcome = integrators.rk4.rk4(model, np.zeros(1), np.ones(1), 1.0, 0.125)
    assert not outcome.complete and t[-1] == 0.375
    assert ("non-finite state" in str(outcome) and "the shortest force element, 'spring', was 0.125 m long at "
            "t = 0.375 s (at length 0 its direction is undefined and its force NaN: keep its points apart)"
            in str(outcome))
    with pytest.raises(gpmegen.errors.SimulationError, match="force element 'spring' has length 0 at the start: its "
                                                             "points 'A' and 'B' meet"):
        integrators.rk4.rk4(model, np.array([H]), np.zeros(1), 1.0, 0.125)


@pytest.mark.long
@pytest.mark.requires_cc
@pytest.mark.parametrize("name", ["arm.toml", "four_bar.toml"])
def test_the_c_backend_and_its_recursion_agree_with_numpy(env, files, name):
    # the C solve runs the articulated-body recursion, whose joint forces hold the elements
    model = gpmegen.load_model_file(files / name)
    numpy_model, c_model = (gpmegen.load(model=model, backend=b) for b in ("numpy", "c"))
    for q, qd in _states(numpy_model, seed=13):
        scale = np.abs(numpy_model.accelerations(0.0, q, qd)).max()
        np.testing.assert_allclose(c_model.accelerations(0.0, q, qd), numpy_model.accelerations(0.0, q, qd),
                                   rtol=1e-10, atol=1e-10 * scale)
        np.testing.assert_allclose(c_model.force_elements(0.0, q, qd), numpy_model.force_elements(0.0, q, qd),
                                   rtol=1e-13, atol=1e-13)
        np.testing.assert_allclose(c_model.stiffness_jacobian(q), numpy_model.stiffness_jacobian(q), rtol=1e-12,
                                   atol=1e-12 * np.abs(numpy_model.stiffness_jacobian(q)).max())


def test_the_casadi_export_carries_the_element():
    pytest.importorskip("casadi")
    from gpmegen.codegen.backends import casadi as casadi_export

    model = gpmegen.load_model_file(HANGER)
    qdd = casadi_export.module_of(casadi_export.render_casadi(model, ())).functions()["qdd"]
    y, rate, c = -0.01, 0.3, 3.0
    F = K * y + c * rate            # k (L0 - L) - c L̇ with L = H - y, L̇ = -ẏ
    p = [G, MASS, K, c, H]          # g, m, k, c, H
    assert float(qdd(0.0, y, rate, [], p)) == pytest.approx((-MASS * G - F) / MASS, rel=1e-14)
