"""The C backend: a generated model whose functions, GPME solve and RK4 loop run compiled.

:class:`CEvaluator` is the :class:`gpmegen.runtime.model.Evaluator` over the compiled library;
:class:`CModel` is a :class:`LoadedModel` that evaluates through it (same methods, shapes and
units). The NumPy module of the same folder still supplies the model's constants (coordinates,
parameters, points, …).
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import numpy as np

from ..errors import BuildError, ModelError, SimulationError
from ..folder import read_verified
from ..status import SolveStatus
from . import ccompile, cprobe
from .model import LoadedModel, vector


class CModel(LoadedModel):
    """A generated model evaluated by its compiled C file (``<folder>/model.c``, compiled only
    when it has the sha256 the folder's manifest records; else StaleModelError gives
    ``<rebuild> --force`` as the fix).

    ``compile_seconds`` is the compiler's wall time for the library in use (recorded when it
    was built, also when it was reused from the cache); ``compiled`` says whether this process
    built it.
    """

    def __init__(self, module: ModuleType, params: dict | None = None, backend: str = "c", folder=None,
                 *, flags=ccompile.DEFAULT_FLAGS, cache=None, rebuild="gpmegen build", requirements=()):
        if folder is None:
            raise BuildError("the C backend needs the generated folder holding model.c")
        evaluator = CEvaluator(module, folder, flags, cache, rebuild)
        super().__init__(module, params, "c", folder, requirements, evaluator)
        self.ffi, self.lib, self.library = evaluator.ffi, evaluator.lib, evaluator.library
        self.compiled = self.library.compiled
        self.compile_seconds = self.library.compile_seconds

    def with_params(self, **overrides) -> CModel:
        """The same model with some parameter values changed; shares the loaded library."""
        other = super().with_params(**overrides)
        other.compiled = False  # nothing was compiled for it
        return other


class CEvaluator:
    """The generated functions, GPME solve and RK4 loop of ``<folder>/model.c``, compiled and
    loaded (an :class:`gpmegen.runtime.model.Evaluator`)."""

    def __init__(self, module: ModuleType, folder, flags, cache, rebuild):
        source = Path(folder) / "model.c"
        # compiled from the very text checked against the manifest, never read again
        text = read_verified(folder, source.name, rebuild)
        module_path = Path(folder) / "model_numpy.py"
        self.ffi, self.lib, self.library = ccompile.load_library(
            source, flags, cache, expect_hash=module.INPUT_HASH, text=text,
            header=read_verified(folder, ccompile.HEADER, rebuild),
            check=lambda library: cprobe.check_in_child(library, source, module_path))
        self.model_name = module.MODEL
        self.n, self.m, self.n_points = len(module.COORDINATES), len(module.CONSTRAINTS), len(module.POINTS)
        self.n_parameters = len(module.PARAMETERS)
        if self.lib.n_dof() != self.n or self.lib.n_parameters() != self.n_parameters:
            raise BuildError(f"{source} does not match {module_path}; rebuild with 'gpmegen build --force'")
        self._partition_c = None

    # --- marshalling ------------------------------------------------------------------------
    def _vec(self, x, what):
        return vector(x, self.n, what)

    def _ptr(self, a):
        # from_buffer is the cheapest way to hand cffi a contiguous float64 array (no copy).
        return self.ffi.from_buffer("double[]", a)

    def _params(self, p):
        p = np.ascontiguousarray(p, dtype=float)
        if p.shape != (self.n_parameters,):
            raise ValueError(f"p must have shape ({self.n_parameters},), got {p.shape}")
        return self.ffi.from_buffer("double[]", p) if p.size else self.ffi.new("double[]", 1)

    def _partition_pointers(self, model):
        # C copies of the model's partition, kept for the last one asked (a run uses one at a time)
        if model.dependent is None or model.independent is None:
            raise ModelError(
                f"model {self.model_name} has no dependent coordinates chosen yet, so the GPME cannot "
                f"split q; set the model's 'dependent' coordinates"
            )
        key = (tuple(np.asarray(model.dependent).tolist()), tuple(np.asarray(model.independent).tolist()))
        if self._partition_c is None or self._partition_c[0] != key:
            dep, ind = key
            if sorted(dep + ind) != list(range(self.n)) or len(dep) != self.m:
                raise ModelError(
                    f"dependent {dep} and independent {ind} must split the {self.n} coordinates, with one "
                    f"dependent coordinate per constraint ({self.m})"
                )
            dep_c = self.ffi.new("int[]", max(1, len(dep)))
            ind_c = self.ffi.new("int[]", max(1, len(ind)))
            dep_c[0:len(dep)] = list(dep)
            ind_c[0:len(ind)] = list(ind)
            self._partition_c = (key, dep_c, ind_c)
        return self._partition_c[1], self._partition_c[2]

    # --- the generated functions -------------------------------------------------------------
    def mass_matrix(self, q, p):
        q = self._vec(q, "q")
        M = np.empty((self.n, self.n))
        self.lib.mass_matrix(self._ptr(q), self._params(p), self._ptr(M))
        return M

    def forces(self, t, q, qd, p):
        q, qd = self._vec(q, "q"), self._vec(qd, "qd")
        f = np.empty(self.n)
        self.lib.forces(float(t), self._ptr(q), self._ptr(qd), self._params(p), self._ptr(f))
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

    def drive_forces(self, t, p):
        Q = np.empty(self.n)
        self.lib.drive_forces(float(t), self._params(p), self._ptr(Q))
        return Q

    def points(self, q, p):
        q = self._vec(q, "q")
        P = np.empty((max(1, self.n_points), 3))
        self.lib.points(self._ptr(q), self._params(p), self._ptr(P))
        return P[:self.n_points]

    def constraint_terms(self, t, q, qd, p):
        q, qd = self._vec(q, "q"), self._vec(qd, "qd")
        m, k = self.m, max(1, self.m)
        phi, phid, D, gamma = np.empty(k), np.empty(k), np.empty((k, self.n)), np.empty(k)
        self.lib.constraint_terms(float(t), self._ptr(q), self._ptr(qd), self._params(p),
                                  self._ptr(phi), self._ptr(phid), self._ptr(D), self._ptr(gamma))
        return phi[:m], phid[:m], D[:m], gamma[:m]

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
        q, qd = self._vec(q, "q"), self._vec(qd, "qd")
        dep, ind = self._partition_pointers(model)
        qdd = np.empty(self.n)
        if M is None:
            status = self.lib.gpme_accelerations(float(t), self._ptr(q), self._ptr(qd), self._params(model.p), dep,
                                                 ind, self._ptr(qdd))
        else:
            status = self.lib.gpme_motion(float(t), self._ptr(q), self._ptr(qd), self._params(model.p), dep, ind,
                                          self._ptr(qdd), self._ptr(M), self._ptr(f))
        if status == SolveStatus.NONFINITE:
            raise SimulationError(
                f"the GPME terms (M, f or D) are not finite at t = {float(t):g} s: check the state and the "
                f"parameter values"
            )
        if status:
            raise SimulationError(
                f"the GPME system is singular at t = {float(t):g} s: the constraints are not independent in "
                f"this configuration (their Jacobian D lost rank) or M is singular on the motions they allow; "
                f"start from a configuration where the constraints are independent"
            )
        return qdd

    def motion(self, t, q, qd, model):
        M, f = np.empty((self.n, self.n)), np.empty(self.n)
        return self._solve(t, q, qd, model, M, f), M, f

    def accelerations(self, t, q, qd, model):
        return self._solve(t, q, qd, model)

    def rk4(self, model, g, k_from, k_to, save_every, y0):
        n = self.n
        dep, ind = self._partition_pointers(model)
        q0, qd0, w0 = (np.ascontiguousarray(part) for part in (y0[:n], y0[n:2 * n], y0[2 * n:]))
        n_save = k_to // save_every - k_from // save_every + 2
        t_out, y_out = np.empty(n_save), [np.empty((n_save, n)), np.empty((n_save, n)), np.empty((n_save, 2))]
        n_saved = self.ffi.new("long *")
        status = self.lib.rk4(g.t0, g.dt, g.n_steps, g.t_end, k_from, k_to, save_every, self._ptr(q0),
                              self._ptr(qd0), self._ptr(w0), self._params(model.p), dep, ind, self._ptr(t_out),
                              *(self._ptr(part) for part in y_out), n_saved)
        k = int(n_saved[0])
        return t_out[:k].copy(), np.column_stack([part[:k] for part in y_out]), SolveStatus(status)
