"""Internal (zero) dynamics of the actuated realization, linearized.

With the programmed constraints held by inputs ``u`` on the coordinates ``S`` (see
:meth:`gpmegen.runtime.model.LoadedModel.actuation`), the motion left once ``Φ ≡ 0`` is imposed is
that of the unactuated coordinates along the constraints: the internal dynamics. Linearized about
a state ``(t, q, q̇)`` with its ``q̈`` frozen,

    M δq̈ + C δq̇ + K δq = S δu,   D δq = 0,
    K = ∂(M(q) q̈ - f)/∂q,   C = -∂f/∂q̇        (central differences of the model's M and f),

``δq = N η`` with ``N`` a basis of the null space of ``D``, and the rows of the unactuated
coordinates ``P`` (those ``S δu`` does not reach) give ``P M N η̈ + P C N η̇ + P K N η = 0``:
``2(n - m)`` eigenvalues (1/s). ``P M N`` is regular where ``D M⁻¹ S`` is. Eigenvalues with a
positive real part make the realization unstable forward in time (non-minimum phase).
"""

from __future__ import annotations

import numpy as np
import scipy.linalg

from ..status import Ending, Outcome

# A real part above this fraction of the largest eigenvalue counts as unstable (a neutral
# coordinate's double zero, split by the differences' round-off, stays below it).
UNSTABLE = 1e-6
# Relative step of the central differences.
STEP = 1e-6


def linearization(model, t, q, qd, qdd):
    """(M, C, K) (n, n) of ``M q̈ - f`` about ``(t, q, qd)`` with ``q̈ = qdd`` frozen."""
    n = model.n_dof
    M = model.mass_matrix(q)

    def residual(qq, vv):
        return model.mass_matrix(qq) @ qdd - model.forces(t, qq, vv)

    K, C = np.empty((n, n)), np.empty((n, n))
    for j in range(n):
        h = STEP * max(1.0, abs(q[j]))
        e = np.zeros(n)
        e[j] = h
        K[:, j] = (residual(q + e, qd) - residual(q - e, qd)) / (2 * h)
        h = STEP * max(1.0, abs(qd[j]))
        e[j] = h
        C[:, j] = (residual(q, qd + e) - residual(q, qd - e)) / (2 * h)
    return M, C, K


def eigenvalues(model, t, q, qd):
    """The ``2(n - m)`` eigenvalues (1/s) of the linearized internal dynamics of ``model``'s
    actuated realization (``model.actuators`` set) at ``(t, q, qd)``, sorted by real part."""
    qdd = model.actuation(t, q, qd)[0]
    M, C, K = linearization(model, t, q, qd, qdd)
    D = model.constraint_terms(t, q, qd)[2]
    N = scipy.linalg.null_space(D)
    free = [k for k in range(model.n_dof) if k not in set(model.actuators.tolist())]
    Mz, Cz, Kz = (X[free] @ N for X in (M, C, K))
    k = N.shape[1]
    A = np.block([[np.zeros((k, k)), np.eye(k)], [-np.linalg.solve(Mz, Kz), -np.linalg.solve(Mz, Cz)]])
    values = np.linalg.eigvals(A)
    return values[np.argsort(values.real, kind="stable")]


def along(model, t, q, qd) -> np.ndarray:
    """:func:`eigenvalues` at the samples ``t`` (k,), ``q``, ``qd`` (k, n) of a run: (k, 2(n - m))
    complex, NaN at samples that are not finite."""
    out = np.full((len(t), 2 * (model.n_dof - len(model.constraint_names))), np.nan, dtype=complex)
    for k in range(len(t)):
        if np.all(np.isfinite(q[k])) and np.all(np.isfinite(qd[k])):
            out[k] = eigenvalues(model, t[k], q[k], qd[k])
    return out


def unstable(values) -> np.ndarray:
    """The eigenvalues with a real part above :data:`UNSTABLE` times the largest modulus, fastest
    first."""
    values = np.asarray(values)
    growing = values[values.real > UNSTABLE * np.max(np.abs(values), initial=0.0)]
    return growing[np.argsort(-growing.real, kind="stable")]


def describe(values, limit: int = 3) -> str:
    """One line on the unstable eigenvalues among ``values``: how many, the fastest with their
    time constants ``1/Re``."""
    growing = unstable(values)
    if not len(growing):
        return "stable (no eigenvalue with a positive real part)"
    shown = ", ".join(f"{v.real:.4g} 1/s" + (f" ({v.imag:+.3g}j)" if v.imag else "")
                      + f" (time constant {1 / v.real:.3g} s)" for v in growing[:limit])
    return f"{len(growing)} unstable eigenvalue(s), fastest {shown}"


def explain(outcome, values, actuators):
    """``outcome`` of a diverged actuated run with the cause named when its internal dynamics
    (``values`` at the start) are unstable; else ``outcome`` as it is."""
    if outcome.ending is not Ending.DIVERGED or not len(unstable(values)):
        return outcome
    return Outcome.diverged(outcome.t, f"{outcome.why}; the internal dynamics of the inputs on "
                            f"{', '.join(actuators)} are unstable ({describe(values)}): they cannot realize "
                            f"this motion forward in time (non-minimum phase); use the ideal realization "
                            f"(without --actuated)")
