"""The machinery every integrator shares: the augmented state and its derivative, the grid of
the fixed-step loops and of the saved instants, the chunked drive of a loop (violation, loss of
rank and partition checks between chunks, progress, Ctrl-C and SIGTERM), and the save intervals.

The state is ``y = [q, q̇, W_drive, W_constraint, z]``: the work of the drive and of the constraint
forces is integrated with the motion, so the power balance is checked to the integrator's order,
and so are the controller states ``z`` (n_z, none in most models) that the drives read.
"""

from __future__ import annotations

import math
import signal
import sys
import time
from typing import NamedTuple

import numpy as np

from ...errors import SimulationError, StateError
from ...status import Ending, Outcome, SolveStatus
from ..consistent import project_onto_constraints
from ..pacing import StepBudget
from ..partition import check_second_order_rows
from ..redundancy import RowWatch

FIX_VIOLATION = ("try a smaller --dt or other Baumgarte gains, and check that the prescribed motion stays "
                 "within reach")


def violation(model, t, q, qd, limit, phi=None) -> Outcome | None:
    """The outcome of a run whose constraint violation max|Φ| at ``(t, q, qd)`` exceeds
    ``limit``, else None; ``phi``: Φ there where the caller has it."""
    phi = model.constraint_terms(t, q, qd)[0] if phi is None else phi
    worst = float(np.max(np.abs(phi), initial=0.0))
    if worst > limit:
        return Outcome.diverged(t, f"constraint violation {worst:.3e} above {limit:.1e} at t = {t:.6g} s; "
                                   f"{FIX_VIOLATION}")
    return None


#: Wall time (s) between two progress lines where no bar can be drawn (a log, a pipe).
PROGRESS_LINES = 10.0


class Progress:
    """A one-line progress bar on stderr (quiet when not a terminal unless forced); elsewhere (a
    log, a pipe), with ``lines_every`` (s of wall time), a plain line at most that often, the
    first after that long, so that short work prints nothing and long work is never silent."""

    def __init__(self, total: float, label: str, enabled: bool | None = None, lines_every: float | None = None):
        self.total, self.label = total, label
        self.enabled = sys.stderr.isatty() if enabled is None else enabled
        self.lines_every = None if self.enabled else lines_every
        self.start = time.perf_counter()
        self.last = 0.0 if self.enabled else self.start
        self.lines, self.ended = 0, False

    def update(self, done: float):
        now = time.perf_counter()
        if self.lines_every is not None:
            self._line(done, now)
        if not self.enabled or (now - self.last < 0.25 and done < self.total):  # the end is always drawn
            return
        self.last = now
        frac, elapsed, eta = self._measure(done, now)
        bar = "#" * int(30 * frac)
        print(f"\r{self.label} [{bar:<30}] {100 * frac:5.1f}%  {elapsed:6.1f} s, {eta:6.1f} s left",
              end="", file=sys.stderr, flush=True)

    def _measure(self, done, now):
        """(fraction done, s elapsed, s left at the pace so far)."""
        frac = min(done / self.total, 1.0) if self.total else 1.0
        elapsed = now - self.start
        return frac, elapsed, elapsed / frac - elapsed if frac > 0 else float("nan")

    def _line(self, done, now):
        finished = done >= self.total
        if self.ended or not (now - self.last >= self.lines_every or (finished and self.lines)):
            return
        self.last = now
        frac, elapsed, eta = self._measure(done, now)
        self.lines, self.ended = self.lines + 1, finished
        left = "done" if finished else f"about {eta:.0f} s left"
        print(f"{self.label}: {done:.6g} of {self.total:.6g} ({100 * frac:.0f} %) in {elapsed:.0f} s, {left}",
              file=sys.stderr, flush=True)

    def close(self):
        if self.enabled:
            print(file=sys.stderr, flush=True)


def state_derivative(model):
    """``dy/dt`` of the augmented state for ``model``'s GPME; the controller states, where the
    model has them, set in its ``p`` at each call (what its drives and rates read)."""
    n, controlled = model.n_dof, bool(model.controller_names)

    def rhs(t, y):
        q, qd = y[:n], y[n:2 * n]
        at = model.at_controller_states(y[2 * n + 2:])
        qdd, M, f = at.motion(t, q, qd)
        drive = at.drive_forces(t, q, qd)
        reaction = M @ qdd - f
        rates = at.controller_rates(t, q, qd) if controlled else ()
        return np.concatenate([qd, qdd, [qd @ drive, qd @ reaction], rates])

    return rhs


