"""Progress of the long steps a user waits for: deriving (with its estimate, said before it
starts) and compiling (estimate, lines while it runs, its end); an interrupted compile ends
the compiler."""

from __future__ import annotations

import signal
import subprocess
import sys

import pytest

import gpmegen
from gpmegen.runtime import ccompile


@pytest.mark.requires_cc
def test_building_and_compiling_say_what_they_do(env, monkeypatch, fresh_cache):
    monkeypatch.setenv("GPMEGEN_CACHE", str(fresh_cache))  # a cache of its own: the compile happens here
    monkeypatch.setattr(ccompile, "HEARTBEAT", 0.01)  # a line at every poll of a ~1 s compile
    lines = []
    gpmegen.load("manipulator", nrfe=1, backend="c", progress=lines.append)
    text = "\n".join(lines)
    assert lines[0].startswith("deriving the equations of motion of 3 coordinates (deriving and printing "
                               "estimated at ")
    starts = [k for k, line in enumerate(lines) if line.startswith("compiling model.c (")]
    assert len(starts) == 1 and "MB of C; estimated " in lines[starts[0]]
    assert any(line.startswith("still compiling, ") for line in lines[starts[0]:]), text
    ends = [k for k, line in enumerate(lines) if line.startswith("compiled model.c in ")]
    assert len(ends) == 1 and ends[0] > starts[0], text
    # then, once per Python and NumPy, the small fast-call extension (gpmegen/runtime/fastcall.py)
    assert all(line.endswith("fast-call extension (once per Python and NumPy)") or
               line.startswith("compiled the fast-call extension in ") for line in lines[ends[0] + 1:]), text
    lines.clear()
    gpmegen.load("manipulator", nrfe=1, backend="c", progress=lines.append)  # up to date and cached: nothing to say
    assert lines == []


def test_an_interrupted_compile_ends_the_compilers(monkeypatch, tmp_path):
    monkeypatch.setattr(ccompile, "HEARTBEAT", 0.05)
    def interrupt(line):
        raise KeyboardInterrupt  # Ctrl-C while the compiler runs

    started, popen = [], subprocess.Popen
    monkeypatch.setattr(ccompile.subprocess, "Popen", lambda *a, **kw: started.append(popen(*a, **kw)) or started[-1])
    with pytest.raises(KeyboardInterrupt):
        ccompile._run_compilers([[sys.executable, "-c", "import time; time.sleep(60)"]] * 2, str(tmp_path),
                                interrupt)
    # killed (SIGKILL) and reaped, not waited for: a compiler that ran to its end would exit 0
    assert [run.returncode for run in started] == [-signal.SIGKILL] * 2



class _Clock:
    """A wall clock the test moves by hand (no test here waits on real time)."""

    def __init__(self):
        self.now = 1000.0

    def __call__(self):
        return self.now


def test_long_runs_outside_a_terminal_say_how_far_they_are(monkeypatch, capsys):
    """A run of the NumPy backend printed nothing for 96 s when its output went to a log (the bar
    is drawn on a terminal only): away from a terminal, a line every 10 s of wall time, and the
    end; work shorter than that prints nothing."""
    from gpmegen.runtime import integrators

    clock = _Clock()
    monkeypatch.setattr(integrators.loop.time, "perf_counter", clock)
    bar = integrators.loop.Progress(10.0, "n_rfe = 5, t (s)", enabled=False,
                                    lines_every=integrators.loop.PROGRESS_LINES)
    for wall, done in ((3, 0.5), (9.9, 1.0), (10.5, 1.2), (15, 2.0), (20.6, 3.0), (30, 10.0), (31, 10.0)):
        clock.now = 1000.0 + wall
        bar.update(done)
    lines = capsys.readouterr().err.splitlines()
    assert lines == ["n_rfe = 5, t (s): 1.2 of 10 (12 %) in 10 s, about 77 s left",
                     "n_rfe = 5, t (s): 3 of 10 (30 %) in 21 s, about 48 s left",
                     "n_rfe = 5, t (s): 10 of 10 (100 %) in 30 s, done"]
    clock.now = 1000.0
    short = integrators.loop.Progress(10.0, "short", enabled=False, lines_every=integrators.loop.PROGRESS_LINES)
    for wall, done in ((2, 5.0), (4, 10.0)):
        clock.now = 1000.0 + wall
        short.update(done)
    assert capsys.readouterr().err == ""
