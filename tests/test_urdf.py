"""URDF import against Pinocchio's own URDF reader, on the Panda of ``example-robot-data`` (a
real robot description from the package index, not copied here): M, the velocity terms, the
gravity terms, the joint dampers and every link's frame at random states to 1e-10. Then a link
made flexible from a model file (the beam lies where the link was), the refusals of URDFs a
chain cannot hold, each in one line, from the API and the command line, the animation's skeleton
through Pinocchio's frames, and the flexible Panda example built and run from its balanced start
with its tool centre point held on its circle."""

from __future__ import annotations

from importlib import metadata
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis import arm_geometry as geometry
from gpmegen.analysis.driving import point_constraints
from gpmegen.cli import main
from gpmegen.errors import ModelError
from gpmegen.model.expand import expand
from gpmegen.model.toml_file import load_model_file, read_model_file
from gpmegen.model.urdf import import_urdf

pin = pytest.importorskip("pinocchio")
ROOT = Path(__file__).resolve().parents[1]
PANDA_FILE = "robots/panda_description/urdf/panda.urdf"
FINGERS = ("panda_finger_joint1", "panda_finger_joint2")


def panda_urdf() -> Path:
    try:
        files = metadata.files("example-robot-data") or []
    except metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed (pip install -e .[test])")
    return Path(next(f for f in files if str(f).endswith(PANDA_FILE)).locate())


@pytest.fixture(scope="module")
def panda(env):
    robot = import_urdf(panda_urdf(), tip="panda_hand")
    return robot, gpmegen.load(model=robot.model, directory=env[0], backend="numpy")


def pinocchio_panda():
    """Pinocchio's Panda with the fingers locked at zero, as the import holds them."""
    full = pin.buildModelFromUrdf(str(panda_urdf()))
    return pin.buildReducedModel(full, [full.getJointId(j) for j in FINGERS], pin.neutral(full))


def test_panda_agrees_with_pinocchio(panda, rng):
    robot, loaded = panda
    model = pinocchio_panda()
    data = model.createData()
    assert loaded.coordinates == tuple(model.names[1:])
    assert [j.damping for j in robot.joints] == pytest.approx(model.damping.tolist())
    points = expand(robot.model).points
    frames = {name: model.getFrameId(name) for name in points}
    for _ in range(5):
        q, qd = rng.uniform(-2.5, 2.5, 7), rng.uniform(-2, 2, 7)
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(loaded.mass_matrix(q), M, rtol=0, atol=1e-10 * np.abs(M).max())
        gravity = pin.computeGeneralizedGravity(model, data, q)
        velocity = pin.rnea(model, data, q, qd, np.zeros(7)) - gravity
        at_rest = loaded.forces(0.0, q, np.zeros(7))
        np.testing.assert_allclose(at_rest, -gravity, rtol=0, atol=1e-10 * np.abs(gravity).max())
        # the URDF's <dynamics damping> acts as a viscous damper: f = -(C qd + g) - d qd
        moving = loaded.forces(0.0, q, qd) - at_rest
        np.testing.assert_allclose(moving, -velocity - model.damping * qd, rtol=0, atol=1e-10 * np.abs(velocity).max())
        pin.framesForwardKinematics(model, data, q)
        expected = np.array([data.oMf[frames[name]].translation for name in points])
        np.testing.assert_allclose(loaded.point_positions(q), expected, rtol=0, atol=1e-12)


def test_panda_skeleton_runs_through_pinocchio_frames(panda, rng):
    """The animation's skeleton of the imported Panda: the base, the frame of every moving link
    (where its joint is) and the last point (a finger: no constraint names a tool), at random
    states, from Pinocchio's frame placements."""
    robot, loaded = panda
    model = pinocchio_panda()
    data = model.createData()
    scene = geometry.scene(robot.model, loaded)
    assert scene.points[scene.tool] == "panda_rightfinger"
    links = ["panda_link0"] + [f"panda_link{k}" for k in range(1, 8)] + ["panda_rightfinger"]
    for _ in range(3):
        q = rng.uniform(-2.5, 2.5, 7)
        pin.framesForwardKinematics(model, data, q)
        expected = [np.zeros(3)] + [data.oMf[model.getFrameId(name)].translation for name in links]
        np.testing.assert_allclose(geometry.pose(scene, loaded, q).skeleton, expected, rtol=0, atol=1e-12)


