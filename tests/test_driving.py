"""Driving functions: the multipliers λ of the ideal realization, the force on the constrained
point, and the actuated realization (servo-constraints) against an independent inverse dynamics."""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen import cli
from gpmegen.analysis.post import driving
from gpmegen.analysis.post import results as results_io
from gpmegen.analysis.run import reference_case, study
from gpmegen.errors import ModelError
from gpmegen.model.reference import start_constants

sys.path.insert(0, str(Path(__file__).resolve().parent))
import oracle as ref  # noqa: E402  (tests/oracle.py: shares no code with gpmegen)

from gpmegen.analysis.run.runspec import RunSpec

JOINTS = tuple(name for name, _ in start_constants().at)  # the arm's joints, held at its start


def started(model):
    """``model`` with the paper's constraint constants set, and its locked-statics start."""
    return reference_case.initial_state(model, "locked")


def relative(residual, scale):
    return np.max(np.abs(residual)) / max(np.max(np.abs(scale)), 1e-300)


@pytest.fixture(scope="module")
def flexible3():
    return started(gpmegen.load("manipulator", nrfe=3, backend="numpy"))


@pytest.fixture(scope="module")
def ideal3(flexible3):
    model, q0 = flexible3
    return study.simulate(model, q0, RunSpec(t_end=0.05, dt=1e-4, save_every=25))


@pytest.fixture(scope="module")
def rigid_runs():
    model, q0 = started(gpmegen.load("manipulator", nrfe=1, backend="numpy"))
    ideal = study.simulate(model, q0, RunSpec(t_end=0.5, dt=1e-3, save_every=25))
    actuated = study.simulate(model.with_actuators(["psi2", "x3"]), q0, RunSpec(t_end=0.5, dt=1e-3, save_every=25))
    return model, ideal, actuated


def test_multipliers_realize_the_constraints_ideally(flexible3, ideal3):
    """M q̈ - f = Dᵀλ at every saved state of a flexible run, with q̈ and λ as saved; the
    reaction acts on the elastic coordinates too."""
    model, _ = flexible3
    res = ideal3
    assert str(res["status"]) == "complete" and len(res["t"]) > 5
    for k, t in enumerate(res["t"]):
        M, f, _, _, D, _ = model.gpme_terms(t, res["q"][k], res["qd"][k])
        generalized = M @ res["qdd"][k] - f
        assert relative(generalized - D.T @ res["lambda"][k], generalized) < 1e-9
        assert np.allclose(res["constraint_forces"][k], generalized, rtol=1e-12, atol=1e-12)
    elastic = [k for k, name in enumerate(model.coordinates) if name not in JOINTS]
    assert np.max(np.abs(res["constraint_forces"][:, elastic])) > 1.0  # N·m: not actuator torques
    assert np.max(np.abs(res["phi"])) < 1e-8


