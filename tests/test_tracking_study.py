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


def _programmed_path_error(t, E):
    """|circle| and |height| (m) of E's samples (k, 3) at ``t`` (k,) against the programmed path of
    examples/tracking_study.toml (its parameters' values: r_E, y_0, A, T)."""
    r_E, y_0, A, T = 1.06066017177982, 1.66066017177982, 0.5, 2.0
    u = np.clip(t / T, 0.0, 1.0)
    s = u**4 * (35 - 84 * u + 70 * u**2 - 20 * u**3)
    return np.abs(np.hypot(E[:, 0], E[:, 2]) - r_E).max(), np.abs(E[:, 1] - (y_0 - A * s)).max()


@pytest.mark.requires_cc   # the plant's runs are DOP853, compiled
@pytest.mark.filterwarnings("ignore:constraint")
def test_flexible_feedforwards_on_a_plant_equal_to_the_model(tmp_path, env):
    """With the plant equal to the flexible model (n_rfe 2 both): (b') feeds forward the plant's
    own realization of the joint references, so its joints follow them far more closely than (a)'s
    and (c)'s; (b) feeds forward the stable inversion of E's path and starts where it rests, so E
    stays on its path (the arm's sag compensated) where (a), fed the rigid arm's, sags; the
    table and figure are written."""
    a, b, b_joints, c = _example().study(tmp_path, nrfe_model=2, nrfe_plant=2, t_end=0.8)
    turn = b_joints.constraints["turn"][0]
    assert turn < 0.05 * min(a.constraints["turn"][0], c.constraints["turn"][0])
    assert turn < 1e-6 < a.constraints["turn"][0]   # measured 1.3e-8 and 7.2e-4 rad
    # E's height: (a) sags by tens of mm; (b) within what the inversion's table interpolation leaves
    assert b.constraints["height"][0] < 1e-3 < 0.01 < a.constraints["height"][0]   # measured 2.1e-5, 0.037 m
    assert b.path[0] < 0.05 * a.path[0]   # measured 0.33 and 52 mm
    assert {"metrics.csv", "metrics.md", "tracking.png"} <= {p.name for p in tmp_path.iterdir()}
    assert "(b) flexible inversion of E's path + PD" in (tmp_path / "metrics.md").read_text(encoding="utf-8")

    # Without PD (wn = 0) the inversion's inputs alone, fed into its own model (no constraints),
    # reproduce E's path. They are read by linear interpolation of the inversion's mesh: each
    # input is off by at most eps = h²/8·max|ü| (a fraction below 1e-3 of its peak); on the
    # arm's inertia (about 2 kg·m²) that moves E by about eps·t²/(2 I)·1.5 m, 1e-4 m in 0.8 s,
    # and the free arm, which gravity tips away from the raised pose at about 2.4 1/s, may grow
    # that by e^(2.4·0.8) ≈ 7: 1 mm bounds it. (a)'s rigid inputs leave E 10 mm and more off.
    from gpmegen.runtime import signals

    inverse = tmp_path / "flexible_inversion.npz"
    data = np.load(inverse)
    h = np.diff(data["t"])
    rates = np.diff(data["u"], axis=0) / h[:, None]
    second = np.abs(np.diff(rates, axis=0)) / ((h[1:] + h[:-1]) / 2)[:, None]
    around = np.maximum(np.vstack([second[:1], second]), np.vstack([second, second[-1:]]))  # each interval's ends
    eps = np.array([max(signals.error_bound(hk, s) for hk, s in zip(h, around[:, j])) for j in range(3)])
    assert np.all(eps < 1e-3 * np.abs(data["u"]).max(axis=0))   # measured 4.6e-4 of θ1's peak, 4.6e-6 of ψ2's
    example = _example()
    free = gpmegen.simulate(tmp_path / example.PD_INVERSE.name, nrfe=2, t_end=0.8, method="dop853", save_dt=1e-3,
                            rtol=1e-10, atol=1e-11, start="locked", feedforward=str(inverse),
                            params={"wn": 0.0, **example.start_of(inverse)})
    assert free.status == "complete"
    circle, height = _programmed_path_error(free["t"], free["end_effector"])
    assert max(circle, height) < 1e-3   # m; measured 1.1e-4 and 7.9e-5
    q = np.array([np.interp(free["t"], data["t"], data["q"][:, j]) for j in range(data["q"].shape[1])]).T
    assert np.abs(free["q"] - q).max() < 1e-3   # rad, m (measured 9.6e-5): the inversion's own motion
