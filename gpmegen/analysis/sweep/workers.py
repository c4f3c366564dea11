"""A sweep's run as a worker process makes it: the run of :func:`gpmegen.analysis.run.runs.run`,
the same that ``gpmegen simulate`` makes, with the model loaded (built, compiled, probed) once
per process and model and bound to each run's parameter values by ``with_params``.

:func:`perform` is what a local pool's processes and a Dask cluster's workers call; it never
raises for a run that fails, it returns the failure as the run's row.
"""

from __future__ import annotations

import contextlib
import json
import signal
import socket
import sys
import threading
import time
from pathlib import Path

from ... import limits
from ...errors import GpmegenError
from ...fileio import atomic_write_bytes
from ..run import opening, runs
from . import outcomes
from .plan import MANIFEST, SweepError, Task

_lock = threading.Lock()  # a Dask worker may run several tasks at once, in threads
_cases: dict = {}   # (model file, nrfe) -> case whose loads come from _models
_models: dict = {}  # (input hash, backend) -> the model loaded at its default parameter values


def _quiet(message: str) -> None:
    """Progress messages of a run inside a sweep: dropped (the sweep shows its own progress)."""


def _loading_once(case, digest: str):
    """``case`` with its loads made once per process: the first loads the model at its default
    parameter values, every load returns that model ``with_params`` of its own values (so the
    same generated code and compiled library serve every run)."""
    load_anew = case.load

    def load(backend, params, progress):
        with _lock:
            key = (digest, backend)
            if key not in _models:
                _models[key] = load_anew(backend, {}, progress)
        return _models[key].with_params(**params)

    case.load = load  # the case's start calls self.load: this instance's loads come from here
    return case


def _case(task: Task):
    with _lock:
        key = (task.model_file, task.nrfe)
        if key not in _cases:
            case = opening.case_for(task.model_file, task.nrfe)
            _ = case.model  # a model file is read here, once, not by two threads at once
            _cases[key] = _loading_once(case, task.digest)
        return _cases[key]


def prepare(task: Task, progress=_quiet) -> None:
    """Load the model of ``task`` in this process, building and compiling it when missing (with
    ``progress`` messages), so that the runs find it ready."""
    _case(task).load(task.backend, {}, progress)


def perform(task: Task) -> dict:
    """Make the run ``task`` and write its results pair (:func:`gpmegen.analysis.run.runs.run`);
    returns its summary row (:func:`gpmegen.analysis.sweep.outcomes.outcomes`, or a failure
    with its one-line message) with its inputs and wall time, and writes it beside the results
    (``task.row_file``) when the run is complete."""
    began = time.perf_counter()
    try:
        if not (Path(task.folder) / MANIFEST).is_file():
            raise SweepError(f"the sweep's folder {task.folder} is not there on {socket.gethostname()}: a sweep on a "
                             f"cluster needs an --out folder that every worker shares")
        with limits.lifted() if task.no_limits else contextlib.nullcontext():
            done = runs.run(_case(task), task.spec, task.backend, dict(task.params), task.out, _quiet)
        row = outcomes.outcomes(done.results, task.driven)
    except GpmegenError as exc:
        row = outcomes.failure(str(exc))
    except Exception as exc:  # a defect: recorded, so that the other runs go on
        row = outcomes.failure(f"internal error: {type(exc).__name__}: {exc} (this is a bug; report it)")
    row = {**task.inputs(), **row, "wall_s": time.perf_counter() - began}
    if row["status"] == "complete":  # written here, after the results: a run with its row is complete
        atomic_write_bytes(task.row_file, (json.dumps(row, indent=1) + "\n").encode())
    return row


class NotATerminal:
    """A stream that writes to ``stream`` but is no terminal, so that runs in a pool's processes
    draw no progress bars of their own over the sweep's."""

    def __init__(self, stream):
        self._stream = stream

    def isatty(self) -> bool:
        return False

    def __getattr__(self, name):
        return getattr(self._stream, name)


def initialize_pool_process() -> None:
    """Set up a local pool's process: Ctrl-C is the sweep's to handle (it stops the pool), and
    stderr is no terminal."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    sys.stderr = NotATerminal(sys.stderr)


def serve(pipe, prepare, perform) -> None:
    """The loop of a local pool's process: ``(kind, task)`` from ``pipe``, ``prepare(task)`` or
    ``perform(task)``, and back ``("done", value)`` or ``("raised", exception)``; until the
    pool closes its end."""
    initialize_pool_process()
    while True:
        try:
            kind, task = pipe.recv()
        except (EOFError, OSError):
            return
        try:
            answer = ("done", (prepare if kind == "prepare" else perform)(task))
        except Exception as exc:
            answer = ("raised", exc)
        try:
            pipe.send(answer)
        except (BrokenPipeError, OSError):
            return
        except Exception:  # an exception that cannot be pickled: its words, as an error
            pipe.send(("raised", RuntimeError(f"{type(answer[1]).__name__}: {answer[1]}")))
