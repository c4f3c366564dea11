"""The example model files end to end through the command line: ``build``, ``simulate`` (the C
backend when a compiler is present) and ``plot``. Each run must hold its programmed constraints,
finish, and move the end-effector the way the file prescribes; a copy with ``dependent = "auto"``
names the dependent coordinates it chose, and ``--repartition`` runs."""

from __future__ import annotations

import tomllib
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.post import results as results_io
from gpmegen.analysis.run.model_files import read_model_file
from gpmegen.cli import main
from gpmegen.runtime import partition

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
T_END, DT, SAVE_EVERY = 0.5, 1e-4, 10
# every example has flexible links, so the driving functions come with the elastic deformation
FIGURES = {"joint_coordinates", "end_effector", "path", "constraint_violation", "energy_balance",
           "driving_functions", "constraint_multipliers", "elastic_deformation"}


def _have_compiler() -> bool:
    from gpmegen.errors import BuildError
    from gpmegen.runtime.ccompile import find_compiler

    try:
        return bool(find_compiler())
    except BuildError:
        return False


def _params(path) -> dict[str, float]:
    """Parameter values of a model file, read from the file itself."""
    table = tomllib.loads(Path(path).read_text())["parameters"]
    return {k: float(v["value"] if isinstance(v, dict) else v) for k, v in table.items()}


# The end-effector's prescribed motion, evaluated from the file's numbers (t: (k,), E: (k, 3)).
def _planar_residual(p, t, E):
    s = p["A"] * (1 - np.cos(2 * np.pi * t / p["T"])) / 2
    return np.column_stack([E[:, 0] - (p["xa"] + s * np.cos(p["lam"])),
                            E[:, 1] - (p["ya"] + s * np.sin(p["lam"]))])


def _spatial_residual(p, t, E):
    d = p["d0"] - p["A"] * np.sin(np.pi * t / p["T"]) ** 2
    return E[:, 0] * np.sin(p["gam"]) + E[:, 1] * np.cos(p["gam"]) - d


def _nonholonomic_residual(p, t, E):
    return E[:, 2] - p["z0"]   # the height; the heading (first order) is checked through Φ


def _planar_travel(p, t):
    return p["A"] * (1 - np.cos(2 * np.pi * t / p["T"])) / 2


def _spatial_travel(p, t):
    return p["A"] * np.sin(np.pi * t / p["T"]) ** 2


CASES = {
    "planar_two_link.toml": (_planar_residual, _planar_travel),
    "spatial_six_joint.toml": (_spatial_residual, _spatial_travel),
    "nonholonomic.toml": (_nonholonomic_residual, None),
}


def _run(argv, capsys):
    code = main([str(a) for a in argv])
    out, err = capsys.readouterr()
    assert "Traceback" not in out + err, err
    assert code == 0, f"{argv}: exit {code}\n{err}"
    return out, err


def _settings(res) -> dict:
    return results_io.metadata(res)["settings"]


def _check_run(res, model_file):
    assert str(res["status"]) == "complete"
    t = res["t"]
    assert t[0] == 0.0 and t[-1] == pytest.approx(T_END)
    assert len(t) == int(round(T_END / DT / SAVE_EVERY)) + 1
    assert np.all(np.isfinite(res["q"])) and np.all(np.isfinite(res["qd"]))
    phi = res["phi"]
    assert phi.shape == (len(t), len(read_model_file(model_file).model.constraints))
    assert np.max(np.abs(phi)) < 1e-6


@pytest.fixture
def generated(tmp_path, monkeypatch):
    """`build --out` and `simulate` share one folder: simulate loads what build wrote."""
    folder = tmp_path / "generated"
    monkeypatch.setenv("GPMEGEN_GENERATED", str(folder))
    return folder


# Each example built, run for 0.5 s and plotted: 14-23 s of CPU; the planar arm in make test,
# the spatial and the nonholonomic arms in make check-c
@pytest.mark.parametrize("name", [pytest.param(name, marks=[pytest.mark.long] if name != "planar_two_link.toml" else [])
                                  for name in CASES])
