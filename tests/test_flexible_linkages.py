"""Flexible closed loops against independent results: Simeon's flexible slider-crank against the
IVP test set's published solution at t = 0.1 s and against Exudyn's ANCF rod, the flexible
four-bar against Exudyn's ANCF cable elements with RFEM's order of convergence, and Bauchau's
spatial four-bar against Exudyn's geometrically exact 3-D beams (benchmarks/slider_crank.py,
benchmarks/four_bar_flexible.py and benchmarks/bauchau_four_bar.py hold the models' set-up;
these are their short versions)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

ROOT = Path(__file__).resolve().parents[1]
_BENCHMARKS = str(ROOT / "benchmarks")
if _BENCHMARKS not in sys.path:
    sys.path.insert(0, _BENCHMARKS)

import bauchau_four_bar  # noqa: E402  (benchmarks/bauchau_four_bar.py)
import four_bar_flexible  # noqa: E402  (benchmarks/four_bar_flexible.py)
import slider_crank  # noqa: E402  (benchmarks/slider_crank.py)

pytestmark = [pytest.mark.long, pytest.mark.filterwarnings("ignore::gpmegen.errors.ModelWarning")]


def test_slider_crank_start_carries_the_test_sets_initial_velocities():
    """The polygon through the rod's ends and its sdes carries the test set's transverse field
    exactly at the sdes and the tip: its first slope and its kinks rebuild the field there (n_rfe
    even: an sde at the midpoint), and the stretches sum to the tip's axial displacement."""
    amplitudes = (0.3, -0.05)
    for nrfe in (4, 8):
        x = np.concatenate([[0.0], slider_crank.sde_positions(nrfe), [slider_crank.L2]])
        first = slider_crank.transverse(x[1], amplitudes) / x[1]
        slopes = first + np.concatenate([[0.0], np.cumsum(slider_crank.kinks(nrfe, amplitudes))])
        rebuilt = np.concatenate([[0.0], np.cumsum(slopes * np.diff(x))])
        assert np.allclose(rebuilt, slider_crank.transverse(x, amplitudes), rtol=0, atol=1e-15)
        assert float(np.sum(slider_crank.stretches(nrfe, 2e-5, 3e-5))) == pytest.approx(3e-5, rel=1e-12)
    assert float(slider_crank.transverse(slider_crank.L2 / 2, amplitudes)) == pytest.approx(0.3)


@pytest.fixture(scope="module")
def slider_crank_levels():
    """The slider-crank at n_rfe 4 and 8, Radau IIA to 0.1 s: the compared values at the start
    and at the end of each."""
    starts, finals = [], []
    for nrfe in (4, 8):
        res, over_time, _ = slider_crank.gpmegen_level(nrfe, 1e-9, 1e-11, 2e-3)
        assert str(res["status"]) == "complete" and res["t"][-1] == pytest.approx(slider_crank.T_END)
        starts.append({key: float(v[0]) for key, v in over_time.items()})
        finals.append({key: float(v[-1]) for key, v in over_time.items()})
    return starts, finals


def test_slider_crank_starts_on_the_test_sets_initial_values(slider_crank_levels):
    """Both levels start where the test set does: the rod's angular rate (solved from the
    closure), the midpoint's transverse rate (an sde there; to 1e-4 relative: the kinks' rates are
    laid on the unstretched rod, and its initial stretch of 1.7e-5 m moves the sdes, 3.3e-5
    relative at n_rfe 4, exact without it), the stretch and the slider's place."""
    initial = slider_crank.INITIAL
    for start in slider_crank_levels[0]:
        assert start["phi2 rate"] == pytest.approx(initial["phi2_rate"], abs=2e-5)
        assert start["midpoint deflection rate"] == pytest.approx(initial["q_rate"][0], rel=1e-4)
        assert start["tip stretch"] == pytest.approx(initial["q"][3], rel=1e-6)
        assert start["x3"] == pytest.approx(initial["x3"], abs=1e-9)


