"""The flexible arm against beam theory (Euler–Bernoulli statics and vibration, Saint-Venant
torsion), see gpmegen/analysis/post/beam.py for the formulas and their sources.

The reference manipulator is built for nrfe = 5, 10, 20 once (about 40 s of the ~50 s this file
takes on 2 cores; nrfe = 20 alone about 27 s). The clamped arm is the same model with the
joints held, the arm horizontal (ψ2 = 0) and the slider massless (m3 = 0): its flexible
coordinates then see exactly the arm clamped at the column top, which a cheap cross-check
against :func:`gpmegen.analysis.discretization.convergence.clamped_arm_model` confirms.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.discretization import convergence
from gpmegen.analysis.post import beam, modes
from gpmegen.analysis.run import reference_case
from gpmegen.runtime import statics

NRFE = (5, 10, 20)
INCLINATION = math.pi / 4  # ψ2 of the paper's start


@pytest.fixture(scope="module")
def build_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("beam_models")


@pytest.fixture(scope="module")
def manipulators(build_dir):
    return {n: gpmegen.load("manipulator", nrfe=n, directory=build_dir, backend="numpy") for n in NRFE}


def arm_tip(model, q):
    """Origin of the slider frame at x3 = 0, i.e. the arm's tip: E with L3 = 0 (E sits at
    (L3, 0, 0) in the slider frame; L3 enters the kinematics nowhere else)."""
    return model.with_params(L3=0.0).end_effector(q)


def flexible(model):
    return np.array([k for k, name in enumerate(model.coordinates) if name[:3] in ("psi", "the", "phi")
                     and name not in ("theta1", "psi2")])


def clamped(model, **params):
    """The manipulator as the clamped arm: joints at zero (arm horizontal), slider massless."""
    return model.with_params(m3=0.0, **params), np.zeros(model.n_dof)


def midpoint_ratio(nrfe, params, inclination):
    """RFEM tip deflection over the Euler–Bernoulli value, predicted for the modified RFEM:
    an sde at x_s with stiffness EI/Δ turns by M(x_s)Δ/EI, so the tip deflection
    Σ M(x_s)(L - x_s)Δ/EI is the midpoint rule of the unit-load integral ∫ M (L - x)/EI dx."""
    n_sde = nrfe - 1
    L, s = params["L2"], beam.rectangular_section(params["b2"], params["t2"])
    c = math.cos(inclination)
    w = params["rho2"] * s.A * params["g"] * c
    P = params["m3"] * params["g"] * c
    M0 = P * params["L3"] / 2
    delta = L / n_sde
    x = (np.arange(n_sde) + 0.5) * delta
    moment = w * (L - x) ** 2 / 2 + P * (L - x) + M0
    discrete = float(np.sum(moment * (L - x)) * delta / (params["E2"] * s.Iz))
    return discrete / arm_tip_estimate(params, inclination)[0]


def arm_tip_estimate(params, inclination):
    """Euler–Bernoulli tip deflection and rotation of the manipulator's arm clamped at
    ``inclination`` with the slider (its centre ``L3/2`` beyond the tip) at ``x3 = 0``."""
    arm = convergence.link_numbers(convergence.flexible_links(gpmegen.reference_model(2))[0], params)
    return beam.inclined_cantilever_tip(arm["L"], arm["EIz"], arm["rhoA"], arm["g"], params["m3"], params["L3"] / 2,
                                        inclination)


def test_beam_formulas():
    # superposition and a few closed-form values
    assert beam.cantilever_tip(2.0, 3.0, w=1.0, P=2.0, M0=3.0) == pytest.approx(
        (16 / 24 + 16 / 9 + 12 / 6, 8 / 18 + 8 / 6 + 6 / 3))
    assert beam.cantilever_bending_frequency(1.0, 1.0, 1.0) == pytest.approx(1.87510407**2 / (2 * math.pi))
    assert beam.shaft_torsion_frequency(4.0, 1.0, 1.0) == pytest.approx(0.5)
    s = beam.rectangular_section(0.04, 0.01)
    assert (s.A, s.Iy, s.Iz) == pytest.approx((4e-4, 0.01 * 0.04**3 / 12, 0.04 * 0.01**3 / 12))
    # rotary inertia lowers the frequency by ½ κ r²/L² to first order
    f0 = beam.cantilever_bending_frequency(1.0, 1.0, 1.0)
    f1 = beam.cantilever_bending_frequency_rotary(1.0, 1.0, 1e-4, 1.0)
    assert (f1 - f0) / f0 == pytest.approx(-0.5 * beam.CLAMPED_FREE_SLOPE_RATIO * 1e-4, rel=1e-3)


@pytest.mark.long  # builds of the arm up to n_rfe 20, a convergence study
def test_manipulator_arm_tip_deflection(manipulators):
    """Joints locked at θ1 = 0, ψ2 = 45°, x3 = 0, gravity 1e-3·9.81: the arm tip's deflection
    perpendicular to the arm against the Euler–Bernoulli cantilever under the arm's weight and
    the slider's tip force and couple."""
    errors = {}
    for n, model in manipulators.items():
        for scale in (1e-3, 1.0):
            m = model.with_params(g=scale * 9.81)
            q0 = reference_case.joint_start(m)
            q = statics.locked(m, q0)
            normal = np.array([-math.sin(INCLINATION), math.cos(INCLINATION), 0.0])  # up, ⟂ arm
            deflection = -float((arm_tip(m, q) - arm_tip(m, q0)) @ normal)
            ratio = deflection / arm_tip_estimate(m.params, INCLINATION)[0]
            print(f"nrfe {n:2d}, gravity {scale:g}·9.81: arm tip deflection / Euler–Bernoulli = {ratio:.5f}"
                  f" (midpoint-rule prediction {midpoint_ratio(n, m.params, INCLINATION):.5f})")
            if scale == 1e-3:
                errors[n] = abs(ratio - 1.0)
                # what is left is the RFEM's quadrature of the unit-load integral, nothing else
                assert ratio == pytest.approx(midpoint_ratio(n, m.params, INCLINATION), abs=2e-4)
    assert errors[5] < 0.02
    assert errors[10] < errors[5] and errors[20] < errors[10]


