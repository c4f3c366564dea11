"""Driving functions: the forces that realize the programmed constraints, with their units.

Ideal realization (the GPME): ``M q̈ - f = Dᵀλ``. The generalized reaction ``Dᵀλ`` acts on all
coordinates, the elastic ones included, so it is not a set of actuator torques; ``λ_i`` is the
force of constraint ``i`` per unit of its expression. For position constraints written on the
coordinates of one point P, ``Dᵀλ = J_Pᵀ F`` with ``F = Σ λ_i ∂Φ_i/∂r_P`` (N, in {0}): the force
applied at P that realizes those constraints. Actuated realization: inputs ``u`` on named
coordinates alone (:meth:`gpmegen.runtime.model.LoadedModel.actuation`).
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ..model.chain import TIME, Joint, point_symbols
from ..model.expand import expand
from . import results as results_io

# Unit of a generalized force on a coordinate, by joint kind.
FORCE_UNITS = {"revolute": "N·m", "prismatic": "N"}
# Unit of λ by (constraint order, unit of its expression): λ·Φ̇ (order 0) or λ·Ψ (order 1) is a power.
LAMBDA_UNITS = {(0, "m"): "N", (0, "m²"): "N/m", (0, "rad"): "N·m",
                (1, "m/s"): "N", (1, "rad/s"): "N·m", (1, "m²/s"): "N/m"}
GENERALIZED = "generalized"


def force_units(model) -> dict:
    """Unit of the generalized force on each coordinate of the symbolic ``model``."""
    return {e.name: FORCE_UNITS[e.kind] for e in expand(model).elements if isinstance(e, Joint)}


def lambda_units(model, constraint_units: dict) -> dict:
    """Unit of each constraint's λ from the unit of its expression (``constraint_units``, name →
    unit, where the case knows it), else "generalized"."""
    return {c.name: LAMBDA_UNITS.get((c.order, constraint_units.get(c.name)), GENERALIZED)
            for c in model.constraints}


def point_constraints(model) -> dict:
    """Point name → indices of the position constraints written on that point's coordinates
    alone (besides time and parameters)."""
    params = {p.symbol for p in model.parameters}
    found = {}
    for point in expand(model).points:
        allowed = set(point_symbols(point)) | params | {TIME}
        rows = [i for i, c in enumerate(model.constraints)
                if c.order == 0 and sp.sympify(c.expression).free_symbols <= allowed
                and sp.sympify(c.expression).free_symbols & set(point_symbols(point))]
        if rows:
            found[point] = rows
    return found


def point_force_function(model, point: str, rows):
    """``F(t, r_P, p, λ)`` (3,) N: ``Σ λ_i ∂Φ_i/∂r_P`` over the constraints ``rows`` on ``point``;
    ``p`` the parameter values in the model's order."""
    xyz = point_symbols(point)
    params = [p.symbol for p in model.parameters]
    gradient = sp.Matrix([[sp.diff(model.constraints[i].expression, a) for a in xyz] for i in rows])
    evaluate = sp.lambdify([TIME, xyz, params], gradient, modules="numpy")
    return lambda t, r, p, lam: np.asarray(evaluate(t, r, p), dtype=float).T @ np.asarray(lam)[rows]


def point_forces(model, loaded, t, q, lam) -> dict:
    """Point name → (k, 3) forces in {0} (N) that realize the constraints on it, at the saved
    samples ``t`` (k,), ``q`` (k, n) with multipliers ``lam`` (k, m)."""
    out = {}
    for point, rows in point_constraints(model).items():
        force = point_force_function(model, point, rows)
        index = loaded.points.index(point)
        out[point] = np.array([force(t[k], loaded.point_positions(q[k])[index], loaded.p, lam[k])
                               for k in range(len(t))]).reshape(len(t), 3)
    return out


def annotate(results: dict, model, loaded) -> dict:
    """``results`` of a run of the symbolic ``model`` (loaded as ``loaded``) with the units of its
    driving functions in the metadata (``force_units``, ``lambda_units``) and, for the ideal
    realization, ``point_forces`` (k, n_points, 3) N on the points named by ``meta["force_points"]``."""
    meta = results_io.metadata(results)
    units = {"force_units": force_units(model),
             "lambda_units": lambda_units(model, meta.get("constraint_units", {}))}
    if "lambda" not in results:
        return results_io.annotate(results, units, {})
    forces = point_forces(model, loaded, results["t"], results["q"], results["lambda"])
    arrays = {"point_forces": np.stack(list(forces.values()), axis=1)} if forces else {}
    return results_io.annotate(results, {**units, "force_points": list(forces)}, arrays)