def test_slider_crank_against_the_ivp_test_set(slider_crank_levels):
    """At t = 0.1 s, extrapolated from n_rfe 4 and 8: the rod's angle and the slider's place
    agree with the test set's to 1e-6 (rad, m; the difference of the two rod models enters only
    through the rod's stretch, 1e-5 m); the chord's stretch to the bending's foreshortening
    ∫w'²/2 that the test set's linear kinematics leaves out (its chord is L + q4) within 2 % of
    the stretch; the midpoint's deflection within 5 % of its peak in the run (1.6 mm): RFEM carries
    the geometric stiffening by the rod's axial force (up to about 5 % of its Euler load here) and
    every bending shape, the test set neither (a linear stiffness, two sine modes)."""
    _, finals = slider_crank_levels
    estimates = slider_crank.extrapolated([4, 8], finals)
    reference = slider_crank.REFERENCE
    assert float(estimates["phi2"].limit) == pytest.approx(reference["phi2"], abs=1e-6)
    assert float(estimates["x3"].limit) == pytest.approx(reference["x3"], abs=1e-6)
    deflection = float(estimates["midpoint deflection"].limit)
    foreshortening = deflection**2 * math.pi**2 / (4 * slider_crank.L2)
    stretch = float(estimates["tip stretch"].limit) + foreshortening
    assert stretch == pytest.approx(reference["q"][3], rel=0.02)
    assert abs(deflection - reference["q"][0]) < 0.05 * 1.6e-3
    # the levels differ by the discretization, which extrapolation removes: n_rfe 8 is nearer the
    # limit than n_rfe 4
    errors = np.abs(estimates["midpoint deflection"].errors)
    assert errors[1] < errors[0]


def test_slider_crank_meets_exudyn_where_the_test_set_differs(slider_crank_levels):
    """Exudyn's geometrically exact ANCF rod (16 elements, 5e-6 s), from the same start, ends at
    0.1 s with the midpoint deflection of gpmegen's limit (from n_rfe 4 and 8) to a tenth of the
    test set's distance from it (measured: 0.9e-6 m against 4.3e-5 m), and with its rod angle and
    slider place to 5e-7 (rad, m): what separates the test set's value is its model."""
    _, finals = slider_crank_levels
    estimates = slider_crank.extrapolated([4, 8], finals)
    values = slider_crank.exudyn_run(16, 5e-6, np.linspace(0.0, slider_crank.T_END, 51))[0]
    assert values is not None
    exudyn = {key: float(v[-1]) for key, v in values.items()}
    deflection = float(estimates["midpoint deflection"].limit)
    published = slider_crank.REFERENCE["q"][0]
    assert abs(deflection - exudyn["midpoint deflection"]) < 0.1 * abs(published - exudyn["midpoint deflection"])
    assert float(estimates["phi2"].limit) == pytest.approx(exudyn["phi2"], abs=5e-7)
    assert float(estimates["x3"].limit) == pytest.approx(exudyn["x3"], abs=5e-7)


@pytest.fixture(scope="module")
def four_bar_runs(tmp_path_factory):
    """The flexible four-bar (undamped, crank at 20 rad/s, its coupler bending and stretching as
    Exudyn's cable does) for 0.1 s: gpmegen at n_rfe 4, 8 and 16, Exudyn with 16 ANCF elements
    at a step of 1e-5 s and with 8 at 2e-5 s (its own convergence)."""
    model = four_bar_flexible.axial_variant(tmp_path_factory.mktemp("four_bar"))
    levels, t, start = {}, None, None
    for nrfe in (4, 8, 16):
        res, over_time, _ = four_bar_flexible.gpmegen_level(nrfe, 20.0, 0.1, 5e-4, 1e-9, 1e-11, model)
        assert str(res["status"]) == "complete"
        levels[nrfe], t, start = over_time, res["t"], start or four_bar_flexible.rigid_start(res)
    fine = four_bar_flexible.exudyn_run(16, 1e-5, 20.0, 0.1, start, t, 1e-6)[0]
    coarse = four_bar_flexible.exudyn_run(8, 2e-5, 20.0, 0.1, start, t, 1e-6)[0]
    assert fine is not None and coarse is not None
    return levels, fine, coarse


