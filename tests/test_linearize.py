"""gpmegen linearize: the state-space model about the statics and along a run, against the
nonlinear model, the natural modes, finite differences of the drive, and its files."""

from pathlib import Path

import numpy as np
import pytest
import scipy.io
import scipy.linalg

import gpmegen
from gpmegen.analysis.post import modes
from gpmegen.analysis.run import linear
from gpmegen.cli import main
from gpmegen.runtime.gpme import tangent_basis
from gpmegen.status import SolveStatus

# The reference arm at rest on its programmed constraints: the prescribed motion's amplitude A
# off, so that the constrained statics is an equilibrium (the drive is zero at t = 0).
REST = {"A": 0.0}


@pytest.fixture(scope="module")
def rest():
    """(linear model about the constrained statics of the reference arm at n_rfe = 3, the model
    with its Jacobians as that start binds it)."""
    return (gpmegen.linearize(nrfe=3, start="constrained", params=REST, backend="numpy"),
            gpmegen.load("manipulator", nrfe=3, params=REST, jacobians=True, backend="numpy"))


def nonlinear_deviation(model, lin, x0, eps, t_end, dt):
    """States (δq_ind, δq̇_ind) of the nonlinear run from the equilibrium + ε x0 (on the
    constraints to first order) minus those of the run from the equilibrium itself, at the saved
    times; and those times."""
    ind, dep = model.independent, model.dependent
    D = model.constraint_terms(0.0, lin.q, lin.qd)[2]
    N = tangent_basis(D, dep, ind)
    k = len(ind)

    def run(scale):
        q0 = lin.q + scale * N @ x0[:k]
        qd0 = lin.qd + scale * N @ x0[k:]
        t, q, qd, _, status = model.rk4(q0, qd0, t_end, dt, save_every=20)
        assert status == SolveStatus.OK
        return t, np.hstack([q[:, ind], qd[:, ind]])

    t, base = run(0.0)
    return t, run(eps)[1] - base


@pytest.mark.long   # a series of nonlinear runs; the state matrix against differences is in make test
def test_small_perturbations_follow_the_linear_model_to_second_order(rest, rng):
    lin, model = rest
    model = model.partitioned(0.0, lin.q)
    assert np.max(np.abs(lin.qdd)) < 1e-6  # an equilibrium
    x0 = rng.standard_normal(len(lin.states))
    errors, sizes = [], []
    for eps in (1e-4, 2e-4):
        t, deviation = nonlinear_deviation(model, lin, x0, eps, t_end=0.02, dt=1e-5)
        predicted = np.array([scipy.linalg.expm(lin.A * tk) @ x0 * eps for tk in t])
        errors.append(np.max(np.abs(deviation - predicted)))
        sizes.append(np.max(np.abs(predicted)))
    ratio = errors[1] / errors[0]
    assert 3.0 < ratio < 5.0, (errors, ratio)  # the error is second order in the perturbation
    assert errors[0] < 1e-2 * sizes[0]  # measured: 2e-3 of the response at ε = 1e-4


def test_eigenvalues_are_the_constrained_modes(rest):
    lin, model = rest
    # nothing held: the column's rotation theta1 is a state, neutral (zero frequency)
    expected = modes.constrained_modes(model, lin.q, hold=[]).frequencies
    shown = lin.eigenvalues[lin.eigenvalues.imag >= 0]
    f, _ = linear.frequencies(shown)
    assert len(f) == len(expected)
    np.testing.assert_allclose(np.sort(f)[1:], np.sort(np.abs(expected))[1:], rtol=1e-7)
    assert np.all(np.abs(lin.eigenvalues.real) < 1e-8 * np.max(np.abs(lin.eigenvalues)))  # undamped


