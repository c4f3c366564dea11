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

from ..errors import SimulationError


def constraint_rhs(phi, phi_rate, gamma, alpha, beta, orders):
    """Right side of the constraint rows (m,)."""
    orders = np.asarray(orders)
    position = -gamma - 2.0 * alpha * phi_rate - beta**2 * phi
    first = -gamma - alpha * phi
    return np.select([orders == 0, orders == 1], [position, first], -gamma)


def tangent_basis(D, dependent, independent):
    """``B`` (n, n - m): columns span the velocities allowed by the constraints."""
    n = D.shape[1]
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


def accelerations(M, f, phi, phi_rate, D, gamma, alpha, beta, orders, dependent, independent):
    """q̈ (n,) from the GPME; without constraints, ``M⁻¹ f``."""
    if D.shape[0] == 0:
        return np.linalg.solve(M, f)
    B = tangent_basis(D, dependent, independent)
    A = np.vstack([B.T @ M, D])
    b = np.concatenate([B.T @ f, constraint_rhs(phi, phi_rate, gamma, alpha, beta, orders)])
    return np.linalg.solve(A, b)
