"""Stable inversion of the actuated realization: the bounded solution where the internal
dynamics are unstable, with the inputs acting before and after the programmed motion.

Forward in time, inputs that hold the constraints make unstable internal dynamics grow
(:mod:`.internal`). For a programmed motion that rests before ``t0`` and after ``t1``, the
bounded solution starts at rest in the infinite past and ends at rest in the infinite future: on
``[t0 - pre, t1 + post]`` it solves the actuated equations ``M q̈ = f + S u``, Φ held, as a
boundary-value problem (``scipy.integrate.solve_bvp``) whose state starts on the unstable
manifold of the rest state at ``t0`` (its components along the stable eigenvectors of the
linearized actuated system are zero, the constraints' Baumgarte modes among them) and ends on
the stable manifold of the rest state at ``t1`` (no component along the unstable ones). The
internal dynamics must be hyperbolic (no eigenvalue on the imaginary axis: damped sdes, no
neutral coordinate left to the internal dynamics).
"""

from __future__ import annotations

import time
from dataclasses import dataclass

import numpy as np
import scipy.linalg
from scipy.integrate import solve_bvp

from ..errors import SimulationError
from . import internal
from .integrators.loop import PROGRESS_LINES

# Relative step of the differences of the actuated equations.
STEP = 1e-7


@dataclass
class Inversion:
    """A stable inversion: ``t`` (k,) s, ``q``, ``qd`` (k, n), ``u`` (k, m) and ``lead`` (s), how
    long before ``t0`` the inputs leave their rest values by more than 1 % of their largest
    change (``lag`` likewise after ``t1``); ``residual`` the BVP's largest relative residual."""

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    u: np.ndarray
    lead: float
    lag: float
    residual: float


def rest(model, q, t, tol=1e-12, max_iter=50):
    """The rest state at time ``t`` (a programmed motion at rest): the unactuated rows of
    ``g + C q`` zero and ``Φ(q, t) = 0``, by Newton from ``q`` (n,); the inputs take the rest."""
    q = np.array(q, dtype=float)
    n, zero = model.n_dof, np.zeros(model.n_dof)
    free = [k for k in range(n) if k not in set(model.actuators.tolist())]
    for _ in range(max_iter):
        phi, _, D, _ = model.constraint_terms(t, q, zero)
        r = np.concatenate([model.static_residual(q)[free], phi])
        if np.max(np.abs(r)) <= tol * max(1.0, np.max(np.abs(model.static_residual(q)))):
            return q
        J = np.vstack([model.stiffness_jacobian(q)[free], D])
        try:
            q = q - np.linalg.solve(J, r)
        except np.linalg.LinAlgError:
            raise SimulationError(
                f"the rest state at t = {t:g} s is not unique (the unactuated rows of g + C q with Φ have a singular "
                f"Jacobian: a coordinate left to the internal dynamics is neutral, without spring or gravity); "
                f"stable inversion needs hyperbolic internal dynamics: actuate it or give it a spring") from None
        if not np.all(np.isfinite(q)):  # the model's functions refuse it: Newton diverged
            break
    raise SimulationError(f"no rest state of {model.module.MODEL} with the programmed constraints at t = {t:g} s "
                          f"(Newton did not converge); is the programmed motion at rest there?")


def _rhs(model):
    n = model.n_dof

    def rhs(t, y):
        qdd = model.actuation(t, y[:n], y[n:])[0]
        return np.concatenate([y[n:], qdd])

    return rhs


def _jacobian(rhs, t, y):
    """∂rhs/∂y (2n, 2n) by central differences."""
    J = np.empty((len(y), len(y)))
    for j in range(len(y)):
        h = STEP * max(1.0, abs(y[j]))
        e = np.zeros(len(y))
        e[j] = h
        J[:, j] = (rhs(t, y + e) - rhs(t, y - e)) / (2 * h)
    return J


