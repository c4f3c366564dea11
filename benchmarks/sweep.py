"""Parallel efficiency of ``gpmegen sweep`` on this machine: 16 runs of the paper's study (rigid
and flexible arm, eight moduli of the arm, C backend, the paper's step 1e-5 s) at a reduced
``t_end``, one after the other in this process against the local pool (one process per core).

Both are the command ``gpmegen sweep`` (``--workers 1``, and one per core), each a fresh process
that starts, loads the models and makes the same 16 runs into a fresh folder; they alternate
``--rounds`` times and the best wall time of each is kept (a busy machine only lengthens them).
The efficiency is ``T_sequential / (workers × T_pool)``: 1 when the pool's processes lose nothing
to starting, loading the models and sharing the machine. The CPU time of each side (of the
command and its processes) is printed too: on a machine whose cores are taken by other work the
wall times say little, and the pool's CPU time against the sequential one is what parallel runs
cost in start-ups. Before timing, a one-run sweep builds
and compiles the models, so neither side pays for that.

Run: ``.venv/bin/python benchmarks/sweep.py [--t-end 2.5] [--rounds 2] [--workers N]``.
"""

from __future__ import annotations

import argparse
import os
import resource
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import gpmegen

MODULI = [1e10, 2e10, 3e10, 4e10, 5e10, 6e10, 7e10, 8e10]


def timed_sweep(folder: Path, t_end: float, workers: int) -> tuple[float, float]:
    """Wall time and CPU time (s) of ``gpmegen sweep`` of the 16 runs on ``workers`` processes."""
    argv = [sys.executable, "-m", "gpmegen.cli", "sweep", "--nrfe", "1", "5", "--param",
            "E2=" + ",".join(f"{e:g}" for e in MODULI), "--t-end", f"{t_end:g}", "--dt", "1e-5", "--backend", "c",
            "--workers", str(workers), "--out", str(folder)]
    before = resource.getrusage(resource.RUSAGE_CHILDREN)
    began = time.perf_counter()
    subprocess.run(argv, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    wall = time.perf_counter() - began
    after = resource.getrusage(resource.RUSAGE_CHILDREN)
    return wall, (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--t-end", type=float, default=2.5,
                        help="simulated time of each run in s (default 2.5: one period of the height of E)")
    parser.add_argument("--rounds", type=int, default=2, help="alternating rounds, best kept (default 2)")
    parser.add_argument("--workers", type=int, default=os.cpu_count(), help="pool size (default: one per core)")
    args = parser.parse_args()
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory(prefix="gpmegen-sweep-bench-") as tmp:
        tmp = Path(tmp)
        gpmegen.sweep(out=tmp / "warm", nrfe=[1, 5], params={"E2": MODULI[:1]}, t_end=0.001, dt=1e-5, backend="c",
                      workers=1)
        best = {"sequential": (float("inf"), 0.0), "pool": (float("inf"), 0.0)}
        for k in range(args.rounds):
            best["sequential"] = min(best["sequential"], timed_sweep(tmp / f"seq{k}", args.t_end, 1))
            best["pool"] = min(best["pool"], timed_sweep(tmp / f"pool{k}", args.t_end, args.workers))
    load = os.getloadavg()[0]
    (seq, seq_cpu), (pool, pool_cpu) = best["sequential"], best["pool"]
    print(f"16 runs (n_rfe 1 and 5, 8 moduli), t_end = {args.t_end:g} s at dt = 1e-5 s, C backend; "
          f"load average {load_before:.2f} before, {load:.2f} after, on {os.cpu_count()} cores")
    print(f"sequential (--workers 1): {seq:.2f} s wall, {seq_cpu:.2f} s CPU")
    print(f"local pool, {args.workers} processes: {pool:.2f} s wall, {pool_cpu:.2f} s CPU")
    print(f"speed-up {seq / pool:.2f}, parallel efficiency {seq / (args.workers * pool):.2f}; CPU spent by the "
          f"pool against sequential {pool_cpu / seq_cpu:.2f}")


if __name__ == "__main__":
    main()
