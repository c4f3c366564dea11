"""Results files: NPZ (all arrays) and a CSV beside it, written as a pair.

An NPZ written here holds ``format = "gpmegen-results-2"`` so that foreign files are refused
with a clear message instead of a KeyError deep inside plotting, and a ``run_id`` that the
first line of its CSV repeats (``# gpmegen-results-2 run <id>: complete``, or ``partial (why)``),
so that a reader can tell the two files of one run from a mismatched pair. Its ``meta`` is a
JSON object: ``model``, ``coordinates``, ``constraint_names``, ``backend``, ``start``,
``settings``, ``params`` and what the run's case adds for plots (see :func:`metadata`). Files of
format 1 (settings as Python text) are refused with the command that makes them again.

The driving functions were added to format 2 without changing it (files without them are read as
before): ``qdd`` (k, n) q̈, ``constraint_forces`` (k, n) ``M q̈ - f``, and either ``lambda``
(k, m) with ``point_forces`` (k, n_points, 3) N (ideal realization) or ``u`` (k, m) with
``actuators`` (m,) names (actuated realization); their units are in ``meta``. A model with
closed loops adds each closure's reaction, ``closure_<name>_force`` and ``closure_<name>_moment``
(k, 3) in {0}, described by ``meta["closures"]``. A model with force elements between points adds
``force_names`` (f,) and ``force_elements`` (k, f, 3): each element's length L (m), its rate
(m/s) and its force (N, positive pushing its two points apart), also in the CSV as
``L_<name> [m]``, ``Ldot_<name> [m/s]`` and ``F_<name> [N]``. A model with drives that have a
``limit`` adds ``limited_drives`` (l,) their coordinates, ``drive_laws`` and ``drive_limits``
(k, l) each law before its clip and its limit, and ``time_at_limit`` (l,) s
(:mod:`gpmegen.analysis.post.drive_limits`). A model under computed torque adds
``reference_coordinates`` (r,) the law's coordinates, ``q_reference`` (k, r) their references
``q_r`` and ``tracking_error`` (k, r) ``q_r - q`` (:mod:`gpmegen.analysis.post.law_references`),
also in the CSV as ``qr_<name>`` and ``e_<name>``; under a task-space law the names are its
point's coordinates (``x_E``, ...), ``x_r - x`` the error of the controller model's point, and
``reference_units`` (r,) says they are in m.
"""

from __future__ import annotations

import json
import re
import uuid
import zipfile
import zlib
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from ... import npz
from ...errors import GpmegenError
from ...fileio import atomic_write_all

FORMAT = "gpmegen-results-2"
OLD_FORMATS = ("gpmegen-results-1",)
REQUIRED = ("t", "q", "qd", "coordinates", "end_effector", "phi", "tau_drive", "meta")
PER_SAMPLE = ("t", "q", "qd", "end_effector", "phi", "tau_drive")
#: The arrays a results file may hold, the only ones :func:`load` reads: others (a foreign file's)
#: are never inflated.
ENTRIES = REQUIRED + ("format", "run_id", "status", "qdd", "constraint_names", "drive_forces", "constraint_forces",
                      "lambda", "point_forces", "u", "actuators", "kinetic_energy", "gravity_energy", "spring_energy",
                      "work_drive", "work_constraints", "work_dampers", "prescribed", "spring_forces", "deflection",
                      "internal_eigenvalues", "force_names", "force_elements", "limited_drives", "drive_laws",
                      "drive_limits", "time_at_limit", "controller_names", "controller_states",
                      "reference_coordinates", "q_reference", "tracking_error", "reference_units")
#: A closure's reaction (:mod:`gpmegen.analysis.post.closures`): ``closure_<name>_force`` and
#: ``closure_<name>_moment`` (k, 3), the closure's name being a model's name.
CLOSURE_ENTRY = re.compile(r"closure_[A-Za-z][A-Za-z0-9_]{0,47}_(force|moment)")


def readable(name: str) -> bool:
    """Whether :func:`load` reads the array ``name``: one of :data:`ENTRIES` or a closure's reaction."""
    return name in ENTRIES or CLOSURE_ENTRY.fullmatch(name) is not None


class ResultsError(GpmegenError):
    """A results file is missing, unreadable or not written by gpmegen."""


