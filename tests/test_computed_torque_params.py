"""The controller model's parameters set from the plant's (docs/model-file.md "Computed torque",
``[controller.params]``): a controller that believes the plant's payload tracks perfectly, one
that believes another does not, and the belief is a run-time parameter (no rebuild)."""

from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run.model_files import read_model_file
from gpmegen.errors import ModelError

ARM = Path(__file__).parent / "models" / "ct_arm.toml"
A, W = 0.4, 2.0   # ct_arm.toml's amplitude and frequency of the references
BELIEF = 'm_c = { value = 0.3, unit = "kg", doc = "the tip mass the controller believes" }\n'


def write(folder, name, params=""):
    """A plant (ct_arm.toml with a parameter ``m_c``, 0.3 kg as its tip mass ``m_tip``) whose
    controller model is ct_arm.toml with a 0.6 kg tip; ``params``: its [controller] table's params line."""
    (folder / "controller.toml").write_text(ARM.read_text().replace('m_tip = { value = 0.3', 'm_tip = { value = 0.6'))
    text = (ARM.read_text().replace('name = "ct_arm"', f'name = "{name}"')
            .replace("[parameters]\n", "[parameters]\n" + BELIEF)
            .replace('model = "ct_arm.toml"\n', 'model = "controller.toml"\n' + params))
    (folder / f"{name}.toml").write_text(text)
    return folder / f"{name}.toml"


def tracking_error(path, params=None):
    run = gpmegen.simulate(path, t_end=1.0, dt=1e-3, backend="c", params=params)
    assert run.status == "complete"
    r = np.stack([A * np.sin(W * run.t), np.pi / 4 + A * (1 - np.cos(W * run.t))], axis=-1)
    return np.abs(np.stack([run.coordinate("theta1"), run.coordinate("theta2")], axis=-1) - r).max()


def test_controller_believes_the_parameter_it_is_given(tmp_path, env):
    """The 0.6 kg tip of the controller's file errs; set from the plant's ``m_c`` (0.3 kg, the
    plant's tip) it tracks to 1e-8; ``m_c`` changed at run time changes the belief without a
    rebuild: 0.6 kg errs again, 0.45 kg with the plant's tip 0.45 kg tracks."""
    assert tracking_error(write(tmp_path, "ct_believes_file")) > 1e-4
    plant = write(tmp_path, "ct_believes", "params = { m_tip = \"m_c\" }\n")
    assert tracking_error(plant) < 1e-8
    generated, _ = env
    stamps = {p: p.stat().st_mtime_ns for p in (generated / "ct_believes").iterdir()}
    assert tracking_error(plant, {"m_c": 0.6}) > 1e-4
    assert tracking_error(plant, {"m_c": 0.45, "m_tip": 0.45}) < 1e-8
    assert {p: p.stat().st_mtime_ns for p in (generated / "ct_believes").iterdir()} == stamps


def test_an_expression_of_the_plant_parameters(tmp_path, env):
    """``m_tip = "2*m_tip"`` on a 0.3 kg plant tip is the controller's 0.6 kg of its file: the
    same run, to rounding."""
    plant = write(tmp_path, "ct_twice", "params = { m_tip = \"2*m_tip\" }\n")
    file_run = gpmegen.simulate(write(tmp_path, "ct_twice_file"), t_end=0.5, dt=1e-3, backend="c")
    run = gpmegen.simulate(plant, t_end=0.5, dt=1e-3, backend="c")
    assert np.abs(run.coordinate("theta2") - file_run.coordinate("theta2")).max() < 1e-12


@pytest.mark.parametrize("params, message", [
    ("params = { m9 = \"m_c\" }\n", "controller.params.m9: controller controller.toml: m9 is no parameter of the "
                                      "controller model (its parameters: g, m1,"),
    ("params = { m_tip = \"m_nine\" }\n", "controller.params.m_tip: unknown name 'm_nine'"),
    ("params = 3\n", "controller.params: expected a table of the controller model's parameters"),
])
def test_refusals(tmp_path, params, message):
    with pytest.raises(ModelError) as caught:
        gpmegen.load_model_file(write(tmp_path, "ct_refused", params))
    text = str(caught.value)
    assert message in text and "\n" not in text and "ct_refused.toml:" in text