def start_state(model, q0, qd0):
    """The augmented state at the start: ``[q0, qd0, 0, 0, z0]``, no work done yet and the
    controller states at their initial values."""
    return np.concatenate([q0, qd0, [0.0, 0.0], model.controller_initial]).astype(float)


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


#: Simulated time (s) between two looks of the driver at a run (progress, violation, partition).
CHUNK_SECONDS = 0.05


def check_start(model, t0, q0, qd0):
    """Refuse a start where a force element's points meet or the row of a second-order
    constraint vanishes (at rest, for a path curvature), with SimulationError naming it; other
    singular starts end the run at its first step with their own message."""
    model.check_forces_apart(q0)
    check_second_order_rows(model, model.constraint_terms(t0, q0, qd0)[2], t0, qd0)



def chunked(model, y, g: Grid, chunk: int, advance, progress=None, max_violation=None, watch=None,
            steps_per_call=None):
    """Drive an integrator over the instants of grid ``g`` from the augmented state ``y`` at its
    start, ``chunk`` grid intervals at a time. ``advance(model, y, k_from, k_to)`` starts a chunk
    and returns ``more(max_steps)``, which takes at most ``max_steps`` steps of it and returns the
    times and states of the rows saved on the way, a :class:`SolveStatus`, the steps taken and,
    once at ``g.time(k_to)``, the state to go on from (else None); ``max_steps`` is
    ``steps_per_call`` or chosen by :class:`gpmegen.runtime.pacing.StepBudget` so that a call
    lasts about :data:`gpmegen.runtime.pacing.CALL_SECONDS`, and the loops go on from where a
    call stopped to the same bits, so the results do not depend on it. Between chunks, the
    constraint violation max|Φ| is checked against ``max_violation``, the rank and the redundant
    rows of a model that closes loops are looked at (:class:`gpmegen.runtime.redundancy.RowWatch`),
    and ``watch`` (a
    :class:`gpmegen.runtime.partition.Watch`) looks at the partition, at the same instants on
    both backends; between calls, progress is shown and Ctrl-C or SIGTERM keep what was
    computed. Returns ``(t, y, outcome)``."""
    n = model.n_dof
    ts, ys = [np.array([g.time(0)])], [y[None, :]]
    done, outcome = 0, None
    loops = RowWatch(model, model.constraint_terms(g.time(0), y[:n], y[n:2 * n])[2]
                    if model.closure_rows or model.redundant else np.zeros((0, n)))
    bar = progress if progress is not None else Progress(g.t_end - g.t0, "RK4", enabled=False)
    budget = StepBudget(steps_per_call)
    with interruptible():
        try:
            while done < g.n_steps and outcome is None:
                end = min(done + chunk, g.n_steps)
                more, carry = advance(model, y, done, end), None
                while carry is None:
                    t, rows, status, steps, carry = more(budget.start())
                    budget.spent(steps)
                    ts.append(t)
                    ys.append(rows)
                    if status != SolveStatus.OK:
                        last = _last_saved(ts, ys)
                        # a singular solve names the constraints' loss of rank itself; a state gone
                        # non-finite (or a step that failed) may be a motion that left the workspace
                        reach = None if status == SolveStatus.SINGULAR else out_of_reach(model, *last, g.time(end))
                        outcome = reach or Outcome.failed(last[0], status)
                        if status == SolveStatus.NONFINITE and model.force_names:
                            outcome = Outcome.diverged(outcome.t, outcome.why + shortest_force(model, *last))
                        break
                    if carry is None and len(t):
                        bar.update(t[-1] - g.t0)
                if outcome is not None:
                    break
                y, done = carry, end
                q, qd, now = y[:n], y[n:2 * n], g.time(end)
                # the constraint terms once for both checks (the watch's model is this one until it repartitions)
                terms = (model.constraint_terms(now, q, qd) if max_violation is not None or loops.active
                         or (watch is not None and watch.model is model) else None)
                if loops.active:   # said before a violation that it may explain stops the run
                    loops.check(now, terms[0], terms[2])
                if max_violation is not None:
                    outcome = violation(model, now, q, qd, max_violation, terms[0])
                if watch is not None and outcome is None:  # with other dependent coordinates, maybe
                    same = terms is not None and watch.model is model
                    model = watch.check(now, q, qd, terms[2] if same else None)
                bar.update(now - g.t0)
        except KeyboardInterrupt:
            outcome = Outcome(Ending.INTERRUPTED, _reached(ts, g))
        finally:
            bar.close()
    return np.concatenate(ts), np.concatenate(ys), outcome or Outcome(Ending.COMPLETE, g.t_end)


