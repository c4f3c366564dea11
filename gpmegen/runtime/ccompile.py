"""Compiling a generated ``model.c`` (with its header ``model.h``) into a shared library and
loading it with cffi (ABI mode).

The library is cached in ``$GPMEGEN_CACHE`` (default ``~/.cache/gpmegen/c/``) under a key, the
sha256 of the source and header, the compiler (path and ``--version``) and the flags, so that any
change to one of them builds a new library and an unchanged one is reused. Beside each ``<key>.so`` a
``<key>.json`` records the library's own sha256 and the compile time: a library whose bytes no
longer match (truncated, overwritten) or that fails to load is rebuilt. Builds go to a temporary
file in the cache folder and are renamed into place, so two processes building the same key at
once both end with a complete library.

The hand-written C every model shares (the GPME's dense solve, the integrators, the Jacobians:
the package data ``gpmegen/csrc``) is the solver library, compiled once per machine, compiler and
flags into one object ``solver-<key>.o`` of the same cache (:func:`build_solver`, keyed by the
sources' sha256, the compiler and the flags, written by rename as the libraries are) and linked
into every model library, whose generated ``model.c`` includes its header ``gpmegen_solver.h``
and hands it the model's descriptor. A model library's key includes the solver's.

The functions to bind are those the header declares (:func:`declarations`). Their C names carry
the model's name as prefix (``arm_nrfe3_mass_matrix`` for the model ``arm_nrfe3``), so that several models link into
one program; the binding :func:`load_library` returns names them without it (:func:`short_names`).
"""

from __future__ import annotations

import hashlib
import json
import os
import shlex
import shutil
import subprocess
import tempfile
import threading
import time
from dataclasses import dataclass
from importlib import resources
from pathlib import Path
from types import SimpleNamespace

from .. import limits
from ..errors import BuildError
from ..fileio import atomic_write_bytes
from .compiler import (  # noqa: F401 (re-exported: the compiler is read from here too)
    COLD_OPTIMIZATION,
    DEFAULT_FLAGS,
    GCC_FLAGS,
    LINK_FLAGS,
    compiler_identity,
    find_compiler,
    is_gcc,
)

#: The header of a generated C file, beside it; model.c includes it.
HEADER = "model.h"
#: Seconds between the progress lines of a running compile.
HEARTBEAT = 10.0
#: The macro that selects a part of a generated C file; a file that does not name it is compiled whole.
PARTS = "GPMEGEN_PART"
#: The function every generated header declares as ``<prefix>input_hash``: it names the prefix.
PREFIX_ANCHOR = "input_hash"
#: The solver library's header, which model.c includes; it is written beside model.h for the compile.
SOLVER_HEADER = "gpmegen_solver.h"
#: The name of the solver library's object in the cache: ``solver-<key>.o``.
SOLVER_PREFIX = "solver-"
#: The file that includes every source of the solver library: compiled as one unit into its object
#: where the compiler cannot join the objects of its sources (no ``-r``).
UNITY = "gpmegen_solver_all.c"

_lock = threading.Lock()
_loaded: dict = {}          # library path -> (ffi, lib), so repeated loads reuse one handle


def cache_directory() -> Path:
    """Where compiled libraries live: ``$GPMEGEN_CACHE``, else ``$XDG_CACHE_HOME/gpmegen/c``
    (``~/.cache/gpmegen/c``)."""
    env = os.environ.get("GPMEGEN_CACHE")
    if env:
        return Path(env).expanduser()
    return Path(os.environ.get("XDG_CACHE_HOME") or Path.home() / ".cache") / "gpmegen" / "c"


def library_key(source: str, identity: str, flags, header: str = "") -> str:
    """sha256 of what the library depends on: source, header, compiler identity, flags."""
    h = hashlib.sha256()
    for part in (source, identity, "\0".join(flags), header):
        h.update(part.encode())
        h.update(b"\0\0")
    return h.hexdigest()