def test_the_table_sets_the_parameters_of_a_controller_model_given_in_place(tmp_path, env, rng):
    """``--controller-model``'s file (here with a 0.9 kg tip) gets the table's parameters: with
    ``m_tip = "m_c"`` the law is the perfect one, q̈ = r̈ + kd (ṙ - q̇) + kp (r - q); a file
    without that parameter is refused in one line."""
    plant = write(tmp_path, "ct_in_place", "params = { m_tip = \"m_c\" }\n")
    other = tmp_path / "other.toml"
    other.write_text(ARM.read_text().replace('m_tip = { value = 0.3', 'm_tip = { value = 0.9'))
    model = gpmegen.load(model=read_model_file(plant, controller_model=str(other)).model, backend="numpy")
    wn = 10.0   # kp = wn², kd = 2 wn
    for _ in range(3):
        t, q, qd = rng.uniform(0, 3), rng.uniform(-2, 2, 2), rng.uniform(-2, 2, 2)
        r = np.array([A * np.sin(W * t), np.pi / 4 + A * (1 - np.cos(W * t))])
        rd = np.array([A * W * np.cos(W * t), A * W * np.sin(W * t)])
        rdd = np.array([-A * W**2 * np.sin(W * t), A * W**2 * np.cos(W * t)])
        assert np.allclose(model.accelerations(t, q, qd), rdd + 2 * wn * (rd - qd) + wn**2 * (r - q),
                           rtol=1e-12, atol=1e-10)
    other.write_text(ARM.read_text().replace("m_tip", "m_load"))
    with pytest.raises(ModelError, match="m_tip is no parameter of the controller model") as caught:
        read_model_file(plant, controller_model=str(other))
    assert "\n" not in str(caught.value)


def test_params_with_a_task_space_law_is_refused(tmp_path):
    text = (ARM.parent / "ct_task_arm.toml").read_text()
    (tmp_path / "ct_task_arm.toml").write_text(text.replace('model = "ct_task_arm.toml"\n',
                                                            'model = "ct_task_arm.toml"\nparams = { m2 = "m2" }\n'))
    with pytest.raises(ModelError) as caught:
        gpmegen.load_model_file(tmp_path / "ct_task_arm.toml")
    text = str(caught.value)
    assert "controller.params: sets the controller model's parameters of a [[controller.computed_torque]] law only" \
        in text and "\n" not in text


def test_a_belief_the_plants_values_make_unphysical_is_refused_as_the_plants_own(tmp_path, env):
    """A tip mass believed negative is refused like a negative mass of the plant: with the
    defaults as the file is read, at the params entry's line; with a value given at run time,
    as the model is loaded (a run with it went on to 1e5 rad without a word)."""
    path = write(tmp_path, "ct_negative", 'params = { m_tip = "-1" }\n')
    with pytest.raises(ModelError, match=r"ct_negative\.toml:\d+: controller\.params\.m_tip: negative value -1; "
                                         r"masses must be zero or positive") as caught:
        read_model_file(path)
    assert "\n" not in str(caught.value)
    path = write(tmp_path, "ct_lighter", 'params = { m_tip = "m_c - 0.2" }\n')
    assert tracking_error(path) > 1e-4   # 0.1 kg believed: fine, and wrong
    with pytest.raises(ModelError, match=r"^model ct_lighter: the mass of controller model's body 'tip' = m_c - 0\.2 "
                                         r"is -0\.1 with m_c = 0\.1; masses must be zero or positive: change m_c$"):
        gpmegen.simulate(path, t_end=0.1, dt=1e-3, backend="c", params={"m_c": 0.1})
