"""The modified rigid finite element method: a flexible link as rfes joined by sdes.

Primary division: the link of length ``L`` is cut into ``n_sde = n_rfe - 1`` equal segments of
length ``Δ = L/n_sde`` with one sde at the middle of each. Secondary division: the rfes lie
between the sdes, so the first and last are ``Δ/2`` long and the others ``Δ``. sde stiffness:
``c_ψ = E·Iz/Δ``, ``c_θ = E·Iy/Δ``, ``c_φ = G·J/Δ`` (reference model, sect. "RFEM"), and
``c_u = E·A/Δ`` for the axial stretch of a link that asks for it. An rfe of
length ``ℓ`` has the mass ``ρA·ℓ``, its centre at ``ℓ/2`` and ``∫x² dm = ρA·ℓ³/3``,
``∫y² dm = ρIz·ℓ``, ``∫z² dm = ρIy·ℓ``.

Every section reaches the RFEM through :func:`section_properties` (``EIz, EIy, GJ, ρA, ρIz,
ρIy``, and ``EA``), so a section given by those values builds the same elements as the section
they come from. Links are axially rigid unless their ``freedoms`` hold ``u``.
"""

from __future__ import annotations

import difflib
from dataclasses import dataclass

import sympy as sp

from ..errors import ModelError
from .chain import (
    PAPER_FREEDOMS,
    SDE_FREEDOMS,
    SDE_JOINTS,
    Body,
    CircularSection,
    FlexibleLink,
    ISection,
    Joint,
    Offset,
    RectangularSection,
    StiffnessSection,
    TubeSection,
)
from .shapes import pseudo_inertia

SECTIONS = (RectangularSection, CircularSection, TubeSection, ISection, StiffnessSection)
MATERIAL = ("density", "young_modulus", "shear_modulus")


@dataclass(frozen=True)
class SectionProperties:
    """What the RFEM uses of a cross-section, per unit length: bending stiffnesses ``EIz``
    (about the local z axis), ``EIy`` and torsional stiffness ``GJ`` (N·m²), mass ``rhoA``
    (kg/m), rotary inertias ``rhoIz = ρ∫y² dA``, ``rhoIy = ρ∫z² dA`` (kg·m) and axial
    stiffness ``EA`` (N; None when a section given by its stiffnesses does not give it)."""

    EIz: sp.Expr
    EIy: sp.Expr
    GJ: sp.Expr
    rhoA: sp.Expr
    rhoIz: sp.Expr
    rhoIy: sp.Expr
    EA: sp.Expr | None


def link_coordinates(n_rfe, freedoms=PAPER_FREEDOMS) -> int:
    """Coordinates of a flexible link of ``n_rfe`` rfes: the free freedoms of each sde. Values
    not yet validated count as far as they can tell (an invalid ``n_rfe``: none; entries of
    ``freedoms`` that are no sde freedom: none), for size estimates before validation."""
    if isinstance(n_rfe, bool) or not isinstance(n_rfe, int) or n_rfe < 1:
        return 0
    if not isinstance(freedoms, (tuple, list)):
        freedoms = PAPER_FREEDOMS
    return sum(1 for name in SDE_FREEDOMS if name in freedoms) * (n_rfe - 1)


