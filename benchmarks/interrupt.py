"""Time from a signal to the end of a long run: ``gpmegen simulate`` of the reference arm over
1e9 s, saving every 1e8 s (each saved interval billions of steps), stopped by SIGINT and by
SIGTERM ``--after`` seconds into its integration, for dop853, radau and genalpha (compiled) and
scipy-radau. Prints, per run, the seconds from the signal to the process's exit, its exit status
and whether the partial results were written and marked partial, with the load average.

    .venv/bin/python benchmarks/interrupt.py [--nrfe 1] [--after 1.0]
"""

from __future__ import annotations

import argparse
import os
import select
import signal
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from gpmegen.analysis.post import results as results_io

METHODS = ("dop853", "radau", "genalpha", "scipy-radau")
STARTED = b"Ctrl-C or SIGTERM stops it"


def stop(method: str, number: int, nrfe: int, after: float, folder: Path) -> tuple[float, int, str]:
    """One run of ``method`` stopped by signal ``number`` ``after`` s into its integration:
    ``(seconds from signal to exit, exit status, the partial results' status)``."""
    out = folder / f"{method}-{signal.Signals(number).name}.npz"
    step = ["--dt", "1e-3"] if method == "genalpha" else []
    proc = subprocess.Popen([sys.executable, "-m", "gpmegen.cli", "simulate", "--nrfe", str(nrfe), "--backend", "c",
                             "--method", method, *step, "--t-end", "1e9", "--save-dt", "1e8", "--no-limits",
                             "--out", str(out)], stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    seen = b""
    while STARTED not in seen:
        select.select([proc.stderr], [], [], 600)
        chunk = os.read(proc.stderr.fileno(), 4096)
        if not chunk:
            raise SystemExit(f"{method}: the run ended before its integration started: {seen.decode()}")
        seen += chunk
    time.sleep(after)  # deep in the loop
    sent = time.perf_counter()
    proc.send_signal(number)
    proc.communicate(timeout=600)
    seconds = time.perf_counter() - sent
    partial = results_io.targets(out, complete=False)[0]
    status = str(results_io.load(partial)["status"]) if partial.exists() else "none written"
    return seconds, proc.returncode, status


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nrfe", type=int, default=1)
    parser.add_argument("--after", type=float, default=1.0, help="seconds into the integration (default 1)")
    parser.add_argument("--methods", nargs="+", default=list(METHODS), choices=METHODS)
    args = parser.parse_args(argv)
    print(f"n_rfe {args.nrfe}, signal {args.after:g} s into the integration; load average "
          f"{' '.join(f'{x:.2f}' for x in os.getloadavg())}")
    print(f"{'method':<12} {'signal':<8} {'to exit (s)':>11}  exit  partial status")
    with tempfile.TemporaryDirectory() as folder:
        for method in args.methods:
            for number in (signal.SIGINT, signal.SIGTERM):
                seconds, code, status = stop(method, number, args.nrfe, args.after, Path(folder))
                print(f"{method:<12} {number.name:<8} {seconds:11.3f}  {code:4d}  {status}", flush=True)
    print(f"load average after: {' '.join(f'{x:.2f}' for x in os.getloadavg())}")


if __name__ == "__main__":
    main()
