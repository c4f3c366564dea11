"""The C backend: a generated model whose functions, GPME solve and RK4 loop run compiled.

:class:`CEvaluator` is the :class:`gpmegen.runtime.evaluator.Evaluator` over the compiled library;
:class:`CModel` is a :class:`LoadedModel` that evaluates through it (same methods, shapes and
units). The NumPy module of the same folder still supplies the model's constants (coordinates,
parameters, points, …).
"""

from __future__ import annotations

import threading
from pathlib import Path
from types import ModuleType

import numpy as np

from ..errors import BuildError, ModelError, SimulationError
from ..folder import read_verified
from ..status import SolveStatus
from . import ccompile, cprobe, cstack, fastcall
from .cactuated import CActuated
from .evaluator import TRANSFORM_FUNCTIONS, NumpyEvaluator, vector
from .integrators.base import ADAPTIVE_COUNTS, COUNTS
from .model import LoadedModel

#: The number of coordinates from which a single fast call lets other threads run while its C
#: does. Releasing and taking back the GIL costs about 0.05 µs a call: 5% of the C at n_rfe = 5
#: (15 coordinates, 1 µs), under 1% from 30 (5 µs and more), where threads can gain.
RELEASE_GIL_FROM = 30

#: The tables whose pointers each loaded library holds (library path -> arrays), kept alive here.
_SIGNAL_ARRAYS: dict = {}


class CModel(LoadedModel):
    """A generated model evaluated by its compiled C file (``<folder>/model.c``, compiled only
    when it has the sha256 the folder's manifest records; else StaleModelError gives
    ``<rebuild> --force`` as the fix).

    ``progress`` (a callable taking one line) hears about a compile as it runs.
    ``compile_seconds`` is the compiler's wall time for the library in use (recorded when it
    was built, also when it was reused from the cache); ``compiled`` says whether this process
    built it.
    """

    def __init__(self, module: ModuleType, params: dict | None = None, backend: str = "c", folder=None,
                 *, flags=ccompile.DEFAULT_FLAGS, cache=None, rebuild="gpmegen build", requirements=(), progress=None):
        if folder is None:
            raise BuildError("the C backend needs the generated folder holding model.c")
        evaluator = CEvaluator(module, folder, flags, cache, rebuild, progress)
        super().__init__(module, params, "c", folder, requirements, evaluator)
        self.ffi, self.lib, self.library = evaluator.ffi, evaluator.lib, evaluator.library
        self.compiled = self.library.compiled
        self.compile_seconds = self.library.compile_seconds

    def with_params(self, **overrides) -> CModel:
        """The same model with some parameter values changed; shares the loaded library."""
        other = super().with_params(**overrides)
        other.compiled = False  # nothing was compiled for it
        return other