def declarations(header: str) -> str:
    """The cffi declarations of a generated header: its text without the preprocessor lines (the
    include guards), which cffi's cdef does not take. The header has no multi-line macros."""
    return "".join(line for line in header.splitlines(keepends=True) if not line.lstrip().startswith("#"))


def short_names(names) -> dict:
    """``{short name: C name}`` of the exported functions among ``names``: the one place where
    the per-model prefix is resolved. The prefix is what precedes ``input_hash`` in the one name
    ending so; names without it (the status constants) are left out."""
    names = list(names)
    anchors = [name for name in names if name.endswith("_" + PREFIX_ANCHOR)]
    if len(anchors) != 1:
        raise BuildError("the C header declares no single <model>_input_hash; it is not a gpmegen model "
                         "header (regenerate it with 'gpmegen build --force')")
    prefix = anchors[0][:-len(PREFIX_ANCHOR)]
    return {name[len(prefix):]: name for name in names if name.startswith(prefix)}


def bind(lib) -> SimpleNamespace:
    """The functions of a loaded model library ``lib`` (cffi) under their short names
    (``mass_matrix``, ``rk4``, ``input_hash``), looked up once."""
    return SimpleNamespace(_library=lib, **{short: getattr(lib, name) for short, name in short_names(dir(lib)).items()})


def solver_sources() -> dict[str, str]:
    """The solver library's sources, ``{file name: text}`` in name order: the C files and headers
    of the package data ``gpmegen.csrc``."""
    root = resources.files("gpmegen.csrc")
    names = sorted(p.name for p in root.iterdir() if p.name.endswith((".c", ".h")))
    return {name: root.joinpath(name).read_text(encoding="utf-8") for name in names}


def solver_include() -> Path:
    """The folder of the solver library's sources (``-I`` of a compile of model.c made by hand)."""
    return Path(str(resources.files("gpmegen.csrc")))


def _solver_key(sources: dict, identity: str, flags) -> str:
    text = "".join(f"{name}\0{text}\0" for name, text in sources.items())
    return library_key(text, identity, tuple(flags) + ("solver",))


def _solver_plan(flags, compiler) -> tuple[tuple, dict, str]:
    """The solver library's flags (``flags`` and the GCC flags), sources and key, nothing built."""
    identity = compiler_identity(compiler)
    flags = tuple(flags) + (GCC_FLAGS if is_gcc(identity) and not set(GCC_FLAGS) <= set(flags) else ())
    sources = solver_sources()
    return flags, sources, _solver_key(sources, identity, flags)


@dataclass
class CompiledLibrary:
    """A compiled model library: where it is, its key, and how it was obtained."""

    path: Path
    key: str
    compiler: str
    flags: tuple
    compiled: bool          # built in this call (False: reused from the cache)
    compile_seconds: float  # wall time of the compiler run that produced the library
    rebuilt_reason: str | None = None  # why a cached library was not reused
    solver: CompiledLibrary | None = None  # the solver library's object it linked (None: reused from the cache)


def _sha256_file(path: Path) -> str:
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for chunk in iter(lambda: fh.read(1 << 20), b""):
            h.update(chunk)
    return h.hexdigest()


def _read_meta(path: Path) -> dict | None:
    try:
        meta = json.loads(path.read_text())
    except (OSError, ValueError):
        return None
    return meta if isinstance(meta, dict) else None


def _cached_ok(lib_path: Path, meta_path: Path) -> tuple[bool, str | None, dict | None]:
    if not lib_path.exists():
        return False, None, None
    meta = _read_meta(meta_path)
    if meta is None:
        return False, f"{meta_path.name} is missing or unreadable", None
    try:
        digest = _sha256_file(lib_path)
    except OSError as exc:
        return False, f"{lib_path.name} cannot be read ({exc.strerror})", None
    if digest != meta.get("sha256"):
        return False, f"{lib_path.name} does not match its recorded sha256 (truncated or overwritten)", None
    return True, None, meta


