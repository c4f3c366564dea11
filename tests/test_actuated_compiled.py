"""The actuated realization in the compiled library (gpmegen/csrc/actuated.c): its accelerations
and inputs against the NumPy solve of the same system (gpmegen.runtime.gpme.actuated), its RK4
loop against the Python loop of the same method and step, and a compiled actuated run holding its
constraints."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run import reference_case, study
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.errors import SimulationError
from gpmegen.runtime import gpme
from gpmegen.status import SolveStatus

pytestmark = pytest.mark.requires_cc
TWO_LINK = Path(__file__).resolve().parent / "models" / "two_link_traced.toml"


def _arm(backend):
    """The reference arm at n_rfe = 2, its locked start, the inputs on psi2 and x3."""
    model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=2, backend=backend), "locked")
    return model.with_actuators(["psi2", "x3"]), q0


def _two_link(backend):
    """Two rigid links, the tip's height programmed, held by an input on the elbow theta2."""
    file = gpmegen.read_model_file(TWO_LINK)
    model = gpmegen.load(model=file.model, backend=backend).with_actuators(["theta2"])
    return model, np.array([0.6, -1.0])


MODELS = {"arm": _arm, "two_link": _two_link}


@pytest.fixture(scope="module", params=sorted(MODELS))
def pair(request, env):
    """The same model on both backends, and a start: ``(c, numpy, q0)``."""
    (c, q0), (numpy, _) = MODELS[request.param]("c"), MODELS[request.param]("numpy")
    return c, numpy, q0


def test_compiled_accelerations_and_inputs_equal_the_numpy_solve(pair, rng):
    """At random states, q̈ and u from C equal gpme.actuated on the NumPy backend's terms to 1e-12
    of their scale, and satisfy the system solved: M q̈ = f + S u and D q̈ = c."""
    c, numpy, q0 = pair
    n = c.n_dof
    S = gpme.selection(n, c.actuators)
    for _ in range(5):
        t, q, qd = rng.uniform(0.0, 1.0), q0 + 0.1 * rng.standard_normal(n), rng.standard_normal(n)
        qdd, u, M, f = c.actuation(t, q, qd)
        M_n, f_n, phi, phid, D, gamma = numpy.gpme_terms(t, q, qd)
        expected_qdd, expected_u = gpme.actuated(M_n, f_n, phi, phid, D, gamma, numpy.alpha, numpy.beta,
                                                 numpy.constraint_orders, numpy.actuators)
        assert np.max(np.abs(qdd - expected_qdd)) <= 1e-12 * np.max(np.abs(expected_qdd))
        assert np.max(np.abs(u - expected_u)) <= 1e-12 * np.max(np.abs(expected_u))
        assert np.allclose(M, M_n, rtol=1e-14, atol=0) and np.allclose(f, f_n, rtol=1e-13, atol=1e-13)
        rhs = gpme.constraint_rhs(phi, phid, gamma, numpy.alpha, numpy.beta, numpy.constraint_orders)
        assert np.max(np.abs(M_n @ qdd - f_n - S @ u)) <= 1e-12 * np.max(np.abs(M_n) @ np.abs(qdd) + np.abs(f_n))
        assert np.max(np.abs(D @ qdd - rhs)) <= 1e-12 * np.max(np.abs(D) @ np.abs(qdd) + np.abs(rhs))


def test_inputs_that_cannot_move_the_constraints_are_refused_alike(env):
    """theta1 moves neither constraint of the arm: D M⁻¹ S is singular, and the compiled solve
    says so in the line the NumPy one gives."""
    lines = {}
    for backend in ("c", "numpy"):
        model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=1, backend=backend), "locked")
        with pytest.raises(SimulationError) as refused:
            model.with_actuators(["theta1", "x3"]).actuation(0.0, q0, np.zeros(model.n_dof))
        lines[backend] = str(refused.value)
    assert lines["c"] == lines["numpy"] and "\n" not in lines["c"] and "D M⁻¹ S is singular" in lines["c"]


def test_a_singular_stage_stops_the_compiled_loop_as_the_python_one(env):
    """An RK4 run whose inputs cannot hold the constraints ends SINGULAR in both loops, the start kept."""
    for backend in ("c", "numpy"):
        model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=1, backend=backend), "locked")
        t, q, _, _, status = model.with_actuators(["theta1", "x3"]).rk4(q0, np.zeros(model.n_dof), 0.01, 1e-3)
        assert status == SolveStatus.SINGULAR and len(t) == 1 and np.array_equal(q[0], q0)


def test_compiled_rk4_equals_the_python_loop(pair):
    """The compiled actuated RK4 and the Python loop over the NumPy backend, same method and step:
    the same states, work and end, to round-off (1e-10 of each quantity's scale)."""
    c, numpy, q0 = pair
    qd0 = np.zeros(c.n_dof)
    compiled = c.rk4(q0, qd0, 0.05, 1e-4, save_every=25)
    python = numpy.rk4(q0, qd0, 0.05, 1e-4, save_every=25)
    assert compiled[4] == python[4] == SolveStatus.OK
    assert np.array_equal(compiled[0], python[0]) and len(compiled[0]) == 21
    for mine, theirs in zip(compiled[1:4], python[1:4]):
        assert np.max(np.abs(mine - theirs)) <= 1e-10 * max(np.max(np.abs(theirs)), 1.0)
    assert np.max(np.abs(compiled[3][:, 1])) > 0.0  # the inputs did work: the comparison saw them


def test_a_compiled_actuated_run_holds_its_constraints_and_saves_its_inputs(env):
    """A simulate run of the two links on the C backend: complete, max |Φ| small, and the inputs u
    those that hold M q̈ - f = S u at every saved sample (the same columns as the Python path's)."""
    model, _ = _two_link("c")
    begun = study.file_start(model, {"theta1": 0.6, "theta2": -1.0})
    res = study.simulate(model, begun.q, RunSpec(t_end=0.25, dt=1e-3, save_every=10), qd0=begun.qd)
    assert str(res["status"]) == "complete" and list(res["actuators"]) == ["theta2"]
    assert np.max(np.abs(res["phi"])) < 1e-8
    assert res["u"].shape == (26, 1) and np.max(np.abs(res["u"])) > 1.0
    reaction = res["constraint_forces"]
    assert np.array_equal(reaction[:, 1], res["u"][:, 0])
    assert np.max(np.abs(reaction[:, 0])) <= 1e-12 * np.max(np.abs(reaction[:, 1]))  # no input on theta1
