"""The C compiler gpmegen builds with and its flags: found from $CC or the path, named by its
path, its version and the processor it builds for (the cache keys of the libraries name it)."""

from __future__ import annotations

import os
import shlex
import shutil
import subprocess
import sys
from pathlib import Path

from ..errors import BuildError

#: The compilers looked for on the path, in order, when $CC is not set.
COMPILERS = ("cc", "gcc", "clang")
#: Flags of every library build (``-shared -fPIC`` are added for linking). No ``-ffast-math``
#: and no contraction into fused multiply-adds: the C backend evaluates the generated expressions
#: with the same roundings as the NumPy one (bit for bit in practice) and sees non-finite values;
#: this matters because q̈ is sensitive to M and f by a condition number near 1e4 for the flexible
#: arm. ``-march=native``: built for this machine's processor, which the cache key names.
DEFAULT_FLAGS = ("-O3", "-march=native", "-std=c99", "-ffp-contract=off", "-fno-math-errno", "-Wall", "-Wextra")
#: Added when the compiler is GCC: priority-based register allocation. A generated function is one
#: long block of straight-line code with hundreds of values live at once, where GCC's default
#: colouring spills more: with this flag gpme_terms has 5% fewer instructions and an RK4 step
#: takes 5-8% less at n_rfe = 5 (3% at 10). Register allocation changes no rounding.
#: No vectorization of straight-line code: GCC 12's SLP vectorizer packs ``a*b - c*d`` beside
#: ``a*b + c*d`` into one fused ``vfmsubadd`` despite ``-ffp-contract=off`` (in ``gpme_terms``,
#: ``forces`` and ``recursive_terms`` of the reference arm at n_rfe = 2), a rounding the NumPy
#: backend does not make and that differed between a function cut into blocks and kept whole
#: (tests/test_c_blocks.py); without it the O(n) GPME solve at n_rfe = 5 takes 4-7% less.
GCC_FLAGS = ("-fira-algorithm=priority", "-fno-tree-slp-vectorize")
#: ``-Bsymbolic``: calls between the library's own functions (rk4 → gpme_terms) bind inside the
#: library, never to a same-named symbol of another loaded model or library.
LINK_FLAGS = ("-shared", "-fPIC") + (("-Wl,-Bsymbolic",) if sys.platform.startswith("linux") else ())
#: Optimization of the functions called rarely (statics, output sampling, single calls from
#: Python), compiled apart from the hot path (GPME terms, solve, RK4; model.c.j2 GPMEGEN_PART).
#: At n_rfe = 10 that part takes 9.3 s of CPU at -O3, 4.7 s at -Og and 0.45 s at -O0, and its
#: functions run 1.0-2.1x slower at -O0 (mass_matrix 3.7 -> 4.7 µs, forces 0.94 -> 1.8 µs).
#: The optimization level changes no rounding (no -ffast-math, no contraction), so no result.
COLD_OPTIMIZATION = "-O0"


_identities: dict = {}      # (compiler path, mtime) -> identity text


def find_compiler() -> list[str]:
    """The C compiler command (program and its fixed arguments): ``$CC`` when set, else the
    first of cc, gcc, clang on ``PATH``. Raises :class:`BuildError` when there is none."""
    env = os.environ.get("CC", "").strip()
    if env:
        argv = shlex.split(env)
        path = shutil.which(argv[0])
        if path is None:
            raise BuildError(
                f"the C compiler named by $CC ({env!r}) was not found; install it, point CC at a C "
                f"compiler, or use backend='numpy'"
            )
        return [path, *argv[1:]]
    for name in COMPILERS:
        path = shutil.which(name)
        if path is not None:
            return [path]
    raise BuildError(
        "no C compiler found (looked for $CC, then " + ", ".join(COMPILERS) + " on PATH); the C backend "
        "needs one: install gcc or clang (e.g. 'apt-get install gcc'), set CC, or use backend='numpy'"
    )


def _processor() -> str:
    """The processor model and flags (a library built with -march=native runs only there)."""
    import platform

    try:
        text = Path("/proc/cpuinfo").read_text()
    except OSError:
        return platform.machine() + " " + platform.processor()
    lines = [ln for ln in text.splitlines() if ln.startswith(("model name", "flags", "Features", "CPU part"))]
    return platform.machine() + "\n" + "\n".join(dict.fromkeys(lines))


def compiler_identity(compiler: list[str]) -> str:
    """The compiler's path, fixed arguments and ``--version`` output (part of the cache key)."""
    path = compiler[0]
    try:
        stamp = os.stat(path).st_mtime_ns
    except OSError:
        stamp = None
    cached = _identities.get((tuple(compiler), stamp))
    if cached is not None:
        return cached
    try:
        # C locale: the text (and with it the cache key and is_gcc) must not follow the user's language
        run = subprocess.run([*compiler, "--version"], capture_output=True, text=True, timeout=60,
                             env={**os.environ, "LC_ALL": "C"})
    except (OSError, subprocess.SubprocessError) as exc:
        raise BuildError(f"the C compiler {path} cannot be run ({exc}); set CC to a working compiler "
                         f"or use backend='numpy'") from None
    if run.returncode != 0:
        raise BuildError(f"'{path} --version' failed (exit {run.returncode}): {run.stderr.strip()[:500]}; "
                         f"set CC to a working C compiler or use backend='numpy'")
    identity = " ".join(compiler) + "\n" + run.stdout + "\n" + _processor()
    _identities[(tuple(compiler), stamp)] = identity
    return identity


def is_gcc(identity: str) -> bool:
    """Whether ``identity`` (see :func:`compiler_identity`: the command line, then the output of
    ``--version``, then the processor) is GCC's, under any name (cc, gcc, x86_64-linux-gnu-gcc)."""
    version = identity.split("\n", 1)[1] if "\n" in identity else ""
    return "Free Software Foundation" in version and "clang" not in version.lower()
