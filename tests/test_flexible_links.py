"""Flexible links as users specify them: the sde rotations a link keeps (``freedoms``), sections
given by their stiffnesses or as tubes and I-sections, and joints moved by a prescribed law.

A planar arm (a revolute joint about z, one flexible link bending in the x-y plane, gravity in
that plane) keeps its out-of-plane sde rotations at zero by symmetry, so the link free in ``psi``
alone must move exactly as the full one; its natural frequencies are the full link's in-plane
ones, without the torsion and out-of-plane modes that set the full link's explicit step."""

from __future__ import annotations

import math

import numpy as np
import pytest
import sympy as sp

import gpmegen
from gpmegen.analysis.post import modes
from gpmegen.analysis.run.model_files import read_model_file
from gpmegen.errors import ModelError
from gpmegen.model.chain import (
    TIME,
    CircularSection,
    FlexibleLink,
    ISection,
    RectangularSection,
    StiffnessSection,
    TubeSection,
    symbol,
)
from gpmegen.model.expand import expand
from gpmegen.model.rfem import section_properties
from gpmegen.model.shapes import point_mass
from gpmegen.runtime import statics
from gpmegen.status import SolveStatus

PARAMETERS = """\
[parameters]
L = 1.0
b = 0.02
h = 0.005
rho = 2700.0
Y = 7.0e10
G = 2.6e10
J = 1.5e-10
g = 9.81
A = 2.0
W = 3.0
"""

RECTANGLE = 'section = { type = "rectangular", width = "b", thickness = "h" }\ndensity = "rho"\n' \
            'young_modulus = "Y"\nshear_modulus = "G"\ntorsion_constant = "J"'
# The same section by the values the RFEM takes from it: E·Iz, E·Iy, G·J, ρA and ρIz, ρIy for a
# width b along z and a thickness h along y (textbook formulas, written out independently).
BY_STIFFNESS = ('section = { type = "stiffness", EIz = "Y*b*h^3/12", EIy = "Y*h*b^3/12", GJ = "G*J", '
                'rhoA = "rho*b*h", rhoIz = "rho*b*h^3/12", rhoIy = "rho*h*b^3/12" }')


def planar_file(name, link, joint="", constraints="", top="", nrfe=3):
    """A model file of a planar arm: joint theta1 about z, one flexible link, tip point E,
    gravity along -y, a torque A sin(5t) on theta1."""
    drive = '[[drives]]\ncoordinate = "theta1"\nexpression = "A*sin(5*t)"\n'
    return (f'schema = 1\nname = "{name}"\nnrfe = {nrfe}\ngravity = [0, "-g", 0]\n{top}\n{PARAMETERS}\n'
            f'[[chain]]\njoint = "theta1"\ntype = "revolute"\naxis = "z"\n{joint}\n'
            f'[[chain]]\nflexible = "1"\nlength = "L"\n{link}\n\n'
            f'[[chain]]\npoint = "E"\n\n{drive}{constraints}')


def write(tmp_path, text, name="model.toml"):
    path = tmp_path / name
    path.write_text(text)
    return path


def load(env, tmp_path, name, link, backend="numpy", **kw):
    return gpmegen.load(model=read_model_file(write(tmp_path, planar_file(name, link, **kw), f"{name}.toml")).model,
                        backend=backend)


def read_error(tmp_path, text) -> str:
    with pytest.raises(ModelError) as info:
        read_model_file(write(tmp_path, text))
    message = str(info.value)
    assert "\n" not in message and message.startswith(str(tmp_path))
    return message


# --- freedoms ------------------------------------------------------------------------------------

@pytest.fixture(scope="module")
def planar(env, tmp_path_factory):
    tmp = tmp_path_factory.mktemp("planar")
    full = load(env, tmp, "planar_full", RECTANGLE)
    psi = load(env, tmp, "planar_psi", RECTANGLE + '\nfreedoms = ["psi"]')
    return full, psi


