"""Tracking metrics (gpmegen/analysis/tracking.py, ``gpmegen metrics``): on runs whose errors are
known exactly (a run of the reference model itself, the same run moved by a known offset) and on
signals whose integrals are known in closed form (a sinusoidal drive's effort, a sinusoidal
vibration's peak-to-peak and RMS).

The model is the cart of tests/models/cart.toml (a prismatic joint x, no gravity) whose
programmed constraint moves it by A in the time T along a smooth step and holds it there; the
plant is the same cart, no constraint, a PD law on x towards the same step."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run import tracking
from gpmegen.cli import main

STEP = "Min(Max(t/T, 0), 1)^3*(10 - 15*Min(Max(t/T, 0), 1) + 6*Min(Max(t/T, 0), 1)^2)"
MODELS = Path(__file__).parent / "models"


def cart(name: str, rest: str) -> str:
    """tests/models/cart.toml named ``name``, with the step's parameters and ``rest`` added."""
    text = (MODELS / "cart.toml").read_text().replace('name = "cart"', f'name = "{name}"')
    return text.replace("[parameters]\n", "[parameters]\nA = 0.2\nT = 0.3\nkp = 400.0\nkd = 20.0\n") + rest


CONSTRAINT = f"""
[[constraints]]
name = "move"
expression = "x - A*{STEP}"
"""
DRIVE = f"""
[[drives]]
coordinate = "x"
expression = "kp*(A*{STEP} - x) - kd*x_dot"
"""
T_END = 0.5
# the step's Min/Max switch at t = T with Φ and Φ̇ continuous there (the step is C²): the build's
# warning that it cannot tell is expected
pytestmark = pytest.mark.filterwarnings("ignore:constraint 'move'. its law switches")


@pytest.fixture(scope="module")
def files(tmp_path_factory, env):
    """The reference model file, the plant's, a run of each (NumPy backend) and a foreign run."""
    folder = tmp_path_factory.mktemp("tracking")
    (folder / "cart.toml").write_text(cart("cart_move", CONSTRAINT))
    (folder / "plant.toml").write_text(cart("cart_pd", DRIVE))
    (folder / "other.toml").write_text(cart("cart_y", "").replace('"x"', '"y"'))
    for name in ("cart", "plant", "other"):
        run = gpmegen.simulate(str(folder / f"{name}.toml"), backend="numpy", t_end=T_END, dt=1e-3, save_every=1)
        assert run.status == "complete"
        run.save(folder / f"{name}.npz")
    return folder


def _metrics(files, run, reference="cart.toml", **options):
    return gpmegen.metrics(files / run, str(files / reference), backend="numpy", **options)[0]


def test_a_run_of_the_reference_model_tracks_it(files):
    m = _metrics(files, "cart.npz")
    assert m.constraints["move"][0] < 1e-10      # the ideal run holds its constraint
    assert m.path == (0.0, 0.0)                  # the reference path is that same run
    assert m.after == pytest.approx(0.3, abs=1e-12)   # the step ends at T: Φ stops depending on t there
    assert m.vibration[0] < 1e-10


def test_an_offset_run_is_off_by_that_offset(files):
    from gpmegen.analysis.post import results as results_io
    run = dict(results_io.load(files / "cart.npz"))
    offset = 1.25e-3
    run["q"] = run["q"] + offset
    run["end_effector"] = run["end_effector"] + np.array([offset, 0.0, 0.0])
    moved = files / "moved.npz"
    gpmegen.Results(run).save(moved)
    for reference in ("cart.toml", "cart.npz"):   # the model, and its run as the reference path
        m = _metrics(files, "moved.npz", reference)
        assert m.path[0] == pytest.approx(offset, rel=1e-9)
        assert m.path[1] == pytest.approx(offset, rel=1e-9)
    m = _metrics(files, "moved.npz")
    assert m.constraints["move"][0] == pytest.approx(offset, rel=1e-7)   # Φ = x - law, moved by the offset
    assert m.constraints["move"][1] == pytest.approx(offset, rel=1e-7)


def test_the_plant_under_pd_lags_the_step_and_spends_effort(files):
    m = _metrics(files, "plant.npz")
    assert 1e-4 < m.path[1] < m.path[0] < 0.2
    phi_max, phi_rms = m.constraints["move"]
    assert phi_max == pytest.approx(m.path[0], rel=1e-9)   # the cart's error along x is its path error
    assert list(m.effort) == ["x"] and m.units == {"x": "N"}   # a force on a prismatic joint
    run = gpmegen.Results.load(files / "plant.npz")
    u = run["drive_forces"][:, 0]
    peak, mean, energy = m.effort["x"]
    assert peak == np.max(np.abs(u))
    assert mean == pytest.approx(np.sqrt(np.mean(u ** 2)), rel=2e-2)   # a uniform grid: nearly the plain mean
    # the drive's work in either direction: at least the kinetic energy it gave, and its net work
    assert energy >= abs(run["work_drive"][-1]) * (1 - 1e-3)


