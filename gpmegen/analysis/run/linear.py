"""Linear state-space models ``ẋ = A x + B u`` of a model's constrained motion about a state.

States are the independent coordinates of the partition at the state and their velocities,
``x = (δq_ind, δq̇_ind)``; the dependent ones follow from the position constraints to first order:
``δq = N δq_ind`` with ``N = [I; -D_dc⁻¹ D_ic]`` (the tangent basis of
:func:`gpmegen.runtime.gpme.tangent_basis`), and from ``δΦ̇ = Φ̇_q δq + D δq̇ = 0``,
``δq̇ = N δq̇_ind + V δq_ind`` with ``V`` zero on the independent rows and
``-D_dc⁻¹ Φ̇_q N`` on the dependent ones (``Φ̇_q = ∂Φ̇/∂q``, zero at rest when ``Φ`` depends on
time only through terms free of ``q``). With ``q̈ = a(t, q, q̇)`` of the GPME and its exact
Jacobians ``A_q``, ``A_q̇``, the independent rows ``P`` of ``δq̈`` give

    A = [[0, I], [P (A_q N + A_q̇ V), P A_q̇ N]].

Picking rows is exact, not a projection: ``q̈_ind`` is a component of ``q̈``, and the dependent
accelerations are those the constraint rows then fix. The Baumgarte terms
``-2αΦ̇ - β²Φ`` of those rows vary by ``-2α δΦ̇ - β² δΦ``, zero for every perturbation of the
states (``δΦ = D N δq_ind = 0``, ``δΦ̇ = 0`` by the choice of ``V``). What remains of them is their
value times the change of the GPME's matrix with ``q``, zero on the constraints (``Φ = Φ̇ = 0``, as
at the statics): there ``A`` does not depend on the gains. At a run's saved state, off the
constraints by its drift, it does so by ``O(β²|Φ| + α|Φ̇|)``.

Inputs ``u`` are generalized forces on chosen coordinates: ``f → f + S u``. The GPME are linear in
``f``, so ``B = [[0], [P q̈_u]]`` with ``q̈_u`` the GPME's solution for ``f = S`` (and the
constraint rows' right side zero): exact, one solve.

A model's controller states ``z`` (``[[controllers]]``, ``ż = r(t, q, q̇, z)``, read by its drives)
are states too, after the mechanical ones: ``x = (δq_ind, δq̇_ind, δz)``, with ``A_z = ∂q̈/∂z`` and
the rates' ``R_q``, ``R_q̇``, ``R_z`` by central differences (the rates are linear in most laws,
where the differences are exact to round-off):

    A = [[0, I, 0], [P (A_q N + A_q̇ V), P A_q̇ N, P A_z], [R_q N + R_q̇ V, R_q̇ N, R_z]],

and zero rows of ``B`` for ``z`` (a rate reads positions and velocities, not forces).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from ... import extras
from ...errors import ModelError
from ...fileio import atomic_write
from ...runtime import gpme
from ...runtime.internal import UNSTABLE
from ..post import results as results_io

# Relative step of the central differences of Φ̇ in q (constraint terms only).
STEP = 1e-7
# Relative step of the central differences in the controller states and of their rates: the cube
# root of the machine epsilon, where truncation and round-off of a central difference balance.
CONTROLLER_STEP = np.finfo(float).eps ** (1 / 3)
# Eigenvalues below this fraction of the largest modulus are zero to round-off.
NEUTRAL = 1e-9


@dataclass
class LinearModel:
    """``ẋ = A x + B u`` about ``(t, q, qd, z)``: ``A`` (2k + c, 2k + c) 1/s and 1/s², ``B``
    (2k + c, j), ``states`` (2k + c,) names (``<coordinate>`` and ``<coordinate>_dot``, then the
    c controller states by their names), ``inputs`` (j,) names (a generalized force on that
    coordinate, N·m or N), ``eigenvalues`` (2k + c,) 1/s of ``A`` sorted by frequency, ``t`` s,
    ``q``, ``qd`` (n,) the state, ``qdd`` (n,) its accelerations (zero at an equilibrium; else the
    linear model holds for the deviation from the motion through it, over times short against
    its change), ``where`` how the state was chosen, ``controllers`` (c,) the controller states'
    names, ``z`` (c,) their values and ``z_rate`` (c,) their rates there (zero at an equilibrium)."""

    A: np.ndarray
    B: np.ndarray
    states: tuple
    inputs: tuple
    eigenvalues: np.ndarray
    t: float
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    coordinates: tuple
    where: str = ""
    controllers: tuple = ()
    z: np.ndarray = field(default_factory=lambda: np.zeros(0))
    z_rate: np.ndarray = field(default_factory=lambda: np.zeros(0))

    def summary(self) -> str:
        """One line: where, the states, the inputs and how far the state is from an equilibrium."""
        k = (len(self.states) - len(self.controllers)) // 2
        coordinates = ", ".join(self.states[:k])
        controllers, off = "", f"max|q''| there {np.max(np.abs(self.qdd)):.3g}"
        if self.controllers:
            controllers = f", controller states {', '.join(self.controllers)}"
            off += f", max|z'| {np.max(np.abs(self.z_rate)):.3g}"
        return (f"linear model about the {self.where}: {len(self.states)} states ({coordinates} and their rates"
                f"{controllers}), inputs {', '.join(self.inputs) or 'none'}; {off} (0 at an equilibrium)")

    def state_space(self, outputs=None):
        """``control.StateSpace(A, B, C, D)`` of python-control, with the state and input names:
        ``C`` the identity on the states (every state an output) unless ``outputs`` names some of
        :attr:`states` (``C`` picks them, in that order), ``D`` zero. Needs python-control
        (the extra ``control``: :func:`gpmegen.extras.require`)."""
        control = extras.require("control", "LinearModel.state_space")
        names = list(self.states)
        chosen = names if outputs is None else list(outputs)
        unknown = [name for name in chosen if name not in names]
        if unknown or not chosen:
            raise ModelError(f"outputs {', '.join(map(repr, unknown)) or '(none)'}: name states of the linear model, "
                             f"among {', '.join(names)}")
        C = np.eye(len(names))[[names.index(name) for name in chosen]]
        D = np.zeros((len(chosen), self.B.shape[1]))
        return control.ss(self.A, self.B, C, D, states=names, inputs=list(self.inputs), outputs=chosen)

    def arrays(self) -> dict:
        """The arrays written to NPZ and .mat files."""
        return {"A": self.A, "B": self.B, "state_names": np.array(self.states, dtype=object),
                "input_names": np.array(self.inputs, dtype=object), "eigenvalues": self.eigenvalues,
                "t": np.float64(self.t), "q": self.q, "qd": self.qd, "qdd": self.qdd,
                "coordinates": np.array(self.coordinates, dtype=object), "where": self.where,
                **({"controller_names": np.array(self.controllers, dtype=object), "z": self.z, "z_rate": self.z_rate}
                   if self.controllers else {})}


def refuse_velocity_constraints(names, orders) -> None:
    """ModelError for constraints (``names``, their ``orders``) of first or second order: they hold
    velocities or accelerations, not positions, so the dependent coordinates do not follow from
    the independent ones."""
    names = [name for name, order in zip(names, orders) if order != 0]
    if names:
        raise ModelError(f"the constraint(s) {', '.join(map(repr, names))} of first or second order hold "
                         f"velocities or accelerations, not positions, so the states cannot be the independent "
                         f"coordinates; linearize a model whose programmed constraints are all position constraints")


def rate_jacobian(model, t, q, qd) -> np.ndarray:
    """``∂Φ̇/∂q`` (m, n) by central differences of the emitted ``Φ̇``."""
    n = model.n_dof
    out = np.zeros((len(model.constraint_names), n))
    for j in range(n):
        h = STEP * max(1.0, abs(q[j]))
        up, down = q.copy(), q.copy()
        up[j] += h
        down[j] -= h
        out[:, j] = (model.constraint_terms(t, up, qd)[1] - model.constraint_terms(t, down, qd)[1]) / (2 * h)
    return out


def controller_jacobians(model, t, q, qd, z):
    """``(A_z, R_q, R_qd, R_z)`` of ``model``'s controller states ``z`` (c,) at ``(t, q, qd)``:
    ``∂q̈/∂z`` (n, c) and the rates' ``∂ż/∂q``, ``∂ż/∂q̇`` (c, n) and ``∂ż/∂z`` (c, c), by
    central differences with steps :data:`CONTROLLER_STEP` ``max(1, |x_j|)``."""
    def differences(f, x):
        columns = []
        for j in range(len(x)):
            h = CONTROLLER_STEP * max(1.0, abs(x[j]))
            up, down = x.copy(), x.copy()
            up[j] += h
            down[j] -= h
            columns.append((f(up) - f(down)) / (2 * h))
        return np.column_stack(columns) if columns else np.zeros((0, 0))

    at = model.at_controller_states(z)
    A_z = differences(lambda x: model.at_controller_states(x).accelerations(t, q, qd), z)
    R_q = differences(lambda x: at.controller_rates(t, x, qd), q)
    R_qd = differences(lambda x: at.controller_rates(t, q, x), qd)
    R_z = differences(lambda x: model.at_controller_states(x).controller_rates(t, q, qd), z)
    return A_z, R_q, R_qd, R_z


def linearize(model, t, q, qd, inputs=(), where="", z=None) -> LinearModel:
    """The linear model of ``model`` (loaded with its Jacobians, ideal realization) about
    ``(t, q, qd)`` and, for a model with controller states, ``z`` (c,; None: those the model
    holds, the start's unless set by :meth:`~gpmegen.runtime.model.LoadedModel.at_controller_states`),
    with inputs on the coordinates named in ``inputs``. The partition is chosen at the state
    (pivoted QR of ``D``) unless the model fixes it."""
    refuse_velocity_constraints(model.constraint_names, model.constraint_orders)
    unknown = [name for name in inputs if name not in model.coordinates]
    if unknown:
        raise ModelError(f"inputs {', '.join(map(repr, unknown))}: not coordinates of {model.module.MODEL}; name "
                         f"among {', '.join(model.coordinates)}")
    q, qd = np.asarray(q, dtype=float), np.asarray(qd, dtype=float)
    held = np.asarray(model.p[len(model.parameter_names):], dtype=float)
    z = held.copy() if z is None else np.asarray(z, dtype=float)
    model = model.at_controller_states(z).with_actuators(()).partitioned(t, q)
    n = model.n_dof
    ind, dep = np.asarray(model.independent), np.asarray(model.dependent)
    A_q, A_qd = model.acceleration_jacobians(t, q, qd)
    M, _, _, _, D, _ = model.gpme_terms(t, q, qd)
    qdd = model.accelerations(t, q, qd)
    S = gpme.selection(n, [model.index(name) for name in inputs])
    # redundant rows (model.redundant): those independent at the state, which near it hold the
    # same configurations as all of them
    rows = gpme.independent_rows(D) if model.redundant else np.arange(len(D))
    D = D[rows]
    if len(D):
        N = gpme.tangent_basis(D, dep, ind)
        V = np.zeros((n, len(ind)))
        V[dep] = -np.linalg.solve(D[:, dep], rate_jacobian(model, t, q, qd)[rows] @ N)
        K = np.vstack([N.T @ M, D])
        forced = np.linalg.solve(K, np.vstack([N.T @ S, np.zeros((len(D), S.shape[1]))]))
    else:
        N, V = np.eye(n), np.zeros((n, n))
        forced = np.linalg.solve(M, S)
    k, c = len(ind), len(z)
    A = np.block([[np.zeros((k, k)), np.eye(k)], [(A_q @ N + A_qd @ V)[ind], (A_qd @ N)[ind]]])
    B = np.vstack([np.zeros((k, S.shape[1])), forced[ind], np.zeros((c, S.shape[1]))])
    z_rate = model.controller_rates(t, q, qd) if c else np.zeros(0)
    if c:
        A_z, R_q, R_qd, R_z = controller_jacobians(model, t, q, qd, z)
        A = np.block([[A, np.vstack([np.zeros((k, c)), A_z[ind]])], [R_q @ N + R_qd @ V, R_qd @ N, R_z]])
    names = [model.coordinates[j] for j in ind]
    values = np.linalg.eigvals(A)
    order = np.lexsort((values.imag, np.abs(values)))
    states = tuple(names + [f"{name}_dot" for name in names] + list(model.controller_names))
    return LinearModel(A, B, states, tuple(inputs), values[order], float(t), q, qd, qdd, tuple(model.coordinates),
                       where, tuple(model.controller_names), z, z_rate)


def neutral(values) -> np.ndarray:
    """Mask of the eigenvalues that are zero to round-off (below :data:`NEUTRAL` times the
    largest modulus): a coordinate with neither spring nor gravity moment, e.g. a free rotation."""
    modulus = np.abs(np.asarray(values))
    return modulus <= NEUTRAL * np.max(modulus, initial=0.0)


def frequencies(values):
    """``(f Hz, ζ)`` of eigenvalues ``values`` (1/s): ``f = |λ|/2π``, ``ζ = -Re λ/|λ|``; for the
    :func:`neutral` ones ``f = 0`` and ``ζ`` NaN (not defined)."""
    values = np.asarray(values)
    zero = neutral(values)
    modulus = np.where(zero, 0.0, np.abs(values))
    with np.errstate(invalid="ignore", divide="ignore"):
        zeta = np.where(zero, np.nan, -values.real / np.where(zero, 1.0, modulus))
    return modulus / (2 * math.pi), zeta


def unstable(values) -> np.ndarray:
    """Mask of the eigenvalues with a real part above :data:`gpmegen.runtime.internal.UNSTABLE`
    times the largest modulus."""
    values = np.asarray(values)
    return values.real > UNSTABLE * np.max(np.abs(values), initial=0.0)


def format_eigenvalues(values) -> str:
    """The eigenvalues as a table, one line per real eigenvalue or complex pair (the one with
    ``Im ≥ 0``), by frequency: Hz, damping ratio ("neutral" for a zero one), the eigenvalue; the
    unstable ones marked."""
    values = np.asarray(values)
    shown = values[values.imag >= -1e-12 * max(1.0, float(np.max(np.abs(values), initial=0.0)))]
    f, zeta = frequencies(shown)
    bad = unstable(shown) & ~neutral(shown)
    lines = [f"{'frequency (Hz)':>15} {'damping ratio':>14}  {'eigenvalue (1/s)':>28}"]
    for fk, zk, v, b in zip(f, zeta, shown, bad):
        damping = "neutral" if np.isnan(zk) else f"{zk:.6g}"
        lines.append(f"{fk:15.6g} {damping:>14}  {v.real:13.6g} {v.imag:+13.6g}j" + ("  UNSTABLE" if b else ""))
    return "\n".join(lines)


def targets(path, count: int) -> list[Path]:
    """The files ``count`` linear models go to at ``path``: ``path`` itself for one (or none
    asked, the statics' model), ``<stem>_1<suffix>``, ``<stem>_2<suffix>``, ... for several."""
    path = Path(path)
    if count <= 1:
        return [path]
    return [path.with_name(f"{path.stem}_{k + 1}{path.suffix}") for k in range(count)]


def save(linear: LinearModel, path) -> Path:
    """Write ``linear`` to ``path``, ``.npz`` (names as string arrays) or ``.mat`` (MATLAB 5,
    names as cell arrays of strings), atomically."""
    path = Path(path)
    data = linear.arrays()
    if path.suffix == ".mat":
        import scipy.io

        cells = {k: (np.array([[s] for s in v], dtype=object) if isinstance(v, np.ndarray) and v.dtype == object else v)
                 for k, v in data.items()}
        return atomic_write(path, lambda fh: scipy.io.savemat(fh, cells, oned_as="column"))
    if path.suffix == ".npz":
        strings = {k: (v.astype(str) if isinstance(v, np.ndarray) and v.dtype == object else v)
                   for k, v in data.items()}
        return atomic_write(path, lambda fh: np.savez(fh, **strings))
    raise ModelError(f"{path}: write the linear model as .npz or .mat")


def default_inputs(case) -> tuple:
    """The coordinates that take an input by default: those the case's model drives, then its
    actuators (none for a built folder, whose drives are not recorded)."""
    drives = [drive.coordinate for drive in getattr(case.source, "drives", ())]
    return tuple(dict.fromkeys(drives + list(case.actuators)))


def along_run(model, path, times, inputs=()) -> list:
    """Linear models at the saved states of the results file ``path`` nearest each of ``times``
    (s) (the saved state, not an interpolation: it lies on the run's motion), with the run's
    parameter values. ModelError for a results file of another model or times outside the run."""
    run = results_io.load(path)
    meta = results_io.metadata(run)
    if meta.get("model") != model.module.MODEL or tuple(meta.get("coordinates", ())) != model.coordinates:
        raise ModelError(f"{path}: results of model {meta.get('model')!r}, not of {model.module.MODEL!r}; give a "
                         f"results file of this model (or the model file that made it)")
    t = np.asarray(run["t"], dtype=float)
    times = np.atleast_1d(np.asarray(times if times is not None else [t[0]], dtype=float))
    outside = [f"{x:g}" for x in times if not t[0] <= x <= t[-1]]
    if outside:
        raise ModelError(f"--times {', '.join(outside)} s: outside the run of {path} ({t[0]:g} to {t[-1]:g} s); give "
                         f"times within it")
    model = model.with_params(**meta.get("params", {}))
    out = []
    for x in times:
        k = int(np.argmin(np.abs(t - x)))
        z = run["controller_states"][k] if model.controller_names else None
        out.append(linearize(model, t[k], run["q"][k], run["qd"][k], inputs,
                             where=f"saved state at t = {t[k]:.6g} s of {path} (nearest to {x:g} s)", z=z))
    return out