def shortest_force(model, t_last: float, y_last) -> str:
    """What a run that went non-finite says of the model's force elements between points: the
    shortest one at its last saved state (a force element's direction is undefined where its
    points meet, and its force there is NaN)."""
    n = model.n_dof
    try:
        lengths = model.force_elements(t_last, y_last[:n], y_last[n:2 * n])[:, 0]
    except SimulationError:
        return ""
    k = int(np.nanargmin(lengths)) if np.any(np.isfinite(lengths)) else 0
    return (f"; the shortest force element, {model.force_names[k]!r}, was {lengths[k]:.3g} m long at "
            f"t = {t_last:.6g} s (at length 0 its direction is undefined and its force NaN: keep its points apart)")


def _last_saved(ts, ys) -> tuple:
    """The time (s) and augmented state of the last row saved in ``ts``, ``ys`` (the start's is
    their first)."""
    return next((float(t[-1]), rows[-1]) for t, rows in zip(reversed(ts), reversed(ys)) if len(t))


def _reached(ts, g: Grid) -> float:
    """The time (s) of the last row saved in ``ts`` (arrays of times), or the start of ``g``."""
    return next((float(t[-1]) for t in reversed(ts) if len(t)), g.time(0))


#: Instants between a failed chunk's last saved state and its end at which the constraints are
#: looked for (each from the configuration found at the one before).
REACH_LOOKS = 20
#: Constraint values at which a configuration that Newton could not finish counts as meeting them.
MET = 1e-6


def out_of_reach(model, t_last: float, y_last, t_end: float) -> Outcome | None:
    """The outcome of a run that failed between ``t_last`` (its last state ``y_last``) and
    ``t_end`` because its position constraints could no longer be met (the prescribed motion left
    the workspace, where their Jacobian D loses rank), naming them and the instant; None when they
    can be met throughout, so that the failure is the step's."""
    orders = np.asarray(model.constraint_orders)
    if model.dependent is None or not np.any(orders == 0) or not np.all(np.isfinite(y_last)):
        return None
    q = np.array(y_last[:model.n_dof], dtype=float)
    for t in np.linspace(t_last, t_end, REACH_LOOKS + 1)[1:]:
        try:
            q = project_onto_constraints(model, q, float(t), tol=1e-9)
        except SimulationError as exc:
            phi = (exc.partial or {}).get("phi")
            if phi is not None and np.max(np.abs(np.asarray(phi)[orders == 0]), initial=0.0) <= MET:
                return None  # met, but where D lost rank: the solve's own message says that
            names = [name for name, order, value in zip(model.constraint_names, orders,
                                                         phi if phi is not None else orders)
                     if order == 0 and (phi is None or abs(value) > 1e-9)]
            return Outcome.diverged(
                t, f"at t = {float(t):.4g} s the constraint{'s' if len(names) > 1 else ''} {', '.join(names)} "
                   f"went out of reach: no configuration meets {'them' if len(names) > 1 else 'it'} (the motion "
                   f"leaves the workspace, where the constraints' Jacobian D loses rank); keep the prescribed "
                   f"motion within reach")
        except StateError:
            return None
    return None


# The save interval when none is asked (s): that of the paper's run (1e-5 s steps, every 100th).
SAVE_INTERVAL = 1e-3


def default_save_every(dt: float) -> int:
    """The steps of ``dt`` (s) saved once when the user asks for no interval: about
    :data:`SAVE_INTERVAL`, whatever the step (every step when it is longer)."""
    return max(1, int(round(SAVE_INTERVAL / dt)))


def save_steps(dt: float, save_dt: float) -> int | None:
    """The RK4 steps of ``dt`` (s) in a save interval ``save_dt`` (s), or None when it is not
    a whole number of them (to a relative 1e-9)."""
    k = round(save_dt / dt)
    return k if k >= 1 and abs(k * dt - save_dt) <= 1e-9 * save_dt else None

