"""A state that is not finite (t, q or q̇ holding a NaN or an infinity) is refused before any
evaluation, with the same exception and text on both backends, through the fast single call as
through the checked path, for one state and for a batch (gpmegen/runtime/finite.py). Before, the
backends disagreed: a NaN q made the C solve fail where NumPy returned NaN accelerations, an
infinite t the reverse."""

from __future__ import annotations

import numpy as np
import pytest

import gpmegen
from gpmegen.errors import StateError

FIX = ": give finite t, q and qd"
BACKENDS = ("numpy", pytest.param("c", marks=pytest.mark.requires_cc))

#: Each public function of a model that takes a state, called with (t, q, qd).
FUNCTIONS = {
    "mass_matrix": lambda model, t, q, qd: model.mass_matrix(q),
    "forces": lambda model, t, q, qd: model.forces(t, q, qd),
    "constraint_terms": lambda model, t, q, qd: model.constraint_terms(t, q, qd),
    "accelerations": lambda model, t, q, qd: model.accelerations(t, q, qd),
}


@pytest.fixture(scope="module")
def models(env):
    """The reference arm at n_rfe = 1 (3 coordinates, 1 programmed constraint) on each backend."""
    loaded = {}

    def get(backend):
        if backend not in loaded:
            loaded[backend] = gpmegen.load("manipulator", nrfe=1, backend=backend)
        return loaded[backend]

    return get


def _state(model):
    return 0.25, np.array([0.1, np.pi / 4, 0.02]), np.array([0.3, -0.2, 0.1])


def _refusal(call, *args):
    with pytest.raises(StateError) as info:
        call(*args)
    return str(info.value)


# (what is spoiled, how, the line expected); mass_matrix takes no t and no qd
SPOILED = [
    ("q", lambda t, q, qd: (t, _with(q, 1, np.nan), qd), "q[1] = nan is not finite: give finite t, q and qd"),
    ("q", lambda t, q, qd: (t, _with(q, 2, -np.inf), qd), "q[2] = -inf is not finite: give finite t, q and qd"),
    ("qd", lambda t, q, qd: (t, q, _with(qd, 0, np.inf)), "qd[0] = inf is not finite: give finite t, q and qd"),
    ("t", lambda t, q, qd: (np.inf, q, qd), "t = inf is not finite: give finite t, q and qd"),
    ("t", lambda t, q, qd: (np.float64(np.nan), q, qd), "t = nan is not finite: give finite t, q and qd"),
]


def _with(x, k, value):
    x = x.copy()
    x[k] = value
    return x


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("function, spoil, line", [
    (function, spoil, line) for function in FUNCTIONS for spoiled, spoil, line in SPOILED
    if function != "mass_matrix" or spoiled == "q"])  # M takes no t and no qd
def test_a_state_that_is_not_finite_is_refused_in_one_line(models, backend, function, spoil, line):
    model = models(backend)
    assert _refusal(FUNCTIONS[function], model, *spoil(*_state(model))) == line


@pytest.mark.parametrize("backend", BACKENDS)
@pytest.mark.parametrize("function", FUNCTIONS)
def test_a_batch_names_its_first_state_that_is_not_finite(models, backend, function):
    model = models(backend)
    call = FUNCTIONS[function]
    t0, q0, qd0 = _state(model)
    t, q, qd = np.full(4, t0), np.tile(q0, (4, 1)), np.tile(qd0, (4, 1))
    q[2, 1] = q[3, 0] = np.nan
    assert _refusal(call, model, t, q, qd) == f"q[2, 1] = nan is not finite (state 2 of the batch){FIX}"
    if function == "mass_matrix":
        return
    q[2, 1] = q[3, 0] = q0[0]
    qd[1, 2] = -np.inf
    assert _refusal(call, model, t, q, qd) == f"qd[1, 2] = -inf is not finite (state 1 of the batch){FIX}"
    qd[1, 2] = qd0[2]
    t[3] = np.inf
    assert _refusal(call, model, t, q, qd) == f"t[3] = inf is not finite (state 3 of the batch){FIX}"
    assert _refusal(call, model, np.nan, q, qd) == f"t[0] = nan is not finite (state 0 of the batch){FIX}"


@pytest.mark.requires_cc
def test_the_refusal_is_a_value_error_and_the_same_on_both_backends(models):
    """What code that caught the shape errors (ValueError) catches; the same type and text from
    the NumPy module and the compiled library."""
    t, q, qd = _state(models("numpy"))
    q = _with(q, 0, np.nan)
    for function, call in FUNCTIONS.items():
        outcomes = []
        for backend in ("numpy", "c"):
            with pytest.raises(ValueError) as info:
                call(models(backend), t, q, qd)
            outcomes.append((type(info.value), str(info.value)))
        assert outcomes[0] == outcomes[1] and outcomes[0][0] is StateError, function


@pytest.mark.requires_cc
def test_the_fast_call_refuses_as_the_checked_path(models):
    """The fast single call hands a state that is not finite to the checked path: same text."""
    c = models("c")
    assert type(c._accelerations_call).__name__ == "Caller"  # the extension is in use here
    t, q, qd = _state(c)
    for args in ((np.inf, q, qd), (-np.inf, q, qd), (np.float64(np.nan), q, qd), (t, _with(q, 1, np.nan), qd),
                 (t, q, _with(qd, 2, np.inf))):
        fast, checked = _refusal(c.accelerations, *args), _refusal(c._checked_accelerations, *args)
        assert fast == checked
    assert np.array_equal(c.accelerations(t, q, qd), c._checked_accelerations(t, q, qd))  # a finite state goes on
