"""The derived quantities of a run's results made for all samples at once (batched calls, one
stacked pseudo-inverse for the multipliers) are those made sample by sample, to round-off; a
sample the batch cannot take falls back to the sample-by-sample path and its error."""

from __future__ import annotations

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run import reference_case, study
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.errors import SimulationError
from gpmegen.runtime import gpme

BACKENDS = ("numpy", pytest.param("c", marks=pytest.mark.requires_cc))
NAMES = ("end_effector", "drive_forces", "phi", "qdd", "constraint_forces", "lambda", "energies")


@pytest.fixture(scope="module")
def runs(env):
    """A short run of the reference arm (2 rfes) on each backend: (model, t, q, qd), q and qd
    copies of their own for each test to change."""
    made = {}

    def get(backend):
        if backend not in made:
            model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=2, backend=backend))
            res = study.simulate(model, q0, RunSpec(t_end=0.05, dt=1e-3, save_every=5))
            assert str(res["status"]) == "complete"
            made[backend] = model, res["t"], res["q"], res["qd"]
        model, t, q, qd = made[backend]
        return model, t, q.copy(), qd.copy()

    return get


@pytest.mark.parametrize("backend", BACKENDS)
def test_batched_derived_quantities_are_those_of_each_sample(runs, backend):
    model, t, q, qd = runs(backend)
    q[3, 0] = np.nan  # a sample that is not finite: NaN where the model cannot evaluate it, as before
    ok = np.all(np.isfinite(np.hstack([q, qd])), axis=1)
    together = study._derived_together(model, t, q, qd, ok)
    each = study._derived_each(model, t, q, qd, ok, np.zeros((len(t), 0)))
    assert together is not None
    for name, a, b in zip(NAMES, together, each):
        assert a.shape == b.shape, name
        assert np.array_equal(np.isnan(a), np.isnan(b)), name
        scale = max(np.nanmax(np.abs(b)), 1.0)
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12 * scale, err_msg=name)
    assert np.isnan(together[3][3]).all() and np.isfinite(together[3][ok]).all()  # q̈


@pytest.mark.requires_cc
def test_a_sample_without_a_gpme_solution_takes_the_path_that_names_it(runs):
    model, t, q, qd = runs("c")
    q[2, model.index("x3")] = 1e200  # finite, but M, f and D overflow
    ok = np.ones(len(t), dtype=bool)
    assert study._derived_together(model, t, q, qd, ok) is None
    y = np.hstack([q, qd, np.zeros((len(t), 2))])
    with pytest.raises(SimulationError, match="not finite"):
        study.collect(model, t, y, "complete", {"start": "none"})


@pytest.mark.parametrize("redundant", [False, True])
def test_multipliers_of_a_batch_are_those_of_each_state(rng, redundant):
    n, m, states = 6, 3, 5
    A = rng.standard_normal((states, n, n))
    M = A @ np.swapaxes(A, 1, 2) + n * np.eye(n)
    f, qdd = rng.standard_normal((states, n)), rng.standard_normal((states, n))
    D = rng.standard_normal((states, m, n))
    if redundant:  # a row that repeats a combination of the others: λ is the minimum-norm one
        D[:, 2] = D[:, 0] - 2 * D[:, 1]
    batch = gpme.multipliers(M, f, qdd, D, redundant)
    assert batch.shape == (states, m)
    for k in range(states):
        np.testing.assert_allclose(batch[k], gpme.multipliers(M[k], f[k], qdd[k], D[k], redundant), rtol=1e-9,
                                   atol=1e-12)
    assert gpme.multipliers(M, f, qdd, D[:, :0]).shape == (states, 0)
