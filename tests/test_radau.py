"""Radau IIA of order 5 in the compiled loop: against the exact solution of a linear chain (its
tolerance, its order at forced steps, its dense output), against DOP853 on the reference arm (the
motion and the work integrals), on a stiff arm (far fewer steps than DOP853), its counts, and the
arguments and backends it refuses."""

import math
from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

import gpmegen
from gpmegen.analysis.post.results import metadata
from gpmegen.analysis.run import reference_case
from gpmegen.cli import build_parser, main
from gpmegen.runtime import integrators
from gpmegen.status import SolveStatus

pytestmark = pytest.mark.requires_cc

# the linear chain of tests/models/spring_chain.toml: x1 the first mass's, x2 the second's
# displacement relative to the first, so the second moves by x1 + x2
M1, M2, K1, K2, C1, C2 = 1.0, 0.5, 100.0, 400.0, 0.5, 0.2
START = np.array([0.1, -0.05, 0.0, 0.3])  # q (m), q̇ (m/s)


@pytest.fixture(scope="module")
def chain(env):
    """The spring chain in C and its exact motion: ``(model, exact)``, ``exact(t)`` the states
    (k, 4) of ``ẋ = A x`` from :data:`START` by the matrix exponential, with the mass matrix of
    the chain's kinematics [[m1 + m2, m2], [m2, m2]] (the kinetic energy of the masses at x1 and
    x1 + x2) and diagonal springs and dampers."""
    path = Path(__file__).parent / "models" / "spring_chain.toml"
    model = gpmegen.load(model=gpmegen.load_model_file(path), backend="c")
    M = np.array([[M1 + M2, M2], [M2, M2]])
    A = np.block([[np.zeros((2, 2)), np.eye(2)],
                  [-np.linalg.solve(M, np.diag([K1, K2])), -np.linalg.solve(M, np.diag([C1, C2]))]])

    def exact(t):
        return np.array([expm(A * tk) @ START for tk in t])

    return model, exact


def _radau(model, q0, qd0, t_end, save_dt, rtol, atol=None):
    return integrators.radau.radau(model, q0, qd0, t_end, save_dt, rtol=rtol, atol=rtol if atol is None else atol)


def test_radau_meets_the_exact_motion_to_a_few_times_its_tolerance(chain):
    model, exact = chain
    errors = []
    for rtol in (1e-4, 1e-7, 1e-10):
        t, y, outcome, effort = _radau(model, START[:2], START[2:], 1.0, 2.0 ** -10, rtol)
        assert outcome.complete and len(t) == 1025
        # every saved row: at 1e-4 and 1e-7 most of them by the dense output between the steps
        assert rtol < 1e-7 or effort.steps < len(t) / 3
        errors.append(np.abs(y[:, :4] - exact(t)).max())
        assert errors[-1] <= 10 * rtol
    # the error follows the tolerance over six decades (not a fixed floor below them)
    assert errors[2] < 1e-5 * errors[0]


def _forced_steps(model, H, n):
    """n steps of H (s) of the compiled radau from START, one a call (the save instant is the
    step's end; the tolerances so loose that the error test passes and Newton stops after one
    iteration, which is exact on a linear system with the exact Jacobian): the last state and counts."""
    y, counts = np.concatenate([START, [0.0, 0.0]]), np.zeros(5, dtype=np.int64)
    for k in range(n):
        rows, status = model.radau(k * H, y, np.array([(k + 1) * H]), 1e10, 1e10, np.array([2 * H]), counts)
        assert status == SolveStatus.OK and len(rows) == 1
        y = rows[0]
    return y, counts


def test_radau_is_fifth_order_at_forced_steps(chain):
    model, exact = chain
    final = exact([1.0])[0]
    errors = [np.abs(_forced_steps(model, 1.0 / n, n)[0][:4] - final).max() for n in (40, 80, 160)]
    orders = [math.log2(a / b) for a, b in zip(errors, errors[1:])]
    assert all(4.7 < p < 5.3 for p in orders), (errors, orders)


def test_radau_counts_what_a_step_costs(chain):
    model, _ = chain
    _, counts = _forced_steps(model, 0.01, 3)
    # a call: the rate at its start, one Jacobian (central differences: 4 n + 1 solves), its real
    # and complex LU, one Newton iteration (3 stage rates), the rate at the step's end
    assert counts.tolist() == [3, 0, 3 * (1 + 4 * 2 + 1 + 3 + 1), 3, 6]


def test_radau_on_the_reference_arm_agrees_with_a_tight_dop853(arm):
    model, q0, t, reference = arm
    n = model.n_dof
    for rtol in (1e-6, 1e-9):
        tr, y, outcome, effort = _radau(model, q0, np.zeros(n), 0.2, 2e-3, rtol, rtol * 1e-2)
        assert outcome.complete and np.array_equal(tr, t)
        assert np.abs(y[:, :2 * n] - reference[:, :2 * n]).max() < 10 * rtol
        # the works of the drive and the constraint forces, integrated with the motion but not
        # in its error test, agree as well (they are J, of the order of 1)
        work = reference[:, 2 * n:]
        assert np.abs(y[:, 2 * n:] - work).max() < 10 * rtol * max(1.0, np.abs(work).max())
        assert np.abs(y[-1, :n] - q0).max() > 1e4 * rtol  # it moved
        assert 1 <= effort.steps and 0 <= effort.rejected <= effort.steps
        assert 1 <= effort.jacobians <= effort.factorizations / 2