def test_damping_makes_every_elastic_mode_decay():
    lin = gpmegen.linearize(nrfe=3, start="constrained", params={**REST, "d2": 0.01}, backend="numpy")
    moving = lin.eigenvalues[np.abs(lin.eigenvalues) > 1.0]
    assert len(moving) == len(lin.eigenvalues) - 2  # all but the neutral column rotation
    _, zeta = linear.frequencies(moving)
    assert np.all(zeta > 0) and not np.any(linear.unstable(lin.eigenvalues))


def test_input_matrix_is_the_derivative_of_the_accelerations_in_the_drive(rest):
    start, model = rest
    q, qd, t = start.q, start.qd, 6.0  # after t0 the drive's torque is tdr0 times a constant
    lin = linear.linearize(model, t, q, qd, ("theta1",))
    h = 1e-3
    up, down = (model.with_params(tdr0=model.params["tdr0"] + s) for s in (h, -h))
    dq = (up.accelerations(t, q, qd) - down.accelerations(t, q, qd)) / (2 * h)
    dQ = (up.drive_forces(t, q, qd) - down.drive_forces(t, q, qd)) / (2 * h)
    assert np.count_nonzero(dQ) == 1 and dQ[model.index("theta1")] != 0
    ind = model.partitioned(t, q).independent
    k = len(ind)
    np.testing.assert_allclose(lin.B[k:, 0], dq[ind] / dQ[model.index("theta1")], rtol=1e-6, atol=1e-9)
    np.testing.assert_array_equal(lin.B[:k], 0)


