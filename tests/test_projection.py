"""Generalized-α with each step's end projected onto the constraints (post-stabilization): the
position constraints held to round-off at steps where the Baumgarte-stabilized GPME alone drifts,
the velocities onto ``D q̇ + Φ_t = 0`` and first-order ``Ψ = 0``, the method still of order 2
against a converged run, and models with nothing to project unchanged bit for bit."""

from __future__ import annotations

import dataclasses
import math
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run import reference_case
from gpmegen.analysis.run.cases import FileCase
from gpmegen.model import reference_model
from gpmegen.runtime import integrators

pytestmark = pytest.mark.requires_cc

ROOT = Path(__file__).resolve().parents[1]
SPAN = 1.0  # s: the reference arm's column spins up and the flexible arm rings
STEPS = (4e-3, 2e-3, 1e-3)  # s: above RK4's stable step at n_rfe 2 (3.6 ms) down to a quarter of it


@pytest.fixture(scope="module")
def arm(env):
    """The reference case at n_rfe = 2 in C, its locked start and q(SPAN) of the compiled DOP853 at
    rtol = atol = 1e-12: ``(model, q0, final)``."""
    model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=2, backend="c"))
    _, y, outcome, _ = integrators.dop853.dop853(model, q0, np.zeros(model.n_dof), SPAN, SPAN, rtol=1e-12, atol=1e-12)
    assert outcome.complete
    return model, q0, y[-1, :model.n_dof]


def _genalpha(model, q0, dt, project, qd0=None, span=SPAN):
    qd0 = np.zeros(model.n_dof) if qd0 is None else qd0
    t, y, outcome, effort = integrators.genalpha.genalpha(model, q0, qd0, span, dt, dt, project=project)
    assert outcome.complete, outcome
    return t, y, effort


def _residuals(model, t, y):
    """max over the saved states of |Φ| (position rows), and of |Φ̇| and |Ψ| (the velocity rows:
    Φ̇ = D q̇ + Φ_t of a position constraint, Ψ of a first-order one), each computed from the
    generated constraint terms at the saved state."""
    n = model.n_dof
    orders = np.array(model.constraint_orders)
    position = velocity = 0.0
    for tk, yk in zip(t, y):
        phi, phi_rate = model.constraint_terms(tk, yk[:n], yk[n:2 * n])[:2]
        position = max(position, np.abs(phi[orders == 0]).max(initial=0.0))
        velocity = max(velocity, np.abs(phi_rate[orders == 0]).max(initial=0.0),
                       np.abs(phi[orders == 1]).max(initial=0.0))
    return position, velocity


def test_projection_holds_the_constraints_where_the_stabilized_gpme_drifts(arm):
    model, q0, _ = arm
    dt = STEPS[0]
    t, y, free = _genalpha(model, q0, dt, project=False)
    tp, yp, projected = _genalpha(model, q0, dt, project=True)
    drift, rate_drift = _residuals(model, t, y)
    held, rate_held = _residuals(model, tp, yp)
    assert drift >= 1e-7 and rate_drift >= 1e-5  # the case the projection is for
    assert held <= 1e-10 and rate_held <= 1e-10
    # one position check and one velocity correction a step at least; the Newton steps on top
    assert projected.projections >= 2 * projected.steps and free.projections == 0


def test_projected_genalpha_converges_as_dt_squared_to_a_converged_run(arm):
    model, q0, final = arm
    errors = [np.abs(_genalpha(model, q0, dt, project=True)[1][-1, :model.n_dof] - final).max() for dt in STEPS]
    orders = [math.log2(a / b) for a, b in zip(errors, errors[1:])]
    assert all(1.9 < p < 2.1 for p in orders), errors
    assert errors[-1] < 2e-3


def test_first_order_constraints_are_projected_at_velocity_level(env):
    """The nonholonomic example (a first-order heading constraint and a position constraint on the
    height, which its quill meets exactly) at n_rfe 1, stepped at 20 ms over 2 s."""
    begun = FileCase(ROOT / "examples" / "nonholonomic.toml", nrfe=1).start("c", "locked", {}, lambda message: None)
    model = begun.model
    assert sorted(model.constraint_orders) == [0, 1]
    t, y, _ = _genalpha(model, begun.q, 2e-2, project=False, qd0=begun.qd, span=2.0)
    tp, yp, _ = _genalpha(model, begun.q, 2e-2, project=True, qd0=begun.qd, span=2.0)
    _, rate_drift = _residuals(model, t, y)
    held, rate_held = _residuals(model, tp, yp)
    assert rate_drift >= 1e-7
    assert held <= 1e-10 and rate_held <= 1e-10


@pytest.mark.parametrize("kind", ["unconstrained", "second order only"])
def test_models_with_nothing_to_project_are_unchanged_bit_for_bit(env, kind):
    if kind == "unconstrained":
        model = gpmegen.load(model=dataclasses.replace(reference_model(1), name="unconstrained_nrfe1", constraints=(),
                                                       dependent=None), backend="c")
        q0, qd0 = np.array([0.0, 0.3, 0.0]), np.array([1.0, 0.0, 0.0])
    else:
        begun = FileCase(ROOT / "tests" / "models" / "reaching_arm_ddot.toml", nrfe=1).start(
            "c", "locked", {}, lambda message: None)
        model, q0, qd0 = begun.model, begun.q, begun.qd
        assert set(model.constraint_orders) == {2}
    t, y, free = _genalpha(model, q0, 2e-3, project=False, qd0=qd0, span=0.2)
    tp, yp, projected = _genalpha(model, q0, 2e-3, project=True, qd0=qd0, span=0.2)
    assert np.array_equal(t, tp) and np.array_equal(y, yp) and free == projected
    assert np.abs(y[-1] - y[0]).max() > 1e-3  # it moved