def test_a_link_free_in_psi_moves_as_the_full_link_in_its_plane(planar):
    full, psi = planar
    elastic = [c for c in full.coordinates if c != "theta1"]
    assert psi.coordinates == ("theta1", "psi1_1", "psi1_2")
    assert 3 * (psi.n_dof - 1) == len(elastic)
    assert psi.mass_matrix(np.zeros(psi.n_dof)).shape == (3, 3)
    same = [full.index(c) for c in psi.coordinates]
    t_f, q_f, qd_f, *_ = full.rk4(np.zeros(full.n_dof), np.zeros(full.n_dof), 0.2, 1e-4)
    t_p, q_p, qd_p, *_ = psi.rk4(np.zeros(psi.n_dof), np.zeros(psi.n_dof), 0.2, 1e-4)
    assert np.array_equal(t_f, t_p)
    assert np.abs(q_f[:, same]).max() > 0.1          # the arm moves and the link bends
    assert np.abs(q_f[:, full.index("psi1_2")]).max() > 1e-5
    assert np.abs(q_f[:, same] - q_p).max() < 1e-10
    assert np.abs(qd_f[:, same] - qd_p).max() < 1e-10
    out_of_plane = [k for k in range(full.n_dof) if k not in same]
    assert np.abs(q_f[:, out_of_plane]).max() < 1e-12


def test_a_link_free_in_psi_keeps_the_in_plane_frequencies_and_drops_the_fastest(planar):
    full, psi = planar
    omega = {}
    for m in planar:
        springs = [k for k, c in enumerate(m.coordinates) if c != "theta1"]
        omega[m.n_dof] = 2 * math.pi * modes.natural_frequencies(m, np.zeros(m.n_dof), springs).frequencies
    kept, all_ = omega[psi.n_dof], omega[full.n_dof]
    for w in kept:   # each in-plane mode of the reduced link is a mode of the full one
        assert np.min(np.abs(all_ - w)) < 1e-9 * w
    assert all_.max() > 10 * kept.max()      # torsion sets the full link's stable RK4 step 2.8/ω_max


def test_the_stable_step_of_the_link_free_in_psi_is_larger(planar):
    """At a step between the two RK4 limits 2.8/ω_max, a tiny twist makes the full link's run
    explode while the planar link's run stays on its fine-step motion."""
    full, psi = planar
    dt = 2e-3
    q0 = np.zeros(full.n_dof)
    q0[full.index("phi1_2")] = 1e-9
    _, q_f, *_, status = full.rk4(q0, np.zeros(full.n_dof), 0.2, dt)
    assert status != SolveStatus.OK or not np.abs(q_f[-1]).max() < 1.0
    _, q_p, *_, status_p = psi.rk4(np.zeros(psi.n_dof), np.zeros(psi.n_dof), 0.2, dt)
    _, q_fine, *_ = psi.rk4(np.zeros(psi.n_dof), np.zeros(psi.n_dof), 0.2, 1e-4)
    assert status_p == SolveStatus.OK and np.abs(q_p[-1] - q_fine[-1]).max() < 1e-3 * np.abs(q_fine[-1]).max()


@pytest.mark.parametrize("freedoms, coordinates", [
    (("theta", "psi"), ("psi1_1", "theta1_1", "psi1_2", "theta1_2")),   # kept in the sde's order
    (("phi",), ("phi1_1", "phi1_2")),
])
def test_freedoms_choose_the_coordinates_in_the_sde_order(freedoms, coordinates):
    link = FlexibleLink("1", 1, RectangularSection(0.02, 0.005), 2700, 7e10, 2.6e10, n_rfe=3, freedoms=freedoms)
    assert expand(_model(link)).coordinates[1:] == coordinates


@pytest.mark.parametrize("freedoms, words", [
    ('["psi", "tehta"]', "unknown sde freedom 'tehta' in freedoms; did you mean 'theta'?"),
    ('["psi", "psi"]', "sde freedom 'psi' is listed twice"),
    ("[]", "freedoms must be a non-empty list"),
    ('"psi"', "expected a list of sde freedoms, got a string"),
])
def test_bad_freedoms_are_one_located_line(tmp_path, freedoms, words):
    message = read_error(tmp_path, planar_file("bad", RECTANGLE + f"\nfreedoms = {freedoms}"))
    assert words in message and ".freedoms" in message