def test_panda_limits_are_kept_as_data(panda):
    robot, _ = panda
    model = pin.buildModelFromUrdf(str(panda_urdf()))
    lower, upper, effort, velocity = zip(*(j.limit for j in robot.joints))
    np.testing.assert_array_equal(lower, model.lowerPositionLimit[:7])
    np.testing.assert_array_equal(upper, model.upperPositionLimit[:7])
    np.testing.assert_array_equal(effort, model.effortLimit[:7])
    np.testing.assert_array_equal(velocity, model.velocityLimit[:7])


# panda_link4 ends at joint 5, which sits off the link's axes: the beam runs along that offset.
ELBOW = np.array([-0.0825, 0.384, 0.0])
L4 = float(np.linalg.norm(ELBOW))
TUBE = {"D": 0.08, "d": 0.07, "rho": 2700.0}
FLEXIBLE = f"""
schema = 1
name = "panda_beam"
nrfe = {{nrfe}}
urdf = {{{{ package = "example-robot-data", file = "{PANDA_FILE}", tip = "panda_hand" }}}}

[[chain]]
link = "panda_link4"
flexible = "4"
along = [{float(ELBOW[0] / L4)!r}, {float(ELBOW[1] / L4)!r}, 0]
length = {L4!r}
section = {{{{ type = "tube", outer_diameter = {TUBE['D']}, inner_diameter = {TUBE['d']} }}}}
density = {TUBE['rho']}
young_modulus = 7e10
shear_modulus = 2.6e10

[[chain]]
link = "panda_hand"
point = "C"
position = [0, 0, "h"]

[parameters]
h = 0.1
"""


def tube_inertia():
    """The beam of FLEXIBLE as one rigid tube: mass, centre and inertia about it in link 4's frame."""
    D, d, rho = TUBE["D"], TUBE["d"], TUBE["rho"]
    mass = rho * np.pi * (D**2 - d**2) / 4 * L4
    rotary = rho * np.pi * (D**4 - d**4) / 64 * L4     # ∫y² dm = ∫z² dm over the tube
    a = ELBOW / L4
    transverse = mass * L4**2 / 12 + rotary
    inertia = transverse * (np.eye(3) - np.outer(a, a)) + 2 * rotary * np.outer(a, a)
    return pin.Inertia(mass, a * L4 / 2, inertia)


def test_flexible_link_replaces_the_link(panda, env, rng, tmp_path):
    """panda_link4 made a tube at n_rfe 1 (one rigid rfe): M, f and every frame are Pinocchio's
    with link 4's inertial replaced by the tube's, so the beam starts at the link's frame, runs
    along the given direction, and the rest of the arm hangs at its tip. A point attached to
    panda_hand (fixed to link 7, so no body of its own) sits in the hand's frame."""
    path = tmp_path / "beam.toml"
    path.write_text(FLEXIBLE.format(nrfe=1))
    flexible = gpmegen.load(model=load_model_file(path), directory=env[0], backend="numpy")
    assert flexible.coordinates == panda[1].coordinates
    model = pinocchio_panda()
    model.inertias[model.getJointId("panda_joint4")] = tube_inertia()
    data = model.createData()
    for _ in range(3):
        q, qd = rng.uniform(-2, 2, 7), rng.uniform(-2, 2, 7)
        M = pin.crba(model, data, q)
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(flexible.mass_matrix(q), M, rtol=0, atol=1e-10 * np.abs(M).max())
        nle = pin.rnea(model, data, q, qd, np.zeros(7)) + model.damping * qd
        np.testing.assert_allclose(flexible.forces(0.0, q, qd), -nle, rtol=0, atol=1e-10 * np.abs(nle).max())
        pin.framesForwardKinematics(model, data, q)
        hand = data.oMf[model.getFrameId("panda_hand")]
        expected = [data.oMf[model.getFrameId(name)].translation if name != "C" else hand.act(np.array([0, 0, 0.1]))
                    for name in flexible.points]
        assert "C" in flexible.points
        np.testing.assert_allclose(flexible.point_positions(q), expected, rtol=0, atol=1e-12)


