"""How a model's runs are shown is the model's data (a model file's ``[presentation]``, the
reference arm's :func:`gpmegen.model.reference.presentation`): the reference case labels its
runs as the paper does from it, its model file gives the same labels, a user's file labels its
own figures so, each entry is checked in one line, and a built folder is taken for the reference
arm by its input hash, never by its name."""

from __future__ import annotations

import json
from pathlib import Path
from types import SimpleNamespace

import numpy as np
import pytest
import sympy as sp

from gpmegen.analysis.figures import plots
from gpmegen.analysis.post import results as results_io
from gpmegen.analysis.run import runs
from gpmegen.analysis.run.cases import FileCase, FolderCase
from gpmegen.analysis.run.model_files import read_model_file
from gpmegen.analysis.run.opening import case_of_path
from gpmegen.analysis.run.reference_case import ReferenceCase
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.codegen.render import input_hash
from gpmegen.errors import ModelError
from gpmegen.model.chain import TIME
from gpmegen.model.names import point_symbols
from gpmegen.model.size import coordinate_count
from gpmegen.runtime.loader import BACKENDS

ROOT = Path(__file__).resolve().parents[1]
MANIPULATOR = ROOT / "examples" / "manipulator.toml"
TIP_LAW = ROOT / "tests" / "models" / "tip_law.toml"

# The paper's labels (reference-model.md, its Figs. 2-4), as the reference case gave them when it
# wrote them itself.
PAPER = {
    "joints": ["theta1", "psi2", "x3"],
    "joint_labels": {"theta1": "θ1 [rad]", "psi2": "ψ2 [rad]", "x3": "x3 [m]"},
    "constraint_units": {"circle": "m²", "height": "m"},
    "figures": {"joint_coordinates": "paper Fig. 2", "end_effector": "paper Fig. 3", "path": "paper Fig. 4"},
    "prescribed": {"axis": 1, "label": "prescribed y_E,a"},
}
RIGID = {"label": "rigid arm", "start_tag": r"$E'_r$", "colour": "C0", "tag_offset": (-22, 8)}
FLEXIBLE = {"label": "flexible arm, n_rfe = 5", "start_tag": r"$E'_f$", "colour": "C2", "tag_offset": (8, -14)}


def _loaded(name, params=None):
    """What a case's metadata and extras read of a loaded model: its module's name, its values."""
    return SimpleNamespace(module=SimpleNamespace(MODEL=name), params=params or {})


@pytest.mark.parametrize(("nrfe", "own"), ((1, RIGID), (5, FLEXIBLE)))
def test_the_reference_case_labels_its_runs_as_the_paper_does(nrfe, own):
    assert ReferenceCase(nrfe).metadata(_loaded(f"manipulator_nrfe{nrfe}")) == {**PAPER, **own}


@pytest.mark.parametrize("nrfe", (1, 3))
def test_the_reference_arms_model_file_labels_its_runs_as_the_built_in_arm(nrfe):
    """examples/manipulator.toml declares the same presentation; its [presentation.rigid] only
    where it is read with nrfe = 1."""
    loaded = _loaded(f"manipulator_nrfe{nrfe}")
    assert FileCase(str(MANIPULATOR), nrfe).metadata(loaded) == ReferenceCase(nrfe).metadata(loaded)
    assert read_model_file(MANIPULATOR, nrfe=nrfe).model.presentation == ReferenceCase(nrfe).model.presentation


@pytest.mark.parametrize("case", (ReferenceCase(2), FileCase(str(MANIPULATOR), 2)), ids=("built-in", "file"))
def test_the_prescribed_height_is_the_one_the_height_constraint_holds_e_at(case):
    """At the run's parameter values (y_c as the start sets it, not its default), the saved
    prescribed height is eq. 18, y_c + A cos(2 pi t / T), and the height constraint is zero with
    y_E there."""
    model = case.model
    params = {p.name: float(p.default) for p in model.parameters} | {"y_c": 1.2345, "A": 0.3, "T": 1.7}
    t = np.linspace(0.0, 3.0, 31)
    prescribed = case.extras(_loaded(model.name, params), {"t": t})["prescribed"]
    np.testing.assert_allclose(prescribed, 1.2345 + 0.3 * np.cos(2 * np.pi * t / 1.7), rtol=1e-14)
    (height,) = [c for c in model.constraints if c.name == "height"]
    _, y, _ = point_symbols("E")
    assert sp.simplify(height.expression.subs(y, model.presentation.prescribed.value)) == 0
    assert model.presentation.prescribed.value.free_symbols <= {p.symbol for p in model.parameters} | {TIME}


