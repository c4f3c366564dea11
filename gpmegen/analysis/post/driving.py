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

from ...model.chain import TIME, FlexibleLink, Joint, point_symbols, point_velocity_symbols, symbol, velocity_symbol
from ...model.expand import expand
from ...model.rfem import discretize
from ...runtime import statics
from . import closures
from . import results as results_io
from .coordinates import elastic_coordinates

# Unit of a generalized force on a coordinate, by joint kind.
FORCE_UNITS = {"revolute": "N·m", "prismatic": "N"}
# Unit of λ by (constraint order, unit of its expression): λ·Φ̇ (order 0) or λ·Ψ (order 1) is a power.
LAMBDA_UNITS = {(0, "m"): "N", (0, "m²"): "N/m", (0, "m³"): "N/m²", (0, "rad"): "N·m",
                (1, "m/s"): "N", (1, "rad/s"): "N·m", (1, "m²/s"): "N/m"}
GENERALIZED = "generalized"
# Unit of a coordinate by joint kind, and the powers of a length that an expression's unit names.
COORDINATE_UNITS = {"revolute": "rad", "prismatic": "m"}
LENGTH_POWERS = {1: "m", 2: "m²", 3: "m³"}


def force_units(model, expanded=None) -> dict:
    """Unit of the generalized force on each coordinate of the symbolic ``model`` (``expanded``:
    its :func:`gpmegen.model.expand.expand` where the caller has it)."""
    elements = (expand(model) if expanded is None else expanded).elements
    return {e.name: FORCE_UNITS[e.kind] for e in elements if isinstance(e, Joint)}


def expression_unit(model, constraint, expanded=None) -> str | None:
    """The unit of ``constraint``'s expression where its form tells it, else None: one
    coordinate (its velocity, first order) with coefficient ±1 beside a law of time and
    parameters (a prescribed joint: rad or m; rad/s or m/s); or a polynomial in the coordinates
    of points (first order: their velocities) whose terms in them have one degree d and numbers
    as coefficients (m^d; m/s). Parameters carry no units, so these are the forms that fix it.
    ``expanded``: as in :func:`force_units`."""
    expr = sp.sympify(constraint.expression)
    expanded = expand(model) if expanded is None else expanded
    kinds = {e.name: e.kind for e in expanded.elements if isinstance(e, Joint)}
    if constraint.order == 0:
        coordinates = {symbol(name): COORDINATE_UNITS[kind] for name, kind in kinds.items()}
        points, lengths = {s for p in expanded.points for s in point_symbols(p)}, LENGTH_POWERS
    elif constraint.order == 1:
        coordinates = {velocity_symbol(name): COORDINATE_UNITS[kind] + "/s" for name, kind in kinds.items()}
        points, lengths = {s for p in expanded.points for s in point_velocity_symbols(p)}, {1: "m/s"}
    else:
        return None
    own_coordinates, own_points = expr.free_symbols & coordinates.keys(), expr.free_symbols & points
    if len(own_coordinates) == 1 and not own_points:
        (coordinate,) = own_coordinates
        return coordinates[coordinate] if sp.diff(expr, coordinate) in (sp.S.One, sp.S.NegativeOne) else None
    if own_points and not own_coordinates:
        try:
            terms = [(sum(powers), c) for powers, c in sp.Poly(expr, *sorted(own_points, key=str)).terms()]
        except sp.PolynomialError:
            return None
        degrees = {d for d, _ in terms if d}
        if len(degrees) == 1 and all(c.is_number for d, c in terms if d):
            return lengths.get(degrees.pop())
    return None


def joint_laws(model, expanded=None) -> dict:
    """Coordinate → (constraint name, ±1) for each position constraint of the form ``±q - law(t)``
    on that coordinate alone (a prescribed joint): its reaction ``Dᵀλ`` is ``±λ`` on that joint
    and nothing elsewhere, the joint's motor. The reactions of the other constraints on that joint
    (a slider's guide on a crank) are not its motor's. ``expanded``: as in :func:`force_units`."""
    expanded = expand(model) if expanded is None else expanded
    kinds = {e.name for e in expanded.elements if isinstance(e, Joint)}
    coordinates = {symbol(name): name for name in kinds}
    points = {s for p in expanded.points for s in point_symbols(p)}
    laws = {}
    for c in model.constraints:
        expr = sp.sympify(c.expression)
        own = expr.free_symbols & coordinates.keys()
        if c.order == 0 and len(own) == 1 and not expr.free_symbols & points:
            (coordinate,) = own
            sign = sp.diff(expr, coordinate)
            if sign in (sp.S.One, sp.S.NegativeOne) and coordinates[coordinate] not in laws:
                laws[coordinates[coordinate]] = (c.name, int(sign))
    return laws


