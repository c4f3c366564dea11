"""Tracking metrics of runs against a reference motion: what a control engineer reads off a run.

The reference is either a model whose programmed constraints define the motion (its constraint
functions ``Φ_i(t, q, q̇)`` are evaluated on each run's states, and its ideal run gives the
end-effector's reference path), or a run (its end-effector path). For each run:

- each programmed constraint's value ``Φ_i`` on the run's states: max ``|Φ_i|`` and RMS, in the
  constraint's own unit (a plant driven by controllers may have no constraints of its own);
- the path error ``e(t) = |E(t) - E_ref(t)|`` (m): max and RMS;
- the residual vibration after ``after`` (s; default the end of the programmed motion where it is
  known): the end-effector's deviation ``E(t) - E(t_end)`` from its final position, its
  peak-to-peak (the largest over x, y, z of max − min of the component, m) and its RMS (of the
  deviation's norm, m);
- the control effort of each drive (generalized force ``u`` on a coordinate, from the results'
  ``drive_forces``, and the inputs ``u`` of an actuated realization): peak ``|u|``, RMS ``u`` and
  the energy ``∫|u q̇| dt`` (J: N·m times rad/s, or N times m/s), the work done by the drive in
  either direction, which braking does not cancel.

RMS values are time-weighted (``sqrt(∫x² dt / T)``, trapezoidal over the saved samples), so that
runs saved on different grids compare: a constant error is its own RMS exactly.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ...errors import GpmegenError
from ...fileio import atomic_write_bytes
from ...model import Model
from ...model.expand import expand
from ..post import results as results_io
from . import runs as runs_io
from .cases import ModelCase
from .opening import case_for
from .runspec import RunSpec

# A constraint function that changes by less than this (relative to 1 + |Φ|) between saved times
# at a fixed state no longer depends on t: the programmed motion has ended.
STILL = 1e-12
# A reference run's end-effector within this distance (m) of its final position has stopped.
STOPPED = 1e-9


class TrackingError(GpmegenError):
    """A run or reference cannot be measured: a missing column, coordinates that do not match."""


@dataclass
class Reference:
    """What runs are measured against: ``label``; ``t`` (k,) s and ``path`` (k, 3) m, the
    end-effector's reference path in {0}; ``model``, the loaded model whose constraint functions
    are evaluated (None for a run given as reference); ``motion_end`` s, the end of the programmed
    motion, or None when it is not known."""

    label: str
    t: np.ndarray
    path: np.ndarray
    model: object = None
    motion_end: float | None = None


@dataclass
class Metrics:
    """One run's metrics: ``name`` (its file or label), ``constraints`` name -> (max |Φ|, RMS),
    ``path`` (max, RMS) m, ``after`` s (None: no vibration measured), ``vibration``
    (peak-to-peak, RMS) m, ``effort`` coordinate -> (peak |u|, RMS u, ∫|u q̇| dt J) with
    ``units`` coordinate -> the unit of u (N·m or N; "generalized" where the run does not say);
    ``t`` (k,) s and ``path_error`` (k,) m for the figure."""

    name: str
    constraints: dict = field(default_factory=dict)
    path: tuple = (np.nan, np.nan)
    after: float | None = None
    vibration: tuple = (np.nan, np.nan)
    effort: dict = field(default_factory=dict)
    units: dict = field(default_factory=dict)
    t: np.ndarray = None
    path_error: np.ndarray = None


def rms(t, values) -> float:
    """Time-weighted RMS ``sqrt(∫ values² dt / (t[-1] - t[0]))`` over the samples (k,) or (k, j)
    (rows summed); the one sample's value for a single sample."""
    t = np.asarray(t, dtype=float)
    square = np.asarray(values, dtype=float) ** 2
    square = square.reshape(len(t), -1).sum(axis=1)
    if len(t) < 2 or t[-1] == t[0]:
        return float(np.sqrt(square.mean()))
    return float(np.sqrt(np.trapezoid(square, t) / (t[-1] - t[0])))


def effort(t, u, qd) -> tuple:
    """(peak |u|, RMS u, ∫|u q̇| dt) of a drive's generalized force ``u`` (k,) on a coordinate of
    rate ``qd`` (k,): N·m (or N), the same, and J (trapezoidal over the samples)."""
    u, qd = np.asarray(u, dtype=float), np.asarray(qd, dtype=float)
    energy = float(np.trapezoid(np.abs(u * qd), t)) if len(t) > 1 else 0.0
    return float(np.max(np.abs(u))), rms(t, u), energy


