"""Malformed command lines never show a traceback: usage errors exit 2, failures 1."""

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from gpmegen.cli import build_parser, main

WORDS = ["build", "simulate", "statics", "plot", "modes", "convergence", "demo", "--nrfe", "--dt", "--t-end",
         "--out", "--param", "--backend", "--method", "--statics", "--save-every", "--force", "--lock", "--format",
         "c", "numpy", "rk4", "locked", "constrained", "0", "-1", "1.5", "nan", "inf", "1e-5", "x=1", "=",
         "tdr0=abc", "--", "-", "--help-me", "", " ", "ü", "5", "results/x.npz"]


@settings(max_examples=300, deadline=None,
          suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow])
@given(st.lists(st.one_of(st.sampled_from(WORDS), st.text(max_size=8)), max_size=6))
def test_parser_never_raises_anything_but_exit_2(capsys, argv):
    try:
        build_parser().parse_args(argv)
    except SystemExit as exc:
        assert exc.code in (0, 2)  # 0 only for --help
    err = capsys.readouterr().err
    assert "Traceback" not in err


@pytest.mark.parametrize("argv, code", [
    (["simulate", "--nrfe", "1", "--backend", "numpy", "--t-end", "0.01", "--dt", "1e-3", "--param", "nosuch=1"], 2),
    (["simulate", "--nrfe", "1", "--backend", "numpy", "--t-end", "0.01", "--dt", "1e-3", "--param", "r_Ea=1e6"], 1),
    (["simulate", "--nrfe", "1", "--backend", "numpy", "--t-end", "0.01", "--out", "x.txt"], 2),
    (["plot", "no/such/file.npz"], 2),
    (["statics", "--nrfe", "1", "--param", "g=nan"], 2),
])
def test_runtime_and_value_errors_are_one_line(tmp_path, monkeypatch, capsys, argv, code):
    monkeypatch.chdir(tmp_path)
    try:
        assert main(argv) == code
    except SystemExit as exc:  # refused by the parser (e.g. g=nan: not a finite number)
        assert exc.code == code
    err = capsys.readouterr().err.strip().splitlines()
    assert err and "Traceback" not in "\n".join(err)
    assert err[-1].startswith("gpmegen ") and "error" in err[-1]
