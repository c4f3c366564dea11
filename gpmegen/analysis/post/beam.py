"""Analytic reference values of linear beam theory, for verifying the RFEM discretization.

Every function is plain arithmetic on floats in SI units (m, N, N·m, Pa, kg/m³); each names
its source. Signs: deflections and rotations are positive in the sense of the load that causes
them (a load pushing the tip down deflects it down and turns it down).

Sources:

- Timoshenko S. P., Gere J. M., *Mechanics of Materials*, appendix "Deflections and slopes of
  beams", table of cantilever beams (cases: uniform load, tip force, tip couple);
  the same formulas are in Roark's *Formulas for Stress and Strain* (Young, Budynas,
  7th ed.), Table 8.1, cases 1a, 2a and 3a (left end free, right end fixed).
- Blevins R. D., *Formulas for Natural Frequency and Mode Shape* (1979), ch. 8 "Straight
  beams": Euler–Bernoulli single-span beam, clamped–free, ``λ₁ = 1.87510407`` (``λᵢ = βᵢL``);
  and the torsional vibration of a uniform shaft, fixed–free (also Timoshenko, Young, Weaver,
  *Vibration Problems in Engineering*, torsional vibration of circular shafts, with the polar
  moment replaced by the section's ``I_p`` and the stiffness by ``G·J``).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

# Roots of cos(λ)·cosh(λ) = -1, the clamped–free Euler–Bernoulli beam (Blevins, ch. 8).
CLAMPED_FREE_LAMBDA = (1.87510407, 4.69409113, 7.85475744, 10.99554073, 14.13716839)

# L²·∫φ'² dx / ∫φ² dx of the first clamped–free mode φ(x) = cosh λx/L - cos λx/L
# - σ (sinh λx/L - sin λx/L), σ = (cosh λ + cos λ)/(sinh λ + sin λ), by quadrature (30 digits).
CLAMPED_FREE_SLOPE_RATIO = 4.64777831867864


@dataclass(frozen=True)
class Section:
    """Properties of a cross-section: area ``A`` (m²), second moments ``Iy`` (about the local y
    axis: bending in the x–z plane) and ``Iz`` (about z: bending in the x–y plane), polar
    moment ``Ip = Iy + Iz`` (m⁴)."""

    A: float
    Iy: float
    Iz: float

    @property
    def Ip(self) -> float:
        return self.Iy + self.Iz


def rectangular_section(width: float, thickness: float) -> Section:
    """Solid rectangle, ``width`` b along the local z, ``thickness`` t along y (m):
    ``A = b t``, ``Iz = b t³/12``, ``Iy = t b³/12`` (Timoshenko & Gere, appendix "Properties of
    plane areas"); the convention of :mod:`gpmegen.model.rfem`."""
    b, t = float(width), float(thickness)
    return Section(A=b * t, Iy=t * b**3 / 12.0, Iz=b * t**3 / 12.0)


# --- statics of the cantilever (clamped at x = 0, free at x = L) -------------------------------

def cantilever_uniform_load(w: float, L: float, EI: float) -> tuple[float, float]:
    """Tip deflection (m) and tip rotation (rad) of a cantilever of length ``L`` (m) and
    flexural rigidity ``EI`` (N·m²) under a uniform load ``w`` (N/m):
    ``δ = w L⁴ / (8 EI)``, ``θ = w L³ / (6 EI)``.
    Timoshenko & Gere, cantilever table, uniform load; Roark Table 8.1 case 2a (w_a = w_l)."""
    return w * L**4 / (8.0 * EI), w * L**3 / (6.0 * EI)


def cantilever_tip_force(P: float, L: float, EI: float) -> tuple[float, float]:
    """Tip deflection (m) and rotation (rad) under a transverse force ``P`` (N) at the free end:
    ``δ = P L³ / (3 EI)``, ``θ = P L² / (2 EI)``.
    Timoshenko & Gere, cantilever table, concentrated load at the free end; Roark Table 8.1
    case 1a (a = 0)."""
    return P * L**3 / (3.0 * EI), P * L**2 / (2.0 * EI)


def cantilever_tip_moment(M0: float, L: float, EI: float) -> tuple[float, float]:
    """Tip deflection (m) and rotation (rad) under a couple ``M0`` (N·m) at the free end, turning
    the tip in the sense of the deflection: ``δ = M0 L² / (2 EI)``, ``θ = M0 L / EI``.
    Timoshenko & Gere, cantilever table, couple at the free end; Roark Table 8.1 case 3a
    (a = 0)."""
    return M0 * L**2 / (2.0 * EI), M0 * L / EI


def cantilever_tip(L: float, EI: float, w: float = 0.0, P: float = 0.0, M0: float = 0.0) -> tuple[float, float]:
    """Tip deflection (m) and rotation (rad) under a uniform load ``w`` (N/m), a tip force ``P``
    (N) and a tip couple ``M0`` (N·m) together: the superposition of
    :func:`cantilever_uniform_load`, :func:`cantilever_tip_force` and
    :func:`cantilever_tip_moment` (linear theory, Timoshenko & Gere)."""
    parts = (cantilever_uniform_load(w, L, EI), cantilever_tip_force(P, L, EI),
             cantilever_tip_moment(M0, L, EI))
    return sum(p[0] for p in parts), sum(p[1] for p in parts)


# --- free vibration ----------------------------------------------------------------------------

def cantilever_bending_frequency(EI: float, mass_per_length: float, L: float, mode: int = 1) -> float:
    """Natural frequency (Hz) of bending mode ``mode`` (1, 2, …, 5) of a clamped–free
    Euler–Bernoulli beam: ``f = λ² / (2π L²) · sqrt(EI / (ρA))``, ``λ₁ = 1.87510407``.
    ``EI`` in N·m², ``mass_per_length`` = ρA in kg/m, ``L`` in m. Blevins, *Formulas for Natural
    Frequency and Mode Shape*, ch. 8, single-span beam, clamped–free (no rotary inertia or
    shear deformation)."""
    lam = CLAMPED_FREE_LAMBDA[mode - 1]
    return lam**2 / (2.0 * math.pi * L**2) * math.sqrt(EI / mass_per_length)


def cantilever_bending_frequency_rotary(EI: float, mass_per_length: float, rotary_inertia_per_length: float,
                                        L: float) -> float:
    """First bending frequency (Hz) of a clamped–free beam with the rotary inertia of its
    sections (a Rayleigh beam): ``f = f_EB / sqrt(1 + (ρI/ρA)·κ/L²)`` with
    ``κ = L² ∫φ'² / ∫φ² = 4.6478`` of the first Euler–Bernoulli mode φ. This is Rayleigh's
    quotient ``ω² = ∫EI φ''² / (∫ρA φ² + ∫ρI φ'²)`` evaluated with the Euler–Bernoulli mode
    (Rayleigh, *The Theory of Sound*, vol. 1, §186 "rotatory inertia"; Timoshenko, Young &
    Weaver, *Vibration Problems in Engineering*, "effect of rotatory inertia and shearing
    force"), exact to first order in ``ρI/(ρA L²)`` (the next term is of order
    ``(κ ρI/(ρA L²))²``, 4e-7 for the reference arm's horizontal bending).
    ``rotary_inertia_per_length`` = ρI (kg·m) about the bending axis.

    The rigid finite elements carry their sections' rotary inertia (``∫y² dm``, ``∫z² dm`` in
    their pseudo-inertias), so this, not :func:`cantilever_bending_frequency`, is the limit of
    the RFEM frequencies as ``n_rfe`` grows."""
    ratio = rotary_inertia_per_length / mass_per_length
    euler_bernoulli = cantilever_bending_frequency(EI, mass_per_length, L)
    return euler_bernoulli / math.sqrt(1.0 + ratio * CLAMPED_FREE_SLOPE_RATIO / L**2)


def shaft_torsion_frequency(GJ: float, polar_inertia_per_length: float, L: float, mode: int = 1) -> float:
    """Natural frequency (Hz) of torsional mode ``mode`` of a uniform shaft fixed at one end and
    free at the other: ``f = (2 mode - 1) π / (2L) · sqrt(GJ / (ρ I_p)) / (2π)``.
    ``GJ`` torsional rigidity (N·m²), ``polar_inertia_per_length`` = ρ·I_p (kg·m), I_p = Iy + Iz
    the polar second moment of the section (Saint-Venant torsion, no warping inertia).
    Blevins, ch. 8, torsional vibration of a shaft, fixed–free; Timoshenko, Young & Weaver,
    *Vibration Problems in Engineering*, torsional vibration of shafts."""
    return (2 * mode - 1) * math.pi / (2.0 * L) * math.sqrt(GJ / polar_inertia_per_length) / (2.0 * math.pi)


# --- the reference arm -------------------------------------------------------------------------

@dataclass(frozen=True)
class ArmReference:
    """Beam-theory values of a clamped–free arm (SI units): self-weight tip deflection under
    gravity ``g`` perpendicular to the arm (m), first vertical (about z, ``Iz``) and horizontal
    (about y, ``Iy``) Euler–Bernoulli bending frequencies and first torsional frequency (Hz);
    ``*_rotary``: the bending frequencies with the sections' rotary inertia
    (:func:`cantilever_bending_frequency_rotary`)."""

    tip_deflection: float
    vertical_bending: float
    horizontal_bending: float
    torsion: float
    vertical_bending_rotary: float
    horizontal_bending_rotary: float


def link_reference(L, EIz, EIy, GJ, rhoA, rhoIz, rhoIy, g) -> ArmReference:
    """:class:`ArmReference` of a clamped–free link of length ``L`` (m) with bending stiffnesses
    ``EIz``, ``EIy`` and torsional stiffness ``GJ`` (N·m²), mass ``rhoA`` (kg/m) and rotary
    inertias ``rhoIz``, ``rhoIy`` (kg·m), under gravity ``g`` (m/s²) perpendicular to it, bending
    about z. A section without rotary inertia has no torsion frequency (nan)."""
    polar = rhoIz + rhoIy
    return ArmReference(
        tip_deflection=cantilever_uniform_load(rhoA * g, L, EIz)[0],
        vertical_bending=cantilever_bending_frequency(EIz, rhoA, L),
        horizontal_bending=cantilever_bending_frequency(EIy, rhoA, L),
        torsion=shaft_torsion_frequency(GJ, polar, L) if polar > 0 else float("nan"),
        vertical_bending_rotary=cantilever_bending_frequency_rotary(EIz, rhoA, rhoIz, L),
        horizontal_bending_rotary=cantilever_bending_frequency_rotary(EIy, rhoA, rhoIy, L),
    )


def inclined_cantilever_tip(L: float, EI: float, rhoA: float, g: float, tip_mass: float, lever: float,
                            inclination: float) -> tuple[float, float]:
    """Euler–Bernoulli estimate of the tip deflection (m, perpendicular to the link in its
    vertical plane, downwards positive) and rotation (rad) of a link of length ``L`` (m), bending
    stiffness ``EI`` (N·m²) and mass ``rhoA`` (kg/m), clamped at ``inclination`` (rad above the
    horizontal) under gravity ``g`` (m/s²), carrying at its tip a body of mass ``tip_mass`` (kg)
    whose centre lies ``lever`` (m) beyond the tip along the link: the link's own weight, the
    body's weight at the tip and the couple of that weight about the tip, each projected
    perpendicular to the link (factor ``cos(inclination)``). Axial loads (beam-column effect) and
    large-deflection geometry are left out: the estimate is for small loads."""
    c = math.cos(inclination)
    w = rhoA * g * c
    P = tip_mass * g * c
    return cantilever_tip(L, EI, w=w, P=P, M0=P * lever)


__all__ = [
    "CLAMPED_FREE_LAMBDA", "Section", "rectangular_section", "cantilever_uniform_load",
    "cantilever_tip_force", "cantilever_tip_moment", "cantilever_tip",
    "cantilever_bending_frequency", "CLAMPED_FREE_SLOPE_RATIO", "cantilever_bending_frequency_rotary",
    "shaft_torsion_frequency", "ArmReference", "link_reference",
    "inclined_cantilever_tip",
]
