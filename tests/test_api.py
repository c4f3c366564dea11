"""The public Python API that mirrors the command line: gpmegen.statics, gpmegen.simulate and
their Results; every command on model files and on folders made by ``gpmegen build --out``."""

import re
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.post.results import ResultsError
from gpmegen.analysis.run import reference_case
from gpmegen.cli import main
from gpmegen.runtime import partition
from gpmegen.status import SolveStatus

ROOT = Path(__file__).resolve().parents[1]
TIP_LAW = ROOT / "tests" / "models" / "tip_law.toml"


def _readme_block(marker):
    blocks = re.findall(r"```python\n(.*?)```", (ROOT / "README.md").read_text(encoding="utf-8"), re.S)
    return next(block for block in blocks if marker in block)


# make check-c: the reference arm at n_rfe 5 (the README's blocks run as pasted: test_docs.py)
@pytest.mark.long
def test_the_readme_example_of_the_python_api_runs(env, tmp_path, monkeypatch):
    """The README's one Python example, and what its comments say it prints."""
    monkeypatch.chdir(tmp_path)
    (tmp_path / "examples").symlink_to(ROOT / "examples")
    namespace = {}
    exec(compile(_readme_block("gpmegen.simulate("), "README.md", "exec"), namespace)
    run = namespace["run"]
    assert run.status == "complete" and run.t[-1] == pytest.approx(0.05)
    assert np.abs(run["phi"]).max() < 1e-10   # "the constraints hold to round-off"
    np.testing.assert_array_equal(gpmegen.Results.load(tmp_path / "results" / "arm_nrfe5.npz").q, run.q)


def test_load_statics_and_simulate_bind_the_same_constraint_constants(env):
    """r_Ea, y_c: those that put E of the locked statics on the constraints, on every path."""
    loaded = gpmegen.load("manipulator", nrfe=5)
    begun = gpmegen.statics(nrfe=5)
    run = gpmegen.simulate(nrfe=5, t_end=1e-3, dt=1e-4)
    for name in ("r_Ea", "y_c"):
        assert loaded.params[name] == begun.model.params[name] == run.meta["params"][name]
    x, y, z = loaded.end_effector(begun.q)
    assert loaded.params["r_Ea"] == pytest.approx(np.hypot(x, z), abs=1e-12)
    assert loaded.params["y_c"] == pytest.approx(y - loaded.params["A"], abs=1e-12)
    # the arm's sag moves E: not the rigid arm's values, which stay the file's defaults
    rigid = gpmegen.load("manipulator", nrfe=1)
    assert abs(loaded.params["r_Ea"] - rigid.params["r_Ea"]) > 1e-2
    assert rigid.params["r_Ea"] == pytest.approx(np.hypot(*rigid.end_effector(reference_case.joint_start(rigid))[::2]))
    assert gpmegen.load("manipulator", nrfe=5, params={"r_Ea": 1.05}).params["r_Ea"] == 1.05


@pytest.mark.requires_cc
def test_the_default_backend_is_c_where_a_compiler_is_found_and_numpy_stays_available():
    assert gpmegen.load("manipulator", nrfe=1).backend == "c"
    assert gpmegen.load("manipulator", nrfe=1, backend="numpy").backend == "numpy"
    assert gpmegen.statics(nrfe=1).model.backend == "c"


def test_without_a_compiler_the_default_is_numpy_said_in_one_line(monkeypatch):
    monkeypatch.setenv("CC", "gpmegen-test-no-such-compiler")
    with pytest.warns(RuntimeWarning) as caught:
        model = gpmegen.load("manipulator", nrfe=1)
    said = [str(w.message) for w in caught]
    assert model.backend == "numpy"
    assert len(said) == 1 and "\n" not in said[0] and said[0].endswith("; using the NumPy backend"), said
    told = []
    run = gpmegen.simulate(nrfe=1, t_end=1e-3, dt=1e-4, progress=told.append)
    assert run.meta["backend"] == "numpy"
    assert [line for line in told if "NumPy backend" in line] == [said[0]]
    with pytest.raises(gpmegen.BuildError, match="no-such-compiler"):
        gpmegen.load("manipulator", nrfe=1, backend="c")  # asked for by name, C is not replaced


