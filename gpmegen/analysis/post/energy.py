"""The energy balance of a run: ``ΔT + ΔV_gravity + ΔV_springs = W_drive + W_constraints +
W_dampers``. Joint and sde springs, and the springs of force elements, are potential energy;
drives (with the force elements' dampers and actuators) and the constraint forces do work
(integrated with the motion), and the dampers' work ``W_dampers = -∫ q̇ᵀ C_d q̇ dt ≤ 0`` is a term
of the balance, not an error: the residual is what remains.

``C_d`` is the dampers' matrix, ``-∂(f - Q)/∂q̇`` by central differences about ``q̇ = 0``: the
velocity terms are quadratic in ``q̇`` and cancel exactly, so only the joints' and sdes' viscous
dampers remain (constants of the model). The drives' ``Q`` is left out: a feedback law's
velocity terms, and the force elements' dampers and actuators that ``Q`` holds
(:mod:`gpmegen.symbolic.forces`), do work that the integrators integrate with the state in
``W_drive``. ``W_dampers`` is integrated over the saved samples: on each interval ``q̇`` is the
cubic Hermite interpolant of the saved ``q̇`` and ``q̈``, and the power, a polynomial of degree 6
in time there, is integrated exactly by 4-point Gauss–Legendre. Its error is that of the
interpolant, ``O(Δt⁴)`` in the save interval: the residual stays at the integrator's level where
the saved samples resolve the damped motion.
"""

from __future__ import annotations

import numpy as np

# Relative step of the central differences in q̇ (exact up to round-off: f is quadratic in q̇).
STEP = 1e-3
_NODES, _WEIGHTS = np.polynomial.legendre.leggauss(4)
_NODES, _WEIGHTS = (_NODES + 1) / 2, _WEIGHTS / 2  # on [0, 1]


def damping_matrix(model, t, q) -> np.ndarray:
    """The dampers' matrix ``C_d`` (n, n), N·m·s/rad or N·s/m, of ``model`` at ``(t, q)``: the
    joints' and sdes' dampers, the drives' ``Q`` left out (its work is ``W_drive``)."""
    n = model.n_dof
    C = np.empty((n, n))

    def passive(qd):
        return model.forces(t, q, qd) - model.drive_forces(t, q, qd)

    for j in range(n):
        e = np.zeros(n)
        e[j] = STEP
        C[:, j] = -(passive(e) - passive(-e)) / (2 * STEP)
    return C


def damper_work(C, t, qd, qdd) -> np.ndarray:
    """The dampers' work (k,) J since ``t[0]`` at the samples ``t`` (k,) with velocities ``qd`` and
    accelerations ``qdd`` (k, n); NaN from the first sample that is not finite on."""
    t, qd, qdd = np.asarray(t, float), np.asarray(qd, float), np.asarray(qdd, float)
    out = np.zeros(len(t))
    if len(t) < 2 or not np.any(C):
        out[~np.all(np.isfinite(qd), axis=1)] = np.nan
        return out
    h = np.diff(t)[:, None]
    v0, v1, a0, a1 = qd[:-1], qd[1:], qdd[:-1], qdd[1:]
    step = np.zeros(len(t) - 1)
    for s, w in zip(_NODES, _WEIGHTS):
        # cubic Hermite basis on [0, 1]
        b00, b10 = 2 * s**3 - 3 * s**2 + 1, s**3 - 2 * s**2 + s
        b01, b11 = -2 * s**3 + 3 * s**2, s**3 - s**2
        v = b00 * v0 + b10 * h * a0 + b01 * v1 + b11 * h * a1
        step -= w * np.einsum("ki,ij,kj->k", v, C, v)
    out[1:] = np.cumsum(step * h[:, 0])
    bad = np.flatnonzero(~(np.isfinite(step)))
    if len(bad):
        out[bad[0] + 1:] = np.nan
    return out


def balance_residual(results) -> np.ndarray:
    """``ΔE - W`` (k,) J: the change of kinetic, gravity and spring energy since the start less the
    work of the drive, of the constraint forces and of the dampers; zero for an exact solution.
    Results saved before the dampers' work was (no ``work_dampers``) count it as zero."""
    total = results["kinetic_energy"] + results["gravity_energy"] + results["spring_energy"]
    dampers = results["work_dampers"] if "work_dampers" in results else 0.0
    return total - total[0] - results["work_drive"] - results["work_constraints"] - dampers