def _remove_abandoned(cache: Path, older_than=24 * 3600.0) -> None:
    """Temporary files (and header folders) of builds that were killed before their rename."""
    limit = time.time() - older_than
    for path in cache.glob(".*.tmp"):
        try:
            if path.stat().st_mtime < limit:
                shutil.rmtree(path) if path.is_dir() else path.unlink()
        except OSError:
            pass


def _run_compilers(argvs, cwd: str, say) -> list[tuple[int, str]]:
    """Run the compiler commands ``argvs`` at once in ``cwd``: (exit status, diagnostics) of each.
    With ``say``, a line every :data:`HEARTBEAT` seconds says they are still running; an
    interruption ends them all. A compiler that cannot be started is a :class:`BuildError`."""
    runs, t0 = [], time.perf_counter()
    try:
        for k, argv in enumerate(argvs):
            try:
                with open(Path(cwd, f"diagnostics{k}.txt"), "wb") as diagnostics:
                    runs.append(subprocess.Popen(argv, stdin=subprocess.DEVNULL, stdout=diagnostics,
                                                 stderr=subprocess.STDOUT, cwd=cwd))
            except OSError as exc:
                raise BuildError(f"cannot run the C compiler {argv[0]} ({exc.strerror}); set CC to a "
                                 f"working C compiler or use backend='numpy'") from None
        for run in runs:
            while True:
                try:
                    run.wait(timeout=HEARTBEAT if say else None)
                    break
                except subprocess.TimeoutExpired:
                    say(f"still compiling, {time.perf_counter() - t0:.0f} s so far")
    except BaseException:
        for run in runs:
            run.kill()
            run.wait()
        raise
    return [(run.returncode, Path(cwd, f"diagnostics{k}.txt").read_text("utf-8", "replace").strip())
            for k, run in enumerate(runs)]


def part_flags(flags) -> tuple[tuple, tuple]:
    """The flags of the two parts of model.c (see model.c.j2): the hot path with ``flags``, the
    functions called rarely with every optimization level in them replaced by
    :data:`COLD_OPTIMIZATION`."""
    cold = tuple(COLD_OPTIMIZATION if f.startswith("-O") else f for f in flags)
    return tuple(flags), cold


def _compile(compiler, flags, source: str, header: str, source_path: Path, lib_path: Path, meta_path: Path,
             key: str, say=None, solver: Path | None = None) -> float:
    cache = lib_path.parent
    _remove_abandoned(cache)
    fd, tmp = tempfile.mkstemp(prefix=f".{key[:16]}.", suffix=".so.tmp", dir=cache)
    os.close(fd)
    tmp = Path(tmp)
    # The compiler reads the texts the key was made of, not the files, which may have changed
    # since they were read: both are written into a private folder it runs in.
    # (the compiler by its absolute path: a relative $CC names it from the caller's folder)
    cc = [os.path.abspath(compiler[0]), *compiler[1:]]
    solver_objects = [str(solver)] if solver is not None else []
    if PARTS in source:
        parts = [[*cc, *part, "-fPIC", f"-D{PARTS}={k}", "-c", "model.c", "-o", f"part{k}.o"]
                 for k, part in enumerate(part_flags(flags), start=1)]
        link = [*cc, *flags, *LINK_FLAGS, "-o", str(tmp), "part1.o", "part2.o", *solver_objects, "-lm"]
    else:  # a C file not made in parts (not generated by this version): compiled whole
        parts, link = [], [*cc, *flags, *LINK_FLAGS, "-o", str(tmp), "model.c", *solver_objects, "-lm"]
    t0 = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory(prefix=f".{key[:16]}.", suffix=".h.tmp", dir=cache) as folder:
            Path(folder, HEADER).write_text(header, encoding="utf-8")
            Path(folder, SOLVER_HEADER).write_text(solver_sources()[SOLVER_HEADER], encoding="utf-8")
            Path(folder, "model.c").write_text(source, encoding="utf-8")
            results = _run_compilers(parts, folder, say)
            if all(code == 0 for code, _ in results):
                results += _run_compilers([link], folder, None if parts else say)
        seconds = time.perf_counter() - t0
        for argv, (returncode, diagnostics) in zip(parts + [link], results):
            if returncode != 0:
                raise BuildError(
                    f"compiling {source_path} failed (exit {returncode}):\n{diagnostics[:4000]}\n"
                    f"command: {' '.join(shlex.quote(a) for a in argv)} (in a folder holding {source_path} "
                    f"and its {HEADER})"
                )
        diagnostics = "\n".join(text for _, text in results if text)
        digest = _sha256_file(tmp)
        meta = {
            "sha256": digest, "compile_seconds": seconds, "compiler": " ".join(compiler),
            "flags": list(flags) + list(LINK_FLAGS), "cold_flags": list(part_flags(flags)[1]) if parts else None,
            "source": str(source_path), "built": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
            "warnings": diagnostics[:4000],
        }
        # The metadata first: a reader that sees the new library also sees its digest. If two
        # builders interleave, a mismatch only causes one more rebuild later.
        atomic_write_bytes(meta_path, (json.dumps(meta, indent=2, sort_keys=True) + "\n").encode())
        os.chmod(tmp, 0o755)
        os.replace(tmp, lib_path)
    finally:
        tmp.unlink(missing_ok=True)
    return seconds


