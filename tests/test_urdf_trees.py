"""URDF trees imported whole, against Pinocchio's own URDF reader on branched robots of
``example-robot-data`` (real robot descriptions from the package index, not copied here):
Solo-12 (a base and four legs, 12 joints), Baxter (a torso, two arms and their grippers, 19
joints: revolute and prismatic) and the reduced iCub (legs, torso, arms, 29 joints). Joints are
mapped by name, as Pinocchio orders its coordinates its own way. M, the velocity terms (the
URDF's dampers included) and the gravity terms at random states to 1e-10 relative, every link's
frame, and ``q̈`` of the unconstrained tree from the C backend's O(n) recursion against
``pinocchio.aba``, all from one C build per robot (the iCub's, minutes, is marked long), and
the skeleton drawn branch by branch. Then a flexible link in a URDF tree, with two branches on
its tip: the branches hang from the beam's tip whichever comes first in the file, the C
recursion agrees with the dense solves, and the tree exported to URDF reads back as itself.
"""

from __future__ import annotations

import dataclasses
from importlib import metadata
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.figures import arm_geometry as geometry
from gpmegen.analysis.run.model_files import load_model_file
from gpmegen.errors import ModelWarning
from gpmegen.model.chain import Branch, FlexibleLink, RectangularSection
from gpmegen.model.expand import expand
from gpmegen.model.rfem import discretize
from gpmegen.model.urdf import FlexibleUrdfLink, import_urdf

pin = pytest.importorskip("pinocchio")

REL_TOL = 1e-10
ROBOTS = {
    "solo12": "robots/solo_description/robots/solo12.urdf",
    "baxter": "robots/baxter_description/urdf/baxter.urdf",
    "icub": "robots/icub_description/robots/icub_reduced.urdf",
}
LONG = {"icub", "baxter"}   # their derivations and C builds take 10 s to minutes: make check-c


def robot_file(key: str) -> Path:
    try:
        files = metadata.files("example-robot-data") or []
    except metadata.PackageNotFoundError:
        pytest.skip("example-robot-data is not installed (pip install -e .[test])")
    return Path(next(f for f in files if str(f).endswith(ROBOTS[key])).locate())


def _relative(a, b):
    return float(np.max(np.abs(a - b)) / np.max(np.abs(b)))


@pytest.fixture(scope="module", params=[pytest.param(key, marks=(pytest.mark.long,) if key in LONG else ())
                                        for key in ROBOTS])
def robot(request, env):
    """``(imported robot, C model of the tree without its mimic constraints, Pinocchio model,
    index of each coordinate in Pinocchio's q)``."""
    path = robot_file(request.param)
    imported = import_urdf(path)
    tree = dataclasses.replace(imported.model, name=f"tree_{request.param}", constraints=(), dependent=None)
    loaded = gpmegen.load(model=tree, directory=env[0], backend="c")
    model = pin.buildModelFromUrdf(str(path))
    assert model.nq == model.nv == len(imported.joints)   # no continuous joint: one q entry each
    index = np.array([model.idx_vs[model.getJointId(j.name)] for j in imported.joints])
    return imported, loaded, model, index


def _states(n, rng, count=4):
    for _ in range(count):
        yield rng.uniform(-1.5, 1.5, n), rng.uniform(-2.0, 2.0, n)


def test_a_tree_is_imported_whole_depth_first(robot):
    """Every moving joint is a coordinate, in depth-first file order (each joint after the one it
    hangs from, a joint's subtree before its next sibling), and the model branches."""
    imported, loaded, model, index = robot
    tree = imported.tree
    moving = [j.name for j in tree.joints if j.type != "fixed"]
    assert sorted(j.name for j in imported.joints) == sorted(moving)
    expected, todo = [], list(reversed(tree.children(tree.root)))
    while todo:
        joint = todo.pop()
        expected += [joint.name] if joint.type != "fixed" else []
        todo += reversed(tree.children(joint.child))
    assert [j.name for j in imported.joints] == expected
    topology = expand(imported.model).topology
    assert not topology.is_serial and any(isinstance(e, Branch) for e in imported.model.chain)
    # the parent of each coordinate is the one Pinocchio reads from the URDF
    parents = [model.parents[model.getJointId(j.name)] for j in imported.joints]
    assert [model.names[p] if p else None for p in parents] == [
        imported.joints[p].name if p >= 0 else None for p in topology.parent]


