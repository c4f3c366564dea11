"""Controller states: first-order states of a model file (``[[controllers]]``) integrated with the
mechanics, read by its drives.

The models: a slider pushed back by a constant force F and held at x_ref by a PID law
(tests/models/pid_slider.toml), whose steady states are known in closed form with and without
the integral term, and a slider whose drive reads a first-order filter of a step (below), whose
response is 1 - exp(-t/T)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run import linear
from gpmegen.errors import ModelError
from gpmegen.runtime import integrators
from gpmegen.status import SolveStatus
from tests.backends import each_backend, on
from tests.refusals import refused_in_one_line

MODELS = Path(__file__).parent / "models"
PID = MODELS / "pid_slider.toml"
BACKENDS = ["numpy", pytest.param("c", marks=pytest.mark.requires_cc)]
M, KP, KI, KD, X_REF, F = 1.0, 40.0, 60.0, 12.0, 0.1, 2.0   # the file's defaults

FILTER = """schema = 1
name = "filtered_slider"
gravity = [0, 0, 0]

[parameters]
m = 0.5
k = 8.0
u = 1.0
T = 0.2

[[chain]]
joint = "x"
type = "prismatic"
axis = "x"

[[chain]]
body = "cart"
mass = "m"

[[chain]]
point = "C"

[[controllers]]
state = "s"
rate = "(u - s)/T"