def test_point_force_maps_to_the_generalized_reaction(flexible3, ideal3):
    """The force F on E (from the constraints' gradients in x_E, y_E, z_E) satisfies
    J_Eᵀ F = Dᵀλ, with J_E by central differences of E's position."""
    model, _ = flexible3
    forces = driving.point_forces(reference_case.ReferenceCase(3).model, model, ideal3["t"], ideal3["q"],
                                  ideal3["lambda"])
    assert list(forces) == ["E"]
    for k in (0, len(ideal3["t"]) // 2, -1):
        q = ideal3["q"][k]
        h = 1e-6
        J = np.column_stack([(model.end_effector(q + h * e) - model.end_effector(q - h * e)) / (2 * h)
                             for e in np.eye(model.n_dof)])
        D = model.constraint_terms(ideal3["t"][k], q, ideal3["qd"][k])[2]
        reaction = D.T @ ideal3["lambda"][k]
        assert relative(J.T @ forces["E"][k] - reaction, reaction) < 1e-7


def test_units_of_the_driving_functions():
    """λ of the circle (m²) in N/m, of the height (m) in N; rotations take N·m, the slider N."""
    model = reference_case.ReferenceCase(2).model
    assert driving.lambda_units(model, {"circle": "m²", "height": "m"}) == {"circle": "N/m", "height": "N"}
    # without the case's units, from the expressions' forms: x_E² + z_E² - r_Ea² and y_E - y_c - A cos(…)
    assert driving.lambda_units(model, {}) == {"circle": "N/m", "height": "N"}
    units = driving.force_units(model)
    assert units["psi2"] == units["theta1"] == "N·m" and units["x3"] == "N"
    assert {units[name] for name in units if name not in JOINTS} == {"N·m"}


def test_actuated_realization_holds_the_constraints_by_the_inputs(rigid_runs):
    """M q̈ - f - S u = 0 and Φ = 0 along an actuated run of the rigid arm."""
    model, _, res = rigid_runs
    assert str(res["status"]) == "complete" and list(res["actuators"]) == ["psi2", "x3"]
    S = np.zeros((3, 2))
    S[[1, 2], [0, 1]] = 1.0
    for k, t in enumerate(res["t"]):
        M, f, _, _, _, _ = model.gpme_terms(t, res["q"][k], res["qd"][k])
        residual = M @ res["qdd"][k] - f - S @ res["u"][k]
        assert relative(residual, M @ res["qdd"][k] - f) < 1e-9
    assert np.max(np.abs(res["phi"])) < 1e-8


def test_rigid_inputs_match_an_independent_inverse_dynamics(rigid_runs):
    """Inverse dynamics of the rigid arm by the oracle's own Lagrange equations along the
    actuated motion: zero on θ1 (driven only by its drive), the inputs u on ψ2 and x3."""
    model, _, res = rigid_runs
    orc = ref.oracle(1, model.params)
    for k, t in enumerate(res["t"]):
        q, qd, qdd = res["q"][k], res["qd"][k], res["qdd"][k]
        tau = orc.mass_matrix(q) @ qdd - orc.forces(t, q, qd)
        scale = np.max(np.abs(tau))
        assert abs(tau[0]) < 1e-9 * scale
        assert np.allclose(tau[1:], res["u"][k], rtol=1e-9, atol=1e-9 * scale)


def test_rigid_actuated_realization_equals_the_ideal_one(rigid_runs):
    """For the rigid arm the constraints do not depend on θ1, so Dᵀλ vanishes there and the
    ideal reaction on ψ2 and x3 is the actuated input: same motion, same forces."""
    _, ideal, actuated = rigid_runs
    assert np.allclose(ideal["q"], actuated["q"], rtol=0, atol=1e-12)
    reaction = ideal["constraint_forces"]
    assert np.max(np.abs(reaction[:, 0])) < 1e-9 * np.max(np.abs(reaction))
    assert np.allclose(reaction[:, 1:], actuated["u"], rtol=1e-9, atol=1e-9)


def test_actuators_the_constraints_cannot_use_are_refused(rigid_runs):
    model, _, _ = rigid_runs
    q0 = started(model)[1]
    with pytest.raises(ModelError, match=r"inputs on theta1, x3 cannot hold .* depend on \(psi2, x3\)"):
        study.simulate(model.with_actuators(["theta1", "x3"]), q0, RunSpec(t_end=0.01, dt=1e-3, save_every=1))
    with pytest.raises(ModelError, match="one input per constraint"):
        model.with_actuators(["psi2"])
    with pytest.raises(ModelError, match="unknown actuated coordinate 'x9'"):
        model.with_actuators(["x9", "x3"])


def test_cli_writes_the_driving_functions_with_units(tmp_path, capsys):
    """``simulate`` saves q̈, λ and the force on E (ideal), or u and the actuators (--actuated),
    with units in the CSV's header; ``--actuated`` on a coordinate no constraint moves exits 2."""
    common = ["simulate", "--nrfe", "1", "--t-end", "0.05", "--dt", "1e-3", "--save-every", "10",
              "--backend", "numpy"]
    assert cli.main(common + ["--out", str(tmp_path / "ideal.npz")]) == 0
    assert cli.main(common + ["--out", str(tmp_path / "act.npz"), "--actuated", "psi2", "x3"]) == 0
    ideal, act = results_io.load(tmp_path / "ideal.npz"), results_io.load(tmp_path / "act.npz")
    header = (tmp_path / "ideal.csv").read_text(encoding="utf-8").splitlines()[1].split(",")
    assert header[-5:] == ["lambda_circle [N/m]", "lambda_height [N]", "Fx_E [N]", "Fy_E [N]", "Fz_E [N]"]
    header = (tmp_path / "act.csv").read_text(encoding="utf-8").splitlines()[1].split(",")
    assert header[-2:] == ["u_psi2 [N·m]", "u_x3 [N]"]
    assert ideal["point_forces"].shape == (len(ideal["t"]), 1, 3) and "u" not in ideal
    assert np.allclose(act["u"], ideal["constraint_forces"][:, 1:], rtol=1e-9, atol=1e-9)
    # the height constraint's force is the vertical force on E (∂Φ/∂y_E = 1)
    assert np.allclose(ideal["point_forces"][:, 0, 1], ideal["lambda"][:, 1], rtol=1e-12)
    capsys.readouterr()
    assert cli.main(common + ["--out", str(tmp_path / "bad.npz"), "--actuated", "theta1", "psi2"]) == 2
    errors = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(errors) == 1 and errors[0].startswith("gpmegen simulate: error: at t = 0 s the inputs on theta1, psi2")


def test_holding_forces_at_rest_against_the_oracle(flexible3):
    """At the locked start the joints' holding forces are the oracle's g + C q on θ1, ψ2, x3;
    at the constrained equilibrium the constraints alone hold the arm (nothing left unbalanced),
    while at the locked start they cannot (the jolt when the joints are freed)."""
    model, q_locked = flexible3
    symbolic = reference_case.ReferenceCase(3).model
    orc = ref.oracle(3, model.params)
    expected = orc.chain.gravity(q_locked) + orc.chain.stiffness() @ q_locked
    held = driving.holding(symbolic, model, q_locked)
    assert list(held["joints"]) == ["theta1", "psi2", "x3"]
    joints = [model.index(name) for name in held["joints"]]
    assert np.allclose(list(held["joints"].values()), expected[joints], rtol=1e-10, atol=1e-10)
    assert held["unbalanced"] > 1.0
    _, q_constrained = reference_case.initial_state(model, "constrained")
    assert driving.holding(symbolic, model, q_constrained)["unbalanced"] < 1e-8


def test_deformation_is_the_springs_and_the_flexible_displacement_of_E(flexible3, ideal3):
    """``spring_forces`` is C q with C from the oracle's springs; the deflection of E vanishes for
    the rigid arm's configuration and equals E(q) - E(q with the sde rotations zero)."""
    model, _ = flexible3
    orc = ref.oracle(3, model.params)
    out = driving.deformation(model, ideal3["q"])
    assert np.allclose(out["spring_forces"], ideal3["q"] @ orc.chain.stiffness().T, rtol=1e-12, atol=1e-9)
    rigid = ideal3["q"].copy()
    rigid[:, [k for k, name in enumerate(model.coordinates) if name not in JOINTS]] = 0.0
    assert np.max(np.abs(driving.deformation(model, rigid)["deflection"])) == 0.0
    k = -1
    assert np.allclose(out["deflection"][k], orc.end_effector(ideal3["q"][k]) - orc.end_effector(rigid[k]),
                       rtol=1e-10, atol=1e-12)
    assert np.max(np.abs(out["deflection"][:, 1])) > 1e-4  # m: the arm sags


# make check-c: every figure of two runs drawn twice (the driving functions' figures of a run:
# test_plots.py's every-figure tests)
@pytest.mark.long
def test_driving_figures_need_the_driving_functions(flexible3, ideal3, rigid_runs, tmp_path):
    """The figures of the driving functions are drawn from runs that hold them; a results file of
    format 2 written before they were saved still plots, without them. The force drawn on a
    joint is its drive plus the reaction, M q̈ - f there."""
    from gpmegen.analysis.figures import driving_plots, run_figures

    model, _ = flexible3
    res = driving.annotate(ideal3, reference_case.ReferenceCase(3).model, model)
    k = model.index("psi2")
    M, f, *_ = model.gpme_terms(res["t"][-1], res["q"][-1], res["qd"][-1])
    assert np.isclose(driving_plots.joint_forces(res, "psi2")[-1], (M @ res["qdd"][-1] - f)[k]
                      + res["drive_forces"][-1, k], rtol=1e-12)
    names = {p.name for p in run_figures.plot_all([res, rigid_runs[2]], tmp_path / "new")}
    assert {"driving_functions.png", "elastic_deformation.png", "constraint_multipliers.png"} <= names
    old = {key: value for key, value in ideal3.items()
           if key not in ("qdd", "lambda", "u", "actuators", "drive_forces", "constraint_forces")}
    names = {p.name for p in run_figures.plot_all([old], tmp_path / "old")}
    assert "joint_coordinates.png" in names and "driving_functions.png" not in names


@pytest.mark.requires_cc
def test_actuated_realization_on_the_c_terms_equals_numpy(env):
    """The actuated realization in the compiled loop (C) and in the Python one (NumPy): the same
    motion and inputs."""
    runs = {}
    for backend in ("numpy", "c"):
        model, q0 = started(gpmegen.load("manipulator", nrfe=2, backend=backend))
        runs[backend] = study.simulate(model.with_actuators(["psi2", "x3"]), q0,
                                       RunSpec(t_end=0.02, dt=1e-4, save_every=20, max_violation=None))
    assert str(runs["c"]["status"]) == str(runs["numpy"]["status"]) == "complete"
    for key in ("q", "qd", "u"):
        assert np.allclose(runs["c"][key], runs["numpy"][key], rtol=1e-9, atol=1e-9)


@pytest.mark.requires_cc
def test_actuated_runs_are_estimated_by_the_loop_they_run_in(env, monkeypatch):
    """An actuated RK4 run is estimated as the loop it runs in: 3·10⁷ steps of the rigid arm are
    refused before they start in the Python loop of the NumPy backend (about 2 h), and taken as
    the compiled loop's on the C backend (the estimate the ideal realization's run gets)."""
    from gpmegen import limits

    model, q0 = started(gpmegen.load("manipulator", nrfe=1, backend="numpy"))
    spec = RunSpec(t_end=300.0, dt=1e-5, save_every=100)
    with pytest.raises(limits.LimitError, match="would take about"):
        study.simulate(model.with_actuators(["psi2", "x3"]), q0, spec)
    estimated = []

    def estimate(n_dof, n_constraints, spec, backend, omega=None):
        estimated.append(backend)
        raise limits.LimitError("estimated")

    monkeypatch.setattr(limits, "check_run", estimate)
    model, q0 = started(gpmegen.load("manipulator", nrfe=1, backend="c"))
    with pytest.raises(limits.LimitError, match="estimated"):
        study.simulate(model.with_actuators(["psi2", "x3"]), q0, spec)
    assert estimated == ["c"]


def test_an_actuated_run_keeps_its_own_default_results_and_says_so(tmp_path, monkeypatch, capsys):
    """Without --out the ideal and the actuated run of one model, start and method used to share
    a default name (the second refused); each now has its own, and the summary names the inputs."""
    monkeypatch.chdir(tmp_path)
    common = ["simulate", "--nrfe", "1", "--t-end", "0.01", "--dt", "1e-3", "--save-every", "5", "--backend", "numpy"]
    assert cli.main(common) == 0
    assert "actuated" not in capsys.readouterr().out
    assert cli.main(common + ["--actuated", "psi2", "x3"]) == 0
    summary = capsys.readouterr().out
    assert "(numpy, rk4, dt = 0.001 s, actuated on psi2, x3; saved every 0.005 s; 10 steps" in summary
    assert sorted(p.name for p in (tmp_path / "results").glob("*.npz")) == [
        "run_nrfe1_locked_rk4.npz", "run_nrfe1_locked_rk4_actuated-psi2-x3.npz"]
    assert "u" in results_io.load(tmp_path / "results" / "run_nrfe1_locked_rk4_actuated-psi2-x3.npz")


def test_units_of_multipliers_come_from_the_forms_of_their_constraints(tmp_path):
    """Every multiplier of a model file was "generalized", even a prescribed crank's: a joint's
    law takes its joint's force unit, a point's coordinate N, a squared distance N/m, a point's
    velocity N; a form that does not fix the unit (a parameter as coefficient) stays generalized."""
    from dataclasses import replace

    import sympy

    from gpmegen.analysis.run.model_files import read_model_file
    from gpmegen.model.chain import TIME, point_symbols, point_velocity_symbols, symbol, velocity_symbol

    path = tmp_path / "slider.toml"
    path.write_text("""schema = 1
name = "units"
dependent = ["slide"]
[parameters]
w = 2.0
a = 3.0
[[chain]]
joint = "crank"
type = "revolute"
axis = "z"
prescribed = "w*t"
[[chain]]
joint = "slide"
type = "prismatic"
axis = "y"
[[chain]]
body = "b"
shape = { type = "point_mass", mass = 1.0, position = [1, 0, 0] }
[[chain]]
point = "P"
[[constraints]]
name = "height"
expression = "y_P - 0.1*sin(t)"
""", encoding="utf-8")
    model = read_model_file(path).model
    assert driving.lambda_units(model, {}) == {"height": "N", "prescribed_crank": "N·m"}
    height = model.constraints[0]
    names = {str(s): s for s in (*point_symbols("P"), *point_velocity_symbols("P"), symbol("slide"), symbol("crank"),
                                 velocity_symbol("crank"), symbol("w"), symbol("a"), TIME)}
    for text, order, unit in (("x_P**2 + y_P**2 - 4", 0, "m²"), ("a*z_P", 0, None), ("vz_P - 0.5", 1, "m/s"),
                                    ("slide - 2*t", 0, "m"), ("crank_dot - w", 1, "rad/s"),
                              ("2*crank - w*t", 0, None), ("sqrt(x_P**2 + y_P**2) - 1", 0, None)):
        expression = sympy.sympify(text, locals=names)
        assert driving.expression_unit(model, replace(height, expression=expression, order=order)) == unit, text


SLIDER_CRANK = """schema = 1
name = "slider_crank_units"
dependent = ["rod"]
[parameters]
r = 0.1
l = 0.3
m1 = 0.5
m2 = 2.0
w = 6.0
[[chain]]
joint = "crank"
type = "revolute"
axis = "z"
prescribed = "w*t"
[[chain]]
translation = ["r", 0, 0]
[[chain]]
body = "pin"
shape = { type = "point_mass", mass = "m1" }
[[chain]]
joint = "rod"
type = "revolute"
axis = "z"
[[chain]]
translation = ["l", 0, 0]
[[chain]]
body = "slider"
shape = { type = "point_mass", mass = "m2" }
[[chain]]
point = "B"
[[constraints]]
name = "guide"
expression = "y_B"
[initial]
q = { rod = 0.0 }
"""


def test_the_motor_torque_of_a_prescribed_crank_is_its_own_reaction_alone(tmp_path):
    """A slider-crank as a serial chain: the crank prescribed, the slider held on its guide by a
    closing constraint. The driving function drawn on the crank added the guide's passive reaction
    to the motor torque; it is the crank law's reaction alone, whose power is the rate of the
    kinetic energy (the guide does no work), while the sum is not."""
    from gpmegen.analysis.figures import driving_plots

    path = tmp_path / "slider_crank.toml"
    path.write_text(SLIDER_CRANK, encoding="utf-8")
    res = gpmegen.simulate(str(path), t_end=0.1, dt=2e-4, save_every=1, backend="numpy").arrays
    model = gpmegen.load(model=gpmegen.load_model_file(path), backend="numpy")
    k = model.index("crank")
    motor = driving_plots.joint_forces(res, "crank")
    kinetic = np.array([model.energies(q, qd)[0] for q, qd in zip(res["q"], res["qd"])])
    rate = np.gradient(kinetic, res["t"])[5:-5]
    power = (motor * res["qd"][:, k])[5:-5]
    scale = np.max(np.abs(rate))
    assert np.max(np.abs(power - rate)) < 1e-4 * scale
    summed = (res["drive_forces"][:, k] + res["constraint_forces"][:, k]) * res["qd"][:, k]
    assert np.max(np.abs(summed[5:-5] - rate)) > 0.1 * scale  # the guide's reaction on the crank is no motor's