def lambda_units(model, constraint_units: dict, expanded=None) -> dict:
    """Unit of each constraint's λ from the unit of its expression: ``constraint_units`` (name →
    unit) where the case gives it, else a closure's row's (a coincidence or slide row is a length,
    its λ a force; an orientation row a cosine, its λ a moment), else :func:`expression_unit`,
    else "generalized". ``expanded``: as in :func:`force_units`."""
    looped = {closure.row_name(label): "m" if len(label) == 1 or label.endswith("1") else "rad"
              for closure in model.closures for label in closure.rows}
    return {c.name: LAMBDA_UNITS.get((c.order, constraint_units.get(c.name) or looped.get(c.name)
                                      or expression_unit(model, c, expanded)), GENERALIZED)
            for c in model.constraints}


def point_constraints(model, expanded=None) -> dict:
    """Point name → indices of the position constraints written on that point's coordinates
    alone (besides time and parameters). ``expanded``: as in :func:`force_units`."""
    params = {p.symbol for p in model.parameters}
    found = {}
    for point in (expand(model) if expanded is None else expanded).points:
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


def point_forces(model, loaded, t, q, lam, expanded=None) -> dict:
    """Point name → (k, 3) forces in {0} (N) that realize the constraints on it, at the saved
    samples ``t`` (k,), ``q`` (k, n) with multipliers ``lam`` (k, m). ``expanded``: as in
    :func:`force_units`."""
    out = {}
    for point, rows in point_constraints(model, expanded).items():
        force = point_force_function(model, point, rows)
        positions = loaded.point_positions(q)[:, loaded.points.index(point)] if len(t) else np.zeros((0, 3))
        out[point] = np.array([force(t[k], positions[k], loaded.p, lam[k])
                               for k in range(len(t))]).reshape(len(t), 3)
    return out


def deformation(loaded, q, elastic=None) -> dict:
    """The elastic deformation at the samples ``q`` (k, n): ``spring_forces`` (k, n) the springs'
    generalized forces ``C q`` (the bending and torsion moments ``c·ψ`` at the sdes, N·m; zero on
    coordinates without a spring) and ``deflection`` (k, 3) m, the end-effector's displacement in
    {0} from where the rigid arm at the same joint coordinates puts it (the ``elastic``
    coordinates zero: the flexible links' sdes, :func:`gpmegen.analysis.post.coordinates.elastic_coordinates`;
    None, for generated code without its model: those with a spring)."""
    C = statics.spring_stiffness(loaded, q[0])
    if elastic is None:
        elastic = np.flatnonzero(np.abs(np.diag(C)) > 0)
    rigid = q.copy()
    rigid[:, elastic] = 0.0
    return {"spring_forces": q @ C.T, "deflection": loaded.end_effector(q) - loaded.end_effector(rigid)}


#: The largest rotation (rad) of one sde that the RFEM's linear springs describe as a beam: its
#: moment ``c·ψ`` with ``c = EI/Δ`` is small-strain beam theory's, whose ``sin ψ ≈ ψ`` is off by
#: 0.17 % at 0.1 rad and by ``ψ²/6`` beyond; a larger rotation is a kink between two rfes, not a
#: smooth bend, and more rfes share it out.
ELASTIC_ROTATION = 0.1