PRESENTED = """
[presentation]
label = "tip on a ramp, {nrfe} rfes"
coordinates = { theta1 = "θ [rad]" }
constraint_units = { tip_law = "m" }
figures = { path = "Fig. 7 of the lab notes" }
start_tag = "$T_0$"
colour = "C4"
prescribed = { axis = "y", label = "programmed y_tip", value = "v0*t" }

[presentation.rigid]
label = "rigid link"
"""


def _presented(tmp_path, extra=PRESENTED) -> Path:
    text = TIP_LAW.read_text(encoding="utf-8") + extra
    path = tmp_path / "presented.toml"
    path.write_text(text, encoding="utf-8")
    return path


def test_a_model_files_presentation_labels_its_runs_figures(tmp_path):
    """A short run of a user's file: its metadata carries the file's labels, the figures read
    them, and the saved prescribed coordinate is the tip's y, which the constraint holds there."""
    case = FileCase(str(_presented(tmp_path)))
    res = runs.run(case, RunSpec(start="none", t_end=0.004, dt=2e-4, save_every=5, method="rk4"), "numpy", {},
                   tmp_path / "run.npz", lambda message: None).results
    meta = results_io.metadata(res)
    assert meta["label"] == "tip on a ramp, 2 rfes" and meta["joints"] == ["theta1"]
    assert meta["joint_labels"] == {"theta1": "θ [rad]"} and meta["constraint_units"] == {"tip_law": "m"}
    assert meta["colour"] == "C4" and meta["prescribed"] == {"axis": 1, "label": "programmed y_tip"}
    assert meta["lambda_units"] == {"tip_law": "N"}
    assert plots.label(res) == "tip on a ramp, 2 rfes (no statics)"
    assert plots._caption([res], "path") == "Corresponds to Fig. 7 of the lab notes."
    assert plots._caption([res], "end_effector") is None
    assert plots.styles([res])[0]["color"] == "C4"
    np.testing.assert_allclose(res["prescribed"], 0.2 * res["t"], rtol=1e-15)   # v0 t, v0 = 0.2 m/s
    np.testing.assert_allclose(res["end_effector"][:, 1], res["prescribed"], atol=1e-8)


def test_the_rigid_table_replaces_the_labels_only_where_the_file_is_read_with_one_rfe(tmp_path):
    path = _presented(tmp_path)
    assert read_model_file(path, nrfe=1).model.presentation.label == "rigid link"
    rigid, flexible = (read_model_file(path, nrfe=n).model.presentation for n in (1, 3))
    assert flexible.label == "tip on a ramp, 3 rfes"
    assert rigid.colour == flexible.colour == "C4" and rigid.start_tag == flexible.start_tag == "$T_0$"


def test_the_presentation_is_not_in_the_input_hash(tmp_path):
    """Labels are for figures: a file with and without them generates the same code."""
    bare, presented = TIP_LAW, _presented(tmp_path)
    assert (input_hash(read_model_file(bare).model, BACKENDS)
            == input_hash(read_model_file(presented).model, BACKENDS))


@pytest.mark.parametrize(("table", "line", "message"), (
    ('[presentation]\nlabels = "x"\n', 2, "unknown key 'labels'; did you mean 'label'?"),
    ('[presentation]\nlabel = 3\n', 2, "label: expected a string, got a number"),
    ('[presentation]\ncoordinates = { theta9 = "θ" }\n', 2, "'theta9' is not a coordinate of the model; name one of "
                                                           "theta1"),
    ('[presentation]\nconstraint_units = { circle = "m" }\n', 2, "'circle' is not a constraint of the model"),
    ('[presentation]\nfigures = { fig2 = "x" }\n', 2, "'fig2' is not a figure of the model; name one of "
                                                     "joint_coordinates, end_effector, path"),
    ('[presentation]\ncolour = "red"\n', 2, "unknown colour 'red'; use one of the plot cycle's colours"),
    ('[presentation]\ntag_offset = [8]\n', 2, "expected 2 entries, got 1"),
    ('[presentation]\ntag_offset = [8, "up"]\n', 2, "expected a number of points from -200 to 200, got 'up'"),
    ('[presentation]\nstart_tag = "a\\nb"\n', 2, "the text holds a line break or control character"),
    ('[presentation]\nfigures = { path = "%s" }\n' % ("x" * 81), 2,
     "the text has 81 characters, more than a figure's 80"),
    ('[presentation]\nprescribed = { axis = "w", label = "x", value = "0" }\n', 2, "unknown axis 'w'"),
    ('[presentation]\nprescribed = { axis = "y", label = "x" }\n', 2, "missing required key 'value'"),
    ('[presentation]\nprescribed = { axis = "y", label = "x", value = "theta1" }\n', 2,
     "coordinate 'theta1' may appear only in drives and constraints"),
    ('[presentation.rigid]\ncoordinates = { theta1 = "θ" }\n', 2, "unknown key 'coordinates'"),
))
def test_a_wrong_entry_is_refused_in_one_line_at_its_line(tmp_path, table, line, message):
    path = _presented(tmp_path, "\n" + table)
    at = len(TIP_LAW.read_text(encoding="utf-8").splitlines()) + 1 + line   # after a blank line
    with pytest.raises(ModelError) as caught:
        read_model_file(path)
    text = str(caught.value)
    assert "\n" not in text and text.startswith(f"{path}:{at}: ") and message in text, text


