"""The summary of a sweep: one row per run, its inputs and scalar outcomes, written as CSV and
as Parquet (the same table, column for column).

Columns: ``run`` (id), ``nrfe`` (empty: a model file's own), the parameters given, ``status`` (complete, diverged,
interrupted, failed, or died: its process was killed making it), ``message`` (why, when not complete),
``t_final`` (s), ``max_abs_phi``
and ``max_abs_phi.<constraint>`` (the largest constraint violation over the run), ``q_final.<c>``
per coordinate, ``peak_drive.<c>`` per driven coordinate and ``peak_constraint_force.<c>`` per
coordinate (largest magnitude over the saved samples, N·m or N), ``energy_balance_error`` (J:
the largest ``|ΔE - W_drive - W_constraints - W_dampers|``, the dampers' work a term of the
balance), and ``wall_s`` (the run's wall time in s, model loading and writing included). A
column that does not apply to a run (a coordinate another nrfe does not have, the outcomes of a
failed run) is empty in the CSV and null in Parquet.
"""

from __future__ import annotations

import csv
import io
import math
from pathlib import Path

import numpy as np

from ...fileio import atomic_write_all
from ..post.energy import balance_residual

CSV = "summary.csv"
PARQUET = "summary.parquet"
TEXT_COLUMNS = ("run", "status", "message")
INTEGER_COLUMNS = ("nrfe",)
#: Per-coordinate arrays of a run's results whose largest magnitude the summary holds, with
#: their column prefix; results that carry further forces per coordinate (actuator forces) add
#: a line here.
PEAKS = (("constraint_forces", "peak_constraint_force"),)


def outcomes(results, driven=()) -> dict:
    """The scalar outcomes of one run's ``results`` (see :mod:`gpmegen.analysis.post.results`);
    ``driven``: the coordinates the model's drives act on."""
    status = str(results["status"])
    ending, _, why = status.partition(": ")
    coordinates = [str(c) for c in results["coordinates"]]
    phi = np.abs(results["phi"])
    row = {"status": ending, "message": why or None, "t_final": float(results["t"][-1]),
           "max_abs_phi": float(phi.max(initial=0.0))}
    for k, name in enumerate(results["constraint_names"]):
        row[f"max_abs_phi.{name}"] = float(phi[:, k].max(initial=0.0))
    row.update({f"q_final.{c}": float(results["q"][-1, k]) for k, c in enumerate(coordinates)})
    drive = np.abs(results["drive_forces"])
    row.update({f"peak_drive.{c}": float(drive[:, coordinates.index(c)].max()) for c in driven})
    for key, prefix in PEAKS:
        if key in results:
            peaks = np.abs(results[key]).max(axis=0)
            row.update({f"{prefix}.{c}": float(peaks[k]) for k, c in enumerate(coordinates)})
    if "kinetic_energy" in results:
        row["energy_balance_error"] = float(np.abs(balance_residual(results)).max())
    return row


def failure(message: str) -> dict:
    """The outcomes of a run that produced no results."""
    return {"status": "failed", "message": " ".join(message.split())}


def died(message: str) -> dict:
    """The outcomes of a run whose process died making it (a crash in compiled code, a kill)."""
    return {"status": "died", "message": " ".join(message.split())}


def columns(rows: list[dict]) -> dict[str, list]:
    """``rows`` as columns: every key of any row, grouped by the part before a dot (``q_final``)
    in the order first met; None where a row lacks one."""
    names = list(dict.fromkeys(key for row in rows for key in row))
    groups = list(dict.fromkeys(name.split(".")[0] for name in names))
    names.sort(key=lambda name: groups.index(name.split(".")[0]))  # stable: first met within a group
    return {name: [row.get(name) for row in rows] for name in names}


def _csv_cell(value) -> str:
    if value is None:
        return ""
    if isinstance(value, float):
        return repr(value) if math.isfinite(value) else str(value)  # repr: read back bit for bit
    return str(value)


def _csv_bytes(table: dict) -> bytes:
    text = io.StringIO()
    writer = csv.writer(text, lineterminator="\n")
    writer.writerow(table)
    for row in zip(*table.values()):
        writer.writerow([_csv_cell(v) for v in row])
    return text.getvalue().encode("utf-8")


def _arrow_table(table: dict):
    import pyarrow as pa

    def kind(name):
        return pa.string() if name in TEXT_COLUMNS else pa.int64() if name in INTEGER_COLUMNS else pa.float64()

    return pa.table({name: pa.array(values, type=kind(name)) for name, values in table.items()})


def write(rows: list[dict], folder: Path) -> list[Path]:
    """Write the summary of ``rows`` into ``folder`` as CSV and Parquet, both or neither."""
    import pyarrow.parquet as pq

    table = columns(rows)
    csv_bytes, arrow = _csv_bytes(table), _arrow_table(table)
    return atomic_write_all({folder / CSV: lambda fh: fh.write(csv_bytes),
                             folder / PARQUET: lambda fh: pq.write_table(arrow, fh)})


def read_csv(path) -> dict[str, list]:
    """A summary CSV as columns (text as written; numbers as floats; empty cells None)."""
    with open(path, newline="", encoding="utf-8") as fh:
        rows = list(csv.reader(fh))
    header, body = rows[0], rows[1:]

    def value(name, cell):
        if cell == "":
            return None
        if name in TEXT_COLUMNS:
            return cell
        return int(cell) if name in INTEGER_COLUMNS else float(cell)

    return {name: [value(name, row[k]) for row in body] for k, name in enumerate(header)}
