"""The reference case: the paper's three-link spatial manipulator (rotary column, flexible
rotary arm, slider) with its programmed constraints; numbers from ``reference-model.md``."""

from __future__ import annotations

import sympy as sp

from .chain import (
    TIME,
    Body,
    Constraint,
    Drive,
    FlexibleLink,
    Joint,
    Model,
    Offset,
    Parameter,
    Point,
    RectangularSection,
    point_symbols,
    symbol,
)
from .presentation import Prescribed, Presentation
from .shapes import shape_quantities, solid_cylinder
from .start_constants import StartConstants

PARAMETERS = (
    Parameter("g", 9.81, "m/s^2", "gravitational acceleration, along -y0"),
    Parameter("m1", 10.0, "kg", "column mass"),
    Parameter("h1", 0.6, "m", "column height"),
    Parameter("R1", 0.05, "m", "column radius"),
    Parameter("L2", 1.0, "m", "arm length"),
    Parameter("b2", 0.04, "m", "arm section width (along the arm's z)"),
    Parameter("t2", 0.01, "m", "arm section thickness (along the arm's y)"),
    Parameter("rho2", 2700.0, "kg/m^3", "arm density"),
    Parameter("E2", 7.0e10, "Pa", "arm Young's modulus"),
    Parameter("G2", 2.6e10, "Pa", "arm shear modulus"),
    Parameter("J2", 1.124e-8, "m^4", "arm torsion constant (Saint-Venant, b/t = 4)"),
    Parameter("d2", 0.0, "N m s/rad", "damping of each sde rotation"),
    Parameter("m3", 2.0, "kg", "slider mass"),
    Parameter("L3", 0.5, "m", "slider length"),
    Parameter("R3", 0.02, "m", "slider radius"),
    Parameter("tdr0", 1.0, "N m", "drive torque on theta1 after the ramp (eq. 17)"),
    Parameter("t0", 5.0, "s", "duration of the drive ramp (eq. 17)"),
    Parameter("A", 0.5, "m", "amplitude of the height of E (eq. 18)"),
    Parameter("T", 2.5, "s", "period of the height of E (eq. 18)"),
    Parameter("r_Ea", 1.06066017177982, "m", "radius of the circle of E (eq. 2); set from statics"),
    Parameter("y_c", 1.16066017177982, "m", "centre of the height of E (eq. 18); set from statics"),
    Parameter("alpha_circle", 100.0, "1/s", "Baumgarte alpha of the circle constraint"),
    Parameter("beta_circle", 50.0, "1/s", "Baumgarte beta of the circle constraint"),
    Parameter("alpha_height", 100.0, "1/s", "Baumgarte alpha of the height constraint"),
    Parameter("beta_height", 50.0, "1/s", "Baumgarte beta of the height constraint"),
)


def start_constants() -> StartConstants:
    """The paper's start (reference-model.md, "Initial state"): the joints at ``θ1 = 0, ψ2 = 45°,
    x3 = 0``, and at their locked statics ``r_Ea = sqrt(x_E² + z_E²)`` and ``y_c = y_E - A``, so
    that the motion starts on the constraints and at rest."""
    P = {p.name: p.symbol for p in PARAMETERS}
    x, y, z = point_symbols("E")
    return StartConstants(at=(("theta1", sp.S.Zero), ("psi2", sp.pi / 4), ("x3", sp.S.Zero)),
                          values=(("r_Ea", sp.sqrt(x**2 + z**2)), ("y_c", y - P["A"])))


def prescribed_height(P: dict):
    """Eq. 18: the height of E (m) the height constraint prescribes; ``P`` maps parameter names
    to symbols."""
    return P["y_c"] + P["A"] * sp.cos(2 * sp.pi * TIME / P["T"])