def _rows(J, keep):
    """Real rows (k, 2n) whose null space is the invariant subspace of ``J`` of the eigenvalues
    for which ``keep`` is False: the left eigenvectors of those it is True for."""
    values, left = scipy.linalg.eig(J, left=True, right=False)
    chosen = left[:, keep(values)].conj().T
    rows = np.vstack([chosen.real, chosen.imag])
    vt = np.linalg.svd(rows)[2]
    rank = int(np.sum(keep(values)))
    return vt[:rank]


def _hyperbolic(model, t, y_rest, rhs):
    """The actuated system's Jacobian at a rest state; SimulationError where the internal
    dynamics have an eigenvalue on the imaginary axis."""
    n = model.n_dof
    values = internal.eigenvalues(model, t, y_rest[:n], y_rest[n:])
    scale = np.max(np.abs(values), initial=1.0)
    flat = values[np.abs(values.real) <= internal.UNSTABLE * scale]
    if len(flat):
        raise SimulationError(f"stable inversion needs hyperbolic internal dynamics, but at t = {t:g} s "
                              f"{len(flat)} eigenvalue(s) lie on the imaginary axis (e.g. {flat[0]:.4g} 1/s); "
                              f"damp the sdes or actuate the coordinates left neutral")
    return _jacobian(rhs, t, y_rest)


# Samples of the programmed law in each window outside [t0, t1] where it must be at rest, and the
# share of its largest rate within [t0, t1] above which it counts as moving there.
REST_SAMPLES = 201
REST_RATE = 1e-9


def check_at_rest_outside(model, q, t0, t1, pre, post) -> None:
    """SimulationError when the programmed law moves in ``[t0 - pre, t0)`` or ``(t1, t1 + post]``:
    the bounded solution is that of a motion at rest outside ``[t0, t1]``, so a law already moving
    there would give inputs whose start (or end) is not at rest. Moving: a rate ``∂Φ/∂t`` at ``q``
    (n,) above :data:`REST_RATE` of its largest within ``[t0, t1]``."""
    zero = np.zeros(model.n_dof)
    position = np.asarray(model.constraint_orders) == 0

    def rates(times):  # at rest: Φ̇ of position constraints, Ψ of first-order ones, are their time terms
        terms = [model.constraint_terms(t, q, zero) for t in times]
        return np.array([np.max(np.abs(np.where(position, rate, phi)), initial=0.0) for phi, rate, _, _ in terms])

    peak = np.max(rates(np.linspace(t0, t1, REST_SAMPLES)), initial=0.0)
    for name, times, fix in (("before t0", np.linspace(t0 - pre, t0, REST_SAMPLES)[:-1], "an earlier --t0"),
                             ("after t1", np.linspace(t1, t1 + post, REST_SAMPLES)[1:], "a later --t1")):
        moving = np.flatnonzero(rates(times) > REST_RATE * max(peak, np.finfo(float).tiny))
        if len(moving):
            t = times[moving[0]] if name == "before t0" else times[moving[-1]]
            raise SimulationError(
                f"the programmed motion moves {name} ({t0:g} to {t1:g} s): its constraints change at t = {t:.6g} s; "
                f"stable inversion is for a motion at rest outside [t0, t1]: give {fix} (where the motion is at "
                f"rest)")


def quasi_static(model, mesh, start, end, t0, t1) -> np.ndarray:
    """The boundary-value problem's first guess (2n, k) on ``mesh`` (k,) s: the quasi-static
    motion, at each time the rest state of the programmed law there (:func:`rest`, each from the
    one before; ``start``'s before ``t0``, ``end``'s after ``t1``), its velocities by
    differences. It holds the constraints, so Newton starts near the bounded solution of a slow
    motion; the straight blend of the rest states ``start`` and ``end`` (2n,) with zero
    velocities does not, and its first steps can leave the states where the inputs hold the
    constraints. Where a time has no rest state, that blend."""
    n = model.n_dof
    q, qs = start[:n], []
    try:
        for t in mesh:  # at rest outside [t0, t1]: the rest states there are start's and end's
            q = start[:n] if t <= t0 else end[:n] if t >= t1 else rest(model, q, t)
            qs.append(q)
    except SimulationError:
        blend = np.clip((mesh - t0) / (t1 - t0), 0.0, 1.0)
        return start[:, None] + (end - start)[:, None] * blend[None, :]
    qs = np.array(qs).T
    return np.vstack([qs, np.gradient(qs, mesh, axis=1)])