def test_a_label_with_nrfe_needs_an_nrfe(tmp_path):
    path = tmp_path / "cart.toml"
    path.write_text((ROOT / "tests" / "models" / "cart.toml").read_text(encoding="utf-8")
                    + '\n[presentation]\nlabel = "cart, {nrfe} rfes"\n', encoding="utf-8")
    with pytest.raises(ModelError, match="label: the label uses {nrfe} but no nrfe is set"):
        read_model_file(path)


def _manifest(model) -> dict:
    """What of a built folder's manifest.json the reference case is recognized by."""
    return {"model": model.name, "n_dof": coordinate_count(model), "input_hash": input_hash(model, BACKENDS)}


@pytest.mark.parametrize("nrfe", (1, 2, 5))
def test_a_folder_of_the_reference_arm_is_the_reference_case(nrfe):
    case = ReferenceCase.of_manifest(_manifest(ReferenceCase(nrfe).model))
    assert isinstance(case, ReferenceCase) and case.nrfe == nrfe


def test_a_model_of_another_named_like_the_reference_arm_is_not_taken_for_it(tmp_path):
    """Named manipulator_nrfe3, with the reference's coordinates: one default changed is another
    model. Neither the name nor a manifest that is not one gpmegen writes makes a reference case."""
    text = MANIPULATOR.read_text(encoding="utf-8").replace('m3 = { value = 2.0,', 'm3 = { value = 2.5,')
    path = tmp_path / "mine.toml"
    path.write_text(text, encoding="utf-8")
    mine = read_model_file(path, nrfe=3).model
    assert mine.name == "manipulator_nrfe3" and coordinate_count(mine) == coordinate_count(ReferenceCase(3).model)
    assert ReferenceCase.of_manifest(_manifest(mine)) is None
    reference = _manifest(ReferenceCase(3).model)
    for broken in ({**reference, "n_dof": "9"}, {**reference, "n_dof": 10}, {**reference, "n_dof": 1},
                   {key: value for key, value in reference.items() if key != "n_dof"}):
        assert ReferenceCase.of_manifest(broken) is None


def test_the_built_reference_folder_opens_as_the_reference_case(generated_elsewhere, tmp_path):
    """A folder of the reference arm runs as the reference case, a lookalike's as a folder."""
    case = case_of_path(generated_elsewhere / "manipulator_nrfe1")
    assert isinstance(case, ReferenceCase) and case.nrfe == 1
    folder = tmp_path / "manipulator_nrfe3"
    folder.mkdir()
    manifest = _manifest(read_model_file(MANIPULATOR.parent / "manipulator.toml", nrfe=3).model)
    (folder / "manifest.json").write_text(json.dumps({**manifest, "input_hash": "0" * 16}))
    assert isinstance(case_of_path(folder), FolderCase)


def test_a_folder_built_from_the_reference_arms_file_runs_the_files_start(generated_elsewhere, tmp_path, capsys):
    """The file's model has the reference arm's hash (the hash leaves [initial] out), but its
    folder records the file's start, which a run from it keeps: ψ2 = π/3 and x3 = 0.1 here, where
    the paper's scenario would start from its locked statics at ψ2 = π/4. Building the reference
    arm into the same folder makes it the reference case again."""
    from gpmegen import cli

    text = MANIPULATOR.read_text(encoding="utf-8")
    start = 'q = { theta1 = 0, psi2 = "pi/4", x3 = 0 }'
    assert text.count(start) == 1
    path = tmp_path / "moved.toml"
    path.write_text(text.replace(start, 'q = { theta1 = 0, psi2 = "pi/3", x3 = 0.1 }'), encoding="utf-8")
    out = tmp_path / "built"
    assert cli.main(["build", str(path), "--nrfe", "1", "--out", str(out)]) == 0
    case = case_of_path(out / "manipulator_nrfe1")
    assert isinstance(case, FolderCase)
    begun = case.started("numpy", case.starts[0], {}, lambda line: None)
    q = dict(zip(begun.model.coordinates, begun.q))
    assert q["psi2"] == pytest.approx(np.pi / 3, abs=1e-12) and q["x3"] == pytest.approx(0.1, abs=1e-12)
    assert cli.main(["build", "--nrfe", "1", "--out", str(out)]) == 0
    assert isinstance(case_of_path(out / "manipulator_nrfe1"), ReferenceCase)
    capsys.readouterr()