def test_bad_freedoms_in_python_are_a_model_error():
    link = FlexibleLink("1", 1, RectangularSection(0.02, 0.005), 2700, 7e10, 2.6e10, n_rfe=3, freedoms=("chi",))
    with pytest.raises(ModelError, match="unknown sde freedom 'chi'") as info:
        expand(_model(link))
    assert info.value.subject == ("chain", 1, "freedoms", 0)


def test_a_link_without_nrfe_in_python_is_a_model_error(env):
    """n_rfe has no default worth guessing; the build's size estimate, which runs before the
    model is validated, must not trip over its absence."""
    link = FlexibleLink("1", 1, RectangularSection(0.02, 0.005), 2700, 7e10, 2.6e10)
    with pytest.raises(ModelError, match="nrfe must be a whole number") as info:
        gpmegen.load(model=_model(link), backend="numpy")
    assert info.value.subject == ("chain", 1, "nrfe")


def _model(link):
    return gpmegen.Model("m", (), (gpmegen.Joint("theta1", "revolute", "z"), link))


# --- axial stretch -------------------------------------------------------------------------------

STEEL = dict(density=7800.0, young_modulus=2.1e11, shear_modulus=8.1e10)


def _hanging(n_rfe, tip_mass=0.0, freedoms=("u",)):
    """A 2 m steel bar of 10 x 10 mm hanging from its top (its x axis along -y, gravity -y)."""
    link = FlexibleLink("1", 2, RectangularSection(0.01, 0.01), n_rfe=n_rfe, freedoms=freedoms, **STEEL)
    chain = (gpmegen.Offset((0, 0, 0), (("z", -sp.pi / 2),)), link,
             gpmegen.Body("weight", point_mass(tip_mass)), gpmegen.Point("E"))
    return gpmegen.Model(f"hanging_{n_rfe}_{len(freedoms)}", (gpmegen.Parameter("g", 9.81),), chain,
                         gravity=(0, -symbol("g"), 0))


@pytest.mark.parametrize("n_rfe", [2, 5])
def test_a_link_free_to_stretch_hangs_as_long_as_beam_theory_says(env, n_rfe):
    """Under its own weight ρAg and a tip weight mg the bar stretches by ρgL²/(2E) + mgL/(EA):
    exact for the RFEM at any n_rfe, the sdes sitting at the middles of their segments, where
    the axial force (linear in x) has its mean."""
    rho, young, g, length, area, mass = 7800.0, 2.1e11, 9.81, 2.0, 1e-4, 5.0
    bar = gpmegen.load(model=_hanging(n_rfe, mass), backend="numpy")
    assert bar.coordinates == tuple(f"u1_{r}" for r in range(1, n_rfe))
    q = statics.locked(bar, np.zeros(bar.n_dof))
    stretch = -bar.end_effector(q)[1] - length
    expected = rho * g * length**2 / (2 * young) + mass * g * length / (young * area)
    assert stretch == pytest.approx(expected, rel=1e-8)
    rigid = gpmegen.load(model=_hanging(n_rfe, mass, ("psi", "theta", "phi")), backend="numpy")
    assert -rigid.end_effector(np.zeros(rigid.n_dof))[1] == pytest.approx(length, rel=1e-15)


def test_the_axial_frequency_of_a_link_free_to_stretch_converges_to_the_bar_s(env):
    """First axial mode of a fixed-free bar: ω = π/(2L) sqrt(E/ρ); the lumped RFEM chain
    approaches it as 1/n_rfe²."""
    exact = math.pi / (2 * 2.0) * math.sqrt(2.1e11 / 7800.0)
    errors = []
    for n_rfe in (3, 9):
        bar = gpmegen.load(model=_hanging(n_rfe), backend="numpy")
        first = modes.natural_frequencies(bar, np.zeros(bar.n_dof), list(range(bar.n_dof))).frequencies[0]
        errors.append(abs(2 * math.pi * first / exact - 1))
    assert errors[1] < 0.005 and errors[0] / errors[1] > 6


