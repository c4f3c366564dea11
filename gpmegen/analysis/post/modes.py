"""Natural modes about an equilibrium: linearized free vibration ``K φ = ω² M φ`` on chosen
coordinates (:func:`natural_frequencies`, :func:`locked_modes`), with the programmed constraints
holding (:func:`constrained_modes`), and the kind of each mode from its shape (vertical bending,
horizontal bending, torsion: :mod:`gpmegen.analysis.post.mode_kinds`). Their CSV and figures:
:mod:`gpmegen.analysis.figures.modes_output`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
import scipy.linalg

from ...errors import ModelError
from ...runtime import statics
from ...runtime.gpme import tangent_basis
from ...runtime.internal import STEP
from .mode_kinds import KINDS, classify


@dataclass
class Modes:
    """Natural modes about an equilibrium, lowest first.

    ``frequencies`` (k,) Hz; ``shapes`` (n_dof, k), zero on the held coordinates, each column
    normalized to unit modal mass (``φᵀ M φ = 1``); ``free`` the indices of the coordinates
    that move; ``coordinates`` the model's coordinate names; ``kinds`` from
    :func:`gpmegen.analysis.post.mode_kinds.classify`."""

    frequencies: np.ndarray
    shapes: np.ndarray
    free: np.ndarray
    coordinates: tuple
    kinds: list = field(default_factory=list)

    def first(self, kind: str) -> float:
        """Lowest frequency (Hz) of a mode of ``kind`` ('vertical', 'horizontal', 'torsion'); NaN
        when no mode is of that kind (a planar link has no horizontal bending nor torsion)."""
        for f, k in zip(self.frequencies, self.kinds):
            if k == kind:
                return float(f)
        return math.nan

    def format(self, count: int | None = 10) -> str:
        """The lowest ``count`` modes (all when None) as text: frequency, kind and the
        coordinate with the largest amplitude."""
        lines = [f"{'mode':>4} {'frequency (Hz)':>15} {'kind':>11}  largest coordinate"]
        for k in range(len(self.frequencies) if count is None else min(count, len(self.frequencies))):
            j = int(np.argmax(np.abs(self.shapes[:, k])))
            lines.append(f"{k + 1:4d} {self.frequencies[k]:15.6g} {self.kinds[k]:>11}  {self.coordinates[j]}")
        return "\n".join(lines)


def natural_frequencies(model, q_eq, free=None) -> Modes:
    """Natural frequencies and mode shapes of ``model`` linearized about the equilibrium
    ``q_eq`` (n,): ``K = ∂(g + C q)/∂q`` and ``M`` at ``q_eq`` restricted to ``free``
    (indices; default: the coordinates with a spring, i.e. every joint without one held), and
    ``K φ = ω² M φ`` solved by ``scipy.linalg.eigh``. K is symmetrized (the gravity part is a
    Hessian, symmetric up to round-off). Negative ω² (an unstable equilibrium) give negative
    frequencies ``-sqrt(-ω²)/(2π)``."""
    q_eq = np.asarray(q_eq, dtype=float)
    if free is None:
        free = statics.spring_coordinates(model, q_eq)
    free = np.asarray(free, dtype=int)
    if free.size == 0:
        raise ModelError("natural_frequencies: no free coordinate; pass the indices to vibrate as 'free'")
    sub = np.ix_(free, free)
    K = model.stiffness_jacobian(q_eq)[sub]
    M = model.mass_matrix(q_eq)[sub]
    K = 0.5 * (K + K.T)
    M = 0.5 * (M + M.T)
    omega2, vectors = scipy.linalg.eigh(K, M)
    frequencies = np.sign(omega2) * np.sqrt(np.abs(omega2)) / (2.0 * math.pi)
    shapes = np.zeros((model.n_dof, free.size))
    shapes[free] = vectors
    modes = Modes(frequencies, shapes, free, tuple(model.coordinates))
    modes.kinds = classify(model, q_eq, shapes)
    return modes


def locked_modes(model, q_start=None, free=None):
    """Natural modes of ``model`` about its equilibrium with the joints locked: the equilibrium
    by :func:`gpmegen.runtime.statics.locked` from ``q_start`` (default all zero), then
    :func:`natural_frequencies`. Returns ``(q_eq, Modes)``."""
    q_start = np.zeros(model.n_dof) if q_start is None else np.asarray(q_start, dtype=float)
    q_eq = statics.locked(model, q_start, free=free)
    return q_eq, natural_frequencies(model, q_eq, free=free)


def constrained_modes(model, q_eq, hold=None, step=1e-7) -> Modes:
    """Natural modes with the programmed constraints holding, about the constrained equilibrium
    ``q_eq``, projected onto the independent coordinates: with ``B = [I; -D_dc⁻¹ D_ic]``,
    ``K_r = Bᵀ (K - Σ λ_k ∂²Φ_k/∂q²) B`` and ``M_r = Bᵀ M B``. ``λ`` solves ``Dᵀλ = g + C q``;
    ``Σ λ_k ∂²Φ_k/∂q² = ∂(Dᵀλ)/∂q`` is taken by central differences of the emitted ``D``
    (relative step ``step``). ``hold``: independent coordinates kept fixed (default: those
    without a spring, e.g. the column's neutral rotation). Shapes are full-coordinate
    vectors ``B v`` normalized to unit modal mass."""
    statics.refuse_second_order(model, "modes with the constraints holding")
    q_eq = np.asarray(q_eq, dtype=float)
    n = model.n_dof
    zero = np.zeros(n)
    _, _, D, _ = model.constraint_terms(0.0, q_eq, zero)
    lam, *_ = np.linalg.lstsq(D.T, model.static_residual(q_eq), rcond=None)
    curvature = np.zeros((n, n))
    for j in range(n):
        h = step * max(1.0, abs(q_eq[j]))
        up, down = q_eq.copy(), q_eq.copy()
        up[j] += h
        down[j] -= h
        curvature[:, j] = (model.constraint_terms(0.0, up, zero)[2].T @ lam
                           - model.constraint_terms(0.0, down, zero)[2].T @ lam) / (2 * h)
    K = model.stiffness_jacobian(q_eq) - 0.5 * (curvature + curvature.T)
    M = model.mass_matrix(q_eq)
    B = tangent_basis(D, model.dependent, model.independent)
    if hold is None:
        springs = set(statics.spring_coordinates(model, q_eq).tolist())
        hold = [k for k in model.independent if k not in springs]
    keep = [c for c, k in enumerate(model.independent) if k not in set(hold)]
    B = B[:, keep]
    Kr, Mr = B.T @ K @ B, B.T @ M @ B
    omega2, vectors = scipy.linalg.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
    frequencies = np.sign(omega2) * np.sqrt(np.abs(omega2)) / (2.0 * math.pi)
    shapes = B @ vectors
    modes = Modes(frequencies, shapes, np.asarray(model.independent)[keep], tuple(model.coordinates))
    modes.kinds = classify(model, q_eq, shapes)
    return modes


def start_modes(model, q, lock: str) -> Modes | None:
    """The modes a model has about its start ``q``: with the joints locked (``lock`` "joints",
    :func:`locked_modes`) or with the programmed constraints holding ("constraints",
    :func:`constrained_modes`, ``q`` the constrained equilibrium). None when no coordinate that
    carries a spring (a flexible link's sde, a sprung joint) is free to move: nothing vibrates."""
    if lock == "joints":
        if statics.spring_coordinates(model, q).size == 0:
            return None
        return locked_modes(model, q)[1]
    modes = constrained_modes(model, q)
    return modes if len(modes.frequencies) else None


def highest_frequency(model, t, q, qd=None) -> float:
    """The highest natural frequency ω (rad/s) of the motion linearized at ``(t, q, qd)`` (not
    necessarily an equilibrium; ``qd`` default rest): ``K φ = ω² M φ`` with ``K`` the tangent
    stiffness (springs and gravity) and ``M`` on the velocities the constraints allow (the null
    space of their ``D`` at that state, by SVD: a row that vanishes there, as a second-order
    constraint's does at rest, constrains nothing and leaves no partition to choose). The
    constraints' curvature is left out: it shifts the low modes, not the sdes' stiff ones that
    bound an explicit step."""
    omega2 = _squared_frequencies(model, t, q, qd)
    return math.sqrt(max(float(omega2[-1]), 0.0)) if len(omega2) else 0.0


#: Squared frequencies below this fraction of the highest one are taken as no vibration (the
#: round-off of a free or rigid motion's zero).
VIBRATING = 1e-12


def lowest_frequency(model, t, q, qd=None) -> float:
    """The lowest natural frequency ω (rad/s) at ``(t, q, qd)`` of :func:`highest_frequency`'s
    problem among those that vibrate (ω² above :data:`VIBRATING` of the highest; the motions of
    no stiffness are left out); 0.0 when none does."""
    omega2 = _squared_frequencies(model, t, q, qd)
    vibrating = omega2[omega2 > VIBRATING * omega2[-1]] if len(omega2) and omega2[-1] > 0 else []
    return math.sqrt(float(vibrating[0])) if len(vibrating) else 0.0


def _squared_frequencies(model, t, q, qd):
    """ω² (rad²/s², increasing) of :func:`highest_frequency`'s problem; empty when the
    constraints hold every coordinate."""
    q = np.asarray(q, dtype=float)
    qd = np.zeros(model.n_dof) if qd is None else np.asarray(qd, dtype=float)
    D = model.constraint_terms(t, q, qd)[2]
    B = scipy.linalg.null_space(D) if len(D) else np.eye(model.n_dof)
    if B.shape[1] == 0:  # the constraints hold every coordinate: nothing vibrates
        return np.empty(0)
    K, M = B.T @ model.stiffness_jacobian(q) @ B, B.T @ model.mass_matrix(q) @ B
    return scipy.linalg.eigh(0.5 * (K + K.T), 0.5 * (M + M.T), eigvals_only=True)


def motion_eigenvalues(model, t, q, qd=None) -> np.ndarray:
    """The eigenvalues (1/s) of the first-order system ``M δq̈ + C δq̇ + K δq = 0`` linearized at
    ``(t, q, qd)`` (``qd`` default rest) on the velocities the constraints allow (the null space
    ``B`` of their ``D`` there, as in :func:`highest_frequency`), dampers included: ``K`` the tangent
    stiffness, ``C = -∂f/∂q̇`` (joint and sde dampers, and the velocity terms away from rest) by
    central differences of the model's forces. They bound RK4's step: see
    :func:`gpmegen.runtime.stability.stable_step`."""
    q = np.asarray(q, dtype=float)
    qd = np.zeros(model.n_dof) if qd is None else np.asarray(qd, dtype=float)
    D = model.constraint_terms(t, q, qd)[2]
    B = scipy.linalg.null_space(D) if len(D) else np.eye(model.n_dof)
    k = B.shape[1]
    if k == 0:  # the constraints hold every coordinate: nothing moves
        return np.zeros(0, dtype=complex)
    C = np.empty((model.n_dof, model.n_dof))
    for j in range(model.n_dof):
        h = STEP * max(1.0, abs(qd[j]))
        up, down = qd.copy(), qd.copy()
        up[j] += h
        down[j] -= h
        C[:, j] = -(model.forces(t, q, up) - model.forces(t, q, down)) / (2 * h)
    M, K, C = (B.T @ X @ B for X in (model.mass_matrix(q), model.stiffness_jacobian(q), C))
    A = np.block([[np.zeros((k, k)), np.eye(k)], [-np.linalg.solve(M, K), -np.linalg.solve(M, C)]])
    return np.linalg.eigvals(A)


__all__ = ["Modes", "natural_frequencies", "highest_frequency", "motion_eigenvalues", "lowest_frequency",
           "locked_modes", "constrained_modes", "classify", "KINDS"]