def vibration(t, path, after) -> tuple:
    """(peak-to-peak, RMS) in m of the end-effector's deviation ``path(t) - path(t_end)`` from its
    final position over ``t >= after``: the largest max − min of its x, y, z components, and the
    RMS of its norm. NaN when no sample lies after ``after``."""
    keep = np.asarray(t) >= after
    if not np.any(keep):
        return np.nan, np.nan
    deviation = path[keep] - path[-1]
    spread = float(np.max(deviation.max(axis=0) - deviation.min(axis=0)))
    return spread, rms(np.asarray(t)[keep], deviation)


def drives(run) -> dict:
    """Coordinate -> (u (k,), q̇ (k,)) of each drive of ``run``: the columns of ``drive_forces``
    not zero throughout, and the inputs ``u`` of an actuated realization. TrackingError when the
    run holds neither column (results of an older gpmegen)."""
    names = [str(c) for c in run["coordinates"]]
    if "drive_forces" not in run and "u" not in run:
        raise TrackingError("the run holds no drive_forces (nor inputs u); make it again with 'gpmegen simulate'")
    out = {}
    if "drive_forces" in run:
        for j, name in enumerate(names):
            column = run["drive_forces"][:, j]
            if np.any(column != 0):
                out[name] = (column, run["qd"][:, j])
    for k, name in enumerate(str(c) for c in run.get("actuators", ())):
        j = names.index(name)
        u = run["u"][:, k] + out.get(name, (0.0,))[0]   # an actuated coordinate's drive adds to its input
        out[name] = (u, run["qd"][:, j])
    return out


def check_coordinates(run, coordinates, name) -> list[str]:
    """The names of ``run``'s coordinates; TrackingError naming those of ``coordinates`` (the
    reference model ``name``'s) it lacks."""
    names = [str(c) for c in run["coordinates"]]
    missing = [c for c in coordinates if c not in names]
    if missing:
        raise TrackingError(f"the run has no coordinate {', '.join(missing)} of the reference model "
                            f"{name} (the run's: {', '.join(names)}); measure it against a model "
                            f"of the same coordinates")
    return names


def columns_of(run, model) -> list[int]:
    """The columns of ``run``'s state arrays in the order of ``model``'s coordinates;
    TrackingError naming the coordinates the run lacks."""
    names = check_coordinates(run, model.coordinates, model.module.MODEL)
    return [names.index(c) for c in model.coordinates]


def constraint_values(run, model) -> np.ndarray:
    """Φ (k, m) of ``model``'s programmed constraints on the states of ``run`` (a second-order
    one's ``D q̈ + γ`` with the run's q̈; TrackingError when the run holds none)."""
    order = columns_of(run, model)
    q, qd = run["q"][:, order], run["qd"][:, order]
    t = np.asarray(run["t"], dtype=float)
    values, _, D, gamma = model.constraint_terms(t, q, qd)
    values = np.asarray(values).reshape(len(t), -1)
    orders = np.asarray(model.constraint_orders)
    if np.any(orders == 2):
        if "qdd" not in run:
            raise TrackingError("the reference has second-order constraints and the run holds no accelerations "
                                "qdd; make it again with 'gpmegen simulate'")
        qdd = run["qdd"][:, order]
        values = np.where(orders == 2, np.matmul(D, qdd[..., None])[..., 0] + gamma, values)
    return values


def motion_end_of_model(model, t, q, qd) -> float | None:
    """The end of the programmed motion of ``model``: the first of the times ``t`` (k,) from
    which its constraint functions at the fixed state ``(q, q̇)`` (n,) no longer change (within
    :data:`STILL`); None when they change up to the last one (a motion that goes on)."""
    t = np.asarray(t, dtype=float)
    if not len(model.constraint_names):
        return None
    values = np.asarray(model.constraint_terms(t, np.tile(q, (len(t), 1)), np.tile(qd, (len(t), 1)))[0])
    values = values.reshape(len(t), -1)
    return _settled(t, np.abs(values - values[-1]) <= STILL * (1 + np.abs(values[-1])))


def motion_end_of_path(t, path) -> float | None:
    """The first of the times ``t`` from which ``path`` (k, 3) m stays within :data:`STOPPED` of
    its final position; None when it moves up to the end."""
    return _settled(np.asarray(t, dtype=float), np.linalg.norm(path - path[-1], axis=1)[:, None] <= STOPPED)


