"""Integration of the GPME: fixed-step RK4 (as in the paper) and an adaptive stepper beside it.

The state is ``y = [q, q̇, W_drive, W_constraint]``: the work of the drive and of the constraint
forces is integrated with the motion, so the power balance is checked to the integrator's order.
"""

from __future__ import annotations

import math
import signal
import sys
import time
from typing import NamedTuple

import numpy as np

from ..errors import EvaluationError, SimulationError
from ..status import Ending, Outcome, SolveStatus
from .partition import check_second_order_rows

FIX_VIOLATION = ("try a smaller --dt or other Baumgarte gains, and check that the prescribed motion stays "
                 "within reach")


def violation(model, t, q, qd, limit) -> Outcome | None:
    """The outcome of a run whose constraint violation max|Φ| at ``(t, q, qd)`` exceeds
    ``limit``, else None."""
    phi = model.constraint_terms(t, q, qd)[0]
    worst = float(np.max(np.abs(phi), initial=0.0))
    if worst > limit:
        return Outcome.diverged(t, f"constraint violation {worst:.3e} above {limit:.1e} at t = {t:.6g} s; "
                                   f"{FIX_VIOLATION}")
    return None


class Progress:
    """A one-line progress bar on stderr (quiet when not a terminal unless forced)."""

    def __init__(self, total: float, label: str, enabled: bool | None = None):
        self.total, self.label = total, label
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.start = time.perf_counter()
        self.last = 0.0

    def update(self, done: float):
        now = time.perf_counter()
        if not self.enabled or (now - self.last < 0.25 and done < self.total):  # the end is always drawn
            return
        self.last = now
        frac = min(done / self.total, 1.0) if self.total else 1.0
        elapsed = now - self.start
        eta = elapsed / frac - elapsed if frac > 0 else float("nan")
        bar = "#" * int(30 * frac)
        print(f"\r{self.label} [{bar:<30}] {100 * frac:5.1f}%  {elapsed:6.1f} s, {eta:6.1f} s left",
              end="", file=sys.stderr, flush=True)

    def close(self):
        if self.enabled:
            print(file=sys.stderr, flush=True)


def state_derivative(model):
    """``dy/dt`` of the augmented state for ``model``'s GPME."""
    n = model.n_dof

    def rhs(t, y):
        q, qd = y[:n], y[n:2 * n]
        qdd, M, f = model.motion(t, q, qd)
        drive = model.drive_forces(t)
        reaction = M @ qdd - f
        return np.concatenate([qd, qdd, [qd @ drive, qd @ reaction]])

    return rhs


class interruptible:
    """Turns SIGTERM into KeyboardInterrupt for the duration of a run, so partial results
    are kept on either signal."""

    def __enter__(self):
        self.previous = None
        try:
            self.previous = signal.signal(signal.SIGTERM, self._raise)
        except ValueError:  # not the main thread
            pass
        return self

    @staticmethod
    def _raise(signum, frame):
        raise KeyboardInterrupt

    def __exit__(self, *exc):
        if self.previous is not None:
            signal.signal(signal.SIGTERM, self.previous)
        return False


class Grid(NamedTuple):
    """The fixed-step grid of both RK4 loops (NumPy here, C in the generated code), made by
    :func:`grid`: step k = 1 … ``n_steps`` ends at ``t0 + k dt`` (so no round-off builds up in
    t), except the last, which ends at ``t_end`` exactly."""

    t0: float
    dt: float
    n_steps: int
    t_end: float

    def time(self, k: int) -> float:
        """Time (s) at the end of step ``k`` (0: the start)."""
        return self.t_end if k == self.n_steps else self.t0 + k * self.dt

    def step(self, k: int) -> float:
        """Length (s) of step ``k`` (1 … n_steps): ``dt``, the last one up to ``t_end``."""
        return self.t_end - self.time(k - 1) if k == self.n_steps else self.dt

    def span(self, steps, save_every) -> tuple[int, int]:
        """``steps = (k_from, k_to)`` of this grid (None: all of them) as ints, checked together
        with ``save_every`` (a whole number of steps >= 1)."""
        k_from, k_to = (0, self.n_steps) if steps is None else (int(steps[0]), int(steps[1]))
        if not 0 <= k_from <= k_to <= self.n_steps or int(save_every) < 1:
            raise ValueError(f"need 0 <= k_from <= k_to <= {self.n_steps} steps and save_every >= 1, got steps = "
                             f"{steps} and save_every = {save_every}")
        return k_from, k_to


