"""The modified rigid finite element method: a flexible link as rfes joined by sdes.

Primary division: the link of length ``L`` is cut into ``n_sde = n_rfe - 1`` equal segments of
length ``Δ = L/n_sde`` with one sde at the middle of each. Secondary division: the rfes lie
between the sdes, so the first and last are ``Δ/2`` long and the others ``Δ``. sde stiffness:
``c_ψ = E·Iz/Δ``, ``c_θ = E·Iy/Δ``, ``c_φ = G·J/Δ`` (reference model, sect. "RFEM").
"""

from __future__ import annotations

import sympy as sp

from ..errors import ModelError
from .chain import Body, CircularSection, FlexibleLink, Joint, Offset, RectangularSection
from .shapes import bar, rod

# Order of the three sde rotations, and their axes (paper eq. 1: ψ about z, θ about y, φ about x).
SDE_ROTATIONS = (("psi", "z"), ("theta", "y"), ("phi", "x"))


def link_coordinates(n_rfe: int) -> int:
    """Coordinates of a flexible link of ``n_rfe`` rfes: the three rotations of each sde."""
    return len(SDE_ROTATIONS) * (n_rfe - 1)


def section_properties(section):
    """Area (m²), second moments ``Iy, Iz`` about the local y and z axes (m⁴), and the default
    torsion constant (m⁴) of a cross-section."""
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
    raise ModelError(f"unknown section type {type(section).__name__}: use a rectangular or circular section")


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


def discretize(link: FlexibleLink):
    """Expand ``link`` into chain elements: rfe bodies, offsets and sde joints with springs,
    ending with an offset to the link's tip."""
    check_nrfe(link.n_rfe, f"flexible link {link.label!r}")
    area, iy, iz, default_torsion = section_properties(link.section)
    torsion = default_torsion if link.torsion_constant is None else link.torsion_constant
    lengths = rfe_lengths(link)
    n_sde = link.n_rfe - 1
    delta = link.length / n_sde if n_sde else None
    stiffness = {}
    if n_sde:
        stiffness = {
            "psi": link.young_modulus * iz / delta,
            "theta": link.young_modulus * iy / delta,
            "phi": link.shear_modulus * torsion / delta,
        }
    damping = dict(zip((name for name, _ in SDE_ROTATIONS), (sp.sympify(d) for d in link.damping)))

    elements = []
    for r, length in enumerate(lengths):
        if r > 0:
            elements.append(Offset((lengths[r - 1], 0, 0)))
            for rot, axis in SDE_ROTATIONS:
                elements.append(
                    Joint(f"{rot}{link.label}_{r}", "revolute", axis, stiffness[rot], damping[rot])
                )
        mass = link.density * area * length
        if isinstance(link.section, RectangularSection):
            h = bar(mass, length, link.section.width, link.section.thickness)
        else:
            h = rod(mass, length, link.section.radius)
        elements.append(Body(f"rfe{link.label}_{r}", h))
    elements.append(Offset((lengths[-1], 0, 0)))
    return elements
