"""The figures of runs of one model, in the order and under the conditions of
:data:`gpmegen.analysis.figures.figure_list.FIGURES`, drawn by :mod:`plots` (the paper's, the
constraints', the energy balance's), :mod:`driving_plots` (the driving functions and the
elastic deformation) and :mod:`control_plots` (tracking error, control effort), and written."""

from __future__ import annotations

from pathlib import Path

from ...fileio import atomic_write_all
from . import control_plots, driving_plots, figure_list, plots


def figures(runs) -> list:
    """The (stem, draw) of the figures ``runs`` can make, in the order and under the conditions of
    :data:`gpmegen.analysis.figures.figure_list.FIGURES`: draw(plt, runs, styles) -> Figure."""
    draws = {"joint_coordinates": plots.joint_coordinates, "end_effector": plots.end_effector, "path": plots.path,
             "constraint_violation": plots.constraint_violation, "energy_balance": plots.energy_balance,
             "force_elements": plots.force_elements, **driving_plots.DRAWS,
             **control_plots.DRAWS}
    return [(stem, draws[stem]) for stem in figure_list.stems(runs)]


def targets(runs, out, formats=("png",)) -> list[Path]:
    """The files :func:`plot_all` writes for ``runs`` into the folder ``out``."""
    formats = (formats,) if isinstance(formats, str) else tuple(formats)
    return [Path(out) / f"{stem}.{fmt}" for stem, _ in figures(runs) for fmt in formats]


def plot_all(runs: list, out, formats=("png",), names=None) -> list[Path]:
    """Write the figures for ``runs`` (results dicts of one model) into ``out``, each in every
    format of ``formats`` (of :data:`plots.FORMATS`); returns the paths. Runs of different models are refused
    before anything is written (``names`` say which run is which)."""
    formats = (formats,) if isinstance(formats, str) else tuple(formats)
    if not formats or not set(formats) <= set(plots.FORMATS):
        raise ValueError(f"figure formats {formats}: choose among {', '.join(plots.FORMATS)}")
    plots.check_compatible(runs, names)
    runs = plots.distinguished(runs)
    plt = plots._pyplot()
    out = Path(out)
    style = plots.styles(runs)
    written = []
    for stem, draw in figures(runs):
        fig = draw(plt, runs, style)
        try:
            written += atomic_write_all({out / f"{stem}.{fmt}": plots._saver(fig, fmt) for fmt in formats})
        finally:
            plt.close(fig)
    return written