def presentation(nrfe: int) -> Presentation:
    """How the paper labels the runs of the arm with ``nrfe`` rfes (1: the rigid arm): its joints
    and constraints with units, the paper's figures, and the prescribed height of E; the rigid
    and flexible arms' start points tagged E'_r and E'_f on opposite sides (they lie close)."""
    rigid = nrfe == 1
    P = {p.name: p.symbol for p in PARAMETERS}
    return Presentation(
        label="rigid arm" if rigid else f"flexible arm, n_rfe = {nrfe}",
        coordinates=(("theta1", "θ1 [rad]"), ("psi2", "ψ2 [rad]"), ("x3", "x3 [m]")),
        constraint_units=(("circle", "m²"), ("height", "m")),
        figures=(("joint_coordinates", "paper Fig. 2"), ("end_effector", "paper Fig. 3"), ("path", "paper Fig. 4")),
        start_tag=r"$E'_r$" if rigid else r"$E'_f$",
        colour="C0" if rigid else "C2",
        tag_offset=(-22, 8) if rigid else (8, -14),
        prescribed=Prescribed(1, "prescribed y_E,a", prescribed_height(P)),
    )


def drive_torque(t, tdr0, t0):
    """Eq. 17: a quintic ramp from 0 to ``tdr0`` over ``t0`` with zero rate and curvature at both
    ends, constant after."""
    s = sp.Min(t / t0, 1)
    return tdr0 * s**3 * (10 - 15 * s + 6 * s**2)


def reference_arm(P: dict, nrfe: int) -> FlexibleLink:
    """The flexible arm (body 2) with ``nrfe`` rfes; ``P`` maps parameter names to symbols."""
    return FlexibleLink(
        label="2",
        length=P["L2"],
        section=RectangularSection(P["b2"], P["t2"]),
        density=P["rho2"],
        young_modulus=P["E2"],
        shear_modulus=P["G2"],
        torsion_constant=P["J2"],
        n_rfe=nrfe,
        damping=(P["d2"], P["d2"], P["d2"]),
    )


def reference_model(nrfe: int = 5) -> Model:
    """The reference manipulator with its arm cut into ``nrfe`` rfes (1: rigid arm)."""
    P = {p.name: p.symbol for p in PARAMETERS}
    chain = (
        Joint("theta1", "revolute", "y"),
        Body("column", solid_cylinder(P["m1"], P["R1"], P["h1"], "y"),
             shape_quantities(mass=P["m1"], radius=P["R1"], length=P["h1"])),
        Offset((0, P["h1"], 0)),
        Joint("psi2", "revolute", "z"),
        reference_arm(P, nrfe),
        Joint("x3", "prismatic", "x"),
        Body("slider", solid_cylinder(P["m3"], P["R3"], P["L3"], "x"),
             shape_quantities(mass=P["m3"], radius=P["R3"], length=P["L3"])),
        Point("E", (P["L3"], 0, 0)),
    )
    x, y, z = point_symbols("E")
    t = TIME
    constraints = (
        # eq. 2: E on a horizontal circle of radius r_Ea about the column's axis
        Constraint("circle", x**2 + z**2 - P["r_Ea"] ** 2, 0, P["alpha_circle"], P["beta_circle"]),
        # eq. 3 with eq. 18: prescribed height of E
        Constraint(
            "height", y - prescribed_height(P), 0,
            P["alpha_height"], P["beta_height"],
        ),
    )
    return Model(
        name=f"manipulator_nrfe{nrfe}",
        parameters=PARAMETERS,
        chain=chain,
        gravity=(0, -P["g"], 0),
        drives=(Drive("theta1", drive_torque(t, P["tdr0"], P["t0"])),),
        constraints=constraints,
        dependent=("psi2", "x3"),
        description="three-link spatial manipulator: rotary column, flexible rotary arm, slider",
        start_constants=start_constants(),
        presentation=presentation(nrfe),
    )


__all__ = ["reference_model", "PARAMETERS", "drive_torque", "start_constants", "symbol"]
