"""model.c is compiled in two parts (the hot path at the build's optimization, the functions
called rarely at ccompile.COLD_OPTIMIZATION) and linked: every function must give the same
bits as the file compiled whole at -O3, the optimization level changing no rounding."""

from __future__ import annotations

import subprocess
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.runtime import ccompile

pytestmark = pytest.mark.requires_cc


def _whole_library(folder: Path, tmp_path: Path, cache: Path) -> Path:
    """model.c of ``folder`` compiled as one translation unit with the default flags, linked with
    the solver library of ``cache``."""
    compiler = ccompile.find_compiler()
    flags = ccompile.DEFAULT_FLAGS + (ccompile.GCC_FLAGS if ccompile.is_gcc(ccompile.compiler_identity(compiler))
                                      else ())
    library = tmp_path / "whole.so"
    solver = ccompile.build_solver(cache=cache).path
    subprocess.run([*compiler, *flags, *ccompile.LINK_FLAGS, f"-I{ccompile.solver_include()}", "-o", str(library),
                    str(folder / "model.c"), str(solver), "-lm"], check=True, capture_output=True)
    return library


def _calls(ffi, lib, n, n_parameters, t, q, qd, p):
    """Every generated function of ``lib`` and its q̈ at one state, as arrays."""
    def out(size):
        return np.zeros(max(1, size))

    buffers = {name: out(size) for name, size in (("M", n * n), ("f", n), ("r", n), ("K", n * n), ("Q", n),
                                                  ("P", 3 * lib.n_points()), ("e", 3), ("qdd", n))}
    m = lib.n_constraints()
    terms = [out(m), out(m), out(m * n), out(m)]
    ptr = lambda a: ffi.from_buffer("double[]", a)  # noqa: E731
    args = (ptr(q), ptr(p))
    lib.mass_matrix(*args, ptr(buffers["M"]))
    lib.forces(t, ptr(q), ptr(qd), ptr(p), ptr(buffers["f"]))
    lib.static_residual(*args, ptr(buffers["r"]))
    lib.stiffness_jacobian(*args, ptr(buffers["K"]))
    lib.drive_forces(t, ptr(q), ptr(qd), ptr(p), ptr(buffers["Q"]))
    lib.points(*args, ptr(buffers["P"]))
    lib.energies(ptr(q), ptr(qd), ptr(p), ptr(buffers["e"]))
    lib.constraint_terms(t, ptr(q), ptr(qd), ptr(p), *map(ptr, terms))
    dep, ind = ffi.new("int[]", max(1, m)), ffi.new("int[]", n)
    dep[0:m], ind[0:n - m] = list(range(m)), list(range(m, n))
    assert lib.gpme_accelerations(t, ptr(q), ptr(qd), ptr(p), dep, ind, ptr(buffers["qdd"])) == 0
    return list(buffers.values()) + terms


@pytest.mark.long   # the model compiled whole besides its parts
def test_the_parts_give_the_bits_of_the_whole_file(env, tmp_path):
    model = gpmegen.load("manipulator", nrfe=3, backend="c")
    folder = Path(model.folder)
    header = (folder / ccompile.HEADER).read_text()
    assert ccompile.part_flags(model.library.flags)[1] != tuple(model.library.flags)  # really two levels
    whole_ffi, whole = ccompile.open_library(_whole_library(folder, tmp_path, env[1]), header)
    rng = np.random.default_rng(7)
    for _ in range(5):
        q = 0.4 * rng.standard_normal(model.n_dof)
        q[model.index("psi2")] += np.pi / 4
        qd, t = rng.standard_normal(model.n_dof), float(rng.uniform(0, 3))
        parts = _calls(model.ffi, model.lib, model.n_dof, len(model.p), t, q, qd, np.array(model.p))
        single = _calls(whole_ffi, whole, model.n_dof, len(model.p), t, q, qd, np.array(model.p))
        for a, b in zip(parts, single):
            assert np.array_equal(a, b)
