"""examples/tracking_study.py at its smallest sizes: the pipeline from the driving functions to
the plant's metrics, and what its numbers rest on."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

import gpmegen

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def _example():
    spec = importlib.util.spec_from_file_location("tracking_study", EXAMPLES / "tracking_study.py")
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    return example


@pytest.mark.filterwarnings("ignore:constraint")
def test_rigid_joint_references_are_the_inverse_kinematics_of_the_path(env):
    """The rigid arm realizing E's path (circle and height) and the rigid arm realizing the joint
    references written from its inverse kinematics need the same inputs: the two files' motions
    agree, so the PD plant's references are E's path."""
    path = gpmegen.simulate(EXAMPLES / "tracking_study.toml", nrfe=1, t_end=1.0, dt=1e-3, start="none")
    joints = gpmegen.simulate(EXAMPLES / "tracking_study_joints.toml", nrfe=1, t_end=1.0, dt=1e-3, start="none")
    assert path.status == joints.status == "complete"
    assert np.abs(path["u"]).max() > 1.0   # the inputs hold the arm against gravity and move it
    assert np.abs(path["u"] - joints["u"]).max() < 1e-5
    assert np.abs(path["end_effector"] - joints["end_effector"]).max() < 1e-9


@pytest.mark.requires_cc   # the plant's runs are DOP853, compiled
@pytest.mark.filterwarnings("ignore:constraint")
def test_flexible_feedforward_tracks_the_joints_of_its_own_plant(tmp_path, env):
    """With the plant equal to the flexible model (n_rfe 2 both), (b)'s feedforward is the plant's
    own driving functions: its joints follow the references to far less than (a)'s, fed the rigid
    arm's, and computed torque's with the rigid model; the table and figure are written."""
    a, b, c = _example().study(tmp_path, nrfe_model=2, nrfe_plant=2, t_end=0.8)
    assert b.constraints["turn"][0] < 0.05 * min(a.constraints["turn"][0], c.constraints["turn"][0])
    assert b.constraints["turn"][0] < 1e-6 < a.constraints["turn"][0]   # measured 1.3e-8 and 7.2e-4 rad
    assert {"metrics.csv", "metrics.md", "tracking.png"} <= {p.name for p in tmp_path.iterdir()}
    assert "(b) flexible feedforward + PD" in (tmp_path / "metrics.md").read_text(encoding="utf-8")