def _read_source(source_path: Path) -> str:
    try:
        return source_path.read_text(encoding="utf-8")
    except OSError as exc:
        raise BuildError(f"cannot read {source_path} ({exc.strerror}); rebuild the model with "
                         f"'gpmegen build --force'") from None


def build_solver(flags=DEFAULT_FLAGS, cache=None, progress=None, compiler=None) -> CompiledLibrary:
    """The solver library's object (``solver-<key>.o`` in the cache) for ``flags`` (to which the
    GCC flags are added as for a model, when the compiler is GCC): reused when its key matches
    and its bytes are intact, else compiled, each source apart and at once, and joined into one
    relocatable object (``-r``; where the compiler refuses it, the sources are compiled as one unit
    instead, :data:`UNITY`). Raises :class:`BuildError` as :func:`build_library`."""
    compiler = compiler or find_compiler()
    flags, sources, key = _solver_plan(flags, compiler)
    cache = _cache_folder(cache)
    path, meta_path = cache / f"{SOLVER_PREFIX}{key}.o", cache / f"{SOLVER_PREFIX}{key}.json"
    ok, reason, meta = _cached_ok(path, meta_path)
    if ok:
        return CompiledLibrary(path, key, compiler[0], flags, False, float(meta.get("compile_seconds", 0.0)))
    if progress:
        progress("compiling the solver library (once per compiler and flags)")
    _remove_abandoned(cache)
    cc = [os.path.abspath(compiler[0]), *compiler[1:]]
    units = [name for name in sources if name.endswith(".c")]
    compiles = [[*cc, *flags, "-fPIC", "-c", name, "-o", name[:-2] + ".o"] for name in units]
    t0 = time.perf_counter()
    tmp = None
    try:
        # in the try: a cache folder where nothing can be written is one line, as for the libraries
        fd, tmp = tempfile.mkstemp(prefix=f".{key[:16]}.", suffix=".o.tmp", dir=cache)
        os.close(fd)
        tmp = Path(tmp)
        join = [*cc, "-r", "-o", str(tmp), *(name[:-2] + ".o" for name in units)]
        with tempfile.TemporaryDirectory(prefix=f".{key[:16]}.", suffix=".src.tmp", dir=cache) as folder:
            for name, text in sources.items():
                Path(folder, name).write_text(text, encoding="utf-8")
            results = _run_compilers(compiles, folder, progress)
            if all(code == 0 for code, _ in results):
                results += _run_compilers([join], folder, None)
                if results[-1][0] != 0:   # a compiler without -r: the sources as one unit instead
                    Path(folder, UNITY).write_text("".join(f'#include "{name}"\n' for name in units))
                    compiles, join = [], [*cc, *flags, "-fPIC", "-c", UNITY, "-o", str(tmp)]
                    results = _run_compilers([join], folder, progress)
        seconds = time.perf_counter() - t0
        for argv, (returncode, diagnostics) in zip(compiles + [join], results):
            if returncode != 0:
                raise BuildError(f"compiling the solver library failed (exit {returncode}):\n{diagnostics[:4000]}\n"
                                 f"command: {' '.join(shlex.quote(a) for a in argv)}")
        meta = {"sha256": _sha256_file(tmp), "compile_seconds": seconds, "compiler": " ".join(compiler),
                "flags": list(flags), "sources": list(sources), "built": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
                "warnings": "\n".join(text for _, text in results if text)[:4000]}
        atomic_write_bytes(meta_path, (json.dumps(meta, indent=2, sort_keys=True) + "\n").encode())
        os.chmod(tmp, 0o644)
        os.replace(tmp, path)
    except OSError as exc:
        raise BuildError(f"cannot write the solver library into the C cache folder {cache} ({exc.strerror}); "
                         f"set GPMEGEN_CACHE to a writable folder") from None
    finally:
        if tmp is not None:
            tmp.unlink(missing_ok=True)
    if progress:
        progress(f"compiled the solver library in {seconds:.1f} s")
    return CompiledLibrary(path, key, compiler[0], flags, True, seconds, reason)


