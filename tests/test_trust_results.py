"""Results that can be trusted: a run ends at t_end with its final state saved, on one grid for
the C and NumPy backends; results files are written as a pair and a complete result is never
replaced by a partial one; Ctrl-C at start-up ends the command without a traceback."""

from __future__ import annotations

import os
import pty
import re
import select
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen import fileio
from gpmegen.analysis.post import results as results_io
from gpmegen.analysis.run import reference_case, study
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.cli import main
from gpmegen.runtime import integrators
from gpmegen.status import Outcome, SolveStatus


def _exit_code(argv):
    """Exit status of ``gpmegen argv`` run in this process (argparse's own refusals included)."""
    try:
        return main(argv)
    except SystemExit as exc:
        return exc.code


def _csv_first_line(path):
    with open(path, encoding="utf-8") as fh:
        return fh.readline().rstrip("\n")


# ---- a run ends at t_end, with its final state ------------------------------------------------

# Command lines whose last sample was wrong: t_end not a whole number of save intervals, or of
# steps, or both. The first two are run on the C backend alone (the NumPy one takes seconds).
RUNS = {
    "save-every-300": ["--t-end", "0.2", "--save-every", "300"],
    "t-end-0.10005": ["--t-end", "0.10005"],
    "dt-3e-5": ["--dt", "3e-5", "--t-end", "0.1"],
    "short-save-every-300": ["--t-end", "0.02", "--save-every", "300"],
    "last-step-shorter": ["--t-end", "0.010005", "--save-every", "300"],
}


def _t_end(key):
    argv = RUNS[key]
    return float(argv[argv.index("--t-end") + 1])


@pytest.fixture(scope="module")
def cli_runs(tmp_path_factory):
    """Results of ``gpmegen simulate --nrfe 1 <RUNS[key]> --backend <backend>``, run once each."""
    folder = tmp_path_factory.mktemp("runs")
    done = {}

    def run(key, backend):
        if (key, backend) not in done:
            out = folder / f"{key}_{backend}.npz"
            assert main(["simulate", "--nrfe", "1", "--backend", backend, *RUNS[key], "--out", str(out)]) == 0
            done[key, backend] = results_io.load(out)
        return done[key, backend]

    return run


@pytest.mark.parametrize("t0, t_end, dt, n_steps, last", [
    (0.0, 0.2, 1e-5, 20000, 1e-5),
    (0.0, 0.1, 3e-5, 3334, 1e-5),
    (0.0, 0.10005, 1e-5, 10005, 1e-5),
    (0.0, 0.100055, 1e-5, 10006, 5e-6),
    (0.0, 1.0, 2.0, 1, 1.0),
    (4.0, 4.3, 1e-3, 300, 1e-3),
    (0.0, 10.0, 1e-5, 1000000, 1e-5),
    (0.0, 0.0, 1e-5, 0, None),
])
def test_grid_ends_at_t_end_with_a_shorter_last_step_where_needed(t0, t_end, dt, n_steps, last):
    g = integrators.loop.grid(t0, t_end, dt)
    assert g.n_steps == n_steps
    assert g.time(0) == t0 and g.time(n_steps) == t_end
    if n_steps:
        assert g.step(n_steps) == pytest.approx(last, rel=1e-6)
        k = n_steps // 2
        if 0 < k < n_steps:  # inner steps on t0 + k dt, without accumulated round-off
            assert g.time(k) == t0 + k * dt and g.step(k) == dt


