"""The integrators beside RK4: DOP853 in the compiled loop (against SciPy's at tight tolerance, its
dense output on the save grid, what it took), the step guidance that refuses an unstable RK4 step,
and the command line's --method, --save-dt, --rtol and --atol."""

import math
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen import limits
from gpmegen.analysis.post import modes
from gpmegen.analysis.post.results import metadata
from gpmegen.analysis.run import reference_case, study
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.cli import build_parser, main
from gpmegen.runtime import integrators, stability

pytestmark = pytest.mark.requires_cc

SPAN = 0.2  # s: the motion starts and the flexible modes ring


@pytest.fixture(scope="module")
def arm(env):
    """The reference case at n_rfe = 2 in C, its locked start and a tight SciPy DOP853 reference
    on the same right-hand side: ``(model, q0, reference)``, ``reference(t)`` the states (k, 2n)."""
    model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=2, backend="c"))
    qd0 = np.zeros(model.n_dof)

    def reference(t):
        _, y, outcome = integrators.scipy_radau.adaptive(model, q0, qd0, float(t[-1]), rtol=1e-13, atol=1e-15, t_eval=t)
        assert outcome.complete
        return y[:, :2 * model.n_dof]

    return model, q0, reference


def _dop853(model, q0, save_dt, rtol, atol=None, t_end=SPAN):
    return integrators.dop853.dop853(model, q0, np.zeros(model.n_dof), t_end, save_dt, rtol=rtol,
                                     atol=rtol * 1e-2 if atol is None else atol)


@pytest.mark.parametrize("rtol", [1e-6, 1e-9])
def test_dop853_meets_a_tight_reference_to_its_tolerance(arm, rtol):
    model, q0, reference = arm
    t, y, outcome, effort = _dop853(model, q0, 1e-3, rtol)
    assert outcome.complete and np.allclose(t, np.linspace(0.0, SPAN, len(t)), rtol=0, atol=1e-15)
    error = np.abs(y[:, :2 * model.n_dof] - reference(t)).max()
    # the state moves by O(1) rad and rad/s: a step's local error is below rtol, the global one
    # within a small multiple of it (and far below the motion: the model is not trivially met)
    assert error < 10 * rtol
    assert np.abs(y[-1, :model.n_dof] - q0).max() > 1e4 * rtol
    assert effort.steps > 0 and effort.jacobians == effort.factorizations == 0


def test_dop853_error_falls_with_the_tolerance(arm):
    model, q0, reference = arm
    errors = []
    for rtol in (1e-5, 1e-8):
        t, y, _, _ = _dop853(model, q0, 1e-3, rtol)
        errors.append(np.abs(y[:, :2 * model.n_dof] - reference(t)).max())
    assert errors[1] < 1e-2 * errors[0]


def test_dense_output_is_the_steps_own_state_where_one_lands_and_accurate_between(arm):
    model, q0, reference = arm
    # the steps land on the ends of the driver's chunks; a coarse grid of one chunk per interval
    # (binary fractions, so both grids hold the same instants exactly) has the same chunks, so the
    # same steps, and holds only the steps' own states
    fine = 2.0 ** -10
    coarse = round(integrators.loop.CHUNK_SECONDS / fine) * fine
    assert round(integrators.loop.CHUNK_SECONDS / coarse) == 1
    tc, yc, _, ec = _dop853(model, q0, coarse, 1e-9)
    tf, yf, _, ef = _dop853(model, q0, fine, 1e-9)
    assert (ec.steps, ec.rejected) == (ef.steps, ef.rejected)
    on_coarse = np.isin(tf, tc)
    assert on_coarse.sum() == len(tc)
    assert np.array_equal(yf[on_coarse], yc)  # bit for bit
    # between the steps, the interpolant of order 7 is as good as the steps
    between = ~on_coarse
    assert np.abs(yf[between, :2 * model.n_dof] - reference(tf)[between]).max() < 1e-8


def test_dop853_counts_what_it_did(arm):
    model, q0, _ = arm
    t, _, _, effort = _dop853(model, q0, 1e-3, 1e-8)
    chunks = math.ceil(SPAN / integrators.loop.CHUNK_SECONDS - 1e-9)
    attempts = effort.steps + effort.rejected
    # 12 solves a step tried, 3 more for the dense output of a step holding a save instant, one to
    # begin each chunk and one to choose the first step
    assert 12 * attempts + chunks <= effort.solves <= 15 * attempts + chunks + 1
    assert effort.rejected >= 0 and len(t) == round(SPAN / 1e-3) + 1


