"""The sign of a closure's reported reaction, from statics alone: a bar of mass m and length L on
a planar free joint (slides x and y, then a turn about z) is held at rest, horizontal, by a
closure to a point G of the ground at its pivot P. The ground then carries the bar's weight, a
force (0, -m g, 0), and the moment of that weight about G, (0, 0, -m g L / 2): the reaction on
the body of the second point from the body of the first, as docs/model-file.md states, is that
with points = [P, G], and its opposite with points = [G, P]."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import gpmegen
from gpmegen.errors import ModelWarning

G, M, L = 9.81, 0.7, 0.4

HELD_BAR = f"""
schema = 1
name = "held_bar"
gravity = [0, "-g", 0]

[parameters]
g = {G}
m = {M}
L = {L}

[[chain]]
point = "G"

[[chain]]
joint = "x"
type = "prismatic"
axis = "x"

[[chain]]
joint = "y"
type = "prismatic"
axis = "y"

[[chain]]
joint = "theta"
type = "revolute"
axis = "z"

[[chain]]
body = "bar"
shape = {{ type = "bar", mass = "m", length = "L", width = 0.02, thickness = 0.01 }}

[[chain]]
point = "P"

[[closures]]
name = "pin"
points = POINTS
type = "revolute"
axis = "x"
"""


@pytest.mark.parametrize("points, sign", [('["P", "G"]', 1.0), ('["G", "P"]', -1.0)])
def test_the_ground_carries_the_weight_and_its_moment(tmp_path, points, sign):
    path = tmp_path / "held_bar.toml"
    path.write_text(HELD_BAR.replace("POINTS", points))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)  # the out-of-plane rows, dropped
        run = gpmegen.simulate(str(path), t_end=0.002, dt=1e-3, save_every=1, backend="numpy",
                               directory=str(tmp_path / "generated"))
    assert run.status == "complete"
    np.testing.assert_allclose(run["q"], 0.0, atol=1e-12)   # held at rest
    weight = M * G
    np.testing.assert_allclose(run["closure_pin_force"], np.tile([0.0, -sign * weight, 0.0], (3, 1)),
                               rtol=0, atol=1e-12 * weight)
    np.testing.assert_allclose(run["closure_pin_moment"], np.tile([0.0, 0.0, -sign * weight * L / 2], (3, 1)),
                               rtol=0, atol=1e-12 * weight)
