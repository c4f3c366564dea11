"""Single accelerations calls through the fast-call extension (gpmegen/runtime/fastcall.c): the
same bits, errors and failures as the checked path through cffi, each model its own parameters,
and the cffi path where the extension cannot be had (threads: tests/test_batch.py)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.errors import SimulationError
from gpmegen.runtime import fastcall

pytestmark = pytest.mark.requires_cc

PENDULUM = Path(__file__).parent / "models" / "pendulum.toml"


@pytest.fixture(scope="module")
def arm(env):
    """The reference arm at n_rfe = 1: 3 coordinates, 1 programmed constraint."""
    return gpmegen.load("manipulator", nrfe=1, backend="c")


@pytest.fixture(scope="module")
def pendulum(env):
    """One coordinate and no constraint."""
    return gpmegen.load(model=gpmegen.load_model_file(PENDULUM), backend="c")


def _states(model, count, seed):
    rng = np.random.default_rng(seed)
    return [(float(rng.uniform(0, 2)), 0.4 * rng.standard_normal(model.n_dof), rng.standard_normal(model.n_dof))
            for _ in range(count)]


def _through_cffi(model, t, q, qd):
    """q̈ by today's path: the inputs checked in Python, the same C function called through cffi."""
    return model.evaluator.accelerations(t, q, qd, model)


def _outcome(call, *args):
    """What a call gives: its array, or its exception's type and message."""
    try:
        return call(*args)
    except Exception as exc:  # noqa: BLE001 - compared, type and text, with the other path's
        return type(exc), str(exc)


def _same(a, b):
    if isinstance(a, np.ndarray) or isinstance(b, np.ndarray):
        return isinstance(a, np.ndarray) and isinstance(b, np.ndarray) and a.shape == b.shape and np.array_equal(a, b)
    return a == b


@pytest.mark.parametrize("which", ["arm", "pendulum"])
def test_the_fast_call_gives_the_bits_of_the_cffi_path(request, which):
    model = request.getfixturevalue(which)
    assert model.evaluator.fastcall_unavailable is None
    assert type(model._accelerations_call).__name__ == "Caller"  # the extension is in use here
    for t, q, qd in _states(model, 20, seed=1):
        expected = _through_cffi(model, t, q, qd)
        for time in (t, np.float64(t)):
            got = model.accelerations(time, q, qd)
            assert got.shape == (model.n_dof,) and got.dtype == np.float64
            assert np.array_equal(got, expected)
    q, qd = _states(model, 1, seed=2)[0][1:]
    assert np.array_equal(model.accelerations(1, q, qd), _through_cffi(model, 1.0, q, qd))  # an int time
    result = model.accelerations(0.5, q, qd)
    assert result is not model.accelerations(0.5, q, qd)  # a new array each call, never a shared buffer


def _other_inputs(n):
    q, qd = np.linspace(-0.3, 0.4, n), np.linspace(0.5, -0.2, n)
    wide = np.zeros(2 * n)
    wide[::2] = q
    return [
        (0.3, q.tolist(), qd.tolist()),                 # lists
        (0.3, q.astype(np.float32), qd),                # another dtype, converted
        (0.3, wide[::2], qd),                           # not contiguous
        (0.3, q.astype(">f8"), qd.astype(">f8")),       # not in native byte order
        (0.3, q.astype(int), qd),                       # integers
        (np.array(0.3), q, qd),                         # a 0-d array for t
        (0.3, np.tile(q, (2, 1)), np.tile(qd, (2, 1))),  # a batch
        (0.3, q[:-1], qd[:-1]),                         # one coordinate short
        (0.3, np.append(q, 0.0), qd),                   # one too many
        (0.3, q, None),                                 # no velocities
        ("soon", q, qd),                                # not a time
        (2**1100, q, qd),                               # a time too large for a double
    ]