BAD = {
    "loop": ("""<robot name="r"><link name="a"/><link name="b"><inertial><mass value="1"/>
<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="j1" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint>
<joint name="j2" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/></joint></robot>""",
             'link name="b"> is the child of both <joint name="j1"> and <joint name="j2">, a closed loop'),
    "floating": ("""<robot name="r"><link name="a"/><link name="b"/>
<joint name="free" type="floating"><parent link="a"/><child link="b"/></joint></robot>""",
                 '<joint name="free"> is floating: a floating base is not a chain fixed to the world'),
    "planar": ("""<robot name="r"><link name="a"/><link name="b"/>
<joint name="slide" type="planar"><parent link="a"/><child link="b"/></joint></robot>""",
               '<joint name="slide"> is planar'),
    "unknown type": ("""<robot name="r"><link name="a"/><link name="b"/>
<joint name="j" type="spherical"><parent link="a"/><child link="b"/></joint></robot>""",
                     "<joint name=\"j\"> has the unknown type 'spherical'; use one of revolute, continuous"),
    "no inertial": ("""<robot name="r"><link name="a"/><link name="b"/>
<joint name="j" type="continuous"><parent link="a"/><child link="b"/></joint></robot>""",
                    '<link name="b">, moved by <joint name="j">, has no <inertial>'),
    "parse error": ("""<robot name="r"><link name="a"><inertial></link></robot>""",
                    ":1: the URDF is not well-formed XML"),
    "unknown link": ("""<robot name="r"><link name="a"/>
<joint name="j" type="revolute"><parent link="a"/><child link="arm"/></joint></robot>""",
                     "<joint name=\"j\"> names the child link 'arm', which the file does not define"),
    "bad name": ("""<robot name="r"><link name="a"/><link name="b-2"><inertial><mass value="1"/>
<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="j" type="revolute"><parent link="a"/><child link="b-2"/><axis xyz="0 0 1"/></joint></robot>""",
                 "<link name=\"b-2\">: point 'b-2' is not a valid name"),
    "branching": ("""<robot name="r"><link name="a"/><link name="b"><inertial><mass value="1"/>
<inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link><link name="c"><inertial>
<mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="j1" type="revolute"><parent link="a"/><child link="b"/></joint>
<joint name="j2" type="revolute"><parent link="a"/><child link="c"/></joint></robot>""",
                  '<link name="a"> branches into the moving joints \'j1\' and \'j2\''),
}


