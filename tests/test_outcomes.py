"""Typed outcomes and one RK4 driver: both backends offer the same ``rk4`` (C loop, Python loop)
with the same status codes, and :func:`gpmegen.runtime.integrators.rk4.rk4` runs either in chunks,
looking at the run at the same instants on both."""

from __future__ import annotations

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run import reference_case
from gpmegen.runtime import integrators, partition
from gpmegen.status import MESSAGES, Ending, Outcome, SolveStatus

pytestmark = pytest.mark.requires_cc


@pytest.fixture(scope="module")
def both(generated_elsewhere):
    """The rigid arm on its constraints, ``(C model, NumPy model, q0)``."""
    numpy_model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=1, backend="numpy"))
    c_model = gpmegen.load("manipulator", nrfe=1, backend="c").with_params(**numpy_model.params)
    return c_model, numpy_model, q0


def test_both_backends_offer_one_rk4_contract(both):
    c, n, q0 = both
    qd0, w0 = np.zeros(3), np.array([0.5, -0.25])
    runs = {}
    for model in (c, n):
        whole = model.rk4(q0, qd0, 0.35, 1e-3, save_every=5, t0=0.3, w0=w0)
        first = model.rk4(q0, qd0, 0.35, 1e-3, 5, 0.3, w0, steps=(0, 20))
        rest = model.rk4(first[1][-1], first[2][-1], 0.35, 1e-3, 5, 0.3, first[3][-1], steps=(20, 50))
        assert whole[4] is SolveStatus.OK and first[4] is rest[4] is SolveStatus.OK
        for part, joined in zip(whole[:4], zip(first[:4], rest[:4])):  # a run in two calls is the same run
            np.testing.assert_array_equal(part, np.concatenate([joined[0], joined[1][1:]]))
        runs[model.backend] = whole
    (t, q, qd, w), (tn, qn, qdn, wn) = runs["c"][:4], runs["numpy"][:4]
    np.testing.assert_array_equal(t, tn)
    assert len(t) == 11 and t[-1] == 0.35 and np.array_equal(w[0], w0)
    for a, b in ((q, qn), (qd, qdn), (w, wn)):
        np.testing.assert_allclose(a, b, rtol=1e-10, atol=1e-12)


def test_both_backends_return_the_same_status_codes(both):
    c, n, q0 = both
    for model in (c, n):
        t, q, _, _, status = model.rk4(np.full(3, np.nan), np.zeros(3), 1e-3, 1e-5)
        assert status is SolveStatus.NONFINITE and len(t) == 0
    # θ1 moves neither constraint: with it dependent, the NumPy solve's D_dc is singular (the C
    # solve does not go through D_dc, and steps on)
    singular = n.with_partition([n.index("theta1"), n.index("x3")])
    t, q, _, _, status = singular.rk4(q0, np.zeros(3), 1e-4, 1e-5)
    assert status is SolveStatus.SINGULAR and len(t) == 1 and np.array_equal(q[0], q0)


def test_the_driver_looks_at_both_backends_at_the_same_instants(both):
    c, n, q0 = both
    # Baumgarte poles at -2790 /s, just beyond RK4's stability at dt = 1e-3 s (-2785 /s): Φ grows
    # above 1e-3 within the first chunk, and the state is still finite at its end
    gains = dict(alpha_height=2.79e3, beta_height=2.79e3)
    runs = [integrators.rk4.rk4(model.with_params(**gains), q0, np.zeros(3), 0.5, 1e-3, max_violation=1e-3)
            for model in (c, n)]
    (t, _, outcome), (tn, _, outcome_n) = runs
    assert outcome.ending is outcome_n.ending is Ending.DIVERGED
    assert outcome.t == outcome_n.t == t[-1] == tn[-1] < 0.5 and len(t) == len(tn)
    assert round(t[-1] / integrators.loop.CHUNK_SECONDS, 9).is_integer()  # at the end of a chunk
    assert str(outcome).startswith("diverged: constraint violation") and str(outcome) == str(outcome_n)


class Counted:
    """``model`` counting the calls of its ``rk4``, interrupted (Ctrl-C) at the ``interrupt``-th."""

    def __init__(self, model, interrupt=None):
        self.model, self.interrupt, self.calls = model, interrupt, 0

    def __getattr__(self, name):
        return getattr(self.model, name)

    def rk4(self, *args, **kwargs):
        self.calls += 1
        if self.calls == self.interrupt:
            raise KeyboardInterrupt
        return self.model.rk4(*args, **kwargs)


@pytest.mark.parametrize("backend", ["c", "numpy"])
def test_an_interrupted_run_keeps_the_chunks_computed(both, backend):
    model, q0 = both[0] if backend == "c" else both[1], both[2]
    # one call per chunk (a call's steps are otherwise sized by wall time)
    t, y, outcome = integrators.rk4.rk4(Counted(model, interrupt=3), q0, np.zeros(3), 1.0, 1e-3, save_every=10,
                                        steps_per_call=10**9)
    assert outcome.ending is Ending.INTERRUPTED and str(outcome) == "interrupted"
    assert outcome.t == t[-1] == pytest.approx(2 * integrators.loop.CHUNK_SECONDS) and len(t) == len(y) == 11
    assert np.all(np.isfinite(y))


def test_the_run_goes_on_with_the_model_the_partition_watch_chose(both):
    _, n, q0 = both
    start = Counted(n)
    # any condition number is too large: after the first chunk the watch chooses anew (the same
    # coordinates) and the run goes on with the model it returns, a copy of the one it started with
    watch = partition.Watch(start, repartition=True, limit=0.0)
    t, _, outcome = integrators.rk4.rk4(start, q0, np.zeros(3), 0.2, 1e-3, save_every=10, watch=watch,
                                        steps_per_call=10**9)  # one call per chunk
    assert outcome.complete and t[-1] == 0.2
    assert start.calls == 1 and watch.model is not start and watch.model.dependent.tolist() == n.dependent.tolist()


def test_a_failed_step_says_when_and_the_fix():
    outcome = Outcome.failed(0.004, SolveStatus.NONFINITE)
    assert not outcome.complete and outcome.t == 0.004
    assert str(outcome) == f"diverged: after t = 0.004 s, {MESSAGES[SolveStatus.NONFINITE]}"
    assert "smaller --dt" in str(outcome)
    assert Outcome(Ending.COMPLETE, 1.0).complete and str(Outcome(Ending.COMPLETE, 1.0)) == "complete"
