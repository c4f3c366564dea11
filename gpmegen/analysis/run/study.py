"""A model's start (a model file's ``[initial]`` configuration moved onto the programmed
constraints) and its constrained motion, with the derived quantities of the results. The paper's
scenario is in :mod:`gpmegen.analysis.run.reference_case`.
"""

from __future__ import annotations

import numpy as np

from ... import limits
from ...errors import ModelError, SimulationError
from ...runtime import gpme, integrators, internal, partition, statics
from ...runtime.consistent import Start, check_redundant, consistent, project_velocities
from ...runtime.integrators.base import Effort
from ...runtime.integrators.loop import interruptible, start_state
from ...status import Ending, Outcome
from ..post import drive_limits, modes
from ..post import energy as energy_balance
from ..post import results as results_io


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
    :mod:`gpmegen.analysis.post.results`). Its ``method``: "rk4" (step ``dt``, saving every
    ``save_every``-th step), "genalpha" (compiled, implicit, step ``dt``, numerical damping
    ``rho_inf``), "dop853" (compiled, adaptive), "radau" (compiled, implicit and adaptive),
    "scipy-radau" or another name of :mod:`gpmegen.runtime.integrators`; all but rk4 save every
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
    integrator = integrators.get(method)
    refusal = integrator.refusal(model.backend, bool(len(model.actuators)))
    if refusal:
        raise SimulationError(refusal)
    model.check_signal_span(0.0, t_end)
    qd0 = np.zeros(model.n_dof) if qd0 is None else np.array(qd0, dtype=float)
    model.check_forces_apart(q0)   # before the start's modes, which its undefined force would spoil
    omega = None  # the natural frequency that bounds the method's steps, when one does
    if t_end > 0 and not limits.are_lifted():  # t_end 0: no step
        if integrator.frequency == "highest":
            omega = modes.highest_frequency(model, 0.0, q0, qd0)
        elif integrator.frequency == "lowest":
            omega = modes.lowest_frequency(model, 0.0, q0, qd0)
    limits.check_run(model.n_dof, len(model.constraint_names), spec, model.backend, omega)
    if omega is not None:
        unstable = integrator.unstable_step(dt, lambda: modes.motion_eigenvalues(model, 0.0, q0, qd0))
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
    with interruptible():
        try:  # from the line below on, a signal keeps at least the start
            (notify or (lambda message: None))(f"integrating with {method} to t = {t_end:g} s; Ctrl-C or SIGTERM "
                                               f"stops it, keeping the results so far")
            t, y, outcome, effort = integrator.run(model, q0, qd0, spec, progress, watch)
        except KeyboardInterrupt:  # before the integrator's own loop began, or in the line
            t, y = np.zeros(1), start_state(model, q0, qd0)[None, :]
            outcome, effort = Outcome(Ending.INTERRUPTED, 0.0), Effort(0, 0, 0, 0, 0)
    model = watch.model  # with the dependent coordinates the run ended with
    if actuated:
        outcome = internal.explain(outcome, stability, actuated)
    taken = {option.name for option in integrator.options}  # the others are recorded as None
    settings = dict(method=method, dt=dt, save_every=spec.save_every, save_dt=spec.save_interval,
                    **{option.name: getattr(spec, option.name) if option.name in taken else None
                       for option in integrators.registry.options()},
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


def collect(model, t, y, status, settings) -> dict:
    """Derived quantities at the saved samples: E, Φ, drive, q̈, the forces that realize the
    constraints (``M q̈ - f``, with ``lambda`` of the ideal realization or the inputs ``u`` of the
    actuated one), energies, the dampers' work (:mod:`gpmegen.analysis.post.energy`) and each force
    element's length, rate and force, and each limited drive's law, limit and time at it. Evaluated
    for all samples at once (:func:`_derived_together`) where the run's model allows it, else
    sample by sample (:func:`_derived_each`): the same values, to round-off."""
    n = model.n_dof
    q, qd = y[:, :n], y[:, n:2 * n]
    samples = len(t)
    actuated = len(model.actuators) > 0
    z = y[:, 2 * n + 2:]   # the controller states: what the drives read at each sample
    ok = np.all(np.isfinite(y[:, :2 * n]), axis=1) & np.all(np.isfinite(z), axis=1)  # what the functions accept
    derived = _derived_together(model, t, q, qd, ok) if samples and not model.controller_names else None
    if derived is None:
        derived = _derived_each(model, t, q, qd, ok, z)
    E, drive, phi, qdd, reaction, lam, energy = derived
    finite = np.flatnonzero(ok)
    elements = np.full((samples, len(model.force_names), 3), np.nan)
    for k in finite if model.force_names else ():
        elements[k] = model.at_controller_states(z[k]).force_elements(t[k], q[k], qd[k])
    limited = np.full((samples, len(model.limited_drives), 2), np.nan)
    for k in finite if model.limited_drives else ():
        limited[k] = model.at_controller_states(z[k]).drive_limits(t[k], q[k], qd[k])
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
        **({"controller_names": np.array(model.controller_names), "controller_states": z}
           if model.controller_names else {}),
        **({"force_names": np.array(model.force_names), "force_elements": elements} if model.force_names else {}),
        **({"limited_drives": np.array(model.limited_drives), "drive_laws": limited[:, :, 0],
            "drive_limits": limited[:, :, 1],
            "time_at_limit": drive_limits.time_at_limit(t, limited[:, :, 0], limited[:, :, 1])}
           if model.limited_drives else {}),
        "meta": results_io.encode({
            "model": model.module.MODEL, "coordinates": list(model.coordinates),
            "constraint_names": list(model.constraint_names), "backend": model.backend,
            "start": settings["start"], "settings": settings,
            "params": {name: float(value) for name, value in model.params.items()},
        }),
    }


def _derived_each(model, t, q, qd, ok, z):
    """:func:`collect`'s derived quantities, one sample at a time, each with its controller
    states ``z`` (samples, n_z): ``(E, drive, Φ, q̈, M q̈ - f, λ or u, energies)``; a sample
    whose GPME has no solution raises."""
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
        model_k = model.at_controller_states(z[k]) if ok[k] else model
        E[k] = model.end_effector(q[k])
        drive[k] = model_k.drive_forces(t[k], q[k], qd[k]) if ok[k] else np.nan
        if ok[k]:  # the state (the model's functions refuse one not finite)
            phi[k] = model.constraint_values(t[k], q[k], qd[k])
            D = model.constraint_terms(t[k], q[k], qd[k])[2]
            qdd[k], M, f = model_k.motion(t[k], q[k], qd[k])
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
