"""Cases: the paper's manipulator and a model file run through the same generic code, which asks
the case (not the model's or coordinates' names) how to start, label and show a run; results
carry that as JSON metadata, and a model file is read once per command."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.figures import plots, run_figures
from gpmegen.analysis.post import results as results_io
from gpmegen.analysis.run import runs
from gpmegen.analysis.run.cases import FileCase
from gpmegen.analysis.run.reference_case import ReferenceCase
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.cli import main
from gpmegen.model import toml_file

EXAMPLE = Path(__file__).resolve().parent.parent / "examples" / "planar_two_link.toml"


def _quiet(message):
    pass


def _run(case, tmp_path, start):
    out = tmp_path / f"{case.results_stem}.npz"
    # the planar example's highest natural frequency (2 kHz) makes RK4 stable below 2.3e-4 s
    return runs.run(case, RunSpec(start=start, t_end=0.01, dt=2e-4, save_every=25, method="rk4"), "numpy", {}, out,
                    _quiet).results


@pytest.fixture
def parses(monkeypatch):
    """How often a model file is parsed."""
    calls = []
    parse = toml_file._parse

    def counted(*args, **kwargs):
        calls.append(args)
        return parse(*args, **kwargs)

    monkeypatch.setattr(toml_file, "_parse", counted)
    return calls


@pytest.mark.parametrize("command", (["statics"], ["simulate", "--t-end", "0.01", "--dt", "2e-4", "--backend",
                                                   "numpy"]))
def test_a_model_file_is_read_once_per_command(command, tmp_path, parses, capsys):
    argv = [command[0], str(EXAMPLE), *command[1:]]
    if command[0] == "simulate":
        argv += ["--out", str(tmp_path / "run.npz")]
    assert main(argv) == 0, capsys.readouterr().err
    assert len(parses) == 1


# make check-c: two runs, one from the reference arm's locked statics, and a figure (the metadata of
# results: test_trust_results.py)
@pytest.mark.long
def test_results_carry_the_cases_metadata_as_json(tmp_path):
    reference = _run(ReferenceCase(1), tmp_path, "locked")
    mine = _run(FileCase(str(EXAMPLE)), tmp_path, "none")
    meta = results_io.metadata(results_io.load(tmp_path / "run_nrfe1.npz"))
    assert meta["model"] == "manipulator_nrfe1" and meta["backend"] == "numpy" and meta["start"] == "locked"
    assert meta["coordinates"] == ["theta1", "psi2", "x3"] and meta["constraint_names"] == ["circle", "height"]
    assert meta["settings"]["dt"] == 2e-4 and meta["params"]["A"] == 0.5
    assert meta["constraint_units"] == {"circle": "m²", "height": "m"}
    # the prescribed height of E (eq. 18) holds along the run
    np.testing.assert_allclose(reference["end_effector"][:, 1], reference["prescribed"], atol=1e-9)

    name = gpmegen.read_model_file(EXAMPLE).model.name
    assert plots.label(reference) == "rigid arm"
    assert plots.label(mine) == f"{name} (no statics)"
    assert plots.joint_names(reference) == ["theta1", "psi2", "x3"]
    # titles name the model; the paper's figure numbers only where every run is the paper's case
    assert plots._title([reference], "Path") == "Path: manipulator"
    assert plots._caption([reference], "path") == "Corresponds to paper Fig. 4."
    assert plots._caption([mine], "path") is None
    assert {p.name for p in run_figures.plot_all([mine], tmp_path / "figures")} >= {"path.png"}


def test_a_model_of_your_own_is_labelled_by_its_name_whatever_it_is_called(tmp_path):
    """A file's model named like the reference case's is still labelled by its name, with no
    paper figure numbers or constraint units; its joints are drawn whatever they are called,
    even like an sde rotation."""
    text = EXAMPLE.read_text(encoding="utf-8").replace('name = "planar_two_link_nrfe{nrfe}"',
                                                      'name = "manipulator_nrfe{nrfe}"')
    text = text.replace("theta2", "psi_elbow_2")
    path = tmp_path / "lookalike.toml"
    path.write_text(text, encoding="utf-8")
    mine = _run(FileCase(str(path), 3), tmp_path, "none")
    meta = results_io.metadata(mine)
    assert meta["model"] == "manipulator_nrfe3"
    assert plots.label(mine) == "manipulator_nrfe3 (no statics)"
    assert plots.joint_names(mine) == ["theta1", "psi_elbow_2"]
    assert "constraint_units" not in meta and "figures" not in meta


def test_a_results_file_of_the_older_format_is_refused_in_one_line(tmp_path, capsys):
    _run(ReferenceCase(1), tmp_path, "locked")
    path = tmp_path / "run_nrfe1.npz"
    with np.load(path) as f:
        data = {k: f[k] for k in f.files}
    old = tmp_path / "old.npz"
    np.savez(old, **dict(data, format=np.array("gpmegen-results-1")))
    assert main(["plot", str(old), "--out", str(tmp_path / "figures")]) == 2
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "older gpmegen" in err and "gpmegen simulate" in err


def test_the_reference_case_refuses_a_model_files_start(capsys):
    assert main(["statics", "--nrfe", "1", "--statics", "none"]) == 2
    assert "--statics none is for model files" in capsys.readouterr().err
