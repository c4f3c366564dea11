"""The same motion at several discretizations, and its limit: the outputs that mean the same at
every ``n_rfe`` (:func:`outputs`) on one time grid, each extrapolated
(:func:`gpmegen.analysis.post.richardson.richardson`), written as one file (:func:`save`).

Comparable outputs (SI units, in the base frame {0}; N samples): ``joints`` (N, j) and
``joint_velocities`` (N, j), the coordinates of the model's joints (not the elastic ones of its
flexible links, whose number and meaning change with ``n_rfe``); ``points`` (N, n_points, 3) and
``point_velocities`` the named points; ``deflections`` (N, n_points, 3) each point's displacement
by the elastic coordinates, ``P(q) - P(q with the elastic coordinates 0)``; ``drive_forces`` and
``constraint_forces`` (N, j), the drives' and the programmed constraints' generalized forces on
the joints.
"""

from __future__ import annotations

import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ... import npz
from ...errors import ExtrapolationError
from ...fileio import atomic_write
from ...model.chain import FlexibleLink
from ..post import richardson
from ..post.coordinates import elastic_coordinates, joint_names, point_names
from .levels import Level, check_alike

FORMAT = "gpmegen-extrapolation-1"
OUTPUTS = ("joints", "joint_velocities", "points", "point_velocities", "deflections", "drive_forces",
           "constraint_forces")


#: Words for groups of outputs (``gpmegen convergence --output``).
GROUPS = {"points": ("points",), "joints": ("joints",), "deflection": ("deflections",),
          "velocities": ("joint_velocities", "point_velocities"), "forces": ("drive_forces", "constraint_forces")}


def _refusal(name, named=()) -> ExtrapolationError:
    """The one-line refusal of an output ``name`` that is not comparable across discretizations."""
    also = f", or a joint or point of the model ({', '.join(named)})" if named else ""
    return ExtrapolationError(f"output {name!r} is not comparable across discretizations (the elastic coordinates, "
                              f"and so q, change in number and meaning with n_rfe); ask for outputs that mean the "
                              f"same at every n_rfe: {', '.join(OUTPUTS)}{also}")


def check_requested(requested) -> list[str]:
    """``requested`` output names (None: all of :data:`OUTPUTS`), refused with the reason when
    one is not comparable across discretizations (an elastic coordinate, ``q``...)."""
    if requested is None:
        return list(OUTPUTS)
    refused = [name for name in requested if name not in OUTPUTS]
    if refused:
        raise _refusal(refused[0])
    return list(requested)


@dataclass(frozen=True)
class Selection:
    """One reported output: ``label``, the output of :data:`OUTPUTS` it is taken from and the
    ``index`` of a joint or point in it (None: all of it)."""

    label: str
    output: str
    index: int | None = None

    def of(self, values):
        """The selected part of ``values`` (k, N, ...) of :attr:`output`."""
        return values if self.index is None else values[:, :, self.index]


def select(requested, joints, points) -> list[Selection]:
    """The outputs ``requested`` by name: one of :data:`OUTPUTS`, a group of :data:`GROUPS`, a
    joint of ``joints`` (its coordinate) or a point of ``points`` (its position); anything else,
    an elastic coordinate say, is refused in one line."""
    chosen = []
    for name in requested:
        if name in GROUPS or name in OUTPUTS:
            chosen += [Selection(output, output) for output in GROUPS.get(name, (name,))]
        elif name in points:
            chosen.append(Selection(name, "points", list(points).index(name)))
        elif name in joints:
            chosen.append(Selection(name, "joints", list(joints).index(name)))
        else:
            raise _refusal(name, [*joints, *points])
    return list(dict.fromkeys(chosen))


def _velocities(loaded, q, qd):
    """Point velocities (N, n_points, 3) by central differences of the positions along qd,
    with a step that moves the coordinates by 1e-6 (error ~1e-12 relative)."""
    h = (1e-6 / np.maximum(np.max(np.abs(qd), axis=1), 1e-300))[:, None]
    return (loaded.point_positions(q + h * qd) - loaded.point_positions(q - h * qd)) / (2 * h[:, :, None])


