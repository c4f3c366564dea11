"""Levels run at once: on threads of this process where the loops are compiled (they release
Python's lock), else on a pool of processes; either way the bytes of the levels run one after
the other, and each level keeps the model its run loaded. A generated module loaded again runs
the code compiled the first time."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

from gpmegen.analysis.discretization.levels import compiled_loops, run_levels
from gpmegen.analysis.run.runspec import RunSpec

SPINUP = Path(__file__).resolve().parent.parent / "examples" / "spinup.toml"
KEYS = ("t", "q", "qd", "qdd", "lambda", "end_effector", "drive_forces", "constraint_forces", "kinetic_energy")


def test_threads_where_the_loops_are_compiled():
    assert compiled_loops("genalpha", "c", actuated=False)
    assert compiled_loops("rk4", "c", actuated=False)
    assert compiled_loops("radau", "c", actuated=False)
    assert not compiled_loops("rk4", "numpy", actuated=False)  # the NumPy loop holds the lock
    assert not compiled_loops("scipy-radau", "c", actuated=False)
    assert compiled_loops("rk4", "c", actuated=True)  # the actuated realization's compiled RK4
    assert compiled_loops("dop853", "c", actuated=True)  # and DOP853
    assert not compiled_loops("radau", "c", actuated=True)
    assert not compiled_loops("rk4", "numpy", actuated=True)


def _levels(backend, workers, told):
    return run_levels(SPINUP, (2, 3), RunSpec(start="none", t_end=0.05, dt=1e-3, save_every=10, method="rk4"), backend,
                      {"Omega": 6.0}, None, told.append, workers=workers)


# the pool of processes (each imports gpmegen and loads the model): make check-c
@pytest.mark.parametrize("backend, where", [pytest.param("c", "threads", marks=pytest.mark.requires_cc),
                                            pytest.param("numpy", "processes", marks=pytest.mark.long)])
def test_levels_at_once_are_the_levels_one_after_the_other(env, backend, where):
    told_serial, told = [], []
    serial, at_once = _levels(backend, 1, told_serial), _levels(backend, 2, told)
    assert f"2 levels on 2 {where}" in told and not any(" levels on " in line for line in told_serial)
    assert [level.nrfe for level in at_once] == [2, 3]
    for one, other in zip(serial, at_once):
        assert other.loaded.n_dof == one.loaded.n_dof == len(other.results["coordinates"])
        for key in KEYS:
            assert np.array_equal(one.results[key], other.results[key]), (backend, one.nrfe, key)


def test_a_generated_module_loaded_again_runs_the_code_compiled_from_its_text(tmp_path):
    """A process that loads one model again runs the code compiled the first time; other text
    (another module, or the same file changed) is compiled anew."""
    from gpmegen.runtime import numpy_module

    path = tmp_path / "model_numpy.py"
    first = numpy_module._code("X = 1\n", path)
    assert numpy_module._code("X = 1\n", path) is first
    assert numpy_module._code("X = 2\n", path) is not first
    namespace = {}
    exec(numpy_module._code("X = 2\n", path), namespace)
    assert namespace["X"] == 2