def test_simulate_returns_results_with_named_accessors_and_saves_without_replacing(env, tmp_path):
    run = gpmegen.simulate(TIP_LAW, t_end=0.01, dt=2.5e-4, save_every=8)  # below its stable step, 4.3e-4 s
    assert run.coordinates == ("theta1", "psi1_1", "theta1_1", "phi1_1")
    np.testing.assert_array_equal(run.coordinate("theta1"), run.q[:, 0])
    np.testing.assert_array_equal(run.velocity("psi1_1"), run.qd[:, 1])
    # the tip law y = v0 t holds from the first step (the start is consistent)
    np.testing.assert_allclose(run["end_effector"][:, 1], 0.2 * run.t, atol=1e-12)
    assert run["phi"].shape == (len(run.t), 1) and run.meta["start_moved"]["qd"]["max_change"] < 1e-12
    path = tmp_path / "tip.npz"
    assert run.save(path) == [path, path.with_suffix(".csv")]
    with pytest.raises(ResultsError, match="earlier run's results.*overwrite=True"):
        run.save(path)
    run.save(path, overwrite=True)
    np.testing.assert_array_equal(gpmegen.Results.load(path).qd, run.qd)
    with pytest.raises(KeyError, match="not a coordinate"):
        run.coordinate("x3")


def test_a_start_off_its_constraints_is_a_python_warning(env, tmp_path):
    path = tmp_path / "from_rest.toml"
    # a velocity given off the law's (a velocity not given is the constraints' to solve: no warning)
    path.write_text(TIP_LAW.read_text(encoding="utf-8").replace('qd = { theta1 = "v0/L" }', "qd = { theta1 = 0.0 }"),
                    encoding="utf-8")
    with pytest.warns(RuntimeWarning, match="qd of theta1 by 4.000e-01"):
        begun = gpmegen.statics(path)
    assert begun.qd[0] == pytest.approx(0.4)


def test_a_model_with_auto_dependent_coordinates_evaluates_out_of_the_box(env, tmp_path):
    """With ``dependent = "auto"`` the accelerations are those of any regular partition: the
    GPME rows Bᵀ(M q̈ - f) = 0 span the same space for every choice of dependent coordinates."""
    text = TIP_LAW.read_text(encoding="utf-8")
    path = tmp_path / "auto.toml"
    path.write_text(text.replace('dependent = ["theta1"]', 'dependent = "auto"').replace("tip_law_", "tip_auto_"),
                    encoding="utf-8")
    model = gpmegen.load(model=gpmegen.load_model_file(path))
    given = gpmegen.load(model=gpmegen.load_model_file(TIP_LAW))
    assert model.dependent is None
    rng = np.random.default_rng(3)
    q, qd = rng.normal(scale=0.1, size=4), rng.normal(size=4)
    np.testing.assert_allclose(model.accelerations(0.3, q, qd), given.accelerations(0.3, q, qd), rtol=1e-10,
                               atol=1e-10)
    chosen = partition.partition_at(model, q, 0.3)
    np.testing.assert_array_equal(model.accelerations(0.3, q, qd), chosen.accelerations(0.3, q, qd))
    t, q_run, _, _, status = model.rk4(q, qd, 1e-3, 1e-4)
    assert status == SolveStatus.OK and np.all(np.isfinite(q_run))