class CEvaluator(CActuated):
    """The generated functions, GPME solve and RK4 loop of ``<folder>/model.c``, compiled and
    loaded (an :class:`gpmegen.runtime.evaluator.Evaluator`)."""

    def __init__(self, module: ModuleType, folder, flags, cache, rebuild, progress=None):
        source = Path(folder) / "model.c"
        # compiled from the very text checked against the manifest, never read again
        text = read_verified(folder, source.name, rebuild)
        module_path = Path(folder) / "model_numpy.py"
        self.ffi, self.lib, self.library = ccompile.load_library(
            source, flags, cache, expect_hash=module.INPUT_HASH, text=text,
            header=read_verified(folder, ccompile.HEADER, rebuild),
            check=lambda library: cprobe.check_in_child(library, source, module_path), progress=progress)
        self.model_name = module.MODEL
        self.n, self.m, self.n_points = len(module.COORDINATES), len(module.CONSTRAINTS), len(module.POINTS)
        # p ends with the controller states (a model without has no CONTROLLERS)
        self.n_controllers = len(getattr(module, "CONTROLLERS", ()))
        self.n_parameters = len(module.PARAMETERS) + self.n_controllers
        self.n_bodies = len(getattr(module, "BODIES", ()))
        self.n_forces = len(getattr(module, "FORCES", ()))
        self.n_limited = len(getattr(module, "LIMITED_DRIVES", ()))
        if self.lib.n_dof() != self.n or self.lib.n_parameters() != self.n_parameters:
            raise BuildError(f"{source} does not match {module_path}; rebuild with 'gpmegen build --force'")
        self.shape = (self.n,)
        self._exact_jacobians = hasattr(module, "gpme_residual_jacobians")
        self._solve_fits = False  # a single solve's stack checked against the limit (once)
        # single calls checked and made in C (see fastcall.py); None: through cffi, and why
        self._fast, self.fastcall_unavailable = fastcall.extension(cache, progress)
        self._partition_c = (None, None, None, None)
        self._params_c = (None, None)
        self._scratch = threading.local()
        self._numpy_signals = NumpyEvaluator(module)

    # --- marshalling ------------------------------------------------------------------------
    # A call costs what the C costs plus this marshalling (a few 0.1 µs per array), so what can be
    # done once is: the parameters' and the partition's C views are kept for the last model asked,
    # and the state of a single call goes into C buffers of the calling thread (cffi releases the
    # GIL, so threads must not share them) rather than into a new cffi view per array.
    def _vec(self, x, what):
        return vector(x, self.n, what)

    def _ptr(self, a):
        # from_buffer is the cheapest way to hand cffi a contiguous float64 array (no copy).
        return self.ffi.from_buffer("double[]", a)

    def _state(self, q, qd, velocities=True):
        """The thread's C buffers holding q and qd (n,) (qd not read without ``velocities``),
        checked and converted: (scratch, q pointer, qd pointer)."""
        scratch = self._scratch
        try:
            view = scratch.q
        except AttributeError:
            view = self._new_scratch(scratch)
        if type(q) is not np.ndarray or q.shape != self.shape:
            q = vector(q, self.n, "q")
        view[...] = q
        if velocities:
            if type(qd) is not np.ndarray or qd.shape != self.shape:
                qd = vector(qd, self.n, "qd")
            scratch.qd[...] = qd
        return scratch, scratch.q_c, scratch.qd_c

    def _new_scratch(self, scratch):
        n = self.n
        buffer = self.ffi.new("double[]", 3 * n)  # q, qd, qdd
        view = np.frombuffer(self.ffi.buffer(buffer), dtype=float)
        scratch.buffer = buffer
        scratch.q, scratch.qd, scratch.qdd = view[:n], view[n:2 * n], view[2 * n:]
        scratch.q_c, scratch.qd_c, scratch.qdd_c = buffer, buffer + n, buffer + 2 * n
        return scratch.q

    def _params(self, p):
        last, pointer = self._params_c
        if p is last:  # the model's own frozen array: its view stays valid while it is held here
            return pointer
        array = np.ascontiguousarray(p, dtype=float)
        if array.shape != (self.n_parameters,):
            raise ValueError(f"p must have shape ({self.n_parameters},), got {array.shape}")
        pointer = self.ffi.from_buffer("double[]", array) if array.size else self.ffi.new("double[]", 1)
        if array is p and not p.flags.writeable:
            self._params_c = (p, pointer)
        return pointer

    def _partition_pointers(self, model):
        # C views of the model's partition, kept for the last one asked (a run uses one at a time)
        # when its index arrays are frozen, so that the same objects mean the same partition
        last_dep, last_ind, dep_c, ind_c = self._partition_c
        if model.dependent is last_dep and model.independent is last_ind and dep_c is not None:
            return dep_c, ind_c
        dep_c, ind_c = (self.ffi.from_buffer("int[]", part) for part in self._partition(model))
        if all(isinstance(a, np.ndarray) and not a.flags.writeable for a in (model.dependent, model.independent)):
            self._partition_c = (model.dependent, model.independent, dep_c, ind_c)
        return dep_c, ind_c

    def _partition(self, model):
        """The model's dependent and independent coordinate indices, checked, as C ints (one
        at least: C has no empty arrays)."""
        if model.dependent is None or model.independent is None:
            raise ModelError(
                f"model {self.model_name} has no dependent coordinates chosen yet, so the GPME cannot "
                f"split q; set the model's 'dependent' coordinates"
            )
        dep, ind = (tuple(np.asarray(part).tolist()) for part in (model.dependent, model.independent))
        if sorted(dep + ind) != list(range(self.n)) or (len(dep) > self.m if model.redundant else len(dep) != self.m):
            raise ModelError(
                f"dependent {dep} and independent {ind} must split the {self.n} coordinates, with one "
                f"dependent coordinate per constraint ({self.m})"
            )
        return tuple(np.array(part or (0,), dtype=np.intc) for part in (dep, ind))

    def set_signals(self, tables):
        """Set the library's tables of the signals (and the NumPy module's, which sizes the
        outputs and serves what the library does not): pointers to the tables' arrays, which
        this evaluator keeps."""
        self._numpy_signals.set_signals(tables)
        kept = []
        for k, table in enumerate(tables):
            t, y = (np.ascontiguousarray(a, dtype=float) for a in (table.t, table.y))
            t_c, y_c = self.ffi.from_buffer("double[]", t), self.ffi.from_buffer("double[]", y)
            if self.lib.set_signal(k, len(t), t_c, y_c) != 0:
                raise SimulationError(f"model {self.model_name}: the library refused the table of signal "
                                      f"{table.name!r}; rebuild it with 'gpmegen build --force'")
            kept.append((t, y, t_c, y_c))
        # kept with the library (one per process and path), not this evaluator: another model of
        # the same library may outlive it and still call the signals
        _SIGNAL_ARRAYS[str(self.library.path)] = tuple(kept)

    # --- the generated functions -------------------------------------------------------------
    def mass_matrix(self, q, p):
        _, q_c, _ = self._state(q, None, velocities=False)
        M = np.empty((self.n, self.n))
        self.lib.mass_matrix(q_c, self._params(p), self._ptr(M))
        return M

    def forces(self, t, q, qd, p):
        _, q_c, qd_c = self._state(q, qd)
        f = np.empty(self.n)
        self.lib.forces(float(t), q_c, qd_c, self._params(p), self._ptr(f))
        return f

    def static_residual(self, q, p):
        q = self._vec(q, "q")
        r = np.empty(self.n)
        self.lib.static_residual(self._ptr(q), self._params(p), self._ptr(r))
        return r

    def stiffness_jacobian(self, q, p):
        q = self._vec(q, "q")
        K = np.empty((self.n, self.n))
        self.lib.stiffness_jacobian(self._ptr(q), self._params(p), self._ptr(K))
        return K

    def drive_forces(self, t, q, qd, p):
        _, q_c, qd_c = self._state(q, qd)
        Q = np.empty(self.n)
        self.lib.drive_forces(float(t), q_c, qd_c, self._params(p), self._ptr(Q))
        return Q

    def force_elements(self, t, q, qd, p):
        _, q_c, qd_c = self._state(q, qd)
        F = np.empty((max(1, self.n_forces), 3))
        self.lib.force_elements(float(t), q_c, qd_c, self._params(p), self._ptr(F))
        return F[:self.n_forces]

    def controller_rates(self, t, q, qd, p):
        _, q_c, qd_c = self._state(q, qd)
        rates = np.empty(self.n_controllers)
        self.lib.controller_rates(float(t), q_c, qd_c, self._params(p), self._ptr(rates))
        return rates

    def controller_initial(self, p):
        z0 = np.empty(self.n_controllers)
        self.lib.controller_initial(self._params(p), self._ptr(z0))
        return z0

    def drive_limits(self, t, q, qd, p):
        _, q_c, qd_c = self._state(q, qd)
        L = np.empty((max(1, self.n_limited), 2))
        self.lib.drive_limits(float(t), q_c, qd_c, self._params(p), self._ptr(L))
        return L[:self.n_limited]

    def points(self, q, p):
        q = self._vec(q, "q")
        P = np.empty((max(1, self.n_points), 3))
        self.lib.points(self._ptr(q), self._params(p), self._ptr(P))
        return P[:self.n_points]

    def transforms(self, q, p, kind):
        q = self._vec(q, "q")
        order = tuple(TRANSFORM_FUNCTIONS).index(kind)  # T, T_i, T_ij: one more coordinate axis each
        T = np.empty((max(1, self.n_bodies),) + (self.n,) * order + (4, 4))  # one body at least: C has no empty arrays
        getattr(self.lib, TRANSFORM_FUNCTIONS[kind])(self._ptr(q), self._params(p), self._ptr(T))
        return T[:self.n_bodies]

    def constraint_terms(self, t, q, qd, p):
        _, q_c, qd_c = self._state(q, qd)
        phi, phid, D, gamma = self._constraint_outputs(())
        self.lib.constraint_terms(float(t), q_c, qd_c, self._params(p), *map(self._ptr, (phi, phid, D, gamma)))
        return phi[:self.m], phid[:self.m], D[:self.m], gamma[:self.m]

    def _constraint_outputs(self, batch: tuple):
        """Empty Φ, Φ̇, D, γ with leading axes ``batch``, one row at least (C has no empty arrays)."""
        k = max(1, self.m)
        return np.empty(batch + (k,)), np.empty(batch + (k,)), np.empty(batch + (k, self.n)), np.empty(batch + (k,))

    def energies(self, q, qd, p):
        q, qd = self._vec(q, "q"), self._vec(qd, "qd")
        e = np.empty(3)
        self.lib.energies(self._ptr(q), self._ptr(qd), self._params(p), self._ptr(e))
        return e

    def gpme_terms(self, t, q, qd, p):
        q, qd = self._vec(q, "q"), self._vec(qd, "qd")
        n, m = self.n, self.m
        M, f = np.empty((n, n)), np.empty(n)
        phi, phid, D, gamma = (np.empty(max(1, m)), np.empty(max(1, m)), np.empty((max(1, m), n)),
                               np.empty(max(1, m)))
        self.lib.gpme_terms(float(t), self._ptr(q), self._ptr(qd), self._params(p), self._ptr(M), self._ptr(f),
                            self._ptr(phi), self._ptr(phid), self._ptr(D), self._ptr(gamma))
        return M, f, phi[:m], phid[:m], D[:m], gamma[:m]

    # --- the GPME solve and the RK4 loop ------------------------------------------------------
    def _solve(self, t, q, qd, model, M=None, f=None):
        if not self._solve_fits:
            self._check_stack("solve")
            self._solve_fits = True
        scratch, q_c, qd_c = self._state(q, qd)
        dep, ind = self._partition_pointers(model)
        if M is None:
            status = self.lib.gpme_accelerations(float(t), q_c, qd_c, self._params(model.p), dep, ind, scratch.qdd_c)
        else:
            status = self.lib.gpme_motion(float(t), q_c, qd_c, self._params(model.p), dep, ind, scratch.qdd_c,
                                          self._ptr(M), self._ptr(f))
        if status:
            raise self._failure(status, t)
        return scratch.qdd.copy()

    @staticmethod
    def _failure(status, t, where=""):
        """The SimulationError of a failed GPME solve (``status`` a SolveStatus) at time ``t``."""
        if status == SolveStatus.NONFINITE:
            return SimulationError(
                f"the GPME terms (M, f or D) are not finite at t = {float(t):g} s{where}: check the state and the "
                f"parameter values"
            )
        return SimulationError(
            f"the GPME system is singular at t = {float(t):g} s{where}: the constraints are not independent in "
            f"this configuration (their Jacobian D lost rank) or M is singular on the motions they allow; "
            f"start from a configuration where the constraints are independent"
        )

    def motion(self, t, q, qd, model):
        M, f = np.empty((self.n, self.n)), np.empty(self.n)
        return self._solve(t, q, qd, model, M, f), M, f

    def accelerations(self, t, q, qd, model):
        return self._solve(t, q, qd, model)

    def accelerations_call(self, model, checked):
        """``(t, q, qd) -> q̈`` of ``model`` (its parameter values and partition, copied now) made
        in C by the fast-call extension, which hands every call not of its fast form to
        ``checked``; None when the extension is not available."""
        if self._fast is None:
            return None
        self._check_stack("solve")
        address = int(self.ffi.cast("uintptr_t", self.lib.gpme_accelerations))
        return self._fast.Caller(address, self.n, np.ascontiguousarray(model.p, dtype=float), *self._partition(model),
                                 checked, self._failure, self.lib, self.n >= RELEASE_GIL_FROM)

    def residual_jacobians(self, t, q, qd, a, lam, p):
        q, qd, a = self._vec(q, "q"), self._vec(qd, "qd"), self._vec(a, "a")
        n, m = self.n, self.m
        lam = np.ascontiguousarray(lam, dtype=float) if m else np.zeros(1)
        F_q, F_qd, C_q, C_qd = np.empty((n, n)), np.empty((n, n)), np.empty((max(1, m), n)), np.empty((max(1, m), n))
        self.lib.gpme_residual_jacobians(float(t), self._ptr(q), self._ptr(qd), self._ptr(a), self._ptr(lam),
                                         self._params(p), *map(self._ptr, (F_q, F_qd, C_q, C_qd)))
        return F_q, F_qd, C_q[:m], C_qd[:m]

    def acceleration_jacobians(self, t, q, qd, model):
        # redundant rows (a model that closes loops): the C system takes the independent rows, as
        # gpmegen.runtime.model.redundant_acceleration_jacobians does
        self._check_stack("jacobian")
        scratch, q_c, qd_c = self._state(q, qd)
        dep, _ = self._partition_pointers(model)
        A_q, A_qd = np.empty((self.n, self.n)), np.empty((self.n, self.n))
        status = self.lib.gpme_jacobian(float(t), q_c, qd_c, self._params(model.p), dep, scratch.qdd_c,
                                        self._ptr(A_q), self._ptr(A_qd))
        if status:
            raise self._failure(status, t)
        return scratch.qdd.copy(), A_q, A_qd

    # --- many states in one call (see gpmegen.runtime.batch) -----------------------------------
    def mass_matrix_batch(self, q, p):
        M = np.empty((len(q), self.n, self.n))
        self.lib.mass_matrix_batch(len(q), self._ptr(q), self._params(p), self._ptr(M))
        return M

    def forces_batch(self, t, q, qd, p):
        f = np.empty((len(q), self.n))
        self.lib.forces_batch(len(q), self._ptr(t), self._ptr(q), self._ptr(qd), self._params(p), self._ptr(f))
        return f

    def constraint_terms_batch(self, t, q, qd, p):
        outputs = self._constraint_outputs((len(q),))
        self.lib.constraint_terms_batch(len(q), self._ptr(t), self._ptr(q), self._ptr(qd), self._params(p),
                                        *map(self._ptr, outputs))
        return tuple(a[:, :self.m] for a in outputs)

    # the functions C has no batched form of: one call per state, stepping pointers through one
    # view of each array (the marshalling of a single call, a few µs, once per array)
    def _each(self, function, out, p, *arrays, t=None):
        """``out`` (N, ...) filled by ``function([t_k,] row_k of each array..., p, out_k)``."""
        params, target = self._params(p), self._ptr(out)
        views = [(self._ptr(a), a.shape[1]) for a in arrays]
        size = out[0].size
        for k in range(len(out)):
            rows = [view + k * width for view, width in views]
            function(*(() if t is None else (float(t[k]),)), *rows, params, target + k * size)
        return out

    def points_batch(self, q, p):
        P = self._each(self.lib.points, np.empty((len(q), max(1, self.n_points), 3)), p, q)
        return P[:, :self.n_points]

    def energies_batch(self, q, qd, p):
        return self._each(self.lib.energies, np.empty((len(q), 3)), p, q, qd)

    def drive_forces_batch(self, t, q, qd, p):
        return self._each(self.lib.drive_forces, np.empty((len(q), self.n)), p, q, qd, t=t)

    def accelerations_batch(self, t, q, qd, model):
        dep, ind = self._partition_pointers(model)
        qdd, status = np.empty((len(q), self.n)), self.ffi.new("int *")
        done = self.lib.gpme_accelerations_batch(len(q), self._ptr(t), self._ptr(q), self._ptr(qd),
                                                 self._params(model.p), dep, ind, self._ptr(qdd), status)
        if status[0]:
            raise self._failure(status[0], t[done], f" (state {done} of the batch)")
        return qdd

    def rk4(self, model, g, k_from, k_to, save_every, y0):
        self._check_stack("rk4")
        return self._steps(self.lib.rk4, model, g, k_from, k_to, save_every, y0, *self._partition_pointers(model))

    def _steps(self, entry, model, g, k_from, k_to, save_every, y0, *choice):
        """A compiled fixed-step loop ``entry`` (``rk4``, ``rk4_actuated``) over steps ``k_from + 1
        … k_to`` of grid ``g`` from ``y0`` (``[q, q̇, w]``, ``w`` the work integrals and controller
        states): ``(t, y, status)`` of the rows saved. ``choice``: the entry's arguments after
        ``p`` that pick the solve (the partition's two, or the actuators)."""
        n = self.n
        q0, qd0, w0 = (np.ascontiguousarray(part) for part in (y0[:n], y0[n:2 * n], y0[2 * n:]))
        n_save = k_to // save_every - k_from // save_every + 2
        t_out, y_out = np.empty(n_save), [np.empty((n_save, n)), np.empty((n_save, n)), np.empty((n_save, len(w0)))]
        n_saved = self.ffi.new("long *")
        status = entry(g.t0, g.dt, g.n_steps, g.t_end, k_from, k_to, save_every, self._ptr(q0), self._ptr(qd0),
                       self._ptr(w0), self._params(model.p), *choice, self._ptr(t_out),
                       *(self._ptr(part) for part in y_out), n_saved)
        k = int(n_saved[0])
        return t_out[:k].copy(), np.column_stack([part[:k] for part in y_out]), SolveStatus(status)

    def dop853(self, model, t_a, y_a, t_save, rtol, atol, step, counts, memory=None, max_steps=0, first=0):
        self._check_stack("dop853")
        return self._adaptive(self.lib.dop853, model, t_a, y_a, t_save, rtol, atol, step, counts, memory, max_steps,
                              first)

    def radau(self, model, t_a, y_a, t_save, rtol, atol, step, counts, memory=None, max_steps=0, first=0):
        self._check_stack("radau")
        return self._adaptive(self.lib.radau, model, t_a, y_a, t_save, rtol, atol, step, counts, memory, max_steps,
                              first)

    def loop_memory(self, method):
        """Zeroed bytes (uint8) for what the adaptive C loop ``method`` ("dop853" or "radau") keeps
        between the calls of one span."""
        return np.zeros(getattr(self.lib, f"{method}_memory_bytes")(), dtype=np.uint8)

    def _adaptive(self, function, model, t_a, y_a, t_save, rtol, atol, step, counts, memory, max_steps, first,
                  partitioned=True):
        """A call of the adaptive C loop ``function`` (dop853 or radau: one interface); its rows
        from ``first`` (the rows the calls before saved) on. Not ``partitioned``: the partition's
        arguments are NULL (the actuated realization's loop takes none)."""
        dep, ind = self._partition_pointers(model) if partitioned else (self.ffi.NULL, self.ffi.NULL)
        y_a, t_save = np.ascontiguousarray(y_a, dtype=float), np.ascontiguousarray(t_save, dtype=float)
        self._check_counts(counts, ADAPTIVE_COUNTS)
        if max_steps and (memory is None or memory.dtype != np.uint8 or not memory.flags.c_contiguous):
            raise TypeError("a call with max_steps needs its memory: contiguous uint8 from loop_memory()")
        y_out = np.empty((len(t_save), len(y_a)))
        n_saved = self.ffi.new("long *")
        status = function(t_a, self._ptr(y_a), len(t_save), self._ptr(t_save), rtol, atol, self._ptr(step),
                          int(max_steps), self.ffi.NULL if memory is None else self.ffi.from_buffer(memory),
                          self._params(model.p), dep, ind, self._ptr(y_out), n_saved,
                          self.ffi.from_buffer("long[]", counts))
        return y_out[first:int(n_saved[0])].copy(), SolveStatus(status)

    def genalpha(self, model, g, k_from, k_to, rho_inf, project, y, memory, t_save, counts):
        self._check_stack("genalpha")
        dep, ind = self._partition_pointers(model)
        self._check_counts(counts, COUNTS)
        t_save = np.ascontiguousarray(t_save, dtype=float)
        y_out = np.empty((len(t_save), len(y)))
        n_saved = self.ffi.new("long *")
        a, S, pivot, have = memory["a"], memory["S"], memory["pivot"], memory["have"]
        if not (y.flags.c_contiguous and y.dtype == float and a.flags.c_contiguous and a.dtype == float
                and S.flags.c_contiguous and pivot.dtype == np.intc and have.dtype == np.intc):
            raise TypeError("y, a and S must be contiguous float64, pivot and have intc")
        if a.shape != (2 * self.n,):
            raise ValueError(f"genalpha needs a ({2 * self.n},): a and the q̈ of the step before, got {a.shape}")
        n_r = self.n + self.n_controllers   # Newton's unknowns: q̈ and the controller states
        if S.shape != (n_r, n_r) or pivot.shape != (n_r,) or len(y) != 2 * self.n + 2 + self.n_controllers:
            raise ValueError(f"genalpha needs y ({2 * self.n + 2 + self.n_controllers},), S ({n_r}, {n_r}) and "
                             f"pivot ({n_r},), got {len(y)}, {S.shape}, {pivot.shape}")
        status = self.lib.genalpha(g.t0, g.dt, g.n_steps, g.t_end, k_from, k_to, rho_inf, int(bool(project)),
                                   self._ptr(y),
                                   self._ptr(a), self._ptr(S), self.ffi.from_buffer("int[]", pivot),
                                   self.ffi.from_buffer("int[]", have), len(t_save),
                                   self._ptr(t_save) if len(t_save) else self.ffi.new("double[]", 1),
                                   self._params(model.p), dep, ind, self._ptr(y_out), n_saved,
                                   self.ffi.from_buffer("long[]", counts))
        return y_out[:int(n_saved[0])].copy(), SolveStatus(status)

    def _check_stack(self, call):
        """Refuse in one line a call of the solver library that would overflow the stack."""
        cstack.check(call, self.n, self.m, self._exact_jacobians, self.model_name, self.n_controllers)

    def _check_counts(self, counts, size):
        if counts.dtype != np.int64 or self.ffi.sizeof("long") != 8 or len(counts) < size:
            raise TypeError(f"counts must be {size} or more int64 (a 64-bit C long)")
