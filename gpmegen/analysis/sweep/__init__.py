"""Parameter sweeps: many runs of one case (the reference manipulator or a model file), each
with its own parameter values and rfe count, on all local cores or on a Dask cluster.

:func:`sweep` plans the runs (:mod:`.plan`), refuses up front what cannot finish
(:func:`gpmegen.limits.check_sweep`), claims the output folder (its manifest), skips the runs
a previous call of the same sweep completed, makes the others (:mod:`.pools`, :mod:`.workers`)
and writes the summary (:mod:`.outcomes`). Each run's results are those ``gpmegen simulate``
writes for the same inputs, bit for bit: the same code makes them.
"""

from __future__ import annotations

import hashlib
import json
import os
import time
from collections.abc import Iterable, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from ... import limits
from ...codegen.render import input_hash
from ...errors import GpmegenError
from ...model.size import coordinate_count
from ...runtime.integrators.loop import Progress, interruptible
from ...runtime.loader import BACKENDS
from ..run.opening import case_for
from ..run.runspec import NAMES, RunSpec, split_options
from . import outcomes, plan, pools
from .plan import Range, SweepError

__all__ = ["sweep", "Summary", "Range", "SweepError", "SweepFailures"]


class SweepFailures(GpmegenError):
    """A sweep ended with runs that failed, diverged or stopped; its summary was written."""


@dataclass
class Summary:
    """What a sweep made: ``columns`` (name → one value per run, None where it does not apply;
    see :mod:`gpmegen.analysis.sweep.outcomes`), the summary files ``written``, the counts of
    ``runs``, ``failed`` (not complete) and ``skipped`` (complete before), the ``workers`` used
    and the sweep's ``wall`` time (s)."""

    columns: dict
    written: list
    runs: int
    failed: int
    skipped: int
    workers: int
    wall: float


def _file_digest(model_file) -> str | None:
    return hashlib.sha256(Path(model_file).read_bytes()).hexdigest() if model_file else None


def _plan_models(model_file, nrfe_values, start):
    """Per rfe count: the case, its start and its model's input hash (a bad model or start is
    refused here, before anything runs)."""
    models = []
    for nrfe in nrfe_values:
        case = case_for(model_file, nrfe)
        chosen = start or case.starts[0]
        if chosen not in case.starts:
            raise SweepError(case.start_refusal or f"start {chosen!r}: use one of {', '.join(case.starts)}")
        models.append((case, chosen, input_hash(case.model, BACKENDS)))
    return models


def _check_parameters(models, params) -> None:
    names = {p.name for case, _, _ in models for p in case.model.parameters}
    unknown = [name for name in params if name not in names]
    if unknown:
        raise SweepError(f"unknown parameter {', '.join(map(repr, unknown))}; the model's parameters are "
                         f"{', '.join(sorted(names))}")


#: A sweep's own options (beyond its runs' :class:`~gpmegen.analysis.run.runspec.RunSpec`), with their defaults.
OPTIONS = {"backend": "c", "samples": None, "seed": 0, "sampling": "lhs", "workers": None, "scheduler": None,
           "progress": None}
#: The fields of a run's spec a sweep's runs take (the others keep their defaults).
RUN_FIELDS = ("t_end", "dt", "save_every", "method", "start", "repartition")


