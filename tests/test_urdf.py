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
from gpmegen.analysis.figures import arm_geometry as geometry
from gpmegen.analysis.post.driving import point_constraints
from gpmegen.analysis.run.model_files import load_model_file, read_model_file
from gpmegen.cli import main
from gpmegen.errors import ModelError
from gpmegen.model.expand import expand
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
}


def one_joint(inertia="1 1 1 0 0 0", mass="1", origin='xyz="0 0 0.1" rpy="0 0 0"', axis="0 0 1", inertial_origin="",
              extra=""):
    """A URDF of one revolute joint moving link b, with the values given (inertia: ixx iyy izz ixy
    ixz iyz)."""
    tensor = " ".join(f'{key}="{value}"' for key, value in zip(("ixx", "iyy", "izz", "ixy", "ixz", "iyz"),
                                                                inertia.split()))
    return (f'<robot name="r"><link name="a"/><link name="b"><inertial>{inertial_origin}<mass value="{mass}"/>'
            f'<inertia {tensor}/></inertial></link><joint name="j" type="revolute"><parent link="a"/>'
            f'<child link="b"/><origin {origin}/><axis xyz="{axis}"/>{extra}</joint></robot>')


# Values no body has and values that are no numbers: refused when the URDF is read (they were
# built, and ran silently or ended in "internal error: LinAlgError" or "ValueError").
BAD.update({
    "indefinite inertia": (one_joint("1 1 1 2 0 0"), '<link name="b"> <inertia> is not positive semi-definite: '
                                                     'its principal moments are -1, 1, 3 kg·m²'),
    "negative principal inertia": (one_joint("-1 1 1 0 0 0"), '<link name="b"> <inertia> is not positive '
                                                              'semi-definite: its principal moments are -1, 1, 1'),
    "triangle inequality": (one_joint("1 1 3 0 0 0"), '<link name="b"> <inertia> breaks the triangle inequality of '
                                                      'principal moments: 1 + 1 < 3 kg·m²'),
    "every link massless": (one_joint("0 0 0 0 0 0", mass="0"), "every link of the chain is massless"),
    "nan in origin xyz": (one_joint(origin='xyz="0 nan 0.1"'), '<joint name="j"> <origin xyz> is \'0 nan 0.1\', '
                                                               'not three finite numbers'),
    "inf in origin rpy": (one_joint(origin='xyz="0 0 0" rpy="0 inf 0"'), '<joint name="j"> <origin rpy> is '
                                                                         '\'0 inf 0\', not three finite numbers'),
    "nan in axis": (one_joint(axis="0 nan 1"), '<joint name="j"> <axis xyz> is \'0 nan 1\', not three finite numbers'),
    "nan in inertial origin": (one_joint(inertial_origin='<origin xyz="nan 0 0"/>'),
                               '<link name="b"> <inertial> <origin xyz> is \'nan 0 0\', not three finite numbers'),
    "inf mass": (one_joint(mass="inf"), '<link name="b"> <inertial> <mass value> is inf, not a finite number'),
    "nan inertia": (one_joint("nan 1 1 0 0 0"), '<link name="b"> <inertial> <inertia> holds a value that is not a '
                                                'finite number'),
    "nan limit": (one_joint(extra='<limit lower="-1" upper="1" effort="1" velocity="nan"/>'),
                  '<joint name="j"> <limit velocity> is nan, not a finite number'),
    "nan mimic": (one_joint(extra='<mimic joint="j" multiplier="nan"/>'),
                  '<joint name="j"> <mimic multiplier> is \'nan\', not a finite number'),
    "mimic of no joint": (one_joint(extra='<mimic joint="k"/>'),
                          '<joint name="j"> <mimic joint="k"> names a joint the file does not define'),
    "mimic loop": (one_joint(extra='<mimic joint="j"/>'), 'the joints j -> j mimic each other round a loop'),
})


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


def test_a_chain_of_1500_fixed_joints_is_read(tmp_path):
    """1,500 fixed joints in a row before the one revolute joint (it ended in "internal error:
    RecursionError"): read without recursion, every link a point, the joint where the fixed
    joints put it (1 mm each), and one after it."""
    n = 1500
    links = "".join(f'<link name="l{k}"/>' for k in range(n + 1))
    fixed = "".join(f'<joint name="f{k}" type="fixed"><parent link="l{k}"/><child link="l{k + 1}"/>'
                    f'<origin xyz="0 0 0.001"/></joint>' for k in range(n))
    path = tmp_path / "tall.urdf"
    path.write_text(f'<robot name="tall">{links}<link name="arm"><inertial><mass value="1"/><inertia ixx="1" iyy="1" '
                    f'izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>{fixed}<joint name="j" type="revolute">'
                    f'<parent link="l{n}"/><child link="arm"/><axis xyz="0 1 0"/></joint></robot>')
    flat = expand(load_model_file(path))
    assert flat.coordinates == ("j",)
    assert flat.points == tuple(f"l{k}" for k in range(n + 1)) + ("arm",)
    robot = import_urdf(path)
    offsets = [e for e in robot.model.chain if type(e).__name__ == "Offset"]
    assert len(offsets) == 1 and offsets[0].translation == pytest.approx((0, 0, n * 0.001), abs=1e-12)


