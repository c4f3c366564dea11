"""SciPy's solvers on the model's right-hand side called from Python, stepped so that Ctrl-C or
SIGTERM keep what was computed; ``--method scipy-radau`` is SciPy's Radau IIA."""

from __future__ import annotations

import numpy as np

from ...status import Ending, Outcome
from .base import TOLERANCES, Effort, Integrator
from .loop import check_start, grid, interruptible, start_state, state_derivative
from .radau import radau_estimate
from .registry import register

IMPLICIT = ("Radau", "BDF", "LSODA")


def _difference_jacobian(rhs, relative=1e-7):
    """∂rhs/∂y by forward differences with step ``relative·max(1, |y_j|)``."""

    def jac(t, y):
        f0 = rhs(t, y)
        J = np.empty((len(f0), len(y)))
        for j in range(len(y)):
            h = relative * max(1.0, abs(y[j]))
            yj = y.copy()
            yj[j] += h
            J[:, j] = (rhs(t, yj) - f0) / h
        return J

    return jac


def adaptive(model, q0, qd0, t_end, t0=0.0, method="DOP853", rtol=1e-10, atol=1e-12, t_eval=None):
    """SciPy's ``method`` on the same equations. Returns ``(t, y, outcome)``; see
    :func:`scipy_solve`."""
    return scipy_solve(model, q0, qd0, t_end, t0, method, rtol, atol, t_eval)[:3]


def scipy_solve(model, q0, qd0, t_end, t0=0.0, method="DOP853", rtol=1e-10, atol=1e-12, t_eval=None):
    """SciPy's ``method`` (a solver class of ``scipy.integrate``) on the same equations, stepped as
    ``solve_ivp`` steps it (by :func:`_stepped`, so that Ctrl-C or SIGTERM keep what was
    computed), saving at ``t_eval`` (s; None: at its steps) by the method's dense output.
    Returns ``(t, y, outcome, effort)``.

    The implicit methods (Radau, BDF, LSODA) get a forward-difference Jacobian with a fixed
    relative step: scipy's own adapts its step per column and lets it grow without bound on a
    coordinate nothing depends on (the column's rotation θ1, or the work states), until the state
    overflows. Their Jacobians count in ``effort`` as calls, each 2n + 3 GPME solves (among the
    solves counted). Every method integrates the work states with the motion."""
    import scipy.integrate

    check_start(model, t0, q0, qd0)
    y0 = start_state(model, q0, qd0)
    full = state_derivative(model)
    solves = [0]

    def counted(t, y):
        solves[0] += 1
        return full(t, y)

    options = {"jac": _difference_jacobian(counted)} if method in IMPLICIT else {}
    solver = getattr(scipy.integrate, method)(counted, t0, y0, t_end, rtol=rtol, atol=atol, **options)
    t, y, outcome = _stepped(solver, t0, y0, t_eval)
    effort = Effort(None, None, solves[0], int(solver.njev or 0), int(solver.nlu or 0))  # steps not counted by SciPy
    return t, y, outcome, effort


def _stepped(solver, t0, y0, t_eval):
    """Step a SciPy ``OdeSolver`` to its end as ``solve_ivp`` does, saving at ``t_eval`` (s;
    increasing) by its dense output, or at its steps when None; Ctrl-C or SIGTERM (Python
    handles them between the right-hand side's calls) keep the rows saved. Returns ``(t, y,
    outcome)``."""
    ts, ys = ([np.array([t0])], [np.array(y0)[None, :]]) if t_eval is None else ([], [])
    saved, outcome = 0, None
    with interruptible():
        try:
            while solver.status == "running":
                message = solver.step()
                if solver.status == "failed":
                    outcome = Outcome.diverged(float(solver.t), message)
                    break
                if t_eval is None:
                    ts.append(np.array([solver.t]))
                    ys.append(np.array(solver.y)[None, :])
                    continue
                upto = int(np.searchsorted(t_eval, solver.t, side="right"))
                if upto > saved:
                    ts.append(t_eval[saved:upto])
                    ys.append(solver.dense_output()(t_eval[saved:upto]).T)
                    saved = upto
        except KeyboardInterrupt:
            outcome = Outcome(Ending.INTERRUPTED, next((float(t[-1]) for t in reversed(ts) if len(t)), float(t0)))
    t = np.concatenate(ts) if ts else np.empty(0)
    y = np.concatenate(ys) if ys else np.empty((0, len(y0)))
    return t, y, outcome or Outcome(Ending.COMPLETE, float(solver.t))


@register
class ScipyRadau(Integrator):
    """SciPy's Radau IIA of order 5 with its collocation polynomial as dense output, on the
    model's right-hand side called from Python (either backend)."""

    name = "scipy-radau"
    summary = "scipy-radau (implicit, SciPy on the model from Python)"
    fixed_step = False
    options = TOLERANCES
    frequency = "lowest"
    #: the solver class of ``scipy.integrate``
    scipy_method = "Radau"

    def run(self, model, q0, qd0, spec, progress=None, watch=None):
        times = grid(0.0, spec.t_end, spec.save_interval)
        return scipy_solve(model, q0, qd0, spec.t_end, method=self.scipy_method, rtol=spec.rtol, atol=spec.atol,
                           t_eval=np.array([times.time(k) for k in range(times.n_steps + 1)]))

    def estimate(self, n_dof, t_end, dt, omega, backend):
        return radau_estimate(n_dof, t_end, omega, "scipy Radau")


#: The SciPy methods offered by name: ``--method`` name -> solver class of ``scipy.integrate``.
SCIPY = {ScipyRadau.name: ScipyRadau.scipy_method}
