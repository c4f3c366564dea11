"""Run estimates of the integrators beside RK4 (gpmegen.limits): a generalized-α run that cannot
finish and a DOP853 run whose steps, bounded by its stable step, cannot, are refused before they
run, in one line with the numbers and the methods that can take them; runs that fit are not; the
stability radius behind DOP853's bound is its tableau's, and its bound is below the steps it takes."""

from __future__ import annotations

import numpy as np
import pytest

import gpmegen
from gpmegen import limits
from gpmegen.analysis.post import modes
from gpmegen.analysis.run import reference_case, study
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.cli import main
from gpmegen.runtime import integrators

pytestmark = pytest.mark.requires_cc


def _stability_function(A, b):
    """R(z) = 1 + z bᵀ (I - z A)⁻¹ 1 of the explicit Runge-Kutta method (A, b)."""
    identity, ones = np.eye(len(b)), np.ones(len(b))
    return lambda z: 1 + z * b @ np.linalg.solve(identity - z * A, ones)


def test_the_dop853_stability_radius_is_that_of_its_tableau():
    """The largest |z| of the region |R(z)| <= 1 about the origin over the rays of the left
    half-plane, from SciPy's copy of the Dormand-Prince 8(5,3) tableau (not the generated one)."""
    coefficients = pytest.importorskip("scipy.integrate._ivp.dop853_coefficients")
    s = coefficients.N_STAGES
    R = _stability_function(coefficients.A[:s, :s], coefficients.B)
    radii = np.linspace(0.0, 10.0, 2001)

    def reach(direction):
        stable = np.array([abs(R(r * direction)) <= 1 + 1e-12 for r in radii])
        return radii[np.argmin(stable) - 1]

    largest = max(reach(np.exp(1j * angle)) for angle in np.linspace(np.pi / 2, np.pi, 91))
    assert limits.DOP853_STABILITY_RADIUS == pytest.approx(largest, abs=0.02)
    assert reach(1j) == pytest.approx(5.96, abs=0.01)  # the imaginary axis, for an undamped mode


def test_a_generalized_alpha_run_that_cannot_finish_is_refused_before_it_starts(capsys, tmp_path, env, monkeypatch):
    monkeypatch.setattr(type(integrators.get("genalpha")), "run", lambda *a, **k: pytest.fail("the run started"))
    code = main(["simulate", "--nrfe", "1", "--method", "genalpha", "--dt", "1e-9", "--t-end", "100", "--save-dt", "1",
                 "--out", str(tmp_path / "run.npz")])
    out, err = capsys.readouterr()
    assert code == 2 and not out and len(err.strip().splitlines()) == 1
    # 1e11 steps, each its solves and projection: most of a day
    assert "1e+11 generalized-α steps of n_dof = 3" in err and "beyond the limit of 3600 s" in err
    assert "--dt" in err and "--no-limits" in err
    assert not list(tmp_path.iterdir())


def test_a_generalized_alpha_run_that_fits_is_not_refused(capsys, tmp_path, env):
    code = main(["simulate", "--nrfe", "1", "--method", "genalpha", "--dt", "1e-3", "--t-end", "0.05",
                 "--out", str(tmp_path / "run.npz")])
    assert code == 0, capsys.readouterr().err


@pytest.fixture(scope="module")
def arm(env):
    """The reference arm at n_rfe = 5 in C, its locked start and highest natural frequency (rad/s)."""
    model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=5, backend="c"))
    return model, q0, modes.highest_frequency(model, 0.0, q0)


