"""The C backend's O(n) GPME solve (templates/recursive.c.j2: the articulated-body recursion in
{0} with the constraint multipliers from D M⁻¹ Dᵀ) against independent computations of the
same accelerations: the dense solves (NumPy's stacked system and the C ``gpme_motion``, both from
M and f), a 50-digit solve of the dense terms, and Pinocchio's articulated-body algorithm.

Two backward-stable solves from terms that differ in their last bits differ in q̈ by up to about
eps·κ, κ = cond₂(ZᵀMZ) the condition number of the motion the constraints allow (Z an
orthonormal basis of null(D); κ = cond₂(M) without constraints): for the flexible arm κ ~ 1e5 at
n_rfe 3, so agreement is asked to ``max(1e-11, 4 eps κ)`` relative (max norm) at each state, the
bound tests/test_c_solve_accuracy.py sets for the dense solve.
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run.model_files import load_model_file, read_initial
from gpmegen.errors import SimulationError
from gpmegen.model import shapes
from gpmegen.model.chain import Body, Joint, Model, Parameter
from gpmegen.runtime import gpme

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)

from precise_solve import EPS, extended_accelerations, problem_condition  # noqa: E402

pytestmark = pytest.mark.requires_cc

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def _bound(c_model, t, q, qd):
    """The relative agreement asked at a state (see the module's doc), and the 50-digit q̈ of
    the dense terms the C backend evaluates there."""
    M, f, phi, phi_rate, D, gamma = c_model.gpme_terms(t, q, qd)
    if D.size:
        rhs = gpme.constraint_rhs(phi, phi_rate, gamma, c_model.alpha, c_model.beta, c_model.constraint_orders)
        kappa = problem_condition(M, D)
    else:
        rhs, kappa = np.zeros(0), float(np.linalg.cond(M))
    return max(1e-11, 4 * EPS * kappa), extended_accelerations(M, f, D.reshape(len(rhs), len(f)), rhs)


def _relative(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


def _check_states(c_model, numpy_model, states):
    """q̈ of the recursive solve (``accelerations``) against the dense C solve (``motion``), the
    NumPy backend and the 50-digit solve, each within the state's bound."""
    checked = 0
    for t, q, qd in states:
        recursive = c_model.accelerations(t, q, qd)
        dense = c_model.motion(t, q, qd)[0]
        bound, exact = _bound(c_model, t, q, qd)
        for reference in (dense, numpy_model.accelerations(t, q, qd), exact):
            assert _relative(recursive, reference) <= bound, (_relative(recursive, reference), bound)
        checked += 1
    assert checked


def _states(model, count, seed, scale=0.3, start=None):
    """Random states near ``start`` (n,) (default: zero with the reference arm's ψ2 at 45°; the
    arm stretched out vertically makes D singular)."""
    rng = np.random.default_rng(seed)
    if start is None:
        start = np.zeros(model.n_dof)
        start[model.index("psi2")] = np.pi / 4
    for _ in range(count):
        q = start + scale * rng.standard_normal(model.n_dof)
        yield float(rng.uniform(0.0, 2.0)), q, rng.standard_normal(model.n_dof)


@pytest.mark.parametrize("nrfe", [1, 3])
def test_reference_arm_agrees_with_the_dense_solves(env, nrfe):
    c_model = gpmegen.load("manipulator", nrfe=nrfe, backend="c")
    _check_states(c_model, gpmegen.load("manipulator", nrfe=nrfe, backend="numpy"), _states(c_model, 8, nrfe))


def test_reference_arm_n_rfe_1_to_1e_11(env):
    """The rigid arm is well conditioned (κ < 1e3): there the two solves agree to 1e-11."""
    c_model = gpmegen.load("manipulator", nrfe=1, backend="c")
    for t, q, qd in _states(c_model, 8, 11):
        assert _relative(c_model.accelerations(t, q, qd), c_model.motion(t, q, qd)[0]) <= 1e-11


# the six-joint arm's derivation is the longest (about 7 s of CPU), the planar arm's 4 s: make check-c
@pytest.mark.parametrize("name", ["curvature_arm", "flexible_gripper", "manipulator", "manipulator_tangential",
                                  "nonholonomic", pytest.param("planar_two_link", marks=pytest.mark.long),
                                  pytest.param("spatial_six_joint", marks=pytest.mark.long), "spinup", "spinup_axial"])
def test_examples_agree_with_the_dense_solves(env, name):
    """Every example model file at n_rfe 2 (second-order and first-order constraints, drives,
    springs, dampers, tilted and prismatic joints, no constraints at all, a tree)."""
    path = EXAMPLES / f"{name}.toml"
    model = load_model_file(path, nrfe=2)
    c_model = gpmegen.load(model=model, directory=env[0], backend="c")
    numpy_model = gpmegen.load(model=model, directory=env[0], backend="numpy")
    initial = read_initial(path, nrfe=2)
    start = np.array([initial.get(name, 0.0) for name in c_model.coordinates])
    _check_states(c_model, numpy_model, _states(c_model, 4, 7, scale=0.1, start=start))


def test_prismatic_and_unaligned_joints_agree_with_pinocchio_aba(env, rng):
    """The chain of tests/test_joint_axes.py (revolute and prismatic joints about unaligned axes,
    bodies off their axes, gravity along no axis) without constraints: q̈ against pinocchio.aba
    on the same chain built from Pinocchio's own joint models."""
    pin = pytest.importorskip("pinocchio")
    import test_joint_axes as chain

    c_model = gpmegen.load(model=chain.gpmegen_model(), directory=env[0], backend="c")
    model, _ = chain.pinocchio_model()
    data = model.createData()
    n = c_model.n_dof
    for _ in range(5):
        q, qd = rng.uniform(-1.5, 1.5, n), rng.uniform(-2, 2, n)
        expected = pin.aba(model, data, q, qd, np.zeros(n))
        assert _relative(c_model.accelerations(0.0, q, qd), expected) <= 1e-11


@pytest.mark.parametrize("seed", [3, 17, 29, 41])
def test_random_chains_agree_with_the_dense_solve(env, seed):
    """Random chains of tests/test_random_chains.py (bodies before the first joint, offsets,
    prismatic joints, springs, dampers, drives, flexible links, any gravity), no constraints."""
    import test_random_chains as chains

    model = chains.random_model(seed)
    c_model = gpmegen.load(model=model, directory=env[0], backend="c")
    numpy_model = gpmegen.load(model=model, directory=env[0], backend="numpy")
    _check_states(c_model, numpy_model, _states(c_model, 4, seed, scale=0.5, start=np.zeros(c_model.n_dof)))


def test_power_of_the_constraint_forces(env):
    """The work of the constraint forces that RK4 integrates (stage powers qd · Dᵀλ from the
    recursion) against the NumPy RK4's, whose powers are qd · (M q̈ - f) from the dense terms:
    over 200 steps of the flexible arm the two agree to 1e-9 of the work."""
    c_model = gpmegen.load("manipulator", nrfe=2, backend="c")
    numpy_model = gpmegen.load("manipulator", nrfe=2, backend="numpy")
    t, q, qd = next(_states(c_model, 1, 5, scale=0.05))
    runs = [model.rk4(q, qd, t + 200 * 1e-4, 1e-4, save_every=50, t0=t) for model in (c_model, numpy_model)]
    (_, _, _, w_c, status_c), (_, _, _, w_numpy, status_numpy) = runs
    assert status_c == status_numpy == 0
    assert np.max(np.abs(w_numpy[:, 1])) > 1e-6  # the constraint forces do work
    np.testing.assert_allclose(w_c[:, 1], w_numpy[:, 1], rtol=0, atol=1e-9 * np.max(np.abs(w_numpy[:, 1])))


def test_a_link_without_mass_at_the_tip_is_singular(env):
    """A joint that moves no mass makes M singular: the recursion's pivot is zero there and the
    solve says so, as the dense one does."""
    chain = (Joint("a", "revolute", "z"), Body("arm", shapes.from_inertia_tensor(1.0, (0.5, 0, 0), [[0.01, 0, 0],
             [0, 0.1, 0], [0, 0, 0.1]])), Joint("b", "revolute", "z"))
    model = Model("massless_tip", (Parameter("unused", 1.0),), chain, gravity=(0, -9.81, 0))
    c_model = gpmegen.load(model=model, directory=env[0], backend="c")
    for solve in (lambda: c_model.accelerations(0.0, np.zeros(2), np.zeros(2)),
                  lambda: c_model.motion(0.0, np.zeros(2), np.zeros(2))):
        with pytest.raises(SimulationError, match="singular"):
            solve()


MASSLESS_HELD = """
schema = 1
name = "massless_held"
description = "joint b moves no mass; a constraint holds its angle"
gravity = [0, -9.81, 0]
dependent = ["b"]

[parameters]
gain = { value = 10.0, unit = "1/s", doc = "Baumgarte gains" }

[[chain]]
joint = "a"
type = "revolute"
axis = "z"

[[chain]]
body = "bob"
shape = { type = "point_mass", mass = 1.0, position = [1.0, 0, 0] }

[[chain]]
joint = "b"
type = "revolute"
axis = "z"

[[constraints]]
name = "hold_b"
expression = "b - 0.1*t"
alpha = "gain"
beta = "gain"
"""


def test_a_joint_without_mass_that_the_constraints_hold_is_solved(env, tmp_path):
    """M singular, BᵀMB not: the GPME has one answer, which the dense solve finds. The
    recursion's pivot of that joint is zero, so it hands the state to the dense solve rather
    than calling the system singular (it did, for every compiled integrator): the reference
    arm with a slider of no mass, and a joint that moves nothing, held by a constraint."""
    path = tmp_path / "massless_held.toml"
    path.write_text(MASSLESS_HELD)
    held = load_model_file(path)
    cases = [(gpmegen.load("manipulator", nrfe=1, backend=backend).with_params(m3=0.0) for backend in ("c", "numpy")),
             (gpmegen.load(model=held, directory=env[0], backend=backend) for backend in ("c", "numpy"))]
    for c_model, numpy_model in cases:
        start = np.zeros(c_model.n_dof)
        if "psi2" in c_model.coordinates:
            start[c_model.index("psi2")] = np.pi / 4
        states = list(_states(c_model, 5, seed=12, start=start))
        for t, q, qd in states:
            assert np.array_equal(c_model.accelerations(t, q, qd), c_model.motion(t, q, qd)[0])
        _check_states(c_model, numpy_model, states)
        t, q, qd = states[0]
        runs = [model.rk4(q, qd, t + 100 * 1e-4, 1e-4, save_every=100, t0=t) for model in (c_model, numpy_model)]
        assert runs[0][-1] == runs[1][-1] == 0
        np.testing.assert_allclose(runs[0][1], runs[1][1], rtol=0, atol=1e-9)


def test_constraints_near_a_loss_of_rank_are_solved_as_the_dense_solve_does(env):
    """The pivots of D M⁻¹ Dᵀ fall as cond(D)², those of the dense solve's basis as cond(D): with
    the arm stretched vertically (ψ2 = -π/2 + 1e-9, cond(D) ~ 2e8) the recursion stops and the
    dense solve, which still has an answer, gives it, bit for bit as ``motion``."""
    c_model = gpmegen.load("manipulator", nrfe=1, backend="c")
    q, qd = np.zeros(c_model.n_dof), np.zeros(c_model.n_dof)
    q[c_model.index("psi2")] = -np.pi / 2 + 1e-9
    D = c_model.constraint_terms(0.0, q, qd)[2]
    assert np.linalg.cond(D) > 1e8
    np.testing.assert_array_equal(c_model.accelerations(0.0, q, qd), c_model.motion(0.0, q, qd)[0])
