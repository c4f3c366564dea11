"""The compiled generalized-α's Newton iteration: its extrapolated start and its stop at the error
estimated from the iteration's contraction leave each step's equation solved to the tolerance,
as an independent step-by-step solve to round-off finds."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from scipy.optimize import brentq

import gpmegen
from gpmegen.runtime import integrators


@pytest.fixture(scope="module")
def pendulum(env):
    """A point mass on a rod under gravity (tests/models/pendulum.toml), in C: q̈ nonlinear in q."""
    return gpmegen.load(model=gpmegen.load_model_file(Path(__file__).parent / "models" / "pendulum.toml"),
                        backend="c")


def genalpha_by_root_finding(model, q0, h, steps, rho_inf):
    """θ at each step of generalized-α (Chung–Hulbert with q̈ given, a_0 = q̈_0) for the one-coordinate
    ``model``, each step's q̈_{n+1} found by bracketing the root of q̈(q_{n+1}, q̇_{n+1}) - q̈_{n+1} to
    round-off (no Newton matrix, no predictor)."""
    alpha_m, alpha_f = (2 * rho_inf - 1) / (rho_inf + 1), rho_inf / (rho_inf + 1)
    gamma = 0.5 + alpha_f - alpha_m
    beta = 0.25 * (gamma + 0.5) ** 2

    def acceleration(t, q, qd):
        return float(model.accelerations(t, np.array([q]), np.array([qd]))[0])

    q, qd = float(q0), 0.0
    qdd = a = acceleration(0.0, q, qd)
    angles = [q]
    for k in range(1, steps + 1):
        t = k * h

        def state(x):
            a_new = (alpha_f * qdd - alpha_m * a + (1 - alpha_f) * x) / (1 - alpha_m)
            return (q + h * qd + h * h * ((0.5 - beta) * a + beta * a_new), qd + h * ((1 - gamma) * a + gamma * a_new),
                    a_new)

        x = brentq(lambda x: acceleration(t, *state(x)[:2]) - x, qdd - 50.0, qdd + 50.0, xtol=1e-15, rtol=1e-15)
        q, qd, a = state(x)
        qdd = acceleration(t, q, qd)
        angles.append(q)
    return np.array(angles)


def test_each_step_is_solved_to_the_tolerance_in_two_iterations(pendulum):
    """The swing of a pendulum from 0.5 rad at a step of 10 ms: every saved angle within 1e-10 rad
    of the steps solved to round-off (Newton's tolerance, 1e-8 of q̈ ~ 5 rad/s², moves θ by β h² of
    it: 1e-12), and on this smooth motion each step's iteration ends after two solves (its
    start from q̈ extrapolated is within O(h²) of the answer); a start from the last q̈ took three."""
    h, steps, rho_inf = 0.01, 300, 0.8
    t, y, outcome, effort = integrators.genalpha.genalpha(pendulum, np.array([-0.5]), np.zeros(1), steps * h, h, h,
                                                          rho_inf)
    assert outcome.complete and len(t) == steps + 1
    reference = genalpha_by_root_finding(pendulum, -0.5, h, steps, rho_inf)
    assert np.abs(reference).max() > 0.49   # it swings
    assert np.abs(y[:, 0] - reference).max() < 1e-10
    # the solves: per step its iterations and the rates at its end; per Jacobian 4 n + 1; per call one
    calls = effort.solves - steps * 3 - effort.jacobians * 5
    assert 1 <= calls <= steps // 5 + 1, effort