def test_a_tree_agrees_with_pinocchio(robot, rng):
    """M against crba, the gravity and velocity parts of f against rnea (the dampers as
    ``-d q̇``), the links' frames against Pinocchio's, q̈ of the C recursion against aba."""
    imported, loaded, model, index = robot
    data = model.createData()
    n = len(index)
    damping = model.damping[index]
    points = [p for p in loaded.points if model.existFrame(p)]
    assert len(points) >= n
    for q, qd in _states(n, rng):
        qp, qdp = np.empty(n), np.empty(n)
        qp[index], qdp[index] = q, qd
        M = pin.crba(model, data, qp)
        M = (np.triu(M) + np.triu(M, 1).T)[np.ix_(index, index)]
        assert _relative(loaded.mass_matrix(q), M) <= REL_TOL
        gravity = pin.computeGeneralizedGravity(model, data, qp)[index]
        velocity = pin.rnea(model, data, qp, qdp, np.zeros(n))[index] - gravity
        at_rest = loaded.forces(0.0, q, np.zeros(n))
        assert _relative(at_rest, -gravity) <= REL_TOL
        assert _relative(loaded.forces(0.0, q, qd) - at_rest, -velocity - damping * qd) <= REL_TOL
        tau = np.empty(n)
        tau[index] = -damping * qd
        expected = pin.aba(model, data, qp, qdp, tau)[index]
        assert _relative(loaded.accelerations(0.0, q, qd), expected) <= REL_TOL
        pin.framesForwardKinematics(model, data, qp)
        rows = [loaded.points.index(p) for p in points]
        frames = np.array([data.oMf[model.getFrameId(p)].translation for p in points])
        np.testing.assert_allclose(loaded.point_positions(q)[rows], frames, rtol=0, atol=1e-12)


def _flexible_tree_urdf(path: Path, swapped: bool) -> Path:
    """A revolute base, a link ``arm`` with two hands on revolute joints at its far end (``j1``
    then ``j2`` in the file, or the other way round) and a fixed sensor link."""
    inertial = ('<inertial><origin xyz="{}" rpy="0 0.2 0"/><mass value="{}"/>'
                '<inertia ixx="0.002" iyy="0.003" izz="0.004" ixy="0.0001" ixz="0" iyz="0"/></inertial>')
    hands = ['<joint name="j1" type="revolute"><parent link="arm"/><child link="hand1"/>'
             '<origin xyz="0.6 0.1 0" rpy="0 0 0.3"/><axis xyz="0 0 1"/></joint>',
             '<joint name="j2" type="revolute"><parent link="arm"/><child link="hand2"/>'
             '<origin xyz="0.6 -0.1 0.05" rpy="0.2 0 0"/><axis xyz="0 1 0"/></joint>']
    text = f"""<robot name="fork">
<link name="base"/>
<link name="arm">{inertial.format("0.3 0 0", 2.0)}</link>
<link name="hand1">{inertial.format("0.1 0 0", 0.5)}</link>
<link name="hand2">{inertial.format("0.05 0.02 0", 0.7)}</link>
<link name="sensor">{inertial.format("0 0 0", 0.1)}</link>
<joint name="j0" type="revolute"><parent link="base"/><child link="arm"/>
<origin xyz="0 0 0.2" rpy="0 0 0"/><axis xyz="0 0 1"/></joint>
{"".join(reversed(hands) if swapped else hands)}
<joint name="fix" type="fixed"><parent link="arm"/><child link="sensor"/><origin xyz="0.6 0 0.1"/></joint>
</robot>"""
    path.write_text(text)
    return path


