"""Consistent starts of model files: ``[initial] q`` moved onto Φ = 0 and ``[initial] qd`` onto the
constraint velocities, with a report of how far each moved."""

from pathlib import Path

import numpy as np
import pytest

from gpmegen.analysis.post import results as results_io
from gpmegen.analysis.run.cases import FileCase
from gpmegen.analysis.run.model_files import read_model_file
from gpmegen.cli import main
from gpmegen.errors import ModelError

TIP_LAW = Path(__file__).parent / "models" / "tip_law.toml"


def _variant(tmp_path, old, new, name="variant.toml"):
    text = TIP_LAW.read_text(encoding="utf-8")
    assert old in text
    path = tmp_path / name
    path.write_text(text.replace(old, new), encoding="utf-8")
    return path


def _start(path, start="none"):
    return FileCase(str(path)).start("numpy", start, {}, lambda message: None)


def _max_violation(model, q0, qd0, steps=200, dt=1e-4):
    """max |Φ| over ``steps`` RK4 steps of ``dt`` from ``(q0, qd0)``."""
    t, q, qd, _, _ = model.rk4(q0, qd0, steps * dt, dt)
    return max(abs(model.constraint_terms(tk, qk, qdk)[0]).max() for tk, qk, qdk in zip(t, q, qd))


def test_a_tip_law_with_speed_at_t0_starts_on_its_constraint_without_a_transient(env):
    begun = _start(TIP_LAW)
    model = begun.model
    phi, phi_rate, _, _ = model.constraint_terms(0.0, begun.q, begun.qd)
    assert abs(phi).max() < 1e-12 and abs(phi_rate).max() < 1e-12
    # the undeformed link's tip moves at L θ̇1: the file's θ̇1 = v0/L is already consistent
    assert begun.moved["qd"][0] < 1e-12 and begun.warning() is None
    assert _max_violation(model, begun.q, begun.qd) < 1e-10
    # the same start from rest leaves the tip behind its law: a Baumgarte transient
    assert _max_violation(model, begun.q, np.zeros(model.n_dof)) > 1e-5


def test_without_initial_velocities_the_dependent_one_is_solved_and_reported(env, tmp_path):
    begun = _start(_variant(tmp_path, 'qd = { theta1 = "v0/L" }', ""))
    model = begun.model
    v0, L = model.params["v0"], model.params["L"]
    np.testing.assert_allclose(begun.qd, np.eye(model.n_dof)[model.index("theta1")] * v0 / L, atol=1e-12)
    assert begun.moved["qd"] == (pytest.approx(v0 / L, abs=1e-12), "theta1")
    assert "max|Δqd| = " in begun.report()
    # the docs say such a law needs no qd: solving the dependent velocity is no warning
    assert begun.warning() is None
    assert _max_violation(model, begun.q, begun.qd) < 1e-10


def test_a_velocity_given_off_the_constraint_is_changed_with_a_warning(env, tmp_path):
    """A θ̇1 given that is not the law's v0/L: changing what the user gave is warned of."""
    begun = _start(_variant(tmp_path, 'qd = { theta1 = "v0/L" }', 'qd = { theta1 = 0.0 }'))
    v0, L = begun.model.params["v0"], begun.model.params["L"]
    assert begun.qd[begun.model.index("theta1")] == pytest.approx(v0 / L, abs=1e-12)
    warning = begun.warning()
    assert warning.count("\n") == 0 and "[initial] qd" in warning and "theta1" in warning


def test_an_independent_velocity_given_moves_the_dependent_one(env, tmp_path):
    """A bending rate of the link given in qd: θ̇1 is solved so that the tip still moves at v0
    (checked against Φ̇ evaluated at the result, and by a finite difference of the tip's y)."""
    begun = _start(_variant(tmp_path, 'qd = { theta1 = "v0/L" }', 'qd = { psi1_1 = 0.3 }'))
    model = begun.model
    assert begun.qd[model.index("psi1_1")] == 0.3
    h = 1e-7
    y = [model.point_positions(begun.q + s * h * begun.qd)[0][1] for s in (-1, 1)]
    assert (y[1] - y[0]) / (2 * h) == pytest.approx(model.params["v0"], rel=1e-7)


def test_a_start_off_the_constraint_is_moved_onto_it_with_a_warning(env, tmp_path):
    begun = _start(_variant(tmp_path, 'qd = { theta1 = "v0/L" }', 'q = { theta1 = 0.1 }\nqd = { theta1 = "v0/L" }'))
    assert abs(begun.q[begun.model.index("theta1")]) < 1e-12
    assert begun.moved["q"] == (pytest.approx(0.1, abs=1e-12), "theta1")
    assert "q of theta1 by 1.000e-01" in begun.warning() and "[initial] q" in begun.warning()


