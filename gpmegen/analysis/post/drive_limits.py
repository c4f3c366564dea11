"""How long each drive with a ``limit`` sat at it over a run: where its law, before the clip,
asked for at least the limit in size, measured on the saved samples."""

from __future__ import annotations

import numpy as np


def at_limit(laws, limits) -> np.ndarray:
    """Whether each sample is at its drive's limit, (k, n_limited) booleans, from the laws
    before their clip and the limits, both (k, n_limited); a sample that is not finite is not."""
    laws, limits = np.asarray(laws, float), np.asarray(limits, float)
    with np.errstate(invalid="ignore"):
        return np.abs(laws) >= limits


def time_at_limit(t, laws, limits) -> np.ndarray:
    """Time (s) each limited drive spent at its limit, (n_limited,): each interval between two
    saved samples counts fully when both ends are at the limit, half when one is (the
    trapezoidal rule of the indicator), so the figure is exact to within a save interval per
    switch."""
    t = np.asarray(t, float)
    flags = at_limit(laws, limits).astype(float)
    if len(t) < 2:
        return np.zeros(flags.shape[1] if flags.ndim == 2 else 0)
    dt = np.diff(t)[:, None]
    return np.sum(dt * (flags[1:] + flags[:-1]) / 2, axis=0)


def summary(names, seconds, t_end) -> list[str]:
    """One line per limited drive: how long it sat at its limit over a run to ``t_end`` (s)."""
    share = [100 * s / t_end if t_end > 0 else 0.0 for s in seconds]
    return [f"drive on {name}: at its limit for {s:.6g} s of {t_end:.6g} s ({p:.3g}%, on the saved samples)"
            for name, s, p in zip(names, seconds, share)]