def test_rk4_through_the_chunked_driver_is_unchanged(arm):
    """The driver now serves every compiled loop; RK4 must give the loop's bits in one call."""
    model, q0, _ = arm
    qd0 = np.zeros(model.n_dof)
    t, y, outcome = integrators.rk4.rk4(model, q0, qd0, 0.12, 1e-4, save_every=7)
    t1, q1, qd1, w1, status = model.rk4(q0, qd0, 0.12, 1e-4, save_every=7)
    assert outcome.complete and np.array_equal(t, t1)
    assert np.array_equal(y, np.column_stack([q1, qd1, w1]))


def test_rk4_above_the_stable_step_is_refused_and_that_step_is_the_edge(arm):
    model, q0, _ = arm
    stable, value = stability.stable_step(modes.motion_eigenvalues(model, 0.0, q0))
    with pytest.raises(limits.LimitError, match=f"{stable:.3g} s.*{abs(value) / (2 * math.pi):.4g} Hz.*dop853"):
        study.simulate(model, q0, RunSpec(t_end=0.01, dt=1.2 * stable, save_every=1))
    # the frequency is the real edge: RK4 holds the motion just below it and blows it up just above
    qd0 = np.zeros(model.n_dof)
    peaks = []
    for factor in (0.9, 1.25):
        _, y, _ = integrators.rk4.rk4(model, q0, qd0, 0.2, factor * stable)
        peaks.append(np.abs(y[:, :model.n_dof]).max())
    assert peaks[0] < 1.0 and peaks[1] > 10 * peaks[0]
    with limits.lifted():  # an expert may go on
        res = study.simulate(model, q0, RunSpec(t_end=0.002, dt=1.2 * stable, save_every=1))
    assert str(res["status"]) == "complete"


def test_rk4_stability_boundary_is_where_its_polynomial_has_modulus_one():
    """The boundary radius against RK4's own polynomial: |R| = 1 there and below 1 just inside,
    2√2 on the imaginary axis and, on the negative real axis, where R(-x) = 1 (R is positive on the
    real axis): the real root of x³/24 - x²/6 + x/2 - 1."""
    real_root = [x.real for x in np.roots([1 / 24, -1 / 6, 1 / 2, -1]) if abs(x.imag) < 1e-12 and x.real > 0]
    assert stability.boundary_radius(math.pi) == pytest.approx(min(real_root), rel=1e-12)
    assert stability.boundary_radius(math.pi / 2) == pytest.approx(2 * math.sqrt(2), rel=1e-12)
    for theta in np.linspace(math.pi / 2, math.pi, 13):
        r = stability.boundary_radius(theta)
        ray = np.exp(1j * theta)
        assert stability.amplification(r * ray) == pytest.approx(1.0, abs=1e-12)
        inside = stability.amplification(np.linspace(0.0, 0.999 * r, 500)[1:] * ray)
        assert np.all(inside < 1.0) and stability.amplification(1.001 * r * ray) > 1.0


def test_rk4_stable_step_comes_from_the_damped_eigenvalues(env, tmp_path):
    """Strong dampers make an overdamped eigenvalue far from the undamped frequencies: the step that
    keeps it stable is 0.42 of 2√2/ω here. The eigenvalues are the chain's own (its exact A), the
    predicted edge holds the motion just below it and blows it up just above, and a run above it
    is refused."""
    from pathlib import Path

    m1, m2, k1, k2, c1, c2 = 1.0, 0.5, 100.0, 400.0, 20.0, 30.0
    path = tmp_path / "chain.toml"  # the test chain with its second mass named, for a run's outputs
    chain = (Path(__file__).parent / "models" / "spring_chain.toml").read_text()
    path.write_text(chain + '\n[[chain]]\npoint = "tip"\n')
    model = gpmegen.load(model=gpmegen.load_model_file(path), backend="numpy", params={"c1": c1, "c2": c2})
    M = np.array([[m1 + m2, m2], [m2, m2]])
    A = np.block([[np.zeros((2, 2)), np.eye(2)],
                  [-np.linalg.solve(M, np.diag([k1, k2])), -np.linalg.solve(M, np.diag([c1, c2]))]])
    values = modes.motion_eigenvalues(model, 0.0, np.zeros(2))
    assert np.sort_complex(values) == pytest.approx(np.sort_complex(np.linalg.eigvals(A)), rel=1e-7)
    stable, value = stability.stable_step(values)
    assert stable < 0.5 * 2 * math.sqrt(2) / modes.highest_frequency(model, 0.0, np.zeros(2))
    assert value.imag == 0 and stable == pytest.approx(stability.boundary_radius(math.pi) / abs(value))
    q0, qd0 = np.array([0.1, -0.05]), np.zeros(2)
    ends = {}
    for factor in (0.99, 1.01):
        _, y, outcome = integrators.rk4.rk4(model, q0, qd0, 1000 * stable, factor * stable)
        assert outcome.complete
        ends[factor] = np.abs(y[-1, :4]).max()
    assert ends[0.99] < 1e-6 * np.abs(q0).max() and ends[1.01] > 1e3 * np.abs(q0).max()
    with pytest.raises(limits.LimitError, match=f"stable step {stable:.3g} s.*overdamped"):
        study.simulate(model, q0, RunSpec(t_end=0.5, dt=1.01 * stable, save_every=1))
    assert str(study.simulate(model, q0, RunSpec(t_end=0.5, dt=0.99 * stable, save_every=10))["status"]) == "complete"