def test_example_builds_simulates_and_plots(name, tmp_path, generated, capsys):
    path = EXAMPLES / name
    model = read_model_file(path).model

    out, _ = _run(["build", path, "--out", generated], capsys)
    assert model.name in out and "built in" in out
    folder = generated / model.name
    assert {"manifest.json", "model.c", "model_numpy.py"} <= {p.name for p in folder.iterdir()}
    # built once: a second build is skipped, and simulate reuses it
    out, _ = _run(["build", path, "--out", generated], capsys)
    assert "up to date, skipped" in out

    run = tmp_path / "run.npz"
    out, err = _run(["simulate", path, "--t-end", T_END, "--dt", DT, "--save-every", SAVE_EVERY, "--out", run],
                    capsys)
    assert run.exists() and run.with_suffix(".csv").exists()
    assert "max|Φ|" in out
    assert "deriving" not in err  # the model built above is used, not derived again

    res = results_io.load(run)
    _check_run(res, path)
    settings = _settings(res)
    assert settings["backend"] == ("c" if _have_compiler() else "numpy")
    assert settings["dependent"] == list(model.dependent)
    assert settings["start"] == "none"

    # the end-effector (the file's only point) follows what the file prescribes
    residual, travel = CASES[name]
    p = _params(path)
    t, E = res["t"], res["end_effector"]
    assert np.max(np.abs(residual(p, t, E))) < 1e-6
    if travel is not None:    # and it does move: the prescribed travel is reached
        moved = np.linalg.norm(E - E[0], axis=1)
        assert np.max(moved) > 0.5 * np.max(travel(p, t)) > 1e-3
    # the coordinates the file names start where it says
    initial = read_model_file(path).initial_values()
    coordinates = [str(c) for c in res["coordinates"]]
    for coordinate, value in initial.items():
        if coordinate not in model.dependent:
            assert res["q"][0, coordinates.index(coordinate)] == pytest.approx(value, abs=1e-12)

    figures = tmp_path / "figures"
    out, _ = _run(["plot", run, "--out", figures], capsys)
    pngs = {p.stem for p in figures.glob("*.png")}
    assert pngs == FIGURES
    assert all(p.stat().st_size > 1000 for p in figures.glob("*.png"))
    assert len(out.split()) == len(FIGURES)


# make check-c: the six-joint arm built, run twice and compared: about 12 s of CPU
@pytest.mark.long
def test_automatic_partition_is_recorded_and_repartition_runs(tmp_path, generated, capsys):
    """The spatial arm's file names d4; with "auto" the column-pivoted QR of D at the start picks
    its own dependent coordinate, the run records it, and the motion is the same."""
    text = (EXAMPLES / "spatial_six_joint.toml").read_text()
    assert 'dependent = ["d4"]' in text
    path = tmp_path / "spatial_auto.toml"
    path.write_text(text.replace('dependent = ["d4"]', 'dependent = "auto"'))
    file = read_model_file(path)
    assert file.model.dependent is None

    _run(["build", path, "--out", generated], capsys)
    run = tmp_path / "auto.npz"
    common = ["--t-end", T_END, "--dt", DT, "--save-every", SAVE_EVERY]
    _run(["simulate", path, *common, "--out", run], capsys)
    res = results_io.load(run)
    _check_run(res, path)
    chosen = _settings(res)["dependent"]
    assert len(chosen) == 1 and chosen[0] in [str(c) for c in res["coordinates"]]

    # what was recorded is what the partition chooses at the start configuration
    loaded = gpmegen.load(model=file.model, backend="numpy", directory=generated, build=False)
    q0 = res["q"][0]
    expected = partition.partition_at(loaded, q0)
    assert chosen == [loaded.coordinates[k] for k in expected.dependent]
    _, _, D, _ = loaded.constraint_terms(0.0, q0, np.zeros(loaded.n_dof))
    assert partition.condition(D, expected.dependent) < 1e3

    # the partition changes the coordinates solved for, not the motion
    fixed = tmp_path / "fixed.npz"
    _run(["simulate", EXAMPLES / "spatial_six_joint.toml", *common, "--out", fixed], capsys)
    ref = results_io.load(fixed)
    assert _settings(ref)["dependent"] == ["d4"]
    np.testing.assert_allclose(res["q"], ref["q"], rtol=0, atol=1e-7)
    np.testing.assert_allclose(res["end_effector"], ref["end_effector"], rtol=0, atol=1e-8)

    # --repartition: the watch may choose anew; the run completes and records its events
    again = tmp_path / "repartition.npz"
    _run(["simulate", path, *common, "--repartition", "--out", again], capsys)
    res2 = results_io.load(again)
    _check_run(res2, path)
    settings = _settings(res2)
    assert isinstance(settings["repartitions"], list)
    for t_event, old, new in settings["repartitions"]:
        assert 0 <= t_event <= T_END and len(old) == len(new) == 1 and old != new
    if not settings["repartitions"]:
        assert settings["dependent"] == chosen
        np.testing.assert_array_equal(res2["q"], res["q"])