def outputs(level: Level, names=OUTPUTS) -> dict:
    """The comparable outputs ``names`` of one level (see the module's doc; default all of
    :data:`OUTPUTS`), keyed by name; the others are not evaluated."""
    loaded, res = level.loaded, level.results
    joints = [loaded.index(name) for name in joint_names(level.model)]
    q, qd = res["q"], res["qd"]
    out = {"joints": lambda: q[:, joints], "joint_velocities": lambda: qd[:, joints],
           "drive_forces": lambda: res["drive_forces"][:, joints],
           "constraint_forces": lambda: res["constraint_forces"][:, joints],
           "point_velocities": lambda: _velocities(loaded, q, qd)}
    if "points" in names or "deflections" in names:
        points = loaded.point_positions(q)
        out["points"] = lambda: points
        if "deflections" in names:
            elastic = np.zeros(loaded.n_dof, dtype=bool)
            elastic[elastic_coordinates(level.model, loaded)] = True
            out["deflections"] = lambda: points - loaded.point_positions(np.where(elastic, 0.0, q))
    return {name: out[name]() for name in names}


def check_flexible(model) -> None:
    """Refuse a symbolic model without a flexible link: nothing in it changes with n_rfe."""
    if not any(isinstance(element, FlexibleLink) for element in model.chain):
        raise ExtrapolationError(f"model {model.name}: no flexible link, so nothing changes with n_rfe; "
                                 f"extrapolate a model with a flexible link")


def check_comparable(levels: list[Level]) -> None:
    """Refuse levels that are not one model at several discretizations: different joints,
    points or parameter values (but for those the start sets at each level, ``set_at_start``:
    the reference case's circle constants come from each level's own statics), no flexible
    link, unfinished runs."""
    check_flexible(levels[0].model)
    for level in levels:
        status = str(level.results["status"])
        if status != "complete":
            raise ExtrapolationError(f"the run at n_rfe = {level.nrfe} did not finish ({status}): the levels "
                                     f"must cover the same motion; fix that run (a smaller --dt?) first")
    check_alike({lv.nrfe: (joint_names(lv.model), list(lv.loaded.points),
                            {k: v for k, v in lv.loaded.params.items() if k not in lv.set_at_start})
                  for lv in levels})


def common_grid(levels: list[Level]) -> tuple[np.ndarray, str]:
    """The time grid of the extrapolation and how the levels are brought onto it: their own
    when they saved the same instants, else the finest level's within the span they all cover,
    the others interpolated linearly (an error of order (Δt_saved)², not removed)."""
    grids = [np.asarray(level.results["t"], dtype=float) for level in levels]
    if all(g.shape == grids[0].shape and np.array_equal(g, grids[0]) for g in grids):
        return grids[0], "common"
    start, end = max(g[0] for g in grids), min(g[-1] for g in grids)
    finest = grids[-1]
    return finest[(finest >= start) & (finest <= end)], (
        f"interpolated linearly onto the samples of n_rfe = {levels[-1].nrfe}")


def on_grid(t_level, values, t):
    """``values`` (N_level, ...) sampled at ``t_level``, linearly interpolated at ``t``."""
    flat = values.reshape(len(t_level), -1)
    return np.stack([np.interp(t, t_level, flat[:, j]) for j in range(flat.shape[1])], axis=-1).reshape(
        (len(t),) + values.shape[1:])