@pytest.mark.parametrize("which", ["arm", "pendulum"])
def test_other_inputs_give_exactly_the_checked_path_s_results_and_errors(request, which):
    model = request.getfixturevalue(which)
    for args in _other_inputs(model.n_dof):
        fast, checked = _outcome(model.accelerations, *args), _outcome(model._checked_accelerations, *args)
        assert _same(fast, checked), args
    q, qd = _states(model, 1, seed=3)[0][1:]
    assert np.array_equal(model.accelerations(t=0.2, q=q, qd=qd), _through_cffi(model, 0.2, q, qd))
    with pytest.raises(TypeError):
        model.accelerations(0.2, q)


def test_a_failed_solve_raises_today_s_simulation_error(arm):
    q, qd = _states(arm, 1, seed=4)[0][1:]
    q[arm.index("x3")] = 1e200  # finite, but M, f and D overflow
    with pytest.raises(SimulationError) as fast:
        arm.accelerations(0.375, q, qd)
    with pytest.raises(SimulationError) as checked:
        _through_cffi(arm, 0.375, q, qd)
    assert str(fast.value) == str(checked.value)
    assert "not finite at t = 0.375 s" in str(fast.value)


def test_each_model_of_a_library_uses_its_own_parameters(arm):
    """The Caller copies its model's parameter values when it is made: a with_params copy must
    make its own (were the first model's kept, heavy would give arm's q̈)."""
    t, q, qd = _states(arm, 1, seed=5)[0]
    own = arm.accelerations(t, q, qd)
    heavy = arm.with_params(m3=2 * arm.params["m3"])
    assert heavy._accelerations_call is not arm._accelerations_call
    for _ in range(3):
        assert np.array_equal(heavy.accelerations(t, q, qd), _through_cffi(heavy, t, q, qd))
        assert np.array_equal(arm.accelerations(t, q, qd), own)
    assert not np.array_equal(heavy.accelerations(t, q, qd), own)


def test_values_set_by_hand_are_followed(arm):
    """A partition set after loading (tests/test_c_backend.py) or parameter values set by hand
    make the fast call again."""
    model = arm.with_params()
    t, q, qd = _states(arm, 1, seed=9)[0]
    model.accelerations(t, q, qd)
    first = model._accelerations_call
    model.p = arm.with_params(m3=3 * arm.params["m3"]).p
    assert np.array_equal(model.accelerations(t, q, qd), _through_cffi(model, t, q, qd))
    assert not np.array_equal(model.accelerations(t, q, qd), arm.accelerations(t, q, qd))
    model.dependent, model.independent = np.array([1, 2]), np.array([0])
    assert model._accelerations_call is not first and np.array_equal(model.accelerations(t, q, qd),
                                                                      _through_cffi(model, t, q, qd))
    model.dependent = None  # chosen at each state again: the checked path
    assert model._accelerations_call == model._checked_accelerations


@pytest.fixture
def fresh(monkeypatch, tmp_path):
    """No extension loaded yet in this process, and an empty cache folder for it."""
    monkeypatch.setattr(fastcall, "_extensions", {})
    return tmp_path / "cache"


def _without_extension(arm, why):
    model = gpmegen.load("manipulator", nrfe=1, backend="c")
    assert model.evaluator.fastcall_unavailable is not None and why in model.evaluator.fastcall_unavailable
    assert model._accelerations_call == model._checked_accelerations
    for t, q, qd in _states(arm, 5, seed=7):
        assert np.array_equal(model.accelerations(t, q, qd), arm.accelerations(t, q, qd))
    for args in _other_inputs(arm.n_dof):
        assert _same(_outcome(model.accelerations, *args), _outcome(arm.accelerations, *args)), args


def test_switched_off_calls_go_through_cffi_with_the_same_results(arm, monkeypatch, fresh):
    monkeypatch.setenv(fastcall.SWITCH, "0")
    _without_extension(arm, "GPMEGEN_FASTCALL=0")


