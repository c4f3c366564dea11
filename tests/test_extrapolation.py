"""Richardson extrapolation across discretizations: the estimator on data with a known error,
the clamped arm's static tip deflection against beam theory (an exact limit), the spin-up
beam's motion against a finer run, and the refusal of what cannot be compared."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest

from gpmegen.analysis.discretization import convergence, extrapolate, levels
from gpmegen.analysis.discretization.levels import simulate_levels
from gpmegen.analysis.post import richardson
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.cli import main
from gpmegen.errors import ExtrapolationError

SPINUP = Path(__file__).resolve().parent.parent / "examples" / "spinup.toml"
N_SDE = np.array([4, 9, 19])  # n_rfe 5, 10, 20


def synthetic(limit, C, D, q, n=N_SDE):
    """values (k, 50, 2) = limit + C/n² + D/n^q at every sample."""
    return np.array([limit + C / m**2 + D / m**q for m in n])


@pytest.fixture
def signal(rng):
    t = np.linspace(0.0, 1.0, 50)
    return np.stack([np.sin(5 * t), t**2], axis=-1), rng.normal(size=(50, 2)), rng.normal(size=(50, 2))


def test_pure_second_order_error_is_removed_exactly_with_a_zero_error_estimate(signal):
    limit, C, _ = signal
    est = richardson.richardson(N_SDE, synthetic(limit, C, 0.0, 3))
    assert np.allclose(est.limit, limit, rtol=0, atol=1e-13)
    assert np.allclose(est.errors, [C / m**2 for m in N_SDE], rtol=0, atol=1e-13)
    assert np.max(np.abs(est.limit_error)) < 1e-13
    assert est.order == pytest.approx(2.0, abs=1e-9)


def test_next_order_term_is_what_the_limit_error_estimates(signal):
    limit, C, D = signal
    est = richardson.richardson(N_SDE, synthetic(limit, C, 30 * D, 3))  # the assumed next term n^-3: exact
    assert np.allclose(est.limit_error, est.limit - limit, rtol=1e-9, atol=1e-14)
    # a faster next term, n^-4: the estimate is conservative, 2.34 times the true error here
    est = richardson.richardson(N_SDE, synthetic(limit, C, 3 + np.abs(D), 4))
    ratio = est.limit_error / (est.limit - limit)
    assert np.all((ratio > 1) & (ratio < 3))


def test_even_expansion_removes_the_n4_term_and_estimates_the_n6_one(signal):
    """With ``terms = 2`` the error C/n² + D/n⁴ is removed exactly by three levels (the one-term
    limit keeps part of D/n⁴, which bounds the error); a fourth level estimates an E/n⁶ term
    exactly."""
    limit, C, D = signal
    n = np.array([4, 9, 19, 39])
    values = np.array([limit + C / m**2 + 50 * D / m**4 for m in n])
    one, two = richardson.richardson(n[:3], values[:3]), richardson.richardson(n[:3], values[:3], terms=2)
    assert np.max(np.abs(one.limit - limit)) > 1e-4 and np.allclose(two.limit, limit, rtol=0, atol=1e-12)
    assert np.allclose(two.limit_error, one.limit - two.limit, rtol=0, atol=1e-14)  # the bound of three levels
    values = values + np.array([300 * C / m**6 for m in n])
    est = richardson.richardson(n, values, terms=2)
    assert np.allclose(est.limit_error, est.limit - limit, rtol=1e-8, atol=1e-15)
    with pytest.raises(richardson.LevelsError, match="2 terms of the error need 3 levels"):
        richardson.richardson(n[:2], values[:2], terms=2)


def test_a_phase_error_is_extrapolated_better_with_the_even_expansion_and_estimated_within_3():
    """A free vibration whose frequency converges as n⁻² (ω_n = ω(1 + 0.77/n²): the spin-up beam's
    first mode in the hub frame, 4.197 rad/s at n_sde = 9 against 4.157 in the limit) over
    15-20 s: pointwise in time its error is not C/n² alone at the coarser levels (the phase error
    reaches 0.8 rad at n_sde = 9). The even expansion removes the next term: 3.7 times less error
    from three levels, 16 times less from four, whose estimate is then within a factor 3; the
    one-term estimate is too."""
    t = np.linspace(15.0, 20.0, 501)
    n = np.array([9, 19, 39, 79])
    values = np.array([np.cos(4.16 * (1 + 0.77 / m**2) * t) for m in n])
    exact = np.cos(4.16 * t)

    def error(est):
        return np.max(np.abs(est.limit - exact))

    def ratio(est):
        return np.max(np.abs(est.limit_error)) / error(est)

    assert error(richardson.richardson(n[:3], values[:3], terms=2)) < 0.3 * error(
        richardson.richardson(n[:3], values[:3]))
    one, two = (richardson.richardson(n, values, terms=k) for k in (1, 2))
    assert error(two) < 0.1 * error(one)
    assert 1 / 3 < ratio(two) < 3 and 1 / 3 < ratio(one) < 3


def test_observed_order_is_the_order_of_the_data_and_two_levels_do_not_tell_it(signal):
    limit, C, _ = signal
    values = np.array([limit + C / m**1.5 for m in N_SDE])
    assert richardson.observed_order(N_SDE, values) == pytest.approx(1.5, abs=1e-9)
    two = richardson.richardson(N_SDE[:2], values[:2])
    assert np.isnan(two.order) and np.all(np.isnan(two.limit_error))
    assert np.isnan(richardson.observed_order(N_SDE, np.array([limit, limit + C, limit])))  # no convergence


@pytest.mark.parametrize("levels", [[4], [4, 4], [0, 3]])
def test_levels_that_cannot_be_extrapolated_are_refused(levels):
    with pytest.raises(richardson.LevelsError, match="at least two distinct levels"):
        richardson.richardson(levels, np.zeros(len(levels)))


@pytest.mark.long  # a convergence study: one build per n_rfe
def test_clamped_arm_tip_deflection_extrapolates_to_beam_theory(env):
    """The RFEM's static tip deflection under self weight is exactly wL⁴/8EI·(1 - 1/(2 n_sde²))
    (checked here too), so two levels give wL⁴/8EI and three an order of 2 and no error left."""
    nrfe = (2, 3, 5)
    models = [convergence.load_clamped_arm(n, directory=env[0]) for n in nrfe]
    exact = convergence.arm_reference(models[0].params).tip_deflection
    values = np.array([convergence.tip_deflection(m) for m in models])
    n_sde = np.array(nrfe) - 1
    assert np.allclose(values / exact - 1, -1 / (2 * n_sde**2), rtol=1e-12, atol=1e-14)
    est = richardson.richardson(n_sde[:2], values[:2])
    assert est.limit == pytest.approx(exact, rel=1e-12)
    est = richardson.richardson(n_sde, values)
    assert est.limit == pytest.approx(exact, rel=1e-12)
    assert abs(est.limit_error) < 1e-12 * exact and est.order == pytest.approx(2.0, abs=1e-6)
    assert np.allclose(est.errors, values - exact, rtol=1e-9, atol=1e-16)


def spinup_levels(nrfe, t_end, dt, backend="c", omega=4.0):
    return simulate_levels(SPINUP, nrfe, RunSpec(t_end=t_end, dt=dt, save_every=10, start="none"), backend=backend,
                           params={"Omega": omega})


@pytest.mark.long  # a convergence study: builds up to n_rfe 13, each run 6 s long (the runs' outputs and
@pytest.mark.requires_cc  # their extrapolation: test_point_velocities_*, test_levels_run_on_a_pool_*)
def test_spinup_limit_from_coarse_runs_is_closer_to_a_fine_run_than_any_of_them(env):
    """The tip's deflection during the spin-up: extrapolated from n_rfe 3, 5, 7 it is far nearer
    the limit from n_rfe 7 and 13 than the runs themselves, the estimated error of the n_rfe 7
    run is its distance from that limit, and the limit's estimated error is within a factor 3
    of its own distance."""
    levels = spinup_levels((3, 5, 7, 13), t_end=6.0, dt=1e-3)
    data = extrapolate.extrapolate(levels[:3], ["deflections", "point_velocities"])
    fine = extrapolate.extrapolate(levels[2:], ["deflections"])["deflections_limit"]
    run = data["deflections"][-1]
    assert np.max(np.abs(data["deflections_limit"] - fine)) < 0.05 * np.max(np.abs(run - fine))
    assert np.max(np.abs(data["deflections_error"][-1] - (run - fine))) < 0.05 * np.max(np.abs(run - fine))
    assert 1.7 < float(data["deflections_order"]) < 2.3
    # the limit's own estimated error against its distance from the finer limit: 2.0 times it
    ratio = np.max(np.abs(data["deflections_limit_error"])) / np.max(np.abs(data["deflections_limit"] - fine))
    assert 1 / 3 < ratio < 3
    assert data["point_velocities_limit"].shape == (len(data["t"]), 1, 3)


def test_outputs_not_comparable_across_discretizations_are_refused(env):
    levels = spinup_levels((2, 3), t_end=0.02, dt=1e-3, backend="numpy")
    for name in ("q", "psi1_1"):
        with pytest.raises(ExtrapolationError, match=f"output '{name}' is not comparable across discretizations"):
            extrapolate.extrapolate(levels, [name])
    other = spinup_levels((4,), t_end=0.02, dt=1e-3, backend="numpy", omega=6.0)
    with pytest.raises(ExtrapolationError, match="different parameter values, not one model"):
        extrapolate.extrapolate(levels + other)
    for few in (levels[:1], levels[:1] * 2):
        with pytest.raises(ExtrapolationError, match="at least two distinct levels"):
            extrapolate.extrapolate(few)


def test_point_velocities_and_hub_torque_agree_with_positions_and_energy(env):
    """The outputs of one run against independent quantities of the same run: point velocities
    against the time derivative of the positions, the hub's reaction torque against the power
    that the energies take in (no gravity, no damping: τ θ̇ = d(T + V)/dt)."""
    (level,) = simulate_levels(SPINUP, [3], RunSpec(t_end=2.0, dt=1e-3, save_every=1, start="none"),
                               params={"Omega": 6.0})
    out, res = extrapolate.outputs(level), level.results
    t = res["t"]
    dt = t[1] - t[0]
    slope = (out["points"][2:] - out["points"][:-2]) / (2 * dt)
    assert np.max(np.abs(out["point_velocities"][1:-1] - slope)) < 1e-5 * np.max(np.abs(slope))
    power = out["constraint_forces"][:, 0] * out["joint_velocities"][:, 0]
    energy = res["kinetic_energy"] + res["spring_energy"]
    assert np.max(np.abs(power[1:-1] - (energy[2:] - energy[:-2]) / (2 * dt))) < 1e-4 * np.max(np.abs(power))


# make check-c: two levels run and extrapolated through the command line (the refusal before the
# first level: test_outputs_not_comparable_across_discretizations_are_refused)
@pytest.mark.long
def test_simulate_extrapolate_writes_limits_errors_and_the_figure(env, tmp_path):
    out = tmp_path / "spin.npz"
    assert main(["simulate", str(SPINUP), "--nrfe", "3", "2", "--extrapolate", "--t-end", "0.05", "--dt", "1e-3",
                 "--save-every", "5", "--backend", "numpy", "--out", str(out)]) == 0
    data = extrapolate.load(out)
    assert list(data["nrfe"]) == [2, 3] and data["points"].shape == (2, 11, 1, 3)
    assert data["points_error"].shape == data["points"].shape and data["points_limit"].shape == (11, 1, 3)
    assert np.allclose(data["points_error"], data["points"] - data["points_limit"])
    assert out.with_suffix(".png").stat().st_size > 0
    assert (tmp_path / "spin_nrfe2.npz").exists() and (tmp_path / "spin_nrfe3.npz").exists()
    assert main(["simulate", str(SPINUP), "--nrfe", "3", "5", "--t-end", "0.05", "--out", str(out)]) == 2
    # two terms of the error need three levels: refused before any run
    assert main(["simulate", str(SPINUP), "--nrfe", "3", "5", "--extrapolate", "--terms", "2", "--t-end", "0.05",
                 "--out", str(tmp_path / "two.npz")]) == 2
    assert not list(tmp_path.glob("two*"))


def test_a_model_without_flexible_link_is_refused_before_any_run(tmp_path, capsys):
    model = tmp_path / "pendulum.toml"
    model.write_text('schema = 1\nname = "pendulum"\ngravity = [0, "-g", 0]\n[parameters]\ng = 9.81\nm = 1.0\n'
                     '[[chain]]\njoint = "theta1"\ntype = "revolute"\naxis = "z"\n'
                     '[[chain]]\nbody = "bob"\nshape = { type = "point_mass", mass = "m" }\n'
                     '[[chain]]\npoint = "E"\n')
    out = tmp_path / "p.npz"
    assert main(["simulate", str(model), "--nrfe", "2", "3", "--extrapolate", "--out", str(out)]) == 2
    assert "no flexible link, so nothing changes with n_rfe" in capsys.readouterr().err
    assert not list(tmp_path.glob("p*.npz"))


@pytest.mark.requires_cc
@pytest.mark.long   # every level run twice; the levels in one process are in make test
def test_levels_run_on_a_pool_of_processes_give_the_bytes_of_levels_run_one_after_the_other(env):
    """The levels are independent runs of the same generated code: on two processes they give
    the results, and so the extrapolation, that they give in this process, bit for bit."""
    serial, pooled = (simulate_levels(SPINUP, (2, 3, 4), RunSpec(t_end=0.5, dt=1e-3, save_every=10, start="none"),
                                      backend="c", params={"Omega": 6.0}, workers=workers) for workers in (1, 2))
    assert [level.nrfe for level in pooled] == [2, 3, 4]
    for one, other in zip(serial, pooled):
        for key in ("t", "q", "qd", "drive_forces", "constraint_forces"):
            assert np.array_equal(one.results[key], other.results[key]), (one.nrfe, key)
    a, b = extrapolate.extrapolate(serial), extrapolate.extrapolate(pooled)
    assert a.keys() == b.keys()
    for key in a:
        assert np.array_equal(a[key], b[key], equal_nan=a[key].dtype.kind == "f"), key


CANTILEVER = (Path(__file__).parent / "models" / "cantilever.toml").read_text(encoding="utf-8")


@pytest.mark.long  # a convergence study: one build per n_rfe
def test_convergence_of_a_named_point_at_the_statics_finds_beam_theory(env, tmp_path, capsys):
    """``convergence MODEL --output tip``: a link held horizontal by its locked joint sags under
    its weight by wL⁴/8EI·(1 - 1/(2 n_sde²)) (deflection / L = 6e-5: linear to 1e-8); the limit
    printed is wL⁴/8EI, each level's error its n_sde⁻² part, the limit's error nil, the order 2."""
    model = tmp_path / "cantilever.toml"
    model.write_text(CANTILEVER)
    assert main(["convergence", str(model), "--nrfe", "3", "5", "9", "--output", "tip", "theta1",
                 "--backend", "numpy", "--workers", "1"]) == 0
    out = capsys.readouterr().out
    sag = 3.0 * 9.81 * 2.0**4 / (8 * 5.0e5)
    line = next(text for text in out.splitlines() if text.startswith("tip "))
    limit = [float(x) for x in re.search(r"limit \(([^)]*)\) ±", line).group(1).split(",")]
    assert limit[0] == pytest.approx(2.0, abs=1e-7) and limit[1] == pytest.approx(-sag, rel=1e-6)
    errors = [float(x) for x in re.findall(r"n_rfe \d+: ([0-9.e+-]+)", line)]
    assert errors == pytest.approx([sag / (2 * n**2) / 2.0 for n in (2, 4, 8)], rel=2e-2)  # relative to |x| = L
    assert float(re.search(r"limit: ([0-9.e+-]+);", line).group(1)) < 1e-6 * sag
    assert float(re.search(r"observed order ([0-9.]+)", line).group(1)) == pytest.approx(2.0, abs=0.01)
    assert "theta1 (limit 0 ± 0)" in out or "theta1: zero at every level" in out


@pytest.mark.parametrize("output", ["psi1_1", "q", "tipp"])
def test_convergence_refuses_outputs_not_comparable_across_discretizations_before_any_run(env, tmp_path, capsys,
                                                                                         output):
    model = tmp_path / "cantilever.toml"
    model.write_text(CANTILEVER)
    assert main(["convergence", str(model), "--output", "tip", output]) == 2
    err = capsys.readouterr().err
    assert f"output {output!r} is not comparable across discretizations" in err and "joint or point" in err
    assert len(err.strip().splitlines()) == 1 and "n_rfe =" not in err  # one line, no level run


def test_extrapolation_of_the_papers_arm_runs_though_its_start_sets_constants_per_level(env, tmp_path, capsys):
    """The reference case sets its circle constants r_Ea and y_c from each level's own statics, so
    they differ between levels by design (1.0998 against 1.1008 m at n_rfe 3 and 5); they were
    taken for a different model after every level had run, and the extrapolation refused."""
    out = tmp_path / "arm.npz"
    assert main(["simulate", "--nrfe", "2", "3", "--extrapolate", "--t-end", "0.002", "--dt", "1e-5",
                 "--save-every", "50", "--workers", "1", "--backend", "numpy", "--out", str(out)]) == 0
    data = extrapolate.load(out)
    assert list(data["nrfe"]) == [2, 3] and np.all(np.isfinite(data["points_limit"]))


def test_levels_of_different_models_are_refused_by_the_check_made_before_any_level_runs(tmp_path):
    """Levels are compared by their symbolic models before the first runs (run_levels calls this
    check): the same file at two n_rfe passes, a parameter default that differs is refused."""
    from gpmegen.analysis.run.model_files import read_model_file

    other = tmp_path / "other.toml"
    text = SPINUP.read_text(encoding="utf-8")
    default = re.search(r"^(\w+) = \{ value = ([0-9.e+-]+)", text, re.M)
    other.write_text(text.replace(default.group(0), f"{default.group(1)} = {{ value = {2 * float(default.group(2))}"),
                     encoding="utf-8")
    same = {n: read_model_file(SPINUP, nrfe=n).model for n in (2, 3)}
    levels.check_same_model(same)
    with pytest.raises(ExtrapolationError, match="n_rfe = 3 and n_rfe = 2: different parameter values"):
        levels.check_same_model({2: same[2], 3: read_model_file(other, nrfe=3).model})
