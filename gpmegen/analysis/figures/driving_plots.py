"""Figures of the driving functions (rigid against flexible, ideal against actuated) and of the
elastic deformation, from results files that hold them (see :mod:`gpmegen.analysis.post.driving`)."""

from __future__ import annotations

import numpy as np

from ..post.results import metadata
from . import plots


def realization(results) -> str:
    """How the run's constraints are realized, for legends."""
    if "u" in results:
        return "actuated on " + ", ".join(str(a) for a in results["actuators"])
    return "ideal, Dᵀλ"


def joint_forces(results, name):
    """The generalized force on joint ``name`` that drives it and realizes the constraints: its
    drive plus ``Dᵀλ`` (ideal) or ``S u`` (actuated), both ``M q̈ - f`` there; on a joint with a
    law of its own (``meta["joint_laws"]``, ideal realization), its drive plus that law's
    reaction alone: the other constraints' reactions there are passive (a slider's guide on the
    crank), not the motor's."""
    k = [str(c) for c in results["coordinates"]].index(name)
    law = metadata(results).get("joint_laws", {}).get(name)
    if law is not None and "lambda" in results and "u" not in results:
        i = [str(c) for c in results["constraint_names"]].index(law[0])
        return results["drive_forces"][:, k] + law[1] * results["lambda"][:, i]
    return results["drive_forces"][:, k] + results["constraint_forces"][:, k]


def driving_functions(plt, runs, style):
    """On each joint: its drive plus the forces that realize the programmed motion."""
    joints = plots.joint_names(runs[0])
    units = metadata(runs[0]).get("force_units", {})
    fig, axes = plots._figure(plt, len(joints), 1, 2.2 * len(joints) + 1.0, sharex=True)
    shaded = False
    for r, s in zip(runs, style):
        for ax, name in zip(axes[:, 0], joints):
            if name in [str(c) for c in r["coordinates"]]:
                shaded |= plots.trace(ax, r["t"], joint_forces(r, name), s)
    for ax, name in zip(axes[:, 0], joints):
        ax.set_ylabel(plots.literal(f"on {name} [{units.get(name, 'generalized')}]"))
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("t [s]")
    ways = {realization(r) for r in runs}
    # the way the constraints are realized names each run only where the runs differ in it
    handles = _handles(runs, style, plots.label if len(ways) == 1 else lambda r: f"{plots.label(r)} ({realization(r)})")
    own_laws = any(metadata(r).get("joint_laws") for r in runs)
    plots._finish(fig, plots._title(runs, "Driving functions"), handles, plots._shaded(
                  "Drive plus the forces realizing the programmed motion"
                  + (f" ({ways.pop()})" if len(ways) == 1 else "")
                  + ("; on a joint with its own law, that law's reaction alone." if own_laws else "."), shaded))
    return fig


def elastic_deformation(plt, runs, style):
    """The deflection of E from the rigid arm at the same joints, x, y and z in a panel each (a
    line style is the run's, never a component's), and the largest spring moment |c·ψ|."""
    pairs = [(r, s) for r, s in zip(runs, style) if "spring_forces" in r and np.any(r["spring_forces"])]
    fig, axes = plots._figure(plt, 4, 1, 9.0, width=9.0, sharex=True)
    axes = axes[:, 0]
    shaded = False
    for r, s in pairs:
        for i in range(3):
            shaded |= plots.trace(axes[i], r["t"], 1e3 * r["deflection"][:, i], s, lw=1)
        shaded |= plots.trace(axes[3], r["t"], np.max(np.abs(r["spring_forces"]), axis=1), s, lw=1)
    for i, axis in enumerate("xyz"):
        axes[i].set_ylabel(f"{axis}: E - rigid E [mm]")
    axes[3].set_ylabel("largest |c·ψ| [N·m]")
    for ax in axes:
        ax.grid(True, alpha=0.3)
    axes[3].set_xlabel("t [s]")
    flexible = [r for r, _ in pairs]
    plots._finish(fig, plots._title(runs, "Elastic deformation"), _handles(flexible, [s for _, s in pairs]),
                  plots._shaded("E less E of the rigid arm, by axis of {0}; the largest sde moment.", shaded))
    return fig