def _run(argv, capsys, tmp_path):
    code = main(argv + ["--out", str(tmp_path / "run.npz")])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_command_line_refuses_an_unstable_step_in_one_line(capsys, tmp_path, env):
    code, out, err = _run(["simulate", "--nrfe", "2", "--dt", "1e-2", "--t-end", "0.05"], capsys, tmp_path)
    lines = err.strip().splitlines()  # progress (statics, start), then the refusal
    assert code == 2 and not out and lines[-1].startswith("gpmegen simulate: error: --dt 0.01 s is above")
    assert "stable step" in err and "Hz" in err and "--method genalpha" in err and "dop853" in err
    assert "--no-limits" in err
    assert not (tmp_path / "run.npz").exists()


def test_dop853_from_the_command_line_saves_on_the_grid_and_says_what_it_took(capsys, tmp_path, env):
    code, out, err = _run(["simulate", "--nrfe", "1", "--method", "DOP853", "--t-end", "0.1", "--save-dt", "0.004",
                           "--rtol", "1e-7", "--atol", "1e-9", "--backend", "c"], capsys, tmp_path)
    assert code == 0, err
    res = np.load(tmp_path / "run.npz")
    assert np.allclose(res["t"], np.arange(26) * 0.004, rtol=0, atol=1e-15)
    settings = metadata(res)["settings"]
    assert settings["method"] == "dop853" and (settings["rtol"], settings["atol"]) == (1e-7, 1e-9)
    effort = settings["effort"]
    assert effort["steps"] > 0 and effort["solves"] >= 12 * effort["steps"]
    assert f"{effort['steps']} steps ({effort['rejected']} rejected)" in out and "rtol = 1e-07" in out


def test_save_dt_of_rk4_is_a_whole_number_of_steps(capsys, tmp_path, env):
    code, out, err = _run(["simulate", "--nrfe", "1", "--t-end", "0.01", "--dt", "1e-4", "--save-dt", "1e-3",
                           "--backend", "c"], capsys, tmp_path)
    assert code == 0, err
    res = np.load(tmp_path / "run.npz")
    assert len(res["t"]) == 11 and metadata(res)["settings"]["save_every"] == 10
    assert "100 steps (0 rejected), 400 GPME solves" in out
    code, out, err = _run(["simulate", "--nrfe", "1", "--t-end", "0.01", "--dt", "1e-4", "--save-dt", "2.5e-4",
                           "--backend", "c", "--overwrite"], capsys, tmp_path)
    assert code == 2 and "--save-dt" in err and "whole number" in err


def test_dop853_on_the_numpy_backend_is_refused_with_the_fix(capsys, tmp_path, env):
    code, out, err = _run(["simulate", "--nrfe", "1", "--method", "dop853", "--backend", "numpy", "--t-end", "0.01"],
                          capsys, tmp_path)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "error: --method dop853" in err and "--backend c" in err


@pytest.mark.parametrize("text, method", [("DOP853", "dop853"), ("Scipy-Radau", "scipy-radau"), ("RK4", "rk4"),
                                          ("GENALPHA", "genalpha")])
def test_methods_are_named_in_any_case(text, method):
    assert build_parser().parse_args(["simulate", "--method", text]).method == method


# ---- generalized-α and the orders -------------------------------------------------------------

@pytest.fixture(scope="module")
def rigid_arm(env):
    """The rigid reference arm in C, its locked start and q, q̇ at 0.5 s by SciPy's DOP853 at
    rtol 1e-13: ``(model, q0, final)``."""
    model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=1, backend="c"))
    _, y, outcome = integrators.scipy_radau.adaptive(model, q0, np.zeros(3), 0.5, rtol=1e-13, atol=1e-15)
    assert outcome.complete
    return model, q0, y[-1, :6]


