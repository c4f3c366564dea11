"""gpmegen modes: locked and constrained linearizations, their files, and what they must obey."""

from pathlib import Path

import numpy as np

from gpmegen.analysis.post import modes
from gpmegen.analysis.run import reference_case
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


def test_start_modes_follow_the_lock_and_find_nothing_in_a_rigid_arm(rigid, flexible):
    """``modes.start_modes``: the locked-joint modes about the locked statics, the constrained ones
    about the constrained equilibrium (holding E stiffens the arm: a higher first vertical
    frequency), and None for the rigid arm, which has no spring to vibrate."""
    assert modes.start_modes(*reference_case.initial_state(rigid, "locked"), "joints") is None
    locked = modes.start_modes(*reference_case.initial_state(flexible, "locked"), "joints")
    held = modes.start_modes(*reference_case.initial_state(flexible, "constrained"), "constraints")
    assert np.all(locked.frequencies > 0) and np.all(held.frequencies > 0)
    assert held.first("vertical") > locked.first("vertical")


def test_modes_command_writes_table_csv_and_figure(tmp_path, capsys):
    assert main(["modes", "--nrfe", "3", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "frequency (Hz)" in out and "vertical" in out
    csv = (tmp_path / "modes_nrfe3_joints.csv").read_text().splitlines()
    assert csv[0].startswith("mode,frequency_Hz,kind,theta1,psi2,")
    assert len(csv) == 1 + 6  # six spring coordinates at n_rfe = 3
    assert (tmp_path / "modes_nrfe3_joints.png").stat().st_size > 10_000


# A z-up arm: a sprung joint named psi1 turning about the vertical z0, then a flexible strip along
# x0, thin along z (stiff across, soft up and down), free in psi and theta. Its psi bends it
# across (horizontally), its theta up and down: names say the opposite.
Z_UP = """
schema = 1
name = "z_up_strip"
gravity = [0, 0, "-g"]

[parameters]
g = { value = 9.81, unit = "m/s^2", doc = "gravity" }
L = { value = 0.8, unit = "m", doc = "strip length" }
b = { value = 0.03, unit = "m", doc = "width, along y" }
h = { value = 0.004, unit = "m", doc = "thickness, along z" }

[[chain]]
joint = "psi1"
type = "revolute"
axis = "z"
stiffness = 400

[[chain]]
body = "hub"
shape = { type = "point_mass", mass = 0.5 }

[[chain]]
flexible = "2"
length = "L"
section = { type = "rectangular", width = "b", thickness = "h" }
density = 2700
young_modulus = 7.0e10
shear_modulus = 2.6e10
freedoms = ["psi", "theta"]
nrfe = 3

[[chain]]
point = "tip"
"""


def test_mode_labels_come_from_the_shapes_not_the_coordinate_names(tmp_path):
    """Each mode's kind is the direction its shape moves the strip: checked against the tip's own
    motion (the named point, not the transforms the labels use), and the modes the coordinates
    named psi carry are horizontal here."""
    import gpmegen

    path = tmp_path / "z_up.toml"
    path.write_text(Z_UP)
    model = gpmegen.load(model=gpmegen.load_model_file(path), directory=tmp_path / "built")
    q_eq, result = modes.locked_modes(model, np.zeros(model.n_dof))
    assert set(result.kinds) == {"vertical", "horizontal"}
    tip = model.points.index("tip")
    psi = [k for k, name in enumerate(model.coordinates) if name.startswith("psi")]
    for k, kind in enumerate(result.kinds):
        shape = result.shapes[:, k]
        h = 1e-6 / np.max(np.abs(shape))
        moved = (model.point_positions(q_eq + h * shape)[tip] - model.point_positions(q_eq - h * shape)[tip]) / (2 * h)
        assert kind == ("vertical" if abs(moved[2]) > np.hypot(moved[0], moved[1]) else "horizontal")
        if np.sum(shape[psi] ** 2) > 0.9 * np.sum(shape**2):  # a mode of the psi coordinates
            assert kind == "horizontal"


def test_convergence_of_a_link_bending_in_one_plane_only(tmp_path, capsys):
    """A link free in psi alone has no horizontal bending nor torsion: the study compares what it
    has and says what it leaves out (it stopped on 'no horizontal mode')."""
    path = tmp_path / "planar.toml"
    text = Path(__file__).parent.joinpath("models", "flexible_link.toml").read_text()
    path.write_text(text.replace('damping = ["d", "d", "d"]', 'damping = ["d", "d", "d"]\nfreedoms = ["psi"]'))
    assert main(["convergence", str(path), "--nrfe", "2", "3", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    assert "1st vertical bending frequency" in out and "1st horizontal bending frequency:" not in out
    assert "not compared: 1st horizontal bending frequency, 1st torsional frequency" in out
    block = out[out.index("1st vertical bending frequency"):]
    errors = [float(line.split()[2]) for line in block.splitlines()[2:4]]
    assert abs(errors[1]) < abs(errors[0])  # converging to the beam's vertical bending


def test_the_mode_shapes_title_sits_on_the_highest_panel(tmp_path, monkeypatch):
    """The title's bottom is less than 5 % of the figure's height above the top of the highest
    panel, tick labels included (the default subplot margins left a blank band of about 8 %
    under it), and does not overlap it; nothing falls outside the figure."""
    import matplotlib.pyplot as plt
    from drawn_text import outside

    from gpmegen.analysis.figures import modes_output
    from gpmegen.analysis.post.modes import Modes

    names = tuple(f"{rotation}1_{k}" for k in range(1, 5) for rotation in ("psi", "theta", "phi"))
    shapes = np.sin(np.outer(np.arange(1, 13), np.arange(1, 7)))
    figures = []
    monkeypatch.setattr(plt, "close", figures.append)
    for count in (6, 3, 1):
        shown = Modes(np.linspace(3.0, 90.0, 6), shapes, np.arange(12), names, ["vertical", "torsion"] * 3)
        modes_output.plot_mode_shapes(shown, tmp_path / f"modes{count}.png", count=count)
        fig = figures[-1]
        renderer = fig.canvas.get_renderer()
        title = fig._suptitle.get_window_extent(renderer)
        top = max(ax.get_tightbbox(renderer).y1 for ax in fig.axes)
        height = fig.bbox.height
        assert 0 <= title.y0 - top < 0.05 * height, (count, (title.y0 - top) / height)
        assert outside(fig) == []
    monkeypatch.undo()
    for fig in figures:
        plt.close(fig)


def test_a_model_with_nothing_to_vibrate_is_refused_in_one_line_and_writes_nothing(tmp_path, capsys):
    """The rigid four-bar has no spring: neither locking gives a mode. One line each (not an empty
    table and a figure that fails), naming the model and the fix; no file written."""
    four_bar = str(Path(__file__).resolve().parents[1] / "examples" / "four_bar.toml")
    for lock in ("joints", "constraints"):
        assert main(["modes", four_bar, "--lock", lock, "--out", str(tmp_path)]) != 0
        last = capsys.readouterr().err.strip().splitlines()[-1]
        assert last.startswith("gpmegen modes: error: ") and "four_bar" in last, last
        assert f"no mode with --lock {lock}" in last and "make a link flexible" in last, last
        assert "internal error" not in last
    assert list(tmp_path.iterdir()) == []


def test_modes_of_sprung_joints_are_drawn_as_amplitudes_of_the_free_coordinates(tmp_path, recwarn):
    # the two masses in series of tests/models/spring_chain.toml: no flexible link, so no sde
    # rotation to draw along an arm; the figure shows each free coordinate's amplitude instead
    import matplotlib.pyplot as plt

    from gpmegen.analysis.figures import modes_output

    assert main(["modes", str(Path(__file__).parent / "models" / "spring_chain.toml"), "--out", str(tmp_path)]) == 0
    rows = [line.split(",") for line in (tmp_path / "modes_spring_chain_joints.csv").read_text().splitlines()]
    assert rows[0] == ["mode", "frequency_Hz", "kind", "x1", "x2"]
    # closed form: det(K - ω² M) = 0 for M = diag(m1, m2), K = [[k1 + k2, -k2], [-k2, k2]]
    m1, m2, k1, k2 = 1.0, 0.5, 100.0, 400.0
    b, c = -((k1 + k2) / m1 + k2 / m2), k1 * k2 / (m1 * m2)
    omega2 = np.array([(-b - np.sqrt(b * b - 4 * c)) / 2, (-b + np.sqrt(b * b - 4 * c)) / 2])
    np.testing.assert_allclose([float(r[1]) for r in rows[1:]], np.sqrt(omega2) / (2 * np.pi), rtol=1e-8)
    shapes = np.array([[float(v) for v in r[3:]] for r in rows[1:]]).T
    result = modes.Modes(np.array([float(r[1]) for r in rows[1:]]), shapes, np.array([0, 1]), ("x1", "x2"),
                         [r[2] for r in rows[1:]])
    fig = modes_output.mode_shapes_figure(result)
    heights = [[patch.get_height() for patch in ax.patches] for ax in fig.axes]
    np.testing.assert_allclose(heights, shapes.T, rtol=1e-12)
    assert [t.get_text() for t in fig.axes[-1].get_xticklabels()] == ["x1", "x2"]
    plt.close(fig)
    assert not [w for w in recwarn if "legend" in str(w.message)]