def test_a_section_by_its_stiffnesses_needs_ea_to_stretch(tmp_path):
    section = 'section = { type = "stiffness", EIz = 1e3, EIy = 1e3, GJ = 1e3, rhoA = 1, rhoIz = 1e-4, rhoIy = 1e-4 }'
    message = read_error(tmp_path, planar_file("bad", section + '\nfreedoms = ["u", "psi"]'))
    assert "chain[1].section: flexible link '1': the link is free to stretch" in message and "add EA" in message
    ok = read_model_file(write(tmp_path, planar_file("ok", section.replace("}", ", EA = 2e7 }") +
                                                     '\nfreedoms = ["psi", "u"]'), "ok.toml"))
    assert expand(ok.model).coordinates == ("theta1", "u1_1", "psi1_1", "u1_2", "psi1_2")


# --- sections ------------------------------------------------------------------------------------

@pytest.mark.parametrize("backend", ["numpy", pytest.param("c", marks=[pytest.mark.requires_cc, pytest.mark.long])])
def test_a_section_by_its_stiffnesses_equals_the_rectangle_bit_for_bit(env, tmp_path, backend):
    rectangle = load(env, tmp_path, f"by_size_{backend}", RECTANGLE, backend)
    stiffness = load(env, tmp_path, f"by_stiffness_{backend}", BY_STIFFNESS, backend)
    rng = np.random.default_rng(22)
    for _ in range(3):
        q, qd = rng.normal(size=(2, rectangle.n_dof)) * 0.3
        assert np.array_equal(rectangle.mass_matrix(q), stiffness.mass_matrix(q))
        assert np.array_equal(rectangle.forces(0.3, q, qd), stiffness.forces(0.3, q, qd))
        assert np.array_equal(rectangle.stiffness_jacobian(q), stiffness.stiffness_jacobian(q))
    runs = [m.rk4(np.zeros(m.n_dof), np.zeros(m.n_dof), 0.05, 1e-4)[:3] for m in (rectangle, stiffness)]
    assert all(np.array_equal(a, b) for a, b in zip(*runs))
    assert np.abs(runs[0][1][-1]).max() > 0


def test_the_rfes_of_a_section_by_its_stiffnesses_carry_its_mass_and_rotary_inertia():
    ei, rho_a, rho_iz, rho_iy = 2.0e3, 1.2, 3.0e-5, 1.0e-5
    link = FlexibleLink("1", 2, StiffnessSection(ei, ei / 2, ei / 3, rho_a, rho_iz, rho_iy), n_rfe=3)
    chain = expand(_model(link))
    bodies = [e.pseudo_inertia for e in chain.elements if hasattr(e, "pseudo_inertia")]
    assert [float(h[3, 3]) for h in bodies] == pytest.approx([0.6, 1.2, 0.6])        # ρA·ℓ, ℓ = 0.5, 1, 0.5
    assert float(bodies[1][0, 0]) == pytest.approx(rho_a * 1 / 3)                   # ∫x² dm = ρA ℓ³/3
    assert [float(bodies[1][1, 1]), float(bodies[1][2, 2])] == pytest.approx([rho_iz, rho_iy])
    springs = [float(e.stiffness) for e in chain.elements if hasattr(e, "axis") and e.name != "theta1"]
    assert springs[:3] == pytest.approx([ei / 1, ei / 2, ei / 3])                   # EI/Δ, Δ = 1 m


def _values(section, **material):
    p = section_properties(FlexibleLink("1", 1, section, n_rfe=2, **material))
    return {k: float(getattr(p, k)) for k in ("EIz", "EIy", "GJ", "rhoA", "rhoIz", "rhoIy")}