RENAMED = """<robot name="2dof_planar"><link name="base"/>
<link name="b-2"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
<link name="c"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
<link name="d"><inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="joint_0.0" type="revolute"><parent link="base"/><child link="b-2"/><axis xyz="0 0 1"/></joint>
<joint name="joint_0_0" type="revolute"><parent link="b-2"/><child link="c"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>
</joint>
<joint name="lambda" type="revolute"><parent link="c"/><child link="d"/><origin xyz="1 0 0"/><axis xyz="0 0 1"/>
<limit lower="-1" upper="1" effort="1" velocity="2"/></joint></robot>"""


def test_names_that_cannot_be_code_are_renamed_with_one_warning(tmp_path, capsys):
    """Names that were refused with no way to map them (the Allegro hand's joint_0.0, a robot
    named 2dof_planar) are renamed, deterministically and without meeting another name: the
    characters outside names become _, a name that does not start with a letter or is reserved
    gets its kind in front, a clash gets _2. One warning lists them; the URDF names stay as data."""
    path = tmp_path / "planar.urdf"
    path.write_text(RENAMED)
    expected = (("robot", "2dof_planar", "robot_2dof_planar"), ("joint", "joint_0.0", "joint_0_0_2"),
                ("joint", "lambda", "joint_lambda"), ("link", "b-2", "b_2"))
    with pytest.warns(UserWarning, match="names that cannot stand in generated code renamed: robot '2dof_planar' -> "
                                         "robot_2dof_planar, joint 'joint_0.0' -> joint_0_0_2") as caught:
        robot = import_urdf(path)
    assert len(caught) == 1
    assert robot.renamed == expected
    assert robot.model.name == "robot_2dof_planar"
    assert robot.coordinates == ("joint_0_0_2", "joint_0_0", "joint_lambda")
    assert [j.name for j in robot.joints] == ["joint_0.0", "joint_0_0", "lambda"]
    assert robot.limits["joint_lambda"] == (-1, 1, 2, "rad")
    flat = expand(robot.model)
    assert flat.coordinates == robot.coordinates and flat.points == ("base", "b_2", "c", "d")
    with pytest.warns(UserWarning):
        assert import_urdf(path).renamed == expected   # the same file, the same names
    assert main(["build", str(path), "--out", str(tmp_path / "out")]) == 0
    warned = [line for line in capsys.readouterr().err.splitlines() if "warning" in line]
    assert len(warned) == 1 and warned[0].startswith("gpmegen: warning: ") and "'b-2' -> b_2" in warned[0]


MIMIC = """<robot name="pair"><link name="base"/>
<link name="a"><inertial><origin xyz="0.2 0 0"/><mass value="1"/>
<inertia ixx="0.01" iyy="0.02" izz="0.02" ixy="0" ixz="0" iyz="0"/></inertial></link>
<link name="b"><inertial><origin xyz="0.15 0 0.02"/><mass value="0.5"/>
<inertia ixx="0.005" iyy="0.01" izz="0.01" ixy="0" ixz="0" iyz="0"/></inertial></link>
<joint name="shoulder" type="revolute"><parent link="base"/><child link="a"/><axis xyz="0 1 0"/>
<limit lower="-0.5" upper="0.5" effort="10" velocity="1"/></joint>
<joint name="elbow" type="revolute"><parent link="a"/><child link="b"/><origin xyz="0.4 0 0"/><axis xyz="0 1 0"/>
<mimic joint="shoulder" multiplier="-2" offset="0.1"/></joint></robot>"""


@pytest.fixture(scope="module")
def mimic_pair(env, tmp_path_factory):
    path = tmp_path_factory.mktemp("mimic") / "pair.urdf"
    path.write_text(MIMIC)
    return path, gpmegen.load(model=load_model_file(path), directory=env[0])


