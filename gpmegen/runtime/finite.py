"""The rule for the states a model's functions are given: ``t``, ``q`` and ``q̇`` finite.

A NaN or an infinity has no motion to compute, and each backend did something else with one (the
C solve stopped where NumPy carried it through, and the reverse for an infinite ``t``). So
:func:`check` refuses it before any evaluation with a :class:`gpmegen.errors.StateError` that
names the argument and its first entry that is not finite (in a batch, also the state). The
fast single call (``fastcall.c``) hands such a state to the checked path, which raises here.
"""

from __future__ import annotations

import math

import numpy as np

from ..errors import StateError


def check(t, q, qd=None) -> None:
    """StateError unless ``t``, ``q`` and ``qd`` are finite: one state (``q``, ``qd`` float arrays
    (n,), ``t`` a number) or a batch (``q``, ``qd`` (N, n), ``t`` (N,)); ``t`` or ``qd`` None
    where the function takes none."""
    batch = q.ndim == 2
    if t is not None and not (np.isfinite(t).all() if batch else math.isfinite(float(t))):
        _refuse("t", t, batch)
    for what, x in (("q", q), ("qd", qd)):
        if x is not None and not np.isfinite(x).all():
            _refuse(what, x, batch)


def _refuse(what: str, x, batch: bool):
    """Raise the StateError naming the first entry of ``x`` (argument ``what``) that is not finite."""
    x = np.asarray(x, dtype=float)
    index = tuple(int(k) for k in np.argwhere(~np.isfinite(x))[0])
    subscript = f"[{', '.join(map(str, index))}]" if index else ""
    where = f" (state {index[0]} of the batch)" if batch else ""
    raise StateError(f"{what}{subscript} = {float(x[index])} is not finite{where}: give finite t, q and qd")