def test_a_tube_is_the_hollow_circle():
    steel = dict(density=7800, young_modulus=2.1e11, shear_modulus=8.1e10)
    outer, inner = 0.05, 0.04
    tube = _values(TubeSection(outer, inner), **steel)
    whole, hole = _values(CircularSection(outer / 2), **steel), _values(CircularSection(inner / 2), **steel)
    for key in tube:   # areas and moments subtract: the tube is the outer circle less the hole
        assert tube[key] == pytest.approx(whole[key] - hole[key], rel=1e-12)
    assert _values(TubeSection(outer, 0), **steel) == pytest.approx(whole, rel=1e-14)


def test_an_i_section_by_its_flanges_and_web():
    material = dict(density=1, young_modulus=1, shear_modulus=1)
    h, b, tf, tw = 0.2, 0.1, 0.01, 0.006
    web = h - 2 * tf
    v = _values(ISection(h, b, tf, tw), **material)
    assert v["rhoA"] == pytest.approx(2 * b * tf + web * tw, rel=1e-14)
    # about z (the strong axis): each flange's own moment plus its area times the lever arm²
    flange_z = b * tf**3 / 12 + b * tf * ((h - tf) / 2) ** 2
    assert v["EIz"] == pytest.approx(2 * flange_z + tw * web**3 / 12, rel=1e-12)
    assert v["rhoIz"] == v["EIz"]
    assert v["EIy"] == pytest.approx(2 * tf * b**3 / 12 + web * tw**3 / 12, rel=1e-12)
    assert v["GJ"] == pytest.approx((2 * b * tf**3 + web * tw**3) / 3, rel=1e-12)   # thin-walled Σ b t³/3
    solid = _values(ISection(h, b, tf, b), **material)   # a web as wide as the flanges: a rectangle
    rectangle = _values(RectangularSection(b, h), **material)
    assert {k: solid[k] for k in ("EIz", "EIy", "rhoA")} == pytest.approx(
        {k: rectangle[k] for k in ("EIz", "EIy", "rhoA")}, rel=1e-12)


@pytest.mark.parametrize("section, words", [
    ('{ type = "tube", outer_diameter = 0.04, inner_diameter = 0.05 }',
     "section.inner_diameter: negative value -0.01; tube walls (outer_diameter - inner_diameter) must be positive"),
    ('{ type = "I", height = 0.02, width = 0.1, flange_thickness = 0.01, web_thickness = 0.006 }',
     "section.height: zero value 0; web heights (height - 2 flange_thickness) must be positive"),
    ('{ type = "I", height = 0.2, width = 0.004, flange_thickness = 0.01, web_thickness = 0.006 }',
     "flange overhangs (width - web_thickness) must be positive"),
    ('{ type = "stiffness", EIz = 1, EIy = 1, GJ = 1, rhoA = 0 }', "section.rhoA: zero value 0; masses per length"),
    ('{ type = "stiffness", EIz = 1, EIy = 1, GJ = 1, rhoA = 1 }',
     "section: zero value 0; rotary inertias rhoIz + rhoIy of a link free to twist (phi in freedoms) must be "
     "positive"),
    ('{ type = "stiffness", EIz = 1, EIy = 1, GJ = 1, rhoA = 1, rhoIz = -1, rhoIy = 2 }',
     "section.rhoIz: negative value -1; rotary inertias must be zero or positive"),
    ('{ type = "stiffness", EIz = 1, EIy = 1, rhoA = 1 }', "missing required key 'GJ'"),
    ('{ type = "tube", outer_diameter = 0.04, radius = 0.01 }', "unknown key 'radius'"),
    ('{ type = "box", width = 1 }', "unknown section type 'box'"),
])
def test_bad_sections_are_one_located_line(tmp_path, section, words):
    material = 'density = "rho"\nyoung_modulus = "Y"\nshear_modulus = "G"' if "stiffness" not in section else ""
    assert words in read_error(tmp_path, planar_file("bad", f"section = {section}\n{material}"))