#: A remainder of (t_end - t0) / dt below this many steps is round-off, not a step to take.
STEP_ROUND_OFF = 1e-6


def grid(t0: float, t_end: float, dt: float) -> Grid:
    """The grid from ``t0`` to ``t_end`` (s) with step ``dt`` (s): whole steps of ``dt`` and, where
    ``t_end - t0`` is not a whole number of them, one shorter last step that ends at ``t_end``."""
    if not (math.isfinite(t0) and math.isfinite(t_end) and math.isfinite(dt) and dt > 0 and t_end >= t0):
        raise ValueError(f"need finite t0 <= t_end and dt > 0, got t0 = {t0}, t_end = {t_end}, dt = {dt}")
    steps = (t_end - t0) / dt
    n_steps = round(steps)
    if abs(steps - n_steps) > STEP_ROUND_OFF:
        n_steps = math.ceil(steps)
    if t_end > t0:
        n_steps = max(n_steps, 1)
    return Grid(float(t0), float(dt), int(n_steps), float(t_end))


def rk4_steps(rhs, y, g: Grid, k_from: int, k_to: int, save_every: int):
    """Steps ``k_from + 1 … k_to`` of classical RK4 on grid ``g`` from the augmented state ``y``
    at the end of step ``k_from``, in Python: the loop the C code runs. Saves the start, the state
    after every ``save_every``-th step of the grid and the last one. Returns ``(t, y, status)``:
    the saved times (k,) s and states (k, len(y)), and a :class:`SolveStatus` (on a failure, the
    rows saved before it; none when the start is not finite)."""
    if not np.all(np.isfinite(y)):
        return np.empty(0), np.empty((0, len(y))), SolveStatus.NONFINITE
    ts, ys = [g.time(k_from)], [y.copy()]
    with np.errstate(over="ignore", invalid="ignore"):  # a non-finite state is a status, as in C
        status = _steps(rhs, y, g, k_from, k_to, save_every, ts, ys)
    return np.array(ts), np.array(ys), status


def _steps(rhs, y, g, k_from, k_to, save_every, ts, ys) -> SolveStatus:
    """The loop of :func:`rk4_steps`, appending the saved times and states to ``ts``, ``ys``."""
    for k in range(k_from + 1, k_to + 1):
        t, h = g.time(k - 1), g.step(k)
        try:
            k1 = rhs(t, y)
            k2 = rhs(t + h / 2, y + h / 2 * k1)
            k3 = rhs(t + h / 2, y + h / 2 * k2)
            k4 = rhs(t + h, y + h * k3)
        except EvaluationError:  # Python's math raised where C gives inf or nan
            return SolveStatus.NONFINITE
        except (SimulationError, np.linalg.LinAlgError):
            return SolveStatus.SINGULAR
        y = y + h / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        if not np.all(np.isfinite(y)):
            return SolveStatus.NONFINITE
        if k % save_every == 0 or k == k_to:
            ts.append(g.time(k))
            ys.append(y)
    return SolveStatus.OK


#: Simulated time (s) between two looks of the driver at a run (progress, violation, partition).
CHUNK_SECONDS = 0.05


def check_start(model, t0, q0, qd0):
    """Refuse a start where the row of a second-order constraint vanishes (at rest, for a path
    curvature), with SimulationError naming it; other singular starts end the run at its first
    step with their own message."""
    check_second_order_rows(model, model.constraint_terms(t0, q0, qd0)[2], t0, qd0)