def targets(path: str | Path, complete: bool = True) -> tuple[Path, Path]:
    """The (.npz, .csv) pair that :func:`save` writes for results meant for ``path`` (.npz):
    ``path`` itself for a complete run, ``<name>.partial.npz`` beside it for a partial one."""
    path = Path(path)
    if not complete:
        path = path.with_name(f"{path.stem}.partial{path.suffix}")
    return path, path.with_suffix(".csv")


def default_name(stem: str, start: str, method: str, actuators: Sequence[str] = ()) -> str:
    """The default results file of a run: ``<stem>_<start>_<method>.npz``, one name per model,
    start and integrator (and ``_actuated-<coordinates>`` for an actuated realization), so that
    runs of one model with other settings keep their own files."""
    realization = "_actuated-" + "-".join(actuators) if len(actuators) else ""
    return f"{stem}_{start}_{method.lower()}{realization}.npz"


def encode(meta: Mapping[str, Any]) -> np.ndarray:
    """``meta`` as the JSON text a results file holds."""
    return np.array(json.dumps(meta, ensure_ascii=False))


def metadata(results: Mapping[str, Any]) -> dict[str, Any]:
    """The metadata of ``results``: ``model``, ``coordinates``, ``constraint_names``,
    ``backend``, ``start``, ``settings`` (method, dt, save_every, save_dt, the adaptive methods'
    rtol and atol, effort: steps, rejected, solves, jacobians, factorizations as
    :class:`gpmegen.runtime.integrators.base.Effort`, t_end, dependent, repartitions), ``params`` and,
    from the run's case (:mod:`gpmegen.analysis.run.cases`), what plots use: ``label``, ``joints``,
    ``joint_labels``, ``constraint_units``, ``figures``, ``start_tag``, ``colour``,
    ``tag_offset``, ``prescribed``; ``start_moved``: how far the start was moved onto the
    constraints (see :meth:`gpmegen.runtime.consistent.Start.meta`); ``model_source``: where the model
    is found again (:meth:`gpmegen.analysis.run.cases.Case.locator`); and the units of the driving
    functions (:func:`gpmegen.analysis.post.driving.annotate`): ``force_units``, ``lambda_units``,
    ``force_points``."""
    return json.loads(str(results["meta"]))


def annotate(results: Mapping[str, Any], meta: Mapping[str, Any], arrays: Mapping[str, Any]) -> dict[str, Any]:
    """``results`` with ``meta`` added to its metadata and ``arrays`` to its arrays."""
    return dict(results, **arrays, meta=encode({**metadata(results), **meta}))


def driving_columns(results: Mapping[str, Any]) -> tuple[list[str], list[np.ndarray]]:
    """The CSV's columns of the driving functions, with units in their names: λ of each
    constraint (ideal realization), the force on each constrained point in {0} and each
    closure's reaction (force, and moment where it has one, in {0}), or the inputs ``u``
    (actuated realization). Returns (names, arrays (k,) or (k, j))."""
    meta = metadata(results)
    if "u" in results:
        units = meta.get("force_units", {})
        return ([f"u_{c} [{units.get(str(c), 'generalized')}]" for c in results["actuators"]], [results["u"]])
    if "lambda" not in results:
        return [], []
    units = meta.get("lambda_units", {})
    names = [f"lambda_{c} [{units.get(str(c), 'generalized')}]" for c in results["constraint_names"]]
    arrays = [results["lambda"]]
    if "point_forces" in results:
        names += [f"F{a}_{p} [N]" for p in meta["force_points"] for a in "xyz"]
        arrays.append(results["point_forces"].reshape(len(results["t"]), -1))
    for closure in meta.get("closures", []):   # the reaction on its second point's body, in {0}
        for kind, letter, unit in (("force", "F", "N"), ("moment", "M", "N·m")):
            key = f"closure_{closure['name']}_{kind}"
            if key in results:
                names += [f"{letter}{a}_closure_{closure['name']} [{unit}]" for a in "xyz"]
                arrays.append(results[key])
    return names, arrays


def force_columns(results: Mapping[str, Any]) -> tuple[list[str], list[np.ndarray]]:
    """The CSV's columns of the force elements between points: each one's length, rate and
    force. Returns (names, arrays (k, j))."""
    if "force_elements" not in results or not len(results["force_names"]):
        return [], []
    names = [f"{label}_{name} [{unit}]" for name in results["force_names"]
             for label, unit in (("L", "m"), ("Ldot", "m/s"), ("F", "N"))]
    return names, [results["force_elements"].reshape(len(results["t"]), -1)]


