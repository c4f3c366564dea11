"""GPME, statics and the paper's study: constraint terms against finite differences, the
Baumgarte rows, power balance, integrator agreement, results files and bad input."""

import numpy as np
import pytest

from gpmegen.analysis.post import results as results_io
from gpmegen.analysis.run import reference_case, study
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.cli import main
from gpmegen.errors import SimulationError, StaticsError
from gpmegen.runtime import integrators, statics


def _random_state(model, rng):
    q = reference_case.joint_start(model) + rng.uniform(-0.2, 0.2, model.n_dof) * 0.5
    return q, rng.uniform(-1, 1, model.n_dof)


@pytest.mark.parametrize("which", ["rigid", "flexible"])
def test_constraint_rate_and_acceleration_match_finite_differences(which, request, rng):
    model = request.getfixturevalue(which)
    q, qd = _random_state(model, rng)
    qdd = rng.normal(size=model.n_dof)
    t, h = 0.7, 1e-4

    def phi_at(s):
        return model.constraint_terms(t + s, q + qd * s + 0.5 * qdd * s * s, qd + qdd * s)[0]

    phi, phi_rate, D, gamma = model.constraint_terms(t, q, qd)
    fd_rate = (phi_at(h) - phi_at(-h)) / (2 * h)
    fd_acc = (phi_at(h) - 2 * phi_at(0) + phi_at(-h)) / h**2
    np.testing.assert_allclose(phi_rate, fd_rate, rtol=1e-7, atol=1e-8)
    np.testing.assert_allclose(D @ qd + model.constraint_terms(t, q, 0 * qd)[1], phi_rate, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(D @ qdd + gamma, fd_acc, rtol=1e-4, atol=1e-4)


@pytest.mark.parametrize("which", ["rigid", "flexible"])
def test_gpme_rows_hold(which, request, rng):
    """q̈ satisfies Bᵀ(M q̈ - f) = 0 and the Baumgarte rows, and M q̈ - f lies in range(Dᵀ)."""
    model = request.getfixturevalue(which)
    q, qd = _random_state(model, rng)
    t = 3.3
    qdd = model.accelerations(t, q, qd)
    M, f = model.mass_matrix(q), model.forces(t, q, qd)
    phi, phi_rate, D, gamma = model.constraint_terms(t, q, qd)
    np.testing.assert_allclose(D @ qdd + gamma + 2 * model.alpha * phi_rate + model.beta**2 * phi, 0, atol=1e-8)
    reaction = M @ qdd - f
    lam, *_ = np.linalg.lstsq(D.T, reaction, rcond=None)
    np.testing.assert_allclose(D.T @ lam, reaction, atol=1e-9 * max(1.0, np.abs(f).max()))


def test_locked_statics_is_an_equilibrium_of_the_flexible_coordinates(flexible):
    q = statics.locked(flexible, reference_case.joint_start(flexible))
    free = statics.spring_coordinates(flexible, q)
    assert len(free) == flexible.n_dof - 3
    assert np.abs(flexible.static_residual(q)[free]).max() < 1e-8
    # the arm sags: bending about z is negative along the arm, no out-of-plane or torsion
    psi = q[[flexible.index(f"psi2_{r}") for r in range(1, 5)]]
    assert np.all(psi < 0)
    assert np.abs(q[[flexible.index(f"theta2_{r}") for r in range(1, 5)]]).max() < 1e-12


def test_statics_error_names_the_step(flexible):
    soft = flexible.with_params(E2=1e5)  # large rotations: one Newton step per load step is not enough
    with pytest.raises(StaticsError) as exc:
        statics.locked(soft, reference_case.joint_start(soft), max_iter=1)
    assert "gravity 0.0 m/s²" not in str(exc.value)
    assert "at gravity" in str(exc.value) and "residual" in str(exc.value)


def test_constrained_statics_is_an_equilibrium_on_the_constraints(flexible):
    model, q = reference_case.initial_state(flexible, "constrained")
    phi, _, D, _ = model.constraint_terms(0.0, q, 0 * q)
    assert np.abs(phi).max() < 1e-10
    B = __import__("gpmegen.runtime.gpme", fromlist=["x"]).tangent_basis(D, model.dependent, model.independent)
    generalized = B.T @ model.static_residual(q)
    assert np.abs(generalized).max() < 1e-7
    # at rest there, with the drive off and the height held still, nothing accelerates
    assert np.abs(_still(model).accelerations(0.0, q, 0 * q)).max() < 1e-5


def _still(model):
    """Drive off, prescribed height constant at its t = 0 value."""
    p = model.params
    return model.with_params(tdr0=0.0, A=0.0, y_c=p["y_c"] + p["A"])


def test_locked_start_is_not_an_equilibrium_once_freed(flexible):
    model, q = reference_case.initial_state(flexible, "locked")
    assert np.abs(_still(model).accelerations(0.0, q, 0 * q)).max() > 1.0


@pytest.mark.parametrize("which", ["rigid", pytest.param("flexible", marks=pytest.mark.long)])
def test_short_study_holds_constraints_and_balances_power(which, request):
    model, q0 = reference_case.initial_state(request.getfixturevalue(which))
    # the flexible arm's stiff modes need a smaller RK4 step for the balance to close to 1e-6
    dt = 1e-4 if which == "flexible" else 1e-3
    res = study.simulate(model, q0, RunSpec(t_end=0.3, dt=dt, save_every=10))
    assert str(res["status"]) == "complete"
    assert np.abs(res["phi"]).max() < 1e-6
    E = res["end_effector"]
    np.testing.assert_allclose(np.hypot(E[:, 0], E[:, 2]), model.params["r_Ea"], atol=1e-6)
    p = model.params
    np.testing.assert_allclose(E[:, 1], p["y_c"] + p["A"] * np.cos(2 * np.pi * res["t"] / p["T"]), atol=1e-6)
    total = res["kinetic_energy"] + res["gravity_energy"] + res["spring_energy"]
    work = res["work_drive"] + res["work_constraints"]
    scale = np.abs(total).max()
    assert np.abs(total - total[0] - work).max() < 1e-6 * scale
    assert np.abs(res["work_constraints"]).max() > 1e-3 * scale  # the constraints do real work here


def test_rk4_agrees_with_adaptive(rigid):
    model, q0 = reference_case.initial_state(rigid)
    qd0 = np.zeros(3)
    t, y, status = integrators.rk4.rk4(model, q0, qd0, 1.0, 1e-3)
    ta, ya, status_a = integrators.scipy_radau.adaptive(model, q0, qd0, 1.0, rtol=1e-11, atol=1e-12)
    assert status.complete and status_a.complete
    assert np.abs(y[-1, :3] - ya[-1, :3]).max() < 1e-7


def test_divergence_keeps_results(rigid):
    model, q0 = reference_case.initial_state(rigid)
    # gains of 2790 /s put the Baumgarte poles at -2790 /s, just beyond RK4's stability at dt = 1e-3 s
    # (-2785 /s), so Φ grows slowly enough to pass 1e-3 before the state overflows
    res = study.simulate(model.with_params(alpha_height=2.79e3, beta_height=2.79e3), q0,
                         RunSpec(t_end=0.5, dt=1e-3, max_violation=1e-3, save_every=1))
    assert str(res["status"]).startswith("diverged: constraint violation")
    assert 0 < res["t"][-1] < 0.5


def test_constraints_beyond_reach_are_refused(rigid):
    with pytest.raises(SimulationError, match="cannot be met"):
        reference_case.initial_state(rigid, overrides={"r_Ea": 1e6})


def test_results_round_trip_and_foreign_files(rigid, tmp_path):
    model, q0 = reference_case.initial_state(rigid)
    res = study.simulate(model, q0, RunSpec(t_end=0.05, dt=1e-3, save_every=5))
    paths = results_io.save(res, tmp_path / "run.npz")
    back = results_io.load(paths[0])
    np.testing.assert_array_equal(back["q"], res["q"])
    assert paths[1].read_text().splitlines()[1].startswith("t,theta1,psi2,x3,")
    foreign = tmp_path / "foreign.npz"
    np.savez(foreign, t=np.zeros(3))
    with pytest.raises(results_io.ResultsError, match="not a gpmegen results file"):
        results_io.load(foreign)
    junk = tmp_path / "junk.npz"
    junk.write_text("hello")
    with pytest.raises(results_io.ResultsError, match="not a gpmegen results file"):
        results_io.load(junk)


@pytest.mark.parametrize("args, message", [
    (["--dt", "0"], "positive"),
    (["--dt=-1e-5"], "positive"),
    (["--t-end", "-1"], "below zero"),
    (["--t-end", "nan"], "not finite"),
    (["--nrfe", "0"], "below 1"),
    (["--param", "tdr0"], "NAME=VALUE"),
])
def test_simulate_bad_input(tmp_path, capsys, args, message):
    out = tmp_path / "r.npz"
    try:
        code = main(["simulate", *args, "--backend", "numpy", "--out", str(out)])
    except SystemExit as exc:
        code = exc.code
    assert code == 2
    assert message in capsys.readouterr().err
    assert not out.exists()


def test_plot_refuses_foreign_file(tmp_path, capsys):
    foreign = tmp_path / "x.npz"
    np.savez(foreign, a=np.zeros(2))
    assert main(["plot", str(foreign), "--out", str(tmp_path / "figs")]) == 2  # the user's input, as in metrics
    assert "not a gpmegen results file" in capsys.readouterr().err


# make check-c: the reference arm simulated and every figure drawn (an example end to end: test_examples.py)
@pytest.mark.long
def test_simulate_and_plot_end_to_end(tmp_path, capsys):
    out = tmp_path / "run_nrfe1.npz"
    assert main(["simulate", "--nrfe", "1", "--t-end", "0.2", "--dt", "1e-3", "--save-every", "10",
                 "--backend", "numpy", "--out", str(out)]) == 0
    assert out.exists() and out.with_suffix(".csv").exists()
    assert main(["plot", str(out), "--out", str(tmp_path / "figs")]) == 0
    names = sorted(p.name for p in (tmp_path / "figs").iterdir())
    assert names == ["constraint_multipliers.png", "constraint_violation.png", "driving_functions.png",
                     "end_effector.png", "energy_balance.png", "joint_coordinates.png", "path.png"]


def test_a_loaded_model_is_immutable(rigid):
    """Its copies share its arrays: none can be written to, and the with_ methods leave it as it was."""
    before = (rigid.p.copy(), rigid.dependent.copy())
    for name in ("p", "alpha", "beta", "constraint_orders", "dependent", "independent"):
        with pytest.raises(ValueError, match="read-only"):
            getattr(rigid, name)[0] = 1.0
    rigid.with_params(m1=2 * rigid.params["m1"]).with_partition([rigid.index("theta1"), rigid.index("x3")])
    assert np.array_equal(rigid.p, before[0]) and np.array_equal(rigid.dependent, before[1])


def test_partition_watch_warns_and_repartitions(rigid):
    """θ1 moves neither constraint (rotation about the circle's axis), so a partition that makes
    it dependent has a singular D_dc: the watch says so, or picks a regular partition."""
    from gpmegen.runtime import partition

    model, q = reference_case.initial_state(rigid)
    model = model.with_partition([model.index("theta1"), model.index("x3")])
    messages = []
    partition.Watch(model, repartition=False, notify=messages.append).check(0.0, q)
    assert len(messages) == 1 and "condition number" in messages[0] and "--repartition" in messages[0]
    watch = partition.Watch(model, repartition=True, notify=messages.append)
    assert watch.check(0.0, q) is watch.model
    assert [model.coordinates[k] for k in model.dependent] == ["theta1", "x3"]  # the model is left as it was
    model = watch.model
    assert [model.coordinates[k] for k in model.dependent] == ["psi2", "x3"]
    assert watch.events and watch.events[0][1] == ("theta1", "x3") and watch.events[0][2] == ("psi2", "x3")
    _, _, D, _ = model.constraint_terms(0.0, q, 0 * q)
    assert partition.condition(D, model.dependent) < 1e3


@pytest.mark.parametrize("entry", [2.5, -1e-9, 1e-300, 0.0])
def test_the_condition_of_one_constraint_is_numpys(entry):
    """One constraint's dependent block is a 1 x 1 matrix: 1 unless singular, as its SVD says (the
    watch takes it without one)."""
    from gpmegen.runtime import partition

    D = np.array([[3.0, entry, 1.0]])
    with np.errstate(all="ignore"):
        expected = np.linalg.cond(D[:, [1]])
    assert partition.condition(D, [1]) == (expected if np.isfinite(expected) else np.inf)
