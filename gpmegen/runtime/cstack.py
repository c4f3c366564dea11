"""The stack a call into the solver library takes, and the refusal of a call that would overflow it.

The solver library (``gpmegen/csrc``) and the model's recursion hold their scratch arrays on the
stack as variable-length arrays sized by ``n_dof`` and the number of constraints: a Radau IIA run
keeps five ``n_dof x n_dof`` matrices there (``kept`` in radau.c) while the Jacobian it takes and
the dense GPME solve under it add theirs. Beyond the stack's limit (``ulimit -s``, 8 MiB by
default on Linux) the process dies of a segmentation fault, with no message; a run of Radau IIA
does at n_dof = 450 on that default. :func:`check` refuses such a call before it starts, in one line.

:func:`call_bytes` is an upper bound, each function's arrays summed along its deepest chain of
calls as the C sources declare them (ints counted as doubles); :data:`RESERVE` covers what is not
an array sized by the model (frames, the generated functions' fixed workspaces, the caller's own
stack). Under a stack limit of that size a call completes (tests/test_c_stack.py).
"""

from __future__ import annotations

from ..limits import LimitError

try:
    import resource
except ImportError:  # not a POSIX system: no limit to read
    resource = None

#: Bytes of stack beyond the arrays :func:`call_bytes` counts.
RESERVE = 512 * 1024
#: The library's entry points whose stack :func:`call_bytes` bounds.
CALLS = ("solve", "jacobian", "rk4", "dop853", "radau", "genalpha", "actuated", "actuated_rk4", "actuated_dop853")


def call_bytes(call: str, n: int, m: int, exact_jacobians: bool, z: int = 0) -> int:
    """Bytes of stack (an upper bound, without :data:`RESERVE`) of the library's ``call`` (one of
    :data:`CALLS`) for a model of ``n`` coordinates, ``m`` constraints and ``z`` controller states;
    ``exact_jacobians``: built with its residual Jacobians (``--jacobians``: the Jacobian solves one
    system of ``n + m`` rows for ``2 n`` columns, else it takes central differences)."""
    ny = 2 * n + 2 + z
    r = n + z   # the implicit loops' Newton unknowns
    solve = n * n + 3 * m * n + 2 * m + 8 * (n + m) + 8          # gpme.c: L, or D, X, W and R
    recursive = 32 * n + 2 * m * n + m * m + 8 * m + n * n + n + solve   # recursive.c.j2, its dense fallback
    if exact_jacobians:   # jacobian.c: exact_jacobian, and independent_rows (Q, basis) for redundant rows
        jacobian = (n * n + (n + m) ** 2 + 2 * n * (n + m) + 2 * n * n + 5 * m * n + m * m + 4 * (n + m) + 3 * m
                    + recursive)
    else:                                                         # jacobian.c: differenced_jacobian
        jacobian = 4 * n + recursive
    if z:   # controllers.c: the state's copy and the rates' differences around the GPME Jacobian
        jacobian += 4 * n + 2 * z
    actuated = (n + m) ** 2 + 2 * n * n + 2 * m * n + 8 * (n + m) + 8   # actuated.c: A, x, the terms; a stage's M
    doubles = {
        "actuated": actuated,
        "actuated_rk4": 12 * n + 8 + n + actuated,                # rk4.c: the loop, a stage
        "actuated_dop853": 35 * ny + n + actuated,                # dop853.c: K, F, the states; a stage
        "solve": recursive,
        "jacobian": jacobian,
        "rk4": 12 * n + 8 + n + recursive,                        # rk4.c: the loop, a stage
        "dop853": 35 * ny + n + recursive,                        # dop853.c: K, F, the states, a rate
        # radau.c: kept (the Jacobian's blocks, the three LUs of r x r), the stages, the Jacobian
        "radau": 2 * n * n + 3 * r * r + 3 * n * z + z * z + 25 * ny + 3 * r + jacobian,
        # genalpha.c: the states, the Newton iteration and the qdd it starts from, dq''/dqd (and
        # dq''/dq with controller states)
        "genalpha": 4 * ny + 8 * r + n + (2 if z else 1) * n * n + 3 * n * z + z * z + 2 * m * n + 3 * m + jacobian,
    }[call]
    return 8 * doubles


def stack_limit() -> int | None:
    """This process's stack limit in bytes (the soft ``RLIMIT_STACK``), None when unlimited."""
    if resource is None:
        return None
    soft, _ = resource.getrlimit(resource.RLIMIT_STACK)
    return None if soft == resource.RLIM_INFINITY else int(soft)


def check(call: str, n: int, m: int, exact_jacobians: bool, model: str, z: int = 0) -> None:
    """Raise :class:`gpmegen.limits.LimitError` in one line when the library's ``call`` on the
    model ``model`` (``n`` coordinates, ``m`` constraints, ``z`` controller states) needs more
    stack than the limit."""
    limit = stack_limit()
    need = call_bytes(call, n, m, exact_jacobians, z) + RESERVE
    if limit is not None and need > limit:
        raise LimitError(
            f"model {model} (n_dof = {n}): the C solver's {call} keeps about {need / 2**20:.1f} MiB of scratch "
            f"arrays on the stack, beyond this process's stack limit of {limit / 2**20:.1f} MiB; raise the limit "
            f"(e.g. 'ulimit -s {-(-need // 1024) * 2}' in the shell that starts it) or use backend='numpy'"
        )