@pytest.mark.long  # builds of the arm up to n_rfe 20, a convergence study
def test_clamped_arm_model_matches_the_manipulator(manipulators, build_dir):
    """The stand-alone clamped arm (with and without slider) has the mass and stiffness of the
    manipulator's flexible coordinates with the joints held and the arm horizontal."""
    manipulator = manipulators[5]
    free = flexible(manipulator)
    for with_slider in (False, True):
        arm = convergence.load_clamped_arm(5, with_slider=with_slider, directory=build_dir)
        assert arm.coordinates == tuple(manipulator.coordinates[k] for k in free)
        m = manipulator if with_slider else manipulator.with_params(m3=0.0)
        for q_arm in (np.zeros(arm.n_dof), np.linspace(-0.02, 0.03, arm.n_dof)):
            q = np.zeros(manipulator.n_dof)
            q[free] = q_arm
            np.testing.assert_allclose(arm.mass_matrix(q_arm), m.mass_matrix(q)[np.ix_(free, free)],
                                       rtol=1e-10, atol=1e-12)
            np.testing.assert_allclose(arm.stiffness_jacobian(q_arm),
                                       m.stiffness_jacobian(q)[np.ix_(free, free)], rtol=1e-10, atol=1e-9)
            tip = arm.point_positions(q_arm)[arm.points.index("tip")]
            # the manipulator's arm starts at the column top, (0, h1, 0)
            np.testing.assert_allclose(tip, arm_tip(m, q) - [0, m.params["h1"], 0], atol=1e-12)


@pytest.mark.long  # builds of the arm up to n_rfe 20, a convergence study
@pytest.mark.parametrize("kind, limit_key", [
    ("vertical", "vertical_bending_rotary"),
    ("horizontal", "horizontal_bending_rotary"),
    ("torsion", "torsion"),
])
def test_clamped_arm_frequencies(manipulators, kind, limit_key):
    """First vertical / horizontal bending and torsional frequency of the clamped arm: within 1%
    of Euler–Bernoulli / Saint-Venant at nrfe = 20, error falling at least like 1/nrfe (it
    falls like 1/n_sde²) towards the continuum limit of the model (for bending, the beam with
    its sections' rotary inertia, which the rfes carry; 3e-4 below Euler–Bernoulli in the
    horizontal plane)."""
    key = {"vertical": "vertical_bending", "horizontal": "horizontal_bending", "torsion": "torsion"}[kind]
    errors, errors_limit = [], []
    for n, model in manipulators.items():
        m, q0 = clamped(model, g=0.0)
        f = modes.natural_frequencies(m, q0, free=flexible(m)).first(kind)
        reference = convergence.arm_reference(m.params)
        errors.append((f - getattr(reference, key)) / getattr(reference, key))
        errors_limit.append((f - getattr(reference, limit_key)) / getattr(reference, limit_key))
        print(f"nrfe {n:2d}: first {kind} frequency {f:.6f} Hz, error {errors[-1]:+.3e} "
              f"(against the limit {errors_limit[-1]:+.3e})")
    assert abs(errors[-1]) < 0.01
    assert all(abs(a) > abs(b) for a, b in zip(errors, errors[1:]))
    order = convergence.observed_order(NRFE, errors_limit)
    print(f"observed order {order:.2f}")
    assert order >= 1.8


@pytest.mark.long  # builds of the arm up to n_rfe 20, a convergence study
def test_clamped_arm_self_weight_deflection(manipulators):
    """Horizontal clamped arm under its weight (Newton–Raphson statics, full gravity): the tip
    deflection converges to w L⁴/(8 EI), with the error of the RFEM's midpoint quadrature,
    -1/(2 n_sde²)."""
    errors = []
    for n, model in manipulators.items():
        m, q0 = clamped(model)
        q = statics.locked(m, q0, free=flexible(m))
        deflection = -(arm_tip(m, q)[1] - arm_tip(m, q0)[1])
        reference = convergence.arm_reference(m.params).tip_deflection
        errors.append((deflection - reference) / reference)
        print(f"nrfe {n:2d}: tip deflection {deflection:.6e} m, w L^4/(8 EI) {reference:.6e} m, "
              f"error {errors[-1]:+.3e}")
        assert errors[-1] == pytest.approx(-1 / (2 * (n - 1) ** 2), abs=1e-4)
    assert all(abs(a) > abs(b) for a, b in zip(errors, errors[1:]))
    assert convergence.observed_order(NRFE, errors) >= 1.8


@pytest.mark.long  # builds of the arm up to n_rfe 20, a convergence study
def test_convergence_table_and_classification(build_dir):
    table = convergence.convergence_table((2, 3), directory=build_dir)
    assert list(table.nrfe) == [2, 3]
    for key, _, _ in convergence.QUANTITIES:
        assert abs(table.errors[key][1]) < abs(table.errors[key][0])
    assert "torsional" in table.format() and "not compared" not in table.format()
