"""The entries of the integrators' loops on a loaded model: RK4 (compiled, or in Python on the
NumPy backend and for the actuated realization there), DOP853, Radau and generalized-α in
the compiled loop, each on the model partitioned at the span's start. A mixin of
:class:`gpmegen.runtime.model.LoadedModel`, whose methods it calls."""

from __future__ import annotations

from typing import TYPE_CHECKING

import numpy as np
from numpy.typing import ArrayLike, NDArray

from ..status import SolveStatus
from .evaluator import (
    Array,
    vector,
)
from .integrators import loop

if TYPE_CHECKING:
    pass


class CompiledLoops:
    """The integrators' loop entries of a :class:`~gpmegen.runtime.model.LoadedModel` (a mixin of it)."""

    def rk4(self, q0: ArrayLike, qd0: ArrayLike, t_end: float, dt: float, save_every: int = 1,
            t0: float = 0.0, w0: ArrayLike | None = None,
            steps: tuple[int, int] | None = None) -> tuple[Array, Array, Array, Array, SolveStatus]:
        """Classical RK4 of the GPME from ``t0`` to ``t_end`` (s) with step ``dt`` (s), on the grid
        of :func:`gpmegen.runtime.integrators.loop.grid`, in one call of the backend's loop (C or Python).

        ``steps = (k_from, k_to)`` integrates only those steps of that grid, from ``q0``, ``qd0``
        (n,) and the work ``w0`` (2,) J at the end of step ``k_from`` (default: all of it, from
        ``t0``), followed by the controller states there (n_z,; ``w0`` None: no work and the
        controller states at their initial values). Saves the start, the state after every
        ``save_every``-th step of the grid and the final state. Returns ``(t, q, qd, w, status)``:
        ``t`` (k,) s, ``q`` and ``qd`` (k, n), ``w`` (k, 2 + n_z) the work of the drive and of
        the constraint forces (of the inputs, with :attr:`actuators`) plus ``w0`` (J), then the
        controller states, ``status`` a
        :class:`gpmegen.status.SolveStatus`, OK when all steps were done, else with the states
        saved before the failure (none when the start is not finite).
        """
        g = loop.grid(t0, t_end, dt)
        k_from, k_to = g.span(steps, save_every)
        w0 = np.concatenate([[0.0, 0.0], self.controller_initial]) if w0 is None else w0
        y0 = np.concatenate([vector(q0, self.n_dof, "q0"), vector(qd0, self.n_dof, "qd0"),
                             vector(w0, 2 + len(self.controller_names), "w0")])
        if len(self.actuators):  # the generated loop's actuated entry, or the Python loop on NumPy
            t, y, status = self.evaluator.actuated_rk4(self, g, k_from, k_to, int(save_every), y0)
        else:
            model = self.partitioned(g.time(k_from), y0[:self.n_dof])  # "auto": chosen at the start
            t, y, status = model.evaluator.rk4(model, g, k_from, k_to, int(save_every), y0)
        n = self.n_dof
        return t, y[:, :n], y[:, n:2 * n], y[:, 2 * n:], status

    def dop853(self, t_a: float, y_a: ArrayLike, t_save: Array, rtol: float, atol: float, step: Array,
               counts: NDArray[np.int64], memory: NDArray[np.uint8] | None = None, max_steps: int = 0,
               first: int = 0) -> tuple[Array, SolveStatus]:
        """DOP853 of the GPME (or, with :attr:`actuators`, of the actuated realization) in the
        compiled loop from ``t_a`` (s) and the augmented state
        ``y_a = [q, q̇, w, z]`` (2n + 2 + n_z,) to ``t_save[-1]``, saving at the increasing instants
        ``t_save`` (k,) s. ``step`` (1,): the step to try first (0: chosen), updated to the one to
        try next; ``counts`` (5,) int64: steps, rejected, GPME solves, Jacobians and LU
        factorizations, added to. ``max_steps`` > 0: the call returns after that many steps
        (accepted or rejected), its place kept in ``memory`` (:meth:`loop_memory`, zero at the
        span's start); calls with the same arguments, ``first`` the rows saved by those before,
        go on from it to the same bits as one call. Returns ``(y, status)``: ``y`` the rows saved
        from ``first`` on (to k when the span is done)."""
        if len(self.actuators):   # the actuated realization's loop (C backend): no partition
            return self.evaluator.actuated_dop853(self, t_a, y_a, t_save, rtol, atol, step, counts, memory, max_steps,
                                                  first)
        model = self.partitioned(t_a, np.asarray(y_a)[:self.n_dof])
        return model.evaluator.dop853(model, t_a, y_a, t_save, rtol, atol, step, counts, memory, max_steps, first)

    def radau(self, t_a: float, y_a: ArrayLike, t_save: Array, rtol: float, atol: float, step: Array,
              counts: NDArray[np.int64], memory: NDArray[np.uint8] | None = None, max_steps: int = 0,
              first: int = 0) -> tuple[Array, SolveStatus]:
        """Radau IIA of order 5 (implicit, Hairer's RADAU5) of the GPME in the compiled loop, with
        the arguments and results of :meth:`dop853`; its LU factorizations counted are the real
        and the complex (n, n) ones of its Newton matrices."""
        model = self.partitioned(t_a, np.asarray(y_a)[:self.n_dof])
        return model.evaluator.radau(model, t_a, y_a, t_save, rtol, atol, step, counts, memory, max_steps, first)

    def loop_memory(self, method: str) -> NDArray[np.uint8]:
        """Zeroed bytes (uint8) for what the adaptive compiled loop ``method`` ("dop853" or
        "radau") keeps between the calls of one span (see :meth:`dop853`)."""
        return self.evaluator.loop_memory(method)

    def genalpha(self, g: loop.Grid, k_from: int, k_to: int, rho_inf: float, project: bool, y: Array,
                 memory: dict[str, np.ndarray], t_save: Array, counts: NDArray[np.int64]) -> tuple[Array, SolveStatus]:
        """Generalized-α of the GPME in the compiled loop over steps ``k_from + 1 … k_to`` of the
        grid ``g`` from the augmented state ``y`` (2n + 2 + n_z,), replaced in place by the state at
        the end; with ``project``, each step's end put back onto the constraints of orders 0 and 1;
        ``memory`` holds the method's state across calls ("a" (2n,): the method's a and the q̈ at
        the start of the step before, NaN at the start; the Newton matrix "S" (n + n_z, n + n_z),
        "pivot" (n + n_z,) intc, "have" (1,) intc), ``counts`` as for
        :meth:`dop853` and (6th) the constraint evaluations of the projection. Saves at the
        increasing instants ``t_save`` (k,) within the steps. Returns ``(rows, status)``."""
        model = self.partitioned(g.time(k_from), np.asarray(y)[:self.n_dof])
        return model.evaluator.genalpha(model, g, k_from, k_to, rho_inf, project, y, memory, t_save, counts)