def geometry(section):
    """Area (m²), second moments ``Iy = ∫z² dA, Iz = ∫y² dA`` about the local y and z axes (m⁴),
    and the default torsion constant (m⁴) of a section given by its dimensions."""
    if isinstance(section, RectangularSection):
        b, t = section.width, section.thickness
        area = b * t
        iz = b * t**3 / 12  # bending about z: thickness t along y
        iy = t * b**3 / 12
        # Saint-Venant approximation for a rectangle (Roark): J = a c³ (1/3 - 0.21 c/a (1 - c⁴/(12 a⁴)))
        a, c = sp.Max(b, t), sp.Min(b, t)
        torsion = a * c**3 * (sp.Rational(1, 3) - sp.Rational(21, 100) * c / a * (1 - c**4 / (12 * a**4)))
        return area, iy, iz, torsion
    if isinstance(section, CircularSection):
        r = section.radius
        area = sp.pi * r**2
        i = sp.pi * r**4 / 4
        return area, i, i, 2 * i
    if isinstance(section, TubeSection):
        # Hollow circle (Roark, table of section properties): A = π(D² - d²)/4,
        # I = π(D⁴ - d⁴)/64; its torsion constant is the polar moment 2I, exact for a round tube.
        outer, inner = section.outer_diameter, section.inner_diameter
        area = sp.pi * (outer**2 - inner**2) / 4
        i = sp.pi * (outer**4 - inner**4) / 64
        return area, i, i, 2 * i
    if isinstance(section, ISection):
        # Two flanges b x tf and a web tw x (h - 2 tf), each moment about the centroid
        # (parallel-axis theorem): Iz = (b h³ - (b - tw)(h - 2tf)³)/12, Iy = (2 tf b³ + (h - 2tf) tw³)/12.
        # Torsion: the thin-walled open-section approximation J ≈ Σ b t³/3 over the three
        # rectangles (Roark, torsion of thin-walled open sections); it neglects the fillets and
        # the corners' overlap, and overestimates J for thick walls.
        h, b, tf, tw = section.height, section.width, section.flange_thickness, section.web_thickness
        web = h - 2 * tf
        area = 2 * b * tf + web * tw
        iz = (b * h**3 - (b - tw) * web**3) / 12
        iy = (2 * tf * b**3 + web * tw**3) / 12
        torsion = (2 * b * tf**3 + web * tw**3) / 3
        return area, iy, iz, torsion
    raise ModelError(f"unknown section type {type(section).__name__}: use one of "
                     f"{', '.join(s.__name__ for s in SECTIONS)}")


def section_properties(link: FlexibleLink) -> SectionProperties:
    """The section properties of ``link``: given (:class:`StiffnessSection`), or made from its
    section's dimensions and its material (the link's ``torsion_constant`` when given)."""
    section = link.section
    if isinstance(section, StiffnessSection):
        return SectionProperties(*(None if getattr(section, key) is None else sp.sympify(getattr(section, key))
                                   for key in SectionProperties.__dataclass_fields__))
    area, iy, iz, default_torsion = geometry(section)
    torsion = default_torsion if link.torsion_constant is None else link.torsion_constant
    rho, young = link.density, link.young_modulus
    return SectionProperties(young * iz, young * iy, link.shear_modulus * torsion, rho * area, rho * iz, rho * iy,
                             young * area)


def rfe_lengths(link: FlexibleLink):
    """Lengths (m) of the rfes, from the base of the link to its tip."""
    n = link.n_rfe
    if n == 1:
        return [link.length]
    delta = link.length / (n - 1)
    return [delta / 2] + [delta] * (n - 2) + [delta / 2]


def check_nrfe(nrfe, what: str, minimum: int = 1, subject: tuple = ()) -> int:
    """``nrfe`` when it is a whole number of rfes ≥ ``minimum`` (1: a rigid link), else a
    ModelError naming ``what`` it is for, when given (about the field ``subject``). The one place
    this rule is kept."""
    if isinstance(nrfe, bool) or not isinstance(nrfe, int) or nrfe < minimum:
        rigid = " (1: a rigid link)" if minimum == 1 else ""
        raise ModelError(f"{what}: " * bool(what) + f"nrfe must be a whole number ≥ {minimum}{rigid}, got {nrfe!r}; "
                         f"write e.g. nrfe = {max(minimum, 3)}", subject)
    return nrfe