def _cache_folder(cache) -> Path:
    cache = Path(cache) if cache is not None else cache_directory()
    try:
        cache.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise BuildError(f"cannot create the C cache folder {cache} ({exc.strerror}); set GPMEGEN_CACHE "
                         f"to a writable folder") from None
    return cache


def build_library(source_path, flags=DEFAULT_FLAGS, cache=None, text=None, header=None,
                  progress=None) -> CompiledLibrary:
    """The shared library of the C file ``source_path`` (of its ``text`` when given, already
    read) and of its ``header`` (by default the text of ``model.h`` beside it): reused from the
    cache when its key matches and its bytes are intact, else compiled. ``progress`` (a callable
    taking one line) is told when a compile starts, with its estimated time, while it runs, and
    when it ends. Raises
    :class:`BuildError` when no compiler is found, the cache folder is not writable, or
    compilation fails."""
    source_path = Path(source_path)
    source = _read_source(source_path) if text is None else text
    header = _read_source(source_path.with_name(HEADER)) if header is None else header
    compiler = find_compiler()
    identity = compiler_identity(compiler)
    base_flags = tuple(flags)
    flags = base_flags + (GCC_FLAGS if is_gcc(identity) else ())
    cache = _cache_folder(cache)
    # the solver's key names it; its object is needed (and built if missing) only to link a new library
    key = library_key(source, identity, flags + LINK_FLAGS + part_flags(flags)[1]
                      + (_solver_plan(base_flags, compiler)[2],), header)
    lib_path, meta_path = cache / f"{key}.so", cache / f"{key}.json"
    ok, reason, meta = _cached_ok(lib_path, meta_path)
    if ok:
        return CompiledLibrary(lib_path, key, compiler[0], flags, False, float(meta.get("compile_seconds", 0.0)))
    solver = build_solver(base_flags, cache, progress, compiler)
    size = len(source.encode())
    limits.check_compile(size, source_path)
    if progress:
        progress(f"compiling {source_path.name} ({size / 1e6:.2g} MB of C; estimated "
                 f"{limits.duration(limits.interpolate(limits.COMPILE_SECONDS, size))} of CPU time)")
    try:
        seconds = _compile(compiler, flags, source, header, source_path, lib_path, meta_path, key, progress,
                           solver.path)
    except OSError as exc:  # e.g. a read-only cache folder: the library cannot be written there
        raise BuildError(f"cannot write the compiled library into the C cache folder {cache} ({exc.strerror}); "
                         f"set GPMEGEN_CACHE to a writable folder") from None
    if progress:
        progress(f"compiled {source_path.name} in {seconds:.1f} s")
    return CompiledLibrary(lib_path, key, compiler[0], flags, True, seconds, reason, solver)