def _order(errors):
    return [math.log2(a / b) for a, b in zip(errors, errors[1:])]


def test_rk4_is_fourth_order_and_genalpha_second_by_step_halving(rigid_arm):
    model, q0, final = rigid_arm
    qd0 = np.zeros(3)
    rk4 = [np.abs(integrators.rk4.rk4(model, q0, qd0, 0.5, dt)[1][-1, :6] - final).max() for dt in (4e-3, 2e-3, 1e-3)]
    assert all(3.7 < p < 4.5 for p in _order(rk4)), rk4
    for rho_inf in (1.0, 0.8):
        errors = [np.abs(integrators.genalpha.genalpha(model, q0, qd0, 0.5, dt, dt, rho_inf)[1][-1, :6] - final).max()
                  for dt in (2e-3, 1e-3, 5e-4)]
        assert all(1.9 < p < 2.1 for p in _order(errors)), errors
        assert errors[-1] < 1e-6


def test_genalpha_dense_output_lands_on_its_steps_and_is_as_good_between(rigid_arm):
    model, q0, _ = rigid_arm
    qd0 = np.zeros(3)
    dt = 2.0 ** -10  # binary fractions: the finer save grid holds every step's instant exactly
    ts, ys, _, es = integrators.genalpha.genalpha(model, q0, qd0, 0.25, dt, dt)
    tf, yf, _, ef = integrators.genalpha.genalpha(model, q0, qd0, 0.25, dt, dt / 4)
    assert es == ef  # the saves do not change the steps
    on_steps = np.isin(tf, ts)
    assert on_steps.sum() == len(ts) and np.array_equal(yf[on_steps], ys)
    _, reference, _ = integrators.scipy_radau.adaptive(model, q0, qd0, 0.25, rtol=1e-13, atol=1e-15, t_eval=tf)
    error = np.abs(yf[:, :6] - reference[:, :6]).max(axis=1)
    # cubic Hermite between the steps adds less than the method's own O(h²) error
    assert error[~on_steps].max() < 1.5 * error[on_steps].max()


@pytest.fixture(scope="module")
def pendulum(env):
    from pathlib import Path

    path = Path(__file__).parent / "models" / "pendulum.toml"
    return gpmegen.load(model=gpmegen.load_model_file(path), backend="c")


def _energy(model, y):
    n = model.n_dof
    return np.array([sum(model.energies(row[:n], row[n:2 * n])) for row in y])


def test_genalpha_without_damping_keeps_the_energy_to_second_order(pendulum):
    drifts = []
    for dt in (0.02, 0.01, 0.005):
        _, y, outcome, _ = integrators.genalpha.genalpha(pendulum, np.array([-0.5]), np.zeros(1), 10.0, dt, 0.1,
                                                         rho_inf=1.0)
        energy = _energy(pendulum, y)
        drifts.append(np.abs(energy - energy[0]).max() / abs(energy[0]))
        assert outcome.complete
    assert all(1.9 < p < 2.1 for p in _order(drifts)), drifts


@pytest.mark.parametrize("rho_inf", [0.5, 0.8])
def test_genalpha_damps_an_unresolved_mode_by_rho_inf_a_step(pendulum, rho_inf):
    """An undamped linear oscillator of ω = 100 rad/s stepped at ω h = 1000: its amplitude falls
    by the spectral radius at infinity, ρ∞, each step (a triple root there, so the geometric mean
    over many steps, within a few percent)."""
    oscillator = pendulum.with_params(g=0.0, k=1e4)  # I = 1 kg m²: ω = 100 rad/s
    h = 10.0
    _, y, outcome, _ = integrators.genalpha.genalpha(oscillator, np.array([0.1]), np.zeros(1), 400 * h, h, h, rho_inf)
    energy = _energy(oscillator, y)
    assert outcome.complete
    assert (energy[-1] / energy[200]) ** (1 / 400) == pytest.approx(rho_inf, rel=0.03)


def test_genalpha_from_the_command_line_records_its_newton_work(capsys, tmp_path, env):
    code, out, err = _run(["simulate", "--nrfe", "2", "--method", "GenAlpha", "--t-end", "0.1", "--dt", "1e-3",
                           "--save-every", "10", "--rho-inf", "0.7", "--backend", "c"], capsys, tmp_path)
    assert code == 0, err
    res = np.load(tmp_path / "run.npz")
    settings = metadata(res)["settings"]
    assert settings["rho_inf"] == 0.7 and len(res["t"]) == 11
    effort = settings["effort"]
    assert effort["steps"] == 100 and effort["jacobians"] >= 1 and effort["factorizations"] == effort["jacobians"]
    assert "genalpha, dt = 0.001 s, rho_inf = 0.7" in out and f"{effort['jacobians']} Jacobians" in out
    # the projection onto the constraints: a position check and a velocity correction a step at least
    assert effort["projections"] >= 200 and f"{effort['projections']} constraint evaluations projecting" in out
    # above RK4's stable step of this arm (3.6 ms): genalpha takes it
    code, out, err = _run(["simulate", "--nrfe", "2", "--method", "genalpha", "--t-end", "0.1", "--dt", "1e-2",
                           "--backend", "c", "--overwrite"], capsys, tmp_path)
    assert code == 0, err


