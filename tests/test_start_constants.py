"""Parameters a model sets at its start (``[initial] set``): taken at the locked statics of
``[initial] q`` on every path (load, statics, a run; at ``q`` itself in a run without statics), a
value the user gives kept, refusals in one line; the reference arm declares its r_Ea and y_c so,
with the values its former code gave."""

import json
import math
import shutil
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run.model_files import load_model_file
from gpmegen.cli import main
from gpmegen.errors import ModelError
from gpmegen.runtime import statics

ROOT = Path(__file__).resolve().parent.parent
REACH = ROOT / "tests" / "models" / "sprung_reach.toml"


def _hand(p):
    """P of sprung_reach at the locked statics of θ = 30°: the spring carries both masses,
    k s = -(m1 + m2) g, and P = (L cos θ, s + L sin θ, 0)."""
    s = -(p["m1"] + p["m2"]) * p["g"] / p["k"]
    theta = math.pi / 6
    return {"h": s + p["L"] * math.sin(theta), "w": p["L"] * math.cos(theta) - p["L"]}


def test_a_model_file_sets_parameters_from_its_locked_statics(env):
    loaded = gpmegen.load(REACH, backend="numpy")
    hand = _hand(loaded.params)
    assert loaded.params["h"] == pytest.approx(hand["h"], abs=1e-12)
    assert loaded.params["w"] == pytest.approx(hand["w"], abs=1e-12)
    assert abs(hand["h"] - 0.4) > 0.05   # the sag counts: not the undeformed P
    begun = gpmegen.statics(REACH, backend="numpy", start="locked")
    assert begun.model.params["h"] == loaded.params["h"] and begun.moved["q"][0] < 1e-12  # on the constraint
    assert begun.q[1] == pytest.approx(math.pi / 6, abs=1e-12)
    stiffer = gpmegen.load(REACH, backend="numpy", params={"k": 800.0})
    assert stiffer.params["h"] == pytest.approx(_hand(stiffer.params)["h"], abs=1e-12)
    given = gpmegen.load(REACH, backend="numpy", params={"h": 0.3})
    assert given.params["h"] == 0.3 and given.params["w"] == loaded.params["w"]


def test_the_reference_arm_sets_r_ea_and_y_c_as_before(env):
    """E at the locked statics of θ1 = 0, ψ2 = 45°, x3 = 0, by the former formulas (hypot; y - A),
    to the bit; the example file declares the same start and gets the same values."""
    for nrfe in (1, 2):
        loaded = gpmegen.load("manipulator", nrfe=nrfe, backend="numpy")
        q = np.zeros(loaded.n_dof)
        q[loaded.index("psi2")] = np.pi / 4
        x, y, z = loaded.end_effector(statics.locked(loaded, q))
        assert loaded.params["r_Ea"] == float(np.hypot(x, z))
        assert loaded.params["y_c"] == float(y - loaded.params["A"])
        from_file = gpmegen.load(ROOT / "examples" / "manipulator.toml", nrfe=nrfe, backend="numpy")
        assert (from_file.params["r_Ea"], from_file.params["y_c"]) == (loaded.params["r_Ea"], loaded.params["y_c"])


@pytest.mark.parametrize("change, words", [
    ('set = { h = "y_P", hh = "y_P" }', ["initial.set.hh", "'hh' is not a parameter", "did you mean 'h'?"]),
    ('set = { h = "y_Q" }', ["initial.set.h", "'y_Q' names no declared point 'Q'", "points: P"]),
    ('set = { h = "theta" }', ["initial.set.h", "coordinate 'theta' may appear only in drives"]),
    ('set = { h = "__import__" }', ["initial.set.h"]),
    ('set = "h"', ["initial.set", "expected a table of parameters"]),
    # each value is taken from the others as they were: reading one set too would take its default
    ('set = { h = "y_P", w = "h + 1" }', ["initial.set.w", "reads h, which the start also sets"]),
])
def test_a_bad_set_is_refused_in_one_line(tmp_path, change, words):
    path = tmp_path / "reach.toml"
    path.write_text(REACH.read_text().replace('set = { h = "y_P", w = "x_P - L" }', change))
    with pytest.raises(ModelError) as caught:
        load_model_file(path)
    message = str(caught.value)
    assert "\n" not in message and message.startswith(f"{path}:")
    for word in words:
        assert word in message, message