def test_mat_and_npz_files_hold_the_model_with_its_names(tmp_path, capsys):
    args = ["linearize", "--nrfe", "3", "--statics", "constrained", "--param", "A=0", "--backend", "numpy"]
    assert main(args + ["--out", str(tmp_path / "lin.mat")]) == 0
    out = capsys.readouterr().out
    assert "frequency (Hz)" in out and "damping ratio" in out
    assert main(args + ["--out", str(tmp_path / "lin.npz")]) == 0
    mat = scipy.io.loadmat(tmp_path / "lin.mat")
    with np.load(tmp_path / "lin.npz") as npz:
        np.testing.assert_array_equal(mat["A"], npz["A"])
        states = list(npz["state_names"])
        assert [str(c[0][0]) for c in mat["state_names"]] == states
        assert [str(c[0][0]) for c in mat["input_names"]] == list(npz["input_names"]) == ["theta1"]
    assert states[0] == "theta1" and states[len(states) // 2] == "theta1_dot"


@pytest.fixture(scope="module")
def short_run(tmp_path_factory):
    path = tmp_path_factory.mktemp("run") / "run.npz"
    assert main(["simulate", "--nrfe", "3", "--t-end", "0.01", "--dt", "1e-4", "--save-every", "10",
                 "--backend", "numpy", "--out", str(path)]) == 0
    return path


def test_at_a_run_takes_the_nearest_saved_state(short_run):
    models = gpmegen.linearize(nrfe=3, at=short_run, times=[0.0041, 0.01], backend="numpy")
    run = gpmegen.Results(dict(np.load(short_run)))
    assert [m.t for m in models] == pytest.approx([0.004, 0.01])
    np.testing.assert_array_equal(models[1].q, np.asarray(run["q"])[-1])


def test_several_times_write_one_file_each(short_run, tmp_path, capsys):
    out = tmp_path / "lin.mat"
    assert main(["linearize", "--nrfe", "3", "--backend", "numpy", "--at", str(short_run), "--times", "0,0.01",
                 "--out", str(out)]) == 0
    assert "nearest to 0.01 s" in capsys.readouterr().out
    times = [float(scipy.io.loadmat(tmp_path / f"lin_{k}.mat")["t"][0, 0]) for k in (1, 2)]
    assert times == pytest.approx([0.0, 0.01]) and not out.exists()


def test_unknown_inputs_are_named(rest):
    start, model = rest
    with pytest.raises(gpmegen.ModelError, match="'psi9': not coordinates"):
        linear.linearize(model, 0.0, start.q, start.qd, ("theta1", "psi9"))


@pytest.mark.parametrize("args, says", [
    (["--nrfe", "3", "--times", "0.5"], "outside the run"),
    (["--nrfe", "2", "--times", "0"], "not of 'manipulator_nrfe2'"),
])
def test_bad_runs_get_one_line(short_run, tmp_path, capsys, args, says):
    assert main(["linearize", *args, "--at", str(short_run), "--out", str(tmp_path / "x.npz")]) == 2
    err = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(err) == 1 and says in err[0] and err[0].startswith("gpmegen linearize: error: ")
    assert not (tmp_path / "x.npz").exists()


def test_a_folder_built_without_jacobians_gets_one_line(tmp_path, capsys):
    example = Path(__file__).resolve().parents[1] / "examples" / "planar_two_link.toml"
    assert main(["build", str(example), "--nrfe", "2", "--out", str(tmp_path)]) == 0
    capsys.readouterr()
    out = tmp_path / "lin.npz"
    assert main(["linearize", str(tmp_path / "planar_two_link_nrfe2"), "--backend", "numpy", "--out", str(out)]) == 1
    err = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(err) == 1 and "gpmegen build --jacobians" in err[0] and not out.exists()


def test_a_model_without_its_jacobians_is_refused_with_the_build_command():
    plain = gpmegen.load("manipulator", nrfe=1, backend="numpy")
    with pytest.raises(gpmegen.BuildError, match="--jacobians"):
        linear.linearize(plain, 0.0, np.zeros(3), np.zeros(3))


def test_the_table_marks_growth_and_names_neutral_motion():
    omega = 2 * np.pi * 10.0
    values = np.array([0.0, 1e-15, 3.0, -3.0, -0.1 * omega + 1j * omega * np.sqrt(0.99),
                       -0.1 * omega - 1j * omega * np.sqrt(0.99)])
    lines = linear.format_eigenvalues(values).splitlines()[1:]
    assert len(lines) == 5  # one line per pair
    growing = [line for line in lines if "UNSTABLE" in line]
    assert len(growing) == 1 and growing[0].split()[-3] == "3"  # the eigenvalue 3/s
    assert sum("neutral" in line for line in lines) == 2
    f, zeta = linear.frequencies(values[4:5])
    assert f[0] == pytest.approx(10.0) and zeta[0] == pytest.approx(0.1)


def on_constraints(model, t, q, qd_ind):
    """``(q, q̇)`` with the dependent coordinates solved from ``Φ(t, q) = 0`` (Newton) and their
    rates from ``Φ̇ = 0``, the independent ones as given."""
    dep, ind = model.dependent, model.independent
    q, qd = q.copy(), np.zeros(model.n_dof)
    for _ in range(30):
        phi, _, D, _ = model.constraint_terms(t, q, qd)
        q[dep] -= np.linalg.solve(D[:, dep], phi)
    qd[ind] = qd_ind
    _, rate, D, _ = model.constraint_terms(t, q, qd)
    qd[dep] = -np.linalg.solve(D[:, dep], rate)
    return q, qd


def test_state_matrix_is_the_derivative_of_the_reduced_motion_in_motion(rest, rng):
    """Away from rest and with the programmed motion on (Φ depends on t), A against central
    differences of x = (q_ind, q̇_ind) ↦ q̈_ind, the dependent coordinates and rates solved from
    the constraints exactly: provokes the rates' dependence on q_ind through Φ̇ (V)."""
    start, model = rest
    model = model.with_params(A=0.5).partitioned(1.0, start.q)
    ind, t = model.independent, 1.0
    k = len(ind)
    q, qd = on_constraints(model, t, start.q, 2.0 * rng.standard_normal(k))
    lin = linear.linearize(model, t, q, qd)

    def reduced(x):
        qq = q.copy()
        qq[ind] = x[:k]
        return model.accelerations(t, *on_constraints(model, t, qq, x[k:]))[ind]

    x = np.concatenate([q[ind], qd[ind]])
    numeric = np.empty((k, 2 * k))
    # Steps per block. In q_ind the motion is nonlinear: a small step (truncation ~h², 5e-12 of
    # the block here). In q̇_ind it is quadratic (velocity products, the dependent rates linear in
    # q̇_ind), so central differences are exact at any step and only rounding is left: q̈ carries
    # ~2e-11 of it (ε times the elastic forces it balances), which a step of 1e-6 would make 2e-6
    # of this block's scale (7.7/s); a step of 0.1 leaves 1e-11.
    relative = np.r_[np.full(k, 1e-6), np.full(k, 1e-1)]
    for j in range(2 * k):
        h = relative[j] * max(1.0, abs(x[j]))
        e = np.zeros(2 * k)
        e[j] = h
        numeric[:, j] = (reduced(x + e) - reduced(x - e)) / (2 * h)
    for block in (slice(0, k), slice(k, 2 * k)):  # in q_ind (1/s²) and in q̇_ind (1/s)
        scale = np.max(np.abs(numeric[:, block]))
        np.testing.assert_allclose(lin.A[k:, block] / scale, numeric[:, block] / scale, atol=1e-6)
    np.testing.assert_array_equal(lin.A[:k], np.hstack([np.zeros((k, k)), np.eye(k)]))


def test_baumgarte_gains_leave_the_linear_model_unchanged_on_the_constraints(rest, rng):
    """The gains act on δΦ and δΦ̇, which the states' perturbations keep zero to first order; what
    is left is their terms' value times the change of the GPME's matrix, zero where Φ = Φ̇ = 0."""
    start, model = rest
    model = model.with_params(A=0.5).partitioned(1.0, start.q)
    q, qd = on_constraints(model, 1.0, start.q, rng.standard_normal(len(model.independent)))
    stiff = model.with_params(alpha_circle=1e3, beta_circle=5e2, alpha_height=1e3, beta_height=5e2)

    def change(q):
        A, A_stiff = linear.linearize(model, 1.0, q, qd).A, linear.linearize(stiff, 1.0, q, qd).A
        return np.max(np.abs(A_stiff - A)) / np.max(np.abs(A))

    assert change(q) < 1e-9
    assert change(q + 1e-5) > 1e-6  # off the constraints the gains' terms act (the test can tell)


def test_velocity_constraints_are_refused_by_name():
    with pytest.raises(gpmegen.ModelError, match="'heading', 'push' of first or second order"):
        linear.refuse_velocity_constraints(("circle", "heading", "push"), np.array([0, 1, 2]))
    linear.refuse_velocity_constraints(("circle",), np.array([0]))


def test_a_first_order_constraint_is_refused_before_any_build(tmp_path, monkeypatch, capsys):
    """linearize built the model with its Jacobians (47 s at the size met) and only then refused
    the first-order constraint that makes it impossible: refused first now, nothing built."""
    generated = tmp_path / "generated"
    monkeypatch.setenv("GPMEGEN_GENERATED", str(generated))
    example = Path(__file__).resolve().parents[1] / "examples" / "nonholonomic.toml"
    out = tmp_path / "lin.npz"
    assert main(["linearize", str(example), "--backend", "numpy", "--out", str(out)]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "of first or second order" in err
    assert not out.exists() and not (generated.exists() and any(generated.iterdir()))


def test_a_rebuild_for_missing_jacobians_says_so(tmp_path):
    """A folder built without the Jacobians, loaded with them, is built again: the message named
    "other inputs or another gpmegen version"; it names the missing Jacobians."""
    example = Path(__file__).resolve().parents[1] / "examples" / "planar_two_link.toml"
    model = gpmegen.load_model_file(example, nrfe=1)
    said = []
    gpmegen.load(model=model, backend="numpy", directory=tmp_path)
    gpmegen.load(model=model, backend="numpy", directory=tmp_path, jacobians=True, progress=said.append)
    reasons = [line for line in said if "building it again" in line]
    assert len(reasons) == 1 and "built without the acceleration Jacobians" in reasons[0], said
