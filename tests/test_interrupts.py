"""Every run can be stopped: the compiled loops give the hand back to Python after a budget of
steps (not a saved interval, which may hold billions of them), and go on from there to the same
bits, so Ctrl-C and SIGTERM end a run of any length with its results so far kept and marked
partial; SciPy's Radau, stepped in Python, keeps them too."""

from __future__ import annotations

import os
import select
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.post import results as results_io
from gpmegen.analysis.run import reference_case
from gpmegen.runtime import integrators

pytestmark = pytest.mark.requires_cc

#: Seconds a stopped run may take to end before the test calls it a hang (not a measure: the
#: time from signal to exit is benchmarks/interrupt.py's).
HANG = 30.0


@pytest.fixture(scope="module")
def arm():
    model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=1, backend="c"))
    return model, q0, np.zeros(model.n_dof)


RUNS = {
    "rk4": lambda model, q0, qd0, calls: integrators.rk4.rk4(model, q0, qd0, 0.2, 1e-4, 7, steps_per_call=calls)
    + (None,),
    "genalpha": lambda model, q0, qd0, calls: integrators.genalpha.genalpha(model, q0, qd0, 0.2, 1e-3, 7e-3,
                                                                            steps_per_call=calls),
    "dop853": lambda model, q0, qd0, calls: integrators.dop853.dop853(model, q0, qd0, 0.2, 7e-3, rtol=1e-9,
                                                                      steps_per_call=calls),
    "radau": lambda model, q0, qd0, calls: integrators.radau.radau(model, q0, qd0, 0.2, 7e-3, rtol=1e-7,
                                                                   steps_per_call=calls),
}


@pytest.mark.parametrize("method", sorted(RUNS))
def test_a_run_chopped_into_calls_gives_the_same_bits_as_one_call(arm, method):
    """The compiled loops used to run a whole saved interval per call, whatever it held."""
    run = RUNS[method]
    t, y, outcome, effort = run(*arm, 10**9)  # every chunk in one call
    assert outcome.complete and len(t) > 20
    for calls in (1, 3, None):  # None: as many steps as fit the wall time of a call
        t_c, y_c, outcome_c, effort_c = run(*arm, calls)
        assert outcome_c.complete
        assert np.array_equal(t_c, t) and np.array_equal(y_c, y), (method, calls)
        if method in ("dop853", "radau"):  # the place kept in C, nothing taken again
            assert effort_c == effort


def test_an_adaptive_loop_stopped_returns_after_its_budget_and_goes_on(arm):
    """A call with max_steps returns with part of its rows and its place kept."""
    model, q0, qd0 = arm
    y0 = np.concatenate([q0, qd0, [0.0, 0.0]])
    t_save = np.array([0.1, 0.2])
    for method in ("dop853", "radau"):
        counts, step = np.zeros(integrators.base.COUNTS, dtype=np.int64), np.zeros(1)
        memory, rows, calls = model.loop_memory(method), [], 0
        while sum(len(r) for r in rows) < len(t_save):
            got, status = getattr(model, method)(0.0, y0, t_save, 1e-8, 1e-10, step, counts, memory, 2,
                                                 sum(len(r) for r in rows))
            assert status == 0 and counts[0] + counts[1] == 2 * (calls + 1) or len(got)
            rows.append(got)
            calls += 1
        whole, status = getattr(model, method)(0.0, y0, t_save, 1e-8, 1e-10, np.zeros(1),
                                               np.zeros(integrators.base.COUNTS, dtype=np.int64))
        assert calls > 2 and np.array_equal(np.concatenate(rows), whole)


def _read_until(fd, text, timeout):
    """Read the pipe ``fd`` until ``text`` shows; all that was read (str)."""
    seen, end = b"", time.monotonic() + timeout
    while text.encode() not in seen:
        left = end - time.monotonic()
        assert left > 0 and select.select([fd], [], [], left)[0], f"no {text!r} within {timeout} s: {seen!r}"
        chunk = os.read(fd, 4096)
        assert chunk, f"the run ended before {text!r}: {seen!r}"
        seen += chunk
    return seen.decode()


STOPPED = [("dop853", signal.SIGTERM), ("dop853", signal.SIGINT), ("radau", signal.SIGINT),
           ("genalpha", signal.SIGTERM), ("scipy-radau", signal.SIGTERM), ("scipy-radau", signal.SIGINT)]


@pytest.mark.parametrize("method, number", STOPPED, ids=[f"{m}-{s.name}" for m, s in STOPPED])
def test_a_signal_stops_a_run_of_any_length_and_keeps_its_results(tmp_path, method, number):
    """SIGINT and SIGTERM were not heard for minutes by a compiled run whose saved interval holds
    billions of steps (only SIGKILL ended it, and nothing was kept), and scipy-radau lost its
    results to Ctrl-C and ended without them on SIGTERM."""
    out = tmp_path / "run.npz"
    step = ["--dt", "1e-3"] if method == "genalpha" else []
    proc = subprocess.Popen([sys.executable, "-m", "gpmegen.cli", "simulate", "--nrfe", "1", "--backend", "c",
                             "--method", method, *step, "--t-end", "1e9", "--save-dt", "1e8", "--no-limits",
                             "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    try:
        err = _read_until(proc.stderr.fileno(), "Ctrl-C or SIGTERM stops it", timeout=120)
        proc.send_signal(number)
        _, rest = proc.communicate(timeout=HANG)
    finally:
        proc.kill()
        proc.wait()
    err += rest.decode()
    partial, partial_csv = results_io.targets(out, complete=False)
    assert proc.returncode == 130 and "Traceback" not in err, err
    assert f"kept in {partial} (partial)" in err, err
    res = results_io.load(partial)
    assert str(res["status"]) == "interrupted" and len(res["t"]) >= 1 and res["t"][-1] < 1e9
    with open(partial_csv, encoding="utf-8") as fh:
        assert fh.readline().rstrip("\n").endswith(": partial (interrupted)")
    assert not out.exists()
