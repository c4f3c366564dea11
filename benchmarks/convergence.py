"""Convergence of the RFEM arm to beam theory: the clamped arm (no slider) for several n_rfe.

Prints, for each n_rfe, the static self-weight tip deflection and the first vertical bending,
horizontal bending and torsional frequencies beside their Euler–Bernoulli / Saint-Venant values
(and the same with the sections' rotary inertia, the RFEM's continuum limit for bending), the
relative errors and the observed orders of convergence, and writes figures/convergence.png.

    .venv/bin/python benchmarks/convergence.py                  # n_rfe = 2 … 40
    .venv/bin/python benchmarks/convergence.py --nrfe 2 5 10 20 --static nonlinear

Models are built into build/generated/ (reused on later runs while the generator is unchanged).
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
DEFAULT_NRFE = (2, 3, 5, 8, 10, 15, 20, 30, 40)


def main(argv=None) -> int:
    from gpmegen.analysis.discretization import convergence
    from gpmegen.analysis.figures import modes_output

    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nrfe", type=int, nargs="+", default=list(DEFAULT_NRFE))
    parser.add_argument("--static", choices=("linear", "nonlinear"), default="linear",
                        help="tip deflection from a linear solve (default) or Newton-Raphson statics")
    parser.add_argument("--directory", type=Path, default=ROOT / "build" / "generated",
                        help="where the clamped-arm models are built")
    parser.add_argument("--figure", type=Path, default=ROOT / "figures" / "convergence.png")
    args = parser.parse_args(argv)

    start = time.perf_counter()
    table = convergence.convergence_table(
        args.nrfe, directory=args.directory, static=args.static,
        progress=lambda n, s: print(f"  built/loaded clamped arm n_rfe = {n:3d} in {s:7.1f} s", flush=True),
    )
    print()
    print(table.format())
    path = modes_output.plot_convergence(table, args.figure)
    print(f"\nfigure: {path}")
    print(f"total {time.perf_counter() - start:.1f} s (builds {table.build_seconds.sum():.1f} s)")
    return 0


if __name__ == "__main__":
    sys.exit(main())
