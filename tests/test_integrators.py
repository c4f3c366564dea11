"""The integrators beside RK4: DOP853 in the compiled loop (against SciPy's at tight tolerance, its
dense output on the save grid, what it took), the step guidance that refuses an unstable RK4 step,
and the command line's --method, --save-dt, --rtol and --atol."""

import math

import numpy as np
import pytest

import gpmegen
from gpmegen import limits
from gpmegen.analysis import modes, reference_case, study
from gpmegen.analysis.results import metadata
from gpmegen.cli import build_parser, main
from gpmegen.runtime import integrate

pytestmark = pytest.mark.requires_cc

SPAN = 0.2  # s: the motion starts and the flexible modes ring


@pytest.fixture(scope="module")
def arm(env):
    """The reference case at n_rfe = 2 in C, its locked start and a tight SciPy DOP853 reference
    on the same right-hand side: ``(model, q0, reference)``, ``reference(t)`` the states (k, 2n)."""
    model, q0 = reference_case.initial_state(gpmegen.load(nrfe=2, backend="c"))
    qd0 = np.zeros(model.n_dof)

    def reference(t):
        _, y, outcome = integrate.adaptive(model, q0, qd0, float(t[-1]), rtol=1e-13, atol=1e-15, t_eval=t)
        assert outcome.complete
        return y[:, :2 * model.n_dof]

    return model, q0, reference


def _dop853(model, q0, save_dt, rtol, atol=None, t_end=SPAN):
    return integrate.dop853(model, q0, np.zeros(model.n_dof), t_end, save_dt, rtol=rtol,
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
    coarse = round(integrate.CHUNK_SECONDS / fine) * fine
    assert round(integrate.CHUNK_SECONDS / coarse) == 1
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
    chunks = math.ceil(SPAN / integrate.CHUNK_SECONDS - 1e-9)
    attempts = effort.steps + effort.rejected
    # 12 solves a step tried, 3 more for the dense output of a step holding a save instant, one to
    # begin each chunk and one to choose the first step
    assert 12 * attempts + chunks <= effort.solves <= 15 * attempts + chunks + 1
    assert effort.rejected >= 0 and len(t) == round(SPAN / 1e-3) + 1


def test_rk4_through_the_chunked_driver_is_unchanged(arm):
    """The driver now serves every compiled loop; RK4 must give the loop's bits in one call."""
    model, q0, _ = arm
    qd0 = np.zeros(model.n_dof)
    t, y, outcome = integrate.rk4(model, q0, qd0, 0.12, 1e-4, save_every=7)
    t1, q1, qd1, w1, status = model.rk4(q0, qd0, 0.12, 1e-4, save_every=7)
    assert outcome.complete and np.array_equal(t, t1)
    assert np.array_equal(y, np.column_stack([q1, qd1, w1]))


def test_rk4_above_the_stable_step_is_refused_and_that_step_is_the_edge(arm):
    model, q0, _ = arm
    omega = modes.highest_frequency(model, 0.0, q0)
    stable = integrate.RK4_STABILITY / omega
    with pytest.raises(limits.LimitError, match=f"{stable:.3g} s.*{omega / (2 * math.pi):.4g} Hz.*dop853"):
        study.simulate(model, q0, 0.01, dt=1.2 * stable)
    # the frequency is the real edge: RK4 holds the motion just below it and blows it up just above
    qd0 = np.zeros(model.n_dof)
    peaks = []
    for factor in (0.9, 1.25):
        _, y, _ = integrate.rk4(model, q0, qd0, 0.2, factor * stable)
        peaks.append(np.abs(y[:, :model.n_dof]).max())
    assert peaks[0] < 1.0 and peaks[1] > 10 * peaks[0]
    with limits.lifted():  # an expert may go on
        res = study.simulate(model, q0, 0.002, dt=1.2 * stable)
    assert str(res["status"]) == "complete"


def _run(argv, capsys, tmp_path):
    code = main(argv + ["--out", str(tmp_path / "run.npz")])
    out, err = capsys.readouterr()
    return code, out, err


def test_the_command_line_refuses_an_unstable_step_in_one_line(capsys, tmp_path, env):
    code, out, err = _run(["simulate", "--nrfe", "2", "--dt", "1e-2", "--t-end", "0.05"], capsys, tmp_path)
    lines = err.strip().splitlines()  # progress (statics, start), then the refusal
    assert code == 2 and not out and lines[-1].startswith("gpmegen simulate: error: --dt 0.01 s is above")
    assert "stable step" in err and "Hz" in err and "--method dop853" in err and "--no-limits" in err
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


@pytest.mark.parametrize("text, method", [("DOP853", "dop853"), ("Scipy-Radau", "scipy-radau"), ("RK4", "rk4")])
def test_methods_are_named_in_any_case(text, method):
    assert build_parser().parse_args(["simulate", "--method", text]).method == method
