"""The C GPME solve against a 50-digit solve of the same double-precision terms, at states of
the flexible arm (n_rfe = 5) where the model's partition (ψ2, x3) is ill-conditioned.

With elastic angles near 1 rad the block D_dc of ψ2 and x3 comes near singular: the basis
B = [I; -D_dc⁻¹ D_ic] of the partition gets entries of hundreds and cond(BᵀMB) passes 1e10,
although the motion is no worse conditioned than M (cond(ZᵀMZ) ~ 1e6 for an orthonormal basis
Z of the allowed motions). A solve through that BᵀMB lost 1e-6 of q̈'s relative accuracy at
cond(BᵀMB) ~ 1e11, 1e-3 at 1e14.
"""

from __future__ import annotations

import os
import sys

import numpy as np
import pytest

import gpmegen
from gpmegen.errors import SimulationError
from gpmegen.runtime import integrators

_HERE = os.path.dirname(os.path.abspath(__file__))
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)

from precise_solve import EPS, ill_conditioned_states, solve_errors  # noqa: E402  (tests/precise_solve.py)


@pytest.fixture(scope="module")
def arm(shared_cache):
    """The flexible arm's C backend (compiled once per run, in the shared cache)."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("GPMEGEN_CACHE", str(shared_cache))
        mp.delenv("CC", raising=False)
        yield gpmegen.load("manipulator", nrfe=5, backend="c")


@pytest.fixture(scope="module")
def states(arm):
    return ill_conditioned_states(arm, count=6, seed=4, samples=2000)


def test_states_are_ill_conditioned_for_the_partition(states):
    assert all(cond >= 1e10 for cond, *_ in states)


def test_c_accelerations_are_as_accurate_as_a_backward_stable_solve(arm, states):
    """A backward-stable solve errs in q̈ by a modest multiple of eps·κ, κ = cond₂(ZᵀMZ) the
    condition number of the GPME in the allowed motions (any basis gives the same q̈); 4 eps·κ
    leaves a margin of 10 over what the C solve reaches. The NumPy stacked solve of the same terms,
    the reference backend, is no more accurate."""
    for _, t, q, qd in states:
        error_c, error_numpy, kappa = solve_errors(arm, t, q, qd)
        assert kappa < 1e7  # the motion itself is well conditioned
        assert error_c <= 4 * EPS * kappa, (error_c, EPS * kappa)
        assert error_c <= 4 * error_numpy, (error_c, error_numpy)


def test_c_accelerations_do_not_depend_on_the_partition(arm, states):
    """θ1 moves neither constraint, so D_dc of (θ1, x3) is singular while D is regular: the
    NumPy solve, which builds B from the partition, fails there; the C solve chooses its own
    basis and gives the same q̈, bit for bit, as with the model's partition."""
    regular = arm.with_params()
    singular = arm.with_partition([arm.index("theta1"), arm.index("x3")])
    numpy_singular = gpmegen.load("manipulator", nrfe=5, backend="numpy").with_partition(singular.dependent)
    for _, t, q, qd in states:
        assert np.array_equal(singular.accelerations(t, q, qd), regular.accelerations(t, q, qd))
        with pytest.raises(SimulationError, match="singular"):
            numpy_singular.accelerations(t, q, qd)
    _, t, q, qd = states[0]
    runs = [model.rk4(q, qd, t + 20 * 1e-6, 1e-6, save_every=10, t0=t) for model in (singular, regular)]
    assert runs[0][-1] == 0
    for a, b in zip(*runs):
        assert np.array_equal(a, b)


def test_a_singular_solve_names_the_constraints_not_the_partition(arm):
    """Arm vertical: E on the column's axis, the circle constraint's row of D vanishes. The
    constraints are not independent, which no choice of dependent coordinates mends, and the
    messages of a single solve and of a run say so."""
    q = np.zeros(arm.n_dof)
    q[arm.index("psi2")] = np.pi / 2
    with pytest.raises(SimulationError, match="constraints are not independent") as failure:
        arm.accelerations(0.0, q, np.zeros(arm.n_dof))
    assert "dependent coordinates" not in str(failure.value)
    t, _, outcome = integrators.rk4.rk4(arm, q, np.zeros(arm.n_dof), 1e-4, 1e-5, 1)
    assert len(t) == 1 and "constraints are not independent" in outcome.why and "repartition" not in outcome.why
