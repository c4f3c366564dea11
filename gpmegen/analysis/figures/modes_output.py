"""Files of the modal analysis and of the convergence study: mode tables as CSV, mode shapes
and convergence as figures. Every file is written atomically."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ...fileio import atomic_write, atomic_write_bytes
from ..discretization.convergence import QUANTITIES, ConvergenceTable
from ..post.modes import Modes
from .plots import _freeze_layout


def write_modes_csv(modes: Modes, path) -> Path:
    """Frequencies, kinds and shapes as CSV: one row per mode, one column per coordinate."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    header = ",".join(["mode", "frequency_Hz", "kind", *modes.coordinates])
    rows = [",".join([str(k + 1), f"{f:.9g}", modes.kinds[k], *(f"{v:.9g}" for v in modes.shapes[:, k])])
            for k, f in enumerate(modes.frequencies)]
    return atomic_write_bytes(path, ("\n".join([header, *rows]) + "\n").encode())


def plot_mode_shapes(modes: Modes, path, count: int = 6) -> Path:
    """The first ``count`` mode shapes along the arm (see :func:`mode_shapes_figure`), written to
    ``path``."""
    import matplotlib.pyplot as plt

    fig = mode_shapes_figure(modes, count)
    path = atomic_write(path, lambda fh: fig.savefig(fh, format=Path(path).suffix[1:], dpi=120))
    plt.close(fig)
    return path


def _sde_indices(names, rotation: str) -> list[int]:
    """Indices of the sde coordinates of one rotation (``psi``, ``theta``, ``phi``), in chain
    order: the RFEM names them ``<rotation><link label>_<k>``."""
    return [j for j, c in enumerate(names) if c.startswith(rotation) and "_" in c]


def mode_shapes_figure(modes: Modes, count: int = 6):
    """The figure of the first ``count`` mode shapes, one panel per mode under the title (the
    layout engine places the title: with the default subplot margins a band of 0.1 of the figure
    was left blank under it): along the arm, the sde rotations ψ, θ, φ against the sde index; for
    a model without flexible links (its modes those of sprung joints), each free coordinate's
    amplitude as a bar."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    count = min(count, len(modes.frequencies))
    fig, axes = plt.subplots(count, 1, figsize=(7, 1.9 * count + 0.6), sharex=True, squeeze=False,
                             layout="constrained")
    names = modes.coordinates
    rotations = [(rot, style, _sde_indices(names, rot))
                 for rot, style in (("psi", "o-"), ("theta", "s--"), ("phi", "^:"))]
    along_arm = any(idx for _, _, idx in rotations)
    free = [int(j) for j in modes.free]
    for k in range(count):
        ax = axes[k, 0]
        if along_arm:
            for rot, style, idx in rotations:
                if idx:
                    ax.plot(range(1, len(idx) + 1), modes.shapes[idx, k], style, label=f"{rot} (rad)")
        else:
            ax.bar(range(len(free)), modes.shapes[free, k], color="C0")
        ax.set_ylabel(f"{modes.frequencies[k]:.4g} Hz\n{modes.kinds[k]}", fontsize=8)
        ax.axhline(0, color="k", lw=0.5)
        ax.grid(True, alpha=0.3)
    if along_arm:
        # sdes counted by their most numerous rotation: a link may hold some of them (freedoms)
        axes[-1, 0].set_xticks(range(1, max(len(idx) for _, _, idx in rotations) + 1))
        axes[0, 0].legend(fontsize=7, ncol=3)
        axes[-1, 0].set_xlabel("sde along the arm (1 = at the root)")
        fig.suptitle("Mode shapes: sde rotations (unit modal mass)")
    else:
        axes[-1, 0].set_xticks(range(len(free)), [names[j] for j in free], rotation=30, ha="right", fontsize=8)
        axes[-1, 0].set_xlabel("free coordinate (rad or m)")
        fig.suptitle("Mode shapes: amplitudes of the free coordinates (unit modal mass)")
    _freeze_layout(fig)
    return fig


def plot_convergence(table: ConvergenceTable, path) -> Path:
    """Log–log plot of the relative error of each quantity against ``nrfe``; writes ``path``
    (PNG) and returns it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(7.0, 5.2))
    n = np.array(table.nrfe, dtype=float)
    for (key, label, _), marker, color in zip(QUANTITIES, "osd^", ("C0", "C1", "C2", "C3")):
        if key not in table.values:  # the link has no mode of that kind
            continue
        ax.loglog(n, np.abs(table.errors[key]), marker=marker, color=color,
                  label=f"{label} (fitted order {table.orders[key]:.2f})")
        if table.limit[key] != table.analytic[key]:
            ax.loglog(n, np.abs(table.errors_limit[key]), marker=marker, color=color, ls="--", mfc="none",
                      label=f"  same, against the beam with rotary inertia ({table.orders_limit[key]:.2f})")
    # the modified RFEM's error goes as n_sde^-2 = (n_rfe - 1)^-2: a guide through the last point
    last = np.abs(table.errors["tip_deflection"][-1])
    ax.loglog(n[n > 1], last * ((n[n > 1] - 1) / (n[-1] - 1)) ** -2.0, "k:", lw=1,
              label="guide: (n_rfe - 1)^-2")
    ax.set_xticks(n)
    ax.set_xticklabels([str(int(v)) for v in n])
    ax.minorticks_off()
    ax.set_xlabel("number of rigid finite elements n_rfe (-)")
    ax.set_ylabel("relative error |RFEM - beam theory| / beam theory (-)")
    ax.set_title("Clamped arm: RFEM against beam theory\n(solid: Euler–Bernoulli / Saint-Venant; "
                 "dashed: with the sections' rotary inertia)", fontsize=10)
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=7.5, loc="lower left")
    fig.tight_layout()
    atomic_write(path, lambda fh: fig.savefig(fh, format=Path(path).suffix[1:] or "png", dpi=150))
    plt.close(fig)
    return path


__all__ = ["write_modes_csv", "plot_mode_shapes", "mode_shapes_figure", "plot_convergence"]
