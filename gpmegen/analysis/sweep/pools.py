"""Where a sweep's runs are made: in this process (one worker), in a local pool of processes
(the default, one per core), or on a Dask distributed cluster. Each calls ``record(task, row)``
as runs end, in the order they end; Ctrl-C stops the runs in progress (the complete ones are
kept) and is raised again."""

from __future__ import annotations

import collections
import multiprocessing
import signal
import sys
import time
from multiprocessing import connection
from pathlib import Path

from ... import extras
from . import outcomes, workers
from .plan import SweepError

#: The message of a run whose process died; ``how``: :func:`died`.
DIED = "the process making this run was {how} (a crash in compiled code, or a kill from outside); the sweep's next " \
       "call makes it again"


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


class _Process:
    """A process of a local pool, the pipe to it, and the task it is on (None: idle)."""

    def __init__(self, context, prepare, perform):
        ours, theirs = context.Pipe()
        self.process = context.Process(target=workers.serve, args=(theirs, prepare, perform), daemon=True)
        self.process.start()
        theirs.close()  # so that a recv here ends when the process is gone
        self.pipe = ours
        self.task = None
        self.began = 0.0

    def give(self, kind: str, task) -> None:
        self.pipe.send((kind, task))
        self.task, self.began = task, time.perf_counter()

    def answer(self):
        """``(True, value)`` when the task ended (its value, or its exception raised), ``(False,
        why)`` when the process died on it."""
        try:
            kind, value = self.pipe.recv()
        except (EOFError, OSError):
            self.process.join()
            return False, died(self.process.exitcode)
        if kind == "raised":
            raise value
        return True, value


def died(exitcode) -> str:
    """Why a process ended, from its exit code (negative: the signal that killed it)."""
    if exitcode is not None and exitcode < 0:
        try:
            return f"killed by {signal.Signals(-exitcode).name}"
        except ValueError:
            return f"killed by signal {-exitcode}"
    return f"ended with exit status {exitcode}"


def local_pool(tasks, record, n_workers: int, prepare=workers.prepare, perform=workers.perform) -> None:
    """The runs on ``n_workers`` processes of this machine. The processes are spawned (not
    forked): each starts clean and loads the C library itself, with the environment of now. Each
    model is first loaded by one of them alone (``prepare(task)``), so that one process builds and
    compiles it when it is missing (the others start up meanwhile); then ``perform(task)`` makes
    each run and returns its row. Both are functions of a module, so that the processes find them.

    A process that dies on a run (a crash in compiled code, a kill) makes that run's row ``died``
    with the signal, and another process takes its place. When this function is left by an
    exception (Ctrl-C), every process is killed and reaped first: nothing of the pool writes
    after it returns."""
    context = multiprocessing.get_context("spawn")
    pool = [_Process(context, prepare, perform) for _ in range(n_workers)]
    queue = collections.deque(tasks)
    clean = False
    try:
        for task in models(tasks):
            pool[0].give("prepare", task)
            ended, _ = pool[0].answer()
            pool[0].task = None
            if not ended:  # its runs will tell, each with its own row
                pool[0] = _Process(context, prepare, perform)
        while queue or any(p.task is not None for p in pool):
            for p in pool:
                if p.task is None and queue:
                    p.give("perform", queue.popleft())
            busy = [p for p in pool if p.task is not None]
            ready = connection.wait([p.pipe for p in busy] + [p.process.sentinel for p in busy])
            for k, p in enumerate(pool):
                if p.task is None or (p.pipe not in ready and p.process.sentinel not in ready):
                    continue
                task, began = p.task, p.began
                ended, value = p.answer()
                p.task = None
                if not ended:
                    value = {**task.inputs(), **outcomes.died(DIED.format(how=value)),
                             "wall_s": time.perf_counter() - began}
                    p.pipe.close()
                    pool[k] = _Process(context, prepare, perform) if queue else p
                record(task, value)
        clean = True
    finally:
        if not clean:  # all at once: SIGKILL stops a run now, and it writes nothing more
            for p in pool:
                p.process.kill()
        for p in pool:
            p.pipe.close()  # an idle process reads the end of its pipe and returns
            p.process.join()


def cluster_workers(scheduler: str):
    """A Dask client of the scheduler at ``scheduler`` (an address, or a scheduler file)."""
    Client = extras.require("distributed", "a sweep on a Dask cluster (--scheduler)").Client
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
                row = {**futures[future].inputs(), **outcomes.died(_lost(exc)), "wall_s": None}
            record(futures[future], row)
    except BaseException:
        client.cancel(list(futures))
        raise


def _lost(exc) -> str:
    """Why a Dask cluster gave no row for a run: its worker died (the signal is in that worker's
    log, not here), or the cluster lost the task otherwise."""
    last = getattr(getattr(exc, "last_worker", None), "address", None)
    if last is not None:  # KilledWorker
        return (f"the Dask worker making this run died ({exc.allowed_failures + 1} tried it, the last at {last}; "
                f"its log says why); the sweep's next call makes it again")
    return f"the Dask cluster lost this run ({type(exc).__name__}: {exc}); the sweep's next call makes it again"
