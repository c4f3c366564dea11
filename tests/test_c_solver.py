"""The solver library (gpmegen/csrc) on its own: tests/c/solver_check.c drives its dense solve,
factorizations, Jacobians and integrators through hand-written model descriptors with known
answers (orders of convergence, accuracy against exact motions, runs in chunks ending on the same
bits), linked with the library's object from the C cache as a model library links it; and the
object itself: built once per key and reused, rebuilt when its bytes are damaged, its key part of
each model library's."""

from __future__ import annotations

import subprocess
from pathlib import Path

import pytest

from gpmegen.runtime import ccompile

pytestmark = pytest.mark.requires_cc
CHECK = Path(__file__).parent / "c" / "solver_check.c"


def _run_checks(tmp_path: Path, flags, solver=None) -> subprocess.CompletedProcess:
    solver = solver or ccompile.build_solver(flags, cache=tmp_path / "cache")
    program = tmp_path / "solver_check"
    cc = ccompile.find_compiler()
    subprocess.run([*cc, *flags, f"-I{ccompile.solver_include()}", "-o", str(program), str(CHECK),
                    str(solver.path), "-lm"], check=True, capture_output=True, text=True)
    return subprocess.run([str(program)], capture_output=True, text=True, timeout=300)


def test_the_solver_library_passes_its_c_checks(tmp_path, fresh_cache):  # the run's object, in tmp_path / "cache"
    run = _run_checks(tmp_path, ccompile.DEFAULT_FLAGS)
    lines = run.stdout.splitlines()
    assert run.returncode == 0 and not [line for line in lines if not line.startswith("ok ")], run.stdout
    assert len(lines) == 19, run.stdout  # every check ran


@pytest.mark.long   # the solver library compiled as one unit and checked
def test_a_compiler_without_partial_links_compiles_the_library_as_one_unit(tmp_path):
    """A compiler that refuses ``-r`` (the join of the sources' objects) gets the sources as one
    translation unit instead: the object passes the same checks."""
    log = tmp_path / "asked.txt"
    refusing = tmp_path / "cc-without-r"
    refusing.write_text(f"""#!/bin/sh
for a in "$@"; do
    if [ "$a" = "-r" ]; then
        echo "-r" >> '{log}'
        echo "cc-without-r: error: unrecognized command-line option '-r'" >&2
        exit 1
    fi
done
exec {ccompile.find_compiler()[0]} "$@"
""")
    refusing.chmod(0o755)
    solver = ccompile.build_solver(cache=tmp_path / "cache", compiler=[str(refusing)])
    assert solver.compiled and log.read_text() == "-r\n"
    run = _run_checks(tmp_path, ccompile.DEFAULT_FLAGS, solver)
    lines = run.stdout.splitlines()
    assert run.returncode == 0 and len(lines) == 19 and all(line.startswith("ok ") for line in lines), run.stdout


def test_the_solver_sources_compile_without_warnings(tmp_path):
    cc = ccompile.find_compiler()
    for name in ccompile.solver_sources():
        if name.endswith(".c"):
            run = subprocess.run([*cc, "-O2", "-std=c99", "-Wall", "-Wextra", "-Werror", "-pedantic", "-fPIC", "-c",
                                  str(ccompile.solver_include() / name), "-o", str(tmp_path / "unit.o")],
                                 capture_output=True, text=True)
            assert run.returncode == 0 and run.stderr == "", (name, run.stderr)


@pytest.mark.long   # three compiles of the solver library
def test_the_solver_object_is_built_once_and_rebuilt_when_damaged(tmp_path):
    cache = tmp_path / "cache"
    first = ccompile.build_solver(cache=cache)
    assert first.compiled and first.path.name == f"{ccompile.SOLVER_PREFIX}{first.key}.o"
    again = ccompile.build_solver(cache=cache)
    assert not again.compiled and again.path == first.path
    first.path.write_bytes(first.path.read_bytes()[:100])
    rebuilt = ccompile.build_solver(cache=cache)
    assert rebuilt.compiled and "does not match its recorded sha256" in rebuilt.rebuilt_reason
    other = ccompile.build_solver(ccompile.DEFAULT_FLAGS + ("-DALIGNED=",), cache=cache)
    assert other.compiled and other.key != first.key


