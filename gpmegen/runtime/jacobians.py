"""The GPME acceleration Jacobians ``∂q̈/∂q`` and ``∂q̈/∂q̇`` from the generated derivatives of the
GPME's terms (:mod:`gpmegen.symbolic.derivatives`).

Differentiating ``M q̈ - f = G λ`` and ``D q̈ = c`` at fixed multipliers ``λ`` gives

    [M  -G] [dq̈]   [dF]        F = f - M a + G λ,   C = c - D a   at a = q̈,
    [D   0] [dλ] = [dC],

``G = Dᵀ`` for the ideal realization and ``G = S`` (the input selection, which does not depend
on the state) for the actuated one, whose ``dF`` is then that of ``λ = 0``. Without
constraints, ``M dq̈ = dF``. The C backend solves the same system in ``<model>_gpme_jacobian``.
"""

from __future__ import annotations

import numpy as np

from ..errors import SimulationError


def acceleration_jacobians(M, G, D, F_q, F_qd, C_q, C_qd):
    """``(∂q̈/∂q, ∂q̈/∂q̇)``, each (n, n), from ``M`` (n, n), ``G`` (n, m), ``D`` (m, n) and the
    residual Jacobians ``F_q``, ``F_qd`` (n, n), ``C_q``, ``C_qd`` (m, n)."""
    n, m = M.shape[0], D.shape[0]
    K = np.block([[M, -G], [D, np.zeros((m, m))]])
    rhs = np.block([[F_q, F_qd], [C_q, C_qd]])
    try:
        x = np.linalg.solve(K, rhs)[:n]
    except np.linalg.LinAlgError:
        raise SimulationError(
            "the linearized GPME are singular at this state: the constraints are not independent here (D lost "
            "rank) or M is singular on the motions they allow; choose a regular configuration") from None
    return x[:, :n], x[:, n:]
