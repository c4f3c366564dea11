"""Richardson extrapolation across discretizations: from the values of one output at several
numbers of sdes, the discretization error of each and the limit as ``n_sde → ∞``.

The rigid finite element method's error falls as ``C/n_sde^p`` with ``p = 2``
(:data:`ORDER`; measured for statics, frequencies and the spin-up beam's motion,
:mod:`gpmegen.analysis.convergence`). Two levels ``n_a < n_b`` then give the limit
``v_b + (v_b - v_a)/((n_b/n_a)^p - 1)`` (Richardson, Phil. Trans. R. Soc. A 210, 1911).
A third level gives what two cannot: the observed order (does the error really fall as
assumed?) and the error of the limit itself, from the next term of the error's expansion.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

ORDER = 2.0  # the RFEM's order of convergence in n_sde


class LevelsError(ValueError):
    """The levels cannot be extrapolated (fewer than two, repeated, or not positive)."""


@dataclass
class Estimate:
    """One output extrapolated. ``n_sde`` (k,) the levels, ascending; ``values`` (k, ...) the
    output at each; ``errors`` (k, ...) the estimated discretization error of each level
    (``value - limit``); ``limit`` (...) the extrapolated value; ``limit_error`` (...) the
    estimated error of ``limit``, signed like ``errors`` (NaN with two levels: they cannot tell it); ``order`` the
    observed order from the three finest levels (NaN with two, or where the differences do
    not shrink); ``assumed_order`` the ``p`` of the extrapolation."""

    n_sde: np.ndarray
    values: np.ndarray
    errors: np.ndarray
    limit: np.ndarray
    limit_error: np.ndarray
    order: float
    assumed_order: float


def check_levels(n_sde) -> np.ndarray:
    """``n_sde`` as an ascending int array; LevelsError unless ≥ 2 distinct positive levels."""
    n = np.asarray(n_sde, dtype=int)
    if n.ndim != 1 or len(n) < 2 or len(set(n.tolist())) != len(n) or np.any(n < 1):
        raise LevelsError(f"levels n_sde = {n.tolist()}: extrapolation needs at least two distinct levels with at "
                          f"least one sde each (n_rfe >= 2)")
    return n


def pair_limit(n_a, n_b, v_a, v_b, order=ORDER):
    """The limit from two levels ``n_a < n_b`` whose error is ``C/n^order``."""
    return v_b + (v_b - v_a) / ((n_b / n_a) ** order - 1.0)


def _ratio(n, p):
    """``(n₀^-p - n₁^-p) / (n₁^-p - n₂^-p)``: the ratio of successive differences of three
    levels ``n`` whose error is ``C/n^p``; it grows with p."""
    a, b, c = (float(x) ** -p for x in n)
    return (a - b) / (b - c)


def observed_order(n_sde, values) -> float:
    """The order p for which ``C/n^p`` makes the three finest levels' successive differences
    (their RMS over all samples and components) stand in the ratio they do; NaN when the
    differences do not shrink as any p in (0.05, 20) would make them."""
    n = check_levels(n_sde)[-3:]
    v = np.asarray(values, dtype=float)[-3:]
    if len(n) < 3:
        return float("nan")
    first, second = (float(np.sqrt(np.mean((v[i + 1] - v[i]) ** 2))) for i in range(2))
    if second == 0.0 or not np.isfinite(first / second):
        return float("nan")
    target = first / second
    lo, hi = 0.05, 20.0
    if not _ratio(n, lo) < target < _ratio(n, hi):
        return float("nan")
    for _ in range(100):  # bisection: the ratio grows with p
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if _ratio(n, mid) < target else (lo, mid)
    return 0.5 * (lo + hi)


def richardson(n_sde, values, order=ORDER) -> Estimate:
    """Extrapolate ``values`` (k, ...) of one output at the levels ``n_sde`` (k,) assuming the
    error ``C/n_sde^order`` (:data:`ORDER`). The limit comes from the two finest levels. With
    three or more, its error is estimated from the next term: the error left by the finest pair
    is taken to fall as ``D/n^(order+1)``, which fixes D from how the limit moves between the
    two finest pairs (a limit that a pure ``C/n^order`` error leaves unmoved has error 0)."""
    n = check_levels(n_sde)
    v = np.asarray(values, dtype=float)
    if v.shape[0] != len(n):
        raise LevelsError(f"{v.shape[0]} values for {len(n)} levels")
    ranking = np.argsort(n)
    n, v = n[ranking], v[ranking]
    limit = pair_limit(n[-2], n[-1], v[-2], v[-1], order)
    limit_error = np.full(limit.shape, np.nan)
    observed = float("nan")
    if len(n) >= 3:
        observed = observed_order(n, v)
        coarser = pair_limit(n[-3], n[-2], v[-3], v[-2], order)
        # A residual D/n^q (q = order + 1) in the values leaves the limit of the pair (a, b) the
        # error D·r(a, b) (_residual): the two finest pairs' limits differ by D·(r_fine - r_coarse).
        q = order + 1.0
        r_fine = _residual(n[-2], n[-1], order, q)
        r_coarse = _residual(n[-3], n[-2], order, q)
        limit_error = (limit - coarser) * r_fine / (r_fine - r_coarse)
    return Estimate(n, v, v - limit, limit, limit_error, observed, float(order))


def _residual(n_a, n_b, p, q):
    """The error that the pair limit of order p leaves of a term ``1/n^q``."""
    return float(pair_limit(n_a, n_b, float(n_a) ** -q, float(n_b) ** -q, p))


__all__ = ["ORDER", "Estimate", "LevelsError", "check_levels", "pair_limit", "observed_order", "richardson"]
