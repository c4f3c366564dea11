"""What commands write, and what they never replace: one of their own inputs (by any name), an
earlier output without --overwrite, a folder gpmegen did not make; an output folder that cannot
be written is named with the cause."""

import os
import shutil
import types
from pathlib import Path

import pytest

from gpmegen import fileio
from gpmegen.cli import main

MODELS = Path(__file__).parent / "models"
TIP_LAW = MODELS / "tip_law.toml"
FAST = ["--t-end", "0.002", "--dt", "2e-4", "--backend", "numpy"]


def _one_line_error(capsys, command):
    """The command's error line; the command printed nothing else (no work was started)."""
    err = capsys.readouterr().err
    assert err.count("\n") == 1 and "Traceback" not in err and "gpmegen: " not in err, err
    assert err.startswith(f"gpmegen {command}: error: "), err
    return err.strip()


def _tiny(path: Path, name: str) -> Path:
    """A model file of one joint and a point at ``path``, its model named ``name``."""
    text = (MODELS / "pendulum.toml").read_text(encoding="utf-8").replace('name = "pendulum"', f'name = "{name}"')
    path.parent.mkdir(parents=True, exist_ok=True)
    path.write_text(text, encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def run(env, tmp_path_factory):
    """A short run of the tip-law model: its results file."""
    out = tmp_path_factory.mktemp("run") / "run.npz"
    assert main(["simulate", str(TIP_LAW), *FAST, "--out", str(out)]) == 0
    return out


# ---- a build replaces only a folder gpmegen made ----------------------------------------------

def test_a_build_over_a_users_folder_named_as_the_model_is_refused(env, tmp_path, monkeypatch, capsys):
    """``build tiny/base.toml --out .`` replaced the folder ``tiny/`` (the model's name) whole,
    deleting the model file and everything beside it."""
    monkeypatch.chdir(tmp_path)
    model = _tiny(tmp_path / "tiny" / "base.toml", "tiny")
    (tmp_path / "tiny" / "notes.txt").write_text("mine\n")
    before = {p: p.read_bytes() for p in (tmp_path / "tiny").iterdir()}
    assert main(["build", "tiny/base.toml", "--out", "."]) == 2
    line = _one_line_error(capsys, "build")
    assert "tiny is not a folder gpmegen made" in line and "another --out" in line and "remove tiny yourself" in line
    assert {p: p.read_bytes() for p in (tmp_path / "tiny").iterdir()} == before
    assert main(["build", str(model), "--out", "built"]) == 0  # elsewhere it builds


def test_a_build_keeps_a_file_of_the_users_in_a_folder_gpmegen_made(env, tmp_path, capsys):
    """A model's folder that gpmegen made and the user added a file to is refused too: a
    rebuild would delete that file."""
    model = _tiny(tmp_path / "tiny.toml", "tiny")
    assert main(["build", str(model), "--out", str(tmp_path)]) == 0
    folder = tmp_path / "tiny"
    (folder / "notes.txt").write_text("mine\n")
    capsys.readouterr()
    assert main(["build", str(model), "--out", str(tmp_path), "--force"]) == 2
    assert "it holds notes.txt" in _one_line_error(capsys, "build")
    assert (folder / "notes.txt").read_text() == "mine\n" and (folder / "manifest.json").is_file()


# ---- no command writes over its inputs, nor over an earlier output without --overwrite ---------

# Each command that writes: its command line in a fresh folder ({model}: a copy of the tip-law
# model there, {run}: a copy of a run of it) and the file there before it, which must be kept.
CASES = {
    "build": (["build", "tiny/base.toml", "--out", "."], "tiny/base.toml"),
    "statics": (["statics", "{model}"], "generated/tip_law_nrfe2/notes.txt"),
    "export-over-its-model": (["export", "{model}", "--format", "urdf", "--out", "{model}", "--overwrite"],
                              "{model}"),
    "export": (["export", "{model}", "--format", "urdf", "--out", "arm.urdf"], "arm.urdf"),
    "simulate": (["simulate", "{model}", *FAST, "--out", "earlier.npz"], "earlier.npz"),
    "simulate-extrapolate": (["simulate", "--nrfe", "2", "3", "--extrapolate", *FAST, "--out", "limit.npz"],
                             "limit.png"),
    "invert": (["invert", "{model}", "--t1", "0.01", "--out", "earlier.npz"], "earlier.csv"),
    "linearize-over-its-run": (["linearize", "{model}", "--at", "{run}", "--times", "0.001", "--out", "{run}",
                                "--overwrite"], "{run}"),
    "linearize": (["linearize", "{model}", "--out", "lin.mat"], "lin.mat"),
    "plot": (["plot", "{run}", "--out", "figures"], "figures/joint_coordinates.png"),
    "animate": (["animate", "{run}", "--out", "arm.gif"], "arm.gif"),
    "modes": (["modes", "--nrfe", "2", "--out", "figures"], "figures/modes_nrfe2_joints.csv"),
    "convergence": (["convergence", "--nrfe", "2", "3", "--out", "figures"], "figures/convergence.png"),
    "sweep": (["sweep", "{model}", "--param", "L=0.5,0.6", *FAST, "--out", "."], "{model}"),
    "demo": (["demo", "--t-end", "0.01"], "results/run_nrfe1.npz"),
}


@pytest.mark.parametrize("case", CASES)
def test_no_command_writes_over_its_inputs_or_an_earlier_output(env, run, tmp_path, monkeypatch, capsys, case):
    """Before, export and linearize replaced the very file they read (``export base.toml --out
    base.toml``, ``linearize --at r.npz --out r.npz``); build and statics replaced a user's
    folder named as the model; plot, animate, modes, convergence, demo and simulate --extrapolate
    replaced earlier outputs unasked."""
    monkeypatch.chdir(tmp_path)
    monkeypatch.setenv("GPMEGEN_GENERATED", str(tmp_path / "generated"))
    names = {"model": "tip_law.toml", "run": "run.npz"}
    shutil.copy(TIP_LAW, tmp_path / names["model"])
    shutil.copy(run, tmp_path / names["run"])
    argv, kept = CASES[case]
    argv, kept = [a.format(**names) for a in argv], Path(kept.format(**names))
    if not kept.exists():
        if kept.parts[0] == "tiny":
            _tiny(kept, "tiny")
        else:
            kept.parent.mkdir(parents=True, exist_ok=True)
            kept.write_text("earlier\n")
    before = {p: p.read_bytes() for p in tmp_path.rglob("*") if p.is_file()}
    assert main(argv) == 2
    line = _one_line_error(capsys, argv[0])
    assert str(kept) in line or str(kept.parent) in line, line
    assert "--overwrite" in line or "an input of this command" in line or "not a folder gpmegen made" in line
    assert {p: p.read_bytes() if p.is_file() else None for p in before} == before


def test_overwrite_replaces_an_earlier_output_but_never_an_input(env, tmp_path, capsys):
    model = tmp_path / "tip_law.toml"
    shutil.copy(TIP_LAW, model)
    out = tmp_path / "arm.urdf"
    out.write_text("earlier\n")
    assert main(["export", str(model), "--format", "urdf", "--out", str(out), "--overwrite"]) == 0
    assert out.read_text().startswith("<?xml")
    link = tmp_path / "link.urdf"
    link.symlink_to(model)
    hard = tmp_path / "hard.toml"
    os.link(model, hard)
    for other in (link, hard):
        capsys.readouterr()
        assert main(["export", str(model), "--format", "urdf", "--out", str(other), "--overwrite"]) == 2
        assert "an input of this command" in _one_line_error(capsys, "export")
    assert model.read_bytes() == TIP_LAW.read_bytes()


# ---- an output folder that cannot be written ----------------------------------------------------

def test_a_read_only_output_folder_is_named_with_its_cause_not_a_temporary_file(env, tmp_path, monkeypatch, capsys):
    """Writing into a folder that refuses new files was reported by the hidden temporary file's
    name (``…/.arm.urdf.k2j3.tmp Permission denied``)."""
    folder = tmp_path / "read-only"
    folder.mkdir()

    def refused(prefix="", suffix="", dir=None):  # what the OS answers in a read-only folder
        raise PermissionError(13, "Permission denied", f"{dir}/{prefix}k2j3{suffix}")

    monkeypatch.setattr(fileio, "tempfile", types.SimpleNamespace(mkstemp=refused))
    assert main(["export", str(TIP_LAW), "--format", "urdf", "--out", str(folder / "arm.urdf")]) == 2
    line = _one_line_error(capsys, "export")
    assert line == (f"gpmegen export: error: output folder {folder} is not writable (Permission denied); choose "
                    f"another --out, or make it writable")
    assert not any(folder.iterdir())


# ---- one place for models: where build writes, the other commands look -----------------------

def test_outside_the_checkout_simulate_uses_the_folder_build_made(tmp_path, fresh_cache):
    """Outside the source checkout, ``build`` wrote ``./generated/`` while ``simulate`` derived
    the model again into another folder (the checkout's ``generated/`` or the user cache)."""
    import subprocess
    import sys

    from gpmegen.runtime.loader import CHECKOUT

    work = tmp_path / "work"
    work.mkdir()
    shutil.copy(TIP_LAW, work / "arm.toml")
    env = {k: v for k, v in os.environ.items() if k != "GPMEGEN_GENERATED"}
    env.update(GPMEGEN_CACHE=str(fresh_cache), XDG_CACHE_HOME=str(tmp_path / "xdg"))
    checkout_before = sorted(p.name for p in (CHECKOUT / "generated").iterdir()) if CHECKOUT else []

    def gpmegen(*argv):
        done = subprocess.run([sys.executable, "-m", "gpmegen.cli", *argv], cwd=work, env=env, capture_output=True,
                              text=True, timeout=600)
        assert done.returncode == 0, done.stderr
        return done

    built = gpmegen("build", "arm.toml", "--nrfe", "1")
    assert "generated/tip_law_nrfe1: " in built.stdout
    assert (work / "generated" / "tip_law_nrfe1" / "manifest.json").is_file()
    ran = gpmegen("simulate", "arm.toml", "--nrfe", "1", "--t-end", "0.002", "--dt", "2e-4", "--backend", "numpy")
    assert "model folder: generated/tip_law_nrfe1\n" in ran.stderr and "deriving" not in ran.stderr, ran.stderr
    assert not (tmp_path / "xdg" / "gpmegen" / "generated").exists()
    if CHECKOUT:
        assert sorted(p.name for p in (CHECKOUT / "generated").iterdir()) == checkout_before


def test_inside_the_checkout_models_go_to_its_generated_folder_from_any_subfolder(monkeypatch):
    from gpmegen.runtime.loader import CHECKOUT, default_directory

    if CHECKOUT is None:
        pytest.skip("gpmegen runs installed, not from its source checkout")
    monkeypatch.delenv("GPMEGEN_GENERATED")
    monkeypatch.chdir(CHECKOUT)
    assert default_directory() == Path("generated")
    monkeypatch.chdir(CHECKOUT / "tests" / "models")
    assert default_directory() == Path("../../generated")
    monkeypatch.setenv("GPMEGEN_GENERATED", "elsewhere")
    assert default_directory() == Path("elsewhere")
