"""A model's start (a model file's ``[initial]`` configuration moved onto the programmed
constraints) and its constrained motion, with the derived quantities of the results. The paper's
scenario is in :mod:`gpmegen.analysis.reference_case`.
"""

from __future__ import annotations

import numpy as np

from .. import limits
from ..errors import ModelError, SimulationError
from ..runtime import gpme, integrate, internal, partition, statics
from . import results as results_io


def project_onto_constraints(model, q, t=0.0, tol=1e-12, max_iter=50, hint=None):
    """Move the dependent coordinates so that Φ(q, t) = 0 (Newton on the m×m block). When it
    fails, the message names the model's constraints left violated, with their values at the
    closest configuration found, and ends with ``hint`` (default: a generic one)."""
    q = np.array(q, dtype=float)
    dep = model.dependent
    qd = np.zeros_like(q)
    closest = None
    for _ in range(max_iter):
        phi, _, D, _ = model.constraint_terms(t, q, qd)
        worst = np.max(np.abs(phi), initial=0.0)
        if worst <= tol:
            return q
        if closest is None or worst < np.max(np.abs(closest)):
            closest = phi
        try:
            q[dep] -= np.linalg.solve(D[:, dep], phi)
        except np.linalg.LinAlgError:
            break
        if not np.all(np.isfinite(q)):
            break
    violated = ", ".join(f"{name} = {value:.3e}" for name, value in zip(model.constraint_names, closest)
                         if abs(value) > tol)
    moved = ", ".join(model.coordinates[k] for k in dep)
    raise SimulationError(
        f"model {model.module.MODEL}: the programmed constraints cannot be met from the start configuration by "
        f"moving {moved}: at best {violated}; "
        + (hint or "is the prescribed position within the chain's reach with these parameter values and this "
                   "start ([initial] q)?"))


def file_start(model, initial: dict, start="initial"):
    """Start of a model file's run: the ``[initial]`` configuration (``initial``: coordinate name
    → value), dependent coordinates chosen when the file says "auto", optionally the locked
    statics first, then moved onto the constraints; ``start="constrained"`` then solves the
    constrained equilibrium. Returns the model and q0 (n,)."""
    q = np.zeros(model.n_dof)
    for name, value in initial.items():
        q[model.index(name)] = value
    if model.dependent is None:
        model = partition.partition_at(model, q)
    if start == "locked":
        q = statics.locked(model, q)
    q = project_onto_constraints(model, q)
    if start == "constrained":
        q = statics.constrained(model, q)
    elif start not in ("initial", "locked"):
        raise ValueError(f"unknown start {start!r}: use 'initial', 'locked' or 'constrained'")
    return model, q