def test_slider_crank_example_closes_its_loop(tmp_path, generated, capsys):
    """Simeon's flexible slider-crank (examples/slider_crank_flexible.toml, n_rfe 2; Radau, as its
    rod's axial springs put the explicit step far below 1e-4 s): the loop holds, the crank's tip
    follows its prescribed circle, and the slider keeps to the rigid mechanism's closed-form place
    within the rod's deformation: started from rest undeformed, a rod of one sde rings with a
    midpoint deflection of up to about 5 mm, whose bow ∫w'²/2 ≈ δ²π²/(4L) shortens it by up to
    0.2 mm (its stretch is 1e-5 m); 0.14 mm measured."""
    path = EXAMPLES / "slider_crank_flexible.toml"
    run = tmp_path / "slider_crank.npz"
    _run(["simulate", path, "--nrfe", 2, "--method", "radau", "--t-end", 0.02, "--save-dt", 1e-3, "--out", run],
         capsys)
    res = results_io.load(run)
    assert str(res["status"]) == "complete" and res["t"][-1] == pytest.approx(0.02)
    assert np.max(np.abs(res["phi"])) < 1e-8
    p = _params(path)
    t, crank_tip = res["t"], res["end_effector"]
    angle = p["w"] * t
    assert np.max(np.abs(crank_tip[:, :2] - p["L1"] * np.column_stack([np.cos(angle), np.sin(angle)]))) < 1e-10
    x3 = res["q"][:, [str(c) for c in res["coordinates"]].index("x3")]
    rigid = p["L1"] * np.cos(angle) + np.sqrt(p["L2"] ** 2 - (p["L1"] * np.sin(angle)) ** 2)
    assert np.max(np.abs(x3 - rigid)) < 3e-4
    assert np.max(rigid) - np.min(rigid) > 0.05   # and the slider does travel


