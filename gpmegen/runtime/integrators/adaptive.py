"""The adaptive loops in C (DOP853 and Radau IIA: one interface) driven on the save grid, and
the tolerances they take."""

from __future__ import annotations

import numpy as np

from ...status import SolveStatus
from .base import COUNTS, TOLERANCES, Effort, Integrator
from .loop import CHUNK_SECONDS, check_start, chunked, grid, start_state


def compiled_adaptive(integrator, model, q0, qd0, t_end, save_dt, t0, rtol, atol, progress, max_violation, watch,
                      steps_per_call=None):
    """The adaptive compiled loop of ``integrator`` (its ``entry`` a method of the model with
    :meth:`gpmegen.runtime.model.LoadedModel.dop853`'s interface) driven by :func:`chunked` on the
    save grid, its step carried across the chunks, its place within a chunk across the calls.
    Returns ``(t, y, outcome, effort)``."""
    method = integrator.entry
    integrator.check_model(model)
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



class CompiledAdaptive(Integrator):
    """An adaptive loop in C of :meth:`gpmegen.runtime.model.LoadedModel.dop853`'s interface (the
    model's method of the integrator's name), to ``rtol`` and ``atol``, saving on the save grid."""

    fixed_step = False
    compiled = c_loop = chunked = True
    options = TOLERANCES

    def run(self, model, q0, qd0, spec, progress=None, watch=None):
        return compiled_adaptive(self, model, q0, qd0, spec.t_end, spec.save_interval, 0.0, spec.rtol, spec.atol,
                                 progress, spec.max_violation, watch)
