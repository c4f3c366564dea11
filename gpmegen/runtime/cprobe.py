"""Every function of a compiled model library called once, in a child process, before the
main process loads the library.

A defect in compiled code (a miscompilation, undefined behaviour in the generated C) does not
raise: it kills the process that runs it. So a freshly compiled library is first exercised by
``python -m gpmegen.runtime.cprobe LIBRARY MODEL_C MODEL_NUMPY_PY`` in a child process: each
function its header (``model.h`` beside ``MODEL_C``) declares is called with exactly sized
buffers at two states (all zeros, and a seeded random one; a state where the model's own NumPy
functions raise, a singular model, is left out), the GPME with a regular partition and three RK4
steps. The parent learns from the
child's exit status whether the library is safe to load, and from its last line which function
it was calling when it died. The same exercise, run on a library compiled with
``-fsanitize=address,undefined`` (``make check-c``), is the sanitizer sweep.
"""

from __future__ import annotations

import os
import re
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np

from ..errors import BuildError
from .ccompile import HEADER, declarations, open_library, short_names
from .gpme import choose_dependent
from .integrators.base import ADAPTIVE_COUNTS, COUNTS
from .numpy_module import import_numpy_module

#: Seconds the child may take: it calls each function a few times, so anything longer is a hang.
TIMEOUT = 120.0

_PROTOTYPE = re.compile(r"^\s*(\w[\w\s\*]*?)\b(\w+)\((.*)\);\s*$")
_ARGUMENT = re.compile(r"(const\s+)?(double|int|long|void)\s*(\*?)\s*(\w+)$")


BATCH = "_batch"  # what ends the name of a function's batched form (model.h)


def prototypes(cdef: str) -> list[tuple[str, list[tuple[str, bool, str]]]]:
    """The functions of a cdef block: ``(name, [(type, is_pointer, argument name), ...])``."""
    functions = []
    for line in re.sub(r"/\*.*?\*/", "", cdef, flags=re.S).splitlines():
        m = _PROTOTYPE.match(line)
        if not m:
            continue
        arguments = []
        for text in filter(None, (a.strip() for a in m.group(3).split(","))):
            if text == "void":
                continue
            a = _ARGUMENT.match(text)
            if a is None:
                raise ValueError(f"cannot read the argument {text!r} of {m.group(2)}")
            arguments.append((a.group(2), bool(a.group(3)), a.group(4)))
        functions.append((m.group(2), arguments))
    return functions