def constraint_multipliers(plt, runs, style):
    """The multipliers λ of the ideal realization, and the force on the constrained point."""
    pairs = [(r, s) for r, s in zip(runs, style) if "lambda" in r]
    first = pairs[0][0]
    # the closures' rows are drawn as their reactions (closure_reactions), apart from these
    looped = {row for closure in metadata(first).get("closures", []) for row in closure["rows"]}
    names = [str(c) for c in first["constraint_names"]]
    shown = [i for i, name in enumerate(names) if name not in looped]
    units = metadata(first).get("lambda_units", {})
    with_force = "point_forces" in first
    rows = max(len(shown) + 3 * with_force, 1)
    fig, axes = plots._figure(plt, rows, 1, 2.0 * rows + 1.0, sharex=True)
    shaded = False
    for r, s in pairs:
        for row, i in enumerate(shown):
            shaded |= plots.trace(axes[row, 0], r["t"], r["lambda"][:, i], s)
            axes[row, 0].set_ylabel(plots.literal(f"λ {names[i]} [{units.get(names[i], 'generalized')}]"))
        if with_force and "point_forces" in r:
            point = metadata(r)["force_points"][0]
            for i, axis in enumerate("xyz"):  # a panel each: a line style is the run's, never a component's
                ax = axes[len(shown) + i, 0]
                shaded |= plots.trace(ax, r["t"], r["point_forces"][:, 0, i], s, lw=1)
                ax.set_ylabel(plots.literal(f"{axis}: force on {point} [N]"))
    return _finish_panels(fig, axes, runs, pairs, "Ideal realization",
                          "Multipliers λ and the force on the constrained point, in {0}.", shaded)


def closure_reactions(plt, runs, style):
    """Each closure's reaction on the body of its second point, from the body of its first: the
    force and, where the closure holds orientation, the moment, by axis of {0} (the components
    its kept rows act along)."""
    pairs = [(r, s) for r, s in zip(runs, style) if "lambda" in r]
    first = pairs[0][0]
    # the components its kept rows act along (a dropped row's is zero throughout)
    panels = [(closure["name"], kind, "xyz".index(a), unit) for closure in metadata(first).get("closures", [])
              for kind, unit in (("force", "N"), ("moment", "N·m"))
              if f"closure_{closure['name']}_{kind}" in first for a in closure["acting"][kind]]
    fig, axes = plots._figure(plt, len(panels), 1, 1.6 * len(panels) + 1.0, sharex=True)
    shaded = False
    for r, s in pairs:
        for row, (name, kind, a, unit) in enumerate(panels):
            key = f"closure_{name}_{kind}"
            if key in r:   # a panel each: a line style is the run's, never a component's
                shaded |= plots.trace(axes[row, 0], r["t"], r[key][:, a], s, lw=1)
            axes[row, 0].set_ylabel(plots.literal(f"{name}: {kind} {'xyz'[a]} [{unit}]"))
    return _finish_panels(fig, axes, runs, pairs, "Closure reactions",
                          "Reaction on the body of each closure's second point from the body of its first, in {0}.",
                          shaded)


def _finish_panels(fig, axes, runs, pairs, title, note, shaded):
    """A figure of panels against time finished: grids, the time axis, the runs' legend of
    ``pairs`` (run, style), the title and the note (with the shading's when ``shaded``)."""
    for ax in axes[:, 0]:
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("t [s]")
    handles = _handles([r for r, _ in pairs], [s for _, s in pairs])
    plots._finish(fig, plots._title(runs, title), handles, plots._shaded(note, shaded))
    return fig


def _handles(runs, style, name=plots.label):
    from matplotlib.lines import Line2D

    return [Line2D([], [], **plots._line(s), label=name(r)) for r, s in zip(runs, style)]


# The figures drawn here, by stem; which of them a set of runs gets, and in what order, is
# gpmegen.analysis.figures.figure_list's.
DRAWS = {"driving_functions": driving_functions, "elastic_deformation": elastic_deformation,
         "constraint_multipliers": constraint_multipliers, "closure_reactions": closure_reactions}
