"""Sweeps: the same runs give the same summary in this process, on a local pool, on a Dask
cluster started here and on scheduler and workers started as separate processes, and the same
numbers as each run made alone with ``gpmegen simulate``; an interrupted sweep resumes; a failing
run is recorded and the sweep goes on; a folder of another sweep and a sweep beyond the limits
are refused."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pyarrow.parquet as pq
import pytest

import gpmegen
from gpmegen.analysis.post import results as results_io
from gpmegen.analysis.sweep import SweepFailures, outcomes, plan
from gpmegen.cli import main
from gpmegen.limits import LimitError

GPMEGEN = [sys.executable, "-m", "gpmegen.cli"]
EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
#: Two rfe counts and two moduli of the arm, 0.02 s each.
GRID = dict(nrfe=[1, 2], params={"E2": [7e10, 7e9]}, t_end=0.02, dt=1e-4, save_every=10, backend="c")


def _same_numbers(summary_columns):
    """The summary without the wall times (the only column that depends on the machine's load)."""
    return {name: values for name, values in summary_columns.items() if name != "wall_s"}


@pytest.fixture(scope="module")
def reference(tmp_path_factory):
    """The grid swept in this process, one run after the other."""
    folder = tmp_path_factory.mktemp("sweep") / "alone"
    return folder, gpmegen.sweep(out=folder, workers=1, **GRID)


def test_values_parse_to_the_runs_asked_for():
    assert plan.parse_param("E2=7e10, 7e9") == ("E2", [7e10, 7e9])
    assert plan.parse_param("tdr0=1:2:5") == ("tdr0", [1.0, 1.25, 1.5, 1.75, 2.0])
    assert plan.parse_param("tdr0=1:2") == ("tdr0", plan.Range(1.0, 2.0))
    grid = plan.points({"a": [1.0, 2.0], "b": [3.0, 4.0, 5.0]}, None, 0)
    assert [(p["a"], p["b"]) for p in grid] == [(1, 3), (1, 4), (1, 5), (2, 3), (2, 4), (2, 5)]


def test_latin_hypercube_samples_fill_each_stratum_once():
    params = plan.normalize({"a": (2.0, 4.0), "b": (-1.0, 1.0), "c": 7.0}, samples=16)
    drawn = plan.points(params, 16, seed=3)
    for name, (low, high) in (("a", (2.0, 4.0)), ("b", (-1.0, 1.0))):
        strata = sorted(int(16 * (p[name] - low) / (high - low)) for p in drawn)
        assert strata == list(range(16))  # one sample in each sixteenth of the range
    assert all(p["c"] == 7.0 for p in drawn)
    assert plan.points(params, 16, seed=3) == drawn and plan.points(params, 16, seed=4) != drawn


@pytest.mark.requires_cc
def test_each_run_equals_simulate_bit_for_bit(reference, tmp_path, capsys):
    folder, summary = reference
    assert summary.runs == 4 and summary.failed == 0 and summary.columns["status"] == ["complete"] * 4
    for k, run in enumerate(summary.columns["run"]):
        nrfe, e2 = summary.columns["nrfe"][k], summary.columns["E2"][k]
        out = tmp_path / f"{run}.npz"
        argv = ["simulate", "--nrfe", str(nrfe), "--param", f"E2={e2!r}", "--t-end", "0.02", "--dt", "1e-4",
                "--save-every", "10", "--backend", "c", "--out", str(out)]
        assert main(argv) == 0, capsys.readouterr().err
        alone, swept = results_io.load(out), results_io.load(folder / "runs" / f"{run}.npz")
        for key in ("t", "q", "qd", "phi", "tau_drive", "drive_forces", "constraint_forces", "kinetic_energy",
                    "work_drive", "work_constraints"):
            assert np.array_equal(alone[key], swept[key]), key
        row = outcomes.outcomes(alone, driven=("theta1",))
        for name, value in row.items():
            assert summary.columns[name][k] == value, name
    # the stiffness matters to the flexible arm only: the rigid arm has no sde
    flexible = [k for k, n in enumerate(summary.columns["nrfe"]) if n == 2]
    rigid = [k for k, n in enumerate(summary.columns["nrfe"]) if n == 1]
    peak = summary.columns["peak_constraint_force.psi2"]
    assert peak[rigid[0]] == peak[rigid[1]] and peak[flexible[0]] != peak[flexible[1]]


@pytest.mark.requires_cc
def test_csv_and_parquet_hold_the_summary(reference):
    folder, summary = reference
    assert outcomes.read_csv(folder / "summary.csv") == summary.columns
    assert pq.read_table(folder / "summary.parquet").to_pydict() == summary.columns


# make check-c: two sweeps of a pool of processes (each run as simulate makes it:
# test_each_run_equals_simulate_bit_for_bit; a sweep's summary:
# test_a_failing_run_is_recorded_and_the_sweep_goes_on)
@pytest.mark.long
@pytest.mark.requires_cc
def test_local_pool_gives_the_same_summary(reference, tmp_path):
    summary = gpmegen.sweep(out=tmp_path / "pool", workers=2, **GRID)
    assert summary.workers == 2
    assert _same_numbers(summary.columns) == _same_numbers(reference[1].columns)


# make check-c: a Dask cluster of worker processes (the local pool: test_local_pool_gives_the_same_summary)
@pytest.mark.long
@pytest.mark.requires_cc
def test_local_dask_cluster_gives_the_same_summary(reference, tmp_path):
    from distributed import LocalCluster

    with LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None) as cluster:
        summary = gpmegen.sweep(out=tmp_path / "dask", scheduler=cluster.scheduler_address, **GRID)
    assert _same_numbers(summary.columns) == _same_numbers(reference[1].columns)


