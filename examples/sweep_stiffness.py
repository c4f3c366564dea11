"""How the force that holds the programmed motion depends on the arm's stiffness: sweeps of the
paper's study over the arm's Young's modulus ``E2``, rigid (``n_rfe = 1``) and flexible
(``n_rfe = 5``), one period of the prescribed height (2.5 s) at the paper's step, from the
paper's locked start and from the constrained equilibrium (one sweep each, in ``--out``/locked
and ``--out``/constrained), and a figure of the peak generalized constraint forces on ``ψ2`` (the
arm's joint) and ``x3`` (the slider) against ``E2``, read from the sweeps' summaries.

Run: ``.venv/bin/python examples/sweep_stiffness.py --out sweeps/stiffness --figure
docs/figures/sweep_stiffness.png``. Run again with the same arguments, it keeps the complete runs.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import pyarrow.parquet as pq  # noqa: E402

import gpmegen  # noqa: E402

MODULI = [2e9, 5e9, 1e10, 2e10, 5e10, 1e11, 2e11]  # Pa; aluminium is 7e10
FORCES = (("psi2", "ψ2 (arm joint) [N·m]"), ("x3", "x3 (slider) [N]"))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("sweeps/stiffness"), help="the sweep's folder")
    parser.add_argument("--figure", type=Path, default=Path("figures/sweep_stiffness.png"))
    parser.add_argument("--t-end", type=float, default=2.5, help="simulated time of each run in s")
    args = parser.parse_args()
    tables = {}
    for start in ("locked", "constrained"):
        gpmegen.sweep(out=args.out / start, nrfe=[1, 5], params={"E2": MODULI}, t_end=args.t_end, dt=1e-5,
                      save_every=100, backend="c", start=start, progress=print)
        tables[start] = pq.read_table(args.out / start / "summary.parquet").to_pydict()
    fig, axes = plt.subplots(1, 2, figsize=(10, 4.2), sharex=True)
    for (coordinate, label), ax in zip(FORCES, axes):
        for start, line in (("locked", "-"), ("constrained", "--")):
            table = tables[start]
            for nrfe, marker, name in ((1, "o", "rigid"), (5, "s", "flexible, n_rfe = 5")):
                rows = [k for k, n in enumerate(table["nrfe"]) if n == nrfe]
                ax.semilogx([table["E2"][k] for k in rows],
                            [table[f"peak_constraint_force.{coordinate}"][k] for k in rows],
                            marker + line, color="C0" if nrfe == 1 else "C2", label=f"{name}, {start} start")
        ax.axvline(7e10, color="0.6", lw=0.8, ls=":")
        ax.set_xlabel("Young's modulus of the arm E2 [Pa]")
        ax.set_ylabel(f"peak constraint force on {label}")
        ax.set_yscale("log")
        ax.grid(True, alpha=0.3, which="both")
        ax.legend(fontsize=7)
    fig.suptitle(f"Forces that hold the programmed motion over {args.t_end:g} s, against the arm's stiffness "
                 f"(dotted: aluminium)", fontsize=10)
    fig.tight_layout()
    args.figure.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(args.figure, dpi=120)
    print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