def test_four_bar_against_exudyn_converges_at_rfems_order(four_bar_runs):
    """The coupler's midpoint deflection (its peak about 0.2 mm): gpmegen's error against Exudyn
    falls with n_rfe at RFEM's order 2 (observed between 1.5 and 2.5 from n_rfe 4 to 16; measured
    1.8), to 1.5 % of the peak at n_rfe 16 (measured 0.6 %), where Exudyn's own change (half its
    elements and twice its step, measured 0.15 %) is less than half of it; and the rocker angle
    agrees to 1e-4 of its swing at every level."""
    levels, fine, coarse = four_bar_runs
    peak = np.max(np.abs(fine["midpoint deflection"]))
    exudyn_change = np.max(np.abs(coarse["midpoint deflection"] - fine["midpoint deflection"])) / peak
    errors = {n: np.max(np.abs(v["midpoint deflection"] - fine["midpoint deflection"])) / peak
              for n, v in levels.items()}
    assert errors[4] > errors[8] > errors[16]
    order = math.log(errors[4] / errors[16]) / math.log((16 - 1) / (4 - 1))
    assert 1.5 < order < 2.5, (order, errors)
    assert errors[16] < 0.015
    assert exudyn_change < 0.5 * errors[16]
    swing = np.max(np.abs(fine["rocker angle"] - fine["rocker angle"][0]))
    for v in levels.values():
        assert np.max(np.abs(v["rocker angle"] - fine["rocker angle"])) < 1e-4 * swing


@pytest.fixture(scope="module")
def bauchau_runs():
    """Bauchau's spatial four-bar for 2 s from rest: gpmegen at n_rfe 2, 4 and 8, Exudyn with 16
    geometrically exact elements on the crank and the follower (32 on the coupler) at a step of
    2e-3 s and with half as many (its own convergence)."""
    levels, t = {}, None
    for nrfe in (2, 4, 8):
        res, over_time, _ = bauchau_four_bar.gpmegen_level(nrfe, 2.0, 0.01, 1e-8, 1e-10)
        assert str(res["status"]) == "complete"
        levels[nrfe], t = over_time, res["t"]
    fine = bauchau_four_bar.exudyn_run(16, 2e-3, 2.0, t, 1e-5)[0]
    coarse = bauchau_four_bar.exudyn_run(8, 2e-3, 2.0, t, 1e-5)[0]
    assert fine is not None and coarse is not None
    return levels, fine, coarse


@pytest.mark.parametrize("key, bound", [("C out of plane", 0.015), ("coupler moment", 0.06),
                                        ("follower moment", 0.004), ("crank torque", 0.012)])
def test_bauchau_four_bar_against_exudyn_converges_at_rfems_order(bauchau_runs, key, bound):
    """The out-of-plane displacement of C (peak 3.5 mm), the out-of-plane mid-span moments of the
    coupler (6.5 N·m) and the follower (45 N·m) and the crank's torque (5.4 N·m), against
    Exudyn's beams: gpmegen's error falls with n_rfe at RFEM's order 2 in n_sde (observed from
    n_rfe 2 to 8 between 1.5 and 2.5; measured 1.9 to 2.0) to below ``bound`` of the peak at
    n_rfe 8, about twice the measured error (0.8 %, 3.8 %, 0.19 %, 0.58 %: the coupler's moment,
    small against the follower's, converges slowest), where Exudyn's own change with half its
    elements (measured 0.32 %, 1.0 %, 0.05 %, 0.16 %) is less than half of it: the difference is
    RFEM's discretization, not the reference's."""
    levels, fine, coarse = bauchau_runs
    peak = np.max(np.abs(fine[key]))
    errors = {n: np.max(np.abs(v[key] - fine[key])) / peak for n, v in levels.items()}
    assert errors[2] > errors[4] > errors[8]
    order = math.log(errors[2] / errors[8]) / math.log((8 - 1) / (2 - 1))
    assert 1.5 < order < 2.5, (order, errors)
    assert errors[8] < bound
    exudyn_change = np.max(np.abs(coarse[key] - fine[key])) / peak
    assert exudyn_change < 0.5 * errors[8]
