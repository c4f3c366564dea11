"""The GPME acceleration Jacobians ∂q̈/∂q and ∂q̈/∂q̇ from the generated derivatives: equal to
central differences of q̈ on the reference arm and on every example (every constraint order),
the same on the NumPy and C backends, and on a rigid chain without constraints equal to
Pinocchio's analytical derivatives of its articulated-body algorithm."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.runtime import loader

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = sorted((ROOT / "examples").glob("*.toml"))
BACKENDS = ["numpy", pytest.param("c", marks=pytest.mark.requires_cc)]


def differences(model, t, q, qd, h=1e-3):
    """Central differences of q̈ in q and in q̇, Richardson-extrapolated from steps h and h/2
    (error O(h⁴)): two (n, n). The large step keeps round-off small where q̈ is large (stiff
    elastic coordinates away from rest)."""
    n = model.n_dof

    def column(dq, dqd):
        step = np.abs(dq + dqd).max()
        return (model.accelerations(t, q + dq, qd + dqd) - model.accelerations(t, q - dq, qd - dqd)) / (2 * step)

    def jacobians(step):
        eye, zero = step * np.eye(n), np.zeros(n)
        return (np.column_stack([column(e, zero) for e in eye]), np.column_stack([column(zero, e) for e in eye]))

    coarse, fine = jacobians(h), jacobians(h / 2)
    return tuple((4 * f - c) / 3 for f, c in zip(fine, coarse))


def relative(a, b, scale=0.0) -> float:
    """Largest difference relative to the largest entry of ``b`` or ``scale``, the larger."""
    size = max(np.abs(b).max(), scale)
    # all of it exactly zero (a rigid arm turning freely in a horizontal plane): the difference
    # itself, which must be zero too
    return float(np.abs(a - b).max() / size) if size > 0 else float(np.abs(a - b).max())


def random_state(model, rng, spread=0.2):
    """A state near the model's start (the reference arm's, or zero) with random velocities."""
    n = model.n_dof
    return 0.37, spread * rng.standard_normal(n), rng.standard_normal(n)


def check_against_differences(model, t, q, qd):
    A_q, A_qd = model.acceleration_jacobians(t, q, qd)
    D_q, D_qd = differences(model, t, q, qd)
    scale = np.abs(model.accelerations(t, q, qd)).max()   # where a Jacobian vanishes (a spinning rotor)
    assert relative(A_q, D_q, scale) < 1e-6
    assert relative(A_qd, D_qd, scale) < 1e-6
    return A_q, A_qd, scale


@pytest.mark.parametrize("backend", BACKENDS)
def test_reference_arm_equals_finite_differences(env, rng, backend):
    # n_rfe 1 is examples/manipulator.toml below; n_rfe 2 has the sdes' rotations and their
    # springs (one sde), at a fraction of the derivation of n_rfe 3
    model = gpmegen.load("manipulator", nrfe=2, backend=backend, jacobians=True)
    check_against_differences(model, *random_state(model, rng))


def test_a_model_built_without_jacobians_refuses_them_and_differences_them_in_c(env, rng, tmp_path):
    plain = gpmegen.load("manipulator", nrfe=1, backend="numpy", directory=tmp_path / "plain")
    with pytest.raises(gpmegen.errors.BuildError, match="--jacobians"):
        plain.acceleration_jacobians(*random_state(plain, rng))
    exact = gpmegen.load("manipulator", nrfe=1, backend="numpy", jacobians=True)
    assert exact.jacobians_built and not plain.jacobians_built
    t, q, qd = random_state(exact, rng)
    A_q, A_qd = exact.acceleration_jacobians(t, q, qd)
    try:
        c_plain = loader.open_folder(plain.folder, "c")
    except gpmegen.errors.BuildError as exc:   # no compiler
        pytest.skip(str(exc))
    assert not c_plain.jacobians_built
    # the implicit integrators' Jacobian of a model built without them: central differences in C
    _, C_q, C_qd = c_plain.evaluator.acceleration_jacobians(t, q, qd, c_plain.partitioned(t, q))
    scale = max(np.abs(A_q).max(), np.abs(A_qd).max())
    assert relative(C_q, A_q, scale) < 1e-6
    assert relative(C_qd, A_qd, scale) < 1e-6


# the two-armed Baxter's derivation with its Jacobians is the longest of the examples, the
# slider-crank's (a closed loop, as four_bar.toml, whose check stays in make test) takes 19 s,
# the flexible Panda's 20-30 s, the Delta's (three loops closed on one platform) 20 s and the
# six-joint arm's 9-13 s (the spatial chain of manipulator and planar_two_link stays), Bauchau's
# spatial four-bar's (three flexible beams) 25 s, the tangential arm's 4 s (the second-order
# constraints of curvature_arm stay): make check-c
LONG_EXAMPLES = {"baxter_flexible", "slider_crank_flexible", "panda_flexible", "spatial_six_joint", "delta_flexible",
                 "bauchau_four_bar", "manipulator_tangential"}
#: n_rfe of the examples checked at more than 1: Bauchau's tilted loop has no freedom when rigid
#: (its file names sde rotations among the dependent coordinates)
NRFE = {"bauchau_four_bar": 2}


@pytest.mark.parametrize("path", [pytest.param(p, marks=(pytest.mark.long,) if p.stem in LONG_EXAMPLES else ())
                                  for p in EXAMPLES], ids=[p.stem for p in EXAMPLES])
def test_examples_equal_finite_differences_on_both_backends(env, rng, path):
    model = gpmegen.load(model=gpmegen.load_model_file(path, nrfe=NRFE.get(path.stem, 1)), backend="numpy",
                         jacobians=True)
    t, q, qd = random_state(model, rng, spread=0.1)
    A_q, A_qd, scale = check_against_differences(model, t, q, qd)
    try:
        c_model = loader.open_folder(model.folder, "c")
    except gpmegen.errors.BuildError as exc:   # no compiler: the NumPy half stands
        pytest.skip(str(exc))
    C_q, C_qd = c_model.acceleration_jacobians(t, q, qd)
    assert relative(C_q, A_q, scale) < 1e-12
    assert relative(C_qd, A_qd, scale) < 1e-12


def test_actuated_realization_equals_finite_differences(env, rng):
    model = gpmegen.load("manipulator", nrfe=1, backend="numpy", jacobians=True)
    actuated = model.with_actuators([model.coordinates[k] for k in model.dependent])
    check_against_differences(actuated, *random_state(model, rng))


def test_batch_equals_single_states(env, rng):
    model = gpmegen.load("manipulator", nrfe=1, backend="numpy", jacobians=True)
    states = [random_state(model, rng) for _ in range(3)]
    t, q, qd = (np.array([s[k] for s in states]) for k in range(3))
    A_q, A_qd = model.acceleration_jacobians(t, q, qd)
    for k, state in enumerate(states):
        single = model.acceleration_jacobians(*state)
        np.testing.assert_array_equal(A_q[k], single[0])
        np.testing.assert_array_equal(A_qd[k], single[1])


# A rigid spatial chain (revolute z, revolute y, prismatic x, revolute x) with general inertias,
# written once as a model file and once as a Pinocchio model.
JOINTS = [("rz", "revolute", "z", [0.0, 0.3, 0.0]), ("ry", "revolute", "y", [0.4, 0.0, 0.1]),
          ("px", "prismatic", "x", [0.2, 0.0, 0.0]), ("rx", "revolute", "x", [0.1, -0.05, 0.0])]
BODIES = [(1.5, [0.05, 0.1, 0.0], [[0.02, 0.001, 0.0], [0.001, 0.03, 0.002], [0.0, 0.002, 0.025]]),
          (2.0, [0.2, 0.0, 0.02], [[0.01, 0.0, 0.001], [0.0, 0.04, 0.0], [0.001, 0.0, 0.05]]),
          (0.7, [0.1, 0.01, 0.0], [[0.004, 0.0, 0.0], [0.0, 0.006, 0.001], [0.0, 0.001, 0.007]]),
          (0.4, [0.03, 0.0, 0.05], [[0.002, 0.0, 0.0], [0.0, 0.003, 0.0], [0.0, 0.0, 0.0025]])]
GRAVITY = 9.81


def rigid_chain_file(path: Path) -> Path:
    lines = ['schema = 1', 'name = "rigid_chain"', 'gravity = [0, "-g", 0]', "",
             "[parameters]", f"g = {{ value = {GRAVITY}, unit = \"m/s^2\" }}", ""]
    for (name, kind, axis, offset), (mass, center, inertia) in zip(JOINTS, BODIES):
        lines += ["[[chain]]", f"translation = {offset}", "", "[[chain]]", f'joint = "{name}"', f'type = "{kind}"',
                  f'axis = "{axis}"', "", "[[chain]]", f'body = "b_{name}"', f"mass = {mass}", f"center = {center}",
                  f"inertia = {inertia}", ""]
    path.write_text("\n".join(lines))
    return path


def pinocchio_chain():
    pin = pytest.importorskip("pinocchio")
    joint_types = {("revolute", "z"): pin.JointModelRZ, ("revolute", "y"): pin.JointModelRY,
                   ("revolute", "x"): pin.JointModelRX, ("prismatic", "x"): pin.JointModelPX}
    model, parent = pin.Model(), 0
    for (name, kind, axis, offset), (mass, center, inertia) in zip(JOINTS, BODIES):
        placement = pin.SE3(np.eye(3), np.array(offset))
        parent = model.addJoint(parent, joint_types[kind, axis](), placement, name)
        model.appendBodyToJoint(parent, pin.Inertia(mass, np.array(center), np.array(inertia)), pin.SE3.Identity())
    model.gravity.linear = np.array([0.0, -GRAVITY, 0.0])
    return pin, model, model.createData()


@pytest.mark.parametrize("backend", BACKENDS)
def test_unconstrained_chain_equals_pinocchio_aba_derivatives(env, tmp_path, rng, backend):
    pin, pin_model, data = pinocchio_chain()
    model = gpmegen.load(model=gpmegen.load_model_file(rigid_chain_file(tmp_path / "chain.toml")), backend=backend,
                         jacobians=True)
    for _ in range(3):
        t, q, qd = random_state(model, rng, spread=1.0)
        pin.computeABADerivatives(pin_model, data, q, qd, np.zeros(model.n_dof))
        np.testing.assert_allclose(model.accelerations(t, q, qd), data.ddq, rtol=1e-10, atol=1e-10)
        A_q, A_qd = model.acceleration_jacobians(t, q, qd)
        assert relative(A_q, data.ddq_dq) < 1e-8
        assert relative(A_qd, data.ddq_dv) < 1e-8


def test_a_folder_serves_asking_for_less_and_is_built_with_both_for_more(env):
    """What a load asks is what the model must have at least: a run after a linearization does not
    build the model back without its Jacobians, and asking for more keeps them."""
    exact = gpmegen.load("manipulator", nrfe=1, backend="numpy", jacobians=True)
    manifest = exact.folder / "manifest.json"
    before = manifest.read_bytes(), manifest.stat().st_mtime_ns
    again = gpmegen.load("manipulator", nrfe=1, backend="numpy")
    assert again.jacobians_built and (manifest.read_bytes(), manifest.stat().st_mtime_ns) == before
    more = gpmegen.load("manipulator", nrfe=1, backend="numpy", transforms=("T", "T_i"))
    assert more.jacobians_built and "T_i" in more.transforms_built and manifest.read_bytes() != before[0]
