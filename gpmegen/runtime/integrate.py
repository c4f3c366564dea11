"""Integration of the GPME: fixed-step RK4 (as in the paper) and an adaptive stepper beside it.

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

from ..errors import EvaluationError, SimulationError, StateError
from ..status import Ending, Outcome, SolveStatus
from .consistent import project_onto_constraints
from .pacing import StepBudget
from .partition import check_second_order_rows
from .redundancy import RowWatch

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
    """Refuse a start where a force element's points meet or the row of a second-order
    constraint vanishes (at rest, for a path curvature), with SimulationError naming it; other
    singular starts end the run at its first step with their own message."""
    model.check_forces_apart(q0)
    check_second_order_rows(model, model.constraint_terms(t0, q0, qd0)[2], t0, qd0)


def rk4(model, q0, qd0, t_end, dt, save_every=1, t0=0.0, progress=None, max_violation=None, watch=None,
        steps_per_call=None):
    """Classical RK4 from ``t0`` to ``t_end`` (s) on :func:`grid` with step ``dt`` (s), run by
    ``model.rk4`` (in C or in Python) in chunks of about :data:`CHUNK_SECONDS` (see
    :func:`chunked`), each made of calls of ``steps_per_call`` steps (None: as many as take
    :data:`gpmegen.runtime.pacing.CALL_SECONDS`). Keeps the initial state, the state after every
    ``save_every``-th step and the final state. Returns ``(t, y, outcome)``: ``y`` rows of the
    augmented state, ``outcome`` an :class:`Outcome`."""
    check_start(model, t0, q0, qd0)
    g = grid(t0, t_end, dt)
    # a whole number of save intervals, so that the chunks' ends (always saved) are saved rows anyway
    chunk = max(save_every, int(round(CHUNK_SECONDS / dt / save_every)) * save_every)
    n = model.n_dof

    def advance(model, y, k_from, k_to):
        place = {"k": k_from, "y": y}

        def more(max_steps):
            a, y = place["k"], place["y"]
            b = min(k_to, a + max_steps)
            t, q, qd, w, status = model.rk4(y[:n], y[n:2 * n], t_end, dt, save_every, t0, y[2 * n:], (a, b))
            t, rows = t[1:], np.column_stack([q, qd, w])[1:]
            done = status == SolveStatus.OK
            if done:
                place["k"], place["y"] = b, rows[-1] if len(rows) else y
                if b < k_to and b % save_every:  # the loop saves where a call ends: not a row of the grid
                    t, rows = t[:-1], rows[:-1]
            return t, rows, status, b - a, place["y"] if done and b == k_to else None

        return more

    y0 = start_state(model, q0, qd0)
    return chunked(model, y0, g, chunk, advance, progress, max_violation, watch, steps_per_call)


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


class Effort(NamedTuple):
    """What an integration took: steps accepted and rejected (None: not reported, as by SciPy's
    solve_ivp), GPME solves (right-hand sides), Jacobians, LU factorizations and the constraint
    evaluations of generalized-α's projection onto the constraints (its Newton iterations on Φ
    and one velocity correction a step). The compiled loops add to an int64 array of
    :data:`COUNTS` entries in this order."""

    steps: int | None
    rejected: int | None
    solves: int
    jacobians: int
    factorizations: int
    projections: int = 0

    def describe(self) -> str:
        """One phrase for a run's summary."""
        steps = "steps not reported" if self.steps is None else f"{self.steps} steps ({self.rejected} rejected)"
        projected = f", {self.projections} constraint evaluations projecting" if self.projections else ""
        return (f"{steps}, {self.solves} GPME solves, {self.jacobians} Jacobians, "
                f"{self.factorizations} LU factorizations{projected}")


#: Entries of the counts array the compiled loops add to (see :class:`Effort`): generalized-α
#: all of them, the adaptive loops (dop853, radau) all but the projection's.
COUNTS = len(Effort._fields)
ADAPTIVE_COUNTS = Effort._fields.index("projections")


def rk4_effort(t, t0: float, dt: float) -> Effort:
    """The :class:`Effort` of an RK4 run on :func:`grid` with step ``dt`` whose last saved state
    is at ``t[-1]`` (s): four GPME solves a step."""
    steps = math.ceil((float(t[-1]) - t0) / dt - STEP_ROUND_OFF) if len(t) else 0
    return Effort(steps, 0, 4 * steps, 0, 0)


