"""Code generation: committed snapshots, determinism, build command and its errors."""

import os
import subprocess
import sys
from pathlib import Path

import pytest

from gpmegen.cli import main
from gpmegen.codegen import render
from gpmegen.model import reference_model

ROOT = Path(__file__).resolve().parents[1]


@pytest.mark.parametrize("nrfe", [1, 5])
def test_snapshot_matches_committed_generated_code(nrfe):
    files = render(reference_model(nrfe), ("numpy", "c"), command=f"gpmegen build --nrfe {nrfe}")
    folder = ROOT / "generated" / f"manipulator_nrfe{nrfe}"
    for name, text in files.items():
        committed = (folder / name).read_text()
        assert committed == text, (
            f"generated/{folder.name}/{name} differs from a fresh build: review the change and "
            f"run 'make snapshots' to update the snapshot"
        )


def _digest_under_seed(seed):
    code = (
        "import hashlib; from gpmegen.codegen import render; from gpmegen.model import reference_model;"
        "f = render(reference_model(3), ('numpy', 'c'));"
        "print(hashlib.sha256(''.join(f[k] for k in sorted(f)).encode()).hexdigest())"
    )
    env = dict(os.environ, PYTHONHASHSEED=str(seed))
    return subprocess.run([sys.executable, "-c", code], env=env, capture_output=True, text=True, check=True).stdout


def test_generation_is_deterministic_whatever_the_hash_seed():
    digests = {_digest_under_seed(seed) for seed in (0, 1, 12345)}
    assert len(digests) == 1


def test_build_writes_and_skips_unchanged(tmp_path, capsys):
    assert main(["build", "--nrfe", "2", "--out", str(tmp_path)]) == 0
    first = capsys.readouterr().out
    assert "n_dof = 6" in first and "built in" in first
    folder = tmp_path / "manipulator_nrfe2"
    stamp = (folder / "model_numpy.py").stat().st_mtime_ns
    assert main(["build", "--nrfe", "2", "--out", str(tmp_path)]) == 0
    assert "skipped" in capsys.readouterr().out
    assert (folder / "model_numpy.py").stat().st_mtime_ns == stamp
    assert main(["build", "--nrfe", "2", "--out", str(tmp_path), "--force"]) == 0
    assert "built in" in capsys.readouterr().out
    # no temporary or replaced folders left behind (the lock file stays, empty)
    assert sorted(p.name for p in tmp_path.iterdir() if not p.name.endswith(".lock")) == ["manipulator_nrfe2"]


@pytest.mark.parametrize("args, message", [
    (["--nrfe", "0"], "below 1"),
    (["--nrfe", "-3"], "below 1"),
    (["--nrfe", "2.5"], "not a whole number"),
    (["--nrfe", "five"], "not a whole number"),
    (["--colour", "red"], "unrecognized arguments"),
])
def test_build_bad_input_exits_2_and_writes_nothing(tmp_path, capsys, args, message):
    out = tmp_path / "out"
    with pytest.raises(SystemExit) as exc:
        main(["build", *args, "--out", str(out)])
    assert exc.value.code == 2
    err = capsys.readouterr().err
    assert message in err and "Traceback" not in err
    assert not out.exists()


def test_build_unwritable_output_exits_2(tmp_path, capsys):
    blocker = tmp_path / "a_file"
    blocker.write_text("x")
    assert main(["build", "--nrfe", "1", "--out", str(blocker / "sub")]) == 2
    err = capsys.readouterr().err
    assert "is a file, not a folder" in err and err.count("\n") == 1
    assert blocker.read_text() == "x"


def test_generated_module_header_records_model_and_hash():
    text = (ROOT / "generated" / "manipulator_nrfe5" / "model_numpy.py").read_text()
    assert "Input hash:" in text and "0: theta1" in text and "14: x3" in text and "E2 = 70000000000.0 Pa" in text
    assert "Regenerate with: gpmegen build --nrfe 5" in text