def test_a_dop853_run_its_stable_step_cannot_finish_is_refused_naming_the_methods_that_can(arm, monkeypatch):
    model, q0, omega = arm
    monkeypatch.setattr(type(integrators.get("dop853")), "run", lambda *a, **k: pytest.fail("the run started"))
    with pytest.raises(limits.LimitError) as refused:
        study.simulate(model, q0, RunSpec(t_end=1e6, method="dop853", save_dt=1e3,
                                          save_every=1))  # 1e6 s: 1.5e9 steps at least
    message = str(refused.value)
    assert "\n" not in message and "at least 1.51e+09 DOP853 steps of n_dof = 15" in message
    assert "stable step 0.00066 s" in message and "1628 Hz" in message and "--method genalpha" in message
    assert abs(omega / (2 * np.pi) - 1628) < 1  # the frequency the message names (README "Integrators")


def test_the_dop853_bound_is_below_the_steps_it_takes_and_near_them_at_a_loose_tolerance(arm):
    """At rtol 1e-3 the accuracy asks for little: the sdes' 1.6 kHz modes bound the steps, near
    the stable step at the start."""
    model, q0, omega = arm
    span = 0.2
    bound = limits.integration_estimate(model.n_dof, span, 1e-3, "dop853", "c", omega)
    assert bound.at_least
    for rtol in (1e-3, 1e-8):
        _, _, outcome, effort = integrators.dop853.dop853(model, q0, np.zeros(model.n_dof), span, 1e-3, rtol=rtol,
                                                          atol=rtol)
        assert outcome.complete and effort.steps >= bound.steps
        if rtol == 1e-3:
            assert effort.steps <= 2 * bound.steps
    # a run that fits is not refused
    limits.check_run(model.n_dof, 2, RunSpec(t_end=10.0, dt=1e-3, save_every=1, method="dop853", save_dt=1e-3), "c",
                     omega=omega)


@pytest.mark.parametrize("method", ["radau", "scipy-radau"])
def test_an_implicit_run_over_an_absurd_span_is_refused_before_it_starts(capsys, tmp_path, env, monkeypatch, method):
    """radau and scipy-radau had no estimate: over 1e9 s they started (and ran for hours)."""
    monkeypatch.setattr(type(integrators.get(method)), "run", lambda *a, **k: pytest.fail("the run started"))
    out = tmp_path / "run.npz"
    code = main(["simulate", "--nrfe", "5", "--backend", "c", "--method", method, "--t-end", "1e9", "--save-dt", "1e8",
                 "--out", str(out)])
    _, err = capsys.readouterr()
    refusal = [line for line in err.splitlines() if "error" in line]
    assert code == 2 and len(refusal) == 1 and "integrating" not in err, err
    # 9.6 periods a second of the lowest mode over 1e9 s, four solves each at least
    assert "at least 9.62e+09" in refusal[0] and "9.622 Hz" in refusal[0] and "beyond the limit of 3600 s" in err
    assert "--t-end" in refusal[0] and "--no-limits" in refusal[0]
    assert not list(tmp_path.iterdir())


def test_the_lowest_period_bound_is_below_the_steps_radau_takes(arm):
    """A step of the compiled Radau stays well within a period of the lowest mode, at a loose
    tolerance as at the default one; a run that fits is not refused."""
    model, q0, _ = arm
    lowest, span = modes.lowest_frequency(model, 0.0, q0), 0.5
    bound = limits.integration_estimate(model.n_dof, span, 1e-3, "radau", "c", lowest)
    assert bound.at_least and bound.steps == np.ceil(span * lowest / (2 * np.pi))
    for rtol in (1e-4, integrators.base.RTOL):
        _, _, outcome, effort = integrators.radau.radau(model, q0, np.zeros(model.n_dof), span, 1e-2, rtol=rtol,
                                                        atol=rtol)
        assert outcome.complete and effort.steps >= 2 * bound.steps
    limits.check_run(model.n_dof, 2, RunSpec(t_end=100.0, dt=1e-3, save_every=1, method="radau", save_dt=1e-3), "c",
                     omega=lowest)
    with limits.lifted():  # --no-limits
        limits.check_run(model.n_dof, 2, RunSpec(t_end=1e9, dt=1e-3, save_every=1, method="radau", save_dt=1e8), "c",
                         omega=lowest)
