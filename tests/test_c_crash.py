"""The compiled library must never take the process down.

- A spinning flexible beam (one revolute joint, a 10 m link, n_rfe = 10, its joint prescribed)
  died with SIGSEGV in the GPME solve when compiled with AVX-512 tuning: GCC 12 stored into a
  local array with aligned vector moves while the array's stack slot was only 16-byte aligned
  (tests/c/gcc_vectorizer_alignment.c). The generated C now declares its local arrays aligned.
- A freshly compiled library is exercised in a child process before this process loads it; a
  library that fails there is never loaded, the verdict is remembered with the library, and the
  command line falls back to NumPy with one line.
"""

from __future__ import annotations

import json
import shutil
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import stacked_gpme

import gpmegen
from gpmegen.analysis.run.model_files import load_model_file
from gpmegen.errors import BuildError
from gpmegen.runtime import ccompile, cprobe, integrators

SPINNING_BEAM = Path(__file__).parent / "models" / "spinning_beam.toml"

pytestmark = pytest.mark.requires_cc
AVX512 = "avx512f" in (Path("/proc/cpuinfo").read_text() if Path("/proc/cpuinfo").exists() else "")
#: The tuning under which GCC 12 miscompiled the beam: AVX-512 for a generic x86-64-v4 processor.
AVX512_FLAGS = tuple(f if f != "-march=native" else "-march=x86-64-v4" for f in ccompile.DEFAULT_FLAGS)


@pytest.fixture(scope="module")
def beam(env):
    return gpmegen.load(model=load_model_file(SPINNING_BEAM), backend="numpy")


def test_spinning_beam_runs_compiled_for_avx512_and_agrees_with_numpy(env, beam):
    if not AVX512:
        pytest.skip("this processor has no AVX-512, where the fault was")
    from gpmegen.runtime.cmodel import CModel

    assert beam.n_dof == 28
    compiled = CModel(beam.module, folder=beam.folder, flags=AVX512_FLAGS, cache=env[1])
    rng = np.random.default_rng(3)
    zero = np.zeros(beam.n_dof)
    states = [(0.0, zero, zero)] + [(rng.uniform(0, 20), 0.05 * rng.standard_normal(beam.n_dof),
                                    0.5 * rng.standard_normal(beam.n_dof)) for _ in range(4)]
    for k, (t, q, qd) in enumerate(states):
        expected = beam.accelerations(t, q, qd)
        got = compiled.accelerations(t, q, qd)
        A, b = stacked_gpme(beam, t, q, qd)
        scale = np.linalg.norm(A) * np.linalg.norm(got) + np.linalg.norm(b)
        assert np.linalg.norm(A @ got - b) <= 1e-14 * scale
        # 1e-12 outright at rest; elsewhere also within what cond(A) lets two stable solvers differ by
        bound = 1e-12 if k == 0 else max(1e-12, 4 * np.linalg.cond(A) * np.finfo(float).eps)
        assert np.linalg.norm(got - expected) <= bound * np.linalg.norm(expected)
    assert np.any(compiled.accelerations(*states[1]) != 0)
    # the whole RK4 loop in C against the NumPy loop over 200 steps
    t, q, qd, _, status = compiled.rk4(zero, zero, 2e-3, 1e-5, save_every=50)
    assert status == 0
    t_np, y_np, outcome = integrators.rk4.rk4(beam, zero, zero, 2e-3, 1e-5, 50)
    assert outcome.complete
    np.testing.assert_allclose(t, t_np, rtol=0, atol=1e-15)
    np.testing.assert_allclose(q, y_np[:, :beam.n_dof], rtol=1e-10, atol=1e-13)


def test_local_arrays_of_the_generated_c_are_all_declared_aligned(env, beam):
    """The workaround is a rule for every local array, so that new code cannot forget it: in the
    generated C and in the solver library's (gpmegen/csrc), which every model library links."""
    import re

    source = (Path(beam.folder) / "model.c").read_text() + "".join(ccompile.solver_sources().values())
    declarations = re.findall(r"^ +(?:double|int|long) +([^;()\n]*\[[^;()\n]*);", source, re.M)
    assert declarations, "no local arrays found: the pattern is out of date"
    for line in declarations:
        for declarator in re.split(r",(?![^\[{]*[\]}])", line):
            name_and_size = declarator.split("=")[0].strip()  # an initializer follows the attribute
            if "[" in name_and_size:
                assert name_and_size.endswith("ALIGNED"), declarator


def _library_meta(cache: Path) -> Path:
    """The metadata of the one model library in ``cache`` (beside it, the solver library's)."""
    [meta] = [p for p in cache.glob("*.json") if not p.name.startswith(ccompile.SOLVER_PREFIX)]
    return meta