[[drives]]
coordinate = "x"
expression = "k*(s - x)"
"""


@pytest.fixture(scope="module")
def pid(env):
    """The PID slider on each backend (the C one missing without a compiler)."""
    return each_backend(gpmegen.load_model_file(PID))


def test_a_drive_reads_the_controller_state_the_model_holds(pid):
    model = pid["numpy"]
    assert model.controller_names == ("e_int",) and model.controller_initial.tolist() == [0.0]
    q, qd = np.array([0.04]), np.array([0.5])
    held = model.at_controller_states([0.25])
    law = KP * (X_REF - 0.04) - KD * 0.5 + KI * 0.25 - F
    assert held.drive_forces(0.0, q, qd)[0] == pytest.approx(law, rel=1e-15)
    assert held.accelerations(0.0, q, qd)[0] == pytest.approx(law / M, rel=1e-15)
    assert held.controller_rates(0.0, q, qd).tolist() == pytest.approx([X_REF - 0.04], rel=1e-15)
    assert model.drive_forces(0.0, q, qd)[0] == pytest.approx(law - KI * 0.25, rel=1e-15)   # at the start's 0


@pytest.mark.parametrize("backend", BACKENDS)
def test_pid_removes_the_steady_error_that_pd_leaves(pid, backend):
    model = on(pid, backend)
    zero = np.zeros(1)
    # PD (ki = 0): poles -6 ± 2j, so e^(-6 t) < 1e-12 by t = 5 s; the error settles at F/kp
    t, y, outcome = integrators.rk4.rk4(model.with_params(ki=0.0), zero, zero, 5.0, 1e-3, save_every=100)
    assert outcome.complete
    assert X_REF - y[-1, 0] == pytest.approx(F / KP, abs=1e-10)
    # PID: s³ + 12 s² + 40 s + 60 has its slowest poles at about -2.05 ± 1.84j; from t = 12 s on
    # the transient is below e^(-24), and the integral alone balances F
    t, y, outcome = integrators.rk4.rk4(model, zero, zero, 15.0, 2e-3, save_every=500)
    assert outcome.complete
    assert np.abs(y[t >= 12.0, 0] - X_REF).max() < 1e-6
    e_int = y[:, 4]   # [x, x_dot, W_drive, W_constraint, e_int]
    assert e_int[-1] == pytest.approx(F / KI, abs=1e-8)


def test_the_slowest_pid_poles_are_those_the_test_relies_on():
    poles = np.roots([M, KD, KP, KI])
    assert poles.real.max() == pytest.approx(-2.05, abs=0.01)


@pytest.mark.parametrize("backend", BACKENDS)
def test_a_first_order_filter_follows_its_closed_form(env, tmp_path, backend):
    path = tmp_path / "filtered_slider.toml"
    path.write_text(FILTER)
    if backend == "c":
        pytest.importorskip("cffi")
    run = gpmegen.simulate(str(path), t_end=1.0, dt=1e-3, backend=backend)
    assert run["controller_names"].tolist() == ["s"]
    s = run["controller_states"][:, 0]
    # RK4 at h/T = 5e-3: a global error of about (h/T)^4/120 relative, far below this bound
    np.testing.assert_allclose(s, 1.0 - np.exp(-run.t / 0.2), rtol=0, atol=1e-10)
    # the drive read the state that was saved: k (s - x) at each sample
    np.testing.assert_allclose(run["drive_forces"][:, 0], 8.0 * (s - run["q"][:, 0]), rtol=0, atol=1e-13)


@pytest.mark.parametrize("backend", BACKENDS)
def test_every_integrator_that_carries_the_states_gives_the_same_run(pid, backend):
    model = on(pid, backend)
    zero = np.zeros(1)
    t, y, outcome = integrators.rk4.rk4(model, zero, zero, 2.0, 1e-3, save_every=100)
    assert outcome.complete
    runs = {"scipy-radau": integrators.scipy_radau.scipy_solve(model, zero, zero, 2.0, method="Radau", rtol=1e-10,
                                                               atol=1e-12,
                                                               t_eval=t)}
    if backend == "c":
        runs["dop853"] = integrators.dop853.dop853(model, zero, zero, 2.0, 0.1, rtol=1e-10, atol=1e-12)
    for method, (t_m, y_m, outcome_m, _) in runs.items():
        assert outcome_m.complete, method
        np.testing.assert_allclose(t_m, t, rtol=0, atol=1e-12)
        # x, x_dot and e_int (the works are not compared: the adaptive methods do not control their error)
        np.testing.assert_allclose(y_m[:, [0, 1, 4]], y[:, [0, 1, 4]], rtol=0, atol=1e-8, err_msg=method)


@pytest.mark.requires_cc
def test_numpy_and_c_give_the_same_run(pid):
    zero = np.zeros(1)
    # the Python loop over the NumPy functions and the compiled loop
    runs = [integrators.rk4.rk4(on(pid, b), zero, zero, 1.0, 1e-3, save_every=10) for b in ("numpy", "c")]
    assert runs[1][1].shape[1] == 5
    np.testing.assert_allclose(runs[0][1], runs[1][1], rtol=0, atol=1e-13)


@pytest.mark.parametrize("backend", BACKENDS)
def test_the_drive_work_carried_with_the_states_is_the_kinetic_energy_gained(env, backend):
    run = gpmegen.simulate(str(PID), t_end=2.0, dt=1e-3, backend=backend)
    gained = run["kinetic_energy"] - run["kinetic_energy"][0]
    np.testing.assert_allclose(run["work_drive"], gained, rtol=0, atol=1e-10)


@pytest.fixture(scope="module")
def reference(pid):
    """DOP853 of the PID slider on the C backend over 15 s at rtol 1e-12, saved every 0.5 s: the
    run the implicit loops are compared with (its own error some 1e-12)."""
    zero = np.zeros(1)
    t, y, outcome, _ = integrators.dop853.dop853(on(pid, "c"), zero, zero, 15.0, 0.5, rtol=1e-12, atol=1e-14)
    assert outcome.complete
    return t, y


def _slowest_settled(t, y):
    # the integral removes the steady error F/kp that PD leaves (see the RK4 test above)
    assert np.abs(y[t >= 12.0, 0] - X_REF).max() < 1e-6
    assert y[-1, 4] == pytest.approx(F / KI, abs=1e-8)


@pytest.mark.requires_cc
def test_radau_carries_the_states_as_dop853_does(pid, reference):
    zero = np.zeros(1)
    t_ref, y_ref = reference
    t, y, outcome, effort = integrators.radau.radau(on(pid, "c"), zero, zero, 15.0, 0.5, rtol=1e-10, atol=1e-12)
    assert outcome.complete
    np.testing.assert_allclose(t, t_ref, rtol=0, atol=1e-12)
    # Radau's global error stays at a few rtol times the state's size (|x| <= 0.1, |x_dot|, e_int
    # below 0.2): 1e-10 at most, here 1e-9 leaves it tenfold room; x, x_dot, e_int
    np.testing.assert_allclose(y[:, [0, 1, 4]], y_ref[:, [0, 1, 4]], rtol=0, atol=1e-9)
    _slowest_settled(t, y)
    # the states' blocks in the Newton matrix: without them (A_z, R_q, R_qd taken as zero) Newton
    # contracted slowly, 171 steps rejected beside 597 accepted; with them, 2 or 3 beside 456
    assert effort.rejected < 20


@pytest.mark.requires_cc
def test_generalized_alpha_carries_the_states_to_second_order(pid, reference):
    zero = np.zeros(1)
    t_ref, y_ref = reference
    model = on(pid, "c")
    errors = []
    for dt in (4e-3, 2e-3, 1e-3):
        t, y, outcome, _ = integrators.genalpha.genalpha(model, zero, zero, 15.0, dt, 0.5)
        assert outcome.complete
        np.testing.assert_allclose(t, t_ref, rtol=0, atol=1e-12)
        error = np.abs(y[:, [0, 1, 4]] - y_ref[:, [0, 1, 4]]).max(axis=0)
        # a second-order method's global error: about (h |lambda|)^2 times the state's size, with
        # |lambda| = 7.9 /s the fastest closed-loop pole (a first-order rule for z would leave
        # h |lambda| times it, 30 times more at dt = 4e-3)
        bound = (dt * np.abs(np.roots([M, KD, KP, KI])).max()) ** 2 * np.abs(y_ref[:, [0, 1, 4]]).max(axis=0)
        assert (error < bound).all(), (dt, error, bound)
        errors.append(error)
        _slowest_settled(t, y)
    # the trapezoidal rule for z in the Newton iteration of q'': the error on z falls 4-fold a halving
    ratios = [errors[k][2] / errors[k + 1][2] for k in range(2)]
    assert ratios == pytest.approx([4.0, 4.0], abs=0.2)


@pytest.mark.requires_cc
def test_the_compiled_loops_called_directly_carry_the_states(pid):
    # past the Python drivers: each loop takes the state with z and returns it with z
    model, zero = on(pid, "c"), np.zeros(1)
    y = integrators.loop.start_state(model, zero, zero)
    y[4] = 0.5
    rows, status = model.radau(0.0, y, np.array([0.01]), 1e-10, 1e-12, np.zeros(1),
                               np.zeros(integrators.base.ADAPTIVE_COUNTS, dtype=np.int64))
    assert status == SolveStatus.OK and rows.shape == (1, 5)
    # e_int' = x_ref - x, x = O(t^2) from rest: e_int(0.01) = 0.5 + 0.01 x_ref - O(1e-6 x'')
    assert rows[0, 4] == pytest.approx(0.5 + 0.01 * X_REF, abs=1e-5)
    memory = {"a": np.full(2, np.nan), "S": np.zeros((2, 2)), "pivot": np.zeros(2, dtype=np.intc),
              "have": np.zeros(1, dtype=np.intc)}
    y_ga = y.copy()
    rows_ga, status = model.genalpha(integrators.loop.grid(0.0, 0.01, 1e-3), 0, 10, 0.9, True, y_ga, memory,
                                     np.array([0.01]), np.zeros(integrators.base.COUNTS, dtype=np.int64))
    assert status == SolveStatus.OK
    # x, x_dot, e_int to generalized-alpha's error: (h |lambda|)^2 = 6e-5 of |x_dot| = 0.3
    np.testing.assert_allclose(rows_ga[:, [0, 1, 4]], rows[:, [0, 1, 4]], rtol=0, atol=2e-5)
    with pytest.raises(ValueError, match=r"S \(2, 2\)"):   # a Newton matrix without the states' room
        model.genalpha(integrators.loop.grid(0.0, 0.01, 1e-3), 0, 10, 0.9, True, y.copy(),
                       {**memory, "S": np.zeros((1, 1)), "pivot": np.zeros(1, dtype=np.intc)},
                       np.array([0.01]), np.zeros(integrators.base.COUNTS, dtype=np.int64))
    with pytest.raises(ValueError, match=r"a \(2,\)"):   # no room for the q̈ the iteration starts from
        model.genalpha(integrators.loop.grid(0.0, 0.01, 1e-3), 0, 10, 0.9, True, y.copy(),
                       {**memory, "a": np.full(1, np.nan)},
                       np.array([0.01]), np.zeros(integrators.base.COUNTS, dtype=np.int64))


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("gains", [{}, {"kp": 25.0, "ki": 10.0, "kd": 4.0, "m": 2.0}])
def test_the_linear_model_has_the_closed_loop_poles(env, backend, gains):
    if backend == "c":
        pytest.importorskip("cffi")
    lin = gpmegen.linearize(str(PID), start="none", backend=backend, params=gains)
    assert lin.states == ("x", "x_dot", "e_int") and lin.controllers == ("e_int",)
    g = {"m": M, "kp": KP, "ki": KI, "kd": KD, **gains}
    # m x'' = kp (x_ref - x) - kd x' + ki e_int - F + u, e_int' = x_ref - x: for the deviations,
    # (m s^3 + kd s^2 + kp s + ki) X = s U, the closed loop's characteristic polynomial
    poles = np.roots([g["m"], g["kd"], g["kp"], g["ki"]])
    np.testing.assert_allclose(np.sort_complex(lin.eigenvalues), np.sort_complex(poles), rtol=0, atol=1e-6)
    np.testing.assert_allclose(lin.B[:, 0], [0.0, 1.0 / g["m"], 0.0], rtol=0, atol=1e-12)
    # about the start (x = 0 at rest, e_int = 0): off the equilibrium, as the summary says
    assert lin.z_rate.tolist() == pytest.approx([X_REF], rel=1e-12)
    assert "controller states e_int" in lin.summary() and "max|z'| 0.1" in lin.summary()


def test_the_linear_model_is_about_the_controller_states_given(env):
    # the law is linear in e_int, so A does not depend on z: the state's acceleration and rate do
    model = gpmegen.load(gpmegen.load_model_file(PID), backend="numpy", jacobians=True)
    q, qd = np.array([0.04]), np.array([0.5])
    lin = linear.linearize(model, 0.0, q, qd, ("x",), z=[0.25])
    assert lin.z.tolist() == [0.25]
    law = KP * (X_REF - 0.04) - KD * 0.5 + KI * 0.25 - F
    assert lin.qdd[0] == pytest.approx(law / M, rel=1e-12)
    assert lin.arrays()["controller_names"].tolist() == ["e_int"]


def test_the_exports_refuse_the_states_in_one_line(pid):
    from gpmegen.codegen import backends

    with pytest.raises(ModelError, match="an FMU does not carry controller states") as caught:
        backends.get("fmu").check(gpmegen.load_model_file(PID))
    assert "\n" not in str(caught.value)


TEXT = PID.read_text()


@pytest.mark.parametrize("change, field, message", [
    (('rate = "x_ref - x"', 'rate = "x_ref - x - x_ddot"'), "controllers[0].rate",
     "a controller state's rate law may use positions and velocities, not the acceleration x_ddot"),
    (('rate = "x_ref - x"', 'rate = "x_ref - y"'), "controllers[0].rate", "unknown name 'y'"),
    (('state = "e_int"', 'state = "x"'), "controllers[0].state",
     "controller state 'x' has the name of a coordinate in expressions; choose another name"),
    (('state = "e_int"', 'state = "kp"'), "controllers[0].state",
     "controller state 'kp' has the name of a parameter in expressions; choose another name"),
    (('rate = "x_ref - x"', 'rate = "__import__(\'os\').system(\'true\')"'), "controllers[0].rate",
     "character \"'\" is not allowed in an expression"),
    (('rate = "x_ref - x"', 'rate = "x_ref.__class__"'), "controllers[0].rate", "is not allowed"),
    (('rate = "x_ref - x"', 'rate = "x_ref - x"\ngain = 2'), "controllers[0].gain",
     "unknown key 'gain'; the keys of a controller are state, rate, initial"),
])
def test_faulty_controllers_are_refused_in_one_line(tmp_path, capsys, change, field, message):
    refused_in_one_line(tmp_path / "pid_slider.toml", TEXT, change, field, message, capsys)


def test_a_drive_reading_an_undeclared_state_names_it(tmp_path, capsys):
    refused_in_one_line(tmp_path / "pid_slider.toml", TEXT, ("ki*e_int", "ki*e_intt"), "drives[0].expression",
                        "unknown name 'e_intt'; did you mean 'e_int'?", capsys)


def test_a_model_made_in_python_is_checked_as_a_file_is():
    import dataclasses

    import sympy as sp

    from gpmegen.model.expand import expand

    model = gpmegen.load_model_file(PID)
    x = sp.Symbol("x", real=True)
    for controllers, message in [
        ((gpmegen.Controller("x_dot", -x),), "controller state 'x_dot' has the name of a time, velocity"),
        ((gpmegen.Controller("e_int", -sp.Symbol("x_ddot", real=True)),),
         "controller state 'e_int': a controller state's rate law may use positions and velocities, not the "
         "acceleration x_ddot"),
        (("e_int",), "controllers\\[0\\] is a str, not a Controller"),
    ]:
        with pytest.raises(ModelError, match=message) as caught:
            expand(dataclasses.replace(model, controllers=controllers))
        assert "\n" not in str(caught.value)