@pytest.mark.parametrize("case", list(BAD))
def test_bad_urdf_one_line(case, tmp_path, capsys):
    text, message = BAD[case]
    path = tmp_path / "robot.urdf"
    path.write_text(text)
    with pytest.raises(ModelError) as info:
        read_model_file(path)
    assert message in str(info.value) and "\n" not in str(info.value)
    assert main(["build", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert message in err and len(err.splitlines()) == 1 and "Traceback" not in err


TOML_FAULTS = {
    "missing link": (('"panda_link4"', '"panda_link44"'),
                     r"beam.toml:8: chain\[0\].link: the URDF panda.urdf has no link 'panda_link44'"),
    "missing tip": (('tip = "panda_hand"', 'tip = "hand"'), r"beam.toml:5: urdf.tip: the URDF panda.urdf has no link "
                                                            r"'hand'"),
    "not installed": (('package = "example-robot-data"', 'package = "no-such-distribution"'),
                      r"beam.toml:5: urdf.package: .*'no-such-distribution', which is not installed; install it"),
    "direction": (("along = [", "along = [1, 1, 0]  # ["), r"beam.toml:10: chain\[0\].along: .*not a unit vector"),
    "twice": (("[[chain]]", '[[chain]]\nlink = "panda_link4"\nflexible = "x"\nalong = [1, 0, 0]\nlength = 0.1\n'
                            'section = { type = "circular", radius = 0.01 }\ndensity = 1\nyoung_modulus = 1\n'
                            'shear_modulus = 1\n[[chain]]'),
              r"chain\[1\].link: link 'panda_link4' is made flexible twice"),
}


@pytest.mark.parametrize("fault", list(TOML_FAULTS))
def test_model_file_urdf_faults(fault, tmp_path, capsys):
    """A model file's faults about its URDF, at their line, from the API and the command line."""
    panda_urdf()
    (old, new), message = TOML_FAULTS[fault]
    text = FLEXIBLE.format(nrfe=2)
    assert old in text
    path = tmp_path / "beam.toml"
    path.write_text(text.replace(old, new, 1))
    with pytest.raises(ModelError, match=message) as info:
        load_model_file(path)
    assert "\n" not in str(info.value)
    assert main(["build", str(path), "--out", str(tmp_path / "out")]) == 2
    err = capsys.readouterr().err.strip()
    assert len(err.splitlines()) == 1 and "Traceback" not in err


def test_serial_urdf_builds_from_the_command_line(tmp_path, env, capsys):
    """A serial URDF (fixed joints merged, a continuous and a prismatic joint) builds as it
    stands; its model holds the URDF's coordinates and one point per link."""
    path = tmp_path / "two.urdf"
    path.write_text("""<robot name="two"><link name="base"/>
<link name="arm"><inertial><origin xyz="0.2 0 0" rpy="0 0.3 0"/><mass value="2"/>
<inertia ixx="0.01" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
<link name="slider"><inertial><mass value="0.5"/>
<inertia ixx="0.001" iyy="0.001" izz="0.001" ixy="0" ixz="0" iyz="0"/></inertial></link>
<link name="tool"><inertial><mass value="0.1"/>
<inertia ixx="0.0001" iyy="0.0001" izz="0.0001" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="turn" type="continuous"><parent link="base"/><child link="arm"/><axis xyz="0 0 1"/>
<origin xyz="0 0 0.5"/></joint>
<joint name="push" type="prismatic"><parent link="arm"/><child link="slider"/><axis xyz="0.6 0.8 0"/>
<origin xyz="0.4 0 0" rpy="0.1 0.2 0.3"/><limit lower="0" upper="0.2" effort="10" velocity="1"/></joint>
<joint name="weld" type="fixed"><parent link="slider"/><child link="tool"/><origin xyz="0.1 0 0"/></joint>
</robot>""")
    out = tmp_path / "built"
    assert main(["build", str(path), "--out", str(out)]) == 0
    model = load_model_file(path)
    flat = expand(model)
    assert flat.coordinates == ("turn", "push")
    assert flat.points == ("base", "arm", "slider", "tool")
    full = pin.buildModelFromUrdf(str(path))
    data = full.createData()
    loaded = gpmegen.load(model=model, directory=env[0], backend="numpy")
    q = np.array([0.7, 0.05])
    configuration = np.array([np.cos(q[0]), np.sin(q[0]), q[1]])   # Pinocchio's continuous joint: (cos, sin)
    M = pin.crba(full, data, configuration)
    M = np.triu(M) + np.triu(M, 1).T
    np.testing.assert_allclose(loaded.mass_matrix(q), M, rtol=0, atol=1e-12)
    pin.framesForwardKinematics(full, data, configuration)
    expected = [data.oMf[full.getFrameId(name)].translation for name in flat.points]
    np.testing.assert_allclose(loaded.point_positions(q), expected, rtol=0, atol=1e-12)


def test_flexible_panda_example_holds_its_circle(env, tmp_path):
    """The example built at n_rfe 2 and run for 0.05 s from its constrained statics: the start
    is at rest and balanced (no acceleration of any coordinate), the tool centre point stays on
    the circle and the wrist joints where they were held (the constraint residuals and the
    coordinates), and the arm moves."""
    panda_urdf()
    out = tmp_path / "panda.npz"
    assert main(["simulate", str(ROOT / "examples" / "panda_flexible.toml"), "--nrfe", "2", "--t-end", "0.05",
                 "--dt", "1e-4", "--save-every", "25", "--statics", "constrained", "--backend", "numpy",
                 "--out", str(out)]) == 0
    with np.load(out) as r:
        coordinates = [str(c) for c in r["coordinates"]]
        q, qd, qdd = r["q"], r["qd"], r["qdd"]
        phi = r["phi"]
    assert np.abs(phi).max() < 1e-8
    assert np.abs(qd[0]).max() == 0.0 and np.abs(qdd[0]).max() < 1e-6
    held = [coordinates.index(f"panda_joint{k}") for k in (3, 5, 6, 7)]
    np.testing.assert_allclose(q[:, held], [[0.0, 0.0, 1.571, 0.785]] * len(q), rtol=0, atol=1e-12)
    assert np.abs(q[-1] - q[0]).max() > 1e-4
    model = load_model_file(ROOT / "examples" / "panda_flexible.toml")
    assert geometry.tool_point(model, point_constraints(model)) == "panda_hand_tcp"  # where the skeleton ends