def stable_inversion(model, q_guess, t0, t1, pre, post, nodes=200, tol=1e-6, progress=None) -> Inversion:
    """The bounded solution of ``model``'s actuated realization (actuators set) for a programmed
    motion at rest before ``t0`` and after ``t1`` (s), on ``[t0 - pre, t1 + post]`` with
    ``nodes`` mesh points at first and the BVP's relative residual ``tol``; ``q_guess`` (n,)
    starts the Newton search of the rest states. ``progress`` (a callable taking one line) is
    told the mesh the solver works on, every :data:`gpmegen.runtime.integrators.loop.PROGRESS_LINES` s."""
    n = model.n_dof
    rhs = _rhs(model)
    ta, tb = t0 - pre, t1 + post
    start = np.concatenate([rest(model, q_guess, t0), np.zeros(n)])
    check_at_rest_outside(model, start[:n], t0, t1, pre, post)
    end = np.concatenate([rest(model, start[:n], t1), np.zeros(n)])
    rows_a = _rows(_hyperbolic(model, t0, start, rhs), lambda v: v.real < 0)
    rows_b = _rows(_hyperbolic(model, t1, end, rhs), lambda v: v.real > 0)
    if len(rows_a) + len(rows_b) != 2 * n:
        raise SimulationError("stable inversion: the rest states' stable and unstable directions do not add up "
                              "to the state's dimension")

    began = last = time.perf_counter()

    def fun(t, y):
        nonlocal last
        now = time.perf_counter()
        if progress is not None and now - last >= PROGRESS_LINES:
            last = now
            progress(f"stable inversion: solving on a mesh of {len(t)} nodes, {now - began:.0f} s so far")
        return np.column_stack([rhs(t[k], y[:, k]) for k in range(len(t))])

    def bc(ya, yb):
        return np.concatenate([rows_a @ (ya - start), rows_b @ (yb - end)])

    mesh = np.linspace(ta, tb, nodes)
    try:
        sol = solve_bvp(fun, bc, mesh, quasi_static(model, mesh, start, end, t0, t1), tol=tol, max_nodes=20 * nodes)
    except SimulationError:  # a Newton iterate, not the motion, where the inputs cannot hold the constraints
        raise SimulationError("stable inversion did not converge: the solver's Newton iterates left the states where "
                              "the inputs can hold the constraints; lengthen the pre- and post-actuation windows or "
                              "raise the mesh nodes") from None
    if not sol.success:
        raise SimulationError(f"stable inversion did not converge ({sol.message}); lengthen the pre- and "
                              f"post-actuation windows or raise the mesh nodes")
    t = sol.x
    q, qd = sol.y[:n].T, sol.y[n:].T
    u = np.array([model.actuation(t[k], q[k], qd[k])[1] for k in range(len(t))])
    change = np.max(np.abs(u - u[0]), initial=0.0)
    away = np.flatnonzero(np.max(np.abs(u - u[0]), axis=1) > 0.01 * change) if change else np.array([], int)
    lead = max(0.0, t0 - t[away[0]]) if len(away) else 0.0
    away_end = np.flatnonzero(np.max(np.abs(u - u[-1]), axis=1) > 0.01 * change) if change else np.array([], int)
    lag = max(0.0, t[away_end[-1]] - t1) if len(away_end) else 0.0
    return Inversion(t, q, qd, u, lead, lag, float(np.max(sol.rms_residuals)))
