"""gpmegen modes: locked and constrained linearizations, their files, and what they must obey."""

import numpy as np

from gpmegen.analysis import modes, reference_case
from gpmegen.cli import main


def test_constrained_modes_move_along_the_constraints(flexible):
    model, q = reference_case.initial_state(flexible, "constrained")
    result = modes.constrained_modes(model, q)
    _, _, D, _ = model.constraint_terms(0.0, q, np.zeros(model.n_dof))
    assert np.all(result.frequencies > 0)  # a stable equilibrium
    np.testing.assert_allclose(D @ result.shapes, 0, atol=1e-9)  # every shape keeps E on the constraints
    M = model.mass_matrix(q)
    np.testing.assert_allclose(result.shapes.T @ M @ result.shapes, np.eye(len(result.frequencies)), atol=1e-8)
    # holding E raises the first vertical bending frequency above the locked-joint one
    _, locked = modes.locked_modes(flexible, reference_case.joint_start(flexible))
    assert result.first("vertical") > locked.first("vertical")


def test_modes_command_writes_table_csv_and_figure(tmp_path, capsys):
    assert main(["modes", "--nrfe", "3", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "frequency (Hz)" in out and "vertical" in out
    csv = (tmp_path / "modes_nrfe3_joints.csv").read_text().splitlines()
    assert csv[0].startswith("mode,frequency_Hz,kind,theta1,psi2,")
    assert len(csv) == 1 + 6  # six spring coordinates at n_rfe = 3
    assert (tmp_path / "modes_nrfe3_joints.png").stat().st_size > 10_000
