"""Computed torque with a controller model (docs/model-file.md "Computed torque"): the closed loop
of a perfect model against the closed-form error dynamics, the two backends' laws against each
other, a wrong model's bounded error, and the refusals of the [controller] table."""

from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.post import results
from gpmegen.cli import main
from gpmegen.errors import ModelError

ARM = Path(__file__).parent / "models" / "ct_arm.toml"
A, W, WN = 0.4, 2.0, 10.0   # ct_arm.toml's amplitude, frequency and natural frequency (kp = wn², kd = 2 wn)


def references(t):
    """``(r, ṙ, r̈)`` of the two joints at times ``t``, (len(t), 2) each: ct_arm.toml's signals."""
    r = np.stack([A * np.sin(W * t), np.pi / 4 + A * (1 - np.cos(W * t))], axis=-1)
    rd = np.stack([A * W * np.cos(W * t), A * W * np.sin(W * t)], axis=-1)
    rdd = np.stack([-A * W**2 * np.sin(W * t), A * W**2 * np.cos(W * t)], axis=-1)
    return r, rd, rdd


def test_perfect_model_tracks_the_reference():
    """Started on the reference, the plant follows it to 1e-8 over 3 s (RK4, 1 ms)."""
    run = gpmegen.simulate(ARM, t_end=3.0, dt=1e-3, backend="c")
    r, _, _ = references(run.t)
    q = np.stack([run.coordinate("theta1"), run.coordinate("theta2")], axis=-1)
    assert run.status == "complete"
    assert np.abs(q - r).max() < 1e-8


def test_perfect_model_error_is_critically_damped():
    """Started e0 off the reference, e = q_r - q follows ë + 2ω ė + ω² e = 0 from e(0) = e0,
    ė(0) = 0: e = e0 (1 + ω t) exp(-ω t), to 1e-6; the other joint stays on its reference."""
    e0 = 0.1
    run = gpmegen.simulate(ARM, t_end=2.0, dt=1e-3, backend="c", params={"e0": e0})
    r, _, _ = references(run.t)
    e1, e2 = r[:, 0] - run.coordinate("theta1"), r[:, 1] - run.coordinate("theta2")
    assert np.abs(e1 - e0 * (1 + WN * run.t) * np.exp(-WN * run.t)).max() < 1e-6
    assert np.abs(e2).max() < 1e-8


@pytest.fixture(scope="module")
def backends():
    model = gpmegen.load_model_file(ARM)
    return gpmegen.load(model=model, backend="numpy"), gpmegen.load(model=model, backend="c")


def test_perfect_model_accelerations_are_the_commanded_ones(backends, rng):
    """With M_c = M and f_c = f, q̈ = r̈ + kd (ṙ - q̇) + kp (r - q) at any state."""
    numpy_model, _ = backends
    for _ in range(5):
        t, q, qd = rng.uniform(0, 3), rng.uniform(-2, 2, 2), rng.uniform(-2, 2, 2)
        r, rd, rdd = (x[0] for x in references(np.array([t])))
        commanded = rdd + 2 * WN * (rd - qd) + WN**2 * (r - q)
        assert np.allclose(numpy_model.accelerations(t, q, qd), commanded, rtol=1e-12, atol=1e-10)


def test_c_law_is_the_numpy_law(backends, rng):
    numpy_model, c_model = backends
    p = numpy_model.p
    for _ in range(10):
        t, q, qd = rng.uniform(0, 3), rng.uniform(-3, 3, 2), rng.uniform(-3, 3, 2)
        expected = numpy_model.evaluator.drive_forces(t, q, qd, p)
        got = c_model.evaluator.drive_forces(t, q, qd, p)
        assert np.abs(got - expected).max() <= 1e-12 * max(1.0, np.abs(expected).max())


def _write(tmp_path, plant_edit=None, controller_edit=None):
    """A plant and its controller model in ``tmp_path``, both ct_arm.toml edited by the given
    functions of the text; the plant names the controller."""
    text = ARM.read_text()
    controller = controller_edit(text) if controller_edit else text
    (tmp_path / "controller.toml").write_text(controller)
    plant = text.replace('model = "ct_arm.toml"', 'model = "controller.toml"')
    plant = plant_edit(plant) if plant_edit else plant
    (tmp_path / "plant.toml").write_text(plant)
    return tmp_path / "plant.toml"


def test_wrong_model_gives_a_bounded_error(tmp_path):
    """A controller whose second link is 20% heavier: the plant no longer follows the
    reference exactly, but stays near it (the PD terms hold it)."""
    heavy = _write(tmp_path, controller_edit=lambda s: s.replace('m2 = { value = 0.7', 'm2 = { value = 0.84'))
    run = gpmegen.simulate(heavy, t_end=3.0, dt=1e-3, backend="c")
    r, _, _ = references(run.t)
    error = np.abs(np.stack([run.coordinate("theta1"), run.coordinate("theta2")], axis=-1) - r).max()
    assert run.status == "complete"
    assert 1e-4 < error < 0.1


