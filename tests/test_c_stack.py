"""The stack the solver library's calls take (gpmegen.runtime.cstack): its bound holds for every
call, run by tests/c/stack_probe.c under a stack limit of that bound, and a call beyond the
process's limit is refused in one line before it starts (the library would die of a segmentation
fault, without a message)."""

from __future__ import annotations

import resource
import subprocess
from pathlib import Path

import pytest

import gpmegen
from gpmegen.limits import LimitError
from gpmegen.runtime import ccompile, cstack

pytestmark = pytest.mark.requires_cc
PROBE = Path(__file__).parent / "c" / "stack_probe.c"
N = 160  # Radau's kept matrices alone, 5 n^2 doubles, are 1 MiB: twice RESERVE


@pytest.fixture(scope="module")
def probe(tmp_path_factory, shared_cache):
    folder = tmp_path_factory.mktemp("stack")
    solver = ccompile.build_solver(cache=shared_cache)
    program = folder / "stack_probe"
    subprocess.run([*ccompile.find_compiler(), *solver.flags, f"-I{ccompile.solver_include()}", "-o", str(program),
                    str(PROBE), str(solver.path), "-lm"], check=True, capture_output=True, text=True)
    return program


def _run(program, call, limit):
    def limited():
        resource.setrlimit(resource.RLIMIT_STACK, (limit, resource.getrlimit(resource.RLIMIT_STACK)[1]))
    return subprocess.run([str(program), call, str(N)], capture_output=True, text=True, timeout=300,
                          preexec_fn=limited)


@pytest.mark.parametrize("call", cstack.CALLS)
def test_each_call_completes_within_its_bound(probe, call):
    run = _run(probe, call, cstack.call_bytes(call, N, 0, False) + cstack.RESERVE)
    assert run.returncode == 0 and run.stdout.split() == ["ok", call, str(N), "0"], (run.returncode, run.stdout)


def test_radau_dies_under_a_limit_below_its_arrays(probe):
    """The limit bites in the probe: Radau under a quarter of its bound does not return."""
    run = _run(probe, "radau", cstack.call_bytes("radau", N, 0, False) // 4)
    assert run.returncode != 0 and "ok" not in run.stdout


def test_the_bound_grows_with_the_constraints_and_the_exact_jacobians():
    for call in cstack.CALLS:
        small = cstack.call_bytes(call, 100, 0, False)
        assert cstack.call_bytes(call, 100, 10, False) > small
        assert cstack.call_bytes(call, 100, 0, True) >= small
        # controller states: the state, and the implicit loops' Newton matrices, grow by them
        assert cstack.call_bytes(call, 100, 0, False, 3) >= small
    for call in ("radau", "genalpha"):
        # the Newton unknowns are n + z: their Jacobian blocks (n x z at least) on the stack
        assert cstack.call_bytes(call, 100, 0, False, 3) - cstack.call_bytes(call, 100, 0, False) > 8 * 3 * 100
    # Radau at n_dof = 450 (where it overflows the default 8 MiB) is beyond it
    assert cstack.call_bytes("radau", 450, 0, False) > 8 * 2**20


def test_a_run_beyond_the_stack_limit_is_refused_in_one_line(monkeypatch):
    model = gpmegen.load("manipulator", nrfe=1, backend="c")
    need = cstack.call_bytes("radau", model.n_dof, len(model.constraint_names), False) + cstack.RESERVE
    monkeypatch.setattr(cstack, "stack_limit", lambda: need - 1)
    with pytest.raises(LimitError) as refused:
        gpmegen.simulate(nrfe=1, t_end=0.01, method="radau", backend="c")
    message = str(refused.value)
    assert "\n" not in message and "stack limit" in message and "ulimit -s" in message
    monkeypatch.setattr(cstack, "stack_limit", lambda: need)
    assert gpmegen.simulate(nrfe=1, t_end=0.01, method="radau", backend="c").status == "complete"
