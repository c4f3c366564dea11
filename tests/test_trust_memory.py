"""No input makes gpmegen allocate without bound: each command runs in a child process whose
address space is capped at 1 GiB, so that a fault ends there in "out of memory" rather than in
the machine's memory (and its CPU time, so that one that loops ends too), and must end in one
line naming the problem with its peak resident memory under 200 MB. Each test is named after the defect it provokes."""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest

from gpmegen.analysis.post import results as results_io
from gpmegen.cli import main

#: The child's address space: far beyond what any refusal needs, far below what the faults took.
ADDRESS_SPACE = 2**30
#: CPU seconds after which the child is stopped: a fault that loops for ever ends as a failure
#: instead of stalling the tests (every command here needs a few seconds).
CPU_SECONDS = 300
#: The peak resident memory a refused command may reach (the interpreter, NumPy and gpmegen take
#: about 110 MB).
PEAK_BYTES = 200e6

# The child writes its own peak (VmHWM of its memory after exec) to the file PEAK names: the
# maximum resident size that wait4 reports counts the parent's memory too when the parent forked
# or vforked it (the kernel records the old memory's high-water mark at exec), so a test run by a
# large process (a pytest-xdist worker: 560 MB) saw that for every child.
_CHILD = f"""
import atexit, os, resource, sys
resource.setrlimit(resource.RLIMIT_AS, ({ADDRESS_SPACE}, {ADDRESS_SPACE}))
cpu = int(sys.argv.pop(1))
resource.setrlimit(resource.RLIMIT_CPU, (cpu, cpu))


def peak():
    with open("/proc/self/status") as status:
        kib = next(line.split()[1] for line in status if line.startswith("VmHWM:"))
    with open(os.environ["PEAK"], "w") as out:
        out.write(kib)


atexit.register(peak)
from gpmegen.cli import main
sys.exit(main(sys.argv[1:]))
"""


class Outcome:
    def __init__(self, status: int, stderr: str, peak_bytes: float):
        self.status, self.stderr, self.peak_bytes = status, stderr, peak_bytes

    def one_line(self) -> str:
        # progress lines ("gpmegen: model folder: ...") are not the refusal
        lines = [line for line in self.stderr.splitlines() if line.strip() and not line.startswith("gpmegen: ")]
        assert len(lines) == 1, self.stderr
        assert "Traceback" not in self.stderr and "out of memory" not in self.stderr, self.stderr
        return lines[0]


def run(tmp_path, *args, cpu_seconds: int = CPU_SECONDS) -> Outcome:
    """``gpmegen args`` in a child capped at :data:`ADDRESS_SPACE` and ``cpu_seconds`` of CPU time:
    its exit status, its stderr and its own peak resident memory (VmHWM, written by the child)."""
    peak = tmp_path / "peak.txt"
    peak.unlink(missing_ok=True)
    env = dict(os.environ, OPENBLAS_NUM_THREADS="1", OMP_NUM_THREADS="1", MKL_NUM_THREADS="1", PEAK=str(peak))
    with open(tmp_path / "stderr.txt", "wb") as err:
        child = subprocess.run([sys.executable, "-c", _CHILD, str(cpu_seconds), *map(str, args)],
                               stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=err, cwd=tmp_path, env=env)
    # a child killed (out of memory, out of CPU time) wrote no peak: it counts as over any bound
    return Outcome(child.returncode, (tmp_path / "stderr.txt").read_text("utf-8", "replace"),
                   int(peak.read_text()) * 1024.0 if peak.exists() else float("inf"))


def refused(outcome: Outcome, status: int = 2) -> str:
    """The one line of a command refused with ``status`` within :data:`PEAK_BYTES`."""
    line = outcome.one_line()
    assert outcome.status == status, outcome.stderr
    assert outcome.peak_bytes < PEAK_BYTES, f"peak {outcome.peak_bytes / 1e6:.0f} MB: {line}"
    return line


@pytest.fixture
def zero_device():
    if not os.path.exists("/dev/zero"):
        pytest.skip("no /dev/zero")
    return "/dev/zero"


def test_model_file_naming_dev_zero_as_its_urdf_read_until_out_of_memory(tmp_path, zero_device):
    model = tmp_path / "robot.toml"
    model.write_text(f'schema = 1\nname = "robot"\nurdf = "{zero_device}"\n', encoding="utf-8")
    line = refused(run(tmp_path, "build", model, "--out", tmp_path / "out"))
    assert f"{zero_device}: the URDF file is a character device, not a regular file" in line
    assert not (tmp_path / "out").exists()


