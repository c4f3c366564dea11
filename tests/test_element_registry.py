"""The element-kind registry (gpmegen.model.elements): a kind registered here, in the test alone
(a linear torsion spring and damper on one coordinate), is read from a model file and derived
with no edit elsewhere, and its effect is the closed form of a linear oscillator; unregistered,
its table is refused again."""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run.model_files import read_model_file
from gpmegen.errors import ModelError
from gpmegen.model import elements
from gpmegen.model.chain import symbol, velocity_symbol

# the pendulum of tests/models (a point mass m at r from a revolute joint about z) without
# gravity, its tip named, and a torsion spring and damper on its joint: J = m r², and the spring
# alone gives ω = sqrt(k/J)
PENDULUM = Path(__file__).parent / "models" / "pendulum.toml"
ROTOR = (PENDULUM.read_text()
         .replace('name = "pendulum"', 'name = "torsion_rotor"')
         .replace('gravity = [0, "-g", 0]', 'gravity = [0, 0, 0]')
         .replace('[[chain]]\njoint', 'kt = { value = 4.0, unit = "N m/rad", doc = "torsion spring" }\n'
                                      'c = { value = 0.0, unit = "N m s/rad", doc = "torsion damper" }\n\n'
                                      '[[chain]]\njoint')
         .replace('[initial]', '[[chain]]\npoint = "tip"\nposition = [1.0, 0, 0]\n\n'
                               '[[torsion_springs]]\ncoordinate = "theta1"\nstiffness = "kt"\ndamping = "c"\n\n'
                               '[initial]'))
J, K, Q0 = 1.0, 4.0, -0.5


@dataclass(frozen=True)
class TorsionSpring(elements.Element):
    """``k q²/2`` on the coordinate (its generalized force ``-k q``) and ``-c q̇`` beside it."""

    coordinate: str
    stiffness: object
    damping: object = 0

    def potential(self):
        return self.stiffness * symbol(self.coordinate) ** 2 / 2

    def applied(self):
        return {self.coordinate: -self.damping * velocity_symbol(self.coordinate)}


class TorsionSprings(elements.ElementKind):
    table = "torsion_springs"
    keys = ("coordinate", "stiffness", "damping")
    required = ("coordinate", "stiffness")
    what = "torsion spring"

    def read(self, reader, item, path):
        name = reader.string(item["coordinate"], path + ("coordinate",), "a coordinate name in quotes")
        reader.check_coordinate(name, path + ("coordinate",))
        values = {key: reader.quantity(item[key], path + (key,), reader.params)
                  for key in ("stiffness", "damping") if key in item}
        return TorsionSpring(name, **values)


@pytest.fixture
def registered():
    elements.register(TorsionSprings)
    yield
    elements.unregister("torsion_springs")


@pytest.fixture
def rotor(tmp_path):
    path = tmp_path / "torsion_rotor.toml"
    path.write_text(ROTOR)
    return path


def test_a_registered_kind_is_read_and_oscillates_at_its_closed_form_frequency(registered, rotor, env):
    """Undamped: q = q0 cos(ωt), ω = sqrt(k/J), to the RK4 error of 2 s at 1 ms, and the spring
    energy k q²/2 plus the kinetic energy J q̇²/2 stays k q0²/2."""
    model = read_model_file(rotor).model
    assert model.elements == (TorsionSpring("theta1", symbol("kt"), symbol("c")),)
    run = gpmegen.simulate(str(rotor), t_end=2.0, dt=1e-3, backend="numpy", directory=env[0])
    omega = np.sqrt(K / J)
    np.testing.assert_allclose(run.coordinate("theta1"), Q0 * np.cos(omega * run.t), rtol=0, atol=1e-9)
    loaded = gpmegen.load(model=model, backend="numpy", directory=env[0])
    kinetic, gravity, spring = loaded.energies(np.array([0.1]), np.array([0.5]))
    assert (kinetic, gravity, spring) == pytest.approx((J * 0.5 ** 2 / 2, 0.0, K * 0.1 ** 2 / 2), abs=1e-12)


def test_its_damper_gives_the_damped_oscillator(registered, rotor, env):
    """With c: the underdamped closed form q0 e^(-ζωt) (cos ω_d t + ζω/ω_d sin ω_d t)."""
    c = 0.8
    run = gpmegen.simulate(str(rotor), t_end=2.0, dt=1e-3, params={"c": c}, backend="numpy", directory=env[0])
    omega = np.sqrt(K / J)
    zeta = c / (2 * np.sqrt(K * J))
    damped = omega * np.sqrt(1 - zeta ** 2)
    t = run.t
    exact = Q0 * np.exp(-zeta * omega * t) * (np.cos(damped * t) + zeta * omega / damped * np.sin(damped * t))
    np.testing.assert_allclose(run.coordinate("theta1"), exact, rtol=0, atol=1e-9)


def test_an_unregistered_table_is_refused_in_one_line(rotor):
    with pytest.raises(ModelError, match=r"torsion_rotor.toml:\d+: torsion_springs: unknown key 'torsion_springs'"):
        read_model_file(rotor)


def test_a_faulty_entry_is_refused_at_its_line(registered, rotor):
    rotor.write_text(ROTOR.replace('coordinate = "theta1"', 'coordinate = "theta2"'))
    line = ROTOR.splitlines().index('coordinate = "theta1"') + 1
    with pytest.raises(ModelError, match=rf"torsion_rotor.toml:{line}: torsion_springs\[0\]\.coordinate: 'theta2' "
                                         "is not a coordinate"):
        read_model_file(rotor)
    rotor.write_text(ROTOR.replace('damping = "c"', 'mass = "c"'))
    with pytest.raises(ModelError, match=r"torsion_springs\[0\]\.mass: unknown key 'mass'; the keys of a torsion "
                                         r"spring are coordinate, stiffness, damping"):
        read_model_file(rotor)


@pytest.mark.parametrize("table", ["forces", "parameters", "chain"])
def test_a_table_taken_is_refused(table):
    """Another kind's table, or a key the model file has of its own (which, taken, would make
    every model file's parameters or chain read as entries of the kind)."""
    class Again(TorsionSprings):
        pass

    Again.table = table
    with pytest.raises(ValueError, match=f"the table '{table}' is empty, another kind's or a model file's own key"):
        elements.register(Again)
    assert [kind.table for kind in elements.kinds()] == ["closures", "controllers", "forces"]
