"""A model's start (a model file's ``[initial]`` configuration moved onto the programmed
constraints) and its constrained motion, with the derived quantities of the results. The paper's
scenario is in :mod:`gpmegen.analysis.run.reference_case`.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from ... import limits
from ...errors import ModelError, ModelWarning, SimulationError
from ...runtime import gpme, integrate, internal, partition, redundancy, statics
from ...status import Ending, Outcome
from ..post import energy as energy_balance
from ..post import modes
from . import results as results_io

# Above this move (rad or m, rad/s or m/s) of a coordinate, making the start consistent is
# reported as a warning: the start given was not one the programmed constraints allow.
MOVE_WARNING = 1e-6


def project_onto_constraints(model, q, t=0.0, tol=1e-12, max_iter=50, hint=None, closures=None):
    """Move the dependent coordinates so that the position constraints (order 0) hold,
    Φ(q, t) = 0 (Newton on their block of D; least squares when first-order constraints take
    some dependent coordinates). When it fails, the message names the model's constraints left
    violated, with their values at the closest configuration found, and ends with ``hint``
    (default: a generic one); a closure among them (``closures``: closure name -> its row names)
    is named with its residual, the norm of its rows."""
    q = np.array(q, dtype=float)
    dep = model.dependent
    rows = np.flatnonzero(np.asarray(model.constraint_orders) == 0)
    qd = np.zeros_like(q)
    closest = None
    for _ in range(max_iter):
        phi, _, D, _ = model.constraint_terms(t, q, qd)
        phi = np.where(np.asarray(model.constraint_orders) == 0, phi, 0.0)
        worst = np.max(np.abs(phi), initial=0.0)
        if worst <= tol:
            return q
        if closest is None or worst < np.max(np.abs(closest)):
            closest = phi
        try:
            block = D[np.ix_(rows, dep)]
            if block.shape[0] == block.shape[1]:
                q[dep] -= np.linalg.solve(block, phi[rows])
            else:
                q[dep] -= np.linalg.lstsq(block, phi[rows], rcond=None)[0]
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(q)):
            break
    violated = ", ".join(f"{name} = {value:.3e}" for name, value in zip(model.constraint_names, closest)
                         if abs(value) > tol)
    moved = ", ".join(model.coordinates[k] for k in dep)
    value_of = dict(zip(model.constraint_names, closest))
    open_loops = {name: float(np.linalg.norm([value_of[row] for row in rows]))
                  for name, rows in (closures or {}).items()
                  if any(abs(value_of[row]) > tol for row in rows)}
    if open_loops:
        loops = " and ".join(f"closure {name!r} (residual {value:.3e}, the norm of its rows)"
                             for name, value in open_loops.items())
        raise SimulationError(
            f"model {model.module.MODEL}: {loops} cannot be closed from the start configuration by moving {moved} "
            f"(at best {violated}); give [initial] q nearer to a configuration where the loop closes, or dimensions "
            f"that let it close (docs/model-file.md, 'Closures')", partial={"phi": closest})
    raise SimulationError(
        f"model {model.module.MODEL}: the programmed constraints cannot be met from the start configuration by "
        f"moving {moved}: at best {violated}; "
        + (hint or "is the prescribed position within the chain's reach with these parameter values and this "
                   "start ([initial] q)?"), partial={"phi": closest})


def velocity_residual(model, t, q, qd):
    """What the velocity ``qd`` (n,) leaves of the constraints at ``(t, q)``, (m,): Φ̇ of the
    position constraints, Ψ of the first-order ones. Both are affine in ``qd`` with slope D."""
    phi, phi_rate, D, _ = model.constraint_terms(t, q, qd)
    return np.where(np.asarray(model.constraint_orders) == 0, phi_rate, phi), D


def project_velocities(model, q, qd, t=0.0):
    """``qd`` (n,) with the dependent velocities solved from the constraints (Φ̇ = 0 for position
    constraints, Ψ = 0 for first-order ones) for the independent velocities given."""
    qd = np.array(qd, dtype=float)
    dep = model.dependent
    if not len(model.constraint_names):
        return qd
    for _ in range(2):  # affine in qd: one step solves it, the second removes round-off
        r, D = velocity_residual(model, t, q, qd)
        try:
            if len(dep) == D.shape[0]:
                qd[dep] -= np.linalg.solve(D[:, dep], r)
            else:   # redundant rows: the dependent coordinates of the independent ones
                qd[dep] -= np.linalg.lstsq(D[:, dep], r, rcond=None)[0]
        except np.linalg.LinAlgError:
            raise SimulationError(
                f"model {model.module.MODEL}: the dependent block D_dc of the constraint Jacobian is singular at the "
                f"start, so the dependent velocities cannot be solved; choose other dependent coordinates "
                f"(model 'dependent') or another start ([initial] q)") from None
    return qd


@dataclass
class Start:
    """A consistent start: the ``model`` (with its partition), ``q`` and ``qd`` (n,) on the
    programmed constraints at t = 0, and ``moved``: for "q" and "qd", the largest change that
    putting them there made (rad or m, rad/s or m/s) and the coordinate it was made on;
    ``overridden``: the same, over the values the user gave only (all of ``q``; of ``qd``, the
    velocities given: the others are the constraints' to solve, so changing them is no warning)."""

    model: object
    q: np.ndarray
    qd: np.ndarray
    moved: dict = field(default_factory=dict)
    overridden: dict = field(default_factory=dict)
    assembled: dict | None = None   # with closures: coordinate -> (before, after), for those moved

    def report(self) -> str:
        """One line: how far the start was moved onto the constraints (with closures: each
        coordinate the assembly of the loops moved, and by how much)."""
        line = "start moved onto the constraints by " + "; ".join(
            f"max|Δ{key}| = {value:.3e}" + (f" ({name})" if value else "") for key, (value, name) in self.moved.items())
        if self.assembled:
            line += "; the loops assembled by moving " + ", ".join(
                f"{name} from {before:.6g} to {after:.6g} ({after - before:+.3e})"
                for name, (before, after) in self.assembled.items())
        return line

    def warning(self) -> str | None:
        """One line when a value the user gave was changed by more than :data:`MOVE_WARNING`, else None
        (with closures, ``q`` is assembled from a rough guess: moving it is reported, not warned of)."""
        far = {key: (value, name) for key, (value, name) in self.overridden.items() if value > MOVE_WARNING
               and not (key == "q" and self.assembled is not None)}
        if not far:
            return None
        given = " and ".join(f"[initial] {key}" for key in far)
        changes = ", ".join(f"{key} of {name} by {value:.3e}" for key, (value, name) in far.items())
        return (f"warning: the start (as given, or after the statics) was off the programmed constraints: putting "
                f"it on them changed {changes}"
                + f"; give {given} that meet them, or constraint constants that the start meets (docs/model-file.md, "
                  f"'Starts')")

    def meta(self) -> dict:
        """The report as results metadata."""
        return {key: {"max_change": float(value), "coordinate": name} for key, (value, name) in self.moved.items()}


def largest_change(model, before, after, among=None):
    """(largest |after - before|, the coordinate it is on), over the coordinates named in
    ``among`` (default: all)."""
    change = np.abs(np.asarray(after) - np.asarray(before))
    if among is not None:
        change = np.where([name in among for name in model.coordinates], change, 0.0)
    if not change.size or not change.any():
        return 0.0, ""
    k = int(np.argmax(change))
    return float(change[k]), model.coordinates[k]


def consistent(model, q, qd, t=0.0, hint=None, given_qd=None, closures=None) -> Start:
    """``q`` moved onto Φ = 0, then ``qd`` onto the constraint velocities, with the report of
    how far each moved (see :class:`Start`). ``given_qd``: the coordinates whose velocity the
    user gave (default: all of them). ``closures`` (closure name -> its row names): the model
    closes loops, whose assembly from a rough ``q`` is reported coordinate by coordinate."""
    q_on = (project_onto_constraints(model, q, t, hint=hint, closures=closures) if len(model.constraint_names)
            else np.array(q, float))
    qd_on = project_velocities(model, q_on, qd, t)
    q_moved = largest_change(model, q, q_on)
    assembled = None if not closures else {
        name: (float(before), float(after)) for name, before, after in zip(model.coordinates, q, q_on)
        if abs(after - before) > 0.0}
    return Start(model, q_on, qd_on, {"q": q_moved, "qd": largest_change(model, qd, qd_on)},
                 {"q": q_moved, "qd": largest_change(model, qd, qd_on, given_qd)}, assembled)


def check_redundant(model, q, closures, t=0.0, warn=True):
    """``model`` as it solves at a start ``q`` where the constraint rows are redundant: the
    constraint Jacobian ``D`` has a rank below its number of rows
    (:func:`gpmegen.runtime.gpme.rank`, relative to D's scale), as where a loop is closed more often
    than its motion needs. Then (with ``warn``) one :class:`ModelWarning` line names the rows that take part in
    a combination that vanishes (each closure's by the closure; ``closures``: closure name -> its
    row names) and says that the reactions shown are the minimum-norm ones, and the model is
    returned marked (:meth:`gpmegen.runtime.model.LoadedModel.with_redundant_rows`), its dependent
    coordinates those it has when they are one per independent row and regular there, else chosen
    on the independent rows at ``q``. Rows that cannot hold together (a loop
    that cannot close) are refused where the start moves ``q`` onto them. Otherwise ``model``."""
    if not len(model.constraint_names) or len(model.actuators):
        return model
    _, _, D, _ = model.constraint_terms(t, q, np.zeros(model.n_dof))
    if not np.all(np.isfinite(D)) or not D.size:
        return model
    rank = gpme.rank(D)
    if rank == D.shape[0]:
        return model
    chosen = partition.choose_dependent(D, rank)
    if model.dependent is not None and len(model.dependent) == rank:   # the model's own, where regular
        kept = D[gpme.independent_rows(D)]
        if partition.condition(kept, model.dependent) <= partition.ILL_CONDITIONED:
            chosen = model.dependent
    if not warn:
        return model.with_redundant_rows(chosen)
    import warnings

    warnings.warn(
        f"{redundancy.taking_part(model.constraint_names, D, rank, closures)} are redundant at the start (the "
        f"constraint Jacobian has rank {rank} for {D.shape[0]} rows): the accelerations come from the independent "
        f"rows; the reactions are not unique, and those shown are the minimum-norm ones", ModelWarning, stacklevel=2)
    return model.with_redundant_rows(chosen)


def vector_of(model, values: dict) -> np.ndarray:
    """(n,) with the named coordinates set from ``values`` (name -> number), the others 0."""
    x = np.zeros(model.n_dof)
    for name, value in values.items():
        x[model.index(name)] = value
    return x


def file_start(model, initial: dict, start="none", velocities: dict | None = None, closures=None) -> Start:
    """Start of a model file's run: the ``[initial]`` configuration (``initial``, ``velocities``:
    coordinate name → value), dependent coordinates chosen when the file says "auto",
    optionally the locked statics first (``start="locked"``), then made consistent
    (:func:`consistent`); ``start="constrained"`` then solves the constrained equilibrium (the
    velocities are projected again there). ``closures`` (closure name -> its row names): the
    loops are assembled from the rough ``initial``; rows that are redundant there are kept with
    one warning (:func:`check_redundant`, before and after)."""
    if start not in ("none", "locked", "constrained"):
        raise ValueError(f"unknown start {start!r}: use 'none', 'locked' or 'constrained'")
    q = vector_of(model, initial)
    if closures:   # a run watches the loops' rows by their closures' names
        model = model.with_closure_rows(closures)
    marked = check_redundant(model, q, closures)
    warned, model = marked is not model, marked
    if model.dependent is None:
        model = partition.partition_at(model, q)
    if start == "locked":
        q = statics.locked(model, q)
    begun = consistent(model, q, vector_of(model, velocities or {}), given_qd=frozenset(velocities or ()),
                       closures=closures)
    marked = check_redundant(model, begun.q, closures, warn=not warned)
    if marked is not model:   # the rows found redundant only once assembled, or the partition chosen there
        model = begun.model = marked
        begun.qd = project_velocities(model, begun.q, begun.qd)
    if start == "constrained":
        begun.q = statics.constrained(model, begun.q)
        begun.qd = project_velocities(model, begun.q, begun.qd)
    return begun


def simulate(model, q0, spec, *, qd0=None, progress=None, notify=None):
    """The constrained motion from ``q0`` with velocities ``qd0`` (default rest) as ``spec`` says
    (a :class:`gpmegen.analysis.run.runspec.RunSpec`); returns a results dict (see
    :mod:`gpmegen.analysis.run.results`). Its ``method``: "rk4" (step ``dt``, saving every
    ``save_every``-th step), "genalpha" (compiled, implicit, step ``dt``, numerical damping
    ``rho_inf``), "dop853" (compiled, adaptive), "radau" (compiled, implicit and adaptive) or a
    name of :data:`gpmegen.runtime.integrate.SCIPY`; all but rk4 save every
    :attr:`~gpmegen.analysis.run.runspec.RunSpec.save_interval` s, the adaptive ones to ``rtol``,
    ``atol``. The conditioning of the dependent block of ``D`` is watched: ``notify`` (a callable
    taking a message) is told when it degrades, and with ``repartition`` the dependent coordinates
    are chosen anew. ``progress``: the progress bar of the chunked loops. A fixed-step run that
    cannot finish (for DOP853: whose steps, at most its stable step at the start, cannot), or whose
    step is above RK4's stable one at the start (from the eigenvalues of the motion linearized there,
    dampers included: :func:`gpmegen.analysis.post.modes.motion_eigenvalues`), is refused before it starts
    (:class:`gpmegen.limits.LimitError`, unless the limits are lifted). An actuated run (``model``
    with actuators) tells ``notify`` its internal dynamics at the start and, with
    ``internal_dynamics``, saves them at every saved sample (``internal_eigenvalues``)."""
    method, t_end, dt = spec.method, spec.t_end, spec.dt
    refusal = integrate.compiled_only(method, model.backend, bool(len(model.actuators)))
    if refusal:
        raise SimulationError(refusal)
    model.check_signal_span(0.0, t_end)
    # the actuated realization runs the Python loop on either backend: estimated as the NumPy one (from above)
    loop = "numpy" if len(model.actuators) else model.backend
    qd0 = np.zeros(model.n_dof) if qd0 is None else np.array(qd0, dtype=float)
    model.check_forces_apart(q0)   # before the start's modes, which its undefined force would spoil
    omega = None  # the natural frequency that bounds the method's steps, when one does
    if t_end > 0 and not limits.are_lifted():  # t_end 0: no step
        if method in limits.NEEDS_FREQUENCY:
            omega = modes.highest_frequency(model, 0.0, q0, qd0)
        elif method in limits.NEEDS_LOWEST_FREQUENCY:
            omega = modes.lowest_frequency(model, 0.0, q0, qd0)
    limits.check_run(model.n_dof, len(model.constraint_names), spec, loop, omega)
    if method == "rk4" and omega is not None:
        unstable = integrate.unstable_step(dt, modes.motion_eigenvalues(model, 0.0, q0, qd0))
        if unstable:
            raise limits.LimitError(f"{unstable} (or pass --no-limits to start it anyway)")
    model.check_actuators(0.0, q0)
    actuated = [model.coordinates[k] for k in model.actuators]
    if spec.internal_dynamics and not actuated:
        raise ModelError("the internal dynamics belong to an actuated realization: name the actuated coordinates "
                         "(--actuated, or a model file's actuators)")
    if actuated:
        stability = internal.eigenvalues(model, 0.0, q0, qd0)
        (notify or (lambda message: None))(
            f"internal dynamics of the inputs on {', '.join(actuated)} at the start: {internal.describe(stability)}")
    # the actuated realization does not use the partition: nothing to watch
    watch = partition.Watch(model, spec.repartition, notify, limit=np.inf if len(model.actuators) else
                            partition.ILL_CONDITIONED)
    with integrate.interruptible():
        try:  # from the line below on, a signal keeps at least the start
            (notify or (lambda message: None))(f"integrating with {method} to t = {t_end:g} s; Ctrl-C or SIGTERM "
                                               f"stops it, keeping the results so far")
            t, y, outcome, effort = _integrate(model, q0, qd0, spec, progress, watch)
        except KeyboardInterrupt:  # before the integrator's own loop began, or in the line
            t, y = np.zeros(1), np.concatenate([q0, qd0, [0.0, 0.0]])[None, :]
            outcome, effort = Outcome(Ending.INTERRUPTED, 0.0), integrate.Effort(0, 0, 0, 0, 0)
    model = watch.model  # with the dependent coordinates the run ended with
    if actuated:
        outcome = internal.explain(outcome, stability, actuated)
    adaptive = spec.adaptive
    settings = dict(method=method, dt=dt, save_every=spec.save_every, save_dt=spec.save_interval,
                    rtol=spec.rtol if adaptive else None, atol=spec.atol if adaptive else None,
                    rho_inf=spec.rho_inf if method == "genalpha" else None,
                    effort=effort._asdict(), t_end=t_end, start=spec.start,
                    backend=model.backend,
                    dependent=[model.coordinates[k] for k in model.dependent] if model.dependent is not None else [],
                    repartitions=watch.events, actuators=actuated)
    results = collect(model, t, y, str(outcome), settings)
    if actuated and spec.internal_dynamics and len(t):
        results["internal_eigenvalues"] = internal.along(model, t, results["q"], results["qd"])
        worst = np.nanmax(results["internal_eigenvalues"].real, axis=1, initial=-np.inf)
        k = int(np.argmax(worst))
        (notify or (lambda message: None))(
            f"internal dynamics along the run: largest real part {worst[k]:.4g} 1/s at t = {t[k]:.6g} s")
    return results


def _integrate(model, q0, qd0, spec, progress, watch):
    """The integration of :func:`simulate` by ``spec.method``: ``(t, y, outcome, effort)``."""
    method, t_end, dt, save_dt, max_violation = spec.method, spec.t_end, spec.dt, spec.save_interval, spec.max_violation
    if method == "rk4":
        t, y, outcome = integrate.rk4(model, q0, qd0, t_end, dt, spec.save_every, progress=progress,
                                      max_violation=max_violation, watch=watch)
        return t, y, outcome, integrate.rk4_effort(t, 0.0, dt)
    if method == "genalpha":
        return integrate.genalpha(model, q0, qd0, t_end, dt, save_dt, spec.rho_inf, progress=progress,
                                  max_violation=max_violation, watch=watch)
    if method in integrate.ADAPTIVE:
        return integrate.ADAPTIVE[method](model, q0, qd0, t_end, save_dt, rtol=spec.rtol, atol=spec.atol,
                                          progress=progress, max_violation=max_violation, watch=watch)
    times = integrate.grid(0.0, t_end, save_dt)
    return integrate.scipy_solve(model, q0, qd0, t_end, method=integrate.SCIPY[method], rtol=spec.rtol,
                                 atol=spec.atol, t_eval=np.array([times.time(k) for k in range(times.n_steps + 1)]))


def collect(model, t, y, status, settings) -> dict:
    """Derived quantities at the saved samples: E, Φ, drive, q̈, the forces that realize the
    constraints (``M q̈ - f``, with ``lambda`` of the ideal realization or the inputs ``u`` of the
    actuated one), energies, the dampers' work (:mod:`gpmegen.analysis.post.energy`) and each force
    element's length, rate and force. Evaluated
    for all samples at once (:func:`_derived_together`) where the run's model allows it, else
    sample by sample (:func:`_derived_each`): the same values, to round-off."""
    n = model.n_dof
    q, qd = y[:, :n], y[:, n:2 * n]
    samples = len(t)
    actuated = len(model.actuators) > 0
    ok = np.all(np.isfinite(y[:, :2 * n]), axis=1)  # the states the model's functions accept
    derived = _derived_together(model, t, q, qd, ok) if samples else None
    if derived is None:
        derived = _derived_each(model, t, q, qd, ok)
    E, drive, phi, qdd, reaction, lam, energy = derived
    finite = np.flatnonzero(ok)
    elements = np.full((samples, len(model.force_names), 3), np.nan)
    for k in finite if model.force_names else ():
        elements[k] = model.force_elements(t[k], q[k], qd[k])
    dampers = (energy_balance.damper_work(energy_balance.damping_matrix(model, t[finite[0]], q[finite[0]]), t, qd, qdd)
               if len(finite) else np.full(samples, np.nan))
    realization = ({"u": lam, "actuators": np.array([model.coordinates[k] for k in model.actuators])} if actuated
                   else {"lambda": lam})
    return {
        "t": t, "q": q, "qd": qd, "qdd": qdd, "coordinates": np.array(model.coordinates),
        "end_effector": E, "phi": phi, "constraint_names": np.array(model.constraint_names),
        # the drives' generalized forces summed: the one drive torque of a single-drive model
        "tau_drive": drive.sum(axis=1),
        "drive_forces": drive, "constraint_forces": reaction, **realization,
        "kinetic_energy": energy[:, 0], "gravity_energy": energy[:, 1], "spring_energy": energy[:, 2],
        "work_drive": y[:, 2 * n], "work_constraints": y[:, 2 * n + 1], "work_dampers": dampers,
        "status": np.array(status),
        **({"force_names": np.array(model.force_names), "force_elements": elements} if model.force_names else {}),
        "meta": results_io.encode({
            "model": model.module.MODEL, "coordinates": list(model.coordinates),
            "constraint_names": list(model.constraint_names), "backend": model.backend,
            "start": settings["start"], "settings": settings,
            "params": {name: float(value) for name, value in model.params.items()},
        }),
    }


def _derived_each(model, t, q, qd, ok):
    """:func:`collect`'s derived quantities, one sample at a time: ``(E, drive, Φ, q̈, M q̈ - f,
    λ or u, energies)``; a sample whose GPME has no solution raises."""
    samples, n, m = len(t), model.n_dof, len(model.constraint_names)
    E = np.zeros((samples, 3))
    phi = np.full((samples, m), np.nan)
    drive = np.zeros((samples, n))
    qdd = np.full((samples, n), np.nan)
    reaction = np.zeros((samples, n))
    lam = np.full((samples, m), np.nan)
    energy = np.zeros((samples, 3))
    actuated = len(model.actuators) > 0
    for k in range(samples):
        E[k] = model.end_effector(q[k])
        drive[k] = model.drive_forces(t[k], q[k], qd[k]) if ok[k] else np.nan
        if ok[k]:  # the state (the model's functions refuse one not finite)
            phi[k] = model.constraint_values(t[k], q[k], qd[k])
            D = model.constraint_terms(t[k], q[k], qd[k])[2]
            qdd[k], M, f = model.motion(t[k], q[k], qd[k])
            reaction[k] = M @ qdd[k] - f
            lam[k] = reaction[k][model.actuators] if actuated else gpme.multipliers(M, f, qdd[k], D, model.redundant)
        energy[k] = model.energies(q[k], qd[k])
    return E, drive, phi, qdd, reaction, lam, energy


def _derived_together(model, t, q, qd, ok):
    """:func:`_derived_each`'s quantities by batched evaluation (one call into C, or one per
    sample from one view of each array; the multipliers by one stacked pseudo-inverse); None
    where they are made sample by sample: an actuated realization, a partition not chosen yet,
    or a sample whose GPME has no solution (which the other path reports)."""
    if len(model.actuators) or model.dependent is None:
        return None
    samples, n, m = len(t), model.n_dof, len(model.constraint_names)
    phi = np.full((samples, m), np.nan)
    drive = np.full((samples, n), np.nan)
    qdd = np.full((samples, n), np.nan)
    reaction = np.zeros((samples, n))
    lam = np.full((samples, m), np.nan)
    if np.any(ok):
        tk, qk, qdk = t[ok], q[ok], qd[ok]
        try:
            a = model.accelerations(tk, qk, qdk)
        except SimulationError:
            return None
        values, _, D, gamma = model.constraint_terms(tk, qk, qdk)
        # a second-order constraint's value is D q̈ + γ (see LoadedModel.constraint_values)
        phi[ok] = np.where(model.constraint_orders == 2, np.matmul(D, a[..., None])[..., 0] + gamma, values)
        drive[ok] = model.drive_forces(tk, qk, qdk)
        M, f = model.mass_matrix(qk), model.forces(tk, qk, qdk)
        qdd[ok] = a
        reaction[ok] = np.matmul(M, a[..., None])[..., 0] - f
        lam[ok] = gpme.multipliers(M, f, a, D, model.redundant)
    return model.end_effector(q), drive, phi, qdd, reaction, lam, model.energies(q, qd)