@pytest.mark.requires_cc
@pytest.mark.parametrize("key", ["save-every-300", "t-end-0.10005", "last-step-shorter"])
def test_last_row_off_the_save_grid_is_the_final_state_not_the_last_saved_one(cli_runs, key):
    """``--t-end 0.2 --save-every 300``: the last row used to repeat the state saved at step
    19800, stamped 0.2 s (max|Φ| 1.2e-3 in the summary instead of 5e-15)."""
    res, t_end = cli_runs(key, "c"), _t_end(key)
    argv = RUNS[key]
    every = int(argv[argv.index("--save-every") + 1]) if "--save-every" in argv else 100
    grid = integrators.loop.grid(0.0, t_end, 1e-5)
    np.testing.assert_array_equal(res["t"], [grid.time(k) for k in [*range(0, grid.n_steps, every), grid.n_steps]])
    assert res["t"][-1] == t_end
    assert np.abs(res["phi"][-1]).max() < 1e-12
    # the same final state as one continuous C call over the whole run
    model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=1, backend="c"))
    np.testing.assert_array_equal(res["q"][0], q0)
    t, q, qd, w, status = model.rk4(q0, np.zeros(3), t_end, 1e-5, save_every=10 ** 9)
    assert status == 0 and list(t) == [0.0, t_end]
    np.testing.assert_array_equal(res["q"][-1], q[-1])
    np.testing.assert_array_equal(res["qd"][-1], qd[-1])


@pytest.mark.requires_cc
@pytest.mark.parametrize("key", ["dt-3e-5", "short-save-every-300", "last-step-shorter"])
def test_c_and_numpy_save_the_same_rows_and_end_at_t_end(cli_runs, key):
    """``--dt 3e-5 --t-end 0.1`` used to end at 0.09999 s, and the C backend's last row was not
    its final state where t_end is off the save grid."""
    c, n = cli_runs(key, "c"), cli_runs(key, "numpy")
    np.testing.assert_array_equal(c["t"], n["t"])
    assert c["t"][-1] == _t_end(key)
    for name in ("q", "qd"):
        scale = np.abs(n[name]).max()
        np.testing.assert_allclose(c[name], n[name], rtol=1e-9, atol=1e-9 * scale)


@pytest.mark.parametrize("backend", ["numpy", pytest.param("c", marks=pytest.mark.requires_cc)])
def test_a_step_longer_than_the_run_is_cut_to_end_at_t_end(backend):
    """``--dt 2 --t-end 1`` used to take no step at all and report success."""
    model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=1, backend=backend))
    res = study.simulate(model, q0, RunSpec(t_end=1.0, dt=2.0, save_every=1))
    np.testing.assert_array_equal(res["t"], [0.0, 1.0])
    assert not np.array_equal(res["q"][-1], q0)  # a step of 1 s was taken (and diverges, as it should)


# ---- results files: never lost, never mismatched ----------------------------------------------

@pytest.fixture(scope="module")
def short_run():
    """A small complete results dict (NumPy backend, 5 steps)."""
    model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=1, backend="numpy"))
    return study.simulate(model, q0, RunSpec(t_end=0.005, dt=1e-3, save_every=1))


def _run_id_of_csv(path):
    match = re.match(rf"# {results_io.FORMAT} run ([0-9a-f]+): ", _csv_first_line(path))
    assert match, _csv_first_line(path)
    return match.group(1)


def test_results_pair_share_a_run_id_and_the_csv_says_complete_or_partial(tmp_path, short_run):
    out = tmp_path / "run.npz"
    npz, csv = results_io.save(short_run, out)
    assert (npz, csv) == (out, out.with_suffix(".csv"))
    assert _csv_first_line(csv).endswith(": complete")
    assert str(results_io.load(npz)["run_id"]) == _run_id_of_csv(csv)
    why = str(Outcome.failed(0.004, SolveStatus.SINGULAR))  # not ASCII: BᵀMB
    npz, csv = results_io.save(dict(short_run, status=np.array(why)), out)
    assert (npz.name, csv.name) == ("run.partial.npz", "run.partial.csv")
    assert _csv_first_line(csv).endswith(f": partial ({why})")
    assert str(results_io.load(npz)["run_id"]) == _run_id_of_csv(csv)
    assert str(results_io.load(out)["status"]) == "complete"  # the complete result is still there


