"""The C backend: a generated model whose functions, GPME solve and RK4 loop run compiled.

:class:`CModel` keeps the public contract of :class:`LoadedModel` (same methods, shapes and
units) and adds :meth:`CModel.rk4`, the whole fixed-step integration in C. The NumPy module of
the same folder still supplies the model's constants (coordinates, parameters, points, …).
"""

from __future__ import annotations

from pathlib import Path
from types import ModuleType

import numpy as np

from ..errors import BuildError, ModelError, SimulationError
from ..folder import read_verified
from ..status import SolveStatus
from . import ccompile, cprobe, integrate
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
        super().__init__(module, params, "c", folder, requirements)
        if folder is None:
            raise BuildError("the C backend needs the generated folder holding model.c")
        source = Path(folder) / "model.c"
        # compiled from the very text checked against the manifest, never read again
        text = read_verified(folder, source.name, rebuild)
        module_path = Path(folder) / "model_numpy.py"
        self.ffi, self.lib, self.library = ccompile.load_library(
            source, flags, cache, expect_hash=module.INPUT_HASH, text=text,
            check=lambda library: cprobe.check_in_child(library, source, module_path))
        if self.lib.gpmegen_n_dof() != self.n_dof or self.lib.gpmegen_n_parameters() != len(self.parameter_names):
            raise BuildError(f"{source} does not match {Path(folder) / 'model_numpy.py'}; rebuild with "
                             f"'gpmegen build --force'")
        self.compiled = self.library.compiled
        self.compile_seconds = self.library.compile_seconds
        self._n_constraints = len(self.constraint_names)
        self._n_points = len(self.points)
        self._partition_c = None

    def with_params(self, **overrides) -> CModel:
        """The same model with some parameter values changed; shares the loaded library."""
        other = super().with_params(**overrides)
        other.compiled = False  # nothing was compiled for it
        return other

    # --- marshalling ------------------------------------------------------------------------
    def _vec(self, x, what):
        return vector(x, self.n_dof, what)

    def _ptr(self, a):
        # from_buffer is the cheapest way to hand cffi a contiguous float64 array (no copy).
        return self.ffi.from_buffer("double[]", a)

    def _params(self):
        # Read at each call, as the NumPy backend does, so the two always see the same values.
        p = np.ascontiguousarray(self.p, dtype=float)
        if p.shape != (len(self.parameter_names),):
            raise ValueError(f"p must have shape ({len(self.parameter_names)},), got {p.shape}")
        return self.ffi.from_buffer("double[]", p) if p.size else self.ffi.new("double[]", 1)

    def _partition_pointers(self):
        # The partition may be set after loading (chosen at the start of a run), so the C copies
        # follow self.dependent / self.independent.
        if self.dependent is None or self.independent is None:
            raise ModelError(
                f"model {self.module.MODEL} has no dependent coordinates chosen yet, so the GPME cannot "
                f"split q; set the model's 'dependent' coordinates"
            )
        key = (tuple(np.asarray(self.dependent).tolist()), tuple(np.asarray(self.independent).tolist()))
        if self._partition_c is None or self._partition_c[0] != key:
            dep, ind = key
            if sorted(dep + ind) != list(range(self.n_dof)) or len(dep) != self._n_constraints:
                raise ModelError(
                    f"dependent {dep} and independent {ind} must split the {self.n_dof} coordinates, with one "
                    f"dependent coordinate per constraint ({self._n_constraints})"
                )
            dep_c = self.ffi.new("int[]", max(1, len(dep)))
            ind_c = self.ffi.new("int[]", max(1, len(ind)))
            dep_c[0:len(dep)] = list(dep)
            ind_c[0:len(ind)] = list(ind)
            self._partition_c = (key, dep_c, ind_c)
        return self._partition_c[1], self._partition_c[2]

    # --- the generated functions -------------------------------------------------------------
    def mass_matrix(self, q):
        """M(q), (n, n), kg·m² / kg."""
        q = self._vec(q, "q")
        M = np.empty((self.n_dof, self.n_dof))
        self.lib.mass_matrix(self._ptr(q), self._params(), self._ptr(M))
        return M

    def forces(self, t, q, qd):
        """f = Q(t) + h(q, qd) - g(q) - C q - damping, (n,)."""
        q, qd = self._vec(q, "q"), self._vec(qd, "qd")
        f = np.empty(self.n_dof)
        self.lib.forces(float(t), self._ptr(q), self._ptr(qd), self._params(), self._ptr(f))
        return f

    def static_residual(self, q):
        """g(q) + C q, (n,): zero at an equilibrium with no drive."""
        q = self._vec(q, "q")
        r = np.empty(self.n_dof)
        self.lib.static_residual(self._ptr(q), self._params(), self._ptr(r))
        return r

    def stiffness_jacobian(self, q):
        """K = ∂(g + C q)/∂q, (n, n)."""
        q = self._vec(q, "q")
        K = np.empty((self.n_dof, self.n_dof))
        self.lib.stiffness_jacobian(self._ptr(q), self._params(), self._ptr(K))
        return K

    def drive_forces(self, t):
        """Q(t), (n,)."""
        Q = np.empty(self.n_dof)
        self.lib.drive_forces(float(t), self._params(), self._ptr(Q))
        return Q

    def point_positions(self, q):
        """Positions of the named points in {0}, (n_points, 3), m."""
        q = self._vec(q, "q")
        P = np.empty((max(1, self._n_points), 3))
        self.lib.points(self._ptr(q), self._params(), self._ptr(P))
        return P[:self._n_points]

    def constraint_terms(self, t, q, qd):
        """(Φ, Φ̇, D, γ) of the programmed constraints: (m,), (m,), (m, n), (m,)."""
        q, qd = self._vec(q, "q"), self._vec(qd, "qd")
        m, k = self._n_constraints, max(1, self._n_constraints)
        phi, phid, D, gamma = np.empty(k), np.empty(k), np.empty((k, self.n_dof)), np.empty(k)
        self.lib.constraint_terms(float(t), self._ptr(q), self._ptr(qd), self._params(),
                                  self._ptr(phi), self._ptr(phid), self._ptr(D), self._ptr(gamma))
        return phi[:m], phid[:m], D[:m], gamma[:m]

    def energies(self, q, qd):
        """(kinetic, gravity potential, spring) energy in J, (3,)."""
        q, qd = self._vec(q, "q"), self._vec(qd, "qd")
        e = np.empty(3)
        self.lib.energies(self._ptr(q), self._ptr(qd), self._params(), self._ptr(e))
        return e

    def gpme_terms(self, t, q, qd):
        """(M, f, Φ, Φ̇, D, γ) in one compiled pass."""
        q, qd = self._vec(q, "q"), self._vec(qd, "qd")
        n, m = self.n_dof, self._n_constraints
        M, f = np.empty((n, n)), np.empty(n)
        phi, phid, D, gamma = (np.empty(max(1, m)), np.empty(max(1, m)), np.empty((max(1, m), n)),
                               np.empty(max(1, m)))
        self.lib.gpme_terms(float(t), self._ptr(q), self._ptr(qd), self._params(), self._ptr(M), self._ptr(f),
                            self._ptr(phi), self._ptr(phid), self._ptr(D), self._ptr(gamma))
        return M, f, phi[:m], phid[:m], D[:m], gamma[:m]

    def _solve(self, t, q, qd, M=None, f=None):
        q, qd = self._vec(q, "q"), self._vec(qd, "qd")
        dep, ind = self._partition_pointers()
        qdd = np.empty(self.n_dof)
        if M is None:
            status = self.lib.gpme_accelerations(float(t), self._ptr(q), self._ptr(qd), self._params(), dep, ind,
                                                 self._ptr(qdd))
        else:
            status = self.lib.gpme_motion(float(t), self._ptr(q), self._ptr(qd), self._params(), dep, ind,
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

    def motion(self, t, q, qd):
        """(q̈, M, f): the GPME solution with the terms it was solved from, in one C call."""
        M, f = np.empty((self.n_dof, self.n_dof)), np.empty(self.n_dof)
        return self._solve(t, q, qd, M, f), M, f

    def accelerations(self, t, q, qd):
        """q̈ (n,) from the GPME with Baumgarte terms (eq. 16), solved in C."""
        return self._solve(t, q, qd)

    def rk4(self, q0, qd0, t_end, dt, save_every=1, t0=0.0, w0=(0.0, 0.0), steps=None):
        """Classical RK4 of the GPME from ``t0`` to ``t_end`` (s) with step ``dt`` (s), entirely in
        C, on the grid of :func:`gpmegen.runtime.integrate.grid` (the NumPy loop's).

        ``steps = (k_from, k_to)`` integrates only those steps of that grid, from ``q0``, ``qd0``
        (n,) and ``w0`` at the end of step ``k_from`` (default: all of it, from ``t0``). Saves the
        start, the state after every ``save_every``-th step of the grid and the final state.
        Returns ``(t, q, qd, w, status)``: ``t`` (k,) s, ``q`` and ``qd`` (k, n), ``w`` (k, 2) the
        work of the drive and of the constraint forces plus ``w0`` (J), ``status`` a
        :class:`gpmegen.status.SolveStatus`, OK when all steps were done, else with the states
        saved before the failure.
        """
        g = integrate.grid(t0, t_end, dt)
        k_from, k_to = g.span(steps, save_every)
        save_every = int(save_every)
        q0, qd0 = self._vec(q0, "q0"), self._vec(qd0, "qd0")
        dep, ind = self._partition_pointers()
        n_save = k_to // save_every - k_from // save_every + 2
        t_out = np.empty(n_save)
        q_out, qd_out = np.empty((n_save, self.n_dof)), np.empty((n_save, self.n_dof))
        w_start, w_out = np.ascontiguousarray(w0, dtype=float), np.empty((n_save, 2))
        n_saved = self.ffi.new("long *")
        status = self.lib.rk4(g.t0, g.dt, g.n_steps, g.t_end, k_from, k_to, save_every, self._ptr(q0),
                              self._ptr(qd0), self._ptr(w_start), self._params(), dep, ind, self._ptr(t_out),
                              self._ptr(q_out), self._ptr(qd_out), self._ptr(w_out), n_saved)
        k = int(n_saved[0])
        return t_out[:k].copy(), q_out[:k].copy(), qd_out[:k].copy(), w_out[:k].copy(), SolveStatus(status)
