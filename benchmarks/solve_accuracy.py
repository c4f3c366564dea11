"""Accuracy of q̈ from the C and NumPy GPME solves against a 50-digit solve of the same terms.

At random states of the reference arm with elastic angles up to 1 rad it keeps those where the
model's partition (ψ2, x3) makes BᵀMB worst conditioned, and prints for each cond(BᵀMB), the
condition number of the motion κ = cond(ZᵀMZ) (Z an orthonormal basis of the allowed motions)
and the relative error (max norm) of each backend's q̈, all from the double-precision terms the
C backend evaluated (helpers in tests/precise_solve.py, shared with the tests).

Run: ``.venv/bin/python benchmarks/solve_accuracy.py [--nrfe 5 10] [--samples 2000] [--count 6]``.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import gpmegen

sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "tests"))
from precise_solve import EPS, ill_conditioned_states, solve_errors  # noqa: E402


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nrfe", type=int, nargs="+", default=[5, 10])
    ap.add_argument("--samples", type=int, default=2000, help="random states drawn per model")
    ap.add_argument("--count", type=int, default=6, help="worst-conditioned states kept")
    ap.add_argument("--seed", type=int, default=4)
    args = ap.parse_args()

    print(f"{'n_rfe':>5} {'cond(BᵀMB)':>11} {'κ':>8} {'eps·κ':>8} {'C error':>8} {'NumPy error':>11}")
    for n in args.nrfe:
        model = gpmegen.load("manipulator", nrfe=n, backend="c")
        worst_c = worst_numpy = 0.0
        for cond, t, q, qd in ill_conditioned_states(model, args.count, args.seed, args.samples):
            error_c, error_numpy, kappa = solve_errors(model, t, q, qd)
            worst_c, worst_numpy = max(worst_c, error_c / (EPS * kappa)), max(worst_numpy, error_numpy / (EPS * kappa))
            print(f"{n:>5} {cond:>11.1e} {kappa:>8.1e} {EPS * kappa:>8.1e} {error_c:>8.1e} {error_numpy:>11.1e}",
                  flush=True)
        print(f"n_rfe = {n}: largest error / (eps·κ): C {worst_c:.2f}, NumPy {worst_numpy:.2f}")


if __name__ == "__main__":
    main()
