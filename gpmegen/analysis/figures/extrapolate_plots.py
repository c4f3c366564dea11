"""The figure of an extrapolation (:mod:`gpmegen.analysis.discretization.extrapolate`): for each named point,
its deflection at every discretization and the limit within its error band, and below the
estimated discretization error of each run and of the limit."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...fileio import atomic_write

AXES = "xyz"


def plot(data: dict, path) -> Path:
    """Write the figure of ``data`` (:func:`gpmegen.analysis.discretization.extrapolate.extrapolate`) to
    ``path`` (its suffix the format) and return it. Per point: the component of its deflection
    (or position, when the deflections were not extrapolated) that varies most; the band is
    ± the limit's estimated error (none with two levels)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    name = "deflections" if "deflections_limit" in data else "points"
    t, limit = data["t"], data[f"{name}_limit"]
    points = [str(p) for p in data["point_names"]]
    fig, axes = plt.subplots(2, len(points), figsize=(6.4 * len(points), 6.4), sharex=True, squeeze=False)
    for j, point in enumerate(points):
        k = int(np.argmax(np.ptp(limit[:, j, :], axis=0)))
        top, bottom = axes[0, j], axes[1, j]
        for level, (n, values, errors) in enumerate(zip(data["nrfe"], data[name], data[f"{name}_error"])):
            top.plot(t, values[:, j, k], lw=0.8, color=f"C{level}", label=f"n_rfe = {n}")
            bottom.semilogy(t, np.abs(errors[:, j, k]), lw=0.8, color=f"C{level}", label=f"n_rfe = {n}")
        band = np.abs(data[f"{name}_limit_error"][:, j, k])
        top.plot(t, limit[:, j, k], "k", lw=1.2, label="limit")
        if np.all(np.isfinite(band)):
            top.fill_between(t, limit[:, j, k] - band, limit[:, j, k] + band, color="k", alpha=0.25,
                             label="limit ± its estimated error")
            bottom.semilogy(t, band, "k", lw=1.2, label="limit")
        top.set_ylabel(f"{name[:-1]} of {point}, {AXES[k]} in {{0}} (m)")
        bottom.set_ylabel("estimated discretization error (m)")
        bottom.set_xlabel("t (s)")
        top.legend(fontsize=8)
        bottom.legend(fontsize=8)
        top.grid(alpha=0.3)
        bottom.grid(alpha=0.3)
    order = float(data[f"{name}_order"])
    fig.suptitle(f"Richardson extrapolation in n_sde = n_rfe - 1 (assumed order {float(data['assumed_order']):g}"
                 + (f", observed {order:.2f})" if np.isfinite(order) else ")"), fontsize=10)
    fig.tight_layout()
    path = Path(path)
    atomic_write(path, lambda fh: fig.savefig(fh, format=path.suffix[1:] or "png", dpi=120))
    plt.close(fig)
    return path


__all__ = ["plot"]
