"""The actuated realization's calls of a model's C library (``gpmegen/csrc/actuated.c``: the
``(n + m)``-row system by dense LU): its solve at one state and its compiled RK4 and DOP853 loops. A mixin of
:class:`gpmegen.runtime.cmodel.CEvaluator`, apart from it because it is a concern of its own."""

from __future__ import annotations

import numpy as np

from ..status import SolveStatus


class CActuated:
    """The actuated entries of :class:`gpmegen.runtime.cmodel.CEvaluator` (a mixin of it)."""

    def actuated_motion(self, t, q, qd, model):
        self._check_stack("actuated")
        n, m = self.n, len(model.constraint_names)
        _, q_c, qd_c = self._state(q, qd)
        qdd, u, M, f = np.empty(n), np.empty(max(m, 1)), np.empty((n, n)), np.empty(n)
        ptr = self._ptr
        status = self.lib.actuated_motion(float(t), q_c, qd_c, self._params(model.p), self._actuator_indices(model),
                                          ptr(qdd), ptr(u), ptr(M), ptr(f))
        if status == SolveStatus.SINGULAR:
            return None
        if status:
            raise self._failure(status, t)
        return qdd, u[:m], M, f

    def actuated_rk4(self, model, g, k_from, k_to, save_every, y0):
        self._check_stack("actuated_rk4")
        return self._steps(self.lib.rk4_actuated, model, g, k_from, k_to, save_every, y0,
                           self._actuator_indices(model))

    def actuated_dop853(self, model, t_a, y_a, t_save, rtol, atol, step, counts, memory, max_steps, first):
        """:meth:`~gpmegen.runtime.model.LoadedModel.dop853` of ``model``'s actuated realization in
        the compiled loop (its arguments and results)."""
        self._check_stack("actuated_dop853")
        indices = self._actuator_indices(model)

        def entry(*arguments):   # the ideal entry's arguments, the actuators in place of the partition's two
            return self.lib.dop853_actuated(*arguments[:10], indices, *arguments[12:])

        return self._adaptive(entry, model, t_a, y_a, t_save, rtol, atol, step, counts, memory, max_steps, first,
                              partitioned=False)

    def _actuator_indices(self, model):
        """``model``'s actuated coordinates as C ints (one at least: C has no empty arrays)."""
        return self.ffi.from_buffer("int[]", np.array(list(model.actuators) or [0], dtype=np.intc))
