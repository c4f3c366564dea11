"""Many states in one call: the shapes a batched evaluation takes and gives.

A batch is ``N`` states: ``q``, ``qd`` of shape (N, n_dof) and ``t`` a scalar (the same time for
all) or (N,). Results gain a leading axis of length N.
"""

from __future__ import annotations

import numpy as np


def is_batch(q) -> bool:
    """Whether ``q`` holds many states (two axes) rather than one."""
    return (q.ndim if type(q) is np.ndarray else np.ndim(q)) == 2


def rows(x, n: int, what: str, n_states: int | None = None) -> np.ndarray:
    """``x`` as a contiguous float array (N, n), else ValueError naming ``what``; ``n_states``:
    the N it must have (that of ``q``)."""
    a = np.ascontiguousarray(x, dtype=float)
    if a.ndim != 2 or a.shape[1] != n or (n_states is not None and a.shape[0] != n_states):
        want = f"({n_states}, {n}) like q" if n_states is not None else f"(N, {n})"
        raise ValueError(f"{what} must have shape {want}, got {a.shape}")
    if a.shape[0] == 0:
        raise ValueError(f"{what} holds no state (shape {a.shape}); give at least one row")
    return a


def times(t, n_states: int) -> np.ndarray:
    """``t`` (s) as a contiguous float array (N,): a scalar is the time of every state."""
    a = np.asarray(t, dtype=float)
    if a.ndim == 0:
        return np.full(n_states, float(a))
    if a.shape != (n_states,):
        raise ValueError(f"t must be a scalar or have shape ({n_states},) like the rows of q, got {a.shape}")
    return np.ascontiguousarray(a)


def states(t, q, qd, n: int):
    """``(t (N,), q (N, n), qd (N, n))`` of a batch, checked."""
    q = rows(q, n, "q")
    return times(t, len(q)), q, rows(qd, n, "qd", len(q))


def stacked(results: list):
    """Per-state results (arrays, or tuples of arrays) as one array (or tuple) with a leading
    state axis."""
    if isinstance(results[0], tuple):
        return tuple(np.stack(parts) for parts in zip(*results))
    return np.stack(results)
