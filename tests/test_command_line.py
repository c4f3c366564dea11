"""The command line as a user meets it: --version, help pages with a description, examples and the
files written, "did you mean" for typos, integrators named in any case, expressions in --param,
one exit status per kind of ending (2 usage, 1 failure, 130 interrupted) and a summary line that
names how a run ended."""

from __future__ import annotations

import argparse
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from gpmegen.cli import build_parser, main
from gpmegen.help_pages import DESCRIPTIONS
from gpmegen.version import __version__

MODELS = Path(__file__).resolve().parent / "models"


def _exit(argv, capsys):
    """(exit status, stdout, stderr) of ``gpmegen argv`` run in this process."""
    try:
        code = main(argv)
    except SystemExit as exc:
        code = exc.code
    captured = capsys.readouterr()
    return code, captured.out, captured.err


def _commands():
    parser = build_parser()
    return next(a for a in parser._actions if isinstance(a, argparse._SubParsersAction)).choices


def test_version_is_the_packages(capsys):
    from importlib.metadata import version

    code, out, _ = _exit(["--version"], capsys)
    assert code == 0 and out.strip() == f"gpmegen {__version__}"
    assert __version__ == version("gpmegen")  # the installed distribution says the same


@pytest.mark.parametrize("command", sorted(_commands()))
def test_each_help_page_has_a_description_examples_and_the_files_written(command, capsys):
    assert command in DESCRIPTIONS, f"{command}: give it a description, examples and files in gpmegen/help_pages.py"
    code, out, _ = _exit([command, "--help"], capsys)
    assert code == 0
    first_line = DESCRIPTIONS[command].splitlines()[0]
    assert first_line in out  # kept as written (RawDescriptionHelpFormatter)
    examples = out.split("examples:\n", 1)[1].split("\n\n", 1)[0].splitlines()
    assert examples and all(line.startswith(f"  gpmegen {command}") for line in examples)
    assert "files written:\n  " in out
    # every option says what it does
    for action in _commands()[command]._actions:
        assert action.help, f"{command} {action.option_strings or action.dest} has no help text"


