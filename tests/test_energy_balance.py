"""The energy balance of a damped run: the dampers' work is a term of the balance (in the results,
the figure and the sweep summary), so the residual is the integrator's error, not the losses."""

from pathlib import Path

import numpy as np
import pytest
from scipy.linalg import expm

import gpmegen
from gpmegen.analysis.figures import plots
from gpmegen.analysis.post import energy
from gpmegen.analysis.run import study
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.analysis.sweep.outcomes import outcomes

M1, M2, K1, K2, C1, C2 = 1.0, 0.5, 100.0, 400.0, 5.0, 3.0
START = np.array([0.1, -0.05])  # m: the chain released from rest


@pytest.fixture(scope="module")
def chain(tmp_path_factory):
    """The spring chain of the tests with strong dampers and its second mass named."""
    folder = tmp_path_factory.mktemp("chain")
    path = folder / "chain.toml"
    text = (Path(__file__).parent / "models" / "spring_chain.toml").read_text()
    path.write_text(text + '\n[[chain]]\npoint = "tip"\n')
    return gpmegen.load(model=gpmegen.load_model_file(path), backend="numpy", params={"c1": C1, "c2": C2},
                        directory=folder / "built")


def _exact_energy(t):
    """Kinetic plus spring energy (J) of the exact motion at ``t`` (s), by the matrix exponential."""
    M = np.array([[M1 + M2, M2], [M2, M2]])
    K, C = np.diag([K1, K2]), np.diag([C1, C2])
    A = np.block([[np.zeros((2, 2)), np.eye(2)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    x = expm(A * t) @ np.concatenate([START, [0.0, 0.0]])
    return 0.5 * x[2:] @ M @ x[2:] + 0.5 * x[:2] @ K @ x[:2]


def test_the_dampers_work_is_a_term_of_the_balance_and_the_residual_is_the_integrators(chain):
    assert energy.damping_matrix(chain, 0.0, START) == pytest.approx(np.diag([C1, C2]), abs=1e-9)
    residuals = []
    for dt in (2e-3, 1e-3):
        run = study.simulate(chain, START, RunSpec(t_end=1.0, dt=dt, save_every=1))
        lost = _exact_energy(1.0) - _exact_energy(0.0)  # the exact motion's change of energy: the dampers' work
        assert run["work_dampers"][-1] == pytest.approx(lost, rel=1e-6)
        assert lost < -0.9  # most of the start's 1 J is dissipated
        residual = energy.balance_residual(run)
        residuals.append(np.abs(residual).max())
        np.testing.assert_array_equal(plots.balance_error(run), residual)  # the figure's panel
        assert outcomes(run)["energy_balance_error"] == residuals[-1]  # the sweep's column
    # the residual is RK4's error: far below the losses, and falling as dt⁴ when the step halves
    assert residuals[-1] < 1e-6 * abs(lost)
    assert residuals[-1] < residuals[0] / 10


def test_scipy_radau_saves_the_multipliers_and_the_work(rigid):
    """scipy-radau integrated (q, q̇) alone and saved NaN for the work, which also made every
    sample's λ NaN: both are now saved, λ as RK4's at the same instants and the balance closed."""
    from gpmegen.analysis.run import reference_case

    model, q0 = reference_case.initial_state(rigid)
    radau = study.simulate(model, q0, RunSpec(t_end=0.1, dt=1e-3, method="scipy-radau", save_dt=1e-2, rtol=1e-10,
                                              atol=1e-12, save_every=1))
    rk4 = study.simulate(model, q0, RunSpec(t_end=0.1, dt=1e-4, save_every=100))
    assert str(radau["status"]) == "complete"
    for key in ("lambda", "work_drive", "work_constraints", "work_dampers"):
        assert np.all(np.isfinite(radau[key])), key
    np.testing.assert_allclose(radau["lambda"], rk4["lambda"], rtol=1e-6, atol=1e-6 * np.abs(rk4["lambda"]).max())
    np.testing.assert_allclose(radau["work_constraints"], rk4["work_constraints"], rtol=0,
                               atol=1e-6 * np.abs(rk4["work_constraints"]).max())
    assert np.abs(energy.balance_residual(radau)).max() < 1e-6 * np.abs(radau["work_constraints"]).max()