def _settled(t, still) -> float | None:
    """The first time from which every column of ``still`` (k, j) holds; None when only the last
    sample does (nothing shows the motion has ended)."""
    moving = np.flatnonzero(~np.all(still, axis=1))
    first = int(moving[-1]) + 1 if len(moving) else 0
    return float(t[first]) if first < len(t) - 1 else None


def measure(run, reference: Reference, name: str, after: float | None = None) -> Metrics:
    """The metrics of ``run`` (a results dict) against ``reference``; ``after`` s the start of the
    residual vibration (default ``reference.motion_end``; None when that is unknown too)."""
    t = np.asarray(run["t"], dtype=float)
    metrics = Metrics(name, t=t)
    if reference.model is not None:
        phi = constraint_values(run, reference.model)
        for i, c in enumerate(reference.model.constraint_names):
            metrics.constraints[c] = (float(np.max(np.abs(phi[:, i]))), rms(t, phi[:, i]))
    if t[-1] > reference.t[-1] * (1 + 1e-12) + 1e-12 or t[0] < reference.t[0] - 1e-12:
        raise TrackingError(f"the run spans {t[0]:g} to {t[-1]:g} s, beyond the reference's {reference.t[0]:g} to "
                            f"{reference.t[-1]:g} s; give a reference that spans the run")
    expected = np.column_stack([np.interp(t, reference.t, reference.path[:, a]) for a in range(3)])
    metrics.path_error = np.linalg.norm(run["end_effector"] - expected, axis=1)
    metrics.path = (float(np.max(metrics.path_error)), rms(t, metrics.path_error))
    metrics.after = after if after is not None else reference.motion_end
    if metrics.after is not None:
        metrics.vibration = vibration(t, np.asarray(run["end_effector"], dtype=float), metrics.after)
    metrics.effort = {c: effort(t, u, qd) for c, (u, qd) in drives(run).items()}
    units = results_io.metadata(run).get("force_units", {})
    metrics.units = {c: units.get(c, "generalized") for c in metrics.effort}
    return metrics


def run_reference(path) -> Reference:
    """A run (results file at ``path``) as the reference: its end-effector path."""
    run = results_io.load(path)
    t = np.asarray(run["t"], dtype=float)
    path_of_e = np.asarray(run["end_effector"], dtype=float)
    return Reference(f"the run {path}", t, path_of_e, None, motion_end_of_path(t, path_of_e))


def model_reference(case, runs, backend, progress) -> Reference:
    """The model of ``case`` as the reference: its constraint functions, and its ideal run (the
    case's start, the ideal realization, RK4 at the first run's step, saved at its save interval)
    to the longest run's end as the end-effector's reference path; the parameters the model shares
    with the first run take that run's values (the motion it was asked to follow)."""

    t_end = max(float(r["t"][-1]) for r in runs)
    first = results_io.metadata(runs[0]).get("settings", {})
    t0 = np.asarray(runs[0]["t"], dtype=float)
    saved = float(np.median(np.diff(t0))) if len(t0) > 1 else t_end
    dt = float(first.get("dt") or min(RunSpec().dt, saved))
    spec = RunSpec.of(t_end=t_end, dt=dt, save_every=max(1, int(round(saved / dt))), actuated=())
    # a reference the runs cannot be measured against is refused before it is built and run
    if case.source is not None:
        coordinates, name = expand(case.source).coordinates, case.source.name
    else:   # a built folder: its manifest names them
        coordinates, name = case.manifest["coordinates"], case.manifest["model"]
    for run in runs:
        check_coordinates(run, coordinates, name)
    known = {p.name for p in case.model.parameters} if case.source is not None else set()
    shared = {k: v for k, v in results_io.metadata(runs[0]).get("params", {}).items() if k in known}
    done = runs_io.run(case, spec, backend, shared, None, progress)
    if str(done.results["status"]) != "complete":
        raise TrackingError(f"the reference {case.label}'s ideal run stopped: {done.results['status']}; give a "
                            f"reference whose motion can be run to {t_end:g} s")
    t = np.asarray(done.results["t"], dtype=float)
    model = done.model.with_actuators(())
    q_end, qd_end = done.results["q"][-1], done.results["qd"][-1]
    return Reference(case.label, t, np.asarray(done.results["end_effector"], dtype=float), model,
                     motion_end_of_model(model, t, q_end, qd_end))