def rk4(model, q0, qd0, t_end, dt, save_every=1, t0=0.0, progress=None, max_violation=None, watch=None):
    """Classical RK4 from ``t0`` to ``t_end`` (s) on :func:`grid` with step ``dt`` (s), run by
    ``model.rk4`` (in C or in Python) in chunks of about :data:`CHUNK_SECONDS`, so that progress
    is shown, the constraint violation max|Φ| is checked against ``max_violation``, ``watch`` (a
    :class:`gpmegen.runtime.partition.Watch`) looks at the partition, and Ctrl-C or SIGTERM keep
    what was computed, at the same instants on both backends. Keeps the initial state, the state
    after every ``save_every``-th step and the final state. Returns ``(t, y, outcome)``: ``y``
    rows of the augmented state, ``outcome`` an :class:`Outcome`."""
    check_start(model, t0, q0, qd0)
    g = grid(t0, t_end, dt)
    # a whole number of save intervals, so that the chunks' ends (always saved) are saved rows anyway
    chunk = max(save_every, int(round(CHUNK_SECONDS / dt / save_every)) * save_every)
    n = model.n_dof
    y = np.concatenate([q0, qd0, [0.0, 0.0]]).astype(float)
    ts, ys = [np.array([g.time(0)])], [y[None, :]]
    done, outcome = 0, None
    bar = progress if progress is not None else Progress(t_end - t0, "RK4", enabled=False)
    with interruptible():
        try:
            while done < g.n_steps and outcome is None:
                end = min(done + chunk, g.n_steps)
                t, q, qd, w, status = model.rk4(y[:n], y[n:2 * n], t_end, dt, save_every, t0, y[2 * n:], (done, end))
                ts.append(t[1:])
                ys.append(np.column_stack([q, qd, w])[1:])
                if status != SolveStatus.OK:
                    outcome = Outcome.failed(t[-1] if len(t) else g.time(done), status)
                    break
                y, done = np.concatenate([q[-1], qd[-1], w[-1]]), end
                if max_violation is not None:
                    outcome = violation(model, t[-1], q[-1], qd[-1], max_violation)
                if watch is not None and outcome is None:
                    model = watch.check(t[-1], q[-1], qd[-1])  # with other dependent coordinates, maybe
                bar.update(t[-1] - t0)
        except KeyboardInterrupt:
            outcome = Outcome(Ending.INTERRUPTED, g.time(done))
        finally:
            bar.close()
    return np.concatenate(ts), np.concatenate(ys), outcome or Outcome(Ending.COMPLETE, g.t_end)


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
    """``scipy.integrate.solve_ivp`` on the same equations. Returns ``(t, y, outcome)``.

    The implicit methods (Radau, BDF, LSODA) integrate ``(q, q̇)`` only (the work columns of ``y``
    are then NaN) and get a forward-difference Jacobian with a fixed relative step: scipy's own
    adapts its step per column and lets it grow without bound on a coordinate nothing depends on
    (the column's rotation θ1, or the work states), until the state overflows."""
    from scipy.integrate import solve_ivp

    check_start(model, t0, q0, qd0)
    n = model.n_dof
    with_work = method not in IMPLICIT
    y0 = np.concatenate([q0, qd0] + ([[0.0, 0.0]] if with_work else [])).astype(float)
    full = state_derivative(model)
    rhs = full if with_work else (lambda t, y: full(t, np.concatenate([y, [0.0, 0.0]]))[:2 * n])
    options = {} if with_work else {"jac": _difference_jacobian(rhs)}
    sol = solve_ivp(rhs, (t0, t_end), y0, method=method, rtol=rtol, atol=atol, t_eval=t_eval, **options)
    y = sol.y.T if with_work else np.column_stack([sol.y.T, np.full((len(sol.t), 2), np.nan)])
    reached = float(sol.t[-1]) if len(sol.t) else float(t0)
    outcome = Outcome(Ending.COMPLETE, reached) if sol.success else Outcome.diverged(reached, sol.message)
    return sol.t, y, outcome