REFUSALS = [
    ("its coordinate phi2 is no coordinate of the plant",
     lambda s: s.replace('joint = "theta2"', 'joint = "phi2"').replace('coordinate = "theta2"', 'coordinate = "phi2"')
     .replace("theta2 = \"pi/4\"", "phi2 = \"pi/4\""), None),
    ("which is no joint of the controller model",
     None, lambda s: s.replace('coordinate = "theta2"\nreference', 'coordinate = "theta3"\nreference')),
    ("the law leaves out theta2",
     None, lambda s: s[:s.rindex("[[controller.computed_torque]]")] + "[initial]\n"),
    ("no signal 'r9'", None, lambda s: s.replace('reference = "r2"', 'reference = "r9"')),
    ("kp: time t may appear only in drives", None, lambda s: s.replace('kp = "wn^2"', 'kp = "wn^2*t"', 1)),
]


@pytest.mark.parametrize("message, controller_edit, plant_edit", REFUSALS)
def test_refusals(tmp_path, message, controller_edit, plant_edit):
    plant = _write(tmp_path, plant_edit=plant_edit, controller_edit=controller_edit)
    with pytest.raises(ModelError) as caught:
        gpmegen.load_model_file(plant)
    text = str(caught.value)
    assert message in text and "\n" not in text and "plant.toml:" in text


def test_table_reference_refused(tmp_path):
    t = np.linspace(0, 1, 11)
    np.savez(tmp_path / "ref.npz", t=t, y=t)
    second = '[[signals]]\nname = "r2"'
    table = '[[signals]]\nname = "table"\ntable = "ref.npz"\ncolumn = "y"\n\n'
    plant = _write(tmp_path, plant_edit=lambda s: s.replace(second, table + second)
                   .replace('reference = "r2"', 'reference = "table"'))
    with pytest.raises(ModelError, match="a table does not give"):
        gpmegen.load_model_file(plant)


def test_command_line_controller_model(tmp_path, capsys, monkeypatch):
    """``--controller-model`` replaces the file's controller model (the plant's own, which
    tracks to 1e-8) by another: here the 20% heavier one, which errs by more than 1e-4."""
    monkeypatch.setenv("GPMEGEN_GENERATED", str(tmp_path / "generated"))
    heavy = tmp_path / "heavy.toml"
    heavy.write_text(ARM.read_text().replace('m2 = { value = 0.7', 'm2 = { value = 0.84'))
    errors = []
    for extra, out in (([], "own.npz"), (["--controller-model", str(heavy)], "heavy.npz")):
        code = main(["simulate", str(ARM), "--t-end", "1", "--dt", "1e-3", "--backend", "c",
                     "--out", str(tmp_path / out), *extra])
        assert code == 0, capsys.readouterr().err
        res = results.load(tmp_path / out)
        r, _, _ = references(res["t"])
        errors.append(np.abs(res["q"] - r).max())
    assert errors[0] < 1e-8 < 1e-4 < errors[1]


def test_command_line_controller_model_needs_the_table(tmp_path, capsys):
    code = main(["simulate", str(ARM.parent / "cart.toml"), "--controller-model", str(ARM),
                 "--out", str(tmp_path / "x.npz")])
    err = capsys.readouterr().err.strip()
    assert code == 2 and "has no [controller] table" in err and len(err.splitlines()) == 1


def test_results_hold_the_reference_and_the_error(tmp_path):
    """Started e0 off the reference, the saved error q_r - q of theta1 is e0 (1 + ω t) exp(-ω t)
    to 1e-6, theta2's below 1e-8, and the saved reference is the signal's closed form; the CSV
    repeats both columns."""
    e0 = 0.1
    run = gpmegen.simulate(ARM, t_end=1.0, dt=1e-3, backend="c", params={"e0": e0})
    r, _, _ = references(run.t)
    assert list(run["reference_coordinates"]) == ["theta1", "theta2"]
    assert np.abs(run["q_reference"] - r).max() < 1e-12
    error = run["tracking_error"]
    assert np.abs(error[:, 0] - e0 * (1 + WN * run.t) * np.exp(-WN * run.t)).max() < 1e-6
    assert np.abs(error[:, 1]).max() < 1e-8
    run.save(tmp_path / "run.npz")
    read = results.load(tmp_path / "run.npz")
    assert np.array_equal(read["tracking_error"], error)
    with open(tmp_path / "run.csv") as fh:
        fh.readline()
        header = fh.readline().strip().split(",")
    table = np.loadtxt(tmp_path / "run.csv", delimiter=",", skiprows=2)
    assert np.allclose(table[:, header.index("e_theta1")], error[:, 0], rtol=1e-10, atol=1e-14)
    assert np.allclose(table[:, header.index("qr_theta2")], r[:, 1], rtol=1e-10)


def test_results_without_a_law_hold_no_reference():
    run = gpmegen.simulate(ARM.parent / "cart.toml", t_end=0.1, dt=1e-3, backend="numpy")
    assert "tracking_error" not in run.keys() and "q_reference" not in run.keys()
