"""The cross-sections of a flexible link and the link itself (cut into rigid finite elements by
:mod:`gpmegen.model.rfem`), with the freedoms an sde may have."""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp


@dataclass(frozen=True)
class RectangularSection:
    """Rectangular cross-section: ``width`` along the link's local z, ``thickness`` along y (m)."""

    width: sp.Expr
    thickness: sp.Expr


@dataclass(frozen=True)
class CircularSection:
    """Solid circular cross-section of ``radius`` (m)."""

    radius: sp.Expr


@dataclass(frozen=True)
class TubeSection:
    """Circular tube of ``outer_diameter`` and ``inner_diameter`` (m; inner 0: a solid rod)."""

    outer_diameter: sp.Expr
    inner_diameter: sp.Expr


@dataclass(frozen=True)
class ISection:
    """I-section: web of ``web_thickness`` along the local y axis over the ``height``, two
    flanges of ``width`` along z and ``flange_thickness`` (all m). Bending about z (``psi``) is
    about the strong axis."""

    height: sp.Expr
    width: sp.Expr
    flange_thickness: sp.Expr
    web_thickness: sp.Expr


@dataclass(frozen=True)
class StiffnessSection:
    """A cross-section given by what the RFEM uses of it, as data sheets and benchmarks give it:
    bending stiffnesses ``EIz`` (about the local z axis) and ``EIy`` (N·m²), torsional stiffness
    ``GJ`` (N·m²), mass per length ``rhoA`` (kg/m) and rotary inertias per length ``rhoIz = ρ∫y² dA``
    and ``rhoIy = ρ∫z² dA`` (kg·m; 0 by default: rotary inertia neglected as in Euler–Bernoulli
    beam data, which leaves torsion without inertia, so a link free in ``phi`` needs them), and
    the axial stiffness ``EA`` (N), needed only by a link free to stretch (``u``)."""

    EIz: sp.Expr
    EIy: sp.Expr
    GJ: sp.Expr
    rhoA: sp.Expr
    rhoIz: sp.Expr = sp.S.Zero
    rhoIy: sp.Expr = sp.S.Zero
    EA: sp.Expr | None = None


# The freedoms of an sde in the order it applies them, each a joint of the current frame: the
# axial stretch ``u`` along x (m), then the paper's rotations (eq. 1: bending ψ about z, bending
# θ about y, torsion φ about x). A link has the paper's three unless it says otherwise.
SDE_JOINTS = (("u", "prismatic", "x"), ("psi", "revolute", "z"), ("theta", "revolute", "y"), ("phi", "revolute", "x"))


SDE_FREEDOMS = tuple(name for name, _, _ in SDE_JOINTS)


PAPER_FREEDOMS = ("psi", "theta", "phi")


@dataclass(frozen=True)
class FlexibleLink:
    """A slender link along the current frame's x axis, discretized by the modified rigid
    finite element method into ``n_rfe`` rfes joined by ``n_rfe - 1`` sdes (spring-damping
    elements) of up to three rotations each (bending about z: ``psi``, bending about y:
    ``theta``, torsion about x: ``phi``) and, when asked for, an axial stretch ``u``.

    ``label`` names the coordinates ``psi<label>_<r>``, ``theta<label>_<r>``, ``phi<label>_<r>``.
    ``freedoms`` names the sde freedoms that are free (the three rotations by default, the
    paper's choice; ``u`` adds the axial stretch, coordinates ``u<label>_<r>``); the others are
    held rigid and are no coordinates. ``density`` (kg/m³), the moduli
    (Pa) and ``torsion_constant`` (m⁴; ``None``: the section's own) belong with a section given
    by its dimensions; a :class:`StiffnessSection` carries them itself and takes none of them.
    ``damping`` holds the three damping coefficients of each sde, psi, theta, phi (N·m·s/rad;
    the stretch is undamped).
    """

    label: str
    length: sp.Expr
    section: RectangularSection | CircularSection | TubeSection | ISection | StiffnessSection
    density: sp.Expr | None = None
    young_modulus: sp.Expr | None = None
    shear_modulus: sp.Expr | None = None
    n_rfe: int | None = None
    torsion_constant: sp.Expr | None = None
    damping: tuple = (0, 0, 0)
    freedoms: tuple = PAPER_FREEDOMS
