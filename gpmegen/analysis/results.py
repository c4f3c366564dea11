"""Results files: NPZ (all arrays) and a CSV beside it, written atomically.

An NPZ written here holds ``format = "gpmegen-results-1"`` so that foreign files are refused
with a clear message instead of a KeyError deep inside plotting.
"""

from __future__ import annotations

import zipfile
import zlib
from pathlib import Path

import numpy as np

from ..errors import GpmegenError
from ..fileio import atomic_write

FORMAT = "gpmegen-results-1"
REQUIRED = ("t", "q", "qd", "coordinates", "end_effector", "phi", "tau_drive")


class ResultsError(GpmegenError):
    """A results file is missing, unreadable or not written by gpmegen."""


def save(results: dict, path, csv: bool = True) -> list[Path]:
    """Write ``results`` to ``path`` (.npz) and, with ``csv``, a CSV of t, q, E and Φ beside it."""
    path = Path(path)
    data = dict(results, format=np.array(FORMAT))
    atomic_write(path, lambda fh: np.savez_compressed(fh, **data))
    written = [path]
    if csv:
        csv_path = path.with_suffix(".csv")
        names = [str(c) for c in results["coordinates"]]
        cons = [f"phi_{c}" for c in results.get("constraint_names", [])]
        header = ",".join(["t"] + names + [f"{c}_dot" for c in names] + ["x_E", "y_E", "z_E"] + cons + ["tau_drive"])
        table = np.column_stack([results["t"], results["q"], results["qd"], results["end_effector"],
                                 results["phi"], results["tau_drive"]])

        def write_csv(fh):
            np.savetxt(fh, table, delimiter=",", header=header, comments="", fmt="%.12g")

        atomic_write(csv_path, write_csv)
        written.append(csv_path)
    return written


def load(path) -> dict:
    """Read a results NPZ written by :func:`save`; ResultsError if it is not one."""
    path = Path(path)
    try:
        with np.load(path, allow_pickle=False) as f:
            data = {k: f[k] for k in f.files}
    except FileNotFoundError:
        raise ResultsError(f"{path}: no such file; run 'gpmegen simulate' first") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as exc:  # empty, truncated, foreign
        raise ResultsError(f"{path}: not a gpmegen results file, or an incomplete one (cannot read it as NPZ: "
                           f"{exc or type(exc).__name__}); make it again with 'gpmegen simulate'") from None
    if str(data.get("format", "")) != FORMAT:
        raise ResultsError(f"{path}: not a gpmegen results file (no '{FORMAT}' marker); make it with 'gpmegen simulate'")
    missing = [k for k in REQUIRED if k not in data]
    if missing:
        raise ResultsError(f"{path}: results file lacks {', '.join(missing)}; make it again with 'gpmegen simulate'")
    samples = {k: data[k].shape[0] if data[k].ndim else None for k in REQUIRED if k != "coordinates"}
    if not samples["t"] or len(set(samples.values())) != 1:
        counts = ", ".join(f"{k} {v}" for k, v in samples.items())
        raise ResultsError(f"{path}: the results hold no samples or disagree on their number ({counts}); make "
                           f"them again with 'gpmegen simulate'")
    return data