def _flexible_fork(path: Path, swapped: bool):
    beam = FlexibleLink("a", 0.6, RectangularSection(0.04, 0.01), density=2700.0, young_modulus=7e10,
                        shear_modulus=2.6e10, n_rfe=3, damping=(0.02, 0.02, 0.02))
    robot = import_urdf(_flexible_tree_urdf(path, swapped), flexible=(FlexibleUrdfLink("arm", (1, 0, 0), beam),))
    return dataclasses.replace(robot.model, name="fork_swapped" if swapped else "fork")


@pytest.fixture(scope="module")
def forks(env, tmp_path_factory):
    folder = tmp_path_factory.mktemp("forks")
    return [gpmegen.load(model=_flexible_fork(folder / f"fork{k}.urdf", bool(k)), directory=env[0], backend="numpy")
            for k in (0, 1)]


def test_branches_on_a_flexible_link_hang_from_its_tip(tmp_path):
    """The first hand continues after the beam; the second starts from the point ``arm_tip``,
    which the beam's tip carries, and the sensor is fixed there too."""
    chain = _flexible_fork(tmp_path / "fork.urdf", False).chain
    beam = next(k for k, e in enumerate(chain) if isinstance(e, FlexibleLink))
    names = [getattr(e, "name", None) for e in chain]
    assert names.index("arm_tip") > beam and Branch("arm_tip") in chain
    assert chain.index(Branch("arm_tip")) > names.index("j1")
    flat = expand(_flexible_fork(tmp_path / "fork.urdf", False))
    sdes = [part.name for part in discretize(chain[beam]) if hasattr(part, "kind")]
    last = flat.coordinates.index(sdes[-1])
    assert flat.topology.parent[flat.coordinates.index("j1")] == last
    assert flat.topology.parent[flat.coordinates.index("j2")] == last


def test_the_order_of_a_flexible_links_branches_in_the_file_changes_nothing(forks, rng):
    """The same tree with its two hands in the other order: the same motion, coordinates and
    points matched by name, at deformed states (a branch that hung from the beam's root would
    not follow its bending)."""
    first, second = forks
    order = [second.coordinates.index(name) for name in first.coordinates]
    rows = [second.points.index(name) for name in first.points]
    assert order != list(range(len(order)))
    n = first.n_dof
    for _ in range(4):
        q, qd = 0.3 * rng.standard_normal(n), rng.standard_normal(n)
        q2, qd2 = np.empty(n), np.empty(n)
        q2[order], qd2[order] = q, qd
        np.testing.assert_allclose(second.point_positions(q2)[rows], first.point_positions(q), rtol=0, atol=1e-12)
        assert _relative(second.mass_matrix(q2)[np.ix_(order, order)], first.mass_matrix(q)) <= REL_TOL
        assert _relative(second.accelerations(0.0, q2, qd2)[order], first.accelerations(0.0, q, qd)) <= REL_TOL


@pytest.mark.requires_cc
def test_a_flexible_urdf_tree_agrees_with_the_dense_solves(forks, env, tmp_path, rng):
    """The C recursion on the flexible tree against the dense C solve and the NumPy backend."""
    c_model = gpmegen.load(model=_flexible_fork(tmp_path / "fork.urdf", False), directory=env[0], backend="c")
    n = c_model.n_dof
    for _ in range(4):
        q, qd = 0.3 * rng.standard_normal(n), rng.standard_normal(n)
        recursive = c_model.accelerations(0.0, q, qd)
        for reference in (c_model.motion(0.0, q, qd)[0], forks[0].accelerations(0.0, q, qd)):
            assert _relative(recursive, reference) <= 1e-9


def _drawn_segments(lines) -> set:
    """The segments of lines with NaN rows between them, each as a pair of rounded end points."""
    segments = set()
    for a, b in zip(lines[:-1], lines[1:]):
        if np.isfinite(a).all() and np.isfinite(b).all():
            segments.add(frozenset((tuple(np.round(a, 9)), tuple(np.round(b, 9)))))
    return segments