def test_a_fifo_is_refused_without_reading_it(tmp_path):
    from gpmegen.errors import ModelError
    from gpmegen.user_files import read_user_file

    fifo = tmp_path / "model.toml"
    os.mkfifo(fifo)
    # a write end held open: a reader that did not refuse the FIFO would wait on it, not on open()
    holder = os.open(fifo, os.O_RDWR | os.O_NONBLOCK)
    try:
        with pytest.raises(ModelError, match="the model file is a FIFO, not a regular file; give a file"):
            read_user_file(fifo, "the model file", ModelError)
    finally:
        os.close(holder)


def test_model_file_beyond_the_cap_is_refused_with_its_size(tmp_path):
    from gpmegen.user_files import MAX_USER_FILE_BYTES

    model = tmp_path / "huge.toml"
    with open(model, "wb") as fh:
        fh.truncate(MAX_USER_FILE_BYTES + 1)   # sparse: nothing is written to the disk
    line = refused(run(tmp_path, "build", model, "--out", tmp_path / "out"))
    assert (f"{model}: the model file holds {MAX_USER_FILE_BYTES + 1} bytes, beyond the {MAX_USER_FILE_BYTES} "
            f"bytes (8 MiB) read; give a smaller file") in line


@pytest.fixture(scope="module")
def small_run(tmp_path_factory):
    """A short run of the reference manipulator at one rfe (11 samples) and its arrays."""
    out = tmp_path_factory.mktemp("run") / "run.npz"
    assert main(["simulate", "--nrfe", "1", "--backend", "numpy", "--t-end", "0.01", "--dt", "1e-3",
                 "--out", str(out)]) == 0
    with np.load(out) as f:
        return out, {k: f[k] for k in f.files}


def test_results_naming_dev_zero_as_their_model_read_until_out_of_memory(tmp_path, small_run, zero_device):
    _, arrays = small_run
    meta = {**results_io.metadata(arrays), "model_source": {"file": zero_device}}
    results = tmp_path / "results.npz"
    np.savez(results, **{**arrays, "meta": results_io.encode(meta)})
    line = refused(run(tmp_path, "animate", results, "--out", tmp_path / "arm.gif"))
    assert f"{zero_device}: the model file is a character device, not a regular file; give a file" in line
    assert not (tmp_path / "arm.gif").exists()


def test_sweep_of_1e11_values_of_one_parameter_filled_the_memory(tmp_path):
    line = refused(run(tmp_path, "sweep", "--param", "m3=1:2:100000000000", "--t-end", "0.01", "--out",
                       tmp_path / "sweep"))
    assert "--param 'm3=1:2:100000000000': 1e+11 values of one parameter are more than a sweep takes (1e+05)" in line
    assert "give a smaller count" in line and not (tmp_path / "sweep").exists()


def test_sweep_of_1e5_values_checked_them_for_duplicates_in_quadratic_time(tmp_path):
    # the values are distinct, so the duplicate check passes and the sweep's estimate refuses it.
    # The command takes about 10 s of CPU time (CPU time, not wall time: a busy machine does not
    # add to it); the quadratic check took over 200 s of it.
    line = refused(run(tmp_path, "sweep", "--param", "m3=1:2:100000", "--t-end", "1", "--workers", "1", "--out",
                       tmp_path / "sweep", cpu_seconds=60))
    assert "a sweep of 100000 runs on 1 worker would take about" in line and "--no-limits" in line


def test_sweep_count_may_be_written_as_a_whole_number_in_exponent_form():
    from gpmegen.analysis.sweep import SweepError, plan

    assert plan.parse_param("m3=1:2:1e1") == ("m3", plan.parse_param("m3=1:2:10")[1])
    with pytest.raises(SweepError, match="must be a whole number >= 1"):
        plan.parse_param("m3=1:2:2.5")
    with pytest.raises(SweepError, match="1, 2 given twice"):
        plan.normalize({"m3": [2.0, 1.0, 2.0, 3.0, 1.0]}, None)


def test_inversion_on_1e8_mesh_nodes_filled_the_memory(tmp_path):
    line = refused(run(tmp_path, "invert", "--nrfe", "1", "--t1", "1", "--actuated", "psi2", "x3", "--nodes",
                       "100000000", "--out", tmp_path / "inversion.npz"))
    assert "a stable inversion on 1e+08 mesh nodes of n_dof = 3 would take at least" in line
    assert "GB of memory" in line and "give fewer --nodes" in line and "--no-limits" in line
    assert not (tmp_path / "inversion.npz").exists()


