"""Faults and interruptions: killed and concurrent builds, interrupted runs, stale artifacts."""

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.post import results as results_io
from gpmegen.errors import StaleModelError

GPMEGEN = [sys.executable, "-m", "gpmegen.cli"]


def _run(args, **kw):
    return subprocess.run(GPMEGEN + args, capture_output=True, text=True, **kw)


def test_killed_build_leaves_the_previous_folder_loadable(tmp_path):
    assert _run(["build", "--nrfe", "3", "--out", str(tmp_path)]).returncode == 0
    folder = tmp_path / "manipulator_nrfe3"
    before = (folder / "model_numpy.py").read_bytes()
    proc = subprocess.Popen(GPMEGEN + ["build", "--nrfe", "3", "--force", "--out", str(tmp_path)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    time.sleep(1.0)  # inside the derivation or printing, well before the swap
    proc.kill()
    proc.wait()
    assert (folder / "model_numpy.py").read_bytes() == before
    model = gpmegen.load("manipulator", nrfe=3, directory=tmp_path, build=False, backend="numpy")
    assert model.n_dof == 9
    # the next build clears what the killed one left
    assert _run(["build", "--nrfe", "3", "--force", "--out", str(tmp_path)]).returncode == 0
    assert not list(tmp_path.glob(".manipulator_nrfe3.tmp-*"))


def test_concurrent_builds_give_one_valid_result(tmp_path):
    procs = [subprocess.Popen(GPMEGEN + ["build", "--nrfe", "2", "--out", str(tmp_path)],
                              stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for _ in range(3)]
    outs = [p.communicate() for p in procs]
    assert [p.returncode for p in procs] == [0, 0, 0], outs
    assert sum("built in" in out for out, _ in outs) == 1  # the others found it up to date
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.endswith(".lock")) == ["manipulator_nrfe2"]
    assert gpmegen.load("manipulator", nrfe=2, directory=tmp_path, build=False, backend="numpy").n_dof == 6


# each waits for the run's first progress line (10 s of running): make check-c (a signal that
# stops a run and keeps its results, every method: test_interrupts.py; Ctrl-C in simulate:
# test_command_line.py)
@pytest.mark.long
@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM])
def test_interrupted_simulation_keeps_partial_results(tmp_path, sig, generated_elsewhere):
    out = tmp_path / "run.npz"
    env = dict(os.environ, GPMEGEN_GENERATED=str(generated_elsewhere))
    proc = subprocess.Popen(GPMEGEN + ["simulate", "--nrfe", "1", "--backend", "numpy", "--t-end", "100", "--dt",
                                       "1e-3", "--save-every", "10", "--out", str(out)],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True, env=env)
    # the signal once the run has said how far it got (a line every 10 s away from a terminal), so
    # that it has rows beyond the start to keep, however long that takes on a busy machine
    for line in proc.stderr:
        if " of 100 (" in line:
            break
    proc.send_signal(sig)
    _, err = proc.communicate(timeout=60)
    assert proc.returncode == 130  # interrupted, as Ctrl-C in any command
    assert "interrupted" in err and "partial" in err and "Traceback" not in err
    res = results_io.load(results_io.targets(out, complete=False)[0])
    assert str(res["status"]) == "interrupted"
    assert 0 < res["t"][-1] < 100 and np.all(np.isfinite(res["q"]))


def test_stale_generated_module_is_refused_with_the_rebuild_command(tmp_path):
    assert _run(["build", "--nrfe", "1", "--out", str(tmp_path)]).returncode == 0
    manifest = tmp_path / "manipulator_nrfe1" / "manifest.json"
    data = json.loads(manifest.read_text())
    data["input_hash"] = "0" * 16
    manifest.write_text(json.dumps(data))
    with pytest.raises(StaleModelError, match="gpmegen build --nrfe 1 --force"):
        gpmegen.load("manipulator", nrfe=1, directory=tmp_path, build=False, backend="numpy")
    # loading with building allowed repairs it
    assert gpmegen.load("manipulator", nrfe=1, directory=tmp_path, backend="numpy").n_dof == 3


def test_half_swapped_folder_is_recovered(tmp_path):
    assert _run(["build", "--nrfe", "1", "--out", str(tmp_path)]).returncode == 0
    folder = tmp_path / "manipulator_nrfe1"
    folder.rename(tmp_path / ".manipulator_nrfe1.old-12345")  # killed between the two renames
    assert gpmegen.load("manipulator", nrfe=1, directory=tmp_path, build=False, backend="numpy").n_dof == 3
    assert folder.is_dir()


def test_divergence_in_the_compiled_loop_stops_with_a_fix_and_keeps_results(tmp_path, capsys, generated_elsewhere):
    from gpmegen.cli import main
    from gpmegen.runtime.ccompile import find_compiler

    if not find_compiler():
        pytest.skip("no C compiler")
    out = tmp_path / "run.npz"
    # 2 ms is above RK4's stable step (0.28 ms): refused unless the limits are lifted, as here
    code = main(["simulate", "--nrfe", "5", "--dt", "2e-3", "--t-end", "2", "--save-every", "1", "--no-limits",
                 "--out", str(out)])
    err = capsys.readouterr().err
    assert code == 1 and "diverged" in err and "smaller --dt" in err and "kept in" in err
    res = results_io.load(results_io.targets(out, complete=False)[0])
    assert str(res["status"]).startswith("diverged") and 0 < res["t"][-1] < 2
    assert np.all(np.isfinite(res["q"]))
