"""Computed-torque references that switch (docs/model-file.md "Computed torque"): a quintic
move written with Min tracks like a smooth reference, its rates are those of finite differences,
and a reference whose value or velocity jumps is warned about, naming the field."""

import dataclasses
from pathlib import Path

import numpy as np
import pytest
import sympy as sp

import gpmegen
from gpmegen.errors import DerivationError
from gpmegen.symbolic import derive

ARM = Path(__file__).parent / "models" / "ct_arm.toml"
A, W, WN = 0.4, 2.0, 10.0   # ct_arm.toml's amplitude, frequency and natural frequency (kp = wn², kd = 2 wn)
D, T0 = 0.6, 0.5            # the quintic move of theta2: D rad in T0 s
SMOOTH = 'expression = "pi/4 + A*(1 - cos(w*t))"'
QUINTIC = 'expression = "pi/4 + D*Min(t/t0, 1)^3*(10 - 15*Min(t/t0, 1) + 6*Min(t/t0, 1)^2)"'
PARAMETERS = ('[parameters]\nD = { value = 0.6, unit = "rad", doc = "the move" }\n'
              't0 = { value = 0.5, unit = "s", doc = "its duration" }\n')


def arm_with(tmp_path, name, expression):
    """ct_arm.toml (its own controller model) with theta2's reference ``expression``, starting
    at rest on it."""
    text = (ARM.read_text().replace("[parameters]\n", PARAMETERS).replace(SMOOTH, expression)
            .replace('name = "ct_arm"', f'name = "{name}"').replace('model = "ct_arm.toml"', f'model = "{name}.toml"'))
    path = tmp_path / f"{name}.toml"
    path.write_text(text)
    return path


def quintic(t):
    """theta2's reference at times ``t`` (rad), by NumPy."""
    s = np.minimum(t / T0, 1.0)
    return np.pi / 4 + D * s**3 * (10 - 15 * s + 6 * s**2)


@pytest.fixture(scope="module")
def quintic_arm(tmp_path_factory):
    return arm_with(tmp_path_factory.mktemp("quintic"), "ct_quintic", QUINTIC)


def test_quintic_reference_with_min_tracks_like_a_smooth_one(quintic_arm):
    """The perfect model started on the reference follows it to 1e-8 through the end of the move
    (t0 = 0.5 s) and after it, as the smooth reference does (tests/test_computed_torque.py)."""
    run = gpmegen.simulate(quintic_arm, t_end=1.0, dt=1e-3, backend="c")
    assert run.status == "complete"
    assert np.abs(run.coordinate("theta1") - A * np.sin(W * run.t)).max() < 1e-8
    assert np.abs(run.coordinate("theta2") - quintic(run.t)).max() < 1e-8


def test_quintic_rates_are_finite_differences(quintic_arm, rng):
    """q̈ = r̈ + kd (ṙ - q̇) + kp (r - q) with ṙ and r̈ central differences of the reference,
    before and after the switch at t0."""
    model = gpmegen.load(model=gpmegen.load_model_file(quintic_arm), backend="numpy")
    h = 1e-4
    for t in (0.05, 0.2, 0.37, 0.49, 0.51, 0.8):
        r = quintic(np.array([t - h, t, t + h]))
        rd, rdd = (r[2] - r[0]) / (2 * h), (r[2] - 2 * r[1] + r[0]) / h**2
        q, qd = rng.uniform(-2, 2, 2), rng.uniform(-2, 2, 2)
        commanded = rdd + 2 * WN * (rd - qd[1]) + WN**2 * (r[1] - q[1])
        assert abs(model.accelerations(t, q, qd)[1] - commanded) < 1e-5 * max(1.0, abs(commanded)), t


@pytest.mark.parametrize("expression, jumps", [
    ('expression = "pi/4 + D*Min(t/t0, 1)"', "q̇_r jumps at t = t0 (0.5 s with the parameter defaults)"),
    ('expression = "pi/4 + D*Heaviside(t - t0)"', "q_r jumps at t = t0 (0.5 s with the parameter defaults)"),
])
def test_reference_that_jumps_is_warned_about(tmp_path, expression, jumps):
    warnings = derive(gpmegen.load_model_file(arm_with(tmp_path, "ct_jump", expression))).warnings
    assert len(warnings) == 1 and "\n" not in warnings[0], warnings
    assert warnings[0].startswith(f"controller.computed_torque[1].reference: signal 'r2': {jumps}; "), warnings


def test_quintic_reference_is_not_warned_about(quintic_arm):
    assert derive(gpmegen.load_model_file(quintic_arm)).warnings == ()


def test_reference_whose_rates_cannot_be_evaluated_is_refused(quintic_arm):
    """A file's expressions cannot name floor; a model built in Python can."""
    model = gpmegen.load_model_file(quintic_arm)
    law = model.computed_torque
    floor = law.references[1] + sp.floor(sp.Symbol("t", real=True))
    law = dataclasses.replace(law, references=(law.references[0], floor))
    with pytest.raises(DerivationError) as caught:
        derive(dataclasses.replace(model, computed_torque=law))
    text = str(caught.value)
    assert text.startswith("controller.computed_torque[1].reference: signal 'r2': it uses floor") and "\n" not in text
    assert caught.value.subject == ("controller", "computed_torque", 1, "reference")