def test_a_signal_between_the_two_renames_waits_until_both_files_are_in_place(tmp_path, short_run, monkeypatch):
    """Ctrl-C between writing the .npz and the .csv used to leave a new .npz beside an old .csv."""
    out = tmp_path / "run.npz"
    results_io.save(short_run, out)
    replace = os.replace

    def replace_then_interrupt(src, dst):
        replace(src, dst)
        os.kill(os.getpid(), signal.SIGINT)

    monkeypatch.setattr(fileio.os, "replace", replace_then_interrupt)
    with pytest.raises(KeyboardInterrupt):
        results_io.save(short_run, out)
    monkeypatch.undo()
    assert str(results_io.load(out)["run_id"]) == _run_id_of_csv(out.with_suffix(".csv"))
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv", "run.npz"]


def test_an_interrupted_write_leaves_the_previous_pair_as_it_was(tmp_path, short_run, monkeypatch):
    out = tmp_path / "run.npz"
    results_io.save(short_run, out)
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}

    def interrupted(*args, **kwargs):
        raise KeyboardInterrupt

    monkeypatch.setattr(results_io.np, "savetxt", interrupted)  # the .csv is written after the .npz
    with pytest.raises(KeyboardInterrupt):
        results_io.save(short_run, out)
    assert {p.name: p.read_bytes() for p in tmp_path.iterdir()} == before  # no temporary files left


def _read_until(fd, pattern, timeout):
    """Read the terminal ``fd`` until ``pattern`` (bytes regex) shows; all that was read."""
    seen, end = b"", time.monotonic() + timeout
    while not re.search(pattern, seen):
        left = end - time.monotonic()
        assert left > 0, f"{pattern!r} did not show within {timeout} s: {seen[-400:]!r}"
        if select.select([fd], [], [], left)[0]:
            try:
                chunk = os.read(fd, 4096)
            except OSError:  # the other end was closed
                chunk = b""
            assert chunk, f"the process ended before {pattern!r}: {seen[-400:]!r}"
            seen += chunk
    return seen


def _read_to_end(fd):
    seen = b""
    while True:
        try:
            chunk = os.read(fd, 4096)
        except OSError:
            return seen
        if not chunk:
            return seen
        seen += chunk


def test_ctrl_c_keeps_the_previous_complete_result_and_writes_the_partial_beside_it(tmp_path):
    """Ctrl-C used to replace a complete run.npz (and run.csv) with the partial run."""
    out = tmp_path / "run.npz"
    common = ["simulate", "--nrfe", "1", "--backend", "numpy", "--dt", "1e-3", "--out", str(out)]
    assert main([*common, "--t-end", "0.01"]) == 0
    before = {p.name: p.read_bytes() for p in tmp_path.iterdir()}
    # stderr on a terminal shows the progress bar, drawn from inside the integration loop: once it
    # has been drawn twice (0.25 s apart), Ctrl-C lands in the integration, which would take minutes
    master, terminal = pty.openpty()
    proc = subprocess.Popen([sys.executable, "-m", "gpmegen.cli", *common, "--t-end", "1000", "--overwrite"],
                            stdout=subprocess.PIPE, stderr=terminal, text=True)
    os.close(terminal)
    try:
        seen = _read_until(master, rb"%[^%]*%", timeout=120)
        proc.send_signal(signal.SIGINT)
        stdout, _ = proc.communicate(timeout=60)
        seen += _read_to_end(master)
    finally:
        proc.kill()
        os.close(master)
    err = seen.decode(errors="replace")
    partial, partial_csv = results_io.targets(out, complete=False)
    assert proc.returncode == 130 and "Traceback" not in err
    assert re.search(rf"interrupted; .*kept in {re.escape(str(partial))} \(partial\); {re.escape(str(out))} is "
                     rf"left as it was", err), err
    assert {name: (tmp_path / name).read_bytes() for name in before} == before
    res = results_io.load(partial)
    assert str(res["status"]) == "interrupted" and 0 < res["t"][-1] < 1000
    assert _csv_first_line(partial_csv).endswith(": partial (interrupted)")
    assert str(res["run_id"]) == _run_id_of_csv(partial_csv)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["run.csv", "run.npz", "run.partial.csv", "run.partial.npz"]