def _crashing_library(tmp_path, folder, cache) -> Path:
    """The library of ``folder/model.c`` whose ``points`` dies with SIGSEGV, linked with the
    solver library of ``cache``."""
    compiler = ccompile.find_compiler()
    crash = tmp_path / "crash.c"
    points = f"{folder.name}_points"  # the exported name: the model's name is its prefix
    crash.write_text(f"#include <signal.h>\nvoid {points}(const double *q, const double *p, double *out_P)\n"
                     "{ (void)q; (void)p; (void)out_P; raise(SIGSEGV); }\n")
    model = tmp_path / "model.o"
    subprocess.run([*compiler, "-O1", "-fPIC", f"-D{points}=points_replaced", f"-I{ccompile.solver_include()}", "-c",
                    "-o", model, folder / "model.c"], check=True, capture_output=True)
    library = tmp_path / "crashing.so"
    solver = ccompile.build_solver(cache=cache).path
    subprocess.run([*compiler, "-shared", "-fPIC", "-o", library, model, crash, solver, "-lm"], check=True,
                   capture_output=True)
    return library


@pytest.mark.long   # compiles a crashing copy of the model; a failed check remembered is in make test
def test_a_crash_in_the_test_run_is_reported_with_the_function(tmp_path, env):
    rigid = gpmegen.load("manipulator", nrfe=1, backend="numpy")
    folder = Path(rigid.folder)
    verdict = cprobe.check_in_child(_crashing_library(tmp_path, folder, env[1]), folder / "model.c",
                                    folder / "model_numpy.py")
    assert verdict == "the test process was killed by SIGSEGV in points()"
    assert cprobe.check_in_child(ccompile.build_library(folder / "model.c", cache=env[1]).path,
                                 folder / "model.c", folder / "model_numpy.py") is None


def test_a_failed_check_is_remembered_and_never_loaded(tmp_path, env, fresh_cache):
    rigid = gpmegen.load("manipulator", nrfe=1, backend="numpy")
    source = Path(rigid.folder) / "model.c"
    cache = fresh_cache
    calls = []

    def failing(library):
        calls.append(library)
        return "the test process was killed by SIGSEGV in rk4()"

    for _ in range(2):
        with pytest.raises(BuildError, match=r"failed its test run \(the test process was killed by SIGSEGV"):
            ccompile.load_library(source, cache=cache, check=failing)
    assert len(calls) == 1
    assert not any(str(path) in ccompile._loaded for path in calls)
    meta = json.loads(_library_meta(cache).read_text())
    assert meta["check"].startswith("the test process was killed")


def test_a_test_run_that_cannot_start_leaves_no_verdict(tmp_path, env, fresh_cache):
    """A test process whose Python cannot start (its environment torn down under it, as a removed
    virtual environment does) says nothing of the library: it used to be recorded as the
    library's failure, so every later load of that library, in any environment, was refused."""
    rigid = gpmegen.load("manipulator", nrfe=1, backend="numpy")
    folder = Path(rigid.folder)
    cache = fresh_cache

    def broken(library):
        return cprobe.check_in_child(library, folder / "model.c", folder / "model_numpy.py",
                                     env={"PYTHONHOME": str(tmp_path / "no-python-here")})

    with pytest.raises(cprobe.ProbeUnavailable, match="could not start"):
        ccompile.load_library(folder / "model.c", cache=cache, check=broken)
    assert "check" not in json.loads(_library_meta(cache).read_text())
    ffi, lib, _ = ccompile.load_library(  # the next load tests it again, and it passes
        folder / "model.c", cache=cache,
        check=lambda library: cprobe.check_in_child(library, folder / "model.c", folder / "model_numpy.py"))
    assert json.loads(_library_meta(cache).read_text())["check"] == "ok"


def test_the_command_line_falls_back_to_numpy_in_one_line(tmp_path, env):
    cache = tmp_path / "cache"
    gpmegen.load("manipulator", nrfe=1, backend="c")  # compile once, checked
    shutil.copytree(env[1], cache)
    for meta_path in cache.glob("*.json"):
        meta = json.loads(meta_path.read_text())
        meta["check"] = "the test process was killed by SIGSEGV in gpme_motion()"
        meta_path.write_text(json.dumps(meta))
    run = subprocess.run(
        [sys.executable, "-m", "gpmegen.cli", "simulate", "--nrfe", "1", "--t-end", "0.01", "--dt", "1e-4",
         "--out", str(tmp_path / "run.npz")],
        capture_output=True, text=True, env={**__import__("os").environ, "GPMEGEN_CACHE": str(cache)})
    assert run.returncode == 0, run.stderr
    fallback = [line for line in run.stderr.splitlines() if "C backend unavailable" in line]
    assert len(fallback) == 1 and "SIGSEGV in gpme_motion()" in fallback[0]
    assert "using the NumPy backend" in fallback[0]
    assert "(numpy, rk4" in run.stdout
    assert "Traceback" not in run.stderr
