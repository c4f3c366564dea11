"""The generated body transforms: ``T`` agrees with the point positions (a point fixed in a
body's frame sits at ``T_body · [r; 1]``), ``T_i`` and ``T_ij`` agree with central finite
differences of ``T``, on both backends; a transform that was not built is refused in one line
naming the build option, and the option enters the input hash."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

import gpmegen
from gpmegen.codegen.render import input_hash
from gpmegen.errors import BuildError
from gpmegen.model import shapes
from gpmegen.model.chain import Body, FlexibleLink, Joint, Model, Offset, Parameter, Point, RectangularSection
from gpmegen.model.expand import expand
from gpmegen.runtime.loader import BACKENDS

ALL = ("T", "T_i", "T_ij")


def spatial_chain(name="transforms_chain") -> Model:
    """Joints about and along every axis, offsets with rotations, a flexible link (torsion and
    both bendings) and points fixed in the frames of the bodies they follow; the lengths are
    parameters, so that ``T`` depends on ``p`` too."""
    L, a = sp.Symbol("L", real=True), sp.Symbol("a", real=True)
    link = FlexibleLink("2", L, RectangularSection(0.04, 0.01), density=2700.0, young_modulus=7e10,
                        shear_modulus=2.6e10, n_rfe=3)
    chain = (
        Joint("q1", "revolute", "y"),
        Body("base", shapes.solid_cylinder(3.0, 0.05, 0.4, "y")),
        Point("B", (0.02, 0.3, -0.01)),
        Offset((0, a, 0), (("x", 0.3), ("z", -0.7))),
        Joint("q2", "revolute", "z"),
        link,
        Joint("q3", "prismatic", "x"),
        Joint("q4", "revolute", "x"),
        Body("tool", shapes.bar(1.0, 0.2, 0.02, 0.02)),
        Point("E", (0.2, 0.01, 0.03)),
        Offset((0.05, 0, 0.02), (("y", 1.1),)),
        Joint("q5", "prismatic", "z"),
        Body("finger", shapes.point_mass(0.1, (0, 0, 0))),
        Point("F", (-0.03, 0.02, 0.04)),
    )
    return Model(name, (Parameter("L", 0.8, "m"), Parameter("a", 0.5, "m")), chain, gravity=(0, -9.81, 0))


def point_bodies(model: Model) -> dict:
    """Each point fixed in the frame of a body (no joint or offset between them): point -> body."""
    pairs, body = {}, None
    for element in expand(model).elements:
        if isinstance(element, Body):
            body = element.name
        elif isinstance(element, Point) and body is not None:
            pairs[element.name] = (body, np.array([float(v) for v in element.position]))
        else:
            body = None
    return pairs


@pytest.fixture(scope="module", params=["numpy", pytest.param("c", marks=pytest.mark.requires_cc)])
def loaded(request, env):
    return gpmegen.load(model=spatial_chain(), backend=request.param, transforms=ALL)


def states(model, count=3, seed=7):
    rng = np.random.default_rng(seed)
    return [rng.uniform(-1.0, 1.0, model.n_dof) for _ in range(count)]


def test_T_places_the_points_of_each_body(loaded):
    pairs = point_bodies(spatial_chain())
    assert set(pairs) == {"B", "E", "F"}  # every point of the chain is checked
    for q in states(loaded):
        T = loaded.transforms(q)
        assert T.shape == (len(loaded.bodies), 4, 4)
        positions = loaded.point_positions(q)
        for k, point in enumerate(loaded.points):
            body, r = pairs[point]
            placed = T[loaded.bodies.index(body)] @ np.append(r, 1.0)
            np.testing.assert_allclose(placed[:3], positions[k], rtol=0, atol=1e-12)
            assert placed[3] == 1.0
        R = T[:, :3, :3]  # rotations: orthonormal, right-handed; bottom row [0 0 0 1]
        np.testing.assert_allclose(R @ R.transpose(0, 2, 1), np.broadcast_to(np.eye(3), R.shape), atol=1e-12)
        np.testing.assert_allclose(np.linalg.det(R), 1.0, atol=1e-12)
        np.testing.assert_array_equal(T[:, 3], np.broadcast_to([0, 0, 0, 1.0], (len(T), 4)))


def test_bodies_name_the_rfes_and_links(loaded):
    assert loaded.bodies == ("base", "rfe2_0", "rfe2_1", "rfe2_2", "tool", "finger")


def central(f, q, h):
    """Central differences of ``f`` at ``q`` along each coordinate: axis 1 of the result."""
    columns = []
    for i in range(len(q)):
        e = np.zeros(len(q))
        e[i] = h
        columns.append((f(q + e) - f(q - e)) / (2 * h))
    return np.stack(columns, axis=1)


@pytest.mark.parametrize("kind, lower", [("T_i", "T"), ("T_ij", "T_i")])
def test_derivatives_agree_with_central_differences(loaded, kind, lower):
    """The truncation error of a central difference is O(h²) ≈ 1e-8 relative at h = 1e-4, well
    inside 1e-6; a wrong twist or a wrong order of Δ_i Δ_j is off by O(1)."""
    for q in states(loaded, 2):
        exact = loaded.transforms(q, kind)
        numeric = central(lambda x: loaded.transforms(x, lower), q, 1e-4)
        if kind == "T_ij":  # (bodies, i, j, 4, 4): numeric holds d(T_j)/dq_i at [:, i, j]
            np.testing.assert_allclose(exact, exact.transpose(0, 2, 1, 3, 4), rtol=0, atol=1e-13)
        scale = np.abs(exact).max()
        assert scale > 0.1
        np.testing.assert_allclose(exact, numeric, rtol=0, atol=1e-6 * scale)


def test_a_body_does_not_move_with_the_joints_after_it(loaded):
    q = states(loaded, 1)[0]
    Ti = loaded.transforms(q, "T_i")
    base, finger = loaded.bodies.index("base"), loaded.bodies.index("finger")
    assert np.abs(Ti[base, 1:]).max() == 0.0 and np.abs(Ti[base, 0]).max() > 0.1
    assert np.abs(Ti[finger]).max(axis=(1, 2)).min() > 0  # the last body moves with every joint


def test_a_transform_not_built_is_refused_naming_the_option(env):
    model = gpmegen.load(model=spatial_chain("transforms_default"), backend="numpy")
    assert model.transforms_built == ("T",)
    model.transforms(np.zeros(model.n_dof))
    with pytest.raises(BuildError) as refused:
        model.transforms(np.zeros(model.n_dof), "T_ij")
    message = str(refused.value)
    assert "\n" not in message and "--transforms T,T_ij" in message


def test_the_transforms_asked_for_enter_the_input_hash():
    model = spatial_chain()
    hashes = {input_hash(model, BACKENDS, kinds) for kinds in [(), ("T",), ("T", "T_i"), ALL]}
    assert len(hashes) == 4


def test_build_asks_for_the_transforms_on_the_command_line(tmp_path, capsys):
    from gpmegen.cli import main
    from gpmegen.folder import read_manifest

    assert main(["build", "--nrfe", "1", "--out", str(tmp_path), "--transforms", "T_i,T"]) == 0
    manifest = read_manifest(tmp_path / "manipulator_nrfe1")
    assert manifest["transforms"] == ["T", "T_i"] and manifest["bodies"] == ["column", "rfe2_0", "slider"]
    text = (tmp_path / "manipulator_nrfe1" / "model_numpy.py").read_text()
    assert "def transform_derivatives(" in text and "def transform_second_derivatives(" not in text
    assert "--transforms T,T_i" in text  # the command that regenerates it says so
    capsys.readouterr()
    with pytest.raises(SystemExit) as refused:
        main(["build", "--nrfe", "1", "--out", str(tmp_path), "--transforms", "T,T_k"])
    assert refused.value.code == 2
    error = capsys.readouterr().err.strip()
    assert "\n" not in error and "'T_k'" in error and "T, T_i, T_ij" in error
