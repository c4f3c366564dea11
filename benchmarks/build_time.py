"""Build time and generated size of the reference manipulator against n_rfe.

Run: ``.venv/bin/python benchmarks/build_time.py [nrfe ...]``. Each build runs in a fresh
process (no warm SymPy caches) and renders both backends into a temporary folder.
"""

from __future__ import annotations

import json
import subprocess
import sys

CODE = """
import json, sys, time, tempfile
from gpmegen.codegen import build
from gpmegen.model import reference_model
n = int(sys.argv[1])
t0 = time.perf_counter()
with tempfile.TemporaryDirectory() as out:
    r = build(reference_model(n), out, ("numpy", "c"), force=True)
print(json.dumps({"n_dof": r.n_dof, "seconds": time.perf_counter() - t0, "files": r.files}))
"""


def main(values):
    print(f"{'n_rfe':>5} {'n_dof':>5} {'build [s]':>9} {'s/n_dof':>8} {'numpy [KiB]':>11} {'C [KiB]':>8}")
    for n in values:
        out = subprocess.run([sys.executable, "-c", CODE, str(n)], capture_output=True, text=True, check=True)
        r = json.loads(out.stdout)
        print(f"{n:>5} {r['n_dof']:>5} {r['seconds']:>9.2f} {r['seconds'] / r['n_dof']:>8.3f} "
              f"{r['files']['model_numpy.py'] / 1024:>11.0f} {r['files']['model.c'] / 1024:>8.0f}", flush=True)


if __name__ == "__main__":
    main([int(v) for v in sys.argv[1:]] or [1, 2, 3, 5, 8, 10, 15, 20])