def exercise(library: Path, source: Path, module_path: Path, say=print) -> None:
    """Call every function of ``library`` (compiled from ``source``) at two states, with
    buffers sized from the outputs of the NumPy module at ``module_path``. ``say`` is told the
    name of each function before it is called."""
    module = import_numpy_module(Path(module_path).parent)
    header = Path(source).with_name(HEADER).read_text(encoding="utf-8")
    ffi, lib = open_library(library, header)
    functions = prototypes(declarations(header))
    short = {c_name: name for name, c_name in short_names(c_name for c_name, _ in functions).items()}
    n = len(module.COORDINATES)
    n_constraints = len(module.CONSTRAINTS)
    # p ends with the controller states (a model without has no CONTROLLERS), probed at zero; the
    # integrators' state y = [q, qd, the two works, the controller states]
    n_z = len(getattr(module, "CONTROLLERS", ()))
    p = np.array(list(module.DEFAULTS) + [0.0] * n_z, dtype=float)
    n_y = 2 * n + 2 + n_z
    rng = np.random.default_rng(20)
    states = [(0.0, np.zeros(n), np.zeros(n)), (0.37, 0.3 * rng.standard_normal(n), 0.3 * rng.standard_normal(n))]

    def doubles(values):
        values = np.atleast_1d(np.asarray(values, dtype=float)).ravel()
        return ffi.new("double[]", values.tolist()) if values.size else ffi.new("double[]", 1)

    def state_values(t, q, qd):
        return {"t": t, "q": q, "qd": qd, "a": qd[::-1].copy(), "lam": np.full(n_constraints, 0.5), "p": p}

    def defined(state) -> bool:
        # A model may be singular where the probe looks (a constraint with the root of a distance
        # that vanishes at q = 0): there its NumPy module, which sizes the buffers, raises, and
        # the library is exercised at the other state.
        values = state_values(*state)
        try:
            for c_name, arguments in functions:
                name = short[c_name]
                if arguments and not name.endswith(BATCH) and hasattr(module, name):
                    getattr(module, name)(*(values[a] for *_, a in arguments if not a.startswith("out_")))
        except ArithmeticError:
            return False
        return True

    states = [state for state in states if defined(state)] or states[-1:]
    for t, q, qd in states:
        values = state_values(t, q, qd)
        for c_name, arguments in functions:
            name = short[c_name]
            if name.endswith(BATCH):
                continue  # below, over both states at once
            say(name)
            if not arguments:
                getattr(lib, name)()
                continue
            if not hasattr(module, name):
                continue
            inputs = [a for *_, a in arguments if not a.startswith("out_")]
            expected = getattr(module, name)(*(values[a] for a in inputs))
            expected = expected if isinstance(expected, tuple) else (expected,)
            outputs = iter(expected)
            call = []
            for *_, a in arguments:
                if a == "t":
                    call.append(t)
                elif a.startswith("out_"):
                    call.append(doubles(np.zeros(np.size(next(outputs)))))
                else:
                    call.append(doubles(values[a]))
            getattr(lib, name)(*call)
        D = np.reshape(module.constraint_terms(t, q, qd, p)[2], (n_constraints, n))
        dependent = choose_dependent(D).tolist()  # the project's choice (the C solve makes its own)
        independent = [k for k in range(n) if k not in dependent]
        dep = ffi.new("int[]", dependent or [0])
        ind = ffi.new("int[]", independent or [0])
        say("gpme_motion")
        lib.gpme_motion(t, doubles(q), doubles(qd), doubles(p), dep, ind, doubles(np.zeros(n)),
                        doubles(np.zeros(n * n)), doubles(np.zeros(n)))
        say("gpme_accelerations")
        lib.gpme_accelerations(t, doubles(q), doubles(qd), doubles(p), dep, ind, doubles(np.zeros(n)))
        say("gpme_jacobian")
        lib.gpme_jacobian(t, doubles(q), doubles(qd), doubles(p), dep, doubles(np.zeros(n)), doubles(np.zeros(n * n)),
                          doubles(np.zeros(n * n)))
        say("rk4")
        steps, dt = 3, 1e-6
        n_save = steps + 2  # the start, every step, and the final state (see the C rk4)
        n_saved = ffi.new("long *")
        lib.rk4(t, dt, steps, t + steps * dt, 0, steps, 1, doubles(q), doubles(qd), doubles(np.zeros(2 + n_z)),
                doubles(p), dep, ind, doubles(np.zeros(n_save)), doubles(np.zeros(n_save * n)),
                doubles(np.zeros(n_save * n)), doubles(np.zeros(n_save * (2 + n_z))), n_saved)
        for name in ("dop853", "radau"):  # one interface
            say(name)
            memory, step = ffi.new("char[]", getattr(lib, name + "_memory_bytes")()), doubles([0.0])
            for max_steps in (1, 0):  # stopped after its first step, then on from there to the end
                getattr(lib, name)(t, doubles(np.concatenate([q, qd, np.zeros(2 + n_z)])), 2,
                                   doubles([t + 1e-4, t + 2e-4]), 1e-6, 1e-8, step, max_steps, memory, doubles(p), dep,
                                   ind, doubles(np.zeros(2 * n_y)), n_saved, ffi.new("long[]", ADAPTIVE_COUNTS))
        say("genalpha")
        lib.genalpha(t, 1e-4, 2, t + 2e-4, 0, 2, 0.9, 1, doubles(np.concatenate([q, qd, np.zeros(2 + n_z)])),
                     doubles(np.full(2 * n, np.nan)), doubles(np.zeros((n + n_z) ** 2)), ffi.new("int[]", n + n_z),
                     ffi.new("int[]", 1),
                     1, doubles([t + 1.5e-4]), doubles(p), dep, ind, doubles(np.zeros(n_y)), n_saved,
                     ffi.new("long[]", COUNTS))
    batch = {"t": [t for t, _, _ in states], "q": [q for _, q, _ in states], "qd": [qd for _, _, qd in states],
             "p": p}
    for c_name, arguments in functions:
        name = short[c_name]
        single = name[:-len(BATCH)]
        if not name.endswith(BATCH) or not hasattr(module, single):
            continue
        say(name)
        inputs = [a for *_, a in arguments[1:] if not a.startswith("out_")]
        expected = getattr(module, single)(*(values[a] for a in inputs))
        outputs = iter(expected if isinstance(expected, tuple) else (expected,))
        call = [len(states)] + [doubles(np.zeros(len(states) * np.size(next(outputs)))) if a.startswith("out_")
                                else doubles(batch[a]) for *_, a in arguments[1:]]
        getattr(lib, name)(*call)
    say("gpme_accelerations_batch")
    lib.gpme_accelerations_batch(len(states), doubles(batch["t"]), doubles(batch["q"]), doubles(batch["qd"]),
                                 doubles(p), dep, ind, doubles(np.zeros(len(states) * n)), ffi.new("int *"))


