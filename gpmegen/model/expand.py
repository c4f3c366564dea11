"""Validation of a Model and its expansion into a flat chain of joints, offsets, bodies and
points (flexible links discretized by RFEM)."""

from __future__ import annotations

import math
from dataclasses import dataclass

import sympy as sp

from ..errors import ModelError
from .chain import (
    AXES,
    JOINT_KINDS,
    TIME,
    Body,
    FlexibleLink,
    Joint,
    Model,
    Offset,
    Point,
    check_name,
    point_symbols,
    point_velocity_symbols,
    symbol,
    velocity_symbol,
)
from .rfem import discretize


@dataclass(frozen=True)
class FlatChain:
    """A validated model with its flexible links expanded.

    ``elements``: Joint, Offset, Body and Point only, base first. ``coordinates``: the joint
    names in chain order (the order of ``q``)."""

    model: Model
    elements: tuple
    coordinates: tuple

    @property
    def n_dof(self) -> int:
        return len(self.coordinates)

    @property
    def points(self) -> tuple:
        return tuple(e.name for e in self.elements if isinstance(e, Point))

    @property
    def bodies(self) -> tuple:
        return tuple(e.name for e in self.elements if isinstance(e, Body))


def _check_expression(expr, allowed: set, where: str):
    try:
        expr = sp.sympify(expr)
    except (sp.SympifyError, TypeError) as exc:
        raise ModelError(f"{where}: not a valid expression ({exc})") from None
    if expr.has(sp.DiracDelta):
        raise ModelError(f"{where}: DiracDelta is an impulse, which generated code cannot evaluate; prescribe the "
                         f"motion it causes instead (a jump with Heaviside or Piecewise)")
    if any(pw.args[-1].cond != sp.true for pw in expr.atoms(sp.Piecewise)):
        raise ModelError(f"{where}: a Piecewise has no last pair (value, True), so its value is undefined where "
                         f"no condition holds; end it with (value, True)")
    unknown = sorted(str(s) for s in expr.free_symbols if s not in allowed)
    if unknown:
        raise ModelError(
            f"{where}: unknown name(s) {', '.join(unknown)}; declare them as parameters or use "
            f"names defined in the model"
        )
    return expr


