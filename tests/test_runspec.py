"""A run's specification (gpmegen.analysis.run.runspec.RunSpec): its rules, each in one line; its
defaults; equal specs for equal runs, whether the command line or the API builds them."""

import pickle

import pytest

import gpmegen
from gpmegen.analysis.run import runs
from gpmegen.analysis.run.runspec import METHODS, NAMES, RunSpec
from gpmegen.analysis.sweep import SweepError
from gpmegen.cli import main
from gpmegen.errors import RunSpecError
from gpmegen.runtime import integrators


@pytest.mark.parametrize("given, message", [
    (dict(method="rk5"), "'rk5' is not an integrator (choose from rk4, genalpha, dop853, radau, scipy-radau)"),
    (dict(t_end=-1.0), "t_end -1 is below zero or not finite; give the end time in seconds"),
    (dict(t_end=float("inf")), "t_end inf is below zero or not finite; give the end time in seconds"),
    (dict(dt=0.0), "dt 0 must be a positive finite number"),
    (dict(dt="1e-3"), "dt '1e-3' is not a number; give it as a float"),
    (dict(save_dt=-1e-3), "save_dt -0.001 must be a positive finite number"),
    (dict(rtol=0.0), "rtol 0 must be a positive finite number"),
    (dict(atol=float("nan")), "atol nan must be a positive finite number"),
    (dict(rho_inf=1.5), "rho_inf 1.5 must be a number from 0 to 1"),
    (dict(max_violation=-1.0), "max_violation -1 must be a positive finite number"),
    (dict(save_every=0), "save_every 0: give a count of 1 or more"),
    (dict(save_every=2.5), "save_every 2.5: give a count of 1 or more"),
    (dict(save_every=True), "save_every True: give a count of 1 or more"),
    (dict(start=3), "start 3: give one of locked, constrained, none, or None for the case's own"),
    (dict(repartition="yes"), "repartition 'yes': give True or False"),
    (dict(internal_dynamics=1), "internal_dynamics 1: give True or False"),
    (dict(actuated=["psi2", ""]), "actuated ['psi2', '']: give coordinate names, () for an ideal realization or "
                                  "None for the case's own"),
    (dict(dt=1e-3, save_dt=1.5e-3), "--save-dt 0.0015 s is not a whole number of RK4 steps --dt 0.001 s; make it a "
                                    "multiple of --dt, or use --save-every"),
])
def test_each_rule_refuses_in_one_line(given, message):
    with pytest.raises(RunSpecError) as refused:
        RunSpec(**given)
    assert str(refused.value) == message
    assert isinstance(refused.value, ValueError)


def test_defaults_are_set_once_and_by_method():
    spec = RunSpec(dt=2.5e-4)
    assert spec.save_every == integrators.loop.default_save_every(2.5e-4) == 4  # the steps in 1 ms
    assert (spec.rtol, spec.atol, spec.rho_inf) == (integrators.base.RTOL, integrators.base.ATOL,
                                                    integrators.genalpha.RHO_INF)
    assert spec.save_dt is None and spec.save_interval == pytest.approx(1e-3)
    # rk4 saves every whole number of steps: save_dt sets save_every, whatever was given
    assert RunSpec(dt=1e-4, save_dt=5e-4, save_every=7).save_every == 5
    # the other methods take save_dt as it is and keep save_every
    other = RunSpec(method="dop853", dt=1e-4, save_dt=5e-4, save_every=7)
    assert (other.save_every, other.save_interval) == (7, 5e-4)
    assert RunSpec(method="dop853").adaptive and not RunSpec(method="genalpha").adaptive
    assert RunSpec(actuated="x3").actuated == ("x3",) and RunSpec(actuated=["psi2", "x3"]).actuated == ("psi2", "x3")


def test_equal_runs_give_equal_specs():
    default = RunSpec(dt=1e-4)
    spelled = RunSpec(t_end=10, dt=1e-4, save_every=10, rtol=integrators.base.RTOL, method="rk4")
    assert default == spelled and hash(default) == hash(spelled)
    assert RunSpec(dt=1e-4, save_dt=1e-3) == RunSpec(dt=1e-4, save_every=10, save_dt=1e-3)
    assert RunSpec(dt=1e-4) != RunSpec(dt=1e-4, save_every=20)
    assert RunSpec(dt=1e-4) != RunSpec(dt=1e-4, start="locked")
    assert pickle.loads(pickle.dumps(spelled)) == spelled  # as a pool's processes receive it
    with pytest.raises(AttributeError):
        default.dt = 1e-3  # frozen


def test_of_changes_fields_and_makes_the_defaults_anew():
    spec = RunSpec.of(dt=1e-4)
    assert RunSpec.of(spec, dt=1e-3).save_every == integrators.loop.default_save_every(1e-3)  # not the 10 of dt 1e-4
    kept = RunSpec.of(RunSpec(dt=1e-4, save_every=3), dt=1e-3)
    assert kept.save_every == 3  # given, so kept
    assert RunSpec.of(spec, method="dop853", rtol=1e-6).rtol == 1e-6
    assert spec.with_start("none") == RunSpec(dt=1e-4, start="none")


