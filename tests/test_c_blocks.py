"""Long generated C functions are split into blocks of bounded length (gpmegen.codegen.blocks):
no emitted C function computes more than SPLIT_ABOVE values, no block more than MAX_STATEMENTS,
and the blocks give the bits of the same function emitted as one block."""

from __future__ import annotations

import re
import sys
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.codegen import blocks
from gpmegen.codegen.render import render
from gpmegen.model.reference import reference_model
from gpmegen.runtime import ccompile

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)

from test_c_parts import _calls, _whole_library  # noqa: E402  (tests/test_c_parts.py)

FUNCTION = re.compile(r"\n(?:NOINLINE static )?void (\w+)\([^)]*\)\n\{\n(.*?)\n\}", re.S)
#: A statement that computes: a definition that is not a load from the workspace, or an output store.
COMPUTES = re.compile(r"\s+(const double _x\d+ = (?!w\[)|out_\w+\[\d+\] = )")


def _computing_statements(c_source: str) -> dict:
    """Function name -> the number of statements of its body that compute a value."""
    return {m.group(1): sum(bool(COMPUTES.match(line)) for line in m.group(2).splitlines())
            for m in FUNCTION.finditer(c_source)}


def test_no_generated_c_function_computes_more_than_a_block():
    counts = _computing_statements(render(reference_model(10), ("c",))["model.c"])
    assert max(counts.values()) <= blocks.SPLIT_ABOVE
    assert max(n for name, n in counts.items() if "_block" in name) <= blocks.MAX_STATEMENTS
    # the GPME terms of this model are longer than SPLIT_ABOVE: split, not merely short
    terms = [n for name, n in counts.items() if name.startswith("gpme_terms_block")]
    assert len(terms) >= 2 and sum(terms) > blocks.SPLIT_ABOVE


@pytest.mark.requires_cc
@pytest.mark.long   # compiles the model twice; the blocks' sizes are checked in make test
def test_blocks_give_the_bits_of_one_block(env, tmp_path, monkeypatch):
    model = reference_model(2)
    libraries = {}
    for limit in (10**9, 40):  # one block per function; many small ones
        monkeypatch.setattr(blocks, "MAX_STATEMENTS", limit)
        monkeypatch.setattr(blocks, "SPLIT_ABOVE", limit)
        files = render(model, ("c",))
        folder = tmp_path / str(limit)
        folder.mkdir()
        for name in ("model.c", ccompile.HEADER):
            (folder / name).write_text(files[name])
        library = _whole_library(folder, folder, env[1])
        libraries[limit] = ccompile.open_library(library, files[ccompile.HEADER])
    assert "_block" not in (tmp_path / str(10**9) / "model.c").read_text()
    assert (tmp_path / "40" / "model.c").read_text().count("NOINLINE static void gpme_terms_block") >= 5
    (one_ffi, one), (split_ffi, split) = libraries[10**9], libraries[40]
    n, p = one.n_dof(), np.array([float(parameter.default) for parameter in model.parameters])
    psi2 = gpmegen.load("manipulator", nrfe=2, backend="numpy").index("psi2")
    rng = np.random.default_rng(11)
    for _ in range(4):
        q = 0.4 * rng.standard_normal(n)
        q[psi2] += np.pi / 4  # away from the constraints' singular configurations, as in test_c_parts
        qd, t = rng.standard_normal(n), float(rng.uniform(0, 3))
        for a, b in zip(_calls(one_ffi, one, n, len(p), t, q, qd, p), _calls(split_ffi, split, n, len(p), t, q, qd, p)):
            assert np.array_equal(a, b)
