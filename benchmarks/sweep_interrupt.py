"""How fast Ctrl-C stops a local sweep: ``gpmegen sweep`` of 12 runs (rigid arm, NumPy backend) on
the local pool is started in a subprocess; once ``--after`` runs have ended it gets SIGINT, and
the time from the signal to the exit of its last worker process and to the command's own exit is
measured. The workers are found as the command's child processes (those multiprocessing spawned,
not its resource tracker) when the signal is sent. Also printed: the runs kept, whether any run
file was written after the command ended and whether any partial or temporary file was left.

Run: ``.venv/bin/python benchmarks/sweep_interrupt.py [--after 3] [--rounds 3] [--t-end 0.05]``.
"""

from __future__ import annotations

import argparse
import os
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import psutil


def interrupt_once(folder: Path, t_end: float, after: int) -> dict:
    """One sweep stopped by SIGINT after ``after`` runs: the seconds to the workers' exit and to
    the command's exit, and what the folder holds."""
    argv = [sys.executable, "-m", "gpmegen.cli", "sweep", "--nrfe", "1", "--param", "tdr0=1:3:12", "--t-end",
            f"{t_end:g}", "--dt", "1e-4", "--save-every", "50", "--backend", "numpy", "--workers", "2", "--out",
            str(folder)]
    proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    ended = 0
    while ended < after:
        line = proc.stderr.readline()
        if not line:
            raise SystemExit(f"the sweep ended before {after} runs: exit status {proc.wait()}")
        ended += line.startswith("gpmegen: run ")
    workers = [child for child in psutil.Process(proc.pid).children(recursive=True)  # not the resource tracker
               if any("spawn_main" in part for part in child.cmdline())]
    sent = time.perf_counter()
    proc.send_signal(signal.SIGINT)
    gone, alive = psutil.wait_procs(workers, timeout=120)
    workers_s = time.perf_counter() - sent
    while "runs complete and kept" not in (proc.stderr.readline() or "runs complete and kept"):
        pass
    said_s = time.perf_counter() - sent
    proc.stderr.read()
    proc.wait(timeout=120)
    command_s = time.perf_counter() - sent
    exited = time.time()
    files = list((folder / "runs").iterdir())
    later = [p for p in files if p.stat().st_mtime > exited]
    time.sleep(2)  # a worker left running would write within this (measurement only, not a test)
    later += [p for p in (folder / "runs").iterdir() if p not in files]
    return {"workers": workers_s, "said": said_s, "command": command_s, "status": proc.returncode, "alive": len(alive),
            "kept": len(list((folder / "runs").glob("*.json"))), "later": len(later),
            "leftovers": sum(".partial" in p.name or p.name.startswith(".") for p in files)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--after", type=int, default=3, help="runs ended before the signal")
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--t-end", type=float, default=0.05, help="of each run (s)")
    args = parser.parse_args()
    print(f"load average before: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.rounds):
            r = interrupt_once(Path(tmp) / f"s{k}", args.t_end, args.after)
            print(f"round {k + 1}: SIGINT -> last worker gone {r['workers']:.3f} s, 'kept' line {r['said']:.3f} s, "
                  f"command exited {r['command']:.3f} s (status {r['status']}); workers left {r['alive']}, runs kept "
                  f"{r['kept']}, files written after the exit {r['later']}, partial or temporary files "
                  f"{r['leftovers']}")
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
