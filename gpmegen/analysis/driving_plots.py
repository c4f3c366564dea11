"""Figures of the driving functions (rigid against flexible, ideal against actuated) and of the
elastic deformation, from results files that hold them (see :mod:`gpmegen.analysis.driving`)."""

from __future__ import annotations

import numpy as np

from . import plots
from .results import metadata


def realization(results) -> str:
    """How the run's constraints are realized, for legends."""
    if "u" in results:
        return "actuated on " + ", ".join(str(a) for a in results["actuators"])
    return "ideal, Dᵀλ"


def joint_forces(results, name):
    """The generalized force on joint ``name`` that drives it and realizes the constraints: its
    drive plus ``Dᵀλ`` (ideal) or ``S u`` (actuated), both ``M q̈ - f`` there."""
    k = [str(c) for c in results["coordinates"]].index(name)
    return results["drive_forces"][:, k] + results["constraint_forces"][:, k]


def driving_functions(plt, runs, style):
    """On each joint: its drive plus the forces that realize the programmed motion."""
    joints = plots.joint_names(runs[0])
    units = metadata(runs[0]).get("force_units", {})
    fig, axes = plots._figure(plt, len(joints), 1, 2.2 * len(joints) + 1.0, sharex=True)
    for r, s in zip(runs, style):
        for ax, name in zip(axes[:, 0], joints):
            if name in [str(c) for c in r["coordinates"]]:
                ax.plot(r["t"], joint_forces(r, name), **plots._line(s), lw=1.2)
    for ax, name in zip(axes[:, 0], joints):
        ax.set_ylabel(plots.literal(f"on {name} [{units.get(name, 'generalized')}]"))
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("t [s]")
    ways = {realization(r) for r in runs}
    # the way the constraints are realized names each run only where the runs differ in it
    handles = _handles(runs, style, plots.label if len(ways) == 1 else lambda r: f"{plots.label(r)} ({realization(r)})")
    plots._finish(fig, plots._title(runs, "Driving functions"), handles,
                  "Drive plus the generalized forces that realize the programmed motion, on the joints"
                  + (f" ({ways.pop()})." if len(ways) == 1 else "."))
    return fig


def elastic_deformation(plt, runs, style):
    """The deflection of E from the rigid arm at the same joints, and the spring moments c·ψ."""
    pairs = [(r, s) for r, s in zip(runs, style) if "spring_forces" in r and np.any(r["spring_forces"])]
    fig, axes = plots._figure(plt, 2, 1, 7.0, width=9.0, sharex=True)
    a1, a2 = axes[:, 0]
    for r, s in pairs:
        for i in range(3):
            a1.plot(r["t"], 1e3 * r["deflection"][:, i], color=s["color"], linestyle=COMPONENTS[i], lw=1)
        for j in np.flatnonzero(np.any(r["spring_forces"] != 0, axis=0)):
            a2.plot(r["t"], r["spring_forces"][:, j], color=s["color"], linestyle=s["linestyle"], lw=0.6, alpha=0.7)
    a1.set_ylabel("E - E of the rigid arm [mm]")
    a2.set_ylabel("spring moments c·ψ [N·m]")
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
    a2.set_xlabel("t [s]")
    flexible = [r for r, _ in pairs]
    handles = _handles(flexible, [s for _, s in pairs]) + _components()
    plots._finish(fig, plots._title(runs, "Elastic deformation"), handles,
                  "Top: x, y, z of E's deflection; bottom: the moment of every sde spring, one line each.")
    return fig


def constraint_multipliers(plt, runs, style):
    """The multipliers λ of the ideal realization, and the force on the constrained point."""
    pairs = [(r, s) for r, s in zip(runs, style) if "lambda" in r]
    first = pairs[0][0]
    names = [str(c) for c in first["constraint_names"]]
    units = metadata(first).get("lambda_units", {})
    with_force = "point_forces" in first
    rows = len(names) + with_force
    fig, axes = plots._figure(plt, rows, 1, 2.2 * rows + 1.0, sharex=True)
    for r, s in pairs:
        for i, name in enumerate(names):
            axes[i, 0].plot(r["t"], r["lambda"][:, i], **plots._line(s), lw=1.2)
            axes[i, 0].set_ylabel(plots.literal(f"λ {name} [{units.get(name, 'generalized')}]"))
        if with_force and "point_forces" in r:
            point = metadata(r)["force_points"][0]
            for i in range(3):
                axes[-1, 0].plot(r["t"], r["point_forces"][:, 0, i], color=s["color"], linestyle=COMPONENTS[i], lw=1)
            axes[-1, 0].set_ylabel(plots.literal(f"force on {point} in {{0}} [N]"))
    for ax in axes[:, 0]:
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("t [s]")
    handles = _handles([r for r, _ in pairs], [s for _, s in pairs]) + (_components() if with_force else [])
    plots._finish(fig, plots._title(runs, "Ideal realization"), handles,
                  "Multipliers λ of the constraints and the force they put on the constrained point.")
    return fig


COMPONENTS = ["-", "--", ":"]  # x, y, z of a vector, in the run's colour


def _handles(runs, style, name=plots.label):
    from matplotlib.lines import Line2D

    return [Line2D([], [], **plots._line(s), label=name(r)) for r, s in zip(runs, style)]


def _components():
    from matplotlib.lines import Line2D

    return [Line2D([], [], color="0.3", linestyle=ls, label=axis) for ls, axis in zip(COMPONENTS, "xyz")]


def figures(runs) -> list:
    """The (stem, draw) of the driving-function figures ``runs`` can make (see
    :func:`gpmegen.analysis.plots.figures`): none for results without the driving functions."""
    if not all("constraint_forces" in r and "drive_forces" in r for r in runs):
        return []
    made = [("driving_functions", driving_functions)]
    if any("spring_forces" in r and np.any(r["spring_forces"]) for r in runs):
        made.append(("elastic_deformation", elastic_deformation))
    if any("lambda" in r for r in runs):
        made.append(("constraint_multipliers", constraint_multipliers))
    return made
