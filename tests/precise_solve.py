"""An extended-precision GPME solve, and states of the reference arm at which the model's
partition makes the reduced system ill-conditioned (for tests/test_c_solve_accuracy.py and
benchmarks/solve_accuracy.py).

The reference solves the GPME (eq. 16) from the very double-precision terms a backend solved
(M, f, D and the right side c of the constraint rows) with 50 significant digits, through the
stacked system [[M, Dᵀ], [D, 0]] [q̈; -λ] = [f; c]. Its q̈ is the one every basis of the allowed
motions gives, so the difference from it is the error of the solve alone.
"""

from __future__ import annotations

import mpmath
import numpy as np
import scipy.linalg

from gpmegen.runtime import gpme

EPS = np.finfo(float).eps


def extended_accelerations(M, f, D, c, dps=50):
    """q̈ (n,) of the GPME with terms M (n, n), f (n,), D (m, n), c (m,), solved in mpmath with
    ``dps`` digits and rounded to double."""
    n, m = len(f), len(c)
    K = np.zeros((n + m, n + m))
    K[:n, :n], K[n:, :n], K[:n, n:] = M, D, D.T
    with mpmath.workdps(dps):
        x = mpmath.lu_solve(mpmath.matrix(K.tolist()), mpmath.matrix(np.concatenate([f, c]).tolist()))
        return np.array([float(x[i]) for i in range(n)])


def problem_condition(M, D):
    """cond₂(ZᵀMZ) with Z an orthonormal basis of the null space of D: how much the GPME's q̈
    amplifies relative perturbations of M, whatever basis a solver uses."""
    Z = scipy.linalg.null_space(D)
    return float(np.linalg.cond(Z.T @ M @ Z))


def partition_condition(model, M, D):
    """cond₂(BᵀMB) with B = [I; -D_dc⁻¹ D_ic] of the model's partition."""
    B = gpme.tangent_basis(D, model.dependent, model.independent)
    return float(np.linalg.cond(B.T @ M @ B))


def random_states(model, count, seed):
    """``count`` states (t, q, q̇) of the reference arm with elastic angles up to 1 rad."""
    rng = np.random.default_rng(seed)
    joints = [model.index(name) for name in ("theta1", "psi2", "x3")]
    for _ in range(count):
        q = rng.uniform(-1.0, 1.0, model.n_dof)
        q[joints] = rng.uniform(0.0, 2 * np.pi), np.pi / 4 + rng.uniform(-0.2, 0.2), rng.uniform(-0.1, 0.1)
        yield float(rng.uniform(0.0, 10.0)), q, rng.standard_normal(model.n_dof)


def ill_conditioned_states(model, count, seed, samples):
    """The ``count`` states with the largest cond(BᵀMB) among ``samples`` random ones, as
    (cond(BᵀMB), t, q, q̇), the worst last."""
    found = []
    for t, q, qd in random_states(model, samples, seed):
        M, _, _, _, D, _ = model.gpme_terms(t, q, qd)
        found.append((partition_condition(model, M, D), t, q, qd))
    found.sort(key=lambda row: row[0])
    return found[-count:]


def solve_errors(model, t, q, qd):
    """Relative errors (max norm) of q̈ against :func:`extended_accelerations`, all from the terms
    the C backend ``model`` evaluates at (t, q, q̇): ``(error of the C solve, error of the NumPy
    stacked solve, cond(ZᵀMZ))``."""
    qdd_c, M, f = model.motion(t, q, qd)
    _, _, phi, phi_rate, D, gamma = model.gpme_terms(t, q, qd)
    args = (phi, phi_rate, gamma, model.alpha, model.beta, model.constraint_orders)
    qdd_numpy = gpme.accelerations(M, f, phi, phi_rate, D, gamma, *args[3:], model.dependent, model.independent)
    exact = extended_accelerations(M, f, D, gpme.constraint_rhs(*args))
    scale = np.max(np.abs(exact))
    return (float(np.max(np.abs(qdd_c - exact)) / scale), float(np.max(np.abs(qdd_numpy - exact)) / scale),
            problem_condition(M, D))
