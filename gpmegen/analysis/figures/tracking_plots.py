"""The figure of ``gpmegen metrics``: the end-effector's path error over time, one line per run,
each labelled by what tells it from the others (:func:`gpmegen.analysis.figures.plots.distinguished`)."""

from __future__ import annotations

from pathlib import Path

from ...fileio import atomic_write_all
from . import plots


def path_error(runs: list, metrics: list, reference_label: str, out, formats=("png",), labels=None) -> list[Path]:
    """Write ``tracking.<format>`` into the folder ``out``: ``|E - E_ref|`` (mm) of each of
    ``metrics`` (:class:`gpmegen.analysis.run.tracking.Metrics`) against time, labelled ``labels``
    or, by default, from its results in ``runs`` (the same order) by what differs between them.
    Returns the paths written."""
    plt = plots._pyplot()
    if labels is not None:
        runs = [{**run, plots.LEGEND: label} for run, label in zip(runs, labels)]
    labelled = plots.distinguished(runs)
    style = plots.styles(labelled)
    fig, axes = plots._figure(plt, 1, 1, 3.6)
    ax = axes[0, 0]
    shaded = False
    for m, s in zip(metrics, style):
        shaded |= plots.trace(ax, m.t, 1e3 * m.path_error, s)
    ax.set_xlabel("t (s)")
    ax.set_ylabel("|E − E_ref| (mm)")
    ax.grid(True, alpha=0.3)
    caption = plots._shaded(f"Reference: {plots.literal(reference_label)}.", shaded)
    plots._finish(fig, "End-effector path error", plots._run_handles(labelled, style), caption)
    try:
        return atomic_write_all({Path(out) / f"tracking.{fmt}": plots._saver(fig, fmt) for fmt in formats})
    finally:
        plt.close(fig)


def targets(out, formats=("png",)) -> list[Path]:
    """The files :func:`path_error` writes into ``out``."""
    return [Path(out) / f"tracking.{fmt}" for fmt in formats]