def test_a_section_by_its_stiffnesses_needs_no_rotary_inertia_when_the_link_does_not_twist(tmp_path):
    text = planar_file("ok", 'section = { type = "stiffness", EIz = 1e3, EIy = 1e3, GJ = 1e3, rhoA = 1 }\n'
                             'freedoms = ["psi", "theta"]')
    assert read_model_file(write(tmp_path, text)).model.chain[1].section.rhoIz == 0


@pytest.mark.parametrize("link, words", [
    (BY_STIFFNESS + '\ndensity = "rho"', "already holds the material; remove density"),
    (BY_STIFFNESS + '\ntorsion_constant = "J"', "remove torsion_constant"),
    ('section = { type = "circular", radius = 0.01 }\ndensity = "rho"\nyoung_modulus = "Y"',
     "needs the material: add shear_modulus"),
])
def test_material_goes_with_sections_by_their_dimensions_only(tmp_path, link, words):
    assert words in read_error(tmp_path, planar_file("bad", link))


# --- prescribed joints ---------------------------------------------------------------------------

LAW = "W*t - sin(W*t)/2"


def test_prescribed_is_the_hand_written_constraint_with_its_joint_dependent(tmp_path):
    short = read_model_file(write(tmp_path, planar_file("arm", RECTANGLE, joint=f'prescribed = "{LAW}"'), "a.toml"))
    long = read_model_file(write(tmp_path, planar_file(
        "arm", RECTANGLE, top='dependent = ["theta1"]',
        constraints=f'[[constraints]]\nname = "prescribed_theta1"\nexpression = "theta1 - ({LAW})"\n'), "b.toml"))
    assert short.model == long.model
    assert short.model.dependent == ("theta1",)
    W = symbol("W")
    assert short.prescribed == {"theta1": W * TIME - sp.sin(W * TIME) / 2}


def test_prescribed_motion_gives_the_law_and_its_rate(tmp_path):
    loaded = read_model_file(write(tmp_path, planar_file("arm", RECTANGLE, joint=f'prescribed = "{LAW}"')))
    t, w, eps = 0.7, 4.0, 1e-6
    law = lambda s: w * s - math.sin(w * s) / 2   # noqa: E731
    q, qd = loaded.prescribed_motion(t, {"W": w})["theta1"]
    assert q == law(t)
    assert qd == pytest.approx((law(t + eps) - law(t - eps)) / (2 * eps), rel=1e-8)
    assert loaded.prescribed_motion()["theta1"] == (0.0, 3.0 - 1.5)


def test_a_prescribed_joint_follows_its_law(env, tmp_path):
    arm = load(env, tmp_path, "prescribed_arm", RECTANGLE, joint=f'prescribed = "{LAW}"')
    qd0 = np.zeros(arm.n_dof)
    qd0[0] = 1.5   # the law's rate at t = 0
    t, q, *_ = arm.rk4(np.zeros(arm.n_dof), qd0, 0.2, 1e-4)
    assert np.abs(q[:, 0] - (3 * t - np.sin(3 * t) / 2)).max() < 1e-9
    assert np.abs(q[:, 1:]).max() > 1e-6                # the link vibrates under the prescribed motion


@pytest.mark.parametrize("joint, top, constraints, words", [
    ('prescribed = "W*t + theta1"', "", "", "coordinate 'theta1' may appear only in drives and constraints"),
    ('prescribed = "W*t"', 'dependent = ["theta1"]', "", "dependent[0]: 'theta1' is prescribed"),
    ('prescribed = "W*t"', "", '[[constraints]]\nname = "tip"\nexpression = "y_E - 0.1"\n',
     "list the dependent coordinates of the [[constraints]]"),
    ('prescribed = "W*t"', 'dependent = ["psi1_1"]',
     '[[constraints]]\nname = "prescribed_theta1"\nexpression = "y_E - 0.1"\n',
     "prescribed writes the constraint 'prescribed_theta1', and that name is already taken"),
])
def test_bad_prescribed_joints_are_one_located_line(tmp_path, joint, top, constraints, words):
    message = read_error(tmp_path, planar_file("bad", RECTANGLE, joint=joint, top=top, constraints=constraints))
    assert words in message
