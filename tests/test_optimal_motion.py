"""examples/optimal_motion.py: the motion optimized on the flexible arm's CasADi export leaves a
small fraction of the vibration the rigid model's optimum leaves, and gpmegen's own simulation
of its torques follows the optimizer's states."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("casadi")

ROOT = Path(__file__).resolve().parents[1]


def _example():
    path = ROOT / "examples" / "optimal_motion.py"
    spec = importlib.util.spec_from_file_location("optimal_motion", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.long
@pytest.mark.requires_cc  # gpmegen's check runs DOP853, compiled
def test_optimal_motion_leaves_less_vibration_than_the_rigid_optimum(tmp_path, capsys):
    example = _example()
    figure = tmp_path / "motion.png"
    report = example.main(["--out", str(tmp_path / "out"), "--figure", str(figure)])
    flexible, rigid = report["flexible"], report["rigid"]
    # the flexible model's optimum: at the goal, its residual vibration within the optimizer's RK4
    # error (the deflections during the motion reach 25 mm)
    assert abs(flexible["theta_at_T"] - example.THETA_F) < 1e-4
    assert flexible["residual_rms"] < 2e-5 and rigid["residual_rms"] > 1e-3
    assert report["ratio"] > 100
    # the rigid optimum reaches the goal on its own model
    assert abs(rigid["rigid_theta_at_T"] - example.THETA_F) < 1e-8
    # gpmegen's DOP853 run of the optimized torques against the optimizer's RK4 states
    assert flexible["agreement_theta"] < 1e-4 and flexible["agreement_deflection"] < 1e-4
    assert figure.stat().st_size > 10_000
    out = capsys.readouterr().out
    assert "residual tip deflection RMS" in out and np.isfinite(report["ratio"])
