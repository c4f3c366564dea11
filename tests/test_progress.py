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
def test_building_and_compiling_say_what_they_do(env, monkeypatch, tmp_path):
    monkeypatch.setenv("GPMEGEN_CACHE", str(tmp_path / "cache"))  # a cache of its own: the compile happens here
    monkeypatch.setattr(ccompile, "HEARTBEAT", 0.01)  # a line at every poll of a ~1 s compile
    lines = []
    gpmegen.load(nrfe=1, backend="c", progress=lines.append)
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
    gpmegen.load(nrfe=1, backend="c", progress=lines.append)  # up to date and cached: nothing to say
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
