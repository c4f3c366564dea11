"""Cost of computed torque in the compiled loop: one RK4 step of a flexible plant whose joints a
rigid controller model drives, against the same plant's open-loop step.

Run: ``.venv/bin/python benchmarks/computed_torque.py [--nrfe 5] [--rounds 5] [--plant FILE]``. The
plant is ``examples/manipulator_computed_torque.toml`` (the reference arm without constraints, its
three joints under computed torque with the rigid arm, ``manipulator.toml`` at ``n_rfe = 1``, as the
controller model), or ``--plant examples/manipulator_task_space.toml`` (the same under the
task-space law); the open loop is the same model without the law (no drives at all). Both are
built and compiled first (not timed), then timed in one process, in alternation round after round
(so both see the same load): the model library's ``rk4``, 4 000 steps of 1e-5 s from the arm
straight at the references' start, CPU time of the process, the best of 3 per round. Prints the
per-step times, their ratio (median over rounds) and the load average before and after.
"""

from __future__ import annotations

import argparse
import dataclasses
import os
import statistics
import time
from pathlib import Path

import numpy as np

import gpmegen

ROOT = Path(__file__).resolve().parents[1]
PLANT = ROOT / "examples" / "manipulator_computed_torque.toml"
STEPS, DT = 4000, 1e-5


def per_step(model, q, qd, repeat=3) -> float:
    """CPU seconds of one RK4 step of ``model``'s compiled loop, the best of ``repeat``."""
    model.rk4(q, qd, STEPS * DT, DT, save_every=STEPS)
    times = []
    for _ in range(repeat):
        t0 = time.process_time()
        *_, status = model.rk4(q, qd, STEPS * DT, DT, save_every=STEPS)
        times.append(time.process_time() - t0)
    return min(times) / STEPS


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nrfe", type=int, default=5)
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--plant", type=Path, default=PLANT, help="a plant model file with a [controller] table")
    args = parser.parse_args()
    print("load average before:", os.getloadavg())
    closed = gpmegen.load_model_file(args.plant, nrfe=args.nrfe)
    opened = dataclasses.replace(closed, name=f"{closed.name}_open", computed_torque=None, task_torque=None)
    models = {"closed": gpmegen.load(model=closed, backend="c"), "open": gpmegen.load(model=opened, backend="c")}
    n = models["open"].n_dof
    q, qd = np.zeros(n), np.zeros(n)
    q[models["open"].index("psi2")] = np.pi / 4
    qd[models["open"].index("psi2")] = 0.4
    ratios = []
    for k in range(args.rounds):
        closed_step, open_step = per_step(models["closed"], q, qd), per_step(models["open"], q, qd)
        ratios.append(closed_step / open_step)
        print(f"round {k}: closed loop {closed_step * 1e6:.2f} us/step, open loop {open_step * 1e6:.2f} us/step, "
              f"ratio {ratios[-1]:.3f}")
    print(f"n_dof {n}, ratio closed/open (median of {args.rounds}): {statistics.median(ratios):.3f}")
    print("load average after:", os.getloadavg())


if __name__ == "__main__":
    main()
