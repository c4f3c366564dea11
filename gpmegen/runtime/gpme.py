"""Assembly and solution of the Generalized Programmed Motion Equations (paper eqs. 12–16).

With the coordinates split into independent ``q_ic`` and dependent ``q_dc``, the constraint
Jacobian ``D = [D_ic D_dc]`` gives ``∂q̇_dc/∂q̇_ic = -D_dc⁻¹ D_ic`` (eqs. 14–15 in general) and
``B = [I; -D_dc⁻¹ D_ic]`` arranged by coordinate index. The GPME are

    Bᵀ (M q̈ - f) = 0                         (n - m rows, one per independent coordinate)
    D q̈ = -γ - 2αΦ̇ - β²Φ   (position)        (m rows, eq. 16 with Baumgarte terms)
    D q̈ = -γ - αΨ           (first order)
    D q̈ = -γ                (second order)

solved together for ``q̈`` (n,).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ..errors import SimulationError

# Below this fraction of the largest pivot (|R_00| of a QR factorization with column pivoting of
# Dᵀ: D's scale), a row of D counts as a combination of the rows before it, so D's rank is the
# number of pivots above it. Relative to D's scale, well above the round-off a row that is a
# combination of others keeps (a few machine epsilons of D's largest entry), far below a pivot of
# rows independent but nearly dependent that a run could use. The C solve's threshold
# (csrc/solver_internal.h GPMEGEN_RANK_TOLERANCE) is the same.
RANK_TOLERANCE = 1e-10


def constraint_rhs(phi, phi_rate, gamma, alpha, beta, orders):
    """Right side of the constraint rows (m,)."""
    orders = np.asarray(orders)
    position = -gamma - 2.0 * alpha * phi_rate - beta**2 * phi
    first = -gamma - alpha * phi
    return np.select([orders == 0, orders == 1], [position, first], -gamma)


def tangent_basis(D, dependent, independent):
    """``B`` (n, n - m): columns span the velocities allowed by the constraints. With fewer
    ``dependent`` coordinates than rows (redundant rows), from D's :func:`independent_rows`."""
    n = D.shape[1]
    if len(dependent) < D.shape[0]:
        D = D[independent_rows(D)]
    B = np.zeros((n, len(independent)))
    B[independent, np.arange(len(independent))] = 1.0
    try:
        B[dependent, :] = -np.linalg.solve(D[:, dependent], D[:, independent])
    except np.linalg.LinAlgError:
        raise SimulationError(
            "the dependent block D_dc of the constraint Jacobian is singular: choose other "
            "dependent coordinates (model 'dependent') or start from a regular configuration"
        ) from None
    return B


def independent_rows(D) -> np.ndarray:
    """Indices (sorted) of rows of ``D`` (m, n) that are independent and span its rows: the
    pivots of a QR factorization with column pivoting of ``Dᵀ`` above :data:`RANK_TOLERANCE`
    times the first; all m rows when D has full rank."""
    D = np.asarray(D, dtype=float)
    if D.shape[0] == 0:
        return np.arange(0)
    _, R, pivots = scipy.linalg.qr(D.T, mode="economic", pivoting=True)
    diagonal = np.abs(np.diag(R))
    rank = int(np.sum(diagonal > RANK_TOLERANCE * max(diagonal[0], np.finfo(float).tiny)))
    return np.sort(pivots[:rank])


def choose_dependent(D, count=None) -> np.ndarray:
    """Indices (sorted) of the dependent coordinates: the first ``count`` (default ``m``) pivots
    of a QR factorization with column pivoting of ``D`` (m, n); with redundant rows, ``count`` is
    D's rank."""
    D = np.asarray(D, dtype=float)
    m = D.shape[0] if count is None else count
    if m == 0:
        return np.arange(0)
    _, _, pivots = scipy.linalg.qr(D, mode="economic", pivoting=True)
    return np.sort(pivots[:m])


def rank(D) -> int:
    """The numerical rank of ``D`` (m, n): the number of :func:`independent_rows`."""
    return len(independent_rows(D))