def test_a_python_models_start_constants_are_checked_as_it_expands():
    from dataclasses import replace

    import sympy as sp

    from gpmegen.model import reference_model
    from gpmegen.model.expand import expand
    from gpmegen.model.start_constants import StartConstants

    arm = reference_model(1)
    for declared, words in [
        (StartConstants(values=(("nope", sp.S.Zero),)), "the start sets 'nope', which is not a parameter"),
        (StartConstants(values=(("y_c", sp.Symbol("y_F", real=True)),)), "reads y_F, which is neither a parameter"),
        (StartConstants(at=(("x9", sp.S.Zero),)), "the start holds 'x9', which is not a coordinate"),
    ]:
        with pytest.raises(ModelError, match=words):
            expand(replace(arm, start_constants=declared))


def test_a_value_that_is_not_a_number_at_the_start_is_refused_in_one_line(tmp_path, env):
    path = tmp_path / "reach.toml"
    path.write_text(REACH.read_text().replace('w = "x_P - L"', 'w = "sqrt(-1 - x_P^2)"'))
    with pytest.raises(ModelError, match=r"^the value set at the start of w, .* is not a finite real number") as caught:
        gpmegen.load(path, backend="numpy")
    assert "\n" not in str(caught.value)


@pytest.mark.parametrize("change, moved", [
    ('set = { h = "y_P", L = "0.5" }', "the points' positions"),   # a length of the chain
    ('set = { h = "y_P", k = "1000 + 0*y_P" }', "the static balance"),   # the spring the statics solved
])
def test_a_value_that_moves_what_it_was_taken_at_is_refused(tmp_path, env, change, moved):
    """A value set for a parameter the chain or its forces read would move the points or the
    springs' balance the values were taken at: refused in one line naming it."""
    path = tmp_path / "reach.toml"
    path.write_text(REACH.read_text().replace('set = { h = "y_P", w = "x_P - L" }', change))
    with pytest.raises(ModelError, match=rf"^\[initial\] set: the value set for \w+ changes {moved}") as caught:
        gpmegen.load(path, backend="numpy")
    assert "\n" not in str(caught.value)


def test_a_run_without_statics_takes_the_values_at_the_undeformed_start(env):
    """With --statics none the run starts from [initial] q itself: the values are P's there
    (s = 0: P = (L cos θ, L sin θ)), so the start is on the constraints and is not moved."""
    run = gpmegen.simulate(REACH, t_end=0.01, dt=1e-3, backend="numpy", start="none")
    meta, theta = json.loads(str(run["meta"])), math.pi / 6
    p = meta["params"]
    assert p["h"] == pytest.approx(p["L"] * math.sin(theta), abs=1e-12)
    assert p["w"] == pytest.approx(p["L"] * math.cos(theta) - p["L"], abs=1e-12)
    assert meta["start_moved"]["q"]["max_change"] == 0.0
    assert run.coordinate("s")[0] == 0.0 and run.coordinate("theta")[0] == pytest.approx(theta, abs=1e-12)


@pytest.fixture(scope="module")
def reach_folder(env, tmp_path_factory):
    """sprung_reach built by ``gpmegen build --out``: its folder."""
    out = tmp_path_factory.mktemp("built")
    assert main(["build", str(REACH), "--out", str(out)]) == 0
    return out / "sprung_reach"