@pytest.mark.parametrize("argv, suggestion", [
    (["simulat", "--nrfe", "1"], "did you mean 'simulate'?"),
    (["simulate", "--t-ned", "1"], "did you mean --t-end?"),
    (["plot", "a.npz", "--fromat", "pdf"], "did you mean --format?"),
    (["build", "--froce"], "did you mean --force?"),
    (["simulate", "--method", "dop835"], "did you mean dop853?"),
])
def test_a_typo_gets_did_you_mean_in_one_line_and_exit_2(argv, suggestion, capsys, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    code, out, err = _exit(argv, capsys)
    assert code == 2 and not out
    assert len(err.strip().splitlines()) == 1 and suggestion in err and "error" in err
    assert not list(tmp_path.iterdir())


def test_build_has_no_backend_option_that_does_nothing(capsys):
    code, _, err = _exit(["build", "--backend", "c"], capsys)
    assert code == 2 and "unrecognized arguments: --backend" in err


@pytest.mark.parametrize("text, value", [
    ("tdr0=2*pi", 2 * math.pi),
    ("tdr0 = 2*pi", 2 * math.pi),
    ("d2=1/3", 1 / 3),
    ("A=sqrt(2)/2", math.sqrt(2) / 2),
    ("g=9.81", 9.81),
    ("x=2^3", 8.0),
    ("T=-1.5e-3", -1.5e-3),
])
def test_param_takes_an_expression_as_model_files_do(text, value):
    for command in ("simulate", "statics", "modes"):
        assert build_parser().parse_args([command, "--param", text]).param == [(text.split("=")[0].strip(), value)]


@pytest.mark.parametrize("text, problem", [
    ("tdr0=2*foo", "'foo'"),
    ("tdr0=2*(pi", "does not parse"),
    ("g=nan", "'nan'"),
    ("g=1/0", "not a finite real value"),
    ("g=__import__('os')", "not allowed"),
    ("g", "NAME=VALUE"),
])
def test_a_bad_param_is_one_line_naming_it(text, problem, capsys):
    code, _, err = _exit(["statics", "--nrfe", "1", "--param", text], capsys)
    assert code == 2 and problem in err and len(err.strip().splitlines()) == 1 and "Traceback" not in err


def test_a_param_expression_runs_as_its_value(tmp_path, capsys):
    """The same run with tdr0 = 2*pi and with the number: the same results."""
    import numpy as np

    from gpmegen.analysis.post import results as results_io

    common = ["simulate", "--nrfe", "1", "--backend", "numpy", "--t-end", "0.02", "--dt", "1e-3"]
    for name, value in (("expression", "2*pi"), ("number", repr(2 * math.pi))):
        assert main([*common, "--param", f"tdr0={value}", "--out", str(tmp_path / f"{name}.npz")]) == 0
    a, b = (results_io.load(tmp_path / f"{name}.npz") for name in ("expression", "number"))
    np.testing.assert_array_equal(a["q"], b["q"])
    assert results_io.metadata(a)["params"]["tdr0"] == 2 * math.pi


def test_the_summary_names_a_complete_run_and_a_divergence(tmp_path, capsys):
    common = ["simulate", "--nrfe", "5", "--backend", "numpy", "--t-end", "0.02"]
    code, out, _ = _exit([*common, "--dt", "1e-4", "--out", str(tmp_path / "ok.npz")], capsys)
    assert code == 0 and "complete at t = 0.02 s" in out.splitlines()[0]
    # RK4 at 10 ms is far beyond the flexible arm's stable step: refused, unless the limits are lifted
    code, out, err = _exit([*common, "--dt", "1e-2", "--out", str(tmp_path / "bad.npz")], capsys)
    assert code == 2 and "stable step" in err and not (tmp_path / "bad.npz").exists()
    code, out, err = _exit([*common, "--dt", "1e-2", "--no-limits", "--out", str(tmp_path / "bad.npz")], capsys)
    assert code == 1
    assert "DIVERGED after t = " in out.splitlines()[0] and "complete" not in out
    assert err.strip().splitlines()[-1].startswith("gpmegen simulate: error: diverged")


def test_the_summary_of_a_model_file_shows_every_coordinate(tmp_path, capsys, env):
    from gpmegen.analysis.post import results as results_io

    path = MODELS / "spinning_beam.toml"
    code, out, _ = _exit(["simulate", str(path), "--nrfe", "3", "--backend", "numpy", "--t-end", "0.01", "--dt",
                          "1e-3", "--out", str(tmp_path / "beam.npz")], capsys)
    assert code == 0
    coordinates = [str(c) for c in results_io.load(tmp_path / "beam.npz")["coordinates"]]
    assert len(coordinates) > 3
    state = out.split("state at t = 0.01 s:\n", 1)[1]
    assert [cell.split(" = ")[0].strip() for line in state.splitlines() for cell in line.split("   ") if cell] \
        == list(coordinates)


def _interrupt_when(argv, pattern, tmp_path):
    """Run ``gpmegen argv`` in a child process, send it SIGINT once its stderr shows ``pattern``;
    (exit status, stderr)."""
    env = dict(os.environ, GPMEGEN_CACHE=str(tmp_path / "cache"))
    proc = subprocess.Popen([sys.executable, "-m", "gpmegen.cli", *argv], stdout=subprocess.DEVNULL,
                            stderr=subprocess.PIPE, text=True, env=env, cwd=tmp_path)
    seen = []
    try:
        for line in proc.stderr:
            seen.append(line)
            if pattern in line:
                time.sleep(0.2)
                proc.send_signal(signal.SIGINT)
                break
        seen += proc.stderr.readlines()
        proc.wait(timeout=60)
    finally:
        proc.kill()
    return proc.returncode, "".join(seen)


@pytest.mark.parametrize("argv, pattern", [
    (["build", "--nrfe", "6", "--force", "--out", "built"], "deriving"),
    (["simulate", "--nrfe", "1", "--backend", "numpy", "--dt", "1e-3", "--t-end", "1000", "--out", "run.npz"],
     "start:"),
])
def test_ctrl_c_exits_130_in_build_and_simulate(argv, pattern, tmp_path):
    """Ctrl-C used to exit 1 in simulate (whose partial results are kept) and 130 in build."""
    code, err = _interrupt_when(argv, pattern, tmp_path)
    assert code == 130, err
    assert "Traceback" not in err and "interrupted" in err.strip().splitlines()[-1]


@pytest.mark.parametrize("dt, samples", [(1e-3, 21), (1e-4, 21), (2.5e-3, 9)])
def test_the_default_save_interval_is_1_ms_whatever_the_step(tmp_path, dt, samples):
    """Saving followed --dt (every 100th step), so a run at a longer step saved a handful of
    samples (genalpha at 1e-3 over 2 s: 21); with no --save-every or --save-dt a run saves about
    every 1 ms (every step when the step is longer)."""
    from gpmegen.analysis.post import results as results_io

    out = tmp_path / "run.npz"
    assert main(["simulate", "--nrfe", "1", "--backend", "numpy", "--t-end", "0.02", "--dt", str(dt),
                 "--out", str(out)]) == 0
    assert len(results_io.load(out)["t"]) == samples


@pytest.mark.parametrize("argv", [["simulate", "--save-every", "0"], ["sweep", "--param", "m3=1", "--workers", "0"],
                                  ["sweep", "--param", "m3=1:2", "--samples", "0"], ["modes", "--count", "0"]])
def test_a_count_of_zero_is_refused_without_a_hint_about_the_arm(argv, capsys):
    """Every count said "use 1 for the rigid arm" when given 0; only n_rfe speaks of the arm."""
    code, _, err = _exit(argv, capsys)
    assert code == 2 and "below 1 (give a count of 1 or more)" in err and "rigid" not in err
    code, _, err = _exit(["simulate", "--nrfe", "0"], capsys)
    assert code == 2 and "use 1 for a rigid link" in err


@pytest.mark.parametrize("argv, named", [(["--t1", "inf"], "--t1: inf"), (["--t0", "nan", "--t1", "1"], "--t0: nan"),
                                         (["--t0=-inf", "--t1", "1"], "--t0: -inf")])
def test_invert_refuses_a_time_that_is_not_finite_in_one_line(argv, named, capsys):
    """``invert --t1 inf`` went on to the inversion with an infinite window."""
    models = Path(__file__).parent / "models"
    with pytest.raises(SystemExit) as info:
        main(["invert", str(models / "flexible_link.toml"), "--nrfe", "2", *argv])
    assert info.value.code == 2
    [line] = capsys.readouterr().err.strip().splitlines()
    assert f"argument {named} is not a finite time; give it in seconds" in line


def test_ctrl_c_during_an_extension_modules_import_exits_130(monkeypatch, capsys):
    # a command imports what it runs when it runs; Ctrl-C while an extension module initializes
    # reaches the command as an ImportError raised from the KeyboardInterrupt (pybind11's
    # "initialization failed"): an interrupt, not a defect
    import gpmegen.cli as cli
    from gpmegen.cli import parser

    def interrupted_import(args):
        try:
            raise KeyboardInterrupt
        except KeyboardInterrupt as exc:
            raise ImportError("initialization failed") from exc

    monkeypatch.setattr(parser, "cmd_simulate", interrupted_import)  # the function the parser names
    assert cli.main(["simulate", "--nrfe", "1"]) == 130
    err = capsys.readouterr().err.strip().splitlines()
    assert err == ["gpmegen simulate: interrupted"]