def test_an_unknown_option_is_refused_in_one_line():
    with pytest.raises(TypeError) as refused:
        RunSpec.of(dtt=1e-3)
    assert str(refused.value) == f"unknown run option 'dtt'; the options of a run are {', '.join(NAMES)}"
    with pytest.raises(TypeError) as refused:
        gpmegen.simulate(nrfe=1, backend="numpy", t_end=0.01, step=1e-3)
    message = str(refused.value)
    assert "\n" not in message and message.startswith("simulate() got an unknown option 'step'; its options are ")
    assert "dt" in message.split("; its options are ")[1].split(", ") and "nrfe" in message
    with pytest.raises(TypeError, match=r"^load\(\) got an unknown option 'backned'; its options are directory, "):
        gpmegen.load("manipulator", nrfe=1, backned="numpy")
    with pytest.raises(TypeError, match=r"^linearize\(\) got an unknown option 'time'; its options are .*times"):
        gpmegen.linearize(nrfe=1, backend="numpy", time=[0.1])


class _Caught(Exception):
    """Raised in place of the run, with the spec it was given."""


@pytest.fixture
def caught(monkeypatch):
    specs = []

    def instead(case, spec, backend, overrides, out, progress):
        specs.append((spec, backend, overrides))
        raise _Caught

    monkeypatch.setattr(runs, "run", instead)
    return specs


def test_the_command_line_and_the_api_build_equal_specs(caught, tmp_path, capsys):
    code = main(["simulate", "--nrfe", "1", "--backend", "numpy", "--t-end", "0.02", "--dt", "1e-4", "--save-dt",
                 "1e-3", "--rho-inf", "0.5", "--repartition", "--actuated", "psi2", "x3", "--param", "tdr0=2",
                 "--out", str(tmp_path / "run.npz")])
    assert code == 1 and "_Caught" in capsys.readouterr().err  # stopped where the run would start
    with pytest.raises(_Caught):
        gpmegen.simulate(nrfe=1, backend="numpy", t_end=0.02, dt=1e-4, save_dt=1e-3, rho_inf=0.5, repartition=True,
                         actuated=["psi2", "x3"], params={"tdr0": 2.0})
    (cli, *_), (api, *_) = caught
    assert cli == api and cli.start == "locked" and cli.save_every == 10 and cli.actuated == ("psi2", "x3")
    assert caught[0][1:] == caught[1][1:] == ("numpy", {"tdr0": 2.0})
    # a spec given whole, with a field changed by a keyword
    with pytest.raises(_Caught):
        gpmegen.simulate(nrfe=1, spec=RunSpec(t_end=0.02, dt=1e-4, rho_inf=0.5), backend="numpy", save_dt=1e-3,
                         repartition=True, actuated=("psi2", "x3"), params={"tdr0": 2.0})
    assert caught[2][0] == cli
    # the defaults: equal whichever builds them
    main(["simulate", "--nrfe", "1", "--backend", "numpy", "--out", str(tmp_path / "default.npz")])
    with pytest.raises(_Caught):
        gpmegen.simulate(nrfe=1, backend="numpy")
    assert caught[3][0] == caught[4][0] == RunSpec(start="locked")


def test_the_command_line_says_a_bad_spec_in_one_line(tmp_path, capsys):
    code = main(["simulate", "--nrfe", "1", "--backend", "numpy", "--dt", "1e-3", "--save-dt", "1.5e-3",
                 "--out", str(tmp_path / "run.npz")])
    err = capsys.readouterr().err
    assert code == 2
    assert err == ("gpmegen simulate: error: --save-dt 0.0015 s is not a whole number of RK4 steps --dt 0.001 s; make "
                   "it a multiple of --dt, or use --save-every\n")


def test_a_sweep_refuses_what_its_runs_do_not_take(tmp_path):
    with pytest.raises(SweepError) as refused:
        gpmegen.sweep(tmp_path / "s", {"tdr0": [1.0, 2.0]}, t_end=0.01, dt=1e-4, save_dt=1e-3, rtol=1e-6)
    assert str(refused.value) == ("save_dt, rtol: not taken by a sweep's runs, which take t_end, dt, save_every, "
                                  "method, start, repartition; leave them out")
    with pytest.raises(TypeError, match="^unknown sweep option 'sample'; a sweep's options are t_end, "):
        gpmegen.sweep(tmp_path / "s", {"tdr0": (1.0, 2.0)}, sample=3)
    assert not (tmp_path / "s").exists()


def test_every_method_has_a_name_the_command_line_takes():
    from gpmegen.cli import method_name

    assert tuple(method_name(m.upper()) for m in METHODS) == METHODS


def test_runs_at_several_nrfe_take_the_one_spec_of_their_options(caught, tmp_path, capsys):
    """The levels' runs take --repartition as a single run does; what they cannot take (an
    actuated realization, its internal dynamics) is refused before any run."""
    main(["simulate", "--nrfe", "2", "3", "--extrapolate", "--repartition", "--backend", "numpy", "--workers", "1",
          "--t-end", "0.01", "--dt", "1e-4", "--out", str(tmp_path / "levels.npz")])
    (spec, backend, overrides), = caught
    assert spec == RunSpec(t_end=0.01, dt=1e-4, start="locked", repartition=True) and backend == "numpy"
    capsys.readouterr()
    for option in (["--actuated", "psi2", "x3"], ["--internal-dynamics"]):
        assert main(["simulate", "--nrfe", "2", "3", "--extrapolate", *option]) == 2
        assert capsys.readouterr().err == (f"gpmegen simulate: error: {option[0]}: not taken by runs at several "
                                           f"--nrfe, which save every --dt x --save-every with the methods' "
                                           f"defaults; leave it out\n")
    assert len(caught) == 1