#: Defaults of the adaptive methods' tolerances (relative, and absolute in the units of q and q̇):
#: at these, DOP853 meets the reference case's q(10 s) to about 1e-7 (benchmarks/integrators.py).
RTOL, ATOL = 1e-8, 1e-10


def dop853(model, q0, qd0, t_end, save_dt, t0=0.0, rtol=RTOL, atol=ATOL, progress=None, max_violation=None,
           watch=None, steps_per_call=None):
    """DOP853 (Dormand–Prince 8(5,3), adaptive) in the compiled loop, from ``t0`` to ``t_end`` (s),
    saving on :func:`grid` with interval ``save_dt`` (s) by its dense output of order 7, driven by
    :func:`chunked` (``steps_per_call``: see there). ``rtol``, ``atol``: the tolerances of each
    step's error in ``q`` and ``q̇``. Returns ``(t, y, outcome, effort)``, ``effort`` an :class:`Effort`."""
    return _compiled_adaptive("dop853", model, q0, qd0, t_end, save_dt, t0, rtol, atol, progress, max_violation,
                              watch, steps_per_call)


def radau(model, q0, qd0, t_end, save_dt, t0=0.0, rtol=RTOL, atol=ATOL, progress=None, max_violation=None,
          watch=None, steps_per_call=None):
    """Radau IIA of order 5 (implicit, Hairer's RADAU5, with the GPME's Jacobians) in the compiled
    loop, as :func:`dop853` (same arguments and results), saving between steps by the polynomial of
    degree 4 whose derivative passes through the rates at the step's start and its three stages.
    Its steps are not bound by the stiff modes."""
    return _compiled_adaptive("radau", model, q0, qd0, t_end, save_dt, t0, rtol, atol, progress, max_violation,
                              watch, steps_per_call)


def _compiled_adaptive(method, model, q0, qd0, t_end, save_dt, t0, rtol, atol, progress, max_violation, watch,
                       steps_per_call=None):
    """The adaptive compiled loop ``method`` ("dop853" or "radau", a method of the model with
    :meth:`gpmegen.runtime.model.LoadedModel.dop853`'s interface) driven by :func:`chunked` on the
    save grid, its step carried across the chunks, its place within a chunk across the calls.
    Returns ``(t, y, outcome, effort)``."""
    check_start(model, t0, q0, qd0)
    if not (rtol > 0 and atol >= 0):
        raise ValueError(f"need rtol > 0 and atol >= 0, got rtol = {rtol}, atol = {atol}")
    g = grid(t0, t_end, save_dt)
    chunk = max(1, int(round(CHUNK_SECONDS / save_dt)))
    counts = np.zeros(COUNTS, dtype=np.int64)
    step = np.zeros(1)  # the step to try next, carried across chunks (0: chosen at the start)

    def advance(model, y, k_from, k_to):
        t_save = np.array([g.time(k) for k in range(k_from + 1, k_to + 1)])
        memory, saved = model.loop_memory(method), [0]

        def more(max_steps):
            taken = counts[0] + counts[1]
            rows, status = getattr(model, method)(g.time(k_from), y, t_save, rtol, atol, step, counts, memory,
                                                  max_steps, saved[0])
            t = t_save[saved[0]:saved[0] + len(rows)]
            saved[0] += len(rows)
            finished = status == SolveStatus.OK and saved[0] == len(t_save)
            return t, rows, status, int(counts[0] + counts[1] - taken), rows[-1] if finished else None

        return more

    y0 = start_state(model, q0, qd0)
    t, y, outcome = chunked(model, y0, g, chunk, advance, progress, max_violation, watch, steps_per_call)
    return t, y, outcome, Effort(*(int(c) for c in counts))


#: The adaptive methods in the compiled loop, by name.
ADAPTIVE = {"dop853": dop853, "radau": radau}


#: Default numerical damping of generalized-α: the spectral radius at h ω → ∞. 0.9 damps what the
#: step cannot resolve (the sdes' kHz modes at h = 1e-3 s lose 10 % a step) and leaves the motion
#: below 0.1/h almost untouched, as flexible multibody codes default to (0.8-0.9).
RHO_INF = 0.9