def test_a_cache_folder_without_room_for_the_solver_object_is_one_line(tmp_path, monkeypatch):
    """Where no file can be made in the cache folder (read-only, full), building the solver
    object, and with it any model library, raises BuildError naming the folder and the fix."""
    def refuse(*args, **kwargs):
        raise PermissionError(13, "Permission denied")

    monkeypatch.setattr(ccompile.tempfile, "mkstemp", refuse)
    source = tmp_path / "model.c"
    folder = Path(__file__).resolve().parents[1] / "generated" / "manipulator_nrfe1"
    for name in ("model.c", ccompile.HEADER):
        (tmp_path / name).write_text((folder / name).read_text())
    for build in (lambda: ccompile.build_solver(cache=tmp_path / "cache"),
                  lambda: ccompile.build_library(source, cache=tmp_path / "cache")):
        with pytest.raises(ccompile.BuildError) as refused:
            build()
        assert str(refused.value) == (f"cannot write the solver library into the C cache folder {tmp_path / 'cache'} "
                                      f"(Permission denied); set GPMEGEN_CACHE to a writable folder")


def test_a_model_library_links_the_solver_object_of_its_flags(tmp_path, fresh_cache):  # tmp_path / "cache"
    """The model library's key names the solver's: a changed solver builds the model again."""
    source = tmp_path / "model.c"
    folder = Path(__file__).resolve().parents[1] / "generated" / "manipulator_nrfe1"
    for name in ("model.c", ccompile.HEADER):
        (tmp_path / name).write_text((folder / name).read_text())
    info = ccompile.build_library(source, cache=tmp_path / "cache")
    assert info.solver is not None and info.solver.path.exists()
    assert ccompile.build_solver(cache=tmp_path / "cache").key == info.solver.key
    # a cached model library is reused without its solver object: that is needed only to link
    for path in (info.solver.path, info.solver.path.with_suffix(".json")):
        path.unlink()
    again = ccompile.build_library(source, cache=tmp_path / "cache")
    assert not again.compiled and again.path == info.path and again.solver is None
    assert not list((tmp_path / "cache").glob(f"{ccompile.SOLVER_PREFIX}*"))
    # the model library exports the model's names only: the solver's are hidden inside it
    symbols = subprocess.run(["nm", "-D", "--defined-only", str(info.path)], capture_output=True, text=True)
    if symbols.returncode == 0:
        assert "gpmegen_rk4" not in symbols.stdout and "manipulator_nrfe1_rk4" in symbols.stdout


@pytest.mark.sanitizers
def test_the_solver_library_passes_its_c_checks_under_the_sanitizers(tmp_path):
    """The same checks with the library and the program under AddressSanitizer and
    UndefinedBehaviorSanitizer (the flags of tests/test_c_sanitizers.py): no access outside an
    array (the variable-length ones sized from the descriptor), no undefined behaviour."""
    flags = ("-O1", "-fsanitize=address,undefined", "-fno-sanitize-recover=all", "-fno-omit-frame-pointer",
             "-std=c99", "-ffp-contract=off", "-fno-math-errno")
    probe = subprocess.run([*ccompile.find_compiler(), "-print-file-name=libasan.so"], capture_output=True, text=True)
    if not Path(probe.stdout.strip()).is_absolute():
        pytest.skip("the compiler has no libasan.so (sanitizers not installed)")
    run = _run_checks(tmp_path, flags)
    assert run.returncode == 0 and run.stderr == "", run.stdout + run.stderr
    assert len(run.stdout.splitlines()) == 19 and "FAIL" not in run.stdout, run.stdout