def test_options_that_runs_at_several_nrfe_would_ignore_are_refused(capsys, tmp_path):
    code, out, err = _run(["simulate", "--nrfe", "1", "2", "--method", "dop853", "--rtol", "1e-6"], capsys, tmp_path)
    assert code == 2 and not out and len(err.strip().splitlines()) == 1 and "--rtol: not taken" in err


def test_a_chain_the_constraints_hold_entirely_has_no_frequency_to_bound_rk4(env):
    """The planar example at n_rfe = 1: two joints, two position constraints, no free coordinate."""
    from pathlib import Path

    from gpmegen.analysis.run.cases import FileCase

    path = Path(__file__).resolve().parent.parent / "examples" / "planar_two_link.toml"
    begun = FileCase(str(path), 1).started("numpy", "none", {}, lambda message: None)
    assert modes.highest_frequency(begun.model, 0.0, begun.q) == 0.0
    res = study.simulate(begun.model, begun.q, RunSpec(t_end=0.01, dt=1e-3, save_every=5))
    assert str(res["status"]) == "complete"


def test_a_start_whose_second_order_rows_vanish_at_rest_gets_its_stable_step(env):
    """The curvature example's rows vanish at rest (no partition can be chosen there): the frequency
    comes from the null space of D at the start's own velocities, and the documented run starts."""
    from pathlib import Path

    from gpmegen.runtime.gpme import tangent_basis

    path = Path(__file__).resolve().parent.parent / "examples" / "curvature_arm.toml"
    file = gpmegen.read_model_file(path)
    model = gpmegen.load(model=file.model, backend="numpy")
    begun = study.file_start(model, file.initial_values(model.params), "locked", file.initial_velocities(model.params))
    omega = modes.highest_frequency(model, 0.0, begun.q, begun.qd)
    # the same subspace as the partition's basis at that state, so the same frequency
    moving = model.partitioned(0.0, begun.q)  # the file fixes its dependent coordinates
    D = moving.constraint_terms(0.0, begun.q, begun.qd)[2]
    B = tangent_basis(D, moving.dependent, moving.independent)
    K, M = B.T @ model.stiffness_jacobian(begun.q) @ B, B.T @ model.mass_matrix(begun.q) @ B
    import scipy.linalg
    assert omega == pytest.approx(math.sqrt(scipy.linalg.eigh(K, M, eigvals_only=True)[-1]), rel=1e-9)
    res = study.simulate(model, begun.q, RunSpec(t_end=0.002, dt=1e-5, save_every=100), qd0=begun.qd)
    assert str(res["status"]) == "complete"


@pytest.mark.parametrize("backend", ["numpy", pytest.param("c", marks=pytest.mark.requires_cc)])
def test_a_constraint_going_out_of_reach_is_reported_as_such_not_as_the_step(env, tmp_path, capsys, backend):
    """The rigid reaching arm asked to reach 0.9449 m with 0.9 m of arm failed at t ≈ 0.72 s and
    was reported as a divergence of the step ("non-finite state; try a smaller --dt")."""
    arm = Path(__file__).parent / "models" / "reaching_arm.toml"
    out = tmp_path / "reach.npz"
    assert main(["simulate", str(arm), "--nrfe", "1", "--param", "A=0.1", "--t-end", "1.2", "--dt", "1e-3",
                 "--backend", backend, "--out", str(out)]) == 1
    line = capsys.readouterr().err.strip().splitlines()[-1]  # after the lines on the start
    assert line.startswith("gpmegen simulate: error: diverged: ")
    assert "the constraint reach went out of reach" in line and "Jacobian D loses rank" in line
    # the first instant looked at with no configuration meeting it: past the analytic 0.718 s, and
    # within the looks' spacing after it (their grid depends on the rows saved before the failure)
    when = float(line.split("at t = ")[1].split(" s")[0])
    assert 0.718 <= when <= 0.73
    assert "smaller --dt" not in line and "shoulder" not in line
    assert (tmp_path / "reach.partial.npz").exists()