def test_the_locked_statics_start_is_consistent_too(env, tmp_path):
    path = _variant(tmp_path, "[parameters]\n", '[parameters]\ng = 9.81\n', "gravity.toml")
    path.write_text(path.read_text(encoding="utf-8").replace('dependent = ["theta1"]',
                                                             'dependent = ["theta1"]\ngravity = [0, "-g", 0]'))
    begun = _start(path, "locked")
    model = begun.model
    phi, phi_rate, _, _ = model.constraint_terms(0.0, begun.q, begun.qd)
    assert abs(phi).max() < 1e-12 and abs(phi_rate).max() < 1e-12
    psi, theta = begun.q[model.index("psi1_1")], begun.q[model.index("theta1")]
    assert abs(psi) > 1e-4  # the link sags under its weight at its sde (the middle, n_rfe = 2) ...
    # ... and the joint turns up so that the tip stays at y = 0: L/2 sin θ1 + L/2 sin(θ1 + ψ) = 0
    assert np.sin(theta) + np.sin(theta + psi) == pytest.approx(0.0, abs=1e-12)


def test_an_unknown_key_of_initial_names_the_field_and_a_fix(tmp_path):
    path = _variant(tmp_path, 'qd = { theta1', 'qdot = { theta1')
    with pytest.raises(ModelError) as info:
        read_model_file(path)
    assert "initial.qdot" in str(info.value) and "did you mean 'qd'" in str(info.value)


def test_simulate_reports_how_far_the_start_moved_and_records_it(env, tmp_path, capsys):
    out = tmp_path / "run.npz"
    path = _variant(tmp_path, 'qd = { theta1 = "v0/L" }', "")
    assert main(["simulate", str(path), "--t-end", "0.01", "--dt", "1e-4", "--backend", "numpy",
                 "--out", str(out)]) == 0
    err = capsys.readouterr().err
    assert "start moved onto the constraints" in err and "warning" not in err  # no qd given: nothing overridden
    meta = results_io.metadata(results_io.load(out))
    assert meta["start"] == "none"
    assert meta["start_moved"]["qd"]["coordinate"] == "theta1"
    assert meta["start_moved"]["qd"]["max_change"] == pytest.approx(0.4, abs=1e-12)
    assert abs(results_io.load(out)["phi"]).max() < 1e-10


# ---- results are never replaced silently --------------------------------------------------------

def _simulate(*argv):
    return main(["simulate", *argv, "--t-end", "0.002", "--dt", "2e-4", "--backend", "numpy"])


def test_runs_with_other_starts_or_methods_get_their_own_default_files(env, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)
    for start, method in (("none", "rk4"), ("locked", "rk4"), ("none", "scipy-radau")):
        assert _simulate(str(TIP_LAW), "--statics", start, "--method", method) == 0, capsys.readouterr().err
        meta = results_io.metadata(results_io.load(f"results/tip_law_{start}_{method.lower()}.npz"))
        assert meta["start"] == start and meta["settings"]["method"] == method
    assert len(list((tmp_path / "results").glob("*.npz"))) == 3


def test_an_earlier_runs_results_are_replaced_only_with_overwrite(env, tmp_path, capsys):
    out = tmp_path / "run.npz"
    assert _simulate(str(TIP_LAW), "--out", str(out)) == 0
    capsys.readouterr()
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    assert _simulate(str(TIP_LAW), "--out", str(out), "--statics", "locked") == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "earlier run" in err and "--overwrite" in err and "gpmegen: " not in err
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before
    assert _simulate(str(TIP_LAW), "--out", str(out), "--statics", "locked", "--overwrite") == 0
    assert results_io.metadata(results_io.load(out))["start"] == "locked"


def test_a_first_order_law_sets_the_velocity_and_leaves_the_position_alone(env, tmp_path):
    """The tip's velocity prescribed (order 1, Ψ = vy_tip - v0): no position condition, so
    [initial] q stays (Ψ at rest is -v0, no position would meet it), and θ̇1 is solved from Ψ = 0:
    the undeformed link turned by θ1 moves its tip along y at L cos θ1 θ̇1 = v0."""
    path = _variant(tmp_path, 'expression = "y_tip - v0*t"', 'expression = "vy_tip - v0"\norder = 1')
    path.write_text(path.read_text(encoding="utf-8").replace('beta = "beta_tip"\n', "")
                    .replace('qd = { theta1 = "v0/L" }', "q = { theta1 = 0.3 }"), encoding="utf-8")
    begun = _start(path)
    model = begun.model
    assert begun.moved["q"][0] == 0.0 and begun.q[model.index("theta1")] == 0.3
    assert begun.qd[model.index("theta1")] == pytest.approx(0.2 / (0.5 * np.cos(0.3)), rel=1e-12)
    assert abs(model.constraint_terms(0.0, begun.q, begun.qd)[0]).max() < 1e-12
