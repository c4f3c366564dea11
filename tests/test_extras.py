"""A missing optional package is said in one line naming the extra of gpmegen that installs it
(:mod:`gpmegen.extras`), by the command line with exit status 2, never as an internal error."""

import sys
import tomllib
from pathlib import Path

import pytest

from gpmegen.cli import main
from gpmegen.extras import EXTRAS, install_command

ROOT = Path(__file__).resolve().parents[1]
PLANAR = ROOT / "examples" / "planar_two_link.toml"


def test_each_optional_package_is_in_the_extra_its_message_names():
    extras = tomllib.loads((ROOT / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    for package, (_, extra) in EXTRAS.items():
        assert any(package in requirement for requirement in extras[extra]), (package, extra)


# The commands that need each optional package (python-control's, LinearModel.state_space, has no
# command: tests/test_state_space.py hides it from the Python call), their outputs kept in tmp.
COMMANDS = {
    "casadi": lambda tmp: ["export", str(PLANAR), "--format", "casadi", "--out", str(tmp / "out")],
    "distributed": lambda tmp: ["sweep", str(PLANAR), "--nrfe", "1", "--param", "xa=0.57", "--t-end", "0.01",
                                "--out", str(tmp / "out"), "--scheduler", "tcp://127.0.0.1:9"],
}


@pytest.mark.parametrize("package", sorted(COMMANDS))
def test_a_command_without_its_optional_package_says_which_extra_in_one_line(package, tmp_path, monkeypatch,
                                                                               capsys):
    monkeypatch.setitem(sys.modules, package, None)  # its import raises ImportError, as when not installed
    assert main(COMMANDS[package](tmp_path)) == 2
    err = capsys.readouterr().err.strip()
    assert "\n" not in err and "internal error" not in err, err
    assert err.endswith(f"which is not installed: {install_command(EXTRAS[package][1])}"), err
    assert not (tmp_path / "out").exists()  # refused before anything is made


def test_every_optional_package_has_a_command_or_a_test_that_hides_it():
    assert set(EXTRAS) == set(COMMANDS) | {"control"}