def test_the_skeleton_of_a_tree_joins_each_body_to_its_parent(robot, rng):
    """Each body's frame (its link's, from Pinocchio) is joined to the frame of the nearest link
    above it in the URDF that carries a body (the base when none does), the tool point to its
    link's body; no other segment, so none joins two branches."""
    imported, loaded, model, index = robot
    scene = geometry.scene(imported.model, loaded)
    names = {new: old for kind, old, new in imported.renamed if kind == "link"}
    link_of = {body: names.get(body.removesuffix("_body"), body.removesuffix("_body")) for body in scene.bodies}
    with_body = {link: body for body, link in link_of.items()}
    parent = {j.child: j.parent for j in imported.tree.joints}

    def carrier(link):   # the nearest link above ``link`` that carries a body; None: the base
        link = parent.get(link)
        while link is not None and link not in with_body:
            link = parent.get(link)
        return link

    tool = scene.points[scene.tool]
    tool_link = names.get(tool, tool)
    tool_body = tool_link if tool_link in with_body else carrier(tool_link)
    data = model.createData()
    n = len(index)
    for _ in range(2):
        q = rng.uniform(-1.5, 1.5, n)
        qp = np.empty(n)
        qp[index] = q
        pin.framesForwardKinematics(model, data, qp)

        def at(link):
            return np.zeros(3) if link is None else data.oMf[model.getFrameId(link)].translation

        expected = {frozenset((tuple(np.round(at(link), 9)), tuple(np.round(at(carrier(link)), 9))))
                    for link in link_of.values()}
        expected.add(frozenset((tuple(np.round(at(tool_link), 9)), tuple(np.round(at(tool_body), 9)))))
        assert _drawn_segments(geometry.pose(scene, loaded, q).lines) == expected


def test_a_tree_exported_to_urdf_imports_as_the_same_tree(forks, env, tmp_path, rng):
    """The flexible fork (rfes, sdes with their springs, a branch from the beam's tip) written
    as URDF and read back: the same coordinates, M and f, matched by name."""
    from gpmegen.model.urdf_export import urdf_text

    first = forks[0]
    path = tmp_path / "exported.urdf"
    path.write_text(urdf_text(_flexible_fork(tmp_path / "fork.urdf", False)))
    back = import_urdf(path)
    assert any(isinstance(e, Branch) for e in back.model.chain)
    again = gpmegen.load(model=dataclasses.replace(back.model, name="fork_again"), directory=env[0], backend="numpy")
    assert sorted(again.coordinates) == sorted(first.coordinates)
    order = [again.coordinates.index(name) for name in first.coordinates]
    n = first.n_dof
    for _ in range(4):
        q, qd = 0.3 * rng.standard_normal(n), rng.standard_normal(n)
        q2, qd2 = np.empty(n), np.empty(n)
        q2[order], qd2[order] = q, qd
        assert _relative(again.mass_matrix(q2)[np.ix_(order, order)], first.mass_matrix(q)) <= REL_TOL
        assert _relative(again.forces(0.0, q2, qd2)[order], first.forces(0.0, q, qd)) <= REL_TOL


FORK_FILE = """
schema = 1
name = "fork_file"
urdf = "fork.urdf"

[[chain]]
link = "arm"
flexible = "a"
along = [1, 0, 0]
length = 0.6
section = { type = "rectangular", width = 0.04, thickness = 0.01 }
density = 2700.0
young_modulus = 7e10
shear_modulus = 2.6e10
nrfe = 3
damping = [0.02, 0.02, 0.02]
"""


def test_a_model_file_imports_the_tree_whole(tmp_path):
    """A model file naming the fork's URDF without ``tip``, its arm made flexible by a
    ``[[chain]]`` table: the same chain as the import from Python, branches included."""
    _flexible_tree_urdf(tmp_path / "fork.urdf", False)
    (tmp_path / "fork.toml").write_text(FORK_FILE)
    model = load_model_file(tmp_path / "fork.toml")
    assert model.chain == _flexible_fork(tmp_path / "fork.urdf", False).chain


