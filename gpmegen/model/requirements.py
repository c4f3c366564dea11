"""Physical bounds on a model's quantities, for any parameter values bound to it.

Rigid bodies: masses, sizes and principal moments of inertia zero or positive (zero is a
massless body or one of no extent; the beam checks use a massless slider). Flexible links:
length, section sizes, density, moduli, torsion constant and a section's given stiffnesses and
mass per length positive (the RFEM divides by the length and needs mass and stiffness in every
element), a tube's wall, an I-section's web height and flange overhang positive, rotary inertias
zero or positive but not both zero in a link free to twist. Stiffness, damping and Baumgarte gains
zero or positive.

:func:`requirements` lists them once from the model's elements; :func:`violation` evaluates one
at parameter values. The model-file reader reports them at their lines with the parameter
defaults, the runtime whenever parameter values are bound (``gpmegen.load(params=...)``,
``--param``, ``with_params``).
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass

import sympy as sp

from .chain import Body, Constraint, FlexibleLink, ISection, Joint, Model, StiffnessSection, TubeSection, symbol

POSITIVE, NONNEGATIVE = "positive", "nonnegative"

# key in an element's description -> (the quantity, the rule's plural)
NAMES = {
    "mass": ("mass", "masses"), "radius": ("radius", "radii"), "length": ("length", "lengths"),
    "width": ("width", "widths"), "thickness": ("thickness", "thicknesses"),
    "inertia": ("moment of inertia", "moments of inertia"), "density": ("density", "densities"),
    "young_modulus": ("Young's modulus", "moduli"), "shear_modulus": ("shear modulus", "moduli"),
    "torsion_constant": ("torsion constant", "torsion constants"),
    "outer_diameter": ("outer diameter", "diameters"), "inner_diameter": ("inner diameter", "diameters"),
    "height": ("height", "heights"), "flange_thickness": ("flange thickness", "thicknesses"),
    "web_thickness": ("web thickness", "thicknesses"),
    "wall": ("tube wall", "tube walls (outer_diameter - inner_diameter)"),
    "web_height": ("web height", "web heights (height - 2 flange_thickness)"),
    "flange_overhang": ("flange overhang", "flange overhangs (width - web_thickness)"),
    "EIz": ("bending stiffness EIz", "stiffnesses"), "EIy": ("bending stiffness EIy", "stiffnesses"),
    "GJ": ("torsional stiffness GJ", "stiffnesses"), "rhoA": ("mass per length rhoA", "masses per length"),
    "EA": ("axial stiffness EA", "stiffnesses"),
    "rhoIz": ("rotary inertia rhoIz", "rotary inertias"), "rhoIy": ("rotary inertia rhoIy", "rotary inertias"),
    "polar": ("polar rotary inertia", "rotary inertias rhoIz + rhoIy of a link free to twist (phi in freedoms)"),
    "stiffness": ("stiffness", "stiffnesses"), "damping": ("damping coefficient", "damping coefficients"),
    "rest_length": ("rest length", "rest lengths"),
    "gear": ("gear ratio", "gear ratios"), "limit": ("force limit", "drive limits"),
    "alpha": ("Baumgarte gain alpha", "Baumgarte gains"), "beta": ("Baumgarte gain beta", "Baumgarte gains"),
}


@dataclass(frozen=True)
class Requirement:
    """``expression`` (of parameters) must be positive, or zero or positive (``sign``).

    ``kind`` and ``name`` say whose quantity it is ("body", "slider"); ``key`` where it sits in
    that element's description, as a model file writes it (``("shape", "mass")``); ``element``
    the path of that element in the model (``("chain", 1)``)."""

    expression: sp.Expr
    sign: str
    kind: str
    name: str
    key: tuple
    element: tuple = ()
    word: str = ""   # the quantity's key in NAMES when it is not the last of ``key``

    @property
    def subject(self) -> tuple:
        """The path of the quantity's field (see :class:`gpmegen.errors.ModelError`)."""
        return self.element + self.key

    @property
    def quantity(self) -> str:
        return NAMES[self.word or _word(self.key)][0]

    @property
    def plural(self) -> str:
        return NAMES[self.word or _word(self.key)][1]

    @property
    def owner(self) -> str:
        return f"{self.kind} {self.name!r}"


