"""Velocity and acceleration of a named point at a state, from its positions alone, and the
curvature of its path: a check of second-order constraints that shares nothing with their
derivation (no Jacobian, no ``γ``, no generated velocity or acceleration).

Along the curve ``q(h) = q + h q̇ + h²/2 q̈`` the point's position ``p(h)`` has ``p'(0) = J q̇ = v``
and ``p''(0) = J q̈ + q̇ᵀ(∂²p/∂q²)q̇ = a``; both are taken by central differences of order 4 (the
errors: ``O(h⁴)`` from truncation, which grows with ``|q̈|`` (stiff sdes ring at 1e4 rad/s²), and
``ε/h²`` from rounding). The step keeps ``h|q̇|`` and ``h²|q̈|`` below 1e-3 and 1e-4 (rad or m).
"""

from __future__ import annotations

import numpy as np

# Central differences of order 4 over the offsets -2h, -h, 0, h, 2h.
_OFFSETS = np.array([-2.0, -1.0, 0.0, 1.0, 2.0])
_FIRST = np.array([1.0, -8.0, 0.0, 8.0, -1.0]) / 12.0
_SECOND = np.array([-1.0, 16.0, -30.0, 16.0, -1.0]) / 12.0


def point_motion(model, point: str, q, qd, qdd):
    """Position, velocity and acceleration (3,) each, in {0} (m, m/s, m/s²), of point ``point``
    of the loaded ``model`` at the state ``q, qd`` (n,) with the accelerations ``qdd`` (n,)."""
    k = model.points.index(point)
    h = 1e-3 / max(1.0, float(np.max(np.abs(qd))), float(np.sqrt(np.max(np.abs(qdd)) / 100)))
    p = np.array([model.point_positions(q + s * h * qd + (s * h) ** 2 / 2 * qdd)[k] for s in _OFFSETS])
    return p[2], _FIRST @ p / h, _SECOND @ p / h**2


def curvature(v, a) -> np.ndarray:
    """Signed curvature (1/m) of a path in the plane x0-y0 from the velocity ``v`` and
    acceleration ``a`` (k, 3) of its point: ``(vx ay - vy ax) / |v|³``, positive turning left."""
    v, a = np.atleast_2d(v), np.atleast_2d(a)
    return (v[:, 0] * a[:, 1] - v[:, 1] * a[:, 0]) / np.hypot(v[:, 0], v[:, 1]) ** 3