def _wait_for(condition, seconds, what):
    deadline = time.monotonic() + seconds
    while not condition():
        if time.monotonic() > deadline:
            raise AssertionError(f"gave up waiting for {what}")
        time.sleep(0.05)


@pytest.mark.long   # a Dask cluster of processes started by hand; the LocalCluster test above is in make test
@pytest.mark.requires_cc
def test_scheduler_and_workers_in_their_own_processes_give_the_same_summary(reference, tmp_path):
    from distributed import Client

    address = tmp_path / "scheduler.json"
    dask = [sys.executable, "-m", "dask"]
    quiet = dict(stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    processes = [subprocess.Popen(dask + ["scheduler", "--host", "127.0.0.1", "--port", "0", "--no-dashboard",
                                          "--scheduler-file", str(address)], **quiet)]
    try:
        _wait_for(address.exists, 60, "the scheduler file")
        for k in range(2):
            processes.append(subprocess.Popen(dask + ["worker", "--scheduler-file", str(address), "--nthreads", "1",
                                                      "--no-dashboard", "--local-directory", str(tmp_path / f"w{k}")],
                                              **quiet))
        with Client(scheduler_file=str(address), timeout=30) as client:
            client.wait_for_workers(2, timeout=60)
        summary = gpmegen.sweep(out=tmp_path / "cluster", scheduler=str(address), **GRID)
    finally:
        for process in reversed(processes):
            process.terminate()
            process.wait(timeout=30)
    assert summary.workers == 2
    assert _same_numbers(summary.columns) == _same_numbers(reference[1].columns)


#: Imported at the start of every Python process of a sweep that finds it on its path: the run
#: with tdr0 = 2 kills its process with SIGSEGV, as a crash in compiled code would.
CRASHING_RUN = """
import os, signal
from gpmegen.analysis.run import runs

_run = runs.run

def run(case, spec, backend, overrides, *args, **kwargs):
    if overrides.get("tdr0") == 2.0:
        os.kill(os.getpid(), signal.SIGSEGV)
    return _run(case, spec, backend, overrides, *args, **kwargs)

runs.run = run
"""
#: Three short runs of the rigid arm on NumPy; the second is the one CRASHING_RUN kills.
THREE_RUNS = ["--nrfe", "1", "--param", "tdr0=1,2,3", "--t-end", "0.002", "--dt", "1e-3", "--save-every", "1",
              "--backend", "numpy"]


def _crashing_environment(tmp_path) -> dict:
    """The environment of a process whose sweeps' run with tdr0 = 2 dies with SIGSEGV."""
    import os

    hook = tmp_path / "hook"
    hook.mkdir()
    (hook / "sitecustomize.py").write_text(CRASHING_RUN)
    return {**os.environ, "PYTHONPATH": os.pathsep.join(filter(None, [str(hook), os.environ.get("PYTHONPATH")]))}


def _died_as_asked(table, died):
    assert table["status"] == ["complete", "died", "complete"]
    assert died in table["message"][1]
    assert table["q_final.theta1"][1] is None and table["q_final.theta1"][2] is not None


# make check-c: a Dask cluster of two worker processes (a failing run is recorded and the sweep goes
# on: test_a_failing_run_is_recorded_and_the_sweep_goes_on)
@pytest.mark.long
def test_a_worker_that_dies_is_that_runs_outcome_and_the_sweep_goes_on(tmp_path):
    """A pool's process killed by SIGSEGV ended the sweep with "internal error: KeyError:
    'wall_s'" and no summary."""
    out = tmp_path / "crashed"
    done = subprocess.run(GPMEGEN + ["sweep", *THREE_RUNS, "--workers", "2", "--out", str(out)],
                          capture_output=True, text=True, env=_crashing_environment(tmp_path), timeout=300)
    assert done.returncode == 1, done.stderr
    last = done.stderr.strip().splitlines()[-1]
    assert last.startswith("gpmegen sweep: error: 1 of 3 runs did not complete (first: run "), last
    assert "died: the process making this run was killed by SIGSEGV" in last
    assert "internal error" not in done.stderr and "Traceback" not in done.stderr
    table = outcomes.read_csv(out / "summary.csv")
    _died_as_asked(table, "killed by SIGSEGV")
    assert table["wall_s"][1] is not None
    assert not list((out / "runs").glob(f"{table['run'][1]}*")) and not list((out / "runs").glob(".*"))
    # run again without the crash, the sweep makes the run that died, and only that one
    again = subprocess.run(GPMEGEN + ["sweep", *THREE_RUNS, "--workers", "2", "--out", str(out)],
                           capture_output=True, text=True, timeout=300)
    assert again.returncode == 0, again.stderr
    assert "2 of 3 runs complete already (kept)" in again.stderr and "\ngpmegen: 1 runs " in again.stderr
    assert outcomes.read_csv(out / "summary.csv")["status"] == ["complete"] * 3


@pytest.mark.long   # the local pool's worker that dies is in make test
@pytest.mark.requires_cc
def test_a_dask_worker_that_dies_is_that_runs_outcome_and_the_sweep_goes_on(tmp_path, monkeypatch):
    """On a cluster the lost worker was an internal error (KeyError: 'wall_s') too."""
    import dask
    from distributed import LocalCluster

    monkeypatch.setenv("PYTHONPATH", _crashing_environment(tmp_path)["PYTHONPATH"])  # the workers' processes
    params = {"tdr0": [1.0, 2.0, 3.0]}
    # a task whose worker dies is not tried again on another (Dask tries 3 more by default)
    with dask.config.set({"distributed.scheduler.allowed-failures": 0}), \
            LocalCluster(n_workers=2, processes=True, threads_per_worker=1, dashboard_address=None) as cluster:
        with pytest.raises(SweepFailures, match=r"1 of 3 runs did not complete \(first: run \w+, died: "):
            gpmegen.sweep(out=tmp_path / "dask", scheduler=cluster.scheduler_address, nrfe=[1], params=params,
                          t_end=0.002, dt=1e-3, save_every=1, backend="numpy")
    _died_as_asked(outcomes.read_csv(tmp_path / "dask" / "summary.csv"), "the Dask worker making this run died")


def _worker_processes(pid) -> list:
    """The pool's processes of the sweep ``pid`` (not multiprocessing's resource tracker, which
    writes nothing and ends on its own once the sweep has ended)."""
    import psutil

    return [child for child in psutil.Process(pid).children(recursive=True)
            if any("spawn_main" in part for part in child.cmdline())]


def _gone(process) -> bool:
    import psutil

    try:
        return process.status() == psutil.STATUS_ZOMBIE
    except psutil.NoSuchProcess:
        return True


# make check-c: eight runs of 0.1 s on the NumPy backend, three sweeps and their pools: about 20 s of CPU
@pytest.mark.long
def test_ctrl_c_stops_the_workers_at_once_and_the_resume_makes_only_the_missing_runs(tmp_path):
    """Ctrl-C said "k of N runs complete and kept" while the pool's processes went on: they wrote
    more runs after the command had ended, left .partial files, and the resume made those runs
    again."""
    # runs long enough that the signal finds them integrating, as a real sweep's would be
    args = ["--nrfe", "1", "--param", "tdr0=1:3:8", "--t-end", "0.1", "--dt", "1e-4", "--save-every", "50",
            "--backend", "numpy"]
    stopped = tmp_path / "stopped"
    proc = subprocess.Popen(GPMEGEN + ["sweep", *args, "--workers", "2", "--out", str(stopped)],
                            stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    lines = []
    while sum(line.startswith("gpmegen: run ") for line in lines) < 3:  # three runs ended
        line = proc.stderr.readline()
        assert line, f"the sweep ended before its third run: {''.join(lines)}"
        lines.append(line)
    workers = _worker_processes(proc.pid)
    assert workers
    proc.send_signal(signal.SIGINT)
    said = None
    while said is None:
        line = proc.stderr.readline()
        assert line, "".join(lines)
        lines.append(line)
        if "runs complete and kept" in line:
            said, told = line, time.time()  # the line was printed before this instant
    rest = proc.stderr.read()
    proc.wait(timeout=120)
    err = "".join(lines) + rest
    assert proc.returncode == 130, err
    assert said.endswith("runs complete and kept; run the same sweep again to make the others\n"), err
    assert rest == "gpmegen sweep: interrupted\n", err
    kept = int(said.removeprefix("gpmegen: ").split()[0])
    assert all(_gone(worker) for worker in workers)  # nothing can write to the folder any more
    files = {path: path.stat().st_mtime_ns for path in (stopped / "runs").iterdir()}
    late = sorted(path.name for path, ns in files.items() if ns > told * 1e9)
    assert not late, f"written after the sweep said it had stopped: {late}"
    complete = [path for path in files if path.suffix == ".npz" and path.with_suffix(".json") in files]
    assert len(complete) == kept and 3 <= kept < 8
    assert not [path for path in files if ".partial" in path.name or path.name.startswith(".")], sorted(files)
    assert not (stopped / "summary.csv").exists()

    params = {"tdr0": plan.parse_param("tdr0=1:3:8")[1]}
    setting = dict(nrfe=[1], params=params, t_end=0.1, dt=1e-4, save_every=50, backend="numpy")
    messages = []
    resumed = gpmegen.sweep(out=stopped, workers=1, progress=messages.append, **setting)
    assert resumed.skipped == kept and resumed.runs == 8
    assert sum(line.startswith("run ") for line in messages) == 8 - kept  # exactly the missing runs made
    assert {path: files[path] for path in complete} == {path: path.stat().st_mtime_ns for path in complete}
    whole = gpmegen.sweep(out=tmp_path / "whole", workers=1, **setting)
    assert _same_numbers(resumed.columns) == _same_numbers(whole.columns)


@pytest.mark.requires_cc
def test_a_failing_run_is_recorded_and_the_sweep_goes_on(tmp_path, capsys):
    # the line the planar arm's E is held on starts 5 m out, beyond the arm's reach (1.1 m)
    out = tmp_path / "failing"
    argv = ["sweep", str(EXAMPLES / "planar_two_link.toml"), "--nrfe", "1", "--param", "xa=0.5734401855541006,5,0.55",
            "--t-end", "0.01", "--dt", "1e-4", "--out", str(out)]
    assert main(argv) == 1
    err = capsys.readouterr().err.strip().splitlines()
    assert err[-1].startswith("gpmegen sweep: error: 1 of 3 runs did not complete")
    assert sum(line.startswith("gpmegen: run ") for line in err) == 3  # a progress line per run (no terminal)
    table = outcomes.read_csv(out / "summary.csv")
    assert table["status"] == ["complete", "failed", "complete"]
    assert "the programmed constraints cannot be met" in table["message"][1]
    assert table["q_final.theta1"][1] is None and table["q_final.theta1"][2] is not None
    assert not (out / "runs" / f"{table['run'][1]}.npz").exists()


def test_samples_are_run_with_the_values_drawn(tmp_path):
    params = {"tdr0": (1.0, 3.0), "d2": 0.01}
    summary = gpmegen.sweep(out=tmp_path / "drawn", nrfe=[1], params=params, samples=3, seed=5, t_end=0.002,
                            dt=1e-3, save_every=1, backend="numpy", workers=1)
    drawn = plan.points(plan.normalize(params, 3), 3, seed=5)
    assert summary.columns["tdr0"] == [p["tdr0"] for p in drawn] and summary.columns["d2"] == [0.01] * 3
    assert len(set(summary.columns["tdr0"])) == 3 and summary.columns["status"] == ["complete"] * 3
    with pytest.raises(plan.SweepError, match="given twice"):
        gpmegen.sweep(out=tmp_path / "twice", params={"tdr0": [1.0, 2.0, 1.0]}, t_end=0.01)
    with pytest.raises(plan.SweepError, match="draws within ranges"):
        gpmegen.sweep(out=tmp_path / "fixed", params={"tdr0": 1.0}, samples=3, t_end=0.01)


def test_a_folder_of_another_sweep_is_refused(tmp_path, capsys):
    out = tmp_path / "one"
    argv = ["sweep", "--nrfe", "1", "--param", "tdr0=1", "--dt", "1e-3", "--backend", "numpy", "--out", str(out)]
    assert main(argv + ["--t-end", "0.01"]) == 0
    assert main(argv + ["--t-end", "0.02"]) == 2
    assert "holds a different sweep (t_end 0.01 there, 0.02 here)" in capsys.readouterr().err
    (tmp_path / "other").mkdir()
    (tmp_path / "other" / "notes.txt").write_text("mine")
    assert main(argv[:-1] + [str(tmp_path / "other"), "--t-end", "0.01"]) == 2
    assert "is not empty and holds no sweep" in capsys.readouterr().err
    assert json.loads((out / "sweep.json").read_text())["arguments"]["t_end"] == 0.01


def test_a_sweep_beyond_the_limits_is_refused_with_its_numbers(tmp_path):
    with pytest.raises(LimitError, match=r"a sweep of 4000 runs on 2 workers would take about .* beyond the limit"):
        gpmegen.sweep(out=tmp_path / "big", nrfe=[1, 5], params={"tdr0": (1.0, 2.0)}, samples=2000, t_end=10.0,
                      workers=2)
    assert not (tmp_path / "big").exists()


def test_runs_in_other_processes_keep_the_limits_lifted(tmp_path, monkeypatch):
    """A pool's process or a Dask worker does not see the caller's limits.lifted(): its tasks say it."""
    from gpmegen import limits
    from gpmegen.analysis import sweep
    from gpmegen.analysis.sweep import workers

    folder = tmp_path / "lifted"
    settings = dict(t_end=0.002, dt=1e-3, save_every=1, method="rk4", backend="numpy", repartition=False)
    gpmegen.sweep(out=folder, nrfe=[1], params={"tdr0": 2.0}, workers=1, **settings)  # the folder and manifest
    models = sweep._plan_models(None, [1], None)
    arguments = {"model_file": None, "model_sha256": None, **settings}
    with limits.lifted():
        (lifted,) = sweep._tasks(models, [{"tdr0": 2.0}], arguments, folder)
    (bound,) = sweep._tasks(models, [{"tdr0": 2.0}], arguments, folder)
    monkeypatch.setattr(limits, "MAX_SECONDS", 1e-9)  # every run is now beyond the limit
    assert workers.perform(lifted)["status"] == "complete"
    refused = workers.perform(bound)
    assert refused["status"] == "failed" and "beyond the limit" in refused["message"]