# make check-c: every command once on one folder: about 10 s of CPU
@pytest.mark.long
def test_every_command_runs_on_a_folder_made_by_build_out(env, tmp_path, capsys):
    out = tmp_path / "built"
    assert main(["build", str(TIP_LAW), "--out", str(out)]) == 0
    folder = out / "tip_law_nrfe2"
    run = tmp_path / "folder.npz"
    assert main(["simulate", str(out), "--t-end", "0.01", "--dt", "2.5e-4", "--backend", "numpy",
                 "--out", str(run)]) == 0
    assert main(["statics", str(folder), "--statics", "locked"]) == 0
    assert main(["modes", str(folder), "--out", str(tmp_path / "figures")]) == 0
    assert main(["plot", str(run), "--out", str(tmp_path / "figures")]) == 0
    capsys.readouterr()
    # the folder keeps the file's [initial] (start.json): the same run as from the file itself
    mine = gpmegen.simulate(TIP_LAW, t_end=0.01, dt=2.5e-4, backend="numpy")  # the default save interval, as above
    np.testing.assert_allclose(gpmegen.Results.load(run).q, mine.q, atol=1e-14)
    assert gpmegen.Results.load(run).qd[0, 0] == pytest.approx(0.4)
    # a Model of one's own starts at q = 0 with no velocity given: the law's is solved, no warning
    import warnings

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        begun = gpmegen.statics(gpmegen.load_model_file(TIP_LAW), directory=tmp_path / "generated")
    assert begun.qd[0] == pytest.approx(0.4) and not [w for w in caught if "qd of theta1" in str(w.message)]
    (folder / "start.json").write_text("{", encoding="utf-8")
    assert main(["statics", str(folder)]) == 1
    err = capsys.readouterr().err
    last = err.strip().splitlines()[-1]
    assert last.startswith("gpmegen statics: error: ") and "start.json is damaged" in last and "--out" in last
    # an output folder holding two models is refused in one line
    assert main(["build", "--nrfe", "1", "--out", str(out)]) == 0
    capsys.readouterr()
    assert main(["statics", str(out)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "holds 2 built models" in err


def test_a_folder_of_the_reference_manipulator_runs_its_scenario(env, tmp_path, capsys):
    out = tmp_path / "built"
    assert main(["build", "--nrfe", "1", "--out", str(out)]) == 0
    run = gpmegen.simulate(out, t_end=1e-3, dt=1e-4)
    assert run.meta["label"] == "rigid arm" and run.meta["start"] == "locked"
    assert run.meta["params"]["r_Ea"] == gpmegen.load("manipulator", nrfe=1).params["r_Ea"]
    assert "prescribed" in run.keys()
    assert gpmegen.statics(out).model.folder == out / "manipulator_nrfe1"  # the folder's code, not a new build


def test_modes_of_a_model_file_match_the_single_spring_formula(env, tmp_path, capsys):
    """n_rfe = 2: one sde at the middle, the outer half (a bar of length L/2) on a spring
    c = E·b·h³/(12 L) (bending in the plane of the joint); joints locked: f = √(c/J)/2π with J the
    half's inertia about the sde. The model has no gravity, so +z is up and this bending in the
    plane x0y0 is horizontal."""
    assert main(["modes", str(TIP_LAW), "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    L, b, h, rho, E = 0.5, 0.02, 0.01, 2700.0, 7.0e10
    c = E * b * h**3 / 12 / L
    m = rho * b * h * L / 2
    J = m * ((L / 2) ** 2 + h**2) / 12 + m * (L / 4) ** 2
    first = float(re.search(r"^\s+1\s+(\S+)\s+horizontal", out, re.M).group(1))
    assert first == pytest.approx(np.sqrt(c / J) / (2 * np.pi), rel=1e-5)
    assert (tmp_path / "modes_tip_law_joints.csv").exists()


def test_convergence_takes_param_overrides(tmp_path, capsys):
    """The clamped arm's static tip deflection (linear) goes as 1/E: E2 four times larger, a
    quarter of the deflection, in beam theory and in every n_rfe."""
    tables = []
    for extra in ([], ["--param", "E2=2.8e11"]):
        assert main(["convergence", "--nrfe", "2", "3", "--out", str(tmp_path / f"E{len(tables)}"), *extra]) == 0
        out = capsys.readouterr().out
        block = out.split("\n\n")[1].splitlines()
        analytic = float(re.search(r"analytic (\S+)", block[0]).group(1))
        values = [float(line.split()[1]) for line in block[2:4]]
        tables.append(np.array([analytic, *values]))
    np.testing.assert_allclose(tables[1] / tables[0], 0.25, rtol=1e-6)


def _standalone(folder):
    """The generated NumPy module of ``folder`` imported as a plain file, without gpmegen."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(f"standalone_{folder.name}", folder / "model_numpy.py")
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("order", (0, 1))
def test_the_standalone_numpy_module_solves_the_gpme_as_gpmegen_does(env, tmp_path, rng, order):
    """The module's own accelerations (null-space basis, no partition) against gpmegen's solve
    (a partition's B), at random states; order 1: the tip's velocity prescribed instead."""
    path = tmp_path / f"order{order}.toml"
    text = TIP_LAW.read_text(encoding="utf-8").replace("tip_law_", f"tip_order{order}_")
    if order:
        text = text.replace('expression = "y_tip - v0*t"', 'expression = "vy_tip - v0"\norder = 1')
        text = text.replace('beta = "beta_tip"\n', "")
    path.write_text(text, encoding="utf-8")
    model = gpmegen.load(model=gpmegen.load_model_file(path), directory=tmp_path / "generated")
    module = _standalone(tmp_path / "generated" / model.module.MODEL)
    for _ in range(3):
        q, qd, t = rng.normal(scale=0.3, size=4), rng.normal(size=4), rng.uniform(0, 1)
        np.testing.assert_allclose(module.accelerations(t, q, qd, module.DEFAULTS), model.accelerations(t, q, qd),
                                   rtol=1e-9, atol=1e-9)


def test_the_reference_snapshots_standalone_accelerations_agree_with_gpmegen(flexible, rng):
    module = _standalone(ROOT / "generated" / "manipulator_nrfe5")
    q, qd = rng.normal(scale=0.1, size=15), rng.normal(scale=0.1, size=15)
    q[1] += np.pi / 4
    np.testing.assert_allclose(module.accelerations(0.2, q, qd, flexible.p), flexible.accelerations(0.2, q, qd),
                               rtol=1e-9, atol=1e-9)


def test_convergence_of_a_model_files_flexible_link_against_beam_theory(env, tmp_path, capsys):
    """The tip law's link clamped: beam theory's w L⁴/(8 E Iz), and at n_rfe = 2 (one sde in the
    middle) exactly half of it: the middle turns by (w (L/2)²/2)/(E Iz/L), the tip drops by that
    times L/2, i.e. w L⁴/(16 E Iz)."""
    assert main(["convergence", str(TIP_LAW), "--nrfe", "2", "3", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "flexible link '1' of tip_law_nrfe2, clamped" in out
    block = out.split("\n\n")[1].splitlines()
    L, b, h, rho, E, g = 0.5, 0.02, 0.01, 2700.0, 7.0e10, 9.81
    exact = rho * b * h * g * L**4 / (8 * E * b * h**3 / 12)
    assert float(re.search(r"analytic (\S+)", block[0]).group(1)) == pytest.approx(exact, rel=1e-7)
    assert float(block[2].split()[1]) == pytest.approx(exact / 2, rel=1e-6)
    assert (tmp_path / "convergence_tip_law_nrfe2_link1.png").exists()


def test_convergence_refuses_a_model_without_a_flexible_link_in_one_line(tmp_path, capsys):
    text = TIP_LAW.read_text(encoding="utf-8")
    start = text.index("[[chain]]\nflexible")
    body = '[[chain]]\nbody = "bar"\nshape = { type = "rod", mass = 1, length = "L", radius = 0.01 }\n'
    rigid = text[:start] + body + text[text.index("[[chain]]\npoint"):]
    path = tmp_path / "rigid.toml"
    path.write_text(rigid.replace("[initial]\nqd", "[initial]\nq"), encoding="utf-8")
    assert main(["convergence", str(path), "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "has no flexible link" in err


def test_load_without_a_model_is_deprecated_and_loads_the_same_arm(env):
    """The old ``load(nrfe=N)`` (and ``load()``) warns once, naming the new call, and gives the
    same mass matrix and forces at a random state as ``load("manipulator", nrfe=N)``."""
    new = gpmegen.load("manipulator", nrfe=1, backend="numpy")
    with pytest.warns(DeprecationWarning) as caught:
        old = gpmegen.load(nrfe=1, backend="numpy")
    assert [str(w.message) for w in caught] == [
        "gpmegen.load() without a model is deprecated; use gpmegen.load('manipulator', nrfe=1)"]
    assert caught[0].filename == __file__  # pointed at the caller's line
    rng = np.random.default_rng(7)
    q, qd = rng.uniform(-1, 1, new.n_dof), rng.uniform(-1, 1, new.n_dof)
    assert np.array_equal(old.mass_matrix(q), new.mass_matrix(q))
    assert np.array_equal(old.forces(0.3, q, qd), new.forces(0.3, q, qd))
    assert old.params == new.params
    with pytest.warns(DeprecationWarning, match=r"gpmegen\.load\('manipulator', nrfe=5\)"):
        assert gpmegen.load(backend="numpy").params == gpmegen.statics("manipulator", backend="numpy").model.params


def test_load_takes_a_model_file_a_name_or_a_model_alike(env):
    """``load(path, nrfe=N)`` is ``gpmegen build path --nrfe N``'s model; a Model with nrfe is
    refused in one line (its rfes are in it)."""
    path = ROOT / "tests" / "models" / "pendulum.toml"
    by_file = gpmegen.load(path, backend="numpy", directory=env[0])
    by_model = gpmegen.load(gpmegen.load_model_file(path), backend="numpy", directory=env[0])
    assert by_file.folder == by_model.folder and by_file.params == by_model.params
    with pytest.raises(TypeError, match=r"^load\(\): nrfe=2 applies to a model file") as refused:
        gpmegen.load(gpmegen.load_model_file(path), nrfe=2)
    assert "\n" not in str(refused.value)