def test_a_mimic_joint_follows_its_leader(mimic_pair, rng, tmp_path):
    """<mimic> (imported as an independent joint before): the constraint elbow = -2·shoulder + 0.1,
    held ideally. On it, q̈ is the motion of the one free coordinate, q̈ = B (BᵀMB)⁻¹ Bᵀ f with
    B = (1, -2); a run keeps elbow on its leader's law from the start the file gives."""
    path, loaded = mimic_pair
    model = load_model_file(path)
    assert [(c.name, str(c.expression)) for c in model.constraints] == [("mimic_elbow", "elbow + 2.0*shoulder - 0.1")]
    B = np.array([1.0, -2.0])
    for _ in range(3):
        s, sd = rng.uniform(-1, 1, 2)
        q, qd = np.array([s, -2 * s + 0.1]), B * sd
        M, f = loaded.mass_matrix(q), loaded.forces(0.0, q, qd)
        expected = B * (B @ f) / (B @ M @ B)
        np.testing.assert_allclose(loaded.accelerations(0.0, q, qd), expected, rtol=0,
                                   atol=1e-12 * np.abs(expected).max())
    out = tmp_path / "pair.npz"
    assert main(["simulate", str(path), "--t-end", "0.3", "--dt", "1e-3", "--save-every", "10", "--backend", "numpy",
                 "--out", str(out)]) == 0
    with np.load(out) as r:
        q = r["q"]
    np.testing.assert_allclose(q[:, 1], -2 * q[:, 0] + 0.1, rtol=0, atol=1e-12)
    assert q[0, 1] == pytest.approx(0.1) and np.abs(q[-1, 0]) > 0.1   # it started on the law, and it moved


def test_a_run_past_the_urdf_limits_warns(mimic_pair, tmp_path, capsys):
    """The limits of a URDF do not act, and a run went past them silently (a falling Panda at
    107 rad/s): after the run, one line for each joint and limit exceeded by a saved sample,
    with the limit, the farthest value and its time, and when it first went past."""
    from gpmegen.analysis.post.joint_limits import exceeded

    path, _ = mimic_pair
    out = tmp_path / "fall.npz"
    assert main(["simulate", str(path), "--t-end", "0.5", "--dt", "1e-3", "--save-every", "50", "--backend", "numpy",
                 "--out", str(out)]) == 0
    warned = [line for line in capsys.readouterr().err.splitlines() if "limit" in line]
    with np.load(out) as r:
        t, q, qd = r["t"], r["q"], r["qd"]
    far = np.argmax(np.abs(qd[:, 0]))
    assert np.abs(qd[far, 0]) > 1 and np.abs(q[:, 0]).max() > 0.5
    assert len(warned) == 2, warned
    assert all(line.startswith("gpmegen: warning: shoulder went past its URDF ") for line in warned)
    assert f"velocity limit 1 rad/s: {qd[far, 0]:.6g} rad/s at t = {t[far]:.6g} s" in warned[1]
    first = np.flatnonzero(np.abs(q[:, 0]) > 0.5)[0]
    assert "position limit [-0.5, 0.5] rad" in warned[0] and f"first past it at t = {t[first]:.6g} s" in warned[0]
    # within the limits, or without any, nothing is said
    assert exceeded({"shoulder": (-10.0, 10.0, 100.0, "rad")}, ["shoulder", "elbow"], t, q, qd) == []
    assert exceeded({"shoulder": (None, None, None, "rad")}, ["shoulder", "elbow"], t, q, qd) == []


def test_a_model_file_keeps_the_urdf_limits(tmp_path):
    """A model file naming the Panda's URDF carries its joints' limits to the runs' check."""
    panda_urdf()
    path = tmp_path / "beam.toml"
    path.write_text(FLEXIBLE.format(nrfe=1))
    limits = read_model_file(path).limits
    model = pin.buildModelFromUrdf(str(panda_urdf()))
    for k in range(7):
        name = f"panda_joint{k + 1}"
        assert limits[name] == (model.lowerPositionLimit[k], model.upperPositionLimit[k], model.velocityLimit[k],
                                "rad")


def test_a_model_file_adds_the_mimic_constraints_after_its_own(tmp_path):
    """A model file naming a URDF with a mimic joint: its own constraints first, then the mimic's,
    and the mimic joint added to the dependent coordinates it lists."""
    (tmp_path / "pair.urdf").write_text(MIMIC)
    path = tmp_path / "pair.toml"
    path.write_text('schema = 1\nname = "pair_file"\nurdf = "pair.urdf"\ndependent = ["shoulder"]\n\n[[constraints]]\n'
                    'name = "hold"\nexpression = "z_b - 0.1"\n')
    model = read_model_file(path).model
    assert [c.name for c in model.constraints] == ["hold", "mimic_elbow"]
    assert model.dependent == ("shoulder", "elbow")


def test_a_robot_named_in_the_solver_librarys_c_namespace_is_renamed(tmp_path):
    """A robot's name becomes the model's, the prefix of its C names: 'gpmegen' would declare the
    solver library's names again, so it is renamed as a name that cannot be code is."""
    path = tmp_path / "robot.urdf"
    path.write_text(RENAMED.replace('name="2dof_planar"', 'name="gpmegen"'))
    with pytest.warns(UserWarning, match="robot 'gpmegen' -> robot_gpmegen"):
        robot = import_urdf(path)
    assert robot.model.name == "robot_gpmegen" and expand(robot.model).coordinates == robot.coordinates
