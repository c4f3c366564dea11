"""The same motion of one model at several discretizations (*levels*, one per ``n_rfe``), run with
the same settings, one after the other or at once (the levels are independent runs). At once:
where the runs' loops are compiled (:func:`compiled_loops`), which let go of Python's lock while
they integrate, on threads of this process, which neither start processes nor load the models a
second time; else on a pool of local processes (:func:`gpmegen.analysis.sweep.pools.local_pool`).
A level's results are the same bytes every way: the same run (:func:`gpmegen.analysis.run.runs.run`)
of the same generated code.
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading
from dataclasses import dataclass
from pathlib import Path

from ... import limits
from ...errors import ExtrapolationError
from ...runtime import integrators
from ..post.coordinates import joint_names, point_names
from ..run import opening, runs
from ..run.runspec import RunSpec
from ..sweep import pools
from ..sweep.workers import NotATerminal


@dataclass
class Level:
    """One discretization: ``nrfe``, the symbolic ``model`` (:class:`gpmegen.model.Model`), the
    ``loaded`` model its run ended with, the run's ``results`` dict, its wall ``seconds`` and the
    parameters its start set (``set_at_start``, see :attr:`gpmegen.analysis.run.cases.Case.start_constants`)."""

    nrfe: int
    model: object
    loaded: object
    results: dict
    seconds: float = float("nan")
    set_at_start: tuple = ()


@dataclass(frozen=True)
class LevelTask:
    """What a pool's process needs to make one level's run: the case (``model_file``, None for
    the reference manipulator, and ``nrfe``), the run's ``spec``
    (:class:`gpmegen.analysis.run.runspec.RunSpec`), ``backend`` and parameter values, and where it
    is written (``out``, None: nowhere); ``no_limits``: the levels were started within
    :func:`gpmegen.limits.lifted`, which another process does not see."""

    model_file: str | None
    nrfe: int
    spec: RunSpec
    backend: str
    params: tuple
    out: str | None
    no_limits: bool = False

    @property
    def digest(self) -> str:
        """Which generated model the task runs (one per level)."""
        return f"{self.model_file}:{self.nrfe}"

    def inputs(self) -> dict:
        return {"nrfe": self.nrfe}


def _quiet(message: str) -> None:
    """Progress of a run in a pool's process: dropped (the levels report as they end)."""


def prepare(task: LevelTask) -> None:
    """Load the level's model in this process, building and compiling it when missing."""
    with limits.lifted() if task.no_limits else contextlib.nullcontext():
        opening.case_for(task.model_file, task.nrfe).load(task.backend, dict(task.params), _quiet)


def _run(task: LevelTask, case) -> runs.Run:
    """The level's run of ``case`` (and its results written to ``task.out``)."""
    with limits.lifted() if task.no_limits else contextlib.nullcontext():
        return runs.run(case, task.spec, task.backend, dict(task.params), task.out, _quiet)


def _row(run: runs.Run) -> dict:
    return {"status": str(run.results["status"]), "results": run.results, "seconds": run.wall,
            "written": [str(path) for path in run.written]}


def perform(task: LevelTask) -> dict:
    """Make the level's run (and write it to ``task.out``); returns its ``results``, wall
    ``seconds`` and the files ``written``."""
    return _row(_run(task, opening.case_for(task.model_file, task.nrfe)))


def level_path(out, nrfe) -> Path | None:
    """Where the run of one level is written beside the extrapolation ``out`` (.npz; None: nowhere)."""
    if out is None:
        return None
    out = Path(out)
    return out.with_name(f"{out.stem}_nrfe{nrfe}{out.suffix}")


def pool_size(levels: int, workers: int | None = None) -> int:
    """Processes (or threads) for ``levels`` runs: ``workers``, else one per core, never more than
    the levels."""
    return max(1, min(levels, workers or os.cpu_count() or 1))


def compiled_loops(method: str, backend: str, actuated: bool) -> bool:
    """Whether runs of ``method`` on ``backend`` integrate in compiled loops, which release
    Python's lock (cffi's calls do), so that runs on threads of one process go on at once: RK4 and
    the compiled methods on the C backend; with the constraints realized by inputs (``actuated``),
    those whose loop runs the actuated realization too (RK4, DOP853; the others integrate the ideal GPME only)."""
    integrator = integrators.get(method)
    return backend == "c" and integrator.c_loop and (not actuated or integrator.actuated_loop)


def _on_threads(tasks, levels_cases, size) -> list:
    """The runs of ``tasks`` (``levels_cases``: n_rfe -> case) on ``size`` threads of this
    process, the finest levels first (the longest runs: so the threads end together); returns
    each task's :class:`gpmegen.analysis.run.runs.Run` in the order of ``tasks``, or raises the first
    task's error. No thread draws a progress bar (``sys.stderr`` is no terminal meanwhile)."""
    pending = sorted(tasks, key=lambda task: -task.nrfe)
    finished, lock = {}, threading.Lock()

    def work():
        while True:
            with lock:
                if not pending:
                    return
                task = pending.pop(0)
            try:
                finished[task.nrfe] = (_run(task, levels_cases[task.nrfe]), None)
            except BaseException as exc:  # raised in the calling thread below
                finished[task.nrfe] = (None, exc)

    threads = [threading.Thread(target=work, daemon=True) for _ in range(size)]
    stderr, sys.stderr = sys.stderr, NotATerminal(sys.stderr)
    try:
        for thread in threads:
            thread.start()
        for thread in threads:
            while thread.is_alive():  # in slices, so that Ctrl-C reaches this thread
                thread.join(0.1)
    finally:
        sys.stderr = stderr
    for task in tasks:
        run, error = finished[task.nrfe]
        if error is not None:
            raise error
    return [finished[task.nrfe][0] for task in tasks]


