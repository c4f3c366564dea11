"""URDF export against Pinocchio: the reference arm at n_rfe 5 written by ``gpmegen export
--format urdf`` and read by Pinocchio's URDF reader gives gpmegen's M, velocity and gravity
terms and point positions at random states; the springs and dampers read back from the
``gpmegen:spring`` extension elements complete f. gpmegen's own import of the file (which
reads that element) gives the arm back. The command refuses a folder as --out."""

from __future__ import annotations

import xml.etree.ElementTree as ET

import numpy as np
import pytest
import sympy as sp

import gpmegen
from gpmegen.cli import main
from gpmegen.model.urdf import import_urdf
from gpmegen.model.urdf_tree import SPRING

pin = pytest.importorskip("pinocchio")


@pytest.fixture(scope="module")
def exported(env, tmp_path_factory):
    path = tmp_path_factory.mktemp("export") / "arm.urdf"
    assert main(["export", "--format", "urdf", "--nrfe", "5", "--out", str(path)]) == 0
    return path, gpmegen.load("manipulator", nrfe=5, directory=env[0], backend="numpy")


def configuration(model, q):
    """Pinocchio's configuration of ``q``: a continuous joint's angle as (cos, sin)."""
    parts = [[np.cos(x), np.sin(x)] if joint.nq == 2 else [x] for joint, x in zip(model.joints[1:], q)]
    return np.concatenate(parts)


def test_exported_arm_agrees_with_gpmegen(exported, rng):
    path, loaded = exported
    model = pin.buildModelFromUrdf(str(path))
    model.gravity.linear = np.array([0.0, -gpmegen.reference_model(5).defaults["g"], 0.0])   # the arm's: -y
    assert tuple(model.names[1:]) == loaded.coordinates
    springs = {j.get("name"): j.find(SPRING) for j in ET.parse(path).getroot().iter("joint")}
    K = np.array([float(springs[n].get("stiffness")) if springs[n] is not None else 0.0 for n in loaded.coordinates])
    D = np.array([float(springs[n].get("damping")) if springs[n] is not None else 0.0 for n in loaded.coordinates])
    assert (K > 0).sum() == 3 * 4   # the three rotations of each of the 4 sdes
    data = model.createData()
    n = loaded.n_dof
    points = [model.getFrameId(name) for name in loaded.points]
    for _ in range(4):
        q, qd = rng.uniform(-0.5, 0.5, n), rng.uniform(-1, 1, n)
        x = configuration(model, q)
        M = pin.crba(model, data, x)
        M = np.triu(M) + np.triu(M, 1).T
        np.testing.assert_allclose(loaded.mass_matrix(q), M, rtol=0, atol=1e-10 * np.abs(M).max())
        nle = pin.rnea(model, data, x, qd, np.zeros(n))
        f = loaded.forces(0.0, q, qd) - loaded.drive_forces(0.0, q, qd)
        expected = -nle - K * q - D * qd
        np.testing.assert_allclose(f, expected, rtol=0, atol=1e-10 * np.abs(expected).max())
        pin.framesForwardKinematics(model, data, x)
        np.testing.assert_allclose(loaded.point_positions(q), [data.oMf[i].translation for i in points],
                                   rtol=0, atol=1e-12)


def test_export_and_import_give_back_the_model(exported, env, rng):
    """The exported arm imported again (springs and dampers from the extension element, gravity
    given as the arm's) has the arm's M, f and points."""
    path, loaded = exported
    g = sp.Symbol("g", real=True)
    again = gpmegen.load(model=import_urdf(path, gravity=(0, -g, 0)).model, directory=env[0], backend="numpy")
    assert again.coordinates == loaded.coordinates
    rows = [again.points.index(name) for name in loaded.points]
    for _ in range(3):
        q, qd = rng.uniform(-0.5, 0.5, loaded.n_dof), rng.uniform(-1, 1, loaded.n_dof)
        M = loaded.mass_matrix(q)
        np.testing.assert_allclose(again.mass_matrix(q), M, rtol=0, atol=1e-10 * np.abs(M).max())
        f = loaded.forces(0.0, q, qd) - loaded.drive_forces(0.0, q, qd)
        np.testing.assert_allclose(again.forces(0.0, q, qd), f, rtol=0, atol=1e-10 * np.abs(f).max())
        np.testing.assert_allclose(again.point_positions(q)[rows], loaded.point_positions(q), rtol=0, atol=1e-12)


def test_export_refuses_a_folder(tmp_path, capsys):
    assert main(["export", "--format", "urdf", "--nrfe", "1", "--out", str(tmp_path)]) == 2
    err = capsys.readouterr().err.strip()
    assert "is a folder" in err and len(err.splitlines()) == 1