def extrapolate(levels: list[Level], requested=None, order=richardson.ORDER, terms=1) -> dict:
    """Extrapolate ``levels`` (one model at ≥ 2 values of n_rfe, ≥ 3 with ``terms = 2``: see
    :func:`gpmegen.analysis.post.richardson.richardson`) for each ``requested`` output
    (default: all of :data:`OUTPUTS`). Returns the arrays of the file :func:`save` writes:
    ``t`` (N,), ``nrfe``, ``n_sde`` (k,) and for each output X: ``X`` (k, N, ...) its values,
    ``X_error`` (k, N, ...) the estimated discretization error of each level, ``X_limit``
    (N, ...), ``X_limit_error`` (N, ...) (NaN with two levels) and ``X_order`` (observed, NaN with
    two levels); ``grid`` says how the levels came onto ``t``."""
    levels = sorted(levels, key=lambda level: level.nrfe)
    try:
        n_sde = richardson.check_levels([level.nrfe - 1 for level in levels])
        richardson.check_terms(n_sde, terms)
    except richardson.LevelsError as exc:
        raise ExtrapolationError(f"n_rfe = {[level.nrfe for level in levels]}: {exc}, e.g. --nrfe 5 10 20") from None
    names = check_requested(requested)
    check_comparable(levels)
    t, grid = common_grid(levels)
    per_level = [outputs(level, names) for level in levels]
    data = {"t": t, "nrfe": np.array([level.nrfe for level in levels]), "n_sde": n_sde, "grid": np.array(grid),
            "joint_names": np.array(joint_names(levels[0].model)), "point_names": np.array(levels[0].loaded.points)}
    for name in names:
        values = np.stack([on_grid(np.asarray(level.results["t"], dtype=float), out[name], t)
                           for level, out in zip(levels, per_level)])
        estimate = richardson.richardson(n_sde, values, order, terms)
        data.update({name: values, f"{name}_error": estimate.errors, f"{name}_limit": estimate.limit,
                     f"{name}_limit_error": estimate.limit_error, f"{name}_order": np.array(estimate.order)})
    data["assumed_order"] = np.array(float(order))
    data["terms"] = np.array(int(terms))
    return data


def save(data: dict, path) -> Path:
    """Write an extrapolation (:func:`extrapolate`) to ``path`` (.npz) atomically, marked with
    :data:`FORMAT`; an existing file is replaced only by a complete one."""
    return atomic_write(path, lambda fh: np.savez_compressed(fh, format=np.array(FORMAT), **data))


def load(path) -> dict:
    """Read a file written by :func:`save`; ExtrapolationError if it is not one."""
    remake = "make it with 'gpmegen simulate MODEL --nrfe 5 10 20 --extrapolate'"
    try:
        data = npz.read_checked(Path(path), lambda key: True, ExtrapolationError, remake)
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise ExtrapolationError(f"{path}: cannot read it as an extrapolation ({exc}); {remake}") from None
    if str(data.get("format", "")) != FORMAT:
        raise ExtrapolationError(f"{path}: not a gpmegen extrapolation (no '{FORMAT}' marker)")
    return data


def report(data: dict, selections) -> list[str]:
    """One line per :class:`Selection` of an extrapolation ``data``: the largest estimated error
    of each level and of the limit, relative to the largest magnitude of the limit, and the
    observed order (of the selection alone)."""
    lines = []
    for chosen in selections:
        values = chosen.of(data[chosen.output])
        estimate = richardson.richardson(data["n_sde"], values, float(data["assumed_order"]),
                                         int(data.get("terms", 1)))
        scale = float(np.max(np.abs(estimate.limit), initial=0.0))
        if scale == 0.0:
            lines.append(f"{chosen.label}: zero at every level")
            continue
        levels = ", ".join(f"n_rfe {n}: {np.max(np.abs(e)) / scale:.2e}" for n, e in zip(data["nrfe"], estimate.errors))
        limit = (f"limit: {np.max(np.abs(estimate.limit_error)) / scale:.2e}"
                 if np.all(np.isfinite(estimate.limit_error)) else "limit: unknown with two levels")
        order = estimate.order
        value = f"max |limit| {scale:.6g}"
        if estimate.limit.size <= 3:  # a point or a joint at one instant: the limit itself
            value = f"limit {_numbers(estimate.limit)} ± {_numbers(np.abs(estimate.limit_error))}"
        lines.append(f"{chosen.label} ({value}): max error / max |limit|: {levels}; {limit}; "
                     f"observed order " + (f"{order:.2f}" if np.isfinite(order) else "-"))
    return lines


def _numbers(values) -> str:
    """One number, or several in parentheses."""
    text = ", ".join(f"{v:.10g}" for v in np.ravel(values))
    return text if np.size(values) == 1 else f"({text})"


def summary(data: dict) -> list[str]:
    """:func:`report` of every output that ``data`` holds."""
    return report(data, [Selection(name, name) for name in OUTPUTS if name in data])


__all__ = [
    "OUTPUTS", "GROUPS", "FORMAT", "Selection", "extrapolate", "outputs", "save", "load", "select", "report", "summary",
    "check_requested", "check_flexible", "common_grid", "joint_names", "point_names",
]