def sweep(out: str | Path, params: Mapping[str, object], spec: RunSpec | None = None, *,
          model_file: str | Path | None = None, nrfe: Iterable[int] | None = None, **options: Any) -> Summary:
    """Run every combination of ``params`` (name → a value or a list of values) for each rfe
    count in ``nrfe`` (a list; None: the case's own), or ``samples`` draws (``sampling`` "lhs"
    or "random", from ``seed``) of the ranges ``params`` gives as ``(low, high)``; write each
    run's results into ``out``/runs and the summary into ``out``. Each run is ``spec`` (a
    :class:`~gpmegen.analysis.run.runspec.RunSpec`; of its fields, :data:`RUN_FIELDS`) with the fields
    ``options`` give (``t_end``, ``dt``, ``save_every``, ``method``, ``start``, ``repartition``, as
    ``gpmegen simulate`` takes them) on ``backend`` (default "c"). ``workers``: local processes
    (default: one per core; 1: in this process); ``scheduler``: the address or scheduler file of
    a Dask cluster to run on instead. ``progress`` takes one-line messages. Returns the
    :class:`Summary`; raises :class:`SweepFailures` (after writing the summary) when some runs did
    not complete."""
    spec, chosen = split_options(spec, options, OPTIONS, lambda names: (
        f"unknown sweep option {names}; a sweep's options are {', '.join((*RUN_FIELDS, *OPTIONS))}"))
    default = RunSpec.of(None, t_end=spec.t_end, dt=spec.dt, method=spec.method)
    others = [name for name in NAMES if name not in RUN_FIELDS and getattr(spec, name) != getattr(default, name)]
    if others:
        raise SweepError(f"{', '.join(others)}: not taken by a sweep's runs, which take {', '.join(RUN_FIELDS)}; "
                         f"leave {'them' if len(others) > 1 else 'it'} out")
    backend, samples, seed, sampling = chosen["backend"], chosen["samples"], chosen["seed"], chosen["sampling"]
    workers, scheduler, progress = chosen["workers"], chosen["scheduler"], chosen["progress"]
    t_end, dt, save_every, method = spec.t_end, spec.dt, spec.save_every, spec.method
    start, repartition = spec.start, spec.repartition
    say = progress or (lambda message: None)
    began = time.perf_counter()
    _check_draws(samples, seed, sampling)
    params = plan.normalize(dict(params), samples)
    nrfe_values = list(dict.fromkeys(nrfe)) if nrfe else [None]
    model_file = str(Path(model_file).resolve()) if model_file else None
    models = _plan_models(model_file, nrfe_values, start)
    _check_parameters(models, params)
    settings = dict(t_end=t_end, dt=dt, save_every=save_every, method=method, backend=backend,
                    repartition=repartition)
    arguments = {"model_file": model_file, "model_sha256": _file_digest(model_file), "nrfe": nrfe_values,
                 "params": params, "samples": samples, "seed": seed if samples is not None else None,
                 "sampling": sampling if samples is not None else None, "start": [s for _, s, _ in models],
                 **settings}
    folder = Path(out)
    client = pools.cluster_workers(scheduler) if scheduler else None
    try:
        size = pools.cluster_size(client) if client else max(1, workers or os.cpu_count() or 1)
        _check_limits(models, plan.count(params, samples), size, settings)
        plan.claim(folder, arguments)
        tasks = _tasks(models, plan.points(params, samples, seed, sampling), arguments, folder)
        rows, todo = _completed(tasks)
        if rows:
            say(f"{len(rows)} of {len(tasks)} runs complete already (kept)")
        failed = _make(tasks, todo, rows, client, size, say)
    finally:
        if client is not None:
            client.close()
    ordered = [rows[task.run_id] for task in tasks]
    written = outcomes.write(ordered, folder)
    if failed:
        first = next(row for row in ordered if row["status"] != "complete")
        raise SweepFailures(f"{failed} of {len(tasks)} runs did not complete (first: run {first['run']}, "
                            f"{first['status']}: {first['message']}); summary in {written[0]}")
    return Summary(outcomes.columns(ordered), written, len(tasks), failed, len(tasks) - len(todo),
                   min(size, max(1, len(todo))), time.perf_counter() - began)


def _check_draws(samples, seed, sampling) -> None:
    if samples is not None and samples < 1:
        raise SweepError(f"--samples {samples}: draw at least one sample")
    if seed < 0:
        raise SweepError(f"--seed {seed}: give a whole number >= 0")
    if sampling not in plan.SAMPLINGS:
        raise SweepError(f"--sampling {sampling!r}: use {' or '.join(plan.SAMPLINGS)}")