def accelerations(M, f, phi, phi_rate, D, gamma, alpha, beta, orders, dependent, independent, redundant=False):
    """q̈ (n,) from the GPME; without constraints, ``M⁻¹ f``. ``redundant``: the rows of ``D``
    may be redundant (a loop closed more often than its motion needs): the rows kept are the
    :func:`independent_rows` at this state, with dependent coordinates chosen on them here (the
    ``dependent``, ``independent`` given are not used); the accelerations are unique when the rows
    left out are consistent with those kept."""
    if D.shape[0] == 0:
        return np.linalg.solve(M, f)
    if redundant:
        rows = independent_rows(D)
        phi, phi_rate, D, gamma = phi[rows], phi_rate[rows], D[rows], gamma[rows]
        alpha, beta, orders = np.asarray(alpha)[rows], np.asarray(beta)[rows], np.asarray(orders)[rows]
        dependent = choose_dependent(D)
        independent = np.setdiff1d(np.arange(D.shape[1]), dependent)
    B = tangent_basis(D, dependent, independent)
    A = np.vstack([B.T @ M, D])
    b = np.concatenate([B.T @ f, constraint_rhs(phi, phi_rate, gamma, alpha, beta, orders)])
    return np.linalg.solve(A, b)


def multipliers(M, f, qdd, D, redundant=False):
    """λ (m,) of the ideal realization ``M q̈ - f = Dᵀλ``: the least-squares solution of
    ``Dᵀλ = M q̈ - f`` (exact when ``q̈`` solves the GPME, whose residual lies in the range of
    ``Dᵀ``). Units: a generalized force per unit of the constraint (J/[Φ] for a position
    constraint, W/[Ψ] for a first-order one). ``redundant``: D may have redundant rows, so λ is
    not unique: the minimum-norm solution, singular values of D at or below
    :data:`RANK_TOLERANCE` times the largest counted as zero. A batch (``M`` (N, n, n), ``f``,
    ``qdd`` (N, n), ``D`` (N, m, n)) gives (N, m): the same solutions by the pseudo-inverse of
    each ``Dᵀ`` with the same cut-off (to round-off)."""
    if D.shape[-2] == 0:
        return np.zeros(D.shape[:-1])
    if D.ndim == 3:
        rcond = RANK_TOLERANCE if redundant else np.finfo(float).eps * max(D.shape[1:])  # lstsq's rcond=None
        residual = np.matmul(M, qdd[..., None])[..., 0] - f
        return np.matmul(np.linalg.pinv(np.swapaxes(D, 1, 2), rcond=rcond), residual[..., None])[..., 0]
    return np.linalg.lstsq(D.T, M @ qdd - f, rcond=RANK_TOLERANCE if redundant else None)[0]


def selection(n, actuators):
    """``S`` (n, k): column j is the unit vector of coordinate ``actuators[j]``, so ``S u`` puts
    the input ``u_j`` on that coordinate."""
    S = np.zeros((n, len(actuators)))
    S[list(actuators), np.arange(len(actuators))] = 1.0
    return S


def actuated(M, f, phi, phi_rate, D, gamma, alpha, beta, orders, actuators):
    """(q̈ (n,), u (m,)) of the actuated realization (servo-constraints): ``M q̈ = f + S u`` with
    the programmed constraints held by the inputs ``u`` on the coordinates ``actuators`` alone,

        [M  -S] [q̈]   [f                       ]
        [D   0] [u ] = [-γ - Baumgarte terms    ]

    np.linalg.LinAlgError when the system is singular (``D M⁻¹ S`` singular: the inputs cannot
    move the constraints)."""
    n, m = M.shape[0], D.shape[0]
    S = selection(n, actuators)
    A = np.block([[M, -S], [D, np.zeros((m, m))]])
    b = np.concatenate([f, constraint_rhs(phi, phi_rate, gamma, alpha, beta, orders)])
    x = np.linalg.solve(A, b)
    return x[:n], x[n:]


def input_coupling(M, D, actuators):
    """``D M⁻¹ S`` (m, m): how the inputs on ``actuators`` accelerate the constraints; the
    actuated realization exists where it is regular."""
    return D @ np.linalg.solve(M, selection(M.shape[0], actuators))