def check_freedoms(freedoms, what: str, subject: tuple = ()) -> tuple:
    """``freedoms`` as the free sde freedoms in the order each sde applies them, else a
    ModelError naming ``what`` they are for (about the field ``subject``). The one place this
    rule is kept."""
    choices = ", ".join(f'"{name}"' for name in SDE_FREEDOMS)
    if isinstance(freedoms, str) or not isinstance(freedoms, (tuple, list)) or not freedoms:
        raise ModelError(f"{what}: freedoms must be a non-empty list of sde freedoms among {choices}, got "
                         f"{freedoms!r}; write e.g. freedoms = [\"psi\"] (a rigid link: nrfe = 1)", subject)
    for k, name in enumerate(freedoms):
        if name not in SDE_FREEDOMS:
            close = difflib.get_close_matches(str(name), SDE_FREEDOMS, 1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            raise ModelError(f"{what}: unknown sde freedom {name!r} in freedoms; {hint}use {choices} (stretch "
                             f"along x, bending about z, about y, torsion about x)", subject + (k,))
        if name in freedoms[:k]:
            raise ModelError(f"{what}: sde freedom {name!r} is listed twice in freedoms; name each once",
                             subject + (k,))
    return tuple(name for name in SDE_FREEDOMS if name in freedoms)


def check_link(link: FlexibleLink, path: tuple = ()) -> tuple:
    """``link``'s free sde freedoms (:func:`check_freedoms`), or a ModelError about the field
    (under ``path``, the link's) at fault when its ``nrfe``, ``freedoms``, section or material
    do not go together."""
    what = f"flexible link {link.label!r}"
    check_nrfe(link.n_rfe, what, subject=path + ("nrfe",))
    freedoms = check_freedoms(link.freedoms, what, path + ("freedoms",))
    if not isinstance(link.section, SECTIONS):
        geometry(link.section)   # raises, naming the sections there are
    if isinstance(link.section, StiffnessSection):
        for key in (*MATERIAL, "torsion_constant"):
            if getattr(link, key) is not None:
                raise ModelError(f"{what}: a section given by its stiffnesses (EIz, EIy, GJ, rhoA) already holds "
                                 f"the material; remove {key}", path + (key,))
        if "u" in freedoms and link.section.EA is None:
            raise ModelError(f"{what}: the link is free to stretch (\"u\" in freedoms) but its section gives no "
                             f"axial stiffness; add EA (N) to the section or remove \"u\"", path + ("section",))
        return freedoms
    for key in MATERIAL:
        if getattr(link, key) is None:
            raise ModelError(f"{what}: a section given by its dimensions needs the material: add {key} (or give "
                             f"the section by its stiffnesses EIz, EIy, GJ, rhoA)", path)
    return freedoms


def rfe_inertia(properties: SectionProperties, length):
    """Pseudo-inertia of an rfe of ``length`` (m) along x from 0 (the module's formulas)."""
    mass = properties.rhoA * length
    return pseudo_inertia(mass, (length / 2, 0, 0),
                          (mass * length**2 / 3, properties.rhoIz * length, properties.rhoIy * length))


def discretize(link: FlexibleLink):
    """Expand ``link`` into chain elements: rfe bodies, offsets and sde joints (its free
    freedoms) with springs, ending with an offset to the link's tip."""
    freedoms = check_link(link)
    section = section_properties(link)
    lengths = rfe_lengths(link)
    n_sde = link.n_rfe - 1
    delta = link.length / n_sde if n_sde else None
    stiffness = {}
    if n_sde:
        stiffness = {"psi": section.EIz / delta, "theta": section.EIy / delta, "phi": section.GJ / delta}
        if "u" in freedoms:
            stiffness["u"] = section.EA / delta
    damping = dict(zip(PAPER_FREEDOMS, (sp.sympify(d) for d in link.damping)), u=sp.S.Zero)

    elements = []
    for r, length in enumerate(lengths):
        if r > 0:
            elements.append(Offset((lengths[r - 1], 0, 0)))
            for name, kind, axis in SDE_JOINTS:
                if name in freedoms:
                    elements.append(Joint(f"{name}{link.label}_{r}", kind, axis, stiffness[name], damping[name]))
        elements.append(Body(f"rfe{link.label}_{r}", rfe_inertia(section, length)))
    elements.append(Offset((lengths[-1], 0, 0)))
    return elements