def simulate(model, q0, t_end, dt=1e-5, save_every=1, method="rk4", progress=None, max_violation=1e-2,
             start="locked", repartition=False, notify=None, internal_dynamics=False):
    """The constrained motion from rest at ``q0``; returns a results dict (see
    :mod:`gpmegen.analysis.results`). The conditioning of the dependent block of ``D`` is
    watched: ``notify`` (a callable taking a message) is told when it degrades, and with
    ``repartition`` the dependent coordinates are chosen anew. A fixed-step run that cannot finish
    is refused before it starts (:func:`gpmegen.limits.check_run`). An actuated run (``model``
    with actuators) tells ``notify`` its internal dynamics at the start and, with
    ``internal_dynamics``, saves them at every saved sample (``internal_eigenvalues``)."""
    # the actuated realization runs the Python loop on either backend: estimated as the NumPy one (from above)
    loop = "numpy" if len(model.actuators) else model.backend
    limits.check_run(model.n_dof, len(model.constraint_names), t_end, dt, save_every, method, loop)
    qd0 = np.zeros(model.n_dof)
    model.check_actuators(0.0, q0)
    actuated = [model.coordinates[k] for k in model.actuators]
    if internal_dynamics and not actuated:
        raise ModelError("the internal dynamics belong to an actuated realization: name the actuated coordinates "
                         "(--actuated, or a model file's actuators)")
    if actuated:
        stability = internal.eigenvalues(model, 0.0, q0, qd0)
        (notify or (lambda message: None))(
            f"internal dynamics of the inputs on {', '.join(actuated)} at the start: {internal.describe(stability)}")
    # the actuated realization does not use the partition: nothing to watch
    watch = partition.Watch(model, repartition, notify, limit=np.inf if len(model.actuators) else
                            partition.ILL_CONDITIONED)
    if method == "rk4":
        t, y, outcome = integrate.rk4(model, q0, qd0, t_end, dt, save_every, progress=progress,
                                      max_violation=max_violation, watch=watch)
    else:
        t, y, outcome = integrate.adaptive(model, q0, qd0, t_end, method=method)
    model = watch.model  # with the dependent coordinates the run ended with
    if actuated:
        outcome = internal.explain(outcome, stability, actuated)
    settings = dict(method=method, dt=dt, save_every=save_every, t_end=t_end, start=start, backend=model.backend,
                    dependent=[model.coordinates[k] for k in model.dependent] if model.dependent is not None else [],
                    repartitions=watch.events, actuators=actuated)
    results = collect(model, t, y, str(outcome), settings)
    if actuated and internal_dynamics and len(t):
        results["internal_eigenvalues"] = internal.along(model, t, results["q"], results["qd"])
        worst = np.nanmax(results["internal_eigenvalues"].real, axis=1, initial=-np.inf)
        k = int(np.argmax(worst))
        (notify or (lambda message: None))(
            f"internal dynamics along the run: largest real part {worst[k]:.4g} 1/s at t = {t[k]:.6g} s")
    return results


def collect(model, t, y, status, settings) -> dict:
    """Derived quantities at the saved samples: E, Φ, drive, q̈, the forces that realize the
    constraints (``M q̈ - f``, with ``lambda`` of the ideal realization or the inputs ``u`` of the
    actuated one), energies."""
    n, m = model.n_dof, len(model.constraint_names)
    q, qd = y[:, :n], y[:, n:2 * n]
    samples = len(t)
    E = np.zeros((samples, 3))
    phi = np.zeros((samples, m))
    drive = np.zeros((samples, n))
    qdd = np.full((samples, n), np.nan)
    reaction = np.zeros((samples, n))
    lam = np.full((samples, m), np.nan)
    energy = np.zeros((samples, 3))
    actuated = len(model.actuators) > 0
    for k in range(samples):
        E[k] = model.end_effector(q[k])
        phi[k], _, D, _ = model.constraint_terms(t[k], q[k], qd[k])
        drive[k] = model.drive_forces(t[k])
        if np.all(np.isfinite(y[k])):
            qdd[k], M, f = model.motion(t[k], q[k], qd[k])
            reaction[k] = M @ qdd[k] - f
            lam[k] = reaction[k][model.actuators] if actuated else gpme.multipliers(M, f, qdd[k], D)
        energy[k] = model.energies(q[k], qd[k])
    realization = ({"u": lam, "actuators": np.array([model.coordinates[k] for k in model.actuators])} if actuated
                   else {"lambda": lam})
    return {
        "t": t, "q": q, "qd": qd, "qdd": qdd, "coordinates": np.array(model.coordinates),
        "end_effector": E, "phi": phi, "constraint_names": np.array(model.constraint_names),
        # the drives' generalized forces summed: the one drive torque of a single-drive model
        "tau_drive": drive.sum(axis=1),
        "drive_forces": drive, "constraint_forces": reaction, **realization,
        "kinetic_energy": energy[:, 0], "gravity_energy": energy[:, 1], "spring_energy": energy[:, 2],
        "work_drive": y[:, 2 * n], "work_constraints": y[:, 2 * n + 1],
        "status": np.array(status),
        "meta": results_io.encode({
            "model": model.module.MODEL, "coordinates": list(model.coordinates),
            "constraint_names": list(model.constraint_names), "backend": model.backend,
            "start": settings["start"], "settings": settings,
            "params": {name: float(value) for name, value in model.params.items()},
        }),
    }
