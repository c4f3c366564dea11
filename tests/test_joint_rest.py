"""A joint spring with a rest position (``rest``): the generalized force ``-k (q - rest)``, the
statics at ``rest``, the spring energy, and the motion of a torsion pendulum about ``rest``
against its closed form."""

from __future__ import annotations

import numpy as np
import pytest

import gpmegen
from gpmegen.errors import ModelError
from gpmegen.runtime import statics

PENDULUM = """schema = 1
name = "torsion_pendulum"
[parameters]
k = {{ value = 40.0, unit = "N m/rad" }}
m = {{ value = 2.0, unit = "kg" }}
L = {{ value = 0.5, unit = "m" }}
r = {{ value = 0.3, unit = "rad" }}
[[chain]]
joint = "theta"
type = "revolute"
axis = "z"
stiffness = "k"
{rest}
[[chain]]
body = "bob"
shape = {{ type = "point_mass", mass = "m", position = ["L", 0, 0] }}
[[chain]]
point = "E"
"""


def pendulum(tmp_path, rest='rest = "r"'):
    path = tmp_path / "pendulum.toml"
    path.write_text(PENDULUM.format(rest=rest), encoding="utf-8")
    return path


def test_the_spring_pulls_to_its_rest_position(tmp_path):
    """Force, statics and energy of a spring to 0.3 rad; the same model without rest is the old
    spring to 0 (its forces and energy shifted by exactly the rest)."""
    model = gpmegen.load(model=gpmegen.load_model_file(pendulum(tmp_path)), backend="numpy",
                         directory=tmp_path / "gen")
    k, r = model.params["k"], model.params["r"]
    for q in (-0.4, 0.0, 0.3, 1.1):
        assert model.forces(0.0, np.array([q]), np.zeros(1))[0] == pytest.approx(-k * (q - r), rel=1e-14, abs=1e-14)
        assert model.energies(np.array([q]), np.zeros(1))[2] == pytest.approx(k * (q - r) ** 2 / 2, rel=1e-14,
                                                                               abs=1e-14)
    assert statics.locked(model, np.zeros(1))[0] == pytest.approx(r, abs=1e-12)
    plain = gpmegen.load(model=gpmegen.load_model_file(pendulum(tmp_path, rest="")), backend="numpy",
                         directory=tmp_path / "gen")
    assert plain.forces(0.0, np.array([r]), np.zeros(1))[0] == pytest.approx(-k * r, rel=1e-14)


def test_the_pendulum_swings_about_its_rest_position(tmp_path):
    """θ(t) = r + (θ0 - r) cos ωt, ω = √(k / m L²), against the RK4 run of the model."""
    model = gpmegen.load(model=gpmegen.load_model_file(pendulum(tmp_path)), backend="numpy",
                         directory=tmp_path / "gen")
    p = model.params
    omega = np.sqrt(p["k"] / (p["m"] * p["L"] ** 2))
    t, q, _, _, _ = model.rk4(np.array([0.0]), np.zeros(1), 0.5, 1e-4)
    np.testing.assert_allclose(q[:, 0], p["r"] - p["r"] * np.cos(omega * np.asarray(t)), atol=1e-9)


def test_a_rest_position_without_a_spring_is_refused(tmp_path):
    text = PENDULUM.format(rest='rest = "r"').replace('stiffness = "k"\n', "")
    path = tmp_path / "no_spring.toml"
    path.write_text(text, encoding="utf-8")
    with pytest.raises(ModelError, match="rest position but no spring; add stiffness"):
        gpmegen.load_model_file(path)


def test_the_rest_position_goes_through_urdf_and_back(tmp_path):
    """Exported to URDF (gpmegen's spring element) and imported again, the spring still pulls to
    its rest position; without it the round trip would make it a spring to 0."""
    from gpmegen.model.urdf import import_urdf
    from gpmegen.model.urdf_export import urdf_text

    model = gpmegen.load_model_file(pendulum(tmp_path))
    path = tmp_path / "pendulum.urdf"
    path.write_text(urdf_text(model), encoding="utf-8")
    assert 'rest="0.3' in path.read_text(encoding="utf-8")
    again = gpmegen.load(model=import_urdf(path).model, backend="numpy", directory=tmp_path / "gen")
    for q in (-0.4, 0.3, 1.1):
        assert again.forces(0.0, np.array([q]), np.zeros(1))[0] == pytest.approx(-40.0 * (q - 0.3), rel=1e-12)