STARTED = "probe started"  # the child's first line: from here on, a failure is the library's


class ProbeUnavailable(BuildError):
    """The test run could not say anything about the library: its process did not get as far as
    loading it (its Python could not import gpmegen, say), or it did not finish in time on a busy
    machine. No verdict is kept: the library is tested again next time."""


def check_in_child(library: Path, source: Path, module_path: Path, env=None, timeout=TIMEOUT) -> str | None:
    """Run :func:`exercise` in a child process. Returns None when every call returned, else one
    line saying how the child ended and in which function; :class:`ProbeUnavailable` when the
    child ended before it began to test the library, or did not finish within ``timeout`` s."""
    argv = [sys.executable, "-m", "gpmegen.runtime.cprobe", str(library), str(source), str(module_path)]
    try:
        run = subprocess.run(argv, capture_output=True, text=True, timeout=timeout,
                             env={**os.environ, **(env or {})})
    except subprocess.TimeoutExpired:
        raise ProbeUnavailable(f"the test run of {library} did not finish within {timeout:g} s") from None
    if run.returncode == 0:
        return None
    if STARTED not in run.stdout.splitlines():
        detail = " ".join(run.stderr.strip().splitlines()[-1:])[:300]
        raise ProbeUnavailable(f"the test run of {library} could not start (exit status {run.returncode}: "
                               f"{detail or 'no message'})")
    calls = [line[len("calling "):] for line in run.stdout.splitlines() if line.startswith("calling ")]
    where = f" in {calls[-1]}()" if calls else ""
    if run.returncode < 0:
        try:
            name = signal.Signals(-run.returncode).name
        except ValueError:
            name = f"signal {-run.returncode}"
        return f"the test process was killed by {name}{where}"
    detail = " ".join(run.stderr.strip().splitlines()[-1:])[:300]
    return f"the test process exited with status {run.returncode}{where}" + (f": {detail}" if detail else "")


def main(argv=None) -> int:
    library, source, module_path = (argv or sys.argv[1:])[:3]
    print(STARTED, flush=True)
    exercise(Path(library), Path(source), Path(module_path),
             say=lambda name: print(f"calling {name}", flush=True))
    return 0


if __name__ == "__main__":
    sys.exit(main())
