"""Classical RK4 with a fixed step, as in the paper: its Python loop (the C one is generated),
its chunked drive, its effort, its stable step and its run estimate."""

from __future__ import annotations

import math

import numpy as np

from ... import limits
from ...errors import EvaluationError, SimulationError
from ...status import SolveStatus
from .base import Effort, Integrator
from .loop import CHUNK_SECONDS, STEP_ROUND_OFF, Grid, check_start, chunked, grid, start_state
from .registry import INTEGRATORS, register, spoken


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


def rk4_effort(t, t0: float, dt: float) -> Effort:
    """The :class:`Effort` of an RK4 run on :func:`grid` with step ``dt`` whose last saved state
    is at ``t[-1]`` (s): four GPME solves a step."""
    steps = math.ceil((float(t[-1]) - t0) / dt - STEP_ROUND_OFF) if len(t) else 0
    return Effort(steps, 0, 4 * steps, 0, 0)


def long_steps() -> str:
    """The registered methods that take steps above RK4's stable one (those not bound by the
    stiff modes, and those that choose their own steps), each with its ``--method`` help phrase,
    in the order registered: ``--method a (…), b (…) or c (…)``."""
    return "--method " + spoken([i.summary for i in INTEGRATORS.values() if i.stiff or not i.fixed_step])


def unstable_step(dt: float, values) -> str | None:
    """Why RK4 at step ``dt`` (s) would blow up on the linearized motion of eigenvalues ``values``
    (1/s, dampers included: :func:`gpmegen.analysis.post.modes.motion_eigenvalues`), with the stable step
    (:func:`gpmegen.runtime.stability.stable_step`), the eigenvalue that sets it and the methods
    that take the step asked for; None when ``dt`` is stable."""
    from ..stability import stable_step  # SciPy's optimize, loaded when a step is checked, not at start-up

    stable, value = stable_step(values)
    if dt <= stable:
        return None
    undamped = value.real > -1e-6 * abs(value)
    real = 0.0 if undamped else value.real
    kind = ("undamped" if undamped else "overdamped" if abs(value.imag) <= 1e-6 * abs(value) else
            f"damping ratio {-value.real / abs(value):.3g}")
    return (f"--dt {dt:g} s is above RK4's stable step {stable:.3g} s (set by the eigenvalue {real:.4g} ± "
            f"{abs(value.imag):.4g}j 1/s of the motion linearized at the start, {abs(value) / (2 * math.pi):.4g} Hz, "
            f"{kind}): use --dt {stable:.2g} or less, or {long_steps()}")


@register
class RK4(Integrator):
    """Fixed-step RK4 (the paper's, the default): in C or NumPy, with or without controller
    states, for the ideal or the actuated realization."""

    name = entry = "rk4"
    summary = "fixed-step rk4 (the paper's, default)"
    c_loop = chunked = saves_on_steps = actuated_loop = True
    frequency = "highest"

    def unstable_step(self, dt, eigenvalues):
        return unstable_step(dt, eigenvalues())

    def run(self, model, q0, qd0, spec, progress=None, watch=None):
        t, y, outcome = rk4(model, q0, qd0, spec.t_end, spec.dt, spec.save_every, progress=progress,
                            max_violation=spec.max_violation, watch=watch)
        return t, y, outcome, rk4_effort(t, 0.0, spec.dt)

    def estimate(self, n_dof, t_end, dt, omega, backend):
        n = limits.steps(t_end, dt)
        where = "in C" if backend == "c" else "in NumPy"
        return limits.Integration(n, n * limits.interpolate(limits.STEP_SECONDS["c" if backend == "c" else "numpy"],
                                                            n_dof), False,
                                  f"{n:.3g} RK4 steps of n_dof = {n_dof} {where}")
