"""Batched evaluation: N states in one call give, bit for bit, what N single calls give, on
both backends; shapes and bad shapes; the C backend's per-thread buffers under threads."""

from __future__ import annotations

import threading

import numpy as np
import pytest

import gpmegen
from gpmegen.errors import SimulationError
from gpmegen.runtime import cmodel

BACKENDS = ("numpy", pytest.param("c", marks=pytest.mark.requires_cc))


@pytest.fixture(scope="module")
def models(env):
    loaded = {}

    def get(backend, nrfe=2):
        if (backend, nrfe) not in loaded:
            loaded[backend, nrfe] = gpmegen.load("manipulator", nrfe=nrfe, backend=backend)
        return loaded[backend, nrfe]

    return get


def _batch(model, n_states, seed):
    rng = np.random.default_rng(seed)
    q = 0.3 * rng.standard_normal((n_states, model.n_dof))
    q[:, model.index("psi2")] += np.pi / 4
    return rng.uniform(0, 2, n_states), q, rng.standard_normal((n_states, model.n_dof))


def _singles(fn, t, q, qd):
    """fn at each state, stacked as a batch would be."""
    results = [fn(float(tk), qk.copy(), qdk.copy()) for tk, qk, qdk in zip(t, q, qd)]
    if isinstance(results[0], tuple):
        return tuple(np.stack(parts) for parts in zip(*results))
    return np.stack(results)


def _equal(a, b):
    if isinstance(b, tuple):
        return len(a) == len(b) and all(_equal(x, y) for x, y in zip(a, b))
    return a.shape == b.shape and np.array_equal(a, b)


@pytest.mark.parametrize("backend", BACKENDS)
def test_batch_is_bit_for_bit_the_single_calls(models, backend):
    model = models(backend)
    n, m = model.n_dof, len(model.constraint_names)
    t, q, qd = _batch(model, 7, seed=1)
    calls = {
        "mass_matrix": (lambda t, q, qd: model.mass_matrix(q), (n, n)),
        "forces": (model.forces, (n,)),
        "accelerations": (model.accelerations, (n,)),
        "drive_forces": (model.drive_forces, (n,)),
        "point_positions": (lambda t, q, qd: model.point_positions(q), (len(model.points), 3)),
        "end_effector": (lambda t, q, qd: model.end_effector(q), (3,)),
        "energies": (lambda t, q, qd: model.energies(q, qd), (3,)),
    }
    for name, (fn, shape) in calls.items():
        batched = fn(t, q, qd)
        assert batched.shape == (7,) + shape, name
        assert _equal(batched, _singles(fn, t, q, qd)), name
    terms = model.constraint_terms(t, q, qd)
    assert [a.shape for a in terms] == [(7, m), (7, m), (7, m, n), (7, m)]
    assert _equal(terms, _singles(model.constraint_terms, t, q, qd))
    # one time for every state, and lists rather than arrays
    same_t = model.accelerations(0.25, q.tolist(), qd.tolist())
    assert _equal(same_t, _singles(model.accelerations, np.full(7, 0.25), q, qd))


@pytest.mark.requires_cc
def test_backends_agree_on_a_batch(models):
    """The batch paths of the two backends compute the same model (to round-off, as single calls)."""
    c, n = models("c"), models("numpy")
    t, q, qd = _batch(c, 4, seed=2)
    assert np.allclose(c.mass_matrix(q), n.mass_matrix(q), rtol=1e-12, atol=0)
    assert np.allclose(c.forces(t, q, qd), n.forces(t, q, qd), rtol=1e-12, atol=1e-12)
    assert np.allclose(c.accelerations(t, q, qd), n.accelerations(t, q, qd), rtol=1e-9, atol=1e-9)


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("args, named", [
    (lambda n: (0.0, np.zeros((3, n + 1)), np.zeros((3, n + 1))), "q must have shape (N, "),
    (lambda n: (0.0, np.zeros((3, n)), np.zeros((2, n))), "qd must have shape (3, "),
    (lambda n: (0.0, np.zeros((3, n)), np.zeros(n)), "qd must have shape (3, "),
    (lambda n: (np.zeros(2), np.zeros((3, n)), np.zeros((3, n))), "t must be a scalar or have shape (3,)"),
    (lambda n: (0.0, np.zeros((0, n)), np.zeros((0, n))), "q holds no state"),
    (lambda n: (0.0, np.zeros((2, 3, n)), np.zeros((2, 3, n))), "q must have shape ("),
    (lambda n: (0.0, np.zeros(n + 1), np.zeros(n + 1)), "q must have shape ("),
])
def test_bad_shapes_are_one_line(models, backend, args, named):
    model = models(backend)
    with pytest.raises(ValueError) as info:
        model.accelerations(*args(model.n_dof))
    message = str(info.value)
    assert named in message and "\n" not in message


@pytest.mark.requires_cc
def test_a_failing_state_names_its_place_in_the_batch(models):
    c = models("c")
    t, q, qd = _batch(c, 5, seed=3)
    q[3, c.index("x3")] = 1e200  # finite, but M, f and D overflow
    with pytest.raises(SimulationError, match=r"not finite at t = .* s \(state 3 of the batch\)"):
        c.accelerations(t, q, qd)
    assert not np.isfinite(c.mass_matrix(q)[3]).all() and np.isfinite(c.mass_matrix(q)[:3]).all()


@pytest.mark.requires_cc
@pytest.mark.parametrize("path, release_from", [("fast", cmodel.RELEASE_GIL_FROM), ("fast", 0), ("checked", 0)])
def test_threads_do_not_share_a_call_s_buffers(models, monkeypatch, path, release_from):
    """Threads calling one model at once each get their own state's q̈: through the fast-call
    extension with the GIL kept or released during the C, and through cffi (which releases it),
    whose single calls keep the state in buffers of their thread."""
    monkeypatch.setattr(cmodel, "RELEASE_GIL_FROM", release_from)
    c = models("c").with_params()  # a copy: its fast call is made under this rule
    call = c.accelerations if path == "fast" else c._checked_accelerations
    t, q, qd = _batch(c, 4, seed=4)
    expected = c.accelerations(t, q, qd)
    wrong = []

    def work(k):
        for _ in range(1000):
            if not np.array_equal(call(t[k], q[k], qd[k]), expected[k]):
                wrong.append(k)

    threads = [threading.Thread(target=work, args=(k,)) for k in range(4)]
    for thread in threads:
        thread.start()
    for thread in threads:
        thread.join()
    assert not wrong


@pytest.mark.requires_cc
def test_models_sharing_a_library_keep_their_own_parameters(models):
    """The C views of the parameters are kept between calls: alternating two models of one
    library must still give each its own result."""
    c = models("c")
    heavy = c.with_params(g=2 * c.params["g"])
    t, q, qd = _batch(c, 1, seed=5)
    own = c.accelerations(t[0], q[0], qd[0]), heavy.accelerations(t[0], q[0], qd[0])
    assert not np.array_equal(*own)
    for _ in range(3):
        assert np.array_equal(c.accelerations(t[0], q[0], qd[0]), own[0])
        assert np.array_equal(heavy.accelerations(t[0], q[0], qd[0]), own[1])
        assert np.array_equal(heavy.accelerations(t, q, qd)[0], own[1])