def test_effort_of_a_sinusoidal_drive_matches_the_closed_form():
    U, V, w = 3.0, 0.7, 2 * math.pi * 5.0
    t = np.linspace(0.0, 3 * 2 * math.pi / w, 30001)       # three periods
    peak, mean, energy = tracking.effort(t, U * np.sin(w * t), V * np.sin(w * t))
    assert peak == pytest.approx(U, rel=1e-6)
    assert mean == pytest.approx(U / math.sqrt(2), rel=1e-12)   # trapezoid over whole periods: exact
    assert energy == pytest.approx(U * V * t[-1] / 2, rel=1e-12)
    # u in quadrature with q̇: no net work, but ∫|u q̇| dt = U V T / π
    energy = tracking.effort(t, U * np.sin(w * t), V * np.cos(w * t))[2]
    assert energy == pytest.approx(U * V * t[-1] / math.pi, rel=1e-6)


def test_vibration_of_a_sinusoid_about_the_final_position():
    a, w = 2e-3, 2 * math.pi * 4.0
    t = np.linspace(0.0, 2.0, 8001)              # 8 periods; t = 1 s starts the window
    path = np.zeros((len(t), 3))
    path[:, 1] = np.where(t >= 1.0, a * np.sin(w * t), 0.05 * t)
    spread, mean = tracking.vibration(t, path, 1.0)
    assert spread == pytest.approx(2 * a, rel=1e-9)       # the samples hit the peaks
    assert mean == pytest.approx(a / math.sqrt(2), rel=1e-9)
    assert np.isnan(tracking.vibration(t, path, 3.0)[0])


def test_run_reference_ends_where_its_path_stops(files):
    m = _metrics(files, "plant.npz", "cart.npz")
    assert m.constraints == {}
    assert m.after is not None and 0.3 <= m.after < 0.31   # the ideal cart is still from T on


def test_command_prints_and_writes(files, tmp_path, capsys):
    out = tmp_path / "metrics"
    assert main(["metrics", str(files / "plant.npz"), str(files / "cart.npz"), "--reference",
                 str(files / "cart.toml"), "--backend", "numpy", "--out", str(out)]) == 0
    printed = capsys.readouterr().out
    assert "path error of E" in printed and "effort on x" in printed
    rows = (out / "metrics.csv").read_text().splitlines()
    assert rows[0] == "run,quantity,of,value,unit"
    assert any(row.startswith(f"{files / 'plant.npz'},effort_energy_abs_power,x,") for row in rows)
    assert (out / "tracking.png").stat().st_size > 0


@pytest.mark.parametrize("case, problem", [
    ("missing", "no such file"),
    ("no_drives", "drive_forces"),
    ("other", "no coordinate x"),
    ("other_folder", "no coordinate x"),
    ("no_reference", "--reference"),
])
def test_command_refuses_in_one_line(files, tmp_path, capsys, case, problem):
    from gpmegen.analysis.post import results as results_io
    run, reference = files / "plant.npz", files / "cart.toml"
    if case == "missing":
        run = tmp_path / "nothing.npz"
    elif case == "no_drives":
        data = dict(results_io.load(files / "plant.npz"))
        del data["drive_forces"]
        run = tmp_path / "bare.npz"
        gpmegen.Results(data).save(run)
    elif case == "other":
        run = files / "other.npz"
    elif case == "other_folder":   # the reference as a built folder: its manifest names its coordinates
        run, reference = files / "other.npz", tmp_path / "built"
        assert main(["build", str(files / "cart.toml"), "--out", str(reference)]) == 0
        capsys.readouterr()
    else:
        reference = tmp_path / "absent.toml"
    code = main(["metrics", str(run), "--reference", str(reference), "--backend", "numpy"])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2
    assert len(err) == 1 or all(line.startswith("gpmegen: ") for line in err[:-1])
    assert err[-1].startswith("gpmegen metrics: error:") and problem in err[-1]
    if case.startswith("other"):   # refused before the reference model is built and run
        assert len(err) == 1, err


def test_the_reference_arm_by_name_takes_the_runs_rfes(tmp_path, capsys, env):
    run = tmp_path / "arm.npz"
    assert main(["simulate", "--nrfe", "1", "--t-end", "0.01", "--backend", "numpy", "--out", str(run)]) == 0
    assert main(["metrics", str(run), "--reference", "manipulator", "--backend", "numpy"]) == 0
    printed = capsys.readouterr().out
    circle = float(printed.split("constraint circle: max |Φ| ")[1].split(",")[0])
    assert circle < 1e-12                        # the run held the paper's circle
    assert "path error of E: max 0 m" in printed   # its reference path is the same run
