"""Figures of control: a computed-torque law's tracking error (the results' ``tracking_error``,
:mod:`gpmegen.analysis.post.law_references`) and each drive's force against time, its peak
marked (the drives as :func:`gpmegen.analysis.run.tracking.drives` finds them: the columns of
``drive_forces`` not zero throughout and the inputs ``u`` of an actuated realization)."""

from __future__ import annotations

import numpy as np

from ..post.results import metadata
from ..run.tracking import drives
from . import driving_plots, plots

# A coordinate's unit from the unit of the generalized force on it.
COORDINATE_UNITS = {"N·m": "rad", "N": "m"}


def _union(lists) -> list:
    """The names of ``lists`` in the order first met."""
    out: list = []
    for names in lists:
        out += [n for n in names if n not in out]
    return out


def _unit(runs, name) -> str:
    """The unit of a drive's force on ``name`` as the first run that says gives it."""
    return next((metadata(r)["force_units"][name] for r in runs if name in metadata(r).get("force_units", {})),
                "generalized")


def tracking_error(plt, runs, style):
    """``q_r - q`` of each coordinate of the runs' computed-torque laws (a task-space law's: ``x_r -
    x`` of each component of its point) against time, a panel each; runs without a law are left
    out of the figure."""
    pairs = [(r, s) for r, s in zip(runs, style) if "tracking_error" in r]
    names = _union([str(c) for c in r["reference_coordinates"]] for r, _ in pairs)
    units = {name: COORDINATE_UNITS.get(_unit(runs, name), "rad or m") for name in names}
    task = {}   # a task-space law's components say their unit
    for r, _ in pairs:
        task.update(zip((str(c) for c in r["reference_coordinates"]), (str(u) for u in r.get("reference_units", ()))))
    units.update(task)
    fig, axes = plots._figure(plt, len(names), 1, 2.0 * len(names) + 1.0, sharex=True)
    shaded = False
    for r, s in pairs:
        own = [str(c) for c in r["reference_coordinates"]]
        for ax, name in zip(axes[:, 0], names):
            if name in own:
                shaded |= plots.trace(ax, r["t"], r["tracking_error"][:, own.index(name)], s)
    for ax, name in zip(axes[:, 0], names):
        ax.set_ylabel(plots.literal(f"{name}: {'x_r − x' if name in task else 'q_r − q'} [{units[name]}]"))
    return driving_plots._finish_panels(fig, axes, runs, pairs, "Tracking error",
                                        "Each law coordinate's reference less the coordinate.", shaded)


def control_effort(plt, runs, style):
    """Each drive's generalized force against time, a panel per driven coordinate; each run's
    peak |u| marked with its value."""
    found = [(r, s, drives(r) if "drive_forces" in r or "u" in r else {}) for r, s in zip(runs, style)]
    pairs = [(r, s) for r, s, d in found if d]
    names = _union(list(d) for _, _, d in found)
    fig, axes = plots._figure(plt, len(names), 1, 2.2 * len(names) + 1.0, sharex=True)
    shaded = False
    for r, s, d in found:
        for ax, name in zip(axes[:, 0], names):
            if name in d:
                u = d[name][0]
                shaded |= plots.trace(ax, r["t"], u, s)
                k = int(np.argmax(np.abs(u)))
                ax.plot([r["t"][k]], [u[k]], marker=s["marker"], color=s["color"], ls="none", ms=6)
                ax.annotate(f"{u[k]:.3g}", (r["t"][k], u[k]), textcoords="offset points", xytext=(4, 4),
                            fontsize=8, color=s["color"])
    for ax, name in zip(axes[:, 0], names):
        ax.set_ylabel(plots.literal(f"u on {name} [{_unit(runs, name)}]"))
    return driving_plots._finish_panels(fig, axes, runs, pairs, "Control effort",
                                        "Each drive's force (and input u); the marker is the run's peak |u|.", shaded)


# The figures drawn here, by stem (their order and conditions: gpmegen.analysis.figures.figure_list)
DRAWS = {"tracking_error": tracking_error, "control_effort": control_effort}
