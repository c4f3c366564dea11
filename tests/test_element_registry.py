"""The element-kind registry (gpmegen.model.elements): a kind registered here, in the test alone
(a linear torsion spring and damper on one coordinate), is read from a model file and derived
with no edit elsewhere, and its effect is the closed form of a linear oscillator; unregistered,
its table is refused again."""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run.model_files import read_model_file
from gpmegen.errors import ModelError
from gpmegen.model import elements
from gpmegen.model.chain import ForceElement, symbol, velocity_symbol
from gpmegen.model.expand import expand

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


class OnePerCoordinate(TorsionSprings):
    """Torsion springs read together (``read_all``, the whole array): at most one per coordinate."""

    def read_all(self, reader, items):
        springs = super().read_all(reader, items)
        seen = set()
        for k, spring in enumerate(springs):
            if spring.coordinate in seen:
                reader.fail((self.table, k, "coordinate"), f"a second torsion spring on {spring.coordinate!r}; "
                                                           f"join them into one")
            seen.add(spring.coordinate)
        return springs


def test_a_kind_reading_its_whole_array_refuses_at_the_entry(rotor):
    elements.register(OnePerCoordinate)
    try:
        entry = '[[torsion_springs]]\ncoordinate = "theta1"\nstiffness = "kt"\n'
        assert len(read_model_file(rotor).model.elements) == 1
        rotor.write_text(ROTOR.replace("[initial]", entry + "\n[initial]"))
        line = rotor.read_text().splitlines().index('coordinate = "theta1"', ROTOR.splitlines().index("[initial]")) + 1
        with pytest.raises(ModelError, match=rf"torsion_rotor.toml:{line}: torsion_springs\[1\]\.coordinate: a second "
                                             r"torsion spring on 'theta1'; join them into one"):
            read_model_file(rotor)
    finally:
        elements.unregister("torsion_springs")


def test_a_field_no_kind_fills_is_refused():
    class Drives(TorsionSprings):
        table = "torques"
        field = "drives"

    with pytest.raises(ValueError, match="field 'drives' is no Model field a kind fills; use one of closures, forces, "
                                         "controllers, elements"):
        elements.register(Drives)
    assert "torques" not in elements.tables()


@pytest.mark.parametrize("entries, words", [
    (("kt",), r"Model.elements\[0\] is a str, not an element"),
    ((TorsionSpring("theta1", symbol("kt")), ForceElement("f", ("A", "B"), "actuator", force=1)),
     r"Model.elements\[1\] is a ForceElement, not an element: .* goes in Model.forces, closures or controllers"),
    (TorsionSpring("theta1", symbol("kt")), r"Model.elements is a TorsionSpring, not a tuple"),
])
def test_a_python_model_holding_no_element_is_refused_in_one_line(entries, words, env):
    """A Model built in Python whose elements are not Elements: one ModelError about the entry as
    it is validated (it was an AttributeError deep in the derivation), before any build."""
    model = dataclasses.replace(read_model_file(PENDULUM).model, elements=entries)
    with pytest.raises(ModelError, match=words) as caught:
        expand(model)
    assert caught.value.subject[0] == "elements" and "\n" not in str(caught.value)
    with pytest.raises(ModelError, match=words):
        gpmegen.load(model=model, backend="numpy", directory=env[0])