@pytest.fixture(scope="module")
def arm(env):
    """The reference arm at n_rfe = 2 in C, its locked start, the save instants of 0.2 s every
    2 ms and the states there by the compiled DOP853 at rtol = atol = 1e-12."""
    model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=2, backend="c"))
    t, y, outcome, _ = integrators.dop853.dop853(model, q0, np.zeros(model.n_dof), 0.2, 2e-3, rtol=1e-12, atol=1e-12)
    assert outcome.complete
    return model, q0, t, y


def test_dense_output_is_the_steps_own_state_where_one_lands(arm):
    model, q0, _, _ = arm
    qd0 = np.zeros(model.n_dof)
    fine = 2.0 ** -10  # binary fractions: both grids hold the chunks' ends exactly
    coarse = round(integrators.loop.CHUNK_SECONDS / fine) * fine
    tc, yc, _, ec = _radau(model, q0, qd0, 0.2, coarse, 1e-8)
    tf, yf, _, ef = _radau(model, q0, qd0, 0.2, fine, 1e-8)
    assert ec == ef  # the saves do not change the steps
    on_coarse = np.isin(tf, tc)
    assert on_coarse.sum() == len(tc) and np.array_equal(yf[on_coarse], yc)


def test_radau_takes_far_fewer_steps_than_dop853_on_a_stiff_arm(env):
    """The links 1e4 times stiffer and strongly damped: their modes decay far faster than the
    motion, which DOP853 must still follow with steps inside its stability region."""
    base = gpmegen.load("manipulator", nrfe=2, backend="c")
    stiff = base.with_params(E2=1e4 * base.params["E2"], G2=1e4 * base.params["G2"], d2=100.0)
    model, q0 = reference_case.initial_state(stiff)
    qd0 = np.zeros(model.n_dof)
    _, y_d, outcome_d, dop = integrators.dop853.dop853(model, q0, qd0, 0.2, 2e-3, rtol=1e-9, atol=1e-11)
    _, y_r, outcome_r, radau = _radau(model, q0, qd0, 0.2, 2e-3, 1e-6, 1e-8)
    assert outcome_d.complete and outcome_r.complete
    assert radau.steps + radau.rejected < 0.1 * (dop.steps + dop.rejected), (radau, dop)
    assert np.abs(y_r[:, :2 * model.n_dof] - y_d[:, :2 * model.n_dof]).max() < 10 * 1e-6


def test_bad_arguments_are_refused(arm):
    model, q0, _, _ = arm
    y = np.concatenate([q0, np.zeros(model.n_dof), [0.0, 0.0]])
    counts = np.zeros(5, dtype=np.int64)
    for t_save, rtol in (([1e-3, 2e-3], 0.0), ([2e-3, 1e-3], 1e-6), ([0.0], 1e-6), ([np.nan], 1e-6)):
        rows, status = model.radau(0.0, y, np.array(t_save), rtol, 1e-8, np.zeros(1), counts)
        assert status == SolveStatus.BAD_ARGUMENTS and len(rows) == 0
    rows, status = model.radau(0.0, np.full_like(y, np.nan), np.array([1e-3]), 1e-6, 1e-8, np.zeros(1), counts)
    assert status == SolveStatus.NONFINITE and not counts.any()
    with pytest.raises(ValueError, match="rtol > 0"):
        integrators.radau.radau(model, q0, np.zeros(model.n_dof), 0.01, 1e-3, rtol=-1.0)


def _run(argv, capsys, tmp_path):
    code = main(argv + ["--out", str(tmp_path / "run.npz")])
    out, err = capsys.readouterr()
    return code, out, err


def test_radau_from_the_command_line_saves_on_the_grid_and_says_what_it_took(capsys, tmp_path, env):
    code, out, err = _run(["simulate", "--nrfe", "1", "--method", "RADAU", "--t-end", "0.1", "--save-dt", "0.004",
                           "--rtol", "1e-7", "--atol", "1e-9", "--backend", "c"], capsys, tmp_path)
    assert code == 0, err
    res = np.load(tmp_path / "run.npz")
    assert np.allclose(res["t"], np.arange(26) * 0.004, rtol=0, atol=1e-15)
    settings = metadata(res)["settings"]
    assert settings["method"] == "radau" and (settings["rtol"], settings["atol"]) == (1e-7, 1e-9)
    effort = settings["effort"]
    assert effort["steps"] > 0 and effort["jacobians"] >= 1 and effort["factorizations"] >= 2 * effort["jacobians"]
    assert f"{effort['steps']} steps ({effort['rejected']} rejected)" in out and "radau, rtol = 1e-07" in out
    assert f"{effort['jacobians']} Jacobians, {effort['factorizations']} LU factorizations" in out


def test_radau_on_the_numpy_backend_is_refused_with_the_fix(capsys, tmp_path, env):
    code, out, err = _run(["simulate", "--nrfe", "1", "--method", "radau", "--backend", "numpy", "--t-end", "0.01"],
                          capsys, tmp_path)
    assert code == 2 and len(err.strip().splitlines()) == 1 and "error: --method radau" in err and "--backend c" in err
    assert not (tmp_path / "run.npz").exists()


def test_radau_is_named_in_any_case_and_apart_from_scipy_radau():
    parse = build_parser().parse_args
    assert parse(["simulate", "--method", "Radau"]).method == "radau"
    assert parse(["simulate", "--method", "SCIPY-RADAU"]).method == "scipy-radau"