def _word(key) -> str:
    return next(part for part in reversed(key) if isinstance(part, str))


# Section sizes that may be zero (a solid tube; a rotary inertia neglected); the others must be positive.
_MAY_BE_ZERO = ("inner_diameter", "rhoIz", "rhoIy")


def _section(link: FlexibleLink) -> list:
    """(key, expression, sign, word) of the section's bounds: each given quantity, then the
    differences of dimensions that make the shape (a tube's wall, an I-section's web and flange)
    and, when the link twists, the rotary inertia torsion needs."""
    section = link.section
    items = [(("section", f.name), getattr(section, f.name), NONNEGATIVE if f.name in _MAY_BE_ZERO else POSITIVE, "")
             for f in dataclasses.fields(section) if getattr(section, f.name) is not None]
    if isinstance(section, TubeSection):
        items.append((("section", "inner_diameter"), section.outer_diameter - section.inner_diameter, POSITIVE,
                      "wall"))
    elif isinstance(section, ISection):
        items += [(("section", "height"), section.height - 2 * section.flange_thickness, POSITIVE, "web_height"),
                  (("section", "width"), section.width - section.web_thickness, POSITIVE, "flange_overhang")]
    elif isinstance(section, StiffnessSection) and isinstance(link.freedoms, (tuple, list)) and "phi" in link.freedoms:
        items.append((("section",), sp.sympify(section.rhoIz) + sp.sympify(section.rhoIy), POSITIVE, "polar"))
    return items


def _link(link: FlexibleLink, element: tuple) -> list:
    items = [(("length",), link.length, POSITIVE, "")] + _section(link)
    items += [((key,), getattr(link, key), POSITIVE, "")
              for key in ("density", "young_modulus", "shear_modulus", "torsion_constant")
              if getattr(link, key) is not None]
    items += [(("damping", k), d, NONNEGATIVE, "") for k, d in enumerate(link.damping)]
    return [Requirement(sp.sympify(e), sign, "flexible link", link.label, key, element, word)
            for key, e, sign, word in items]


def _drive_train(joint: Joint, element: tuple) -> list:
    """A joint's motor (gear ratio positive; inertia zero or positive, positive on a
    series-elastic joint, whose motor coordinate it alone gives mass) and series-elastic spring
    (stiffness positive, damping zero or positive)."""
    items = []
    if joint.motor is not None:
        sign = NONNEGATIVE if joint.series_elastic is None else POSITIVE
        items += [(("motor", "inertia"), joint.motor.inertia, sign),
                  (("motor", "gear"), joint.motor.gear, POSITIVE)]
    if joint.series_elastic is not None:
        items += [(("series_elastic", "stiffness"), joint.series_elastic.stiffness, POSITIVE),
                  (("series_elastic", "damping"), joint.series_elastic.damping, NONNEGATIVE)]
    return [Requirement(sp.sympify(e), sign, "joint", joint.name, key, element) for key, e, sign in items]


def requirements(model: Model) -> tuple[Requirement, ...]:
    """The bounds on ``model``'s quantities that involve parameters or are numbers, in chain
    order, then the constraints' gains."""
    out = []
    for k, element in enumerate(model.chain):
        path = ("chain", k)
        if isinstance(element, Joint):
            out += [Requirement(sp.sympify(getattr(element, key)), NONNEGATIVE, "joint", element.name, (key,), path)
                    for key in ("stiffness", "damping")]
            out += _drive_train(element, path)
        elif isinstance(element, Body):
            quantities = element.quantities or ((("mass",), element.pseudo_inertia[3, 3]),)
            out += [Requirement(sp.sympify(e), NONNEGATIVE, "body", element.name, key, path) for key, e in quantities]
        elif isinstance(element, FlexibleLink):
            out += _link(element, path)
    for k, c in enumerate(model.constraints):
        if isinstance(c, Constraint):
            out += [Requirement(sp.sympify(getattr(c, key)), NONNEGATIVE, "constraint", c.name, (key,),
                                ("constraints", k)) for key in ("alpha", "beta")]
    for k, drive in enumerate(model.drives):
        if drive.limit is not None:
            out.append(Requirement(sp.sympify(drive.limit), POSITIVE, "drive on", drive.coordinate, ("limit",),
                                   ("drives", k)))
    for k, element in enumerate(getattr(model, "forces", ())):
        out += [Requirement(sp.sympify(getattr(element, key)), NONNEGATIVE, "force", element.name, (key,),
                            ("forces", k)) for key in ("stiffness", "rest_length", "damping")]
    return tuple(out) + _believed(model)


