"""A run's saved coordinates against the joint limits its model file gives (a URDF's ``<limit>``):
the limits do not act on the motion, so a run that goes past them is told so afterwards."""

from __future__ import annotations

import numpy as np


def _line(name, kind, bound, unit, values, t, beyond) -> str:
    """One warning line: the joint, its limit, the farthest saved value past it and when, and
    when it first went past."""
    past = np.flatnonzero(beyond)
    far = past[np.argmax(np.abs(values[past]))]
    first = f"; first past it at t = {t[past[0]]:.6g} s" if past[0] != far else ""
    return (f"warning: {name} went past its URDF {kind} limit {bound} {unit}: {values[far]:.6g} {unit} at t = "
            f"{t[far]:.6g} s{first} (URDF limits are data in gpmegen and do not act on the motion)")


def exceeded(limits: dict, coordinates, t, q, qd) -> list[str]:
    """A warning line for each coordinate whose saved position left its ``[lower, upper]`` or
    whose saved speed exceeded its velocity limit; ``limits``: coordinate -> (lower, upper,
    velocity, unit), None where there is none (a range with lower >= upper, or a velocity of 0
    or less, is taken as none, as URDF files write it when a joint has no limit)."""
    t, q, qd = np.asarray(t), np.asarray(q), np.asarray(qd)
    lines = []
    for k, name in enumerate(coordinates):
        if name not in limits or not len(t):
            continue
        lower, upper, velocity, unit = limits[name]
        if lower is not None and upper is not None and lower < upper:
            beyond = (q[:, k] < lower) | (q[:, k] > upper)
            if beyond.any():
                lines.append(_line(name, "position", f"[{lower:g}, {upper:g}]", unit, q[:, k], t, beyond))
        if velocity is not None and velocity > 0:
            beyond = np.abs(qd[:, k]) > velocity
            if beyond.any():
                lines.append(_line(name, "velocity", f"{velocity:g}", f"{unit}/s", qd[:, k], t, beyond))
    return lines
