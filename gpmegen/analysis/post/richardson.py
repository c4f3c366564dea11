"""Richardson extrapolation across discretizations: from the values of one output at several
numbers of sdes, the discretization error of each and the limit as ``n_sde → ∞``.

The rigid finite element method's error falls as ``C/n_sde^p`` with ``p = 2``
(:data:`ORDER`; measured for statics, frequencies and the spin-up beam's motion,
:mod:`gpmegen.analysis.discretization.convergence`). Two levels ``n_a < n_b`` then give the limit
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


def check_terms(n_sde, terms) -> None:
    """LevelsError unless ``terms`` (1 or 2) terms of the error can be removed from the levels."""
    if terms not in (1, 2) or len(n_sde) < terms + 1:
        raise LevelsError(f"{terms} terms of the error need {terms + 1} levels or more (terms 1 or 2), "
                          f"levels n_sde = {list(map(int, n_sde))}")


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


def fit_limit(n, values, powers):
    """The limit ``c₀`` of ``values`` (len(powers) + 1, ...) at the levels ``n`` that
    ``c₀ + Σ cⱼ/n^powers[j]`` passes through exactly (with one power: :func:`pair_limit`)."""
    n = np.asarray(n, dtype=float)
    basis = np.stack([np.ones_like(n)] + [n ** -float(p) for p in powers], axis=1)
    v = np.asarray(values, dtype=float)
    return np.linalg.solve(basis, v.reshape(len(n), -1))[0].reshape(v.shape[1:])


def richardson(n_sde, values, order=ORDER, terms=1) -> Estimate:
    """Extrapolate ``values`` (k, ...) of one output at the levels ``n_sde`` (k,) assuming the
    error ``C/n_sde^order`` (:data:`ORDER`), or with ``terms = 2`` the even expansion
    ``C/n^order + D/n^(2·order)`` (the RFEM's, where the first term alone leaves too much: a
    free vibration whose phase error ``∝ t/n²`` is large at the coarser levels). The limit comes
    from the ``terms + 1`` finest levels. With one level more, its error is estimated from the
    next term (``E/n^(order+1)`` for one term, ``E/n^(3·order)`` for two), fixed by how the limit
    moves between the finest and the next-coarser set of levels (a limit that the assumed terms
    alone leave unmoved has error 0); with ``terms = 2`` and three levels, it is bounded by how
    far the limit of one term lies from it."""
    n = check_levels(n_sde)
    v = np.asarray(values, dtype=float)
    if v.shape[0] != len(n):
        raise LevelsError(f"{v.shape[0]} values for {len(n)} levels")
    check_terms(n, terms)
    ranking = np.argsort(n)
    n, v = n[ranking], v[ranking]
    powers = [order * (j + 1) for j in range(terms)]
    size = terms + 1
    limit = fit_limit(n[-size:], v[-size:], powers)
    limit_error = np.full(limit.shape, np.nan)
    observed = observed_order(n, v) if len(n) >= 3 else float("nan")
    if len(n) > size:
        coarser = fit_limit(n[-size - 1:-1], v[-size - 1:-1], powers)
        # A residual E/n^q in the values leaves the limit of a set of levels the error E·r(levels)
        # (_residual): the finest and next-coarser sets' limits differ by E·(r_fine - r_coarse).
        q = order + 1.0 if terms == 1 else 3.0 * order
        r_fine = _residual(n[-size:], powers, q)
        r_coarse = _residual(n[-size - 1:-1], powers, q)
        limit_error = (limit - coarser) * r_fine / (r_fine - r_coarse)
    elif terms == 2:
        limit_error = pair_limit(n[-2], n[-1], v[-2], v[-1], order) - limit
    return Estimate(n, v, v - limit, limit, limit_error, observed, float(order))


def _residual(n, powers, q):
    """The error that the limit of the levels ``n`` with the error terms ``powers`` leaves of a
    term ``1/n^q``."""
    n = np.asarray(n, dtype=float)
    return float(fit_limit(n, n ** -q, powers))


__all__ = ["ORDER", "Estimate", "LevelsError", "check_levels", "check_terms", "pair_limit", "fit_limit",
           "observed_order", "richardson"]
