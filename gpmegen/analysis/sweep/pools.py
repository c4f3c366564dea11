"""Where a sweep's runs are made: in this process (one worker), in a local pool of processes
(the default, one per core), or on a Dask distributed cluster. Each calls ``record(task, row)``
as runs end, in the order they end; Ctrl-C stops the runs in progress (the complete ones are
kept) and is raised again."""

from __future__ import annotations

import multiprocessing
import sys
from concurrent.futures import ProcessPoolExecutor, as_completed
from concurrent.futures.process import BrokenProcessPool
from pathlib import Path

from . import outcomes, workers
from .plan import SweepError

DIED = "the process making this run died (a crash in compiled code, or it was killed); run the sweep again to retry it"


def models(tasks) -> list:
    """One task of each model among ``tasks``."""
    return list({task.digest: task for task in tasks}.values())


def in_process(tasks, record, progress) -> None:
    """The runs one after the other in this process; Ctrl-C during one ends the sweep."""
    for task in models(tasks):
        workers.prepare(task, progress)
    stderr, sys.stderr = sys.stderr, workers.NotATerminal(sys.stderr)  # no run draws its own progress bar
    try:
        for task in tasks:
            row = workers.perform(task)
            if row["status"] == "interrupted":
                raise KeyboardInterrupt
            record(task, row)
    finally:
        sys.stderr = stderr


def local_pool(tasks, record, n_workers: int, prepare=workers.prepare, perform=workers.perform) -> None:
    """The runs on ``n_workers`` processes of this machine. The processes are spawned (not
    forked): each starts clean and loads the C library itself, with the environment of now. Each
    model is first loaded by one of them alone (``prepare(task)``), so that one process builds and
    compiles it when it is missing (the others start up meanwhile); then ``perform(task)`` makes
    each run and returns its row. Both are functions of a module, so that the processes find them."""
    context = multiprocessing.get_context("spawn")
    pool = ProcessPoolExecutor(max_workers=n_workers, mp_context=context,
                               initializer=workers.initialize_pool_process)
    futures = {}
    try:
        for task in models(tasks):
            pool.submit(prepare, task).result()
        futures = {pool.submit(perform, task): task for task in tasks}
        for future in as_completed(futures):
            try:
                row = future.result()
            except BrokenProcessPool:
                row = {**futures[future].inputs(), **outcomes.failure(DIED)}
            record(futures[future], row)
    except BaseException:
        # the runs in progress are stopped, not waited for (their results files are written
        # atomically: none is left half-written); the pool has no public way to stop them
        processes = list((getattr(pool, "_processes", None) or {}).values())
        pool.shutdown(wait=False, cancel_futures=True)
        for process in processes:
            process.terminate()
        raise
    pool.shutdown()


def cluster_workers(scheduler: str):
    """A Dask client of the scheduler at ``scheduler`` (an address, or a scheduler file)."""
    try:
        from distributed import Client
    except ImportError:
        raise SweepError("--scheduler runs on Dask, which is not installed: pip install 'gpmegen[cluster]'") \
            from None
    where = {"scheduler_file": scheduler} if Path(scheduler).is_file() else {"address": scheduler}
    try:
        return Client(**where, timeout=30)
    except (OSError, TimeoutError, ValueError) as exc:
        raise SweepError(f"cannot reach the Dask scheduler at {scheduler} ({' '.join(str(exc).split())}); start one "
                         f"with 'dask scheduler' and give its address (tcp://HOST:PORT) or its scheduler file") \
            from None


def cluster_size(client) -> int:
    """The number of runs a Dask cluster makes at once: its workers' threads."""
    return max(1, sum(client.nthreads().values()))


def on_cluster(tasks, record, client) -> None:
    """The runs on the workers of a Dask ``client``'s cluster; each worker process loads each
    model once (:mod:`gpmegen.analysis.sweep.workers`)."""
    from distributed import as_completed as completed

    futures = {client.submit(workers.perform, task, pure=False): task for task in tasks}
    try:
        for future in completed(list(futures)):
            try:
                row = future.result()
            except Exception as exc:  # the worker died, or the cluster lost it
                row = {**futures[future].inputs(), **outcomes.failure(f"{DIED} ({type(exc).__name__}: {exc})")}
            record(futures[future], row)
    except BaseException:
        client.cancel(list(futures))
        raise