def genalpha(model, q0, qd0, t_end, dt, save_dt, rho_inf=RHO_INF, t0=0.0, progress=None, max_violation=None,
             watch=None, project=True, steps_per_call=None):
    """Generalized-α (Chung–Hulbert, second order, numerical damping ``rho_inf``) in the compiled
    loop with step ``dt`` (s) on :func:`grid`, modified Newton on q̈ with the GPME's Jacobians,
    saving on the grid of interval ``save_dt`` (s) (cubic Hermite between steps), driven by
    :func:`chunked`. With ``project`` (every run of ``simulate``; False only to measure what it
    does), each step's end is put back onto the position constraints (Newton on Φ = 0 to 1e-12)
    and q̇ onto ``D q̇ + Φ_t = 0`` and first-order ``Ψ = 0``: the Baumgarte-stabilized GPME
    alone drifts to 1e-5 at the steps this method is for. ``steps_per_call``: see :func:`chunked`.
    Returns ``(t, y, outcome, effort)``."""
    check_start(model, t0, q0, qd0)
    if not 0.0 <= rho_inf <= 1.0:
        raise ValueError(f"need 0 <= rho_inf <= 1, got {rho_inf}")
    g, saves = grid(t0, t_end, dt), grid(t0, t_end, save_dt)
    save_times = np.array([saves.time(k) for k in range(1, saves.n_steps + 1)])
    chunk = max(1, int(round(CHUNK_SECONDS / dt)))
    n = model.n_dof
    counts = np.zeros(COUNTS, dtype=np.int64)
    n_r = n + len(model.controller_names)   # Newton's unknowns: q̈ and the controller states
    memory = {"a": np.full(n, np.nan), "S": np.zeros((n_r, n_r)), "pivot": np.zeros(n_r, dtype=np.intc),
              "have": np.zeros(1, dtype=np.intc)}

    def advance(model, y, k_from, k_to):
        carry, place = np.array(y, dtype=float), [k_from]

        def more(max_steps):
            a = place[0]
            b = min(k_to, a + max_steps)
            inside = save_times[(save_times > g.time(a)) & (save_times <= g.time(b))]
            rows, status = model.genalpha(g, a, b, rho_inf, project, carry, memory, inside, counts)
            place[0] = b
            return inside[:len(rows)], rows, status, b - a, carry if b == k_to else None

        return more

    y0 = start_state(model, q0, qd0)
    t, y, outcome = chunked(model, y0, g, chunk, advance, progress, max_violation, watch, steps_per_call)
    return t, y, outcome, Effort(*(int(c) for c in counts))


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


#: The methods that take steps above RK4's stable one: they choose their own.
LONG_STEPS = ("--method genalpha (implicit, in C), radau (implicit, adaptive, in C), dop853 (adaptive, in C) or "
              "scipy-radau (implicit)")


def unstable_step(dt: float, values) -> str | None:
    """Why RK4 at step ``dt`` (s) would blow up on the linearized motion of eigenvalues ``values``
    (1/s, dampers included: :func:`gpmegen.analysis.post.modes.motion_eigenvalues`), with the stable step
    (:func:`gpmegen.runtime.stability.stable_step`), the eigenvalue that sets it and the methods
    that take the step asked for; None when ``dt`` is stable."""
    from .stability import stable_step  # SciPy's optimize, loaded when a step is checked, not at start-up

    stable, value = stable_step(values)
    if dt <= stable:
        return None
    undamped = value.real > -1e-6 * abs(value)
    real = 0.0 if undamped else value.real
    kind = ("undamped" if undamped else "overdamped" if abs(value.imag) <= 1e-6 * abs(value) else
            f"damping ratio {-value.real / abs(value):.3g}")
    return (f"--dt {dt:g} s is above RK4's stable step {stable:.3g} s (set by the eigenvalue {real:.4g} ± "
            f"{abs(value.imag):.4g}j 1/s of the motion linearized at the start, {abs(value) / (2 * math.pi):.4g} Hz, "
            f"{kind}): use --dt {stable:.2g} or less, or {LONG_STEPS}")


#: Integrators that run only in the generated C loops (not the NumPy backend, nor the actuated
#: realization, which runs compiled in RK4 alone).
COMPILED = ("dop853", "genalpha", "radau")


def compiled_only(method: str, backend: str, actuated: bool) -> str | None:
    """Why ``method`` cannot run on ``backend`` ("c" or "numpy") with or without an
    ``actuated`` realization (one line with the fix), or None when it can."""
    if method not in COMPILED:
        return None
    if backend != "c":
        return f"--method {method} runs in the compiled C loop: use --backend c (it needs a C compiler)"
    if actuated:
        return f"--method {method} integrates the ideal GPME only: use --method rk4 for an actuated realization"
    return None


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


#: The SciPy methods still offered by name (``--method scipy-radau``): Radau IIA of order 5 with
#: its collocation polynomial as dense output, on the model's right-hand side called from Python.
SCIPY = {"scipy-radau": "Radau"}


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