def test_bauchau_four_bar_bends_out_of_its_plane_by_its_tilt(tmp_path, generated, capsys):
    """Bauchau's spatial four-bar (examples/bauchau_four_bar.toml, n_rfe 2, Radau, 0.5 s): the
    crank follows its law from rest; with the joint at C untilted the linkage is a planar
    parallelogram, whose out-of-plane sde rotations (theta, phi) stay exactly zero and whose
    coupler translates (alpha2 = -alpha1, alpha3 = alpha1 to the links' in-plane bending, below
    1e-5 rad); tilted, the out-of-plane deformation grows with the tilt, in proportion for a small
    tilt (2.5 and 5 degrees: the follower's out-of-plane rotation doubles, to 1 %), and the
    departure from the parallelogram in the plane with its square (quadruples, to 2 %)."""
    path = EXAMPLES / "bauchau_four_bar.toml"
    p = _params(path)
    runs = {}
    for degrees in (0.0, 2.5, 5.0):
        run = tmp_path / f"tilt{degrees}.npz"
        _run(["simulate", path, "--nrfe", 2, "--method", "radau", "--t-end", 0.5, "--save-dt", 0.01,
              "--param", f"tilt={float(np.radians(degrees))!r}", "--out", run], capsys)
        res = results_io.load(run)
        assert str(res["status"]) == "complete" and res["t"][-1] == pytest.approx(0.5)
        assert np.max(np.abs(res["phi"])) < 1e-10
        names = [str(c) for c in res["coordinates"]]
        runs[degrees] = {name: res["q"][:, names.index(name)] for name in names}
    t = res["t"]
    law = -p["w"] * (t - p["T_r"] * np.tanh(t / p["T_r"]))
    assert np.max(np.abs(runs[5.0]["alpha1"] - law)) < 1e-12
    assert abs(law[-1]) > 0.15                                 # and the crank does turn
    flat = runs[0.0]
    out_of_plane = [name for name in flat if name.startswith(("theta", "phi"))]
    assert len(out_of_plane) == 6
    assert all(np.max(np.abs(flat[name])) == 0.0 for name in out_of_plane)
    assert np.max(np.abs(flat["alpha2"] + flat["alpha1"])) < 1e-5
    assert np.max(np.abs(flat["alpha3"] - flat["alpha1"])) < 1e-5

    def departure(run):
        return np.max(np.abs(run["alpha3"] - run["alpha1"] - (flat["alpha3"] - flat["alpha1"])))

    half, full = runs[2.5]["theta3_1"][-1], runs[5.0]["theta3_1"][-1]
    assert abs(full) > 5e-3
    assert full / half == pytest.approx(2.0, rel=0.01)
    assert departure(runs[5.0]) / departure(runs[2.5]) == pytest.approx(4.0, rel=0.02)


# the Delta's build at its n_rfe 3, 0.4 s of its run and its plots: about 25 s of CPU, make check-c
# (tests/test_delta.py keeps the rigid and the n_rfe 2 Delta in make test)
@pytest.mark.long
def test_delta_example_keeps_its_platform_on_the_arc_and_plots_its_loops(tmp_path, generated, capsys):
    """The Delta robot (examples/delta_flexible.toml, its n_rfe 3) from its constrained
    equilibrium: the three loops and the path hold, the platform centre P follows the half circle
    of the file (its cycloidal law), the forearms bend, and the plots add the closures' reactions."""
    path = EXAMPLES / "delta_flexible.toml"
    run = tmp_path / "delta.npz"
    _run(["simulate", path, "--statics", "constrained", "--t-end", 0.4, "--dt", 5e-5, "--save-every", 20,
          "--out", run], capsys)
    res = results_io.load(run)
    assert str(res["status"]) == "complete" and res["t"][-1] == pytest.approx(0.4)
    assert np.max(np.abs(res["phi"])) < 1e-10
    p = _params(path)
    u = np.minimum(res["t"] / p["T"], 1.0)
    s = np.pi * (u - np.sin(2 * np.pi * u) / (2 * np.pi))
    arc = np.column_stack([p["R_arc"] * np.cos(s), p["R_arc"] * np.sin(s), np.full_like(s, p["z_0"])])
    assert np.max(np.abs(res["end_effector"] - arc)) < 1e-10
    coordinates = [str(c) for c in res["coordinates"]]
    bends = np.abs(res["q"][:, [k for k, c in enumerate(coordinates) if c.startswith(("psi", "theta")) and "_" in c]])
    assert 1e-7 < bends.max() < 1e-3
    figures = tmp_path / "figures"
    _run(["plot", run, "--out", figures], capsys)
    assert {p.stem for p in figures.glob("*.png")} == FIGURES | {"closure_reactions"}