@pytest.mark.parametrize("argv, taken", [
    (["simulate", "--nrfe", "1", "--out", ""], None),
    (["simulate", "--nrfe", "1", "--out", "taken.npz"], "taken.npz"),
    (["simulate", "--nrfe", "1", "--out", "run.npz"], "run.csv"),
    (["simulate", "--nrfe", "1", "--out", "run.npz"], "run.partial.npz"),
    (["simulate", "", "--nrfe", "1"], None),
    (["build", ""], None),
    (["build", "--nrfe", "1", "--out", ""], None),
    (["demo", "--results", ""], None),
    (["demo", "--t-end", "0.01"], "results/run_nrfe5.npz"),
])
def test_empty_or_folder_output_paths_are_refused_before_any_work(tmp_path, monkeypatch, capsys, argv, taken):
    """``--out ''`` and ``build ''`` used to mean the default (and replaced its results); an
    --out naming a folder was refused only after the whole run."""
    monkeypatch.chdir(tmp_path)
    if taken:
        (tmp_path / taken).mkdir(parents=True)
    before = sorted(tmp_path.rglob("*"))
    assert _exit_code([*argv, "--backend", "numpy", "--t-end", "0.01", "--dt", "1e-3"]
                      if argv[0] == "simulate" else argv) == 2
    err = capsys.readouterr().err
    assert "Traceback" not in err and "gpmegen: " not in err  # no progress: no work started
    assert err.strip().splitlines()[-1].startswith(f"gpmegen {argv[0]}: error: ")
    assert ("empty path" in err) if taken is None else (f"{Path(taken)} is a folder" in err)
    assert sorted(tmp_path.rglob("*")) == before


# ---- Ctrl-C at start-up -----------------------------------------------------------------------

PACKAGE = Path(gpmegen.__file__).resolve().parent


def _gpmegen_frames(err):
    """Traceback frames of ``err`` in the gpmegen package."""
    return [f for f in re.findall(r'File "([^"]+)", line', err) if Path(f).resolve().is_relative_to(PACKAGE)]


# The child runs the console command's function, after an import hook that sends it SIGINT the
# moment a given module starts to be imported: the signal lands at a known place in the command's
# start-up, whatever the machine's load (a signal sent after a sleep landed before or after it).
_INTERRUPTED_IMPORT = """
import importlib.abc, os, signal, sys

target = sys.argv.pop(1)


class Interrupt(importlib.abc.MetaPathFinder):
    def find_spec(self, name, path, target_module=None):
        if name == target:
            sys.meta_path.remove(self)
            os.kill(os.getpid(), signal.SIGINT)
        return None


sys.meta_path.insert(0, Interrupt())
sys.argv[0] = "gpmegen"
from gpmegen.entry import main
sys.exit(main())
"""


@pytest.mark.parametrize("module", [
    "gpmegen.fileio", "argparse", "numpy", "scipy", "gpmegen.cli", "gpmegen.help_pages"])
@pytest.mark.parametrize("command", [["--help"], ["simulate", "--help"]])
def test_ctrl_c_at_start_up_ends_without_a_traceback(module, command):
    """Ctrl-C while the command line's modules were being imported (the first ~0.1 s) used to
    show a traceback, or leave NumPy half imported. A signal that lands in gpmegen's start-up,
    while ``module`` is being imported, must end in one line and status 130."""
    proc = subprocess.run([sys.executable, "-c", _INTERRUPTED_IMPORT, module, *command], stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True, timeout=120)
    assert not _gpmegen_frames(proc.stderr), proc.stderr
    assert (proc.returncode, proc.stderr) == (130, "gpmegen: interrupted\n")