def expand(model: Model) -> FlatChain:
    """Validate ``model`` and expand its flexible links; raise ModelError naming the fault."""
    check_name(model.name, "model name")
    seen: dict[str, str] = {}

    def claim(name, what):
        check_name(name, what, bare=what in ("parameter", "coordinate"))
        if name in seen:
            raise ModelError(f"{what} {name!r} duplicates the {seen[name]} of the same name: rename one")
        seen[name] = what

    for p in model.parameters:
        claim(p.name, "parameter")
        if not math.isfinite(float(p.default)):
            raise ModelError(f"parameter {p.name!r} has the default {p.default}, not a finite number; give a "
                             f"value below 1e308 in size")
    params = {p.symbol for p in model.parameters}
    constant = params  # expressions of the chain may use parameters only

    elements = []
    for k, element in enumerate(model.chain):
        where = f"chain element {k + 1}"
        if isinstance(element, FlexibleLink):
            for attr in ("length", "density", "young_modulus", "shear_modulus"):
                _check_expression(getattr(element, attr), constant, f"{where} (flexible link {element.label!r}) {attr}")
            elements.extend(discretize(element))
        elif isinstance(element, (Joint, Offset, Body, Point)):
            elements.append(element)
        else:
            raise ModelError(f"{where}: unknown element {type(element).__name__}")

    coordinates = []
    for element in elements:
        if isinstance(element, Joint):
            claim(element.name, "coordinate")
            if element.kind not in JOINT_KINDS:
                raise ModelError(f"joint {element.name!r}: unknown kind {element.kind!r}; use one of "
                                 f"{', '.join(JOINT_KINDS)}")
            if element.axis not in AXES:
                raise ModelError(f"joint {element.name!r}: unknown axis {element.axis!r}; use x, y or z")
            _check_expression(element.stiffness, constant, f"joint {element.name!r} stiffness")
            _check_expression(element.damping, constant, f"joint {element.name!r} damping")
            coordinates.append(element.name)
        elif isinstance(element, Body):
            claim(element.name, "body")
            h = sp.ImmutableMatrix(element.pseudo_inertia)
            if h.shape != (4, 4) or h != h.T:
                raise ModelError(f"body {element.name!r}: the pseudo-inertia must be a symmetric 4x4 matrix")
            for v in h:
                _check_expression(v, constant, f"body {element.name!r} pseudo-inertia")
        elif isinstance(element, Point):
            claim(element.name, "point")
            for v in element.position:
                _check_expression(v, constant, f"point {element.name!r} position")
        else:
            for v in element.translation:
                _check_expression(v, constant, "offset translation")
            for axis, angle in element.rotations:
                if axis not in AXES:
                    raise ModelError(f"offset rotation about unknown axis {axis!r}; use x, y or z")
                _check_expression(angle, constant, "offset rotation angle")
    if not coordinates:
        raise ModelError(f"model {model.name!r} has no joints: add at least one joint")

    points = [e.name for e in elements if isinstance(e, Point)]
    # names the constraint expressions give to points and velocities must not shadow a parameter
    # or a coordinate, else an expression would silently mean one of the two
    derived = {f"{c}_dot": f"velocity of coordinate {c!r}" for c in coordinates}
    for name in points:
        for a in "xyz":
            for prefix, what in (("", "coordinate"), ("v", "velocity"), ("a", "acceleration")):
                derived[f"{prefix}{a}_{name}"] = f"{what} {a} of point {name!r}"
    for name, what in [(p.name, "parameter") for p in model.parameters] + [(c, "coordinate") for c in coordinates]:
        if name in derived:
            raise ModelError(f"{what} {name!r} has the name of the {derived[name]} in constraint "
                             f"expressions: rename the {what}")
    for v in model.gravity:
        _check_expression(v, constant, "gravity")
    for drive in model.drives:
        if drive.coordinate not in coordinates:
            raise ModelError(f"drive on unknown coordinate {drive.coordinate!r}; coordinates are "
                             f"{', '.join(coordinates)}")
        _check_expression(drive.expression, constant | {TIME}, f"drive on {drive.coordinate!r}")

    kinematic = set(params) | {TIME} | {symbol(c) for c in coordinates}
    for name in points:
        kinematic |= set(point_symbols(name))
    rates = {velocity_symbol(c) for c in coordinates}
    for name in points:
        rates |= set(point_velocity_symbols(name))
    for c in model.constraints:
        claim(c.name, "constraint")
        if c.order not in (0, 1):
            raise ModelError(f"constraint {c.name!r}: order must be 0 (position) or 1 (first order), got {c.order!r}")
        allowed = kinematic | (rates if c.order == 1 else set())
        expr = _check_expression(c.expression, allowed, f"constraint {c.name!r}")
        if c.order == 1 and not (expr.free_symbols & rates):
            raise ModelError(f"constraint {c.name!r}: a first-order constraint must involve velocities")
        if c.order == 1 and any(sp.diff(expr, r, 2) != 0 for r in expr.free_symbols & rates):
            raise ModelError(f"constraint {c.name!r}: a first-order constraint must be linear in the velocities")
        _check_expression(c.alpha, constant, f"constraint {c.name!r} alpha")
        _check_expression(c.beta, constant, f"constraint {c.name!r} beta")
    if model.dependent is not None:
        for name in model.dependent:
            if name not in coordinates:
                raise ModelError(f"dependent coordinate {name!r} is not a coordinate; coordinates are "
                                 f"{', '.join(coordinates)}")
        if len(set(model.dependent)) != len(model.constraints):
            raise ModelError(
                f"{len(model.constraints)} constraint(s) need as many distinct dependent coordinates, "
                f"{len(model.dependent)} given"
            )
    return FlatChain(model, tuple(elements), tuple(coordinates))
