"""The paper's figures (joint coordinates, coordinates and path of E) plus constraint violation
and energy balance, for one or more results files drawn together."""

from __future__ import annotations

import ast
from pathlib import Path

import numpy as np

from ..fileio import atomic_write


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def label(results) -> str:
    """A legend label: the model and, for the reference case, rigid or flexible."""
    name = str(results["model"])
    settings = ast.literal_eval(str(results["settings"])) if "settings" in results else {}
    start = settings.get("start")
    if name.startswith("manipulator_nrfe"):
        n = int(name.rsplit("nrfe", 1)[1])
        text = "rigid arm" if n == 1 else f"flexible arm, n_rfe = {n}"
    else:
        text = name
    return f"{text} ({start} start)" if start and start != "locked" else text


def joint_names(results) -> list:
    """The coordinates to draw as joints: the paper's three for the reference case, else those
    that are not sde rotations of a flexible link (at most four)."""
    import re

    names = [str(c) for c in results["coordinates"]]
    if {"theta1", "psi2", "x3"} <= set(names):
        return ["theta1", "psi2", "x3"]
    sde = re.compile(r"^(psi|theta|phi).+_\d+$")
    return [c for c in names if not sde.match(c)][:4] or names[:3]


def _coordinate(results, name):
    names = [str(c) for c in results["coordinates"]]
    return results["q"][:, names.index(name)] if name in names else None


def _save(fig, out: Path, stem: str, fmt: str) -> Path:
    return atomic_write(out / f"{stem}.{fmt}", lambda fh: fig.savefig(fh, format=fmt, dpi=130, bbox_inches="tight"))


def plot_all(runs: list, out, fmt: str = "png") -> list[Path]:
    """Write the figures for ``runs`` (results dicts) into ``out``; returns the paths."""
    plt = _pyplot()
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    written = []
    styles = ["-", "--", "-.", ":"]

    # Fig. 2: joint coordinates
    joints = joint_names(runs[0])
    fig, axes = plt.subplots(len(joints), 1, figsize=(8, 2.6 * len(joints) + 0.5), sharex=True, squeeze=False)
    axes = axes[:, 0]
    pretty = {"theta1": "θ1 [rad]", "psi2": "ψ2 [rad]", "x3": "x3 [m]"}
    for k, r in enumerate(runs):
        for ax, name in zip(axes, joints):
            v = _coordinate(r, name)
            if v is not None:
                ax.plot(r["t"], v, styles[k % 4], label=label(r))
            ax.set_ylabel(pretty.get(name, name))
            ax.grid(True, alpha=0.3)
    axes[0].legend()
    axes[-1].set_xlabel("t [s]")
    fig.suptitle("Joint coordinates (paper Fig. 2)" if joints == ["theta1", "psi2", "x3"] else "Joint coordinates")
    written.append(_save(fig, out, "joint_coordinates", fmt))
    plt.close(fig)

    # Fig. 3: coordinates of E, with the prescribed height
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for k, r in enumerate(runs):
        for i, (ax, name) in enumerate(zip(axes, ["x_E [m]", "y_E [m]", "z_E [m]"])):
            ax.plot(r["t"], r["end_effector"][:, i], styles[k % 4], label=label(r))
            ax.set_ylabel(name)
            ax.grid(True, alpha=0.3)
        params = ast.literal_eval(str(r["params"])) if "params" in r else {}
        if {"y_c", "A", "T"} <= params.keys():
            t = r["t"]
            axes[1].plot(t, params["y_c"] + params["A"] * np.cos(2 * np.pi * t / params["T"]), ":", color="k",
                         lw=1, label=f"prescribed y_E,a ({label(r)})" if len(runs) > 1 else "prescribed y_E,a")
    axes[1].legend(fontsize=8)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("t [s]")
    fig.suptitle("Coordinates of the end-effector E (paper Fig. 3)")
    written.append(_save(fig, out, "end_effector", fmt))
    plt.close(fig)

    # Fig. 4: path of E in the x0z0 and x0y0 planes, starting points marked
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 5))
    for k, r in enumerate(runs):
        E = r["end_effector"]
        colour = "C0" if "rigid" in label(r) else "C2"
        a1.plot(E[:, 0], E[:, 2], styles[k % 4], lw=1, color=colour, label=label(r))
        a2.plot(E[:, 0], E[:, 1], styles[k % 4], lw=1, color=colour, label=label(r))
        rigid = "rigid" in label(r)
        reference = str(r["model"]).startswith("manipulator_nrfe")
        tag = (r"$E'_r$" if rigid else r"$E'_f$") if reference else "start"
        for ax, (i, j) in ((a1, (0, 2)), (a2, (0, 1))):
            ax.plot(E[0, i], E[0, j], "o", ms=7, color="C0" if rigid else "C2")
            # the two starting points lie close together: put the tags on opposite sides
            ax.annotate(tag, (E[0, i], E[0, j]), textcoords="offset points",
                        xytext=(-22, 8) if rigid else (8, -14), fontsize=12)
    a1.set_xlabel("x0 [m]"), a1.set_ylabel("z0 [m]"), a1.set_aspect("equal", "datalim")
    a2.set_xlabel("x0 [m]"), a2.set_ylabel("y0 [m]")
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    a1.set_title("path of E in the x0z0 plane")
    a2.set_title("path of E in the x0y0 plane")
    fig.suptitle("Path of the end-effector (paper Fig. 4)")
    written.append(_save(fig, out, "path", fmt))
    plt.close(fig)

    # Constraint violation
    fig, axes = plt.subplots(len(runs[0]["constraint_names"]) or 1, 1, figsize=(8, 6), sharex=True, squeeze=False)
    for k, r in enumerate(runs):
        for i, name in enumerate(r["constraint_names"]):
            axes[i, 0].semilogy(r["t"], np.maximum(np.abs(r["phi"][:, i]), 1e-18), styles[k % 4], label=label(r))
            axes[i, 0].set_ylabel(f"|Φ {name}|")
            axes[i, 0].grid(True, alpha=0.3)
    axes[0, 0].legend(fontsize=8)
    axes[-1, 0].set_xlabel("t [s]")
    fig.suptitle("Constraint violation (circle: m², height: m)")
    written.append(_save(fig, out, "constraint_violation", fmt))
    plt.close(fig)

    # Energy balance
    if all("kinetic_energy" in r for r in runs):
        fig, axes = plt.subplots(2, 1, figsize=(8, 7), sharex=True)
        for k, r in enumerate(runs):
            total = r["kinetic_energy"] + r["gravity_energy"] + r["spring_energy"]
            work = r["work_drive"] + r["work_constraints"]
            axes[0].plot(r["t"], total - total[0], styles[k % 4], label=f"ΔE, {label(r)}")
            axes[0].plot(r["t"], work, styles[k % 4], lw=3, alpha=0.4, label=f"W drive + W constraints, {label(r)}")
            axes[1].plot(r["t"], total - total[0] - work, styles[k % 4], label=label(r))
        axes[0].set_ylabel("energy [J]")
        axes[1].set_ylabel("ΔE - W [J]")
        for ax in axes:
            ax.grid(True, alpha=0.3)
            ax.legend(fontsize=8)
        axes[-1].set_xlabel("t [s]")
        fig.suptitle("Power balance: change of total energy against the work of drive and constraints")
        written.append(_save(fig, out, "energy_balance", fmt))
        plt.close(fig)
    return written
