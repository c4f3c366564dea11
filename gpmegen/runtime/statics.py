"""Static equilibria by Newton–Raphson with gravity raised in steps (paper, sect. 3).

Two starts:

- ``locked``: the joints without springs are held where they are and the spring (flexible)
  coordinates are solved from ``g(q) + C q = 0`` with the emitted stiffness Jacobian ``K``;
- ``constrained``: the equilibrium of the constrained system itself, ``g + C q = Dᵀλ`` with
  ``Φ(q, 0) = 0``, the independent coordinates without springs held (they are neutral, e.g. the
  column's rotation under gravity along its axis).
"""

from __future__ import annotations

import numpy as np

from ..errors import StaticsError
from . import gpme

GRAVITY_STEPS = (0.0, 1.0, 2.0, 3.0, 4.0, 5.0, 6.0, 7.0, 8.0, 9.0, 9.81)


def _steps(model, gravity_parameter, steps):
    if gravity_parameter not in model.params:
        return [(None, model)]
    final = model.params[gravity_parameter]
    values = [s for s in steps if s < final] + [final] if final >= 0 else [final]
    return [(v, model.with_params(**{gravity_parameter: v})) for v in values]


def _newton(residual, jacobian, x, what, tol, max_iter):
    """Newton–Raphson on ``residual(x) = 0``; returns x or raises StaticsError."""
    r = residual(x)
    for _ in range(max_iter):
        if np.linalg.norm(r, np.inf) <= tol:
            return x
        try:
            step = np.linalg.solve(jacobian(x), -r)
        except np.linalg.LinAlgError:
            raise StaticsError(f"{what}: the Jacobian is singular (residual {np.linalg.norm(r, np.inf):.3e}); "
                               f"hold more coordinates or change the starting configuration") from None
        x = x + step
        if not np.all(np.isfinite(x)):  # the model's functions refuse it: Newton diverged
            break
        r = residual(x)
        if not np.all(np.isfinite(r)):
            break
    raise StaticsError(
        f"{what}: Newton–Raphson did not converge in {max_iter} iterations (residual "
        f"{np.linalg.norm(r, np.inf):.3e} > {tol:.1e}); use smaller gravity steps or a better start"
    )


def locked(model, q_start, free=None, gravity_parameter="g", steps=GRAVITY_STEPS, tol=1e-10, max_iter=50):
    """Equilibrium with the joints locked: solve the ``free`` coordinates (default: those with a
    spring, found from the diagonal of ``K`` at zero gravity) while gravity is raised through
    ``steps`` (m/s²), each step starting from the last. Returns q (n,)."""
    q = np.array(q_start, dtype=float)
    if free is None:
        free = spring_coordinates(model, q)
    free = np.asarray(free, dtype=int)
    if free.size == 0:
        return q
    for g, m in _steps(model, gravity_parameter, steps):
        def residual(x, m=m):
            qq = q.copy()
            qq[free] = x
            return m.static_residual(qq)[free]

        def jacobian(x, m=m):
            qq = q.copy()
            qq[free] = x
            return m.stiffness_jacobian(qq)[np.ix_(free, free)]

        scale = tol * max(1.0, _force_scale(m, q))
        q[free] = _newton(residual, jacobian, q[free], f"locked statics at gravity {g} m/s²", scale, max_iter)
    return q


def spring_stiffness(model, q):
    """The springs' stiffness ``C`` (n, n): ``K`` at ``q`` with gravity (the parameter ``g``) off."""
    m0 = model.with_params(**{"g": 0.0}) if "g" in model.params else model
    return m0.stiffness_jacobian(q)


def spring_coordinates(model, q):
    """Indices of coordinates that carry a spring (nonzero diagonal of K at zero gravity)."""
    return np.flatnonzero(np.abs(np.diag(spring_stiffness(model, q))) > 0)


def _force_scale(model, q):
    """A force scale for the tolerance: the largest gravity term at ``q`` (N or N·m)."""
    return float(np.max(np.abs(model.static_residual(np.zeros_like(q))) + np.abs(model.static_residual(q))))


def refuse_second_order(model, what: str):
    """Raise StaticsError when ``model`` has second-order constraints: they hold accelerations,
    not a configuration, so ``what`` (an equilibrium on the constraints) is not defined."""
    names = [name for name, order in zip(model.constraint_names, model.constraint_orders) if order == 2]
    if names:
        raise StaticsError(
            f"{what}: the constraint{'s' if len(names) > 1 else ''} {', '.join(map(repr, names))} "
            f"{'are' if len(names) > 1 else 'is'} of second order, which holds accelerations, not a configuration, "
            f"so there is no equilibrium on the constraints; start from the locked statics or the initial "
            f"configuration (--statics locked or initial)")


def constrained(model, q_start, hold=None, t=0.0, gravity_parameter="g", steps=GRAVITY_STEPS, tol=1e-10, max_iter=100):
    """Equilibrium of the constrained system: ``g + C q - Dᵀλ = 0`` on the free coordinates and
    ``Φ(q, t) = 0``, drive off; ``hold`` (default: independent coordinates without a spring)
    stay at their start values. Returns q (n,).

    Newton's Jacobian ``[[K, -Dᵀ], [D, 0]]`` leaves out ``λ·∂²Φ/∂q²`` (not emitted), so the
    convergence is linear with a rate set by that term; it is small against the stiffness."""
    refuse_second_order(model, "constrained statics")
    q = np.array(q_start, dtype=float)
    n = model.n_dof
    if hold is None:
        springs = set(spring_coordinates(model, q).tolist())
        dependent = set(model.dependent.tolist()) if model.dependent is not None else set()
        hold = [k for k in range(n) if k not in springs and k not in dependent]
    free = np.array([k for k in range(n) if k not in set(hold)], dtype=int)
    qd = np.zeros(n)
    # with redundant rows (model.redundant) the rows independent at the start: near it they hold
    # the same configurations as all of them, and their multipliers are unique
    rows = (gpme.independent_rows(model.constraint_terms(t, q, qd)[2]) if model.redundant
            else np.arange(len(model.constraint_names)))
    m_c = len(rows)
    lam = np.zeros(m_c)
    for g, m in _steps(model, gravity_parameter, steps):
        def split(x):
            qq = q.copy()
            qq[free] = x[: free.size]
            return qq, x[free.size:]

        def residual(x, m=m):
            qq, lm = split(x)
            phi, _, D, _ = m.constraint_terms(t, qq, qd)
            return np.concatenate([m.static_residual(qq)[free] - D[np.ix_(rows, free)].T @ lm, phi[rows]])

        def jacobian(x, m=m):
            qq, _ = split(x)
            _, _, D, _ = m.constraint_terms(t, qq, qd)
            K = m.stiffness_jacobian(qq)[np.ix_(free, free)]
            Df = D[np.ix_(rows, free)]
            return np.block([[K, -Df.T], [Df, np.zeros((m_c, m_c))]])

        scale = tol * max(1.0, _force_scale(m, q))
        x = _newton(residual, jacobian, np.concatenate([q[free], lam]),
                    f"constrained statics at gravity {g} m/s²", scale, max_iter)
        q, lam = split(x)
    return q