def _check_limits(models, per_model: int, size: int, settings: dict) -> None:
    """Refuse a sweep that cannot finish (:func:`gpmegen.limits.check_sweep`): ``per_model`` runs
    of each model on ``size`` workers."""
    spec = RunSpec(t_end=settings["t_end"], dt=settings["dt"], save_every=settings["save_every"],
                   method=settings["method"])
    limits.check_sweep([(per_model, limits.run_estimate(coordinate_count(case.model),
                                                        len(case.model.constraints), spec, settings["backend"]))
                        for case, _, _ in models], size)


SETTINGS = ("t_end", "dt", "save_every", "method", "backend", "repartition")


def _tasks(models, points, arguments, folder) -> list:
    """One :class:`~.plan.Task` per rfe count and parameter point."""
    settings = {key: arguments[key] for key in SETTINGS}
    tasks = []
    for case, start, digest in models:
        nrfe = getattr(case, "nrfe", None)
        driven = tuple(d.coordinate for d in case.model.drives)
        for point in points:
            identity = {"model": digest, "model_sha256": arguments["model_sha256"], "nrfe": nrfe, "params": point,
                        "start": start, **settings}
            tasks.append(plan.Task(plan.run_id(identity), arguments["model_file"], nrfe, tuple(point.items()), start,
                                   folder=str(folder.resolve()), digest=digest, driven=driven,
                                   no_limits=limits.are_lifted(), **settings))
    return tasks


def _completed(tasks) -> tuple[dict, list]:
    """The rows of the runs complete already (results and row both written), and the others."""
    rows, todo = {}, []
    for task in tasks:
        try:
            row = json.loads(task.row_file.read_text(encoding="utf-8")) if task.out.is_file() else None
        except (OSError, ValueError):
            row = None
        if row is not None and row.get("status") == "complete" and row.get("run") == task.run_id:
            rows[task.run_id] = row
        else:
            todo.append(task)
    return rows, todo


def _make(tasks, todo, rows, client, size, say) -> int:
    """Make the runs ``todo``, adding their rows to ``rows``; the number of all runs not complete.
    Each complete run's row is written by its worker (:func:`.workers.perform`)."""
    total = len(tasks)
    bar = Progress(total, "sweep")
    done = [len(rows)]
    for task in todo:  # what an earlier call of the sweep, stopped or killed, left of these runs
        _remove(task.leftovers())

    def record(task, row):
        rows[task.run_id] = row
        done[0] += 1
        if bar.enabled:
            bar.update(done[0])
        else:
            state = row["status"] + (f": {row['message']}" if row.get("message") else "")
            inputs = [f"nrfe = {task.nrfe}"] if task.nrfe is not None else []
            inputs += [f"{k} = {v:g}" for k, v in task.params]
            wall = f" ({row['wall_s']:.2f} s)" if row.get("wall_s") is not None else ""
            say(f"run {done[0]}/{total} ({', '.join([task.run_id, *inputs])}): {state}{wall}")

    n_workers = min(size, len(todo))
    if todo:
        where = f"on the Dask cluster at {client.scheduler.address}" if client else \
            "in this process" if n_workers == 1 else f"on {n_workers} local processes"
        say(f"{len(todo)} runs {where}")
    try:
        with interruptible():  # SIGTERM stops the sweep as Ctrl-C does
            if client is not None:
                pools.on_cluster(todo, record, client)
            elif n_workers <= 1:
                pools.in_process(todo, record, say)
            else:
                pools.local_pool(todo, record, n_workers)
    except KeyboardInterrupt:  # the workers are stopped: nothing writes into the folder any more
        bar.close()
        for task in todo:
            if task.run_id not in rows:  # the runs stopped midway (a partial result is no run's outcome)
                _remove(task.leftovers())
        kept = len(_completed(tasks)[0])
        raise KeyboardInterrupt(f"{kept} of {total} runs complete and kept; run the same sweep again to make the "
                                f"others") from None
    bar.close()
    return sum(1 for row in rows.values() if row["status"] != "complete")


def _remove(paths) -> None:
    for path in paths:
        path.unlink(missing_ok=True)