def check_same_model(models: dict) -> None:
    """Refuse symbolic ``models`` (n_rfe → :class:`gpmegen.model.Model`) that are not one model
    at several discretizations: different joints, points or parameter defaults. Cheap: made
    before any level runs."""
    check_alike({nrfe: (joint_names(m), point_names(m), m.defaults) for nrfe, m in models.items()})


def check_alike(described: dict) -> None:
    """ExtrapolationError unless every n_rfe's (joints, points, parameter values) are the first's."""
    (first, reference), *others = described.items()
    for nrfe, description in others:
        for what, mine, theirs in zip(("joints", "points", "parameter values"), description, reference):
            if mine != theirs:
                raise ExtrapolationError(f"n_rfe = {nrfe} and n_rfe = {first}: different {what}, "
                                         f"not one model at two discretizations; extrapolate runs of one model file")


def run_levels(model_file, nrfe, spec, backend, overrides, out, progress, workers=None) -> list[Level]:
    """The run ``spec`` (a :class:`gpmegen.analysis.run.runspec.RunSpec`, its start one the case
    takes) of the case ``model_file`` (None: the reference manipulator) at each ``nrfe`` on
    ``backend`` with the parameter values ``overrides`` (:func:`gpmegen.analysis.run.runs.run`), each
    written to :func:`level_path` of ``out`` (None: kept in memory only), :func:`pool_size` at
    once (1: one after the other in this process): on as many threads of this process where the
    loops are compiled (:func:`compiled_loops`), else on as many processes. Returns the
    :class:`Level` of each, by ascending ``nrfe``."""
    levels_cases = {n: opening.case_for(model_file, n) for n in sorted(set(nrfe))}  # each file read once here
    check_same_model({n: case.model for n, case in levels_cases.items()})
    tasks = [LevelTask(None if model_file is None else str(model_file), n, spec, backend,
                       tuple(sorted(overrides.items())),
                       None if out is None else str(level_path(out, n)), limits.are_lifted())
             for n in sorted(set(nrfe))]
    done, started = {}, {}

    def record(task, row):
        if row["status"] == "died":  # the others' errors are raised
            raise ExtrapolationError(f"n_rfe = {task.nrfe}: {row['message']}")
        done[task.nrfe] = row
        written = f"; wrote {', '.join(row['written'])}" if row["written"] else ""
        progress(f"n_rfe = {task.nrfe}: t = {row['results']['t'][-1]:.6g} s in {row['seconds']:.1f} s{written}")

    size = pool_size(len(tasks), workers)
    actuated = (bool(spec.actuated) if spec.actuated is not None
                else any(len(case.actuators) for case in levels_cases.values()))
    if size == 1 or compiled_loops(spec.method, backend, actuated):  # the run's own loaded model is the level's
        if size > 1:
            progress(f"{len(tasks)} levels on {size} threads")
        done_runs = ([_run(task, levels_cases[task.nrfe]) for task in tasks] if size == 1
                     else _on_threads(tasks, levels_cases, size))
        for task, run in zip(tasks, done_runs):
            started[task.nrfe] = run.started
            record(task, _row(run))
    else:
        progress(f"{len(tasks)} levels on {size} processes")
        pools.local_pool(tasks, record, size, prepare=prepare, perform=perform)
    levels = []
    for task in tasks:
        case = levels_cases[task.nrfe]
        loaded = started.get(task.nrfe)
        if loaded is None:  # run in another process: loaded here (built by the run: loads at once)
            loaded = case.started(backend, spec.start or case.starts[0], dict(overrides), _quiet).model
        levels.append(Level(task.nrfe, case.model, loaded, done[task.nrfe]["results"], done[task.nrfe]["seconds"],
                            case.start_constants))
    return levels


def simulate_levels(model_file, nrfe, spec, backend="numpy", params=None, workers=None) -> list[Level]:
    """The motion of a model file at each ``nrfe`` as ``spec`` says (a
    :class:`gpmegen.analysis.run.runspec.RunSpec`; its ``start`` as
    :func:`gpmegen.analysis.run.study.file_start` takes it, None: "none"), in memory (no files), with
    the parameter overrides ``params``, ``workers`` at once (default: one per core, at most one
    per level; on threads or processes, see :func:`run_levels`). Pass the levels to
    :func:`gpmegen.analysis.discretization.extrapolate.extrapolate`."""
    spec = spec if spec.start is not None else spec.with_start("none")
    return run_levels(model_file, nrfe, spec, backend, dict(params or {}), None, _quiet, workers)


__all__ = ["Level", "LevelTask", "compiled_loops", "level_path", "pool_size", "run_levels", "simulate_levels"]
