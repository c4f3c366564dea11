"""Single-state ``accelerations`` calls from Python at close to the cost of the C.

Through cffi (ABI mode) a call costs the C plus about 1.7 µs at ``n_rfe = 5``: checking and
copying ``q`` and ``q̇`` in Python, cffi's conversion of seven arguments, the result array. The
small CPython extension ``fastcall.c`` does that work in C: a ``Caller``, made once per model (its
parameter values and partition copied into it), checks ``(t, q, qd)`` and calls the library's
``gpme_accelerations`` through its address. Any call not of that fast form goes to the checked
Python path, so results and errors are those of that path.

The extension is the same for every model (no model text enters it). It is compiled once per
Python, NumPy, compiler and processor into the C cache (:func:`gpmegen.runtime.ccompile.cache_directory`),
keyed like the model libraries, written atomically, and exercised in a child process before this
process first imports it (:func:`exercise`; the verdict is kept beside it). Where it cannot be had
(no ``Python.h`` or NumPy headers, no compiler, a failed build or test run, or
``GPMEGEN_FASTCALL=0``), single calls go through cffi as before, with the same results.
"""

from __future__ import annotations

import importlib.machinery
import importlib.util
import json
import os
import subprocess
import sys
import sysconfig
import tempfile
import threading
import time
from pathlib import Path

import numpy as np

from ..errors import BuildError
from ..fileio import atomic_write_bytes
from . import ccompile
from .cprobe import TIMEOUT, ProbeUnavailable

SOURCE = Path(__file__).with_name("fastcall.c")
#: The extension's module name (its init function is ``PyInit_<NAME>``).
NAME = "gpmegen_fastcall"
#: The environment variable that, set to ``0``, keeps single calls on the cffi path.
SWITCH = "GPMEGEN_FASTCALL"
#: No -march=native: the extension only checks arguments and forwards the call.
FLAGS = ("-O2", "-Wall", "-Wextra")
LINK_FLAGS = ("-shared", "-fPIC") + (("-undefined", "dynamic_lookup") if sys.platform == "darwin" else ())

_lock = threading.Lock()
_extensions: dict = {}  # cache folder -> (module or None, why not)


def extension(cache=None, progress=None):
    """``(module, None)``: the extension, built or reused from ``cache`` (default: the C
    cache) and imported; or ``(None, why not)`` when single calls must go through cffi.
    ``progress`` (a callable taking one line) hears about a compile."""
    if os.environ.get(SWITCH, "").strip() == "0":
        return None, f"{SWITCH}=0"
    cache = Path(cache) if cache is not None else ccompile.cache_directory()
    with _lock:
        if str(cache) not in _extensions:
            try:
                _extensions[str(cache)] = (_load(cache, progress), None)
            except BuildError as exc:
                _extensions[str(cache)] = (None, str(exc))
        return _extensions[str(cache)]


def _include_folders() -> list[str]:
    """The folders of ``Python.h`` and of NumPy's headers; BuildError when either is missing."""
    python = sysconfig.get_paths().get("include") or ""
    numpy_include = np.get_include()
    for folder, header in ((python, "Python.h"), (numpy_include, "numpy/arrayobject.h")):
        if not Path(folder, header).is_file():
            raise BuildError(f"{header} is not installed (looked in {folder or 'no folder'})")
    return [python, numpy_include]


def _python_identity(includes) -> str:
    """What the extension's binary depends on besides the source and compiler."""
    return "\n".join([sys.version, sysconfig.get_config_var("EXT_SUFFIX") or "", np.__version__, *includes])


def _load(cache: Path, progress):
    includes = _include_folders()
    source = SOURCE.read_text(encoding="utf-8")
    compiler = ccompile.find_compiler()
    identity = ccompile.compiler_identity(compiler)
    key = ccompile.library_key(source, identity, FLAGS + LINK_FLAGS, _python_identity(includes))
    try:
        cache.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise BuildError(f"cannot create the C cache folder {cache} ({exc.strerror})") from None
    path = cache / f"{key}.so"
    ok, reason, meta = ccompile._cached_ok(path, path.with_suffix(".json"))
    if ok:
        info = ccompile.CompiledLibrary(path, key, compiler[0], FLAGS, False, float(meta.get("compile_seconds", 0)))
    else:
        if progress:
            progress("compiling the fast-call extension (once per Python and NumPy)")
        seconds = _compile(compiler, source, includes, path)
        info = ccompile.CompiledLibrary(path, key, compiler[0], FLAGS, True, seconds, reason)
        if progress:
            progress(f"compiled the fast-call extension in {seconds:.1f} s")
    ccompile.checked(info, check_in_child, SOURCE)
    return _import(path)