def _believed(model: Model) -> tuple[Requirement, ...]:
    """The controller model's bounds that the computed-torque law's ``params`` (its parameters
    as expressions of the plant's) reach, written in the plant's parameters (the controller's
    others at their defaults): a belief the plant's values make unphysical, a negative mass, is
    refused as the plant's own bounds are, at the line of the ``params`` entry."""
    law = getattr(model, "computed_torque", None)
    if law is None or not law.params:
        return ()
    given = dict(law.params)
    own = {p.symbol: p.name for p in law.controller.parameters}
    mapping = {p.symbol: sp.sympify(given[p.name]) if p.name in given else sp.Float(float(p.default))
               for p in law.controller.parameters}
    out = []
    for need in requirements(law.controller):
        reached = sorted(own[s] for s in need.expression.free_symbols if own.get(s) in given)
        if reached:
            out.append(dataclasses.replace(
                need, expression=need.expression.xreplace(mapping), kind=f"controller model's {need.kind}",
                key=(reached[0],), element=("controller", "params"), word=need.word or _word(need.key)))
    return tuple(out)


def evaluate(expression, values: dict) -> float | None:
    """``expression`` with the parameters at ``values`` (symbol -> number) as a finite double, or
    None when it is not one (not a real number, infinite, or beyond a double)."""
    try:
        value = sp.sympify(expression).xreplace({s: sp.Float(v) for s, v in values.items()})
        if not value.is_number:
            return None
        number = sp.N(value, 17)
        if number.is_real is False or not number.is_finite:
            return None
        result = float(number)
    except (TypeError, ValueError, OverflowError, ArithmeticError):
        return None
    return result if math.isfinite(result) else None


def violation(requirement: Requirement, values: dict, bound: str = "") -> str | None:
    """Why ``requirement`` fails at the parameter ``values`` (name -> number), or None when it
    holds. ``bound`` says where the values come from (e.g. "the parameter defaults"); by
    default the values of the parameters involved are named."""
    expr = requirement.expression
    value = evaluate(expr, {symbol(k): v for k, v in values.items()})
    positive = requirement.sign == POSITIVE
    if value is not None and (value > 0 if positive else value >= 0):
        return None
    need = f"{requirement.plural} must be {'positive' if positive else 'zero or positive'}"
    shown = "not a finite real number" if value is None else f"{value:g}"
    if expr.is_number:
        state = ("negative" if value < 0 else "zero") + f" value {shown}" if value is not None else shown
        return f"{state}; {need}"
    names = sorted(s.name for s in expr.free_symbols)
    given = ", ".join(f"{n} = {values[n]:g}" for n in names if n in values)
    source = f"{bound} ({given})" if bound else given
    formula = "" if isinstance(expr, sp.Symbol) else f" = {expr}"
    return (f"the {requirement.quantity} of {requirement.owner}{formula} is {shown} with {source}; {need}: "
            f"change {', '.join(names)}")


def first_violation(needs, values: dict, changed=None, bound: str = "") -> str | None:
    """The first failure among ``needs`` at ``values`` (name -> number), considering only those
    that involve a name in ``changed`` when given; None when all hold."""
    for requirement in needs:
        if changed is not None and not {s.name for s in requirement.expression.free_symbols} & set(changed):
            continue
        problem = violation(requirement, values, bound)
        if problem:
            return problem
    return None