def reference_columns(results: Mapping[str, Any]) -> tuple[list[str], list[np.ndarray]]:
    """The CSV's columns of a computed-torque law: each coordinate's reference and error, in its
    coordinate's unit. Returns (names, arrays (k, j))."""
    if "tracking_error" not in results:
        return [], []
    names = [str(c) for c in results["reference_coordinates"]]
    return [f"qr_{c}" for c in names] + [f"e_{c}" for c in names], [results["q_reference"], results["tracking_error"]]


def save(results: Mapping[str, Any], path: str | Path, csv: bool = True) -> list[Path]:
    """Write ``results`` to ``path`` (.npz) and, with ``csv``, a CSV of t, q, E, Φ and the driving
    functions (:func:`driving_columns`) beside it,
    both files or neither. A partial run (``status`` other than "complete") goes to the
    :func:`targets` beside ``path``, so a complete result there is never replaced by it.
    Returns the paths written."""
    status = str(results["status"])
    npz_path, csv_path = targets(path, complete=status == "complete")
    run_id = uuid.uuid4().hex
    data = dict(results, format=np.array(FORMAT), run_id=np.array(run_id))
    writes = {npz_path: lambda fh: np.savez_compressed(fh, **data)}
    if csv:
        names = [str(c) for c in results["coordinates"]]
        cons = [f"phi_{c}" for c in results.get("constraint_names", [])]
        state = "complete" if status == "complete" else f"partial ({' '.join(status.split())})"
        columns, driving = driving_columns(results)
        for extra_names, extra in (force_columns(results), reference_columns(results)):
            columns, driving = columns + extra_names, driving + extra
        header = (f"# {FORMAT} run {run_id}: {state}\n"
                  + ",".join(["t"] + names + [f"{c}_dot" for c in names] + ["x_E", "y_E", "z_E"] + cons
                             + ["tau_drive"] + columns))
        table = np.column_stack([results["t"], results["q"], results["qd"], results["end_effector"],
                                 results["phi"], results["tau_drive"], *driving])
        writes[csv_path] = lambda fh: np.savetxt(fh, table, delimiter=",", header=header, comments="", fmt="%.12g",
                                                 encoding="utf-8")
    return atomic_write_all(writes)


def load(path: str | Path) -> dict[str, np.ndarray]:
    """Read a results NPZ written by :func:`save`; ResultsError if it is not one."""
    path = Path(path)
    try:
        data = npz.read_checked(path, readable, ResultsError,
                                "make the results again with 'gpmegen simulate'")
    except FileNotFoundError:
        raise ResultsError(f"{path}: no such file; run 'gpmegen simulate' first") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as exc:  # empty, truncated, foreign
        raise ResultsError(f"{path}: not a gpmegen results file, or an incomplete one (cannot read it as NPZ: "
                           f"{exc or type(exc).__name__}); make it again with 'gpmegen simulate'") from None
    found = str(data.get("format", ""))
    if found in OLD_FORMATS:
        raise ResultsError(f"{path}: written by an older gpmegen (format '{found}', this one reads '{FORMAT}'); "
                           f"make it again with 'gpmegen simulate'")
    if found != FORMAT:
        raise ResultsError(f"{path}: not a gpmegen results file (no '{FORMAT}' marker); make it with "
                           f"'gpmegen simulate'")
    missing = [k for k in REQUIRED if k not in data]
    if missing:
        raise ResultsError(f"{path}: results file lacks {', '.join(missing)}; make it again with 'gpmegen simulate'")
    try:
        metadata(data)
    except ValueError:
        raise ResultsError(f"{path}: the results' metadata is not JSON; make them again with 'gpmegen simulate'") \
            from None
    samples = {k: data[k].shape[0] if data[k].ndim else None for k in PER_SAMPLE}
    if not samples["t"] or len(set(samples.values())) != 1:
        counts = ", ".join(f"{k} {v}" for k, v in samples.items())
        raise ResultsError(f"{path}: the results hold no samples or disagree on their number ({counts}); make "
                           f"them again with 'gpmegen simulate'")
    return data