def _compile(compiler, source: str, includes, path: Path) -> float:
    """Compile ``source`` into ``path`` (a temporary file renamed into place, its metadata
    first); the compile's wall time in s."""
    cache = path.parent
    fd, tmp = tempfile.mkstemp(prefix=f".{path.stem[:16]}.", suffix=".so.tmp", dir=cache)
    os.close(fd)
    tmp = Path(tmp)
    cc = [os.path.abspath(compiler[0]), *compiler[1:]]
    argv = [*cc, *FLAGS, *LINK_FLAGS, *(f"-I{folder}" for folder in includes), "fastcall.c", "-o", str(tmp)]
    t0 = time.perf_counter()
    try:
        with tempfile.TemporaryDirectory(prefix=f".{path.stem[:16]}.", suffix=".c.tmp", dir=cache) as folder:
            Path(folder, "fastcall.c").write_text(source, encoding="utf-8")
            try:
                [(code, diagnostics)] = ccompile._run_compilers([argv], folder, None)
            except OSError as exc:
                raise BuildError(f"cannot run the C compiler {compiler[0]} ({exc.strerror})") from None
        if code != 0:
            raise BuildError(f"compiling the fast-call extension failed (exit {code}): {diagnostics[:2000]}")
        seconds = time.perf_counter() - t0
        meta = {"sha256": ccompile._sha256_file(tmp), "compile_seconds": seconds, "compiler": " ".join(compiler),
                "flags": list(FLAGS + LINK_FLAGS), "source": SOURCE.name, "warnings": diagnostics[:4000],
                "built": time.strftime("%Y-%m-%dT%H:%M:%S%z")}
        atomic_write_bytes(path.with_suffix(".json"), (json.dumps(meta, indent=2, sort_keys=True) + "\n").encode())
        os.chmod(tmp, 0o755)
        os.replace(tmp, path)
    except OSError as exc:
        raise BuildError(f"cannot write the fast-call extension into {cache} ({exc.strerror})") from None
    finally:
        tmp.unlink(missing_ok=True)
    return seconds


def _import(path: Path):
    loader = importlib.machinery.ExtensionFileLoader(NAME, str(path))
    spec = importlib.util.spec_from_loader(NAME, loader, origin=str(path))
    try:
        module = importlib.util.module_from_spec(spec)
        loader.exec_module(module)
    except ImportError as exc:
        raise BuildError(f"the fast-call extension {path} cannot be imported ({exc})") from None
    return module


def exercise(module) -> None:
    """Every path of a ``Caller`` over the extension's own test function (n = 3): the fast
    call, each form handed to the fallback (a state that is not finite among them), and a
    failed solve. AssertionError when one is wrong."""
    p, dependent, independent = np.array([0.5]), np.array([1], np.intc), np.array([0, 2], np.intc)

    def failure(status, t):
        return ArithmeticError(f"status {status} at {t}")

    caller = module.Caller(module.reference_address(), 3, p, dependent, independent,
                           lambda *args, **kwargs: ("fallback", args, kwargs), failure, None)
    q, qd = np.array([1.0, 2.0, 3.0]), np.array([0.25, 0.5, 0.75])
    releasing = module.Caller(module.reference_address(), 3, p, dependent, independent, print, failure, None, True)
    for t in (0.125, np.float64(0.125), 2):
        assert np.array_equal(caller(t, q, qd), float(t) + q + 2 * qd + 0.5 + 10 + 0), t
        assert np.array_equal(releasing(t, q, qd), caller(t, q, qd)), t
    others = [((0.1, q.tolist(), qd), {}), ((0.1, q.astype(np.float32), qd), {}), ((0.1, q, np.tile(qd, 2)[::2]), {}),
              ((0.1, q[:2], qd), {}), ((0.1, np.tile(q, (2, 1)), qd), {}), ((np.array(0.1), q, qd), {}),
              ((0.1, q), {}), ((0.1, q), {"qd": qd}), ((2**1100, q, qd), {}),
              ((np.inf, q, qd), {}), ((0.1, np.array([1.0, np.nan, 3.0]), qd), {}),
              ((0.1, q, np.array([0.25, 0.5, -np.inf])), {})]  # not finite: the checked path refuses it
    for args, kwargs in others:
        assert caller(*args, **kwargs)[0] == "fallback", args
    try:
        caller(0.5, np.array([-1.0, 0.0, 0.0]), qd)
    except ArithmeticError as exc:
        assert str(exc) == "status 2 at 0.5", exc
    else:
        raise AssertionError("a failed call did not raise")


STARTED = "fast-call test started"


def check_in_child(path: Path, timeout=TIMEOUT) -> str | None:
    """Run :func:`exercise` on the extension at ``path`` in a child process: None when every
    path works, else how the child ended; :class:`ProbeUnavailable` when it did not get to test."""
    argv = [sys.executable, "-m", "gpmegen.runtime.fastcall", str(path)]
    try:
        run = subprocess.run(argv, capture_output=True, text=True, timeout=timeout)
    except subprocess.TimeoutExpired:
        raise ProbeUnavailable(f"the test run of {path} did not finish within {timeout:g} s") from None
    if run.returncode == 0:
        return None
    detail = " ".join(run.stderr.strip().splitlines()[-1:])[:300] or "no message"
    if STARTED not in run.stdout.splitlines():
        raise ProbeUnavailable(f"the test run of {path} could not start (exit status {run.returncode}: {detail})")
    return f"the test process ended with status {run.returncode}: {detail}"


def main(argv=None) -> int:
    print(STARTED, flush=True)
    exercise(_import(Path((argv or sys.argv[1:])[0])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