def _with_entry(source, target, name: str, elements: int) -> None:
    """``source`` (an .npz) copied to ``target`` with an entry ``name`` whose .npy header declares
    ``elements`` doubles, of which it holds eight bytes (a reader that trusts the header
    allocates them all before reading)."""
    import io
    import zipfile

    header = io.BytesIO()
    np.lib.format.write_array_header_1_0(header, {"descr": "<f8", "fortran_order": False, "shape": (elements,)})
    with zipfile.ZipFile(source) as old, zipfile.ZipFile(target, "w", zipfile.ZIP_DEFLATED) as new:
        for info in old.infolist():
            if info.filename != f"{name}.npy":
                new.writestr(info, old.read(info))
        new.writestr(f"{name}.npy", header.getvalue() + bytes(8))


def test_plot_inflated_an_unused_entry_of_1_gib(tmp_path, small_run):
    results = tmp_path / "results.npz"
    _with_entry(small_run[0], results, "unused", 2**27)
    outcome = run(tmp_path, "plot", results, "--out", tmp_path / "figures")
    assert outcome.status == 0, outcome.stderr
    assert outcome.peak_bytes < PEAK_BYTES + 100e6  # matplotlib's figures come on top of the 110 MB


def test_plot_of_an_entry_declaring_1_gib_in_8_bytes_is_refused(tmp_path, small_run):
    results = tmp_path / "results.npz"
    _with_entry(small_run[0], results, "qdd", 2**27)
    line = refused(run(tmp_path, "plot", results, "--out", tmp_path / "figures"))
    assert f"{results}: its array 'qdd' declares {2**30} bytes in" in line and "gpmegen simulate" in line


def test_animation_at_3000_dpi_filled_the_memory(tmp_path, small_run):
    line = refused(run(tmp_path, "animate", small_run[0], "--dpi", "3000", "--out", tmp_path / "arm.gif"))
    assert "drawing 1 frame of 19200 x 16200 pixels (1.24e+03 MB each, 1 held until written)" in line
    assert "give a smaller --dpi" in line and "--no-limits" in line and not (tmp_path / "arm.gif").exists()


def test_animation_of_every_one_of_20001_samples_held_every_frame(tmp_path, small_run):
    _, arrays = small_run
    k = 20001
    long = {**arrays, "t": np.linspace(0.0, 2.0, k)}
    for key in ("q", "qd", "end_effector", "phi", "tau_drive"):
        long[key] = np.resize(arrays[key], (k, *arrays[key].shape[1:]))
    results = tmp_path / "long.npz"
    np.savez(results, **long)
    line = refused(run(tmp_path, "animate", results, "--every", "1", "--out", tmp_path / "arm.gif"))
    assert "drawing 20001 frames of 640 x 540 pixels (1.38 MB each, 20001 held until written)" in line


def test_import_urdf_from_python_refuses_a_file_beyond_the_cap_before_reading_it(tmp_path):
    import gpmegen
    from gpmegen.errors import ModelError
    from gpmegen.user_files import MAX_USER_FILE_BYTES

    urdf = tmp_path / "huge.urdf"
    with open(urdf, "wb") as fh:
        fh.truncate(MAX_USER_FILE_BYTES + 1)   # sparse: nothing is written to the disk
    with pytest.raises(ModelError, match=f"the URDF file holds {MAX_USER_FILE_BYTES + 1} bytes, beyond the"):
        gpmegen.import_urdf(urdf)


def test_extrapolation_file_declaring_1_gib_in_8_bytes_is_refused_before_it_is_inflated(tmp_path):
    from gpmegen.analysis.discretization import extrapolate
    from gpmegen.errors import ExtrapolationError

    small = tmp_path / "small.npz"
    extrapolate.save({"t": np.zeros(3), "nrfe": np.array([2, 3])}, small)
    forged = tmp_path / "forged.npz"
    _with_entry(small, forged, "q_limit", 2**27)
    with pytest.raises(ExtrapolationError, match=rf"its array 'q_limit' declares {2**30} bytes in \d+; make it with"):
        extrapolate.load(forged)
    assert set(extrapolate.load(small)) == {"format", "t", "nrfe"}