def open_library(path: Path, header: str):
    """``(ffi, functions)`` of the library at ``path`` declared by ``header``: the functions
    under their short names (:func:`bind`). Opened once per process and declarations."""
    import cffi

    cdef = declarations(header)
    with _lock:
        hit = _loaded.get(str(path))
        if hit is not None and hit[2] == cdef:
            return hit[0], hit[1]
        ffi = cffi.FFI()
        ffi.cdef(cdef)
        lib = bind(ffi.dlopen(str(path)))
        _loaded[str(path)] = (ffi, lib, cdef)
        return ffi, lib


def checked(info: CompiledLibrary, check, source_path: Path) -> None:
    """Run ``check(library path)`` (None when the library is safe to load, else why not) once
    per library: its verdict is recorded in the library's metadata and read back on later
    loads. Raises :class:`BuildError` when the library is not safe."""
    meta_path = info.path.with_suffix(".json")
    meta = _read_meta(meta_path) or {}
    verdict = meta.get("check")
    if verdict is None:
        verdict = check(info.path) or "ok"
        try:
            atomic_write_bytes(meta_path, (json.dumps({**meta, "check": verdict}, indent=2, sort_keys=True)
                                           + "\n").encode())
        except OSError:
            pass  # a read-only cache: the check runs again next time
    if verdict != "ok":
        raise BuildError(f"the compiled library of {source_path} failed its test run ({verdict}); it is not "
                         f"loaded (a compiler defect or a fault in the generated C: please report it with "
                         f"{source_path})")


def load_library(source_path, flags=DEFAULT_FLAGS, cache=None, expect_hash=None, text=None, check=None,
                 header=None, progress=None):
    """Build (or reuse) and load the library of ``source_path`` (of its ``text`` when given,
    already read) and its ``header`` (by default ``model.h`` beside it); each file is read once,
    declarations and library from the same texts.

    ``check``: called with the library's path before this process first loads it (see
    :func:`checked`); a library it rejects is never loaded. Returns ``(ffi, lib, info)`` with
    ``info`` a :class:`CompiledLibrary`. A cached library that fails to load, or reports another
    input hash than ``expect_hash``, is rebuilt once. The returned ``lib`` holds the functions
    under their short names (``lib.mass_matrix``). ``progress``: as for :func:`build_library`."""
    source_path = Path(source_path)
    text = _read_source(source_path) if text is None else text
    header = _read_source(source_path.with_name(HEADER)) if header is None else header
    info = build_library(source_path, flags, cache, text, header, progress)
    for attempt in (0, 1):
        if check is not None:
            checked(info, check, source_path)
        try:
            ffi, lib = open_library(info.path, header)
            got = ffi.string(lib.input_hash()).decode()
            if expect_hash is not None and got != expect_hash:
                raise BuildError(f"{info.path} reports input hash {got}, expected {expect_hash}")
            return ffi, lib, info
        except (OSError, AttributeError, BuildError) as exc:
            if attempt or info.compiled:
                raise BuildError(f"the compiled model {info.path} (from {source_path}) cannot be loaded: "
                                 f"{exc}; delete it or the cache folder {info.path.parent} and retry") from None
            with _lock:
                _loaded.pop(str(info.path), None)
            info.path.unlink(missing_ok=True)
            reason = f"{info.path.name} failed to load ({exc})"
            info = build_library(source_path, flags, cache, text, header, progress)
            info.rebuilt_reason = reason
    raise AssertionError("unreachable")