def reference_of(ref, runs, backend="c", progress=lambda line: None, nrfe=None) -> Reference:
    """The :class:`Reference` ``ref`` names: a :class:`gpmegen.Model`, a results file (.npz), a
    model file (with ``nrfe`` rfes, default the first run's where its results name them), a
    folder made by ``gpmegen build --out``, or None for the reference manipulator (with ``nrfe``
    rfes, default the first run's where it is a run of that arm, else 5)
    (:func:`gpmegen.analysis.run.opening.case_for`)."""

    if isinstance(ref, Model):
        return model_reference(ModelCase(ref), runs, backend, progress)
    if ref is not None and Path(ref).suffix == ".npz":
        return run_reference(ref)
    # a model file, or the reference manipulator, has the runs' rfes (a plant is the reference's
    # model with its own drives)
    source = results_io.metadata(runs[0]).get("model_source") or {}
    if nrfe is None and ref is not None and Path(ref).is_file():
        nrfe = source.get("nrfe")
    elif nrfe is None and ref is None:
        nrfe = source.get("reference")
    return model_reference(case_for(ref, nrfe), runs, backend, progress)


def table(metrics: list) -> str:
    """The metrics as a printed table: one block per run."""
    lines = []
    for m in metrics:
        lines.append(f"{m.name}")
        for c, (peak, mean) in m.constraints.items():
            lines.append(f"  constraint {c}: max |Φ| {peak:.4g}, RMS {mean:.4g} (its unit)")
        lines.append(f"  path error of E: max {m.path[0]:.4g} m, RMS {m.path[1]:.4g} m")
        if m.after is None:
            lines.append("  residual vibration: not measured (the end of the programmed motion is not known; "
                         "give --after T)")
        else:
            lines.append(f"  residual vibration after {m.after:g} s: peak-to-peak {m.vibration[0]:.4g} m, "
                         f"RMS {m.vibration[1]:.4g} m")
        for c, (peak, mean, energy) in m.effort.items():
            unit = m.units.get(c, "generalized")
            lines.append(f"  effort on {c}: peak |u| {peak:.4g} {unit}, RMS {mean:.4g} {unit}, "
                         f"∫|u q'| dt {energy:.4g} J")
    return "\n".join(lines)


def rows(metrics: list) -> list:
    """The metrics as CSV rows ``(run, quantity, of, value, unit)``, with a header row first."""
    out = [("run", "quantity", "of", "value", "unit")]
    for m in metrics:
        for c, (peak, mean) in m.constraints.items():
            out += [(m.name, "constraint_max", c, peak, "constraint"),
                    (m.name, "constraint_rms", c, mean, "constraint")]
        out += [(m.name, "path_error_max", "E", m.path[0], "m"), (m.name, "path_error_rms", "E", m.path[1], "m")]
        if m.after is not None:
            out += [(m.name, "vibration_after", "E", m.after, "s"),
                    (m.name, "vibration_peak_to_peak", "E", m.vibration[0], "m"),
                    (m.name, "vibration_rms", "E", m.vibration[1], "m")]
        for c, (peak, mean, energy) in m.effort.items():
            unit = m.units.get(c, "generalized")
            out += [(m.name, "effort_peak", c, peak, unit), (m.name, "effort_rms", c, mean, unit),
                    (m.name, "effort_energy_abs_power", c, energy, "J")]
    return out


def write_csv(metrics: list, path) -> Path:
    """Write :func:`rows` to ``path`` (CSV, UTF-8), atomically."""
    import csv
    import io


    buffer = io.StringIO()
    writer = csv.writer(buffer, lineterminator="\n")
    for row in rows(metrics):
        writer.writerow([f"{v:.12g}" if isinstance(v, float) else v for v in row])
    return atomic_write_bytes(Path(path), buffer.getvalue().encode("utf-8"))


def write_markdown(metrics: list, path) -> Path:
    """Write :func:`rows` to ``path`` as a Markdown table (UTF-8), atomically."""
    header, *body = rows(metrics)
    cells = [[f"{v:.6g}" if isinstance(v, float) else str(v).replace("|", "\\|") for v in row] for row in body]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    lines += ["| " + " | ".join(row) + " |" for row in cells]
    return atomic_write_bytes(Path(path), ("\n".join(lines) + "\n").encode("utf-8"))
