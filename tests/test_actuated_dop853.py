"""The actuated realization in the compiled DOP853 loop (``<model>_dop853_actuated``): against
SciPy's DOP853 driving the NumPy backend's actuated rates from Python at the same tolerances,
against the compiled actuated RK4 at a fine step, and a run that holds its servo-constraints."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.integrate import solve_ivp
from test_actuated_compiled import MODELS, _two_link

from gpmegen.analysis.run import study
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.runtime.integrators.loop import start_state, state_derivative
from gpmegen.status import SolveStatus

pytestmark = pytest.mark.requires_cc
TOL = 1e-12          # rtol and atol of both DOP853 runs
SPAN = {"arm": 0.02, "two_link": 0.2}   # s: the arm's actuated realization is unstable inside (benchmarks/actuated.py)


@pytest.fixture(scope="module", params=sorted(MODELS))
def pair(request, env):
    """The same actuated model on both backends, a start and its span: ``(c, numpy, q0, t_end)``."""
    (c, q0), (numpy, _) = MODELS[request.param]("c"), MODELS[request.param]("numpy")
    return c, numpy, q0, SPAN[request.param]


def _compiled_dop853(model, y0, t_save, tol=TOL):
    counts, step = np.zeros(5, dtype=np.int64), np.zeros(1)
    rows, status = model.dop853(0.0, y0, t_save, tol, tol, step, counts)
    assert status == SolveStatus.OK and counts[0] > 10   # complete, in steps of its own
    return rows


def _scale(x):
    return max(np.max(np.abs(x)), 1.0)


def test_compiled_dop853_equals_scipy_s_dop853_over_the_python_rates(pair):
    """The compiled loop and SciPy's DOP853 over the NumPy backend's actuated rates, at the same
    tolerances: the same q, q̇ and work of the inputs at the saved times to 1e-10 of their scale."""
    c, numpy, q0, t_end = pair
    y0 = start_state(c, q0, np.zeros(c.n_dof))
    t_save = np.linspace(0.0, t_end, 11)[1:]
    compiled = _compiled_dop853(c, y0, t_save)
    python = solve_ivp(state_derivative(numpy), (0.0, t_end), y0, method="DOP853", t_eval=t_save, rtol=TOL, atol=TOL)
    assert python.success
    reference = python.y.T
    n = c.n_dof
    for part in (slice(0, n), slice(n, 2 * n), slice(2 * n + 1, 2 * n + 2)):
        assert np.max(np.abs(compiled[:, part] - reference[:, part])) <= 1e-10 * _scale(reference[:, part])
    assert np.max(np.abs(reference[:, 2 * n + 1])) > 0.0   # the inputs did work: the comparison saw them


def test_compiled_dop853_equals_compiled_rk4_at_a_fine_step(pair):
    c, _, q0, t_end = pair
    qd0 = np.zeros(c.n_dof)
    t, q, qd, w, status = c.rk4(q0, qd0, t_end, t_end / 4000, save_every=400)
    assert status == SolveStatus.OK and len(t) == 11
    rows = _compiled_dop853(c, start_state(c, q0, qd0), t[1:])
    n = c.n_dof
    for mine, theirs in ((rows[:, :n], q[1:]), (rows[:, n:2 * n], qd[1:]), (rows[:, 2 * n:2 * n + 2], w[1:, :2])):
        assert np.max(np.abs(mine - theirs)) <= 1e-9 * _scale(theirs)


def test_a_dop853_actuated_run_holds_its_constraints_and_saves_its_inputs(env):
    """A simulate run of the two links under DOP853 on the C backend (to 0.25 s: near 0.27 s the
    inputs can no longer hold the motion, and RK4 diverges there too): complete, max |Φ| below
    1e-8, and the inputs u those that hold M q̈ - f = S u at every saved sample."""
    model, _ = _two_link("c")
    begun = study.file_start(model, {"theta1": 0.6, "theta2": -1.0})
    res = study.simulate(model, begun.q, RunSpec(t_end=0.25, method="dop853", save_dt=0.01, rtol=1e-9,
                                                 atol=1e-11), qd0=begun.qd)
    assert str(res["status"]) == "complete" and list(res["actuators"]) == ["theta2"]
    assert np.max(np.abs(res["phi"])) < 1e-8
    assert res["u"].shape == (26, 1) and np.max(np.abs(res["u"])) > 1.0
    assert np.array_equal(res["constraint_forces"][:, 1], res["u"][:, 0])
