"""The typed public boundary: mypy checks gpmegen's public modules as pyproject.toml configures it
(make test runs it), and a caller's wrong argument is reported by it; the annotations agree with
what the functions do (the NumPy backend refuses the compiled loops in one line)."""

import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

from gpmegen.errors import SimulationError

ROOT = Path(__file__).resolve().parents[1]


def _mypy(tmp_path, *args):
    """mypy run with the project's configuration, its cache in ``tmp_path``, gpmegen read from
    the repository."""
    env = {**os.environ, "MYPYPATH": str(ROOT)}
    return subprocess.run([sys.executable, "-m", "mypy", "--config-file", str(ROOT / "pyproject.toml"),
                           "--cache-dir", str(tmp_path / "cache"), *args],
                          capture_output=True, text=True, cwd=ROOT, env=env)


def test_mypy_reports_a_wrong_argument_to_the_public_api(tmp_path):
    caller = tmp_path / "caller.py"
    caller.write_text("import gpmegen\n\n"
                      "model = gpmegen.load('manipulator', nrfe='five')\n"
                      "results = gpmegen.simulate(t_end=1.0)\n"
                      "results.coordinate(3)\n"
                      "right: float = model.mass_matrix([0.0])[0, 0]\n")
    done = _mypy(tmp_path, str(caller))
    lines = [line for line in done.stdout.splitlines() if ": error:" in line]
    assert done.returncode == 1, done.stdout + done.stderr
    # the two wrong calls, each on its line, and nothing about the right ones
    assert [line.split(":")[1] for line in lines] == ["3", "5"], done.stdout
    assert 'Argument "nrfe" to "load" has incompatible type "str"; expected "int | None"' in lines[0]
    assert 'Argument 1 to "coordinate" of "Results" has incompatible type "int"; expected "str"' in lines[1]


@pytest.mark.parametrize("method", ["dop853", "radau"])
def test_the_numpy_backend_refuses_the_compiled_adaptive_loops_in_one_line(rigid, method):
    n = rigid.n_dof
    loop = getattr(rigid, method)
    with pytest.raises(SimulationError, match=f"--method {method} runs in the compiled C loop"):
        loop(0.0, np.zeros(2 * n + 2), np.array([0.1]), 1e-6, 1e-8, np.zeros(1), np.zeros(5, np.int64),
             None, 0, 0)
    with pytest.raises(SimulationError, match=f"--method {method} runs in the compiled C loop"):
        rigid.loop_memory(method)
