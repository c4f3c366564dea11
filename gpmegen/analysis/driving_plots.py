"""Figures of the driving functions (rigid against flexible, ideal against actuated) and of the
elastic deformation, from results files that hold them (see :mod:`gpmegen.analysis.driving`)."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from . import plots
from .results import metadata

STYLES = ["-", "--", "-.", ":"]


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


def _colours(runs) -> list:
    """The runs' colours: each case's own (rigid and flexible differ), another where two share it."""
    colours = []
    for k, r in enumerate(runs):
        colour = metadata(r).get("colour", f"C{k}")
        colours.append(colour if colour not in colours else f"C{k + 3}")
    return colours


def _style(runs, k):
    return {"ls": STYLES[k % len(STYLES)], "color": _colours(runs)[k]}


def _driving(plt, runs, out, fmt):
    joints = plots.joint_names(runs[0])
    units = metadata(runs[0]).get("force_units", {})
    fig, axes = plt.subplots(len(joints), 1, figsize=(8, 2.6 * len(joints) + 0.5), sharex=True, squeeze=False)
    for k, r in enumerate(runs):
        for ax, name in zip(axes[:, 0], joints):
            if name in [str(c) for c in r["coordinates"]]:
                ax.plot(r["t"], joint_forces(r, name), lw=1, label=f"{plots.label(r)} ({realization(r)})",
                        **_style(runs, k))
            ax.set_ylabel(f"on {name} [{units.get(name, 'generalized')}]")
            ax.grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel("t [s]")
    fig.suptitle("Driving functions: drive + the forces that realize the programmed motion, on the joints")
    return plots._save(fig, out, "driving_functions", fmt)


def _deformation(plt, runs, out, fmt):
    flexible = [r for r in runs if "spring_forces" in r and np.any(r["spring_forces"])]
    if not flexible:
        return None
    fig, (a1, a2) = plt.subplots(2, 1, figsize=(9, 8), sharex=True)
    for k, r in enumerate(flexible):
        for i, axis in enumerate("xyz"):
            a1.plot(r["t"], 1e3 * r["deflection"][:, i], STYLES[i], lw=1, color=_colours(flexible)[k],
                    label=f"{axis}, {plots.label(r)}")
        names = [str(c) for c in r["coordinates"]]
        for j in np.flatnonzero(np.any(r["spring_forces"] != 0, axis=0)):
            a2.plot(r["t"], r["spring_forces"][:, j], lw=0.8, label=f"{names[j]}, {plots.label(r)}")
    a1.set_ylabel("E - E of the rigid arm [mm]")
    a2.set_ylabel("spring moment c·ψ [N·m]")
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=6, ncol=3)
    a2.set_xlabel("t [s]")
    fig.suptitle("Elastic deformation: deflection of E from the rigid arm at the same joints, moments at the sdes")
    return plots._save(fig, out, "elastic_deformation", fmt)


def _multipliers(plt, runs, out, fmt):
    ideal = [r for r in runs if "lambda" in r]
    if not ideal:
        return None
    names = [str(c) for c in ideal[0]["constraint_names"]]
    units = metadata(ideal[0]).get("lambda_units", {})
    with_force = "point_forces" in ideal[0]
    fig, axes = plt.subplots(len(names) + with_force, 1, figsize=(8, 2.6 * (len(names) + with_force) + 0.5),
                             sharex=True, squeeze=False)
    for k, r in enumerate(ideal):
        for i, name in enumerate(names):
            axes[i, 0].plot(r["t"], r["lambda"][:, i], lw=1, label=plots.label(r), **_style(ideal, k))
            axes[i, 0].set_ylabel(f"λ {name} [{units.get(name, 'generalized')}]")
        if with_force and "point_forces" in r:
            point = metadata(r)["force_points"][0]
            for i, axis in enumerate("xyz"):
                axes[-1, 0].plot(r["t"], r["point_forces"][:, 0, i], STYLES[i], lw=1, color=_colours(ideal)[k],
                                 label=f"F{axis}, {plots.label(r)}")
            axes[-1, 0].set_ylabel(f"force on {point} in {{0}} [N]")
    for ax in axes[:, 0]:
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    axes[-1, 0].set_xlabel("t [s]")
    fig.suptitle("Ideal realization: multipliers λ and the force on the constrained point")
    return plots._save(fig, out, "constraint_multipliers", fmt)


def plot_driving(runs: list, out, fmt: str = "png") -> list[Path]:
    """The driving-function figures of ``runs`` that hold them; returns the paths written."""
    if not all("constraint_forces" in r and "drive_forces" in r for r in runs):
        return []
    plt = plots._pyplot()
    written = []
    for figure in (_driving, _deformation, _multipliers):
        path = figure(plt, runs, Path(out), fmt)
        plt.close("all")
        if path is not None:
            written.append(path)
    return written
