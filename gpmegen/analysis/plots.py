"""The paper's figures (joint coordinates, coordinates and path of E) plus constraint violation
and energy balance, for one or more results files drawn together."""

from __future__ import annotations

from pathlib import Path

import numpy as np

from ..fileio import atomic_write
from .results import metadata


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def label(results) -> str:
    """A legend label: the run's case's label (the model's name by default) and its start
    unless it is the locked statics."""
    meta = metadata(results)
    text, start = meta.get("label", meta["model"]), meta["start"]
    return f"{text} ({start} start)" if start != "locked" else text


def joint_names(results) -> list:
    """The coordinates to draw as joints: those the run's case names, else the first three."""
    return metadata(results).get("joints") or [str(c) for c in results["coordinates"]][:3]


def _title(runs, title, figure) -> str:
    """``title``, with the figure of the source (e.g. "paper Fig. 2") that every run names."""
    sources = {metadata(r).get("figures", {}).get(figure) for r in runs}
    source = sources.pop() if len(sources) == 1 else None
    return f"{title} ({source})" if source else title


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
    pretty = metadata(runs[0]).get("joint_labels", {})
    for k, r in enumerate(runs):
        for ax, name in zip(axes, joints):
            v = _coordinate(r, name)
            if v is not None:
                ax.plot(r["t"], v, styles[k % 4], label=label(r))
            ax.set_ylabel(pretty.get(name, name))
            ax.grid(True, alpha=0.3)
    axes[0].legend()
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(_title(runs, "Joint coordinates", "joint_coordinates"))
    written.append(_save(fig, out, "joint_coordinates", fmt))
    plt.close(fig)

    # Fig. 3: coordinates of E, with the prescribed height
    fig, axes = plt.subplots(3, 1, figsize=(8, 8), sharex=True)
    for k, r in enumerate(runs):
        for i, (ax, name) in enumerate(zip(axes, ["x_E [m]", "y_E [m]", "z_E [m]"])):
            ax.plot(r["t"], r["end_effector"][:, i], styles[k % 4], label=label(r))
            ax.set_ylabel(name)
            ax.grid(True, alpha=0.3)
        prescribed = metadata(r).get("prescribed")
        if prescribed and "prescribed" in r:
            name = prescribed["label"]
            axes[prescribed["axis"]].plot(r["t"], r["prescribed"], ":", color="k", lw=1,
                                          label=f"{name} ({label(r)})" if len(runs) > 1 else name)
    axes[1].legend(fontsize=8)
    axes[0].legend(fontsize=8)
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(_title(runs, "Coordinates of the end-effector E", "end_effector"))
    written.append(_save(fig, out, "end_effector", fmt))
    plt.close(fig)

    # Fig. 4: path of E in the x0z0 and x0y0 planes, starting points marked
    fig, (a1, a2) = plt.subplots(1, 2, figsize=(11, 5))
    for k, r in enumerate(runs):
        E, meta = r["end_effector"], metadata(r)
        colour, tag = meta.get("colour", "C2"), meta.get("start_tag", "start")
        a1.plot(E[:, 0], E[:, 2], styles[k % 4], lw=1, color=colour, label=label(r))
        a2.plot(E[:, 0], E[:, 1], styles[k % 4], lw=1, color=colour, label=label(r))
        for ax, (i, j) in ((a1, (0, 2)), (a2, (0, 1))):
            ax.plot(E[0, i], E[0, j], "o", ms=7, color=colour)
            ax.annotate(tag, (E[0, i], E[0, j]), textcoords="offset points",
                        xytext=meta.get("tag_offset", (8, -14)), fontsize=12)
    a1.set_xlabel("x0 [m]"), a1.set_ylabel("z0 [m]"), a1.set_aspect("equal", "datalim")
    a2.set_xlabel("x0 [m]"), a2.set_ylabel("y0 [m]")
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
        ax.legend(fontsize=8)
    a1.set_title("path of E in the x0z0 plane")
    a2.set_title("path of E in the x0y0 plane")
    fig.suptitle(_title(runs, "Path of the end-effector", "path"))
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
    units = metadata(runs[0]).get("constraint_units")
    fig.suptitle("Constraint violation" + (f" ({', '.join(f'{c}: {u}' for c, u in units.items())})" if units else ""))
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
    from .driving_plots import plot_driving  # the driving functions and the elastic deformation

    return written + plot_driving(runs, out, fmt)