def test_a_base_link_named_ground_is_renamed_when_branches_start_from_it(tmp_path):
    """Branches from the base start from its link's point, and a branch reads ``ground`` as the
    base frame: a base link of that name is renamed (with the warning of renamed names), and
    the model expands with two branches from it."""
    inertial = '<inertial><mass value="1"/><inertia ixx="1" iyy="1" izz="1" ixy="0" ixz="0" iyz="0"/></inertial>'
    path = tmp_path / "two.urdf"
    path.write_text(f"""<robot name="two"><link name="ground"/><link name="b">{inertial}</link>
<link name="c">{inertial}</link>
<joint name="j1" type="revolute"><parent link="ground"/><child link="b"/><axis xyz="0 0 1"/></joint>
<joint name="j2" type="revolute"><parent link="ground"/><child link="c"/><origin xyz="1 0 0"/></joint></robot>""")
    with pytest.warns(ModelWarning, match="link 'ground' -> ground_2"):
        robot = import_urdf(path)
    assert Branch("ground_2") in robot.model.chain
    assert expand(robot.model).topology.parent == (-1, -1)


@pytest.mark.long
def test_the_two_armed_baxter_with_flexible_upper_arms_lifts_both_hands(env, tmp_path):
    """``examples/baxter_flexible.toml``: Baxter imported whole, each upper arm a flexible tube,
    both hands lifted together by their own shoulders and elbows, built at n_rfe 2 and run for
    0.1 s from its constrained statics: the start is at rest and balanced, both hands keep their
    x and y and rise along the law, the held joints stay where they were held, and both tubes bend
    (the elastic coordinates of each arm move)."""
    from gpmegen.cli import main

    robot_file("baxter")
    example = Path(__file__).resolve().parents[1] / "examples" / "baxter_flexible.toml"
    out = tmp_path / "baxter.npz"
    assert main(["simulate", str(example), "--nrfe", "2", "--t-end", "0.1", "--dt", "1e-4", "--save-every", "50",
                 "--statics", "constrained", "--backend", "numpy", "--out", str(out)]) == 0
    model = load_model_file(example, nrfe=2)
    values = {p.name: float(p.default) for p in model.parameters}
    loaded = gpmegen.load(model=model, backend="numpy")
    with np.load(out) as r:
        coordinates = [str(c) for c in r["coordinates"]]
        t, q, qd, qdd, phi = r["t"], r["q"], r["qd"], r["qdd"], r["phi"]
    assert np.abs(phi).max() < 1e-8
    assert np.abs(qd[0]).max() == 0.0 and np.abs(qdd[0]).max() < 1e-6
    lift = values["H"] * (1 - np.cos(np.pi * t / values["T"])) ** 2 / 4
    points = list(loaded.points)
    for side in ("left", "right"):
        hand = np.array([loaded.point_positions(qk)[points.index(f"{side}_gripper")] for qk in q])
        start = [values[f"{c}{side[0]}"] for c in "xyz"]
        np.testing.assert_allclose(hand, np.column_stack([np.full_like(t, start[0]), np.full_like(t, start[1]),
                                                          start[2] + lift]), rtol=0, atol=1e-8)
        held = [coordinates.index(f"{side}_{j}") for j in ("e0", "w0", "w1", "w2")]
        np.testing.assert_allclose(q[:, held], [[values[f"{side[0]}{j}"] for j in ("e0", "w0", "w1", "w2")]] * len(q),
                                   rtol=0, atol=1e-12)
        elastic = [k for k, name in enumerate(coordinates) if name.endswith(f"{side[0].upper()}_1")]
        assert elastic and np.abs(q[-1, elastic] - q[0, elastic]).max() > 1e-7
    assert lift[-1] > 5e-5   # m: the hands rose, by 60 µm at 0.1 s