def test_without_python_headers_calls_go_through_cffi(arm, monkeypatch, fresh):
    monkeypatch.setattr(fastcall.sysconfig, "get_paths", lambda: {"include": str(fresh / "nowhere")})
    _without_extension(arm, "Python.h is not installed")


def test_a_failed_build_leaves_calls_on_cffi(arm, monkeypatch, fresh):
    monkeypatch.setattr(fastcall, "FLAGS", fastcall.FLAGS + ("-include", "nonexistent.h"))
    _without_extension(arm, "compiling the fast-call extension failed")


def test_a_failed_test_run_is_recorded_and_the_extension_never_imported(monkeypatch, fresh):
    imported = []
    monkeypatch.setattr(fastcall, "check_in_child", lambda path: "the test process was killed by SIGSEGV")
    monkeypatch.setattr(fastcall, "_import", imported.append)
    module, why = fastcall.extension(fresh)
    assert module is None and "failed its test run (the test process was killed by SIGSEGV)" in why
    [meta] = fresh.glob("*.json")
    assert json.loads(meta.read_text())["check"] == "the test process was killed by SIGSEGV"
    monkeypatch.setattr(fastcall, "_extensions", {})
    monkeypatch.setattr(fastcall, "check_in_child", lambda path: pytest.fail("the verdict is kept"))
    assert fastcall.extension(fresh)[0] is None and not imported


def test_the_extension_is_built_once_checked_and_rebuilt_when_damaged(monkeypatch, fresh):
    lines = []
    module, why = fastcall.extension(fresh, progress=lines.append)
    assert why is None and module is not None
    assert lines[0].startswith("compiling the fast-call extension") and lines[-1].startswith("compiled")
    [library] = fresh.glob("*.so")
    assert json.loads(library.with_suffix(".json").read_text())["check"] == "ok"
    monkeypatch.setattr(fastcall, "_extensions", {})
    lines.clear()
    assert fastcall.extension(fresh, progress=lines.append)[0] is not None and not lines  # reused
    damaged = fresh / "damaged"
    damaged.write_bytes(library.read_bytes()[:100])
    damaged.replace(library)  # another file in its place (this process still maps the first)
    monkeypatch.setattr(fastcall, "_extensions", {})
    assert fastcall.extension(fresh, progress=lines.append)[0] is not None and lines  # built again
    assert len(library.read_bytes()) > 100


def test_the_child_s_test_run_reports_a_broken_extension(tmp_path):
    broken = tmp_path / "broken.so"
    broken.write_bytes(b"\x7fELF not really")
    verdict = fastcall.check_in_child(broken)
    assert verdict is not None and verdict.startswith("the test process ended with status")


def test_a_caller_refuses_a_partition_that_cannot_hold_n_indices(arm):
    module, _ = fastcall.extension()
    address = module.reference_address()
    with pytest.raises(ValueError, match="number n together"):
        module.Caller(address, 3, np.zeros(1), np.array([0], np.intc), np.array([1], np.intc), print, print, None)
    with pytest.raises(TypeError, match="intc"):
        module.Caller(address, 3, np.zeros(1), np.array([0]), np.array([1, 2]), print, print, None)
    with pytest.raises(TypeError, match="float64"):
        module.Caller(address, 3, [0.0], np.array([0], np.intc), np.array([1, 2], np.intc), print, print, None)


@pytest.mark.parametrize("backend", ["numpy", "c"])
def test_missing_velocities_are_refused_for_one_coordinate(env, backend):
    """NumPy turns None into [nan], of shape (1,): for a model of one coordinate it passed the
    shape check and gave nan accelerations once q̇ entered them."""
    model = gpmegen.load(model=gpmegen.load_model_file(PENDULUM), backend=backend)
    for call in (model.accelerations, model.forces):
        with pytest.raises(ValueError, match="qd is missing"):
            call(0.3, np.array([-0.3]), None)