def large_rotation(model, loaded, t, q) -> str | None:
    """A warning (one line) when a rotation of the symbolic ``model``'s sdes exceeds
    :data:`ELASTIC_ROTATION` in magnitude at the samples ``t`` (k,), ``q`` (k, n) of ``loaded``:
    the largest, its value and time; None when none does."""
    names = [part.name for link in model.chain if isinstance(link, FlexibleLink) for part in discretize(link)
             if isinstance(part, Joint) and part.kind == "revolute"]
    columns = [loaded.index(name) for name in names if name in loaded.coordinates]
    if not columns or not len(t):
        return None
    size = np.abs(np.asarray(q, dtype=float)[:, columns])
    size[~np.isfinite(size)] = 0.0
    k, j = np.unravel_index(int(np.argmax(size)), size.shape)
    if size[k, j] <= ELASTIC_ROTATION:
        return None
    return (f"warning: the sde rotation {loaded.coordinates[columns[j]]} reaches {q[k, columns[j]]:.3g} rad at "
            f"t = {t[k]:.6g} s, beyond {ELASTIC_ROTATION:g} rad per sde, where the RFEM's linear sde springs "
            f"(small-strain beam bending and torsion) no longer model the beam; use more rfes, a stiffer link or "
            f"a gentler motion")


def annotate(results: dict, model, loaded) -> dict:
    """``results`` of a run of the symbolic ``model`` (loaded as ``loaded``) with the units of its
    driving functions in the metadata (``force_units``, ``lambda_units``), the elastic
    :func:`deformation` and, for the ideal realization, ``point_forces`` (k, n_points, 3) N on
    the points named by ``meta["force_points"]`` and the reactions of the closures
    (:mod:`gpmegen.analysis.post.closures`, described by ``meta["closures"]``). ``model`` None
    (generated code alone): the deformation only."""
    meta = results_io.metadata(results)
    elastic = None if model is None else elastic_coordinates(model, loaded)
    arrays = deformation(loaded, results["q"], elastic) if loaded.points and len(results["t"]) else {}
    if model is None:  # generated code without its model (a built folder): forces in generalized units
        return results_io.annotate(results, {}, arrays)
    expanded = expand(model)  # once for all that follows
    units = {"force_units": force_units(model, expanded),
             "lambda_units": lambda_units(model, meta.get("constraint_units", {}), expanded),
             "joint_laws": {name: list(law) for name, law in joint_laws(model, expanded).items()}}
    if "lambda" in results:
        forces = point_forces(model, loaded, results["t"], results["q"], results["lambda"], expanded)
        units["force_points"] = list(forces)
        if forces:
            arrays["point_forces"] = np.stack(list(forces.values()), axis=1)
        if model.closures:
            units["closures"] = closures.describe(model)
            arrays.update(closures.result_arrays(model, results["q"], results["lambda"], loaded.p))
    return results_io.annotate(results, units, arrays)


def holding(model, loaded, q) -> dict:
    """What holds the configuration ``q`` at rest, drive off: ``joints`` (name → generalized
    force of ``g + C q`` on each coordinate without a spring, N·m or N), ``lambda`` (m,) the
    multipliers with which the constraints alone come closest (``Dᵀλ = g + C q``, least squares)
    and ``unbalanced`` the largest generalized force they leave (0 at a constrained
    equilibrium; at the locked start, what the joints' locks hold)."""
    r = loaded.static_residual(q)
    springs = set(np.flatnonzero(np.abs(np.diag(statics.spring_stiffness(loaded, q))) > 0).tolist())
    joints = {name: float(r[k]) for k, name in enumerate(loaded.coordinates) if k not in springs}
    D = loaded.constraint_terms(0.0, q, np.zeros(loaded.n_dof))[2]
    lam = np.linalg.lstsq(D.T, r, rcond=None)[0] if len(D) else np.zeros(0)
    return {"joints": joints, "lambda": lam, "unbalanced": float(np.max(np.abs(r - D.T @ lam), initial=0.0))}


def format_holding(model, loaded, q, constraint_units=None) -> str:
    """:func:`holding` as ``gpmegen statics`` prints it, with units."""
    held = holding(model, loaded, q)
    units = force_units(model)
    lines = ["holding forces at rest, drive off (g + C q on the joints): "
             + ", ".join(f"{name} = {value:.6g} {units[name]}" for name, value in held["joints"].items())]
    if len(held["lambda"]):
        lam_units = lambda_units(model, constraint_units or {})
        lines.append("constraint multipliers at rest (Dᵀλ = g + C q, least squares): "
                     + ", ".join(f"{c.name} = {value:.6g} {lam_units[c.name]}"
                                 for c, value in zip(model.constraints, held["lambda"]))
                     + f"; largest generalized force the constraints leave: {held['unbalanced']:.3g} (N or N·m)")
    return "\n".join(lines)