@pytest.mark.parametrize("start", ["locked", "none"])
def test_a_built_folder_starts_as_its_file_does(reach_folder, start):
    """The folder records [initial] set: from it the start binds h and w as from the file, to the
    bit, at the locked statics (the sag by hand) or, without statics, at [initial] q itself."""
    mine, built = (gpmegen.statics(source, backend="numpy", start=start) for source in (REACH, reach_folder))
    assert built.model.params == mine.model.params
    np.testing.assert_array_equal(built.q, mine.q)
    np.testing.assert_array_equal(built.qd, mine.qd)
    p, theta = built.model.params, math.pi / 6
    undeformed = {"h": p["L"] * math.sin(theta), "w": p["L"] * math.cos(theta) - p["L"]}   # s = 0
    expected = _hand(p) if start == "locked" else undeformed
    assert (p["h"], p["w"]) == (pytest.approx(expected["h"], abs=1e-12), pytest.approx(expected["w"], abs=1e-12))
    assert built.moved["q"][0] < 1e-12   # started on the constraint the value set defines


def test_a_built_folder_loads_and_keeps_given_values_as_its_file_does(reach_folder):
    assert gpmegen.load(reach_folder, backend="numpy").params == gpmegen.load(REACH, backend="numpy").params
    given = gpmegen.load(reach_folder, backend="numpy", params={"h": 0.3, "k": 800.0})
    assert given.params == gpmegen.load(REACH, backend="numpy", params={"h": 0.3, "k": 800.0}).params
    assert given.params["h"] == 0.3 and given.params["w"] != 0.0


@pytest.mark.parametrize("value, words", [
    ("__builtins__", "double underscore"),
    ("open(1)", "'open' is not a name this value may read here"),
    ("y_Q", "'y_Q' is not a name this value may read here"),
    ("w + y_P", "'w' is not a name this value may read here"),   # another value set: its default
])
def test_a_folders_recorded_set_is_read_by_the_safe_reader(reach_folder, tmp_path, value, words):
    """The folder may come from someone else: its recorded text goes through the model file's
    expression reader, with the manifest's names only, refused in one line."""
    folder = tmp_path / "sprung_reach"
    shutil.copytree(reach_folder, folder)
    record = json.loads((folder / "start.json").read_text())
    assert record["set"]["values"] == [["h", "y_P"], ["w", "x_P - L"]]
    record["set"]["values"][0][1] = value
    (folder / "start.json").write_text(json.dumps(record))
    with pytest.raises(ModelError) as caught:
        gpmegen.statics(folder, backend="numpy")
    message = str(caught.value)
    assert message.startswith(f"{folder / 'start.json'}: initial.set.h: ") and words in message
    assert "gpmegen build" in message and "\n" not in message


@pytest.mark.parametrize("edit, field, words", [
    (lambda r: r["set"]["at"].append(["nosuch", "pi/6"]), "initial.q.nosuch",
     "'nosuch' is no coordinate of the model"),
    (lambda r: r["set"]["values"].append(["nosuch", "1"]), "initial.set.nosuch",
     "'nosuch' is no parameter of the model"),
    (lambda r: r["set"]["values"].__setitem__(0, ["h", 10**400]), "initial.set.h", "(401 characters) is not a finite"),
])
def test_a_folders_recorded_names_are_the_models(reach_folder, tmp_path, edit, field, words):
    """A recorded start that names a coordinate or parameter the model lacks was an internal error
    (tuple.index) or a line without the record; now one line naming the record and the field."""
    folder = tmp_path / "sprung_reach"
    shutil.copytree(reach_folder, folder)
    record = json.loads((folder / "start.json").read_text())
    edit(record)
    (folder / "start.json").write_text(json.dumps(record))
    with pytest.raises(ModelError) as caught:
        gpmegen.statics(folder, backend="numpy")
    message = str(caught.value)
    assert message.startswith(f"{folder / 'start.json'}: {field}: ") and words in message, message
    assert "gpmegen build" in message and "\n" not in message and len(message) < 400


def test_a_folders_recorded_name_given_twice_is_damage(reach_folder, tmp_path):
    folder = tmp_path / "sprung_reach"
    shutil.copytree(reach_folder, folder)
    record = json.loads((folder / "start.json").read_text())
    record["set"]["values"].append(["h", "1"])
    (folder / "start.json").write_text(json.dumps(record))
    with pytest.raises(gpmegen.BuildError, match="start.json"):
        gpmegen.statics(folder, backend="numpy")
