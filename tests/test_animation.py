"""``gpmegen animate``: the GIF has one frame per shown sample, the still figure is written (the
same bytes twice), the magnification scales the drawn deformation about the rigid arm (on the
computed geometry, not on pixels), the rigid arm's rfes lie on a straight line, the skeleton runs
from the base through every body's frame to the tool, the inertia boxes are drawn only on
request, results name the model that made them (a model file from any folder), and bad input
gets one line each."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

import gpmegen
from gpmegen.analysis.figures import animation
from gpmegen.analysis.figures import arm_geometry as geometry
from gpmegen.analysis.post import results as results_io
from gpmegen.cli import main

# A hub about y, a rigid block, a flexible strip (3 rfes) with a tip mass and its point, gravity.
ARM = """\
schema = 1
name = "animated_arm"
nrfe = 3
gravity = [0, "-g", 0]

[parameters]
g = { value = 9.81, unit = "m/s^2" }
L = { value = 0.8, unit = "m" }

[[chain]]
joint = "hub"
type = "revolute"
axis = "y"

[[chain]]
body = "block"
shape = { type = "bar", mass = 2.0, length = 0.2, width = 0.1, thickness = 0.05 }

[[chain]]
flexible = "1"
length = "L"
section = { type = "rectangular", width = 0.04, thickness = 0.01 }
density = 2700.0
young_modulus = 7.0e10
shear_modulus = 2.6e10

[[chain]]
body = "tip_mass"
shape = { type = "point_mass", mass = 0.5 }

[[chain]]
point = "tip"
"""


@pytest.fixture(scope="module")
def arm_run(env, tmp_path_factory):
    """A short run of the model file: (its results path, the file's path)."""
    folder = tmp_path_factory.mktemp("arm")
    model_file = folder / "arm.toml"
    model_file.write_text(ARM)
    out = folder / "arm.npz"
    assert main(["simulate", str(model_file), "--backend", "numpy", "--t-end", "0.06", "--dt", "2.5e-4",
                 "--save-every", "8", "--out", str(out)]) == 0  # below RK4's stable step 4.4e-4 s
    return out, model_file


@pytest.fixture(scope="module")
def shown(arm_run):
    return animation.subject(arm_run[0])


def test_results_name_the_model_file_that_made_them(arm_run, shown):
    meta = results_io.metadata(results_io.load(arm_run[0]))
    assert meta["model_source"] == {"file": str(arm_run[1].resolve()), "nrfe": None}
    assert shown.loaded.module.MODEL == "animated_arm"
    assert shown.scene.bodies == ("block", "rfe1_0", "rfe1_1", "rfe1_2", "tip_mass")
    assert shown.scene.links == ((1, 2, 3),)
    assert [shown.loaded.coordinates[k] for k in shown.scene.elastic] == [
        f"{name}1_{r}" for r in (1, 2) for name in ("psi", "theta", "phi")]


def test_the_gif_has_one_frame_per_shown_sample(arm_run, tmp_path, monkeypatch, capsys):
    monkeypatch.chdir(tmp_path)  # the results find their model file from any folder
    gif = tmp_path / "arm.gif"
    assert main(["animate", str(arm_run[0]), "--out", str(gif), "--every", "4", "--fps", "10", "--dpi", "40"]) == 0
    samples = len(results_io.load(arm_run[0])["t"])
    frames = len(range(0, samples, 4))
    with Image.open(gif) as image:
        assert image.n_frames == frames and frames > 3
        assert image.info["duration"] == 100
    assert f"frame {frames} / {frames}" in capsys.readouterr().err  # progress, to the last frame
    assert [p.name for p in tmp_path.iterdir()] == ["arm.gif"]  # no temporary file left beside it
    again = tmp_path / "again.gif"
    assert main(["animate", str(arm_run[0]), "--out", str(again), "--every", "4", "--fps", "10", "--dpi", "40"]) == 0
    assert again.read_bytes() == gif.read_bytes()


def test_the_still_figure_is_written_the_same_twice(arm_run, tmp_path):
    figures = [tmp_path / "a.png", tmp_path / "b.png"]
    for figure in figures:
        assert main(["animate", str(arm_run[0]), "--still", "0,0.03,0.06", "--magnify", "20", "--dpi", "50",
                     "--out", str(figure)]) == 0
    with Image.open(figures[0]) as image:
        assert image.size == (320, 270)
    assert figures[0].read_bytes() == figures[1].read_bytes()


def small_deformation(shown):
    """A state with the joint at 0.7 rad and small elastic coordinates (1e-4 rad)."""
    q = np.zeros(shown.loaded.n_dof)
    q[shown.loaded.index("hub")] = 0.7
    q[shown.scene.elastic] = 1e-4 * np.array([1.0, -2.0, 0.5, 1.5, 1.0, -1.0])
    return q


def test_magnifying_scales_the_drawn_deflection_from_the_rigid_arm(shown):
    q = small_deformation(shown)
    rigid, once, ten = (geometry.poses(shown.scene, shown.loaded, q[None], k)[0] for k in (0.0, 1.0, 10.0))
    deflection = once.chains[0] - rigid.chains[0]
    assert np.abs(deflection).max() > 1e-5
    # linear in the elastic coordinates up to O(K θ) = 1e-3 relative
    np.testing.assert_allclose(ten.chains[0] - rigid.chains[0], 10 * deflection, rtol=0,
                               atol=2e-3 * np.abs(10 * deflection).max())
    np.testing.assert_allclose(ten.points - rigid.points, 10 * (once.points - rigid.points), rtol=0,
                               atol=2e-3 * np.abs(10 * (once.points - rigid.points)).max())
    assert np.array_equal(geometry.magnified(q, shown.scene.elastic, 10.0)[0], q[0])  # the joint itself is kept


def test_the_rigid_arm_is_straight_and_as_long_as_its_link(shown):
    chain = geometry.poses(shown.scene, shown.loaded, small_deformation(shown)[None], 0.0)[0].chains[0]
    direction = (chain[-1] - chain[0]) / np.linalg.norm(chain[-1] - chain[0])
    off_line = (chain - chain[0]) - np.outer((chain - chain[0]) @ direction, direction)
    assert np.abs(off_line).max() < 1e-12
    assert np.linalg.norm(chain[-1] - chain[0]) == pytest.approx(0.8, rel=1e-12)


def test_the_skeleton_runs_through_the_body_frames(shown, rng):
    """At a random state the skeleton is the base, the origin of every body's frame (``T``) and
    the tool, drawn as one line; at zero deformation its vertices are where the hub's rotation puts the block (at
    the hub), the rfes' origins along the strip (at the sdes, L/4 and 3L/4: the rfe method's
    end pieces are half the inner ones) and the tip mass and tip (at L)."""
    scene, loaded = shown.scene, shown.loaded
    assert scene.points[scene.tool] == "tip"
    q = rng.uniform(-1.0, 1.0, loaded.n_dof)
    q[scene.elastic] *= 0.05
    drawn = geometry.poses(scene, loaded, q[None], 3.0)[0]
    bent = geometry.magnified(q, scene.elastic, 3.0)
    origins = loaded.transforms(bent)[:, :3, 3]
    tip = loaded.point_positions(bent).reshape(-1, 3)[scene.points.index("tip")]
    np.testing.assert_array_equal(drawn.skeleton, np.vstack([np.zeros(3), origins, tip]))
    np.testing.assert_array_equal(drawn.lines, drawn.skeleton)   # a serial chain: one line in chain order
    hub = q[loaded.index("hub")]
    along = np.array([np.cos(hub), 0.0, -np.sin(hub)])  # the strip's x turned by the hub about y
    rigid = geometry.poses(scene, loaded, q[None], 0.0)[0].skeleton
    expected = np.outer([0.0, 0.0, 0.0, 0.2, 0.6, 0.8, 0.8], along)  # base, block, rfes, tip mass, tip
    np.testing.assert_allclose(rigid, expected, rtol=0, atol=1e-14)


def test_the_boxes_are_drawn_on_request(shown, arm_run, tmp_path):
    """The default drawing is the skeleton alone: no box edges, and the axes fit the skeleton;
    ``--bodies boxes`` and ``both`` draw the block's box (12 edges) and make another figure."""
    q = small_deformation(shown)[None]
    plain = geometry.poses(shown.scene, shown.loaded, q)[0]
    boxed = geometry.poses(shown.scene, shown.loaded, q, boxes=True)[0]
    assert plain.edges.shape == (0, 2, 3) and len(boxed.edges) >= 12
    np.testing.assert_array_equal(plain.skeleton, boxed.skeleton)
    figures = {}
    for bodies in ("skeleton", "boxes", "both"):
        figures[bodies] = tmp_path / f"{bodies}.png"
        assert main(["animate", str(arm_run[0]), "--still", "0.03", "--bodies", bodies, "--dpi", "40",
                     "--out", str(figures[bodies])]) == 0
    assert len({figure.read_bytes() for figure in figures.values()}) == 3


def test_the_box_of_a_bar_is_the_bar():
    from gpmegen.model import shapes

    box = geometry.inertia_box(np.array(shapes.bar(2.0, 0.2, 0.1, 0.05), dtype=float))
    order = np.argsort(np.abs(box.axes).argmax(axis=0))  # principal axes back to x, y, z
    np.testing.assert_allclose(box.half[order], [0.1, 0.025, 0.05], rtol=1e-12)
    np.testing.assert_allclose(box.center, [0.1, 0, 0], atol=1e-15)


def test_the_title_states_the_magnification(shown):
    assert "magnified 10×" in shown.view((20, -60), 10.0).title("t = 0 s")
    assert "magnified" not in shown.view((20, -60), 1.0).title("t = 0 s")


def one_line_error(capsys, argv) -> str:
    assert main(argv) == 2
    # progress lines ("gpmegen: model folder: ...") may come before; the refusal is one line
    lines = [line for line in capsys.readouterr().err.strip().splitlines() if not line.startswith("gpmegen: ")]
    assert len(lines) == 1 and "Traceback" not in lines[0]
    return lines[0]


def test_bad_input_gets_one_line(arm_run, tmp_path, capsys, monkeypatch):
    results = str(arm_run[0])
    avi, gif, png, mp4 = (str(tmp_path / f"a.{suffix}") for suffix in ("avi", "gif", "png", "mp4"))
    assert "choose one of those suffixes" in one_line_error(capsys, ["animate", results, "--out", avi])
    assert ".png" in one_line_error(capsys, ["animate", results, "--still", "0", "--out", gif])
    with pytest.raises(SystemExit) as exited:  # argparse's own refusal, in one line
        main(["animate", results, "--bodies", "cubes", "--out", gif])
    err = capsys.readouterr().err.strip()
    assert exited.value.code == 2 and "--bodies" in err and "\n" not in err
    assert "within them" in one_line_error(capsys, ["animate", results, "--still", "9", "--out", png])
    monkeypatch.setenv("PATH", str(tmp_path))  # no ffmpeg
    assert "ffmpeg" in one_line_error(capsys, ["animate", results, "--out", mp4])
    monkeypatch.undo()
    data = dict(results_io.load(arm_run[0]))
    meta = results_io.metadata(data)
    del meta["model_source"]  # results that do not say which model made them
    results_io.save(dict(data, meta=np.array(json.dumps(meta))), tmp_path / "anonymous.npz")
    assert "--model" in one_line_error(capsys, ["animate", str(tmp_path / "anonymous.npz"), "--out",
                                                str(tmp_path / "a.gif")])
    # given with --model, they are drawn
    assert main(["animate", str(tmp_path / "anonymous.npz"), "--model", str(arm_run[1]), "--every", "30", "--dpi",
                 "30", "--out", str(tmp_path / "named.gif")]) == 0
    assert main(["build", str(arm_run[1]), "--out", str(tmp_path / "built")]) == 0
    capsys.readouterr()
    assert "give the model file" in one_line_error(capsys, ["animate", results, "--model", str(tmp_path / "built"),
                                                            "--out", str(tmp_path / "a.gif")])
    assert not list(tmp_path.glob("a.*"))


@pytest.mark.skipif(__import__("shutil").which("ffmpeg") is None, reason="needs ffmpeg")
def test_an_mp4_is_written_with_ffmpeg(arm_run, tmp_path):
    made = [tmp_path / "arm.mp4", tmp_path / "again.mp4"]
    for out in made:
        assert main(["animate", str(arm_run[0]), "--out", str(out), "--every", "10", "--dpi", "40"]) == 0
    assert made[0].read_bytes()[4:8] == b"ftyp"  # an MP4 container
    assert made[0].read_bytes() == made[1].read_bytes()


def test_the_reference_arm_results_name_it(env):
    run = gpmegen.simulate(nrfe=2, t_end=0.002, dt=1e-3, save_every=1, backend="numpy")
    assert run.meta["model_source"] == {"reference": 2}


@pytest.mark.parametrize("gravity, vertical", [(("0", "-g", "0"), "y"), (("0", "0", "g"), "-z"),
                                               (("-3", "1", "0"), "x"), (("0", "0", "0"), "z")])
def test_the_axis_against_gravity_is_drawn_upwards(gravity, vertical):
    import sympy as sp

    from gpmegen.model.chain import Model, Parameter, symbol

    model = Model("m", (Parameter("g", 9.81),), (), gravity=tuple(sp.sympify(v, locals={"g": symbol("g")})
                                                                    for v in gravity))
    assert animation.vertical_axis(model, {"g": 9.81}) == vertical


def test_a_sprung_joint_is_neither_magnified_nor_in_the_deflection(env, tmp_path):
    """With a spring on the hub (about z, so that the weight turns it), the elastic coordinates
    are still the strip's sdes alone: the magnified arm turns with the hub as computed, and the
    saved deflection is the tip's displacement by the sdes (the hub's turn would make it a rigid
    swing of the whole arm)."""
    model_file = tmp_path / "sprung.toml"
    model_file.write_text(ARM.replace('axis = "y"\n', 'axis = "z"\nstiffness = 300\n', 1))  # gravity turns it
    out = tmp_path / "sprung.npz"
    assert main(["simulate", str(model_file), "--backend", "numpy", "--t-end", "0.1", "--dt", "2.5e-4",
                 "--save-every", "40", "--out", str(out)]) == 0
    subject = animation.subject(out)
    loaded = subject.loaded
    hub = loaded.index("hub")
    assert hub not in subject.scene.elastic
    assert sorted(subject.scene.elastic) == [k for k in range(loaded.n_dof) if k != hub]
    run = results_io.load(out)
    q = run["q"]
    assert np.abs(q[-1, hub]) > 1e-3  # the hub has turned on its spring under the strip's weight
    rigid = q.copy()
    rigid[:, subject.scene.elastic] = 0.0
    expected = np.array([loaded.end_effector(a) - loaded.end_effector(b) for a, b in zip(q, rigid)])
    np.testing.assert_allclose(run["deflection"], expected, rtol=0, atol=1e-12)
    magnified = geometry.magnified(q[-1:], subject.scene.elastic, 10.0)[0]
    assert magnified[hub] == q[-1, hub]


def test_a_run_warns_once_when_an_sde_rotation_grows_beyond_a_beams_small_strains(env, tmp_path, capsys):
    """A strip 100 times softer droops far beyond what the linear sde springs model: one warning
    names the sde, its rotation and the time (the largest over the run, as the saved q has it); the
    arm of the other tests, whose sdes turn by a few milliradians, gets none."""
    from gpmegen.analysis.post import driving

    soft = tmp_path / "soft.toml"
    soft.write_text(ARM.replace("young_modulus = 7.0e10", "young_modulus = 7.0e8"))
    out = tmp_path / "soft.npz"
    assert main(["simulate", str(soft), "--backend", "numpy", "--t-end", "0.01", "--dt", "2.5e-4",
                 "--save-every", "8", "--out", str(out), "--statics", "locked"]) == 0
    err = capsys.readouterr().err
    warnings = [line for line in err.splitlines() if "sde rotation" in line]
    assert len(warnings) == 1
    run = results_io.load(out)
    q, coordinates = run["q"], [str(c) for c in run["coordinates"]]
    sdes = [k for k, name in enumerate(coordinates) if name != "hub"]
    k, j = np.unravel_index(np.argmax(np.abs(q[:, sdes])), q[:, sdes].shape)
    assert abs(q[k, sdes[j]]) > driving.ELASTIC_ROTATION
    assert f"{coordinates[sdes[j]]} reaches {q[k, sdes[j]]:.3g} rad at t = {run['t'][k]:.6g} s" in warnings[0]
    # the stiff strip: no warning
    assert main(["simulate", str(_stiff(tmp_path)), "--backend", "numpy", "--t-end", "0.01", "--dt", "2.5e-4",
                 "--save-every", "8", "--out", str(tmp_path / "stiff.npz"), "--statics", "locked"]) == 0
    assert "sde rotation" not in capsys.readouterr().err


def _stiff(folder):
    path = folder / "stiff.toml"
    path.write_text(ARM)
    return path


def test_a_run_without_constraints_says_so_instead_of_an_empty_violation(env, tmp_path, capsys):
    assert main(["simulate", str(_stiff(tmp_path)), "--backend", "numpy", "--t-end", "0.005", "--dt", "2.5e-4",
                 "--out", str(tmp_path / "free.npz")]) == 0
    out = capsys.readouterr().out
    assert "no constraints" in out and "max|Φ|" not in out


def test_a_frame_rate_no_movie_can_have_is_refused_in_one_line(arm_run, tmp_path, capsys):
    """--fps 1e-300 was an internal error (an IndexError: the sample step to play it in real time
    is beyond any integer)."""
    with pytest.raises(SystemExit) as info:
        main(["animate", str(arm_run[0]), "--out", str(tmp_path / "a.gif"), "--fps", "1e-300"])
    assert info.value.code == 2
    [line] = capsys.readouterr().err.strip().splitlines()
    assert "argument --fps: 1e-300 frames per second is outside 0.01 to 1000" in line
    assert not (tmp_path / "a.gif").exists()


@pytest.mark.parametrize("source", ["x", [1], {"reference": "abc"}, {"reference": None}, {"reference": 0},
                                    {"file": 5}, {"file": "arm.toml", "nrfe": "x"}, {"folder": ["a"]}])
def test_a_malformed_model_source_is_refused_in_one_line(arm_run, tmp_path, capsys, source):
    """A results file whose model_source is not what gpmegen writes was an internal error
    (AttributeError, ValueError, TypeError)."""
    results = results_io.load(arm_run[0])
    odd = tmp_path / "odd.npz"
    results_io.save(dict(results, meta=results_io.encode({**results_io.metadata(results), "model_source": source})),
                    odd)
    assert main(["animate", str(odd), "--still", "0", "--out", str(tmp_path / "still.png")]) == 2
    [line] = capsys.readouterr().err.strip().splitlines()
    assert "its model_source" in line and "is not one gpmegen writes" in line and "--model" in line


EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def planar_run(env, tmp_path_factory):
    """A short run of the planar example, its links flexible (2 rfes each: their sdes can bend and
    twist out of the plane, and do not)."""
    out = tmp_path_factory.mktemp("planar") / "planar.npz"
    assert main(["simulate", str(EXAMPLES / "planar_two_link.toml"), "--nrfe", "2", "--backend", "numpy",
                 "--t-end", "0.05", "--dt", "1e-4", "--save-every", "50", "--out", str(out)]) == 0
    return out


@pytest.fixture(scope="module")
def reference_run(env, tmp_path_factory):
    """Half a second of the reference case, rigid: its base turns, so the plane of the arm turns."""
    out = tmp_path_factory.mktemp("reference") / "reference.npz"
    assert main(["simulate", "--nrfe", "1", "--backend", "numpy", "--t-end", "0.5", "--dt", "1e-3",
                 "--save-every", "10", "--out", str(out)]) == 0
    return out


@pytest.fixture
def kept(monkeypatch):
    """The figures animate drew, kept open (a Canvas closes its figure when done)."""
    figures = []
    monkeypatch.setattr(animation.Canvas, "close", lambda canvas: figures.append(canvas.fig))
    yield figures
    import matplotlib.pyplot as plt

    for fig in figures:
        plt.close(fig)


def test_a_planar_arm_is_drawn_face_on_in_its_plane_by_default(planar_run, tmp_path, kept):
    assert main(["animate", str(planar_run), "--still", "0,0.05", "--dpi", "40", "--out", str(tmp_path / "a.png")]) == 0
    [fig] = kept
    [ax] = fig.axes
    assert ax.name == "rectilinear"  # not "3d"
    assert (ax.get_xlabel(), ax.get_ylabel()) == ("x [m]", "y [m]")  # the plane x0-y0, y against gravity
    assert ax.get_aspect() == 1.0 and not ax.yaxis_inverted() and not ax.xaxis_inverted()
    # the lines are the arm's x, y: the tool E at its start (xa, ya) at t = 0
    subject = animation.subject(planar_run)
    start = subject.loaded.point_positions(subject.results["q"][0]).reshape(-1, 3)[subject.scene.tool]
    assert start == pytest.approx([0.5734401855541006, 0.6189883999977893, 0.0], abs=2e-3)
    skeleton = ax.get_lines()[0].get_xydata()
    np.testing.assert_array_equal(skeleton[-1], start[:2])
    # asked for in 3D, or from a camera, it is drawn in 3D
    for view in ("3d", "30,-45"):
        assert main(["animate", str(planar_run), "--still", "0", "--dpi", "40", "--view", view, "--overwrite",
                     "--out", str(tmp_path / "a.png")]) == 0
    assert [fig.axes[0].name for fig in kept[1:]] == ["3d", "3d"]
    assert (kept[2].axes[0].elev, kept[2].axes[0].azim) == (30.0, -45.0)


def test_a_spatial_arm_stays_in_3d_and_2d_is_refused_for_it(reference_run, tmp_path, kept, capsys):
    """The reference arm's plane turns with its base (by 3e-5 of its size in half a second)."""
    assert main(["animate", str(reference_run), "--still", "0", "--dpi", "40", "--out", str(tmp_path / "a.png")]) == 0
    assert kept[0].axes[0].name == "3d"
    line = one_line_error(capsys, ["animate", str(reference_run), "--view", "2d", "--out", str(tmp_path / "b.gif")])
    assert "--view 2d: the arm does not move in one plane" in line and "--view 3d" in line
    assert not (tmp_path / "b.gif").exists()
    with pytest.raises(SystemExit) as exited:
        main(["animate", str(reference_run), "--view", "sideways", "--out", str(tmp_path / "b.gif")])
    err = capsys.readouterr().err.strip()
    assert exited.value.code == 2 and "give auto, 3d, 2d or" in err and "\n" not in err


def test_the_plane_is_the_one_the_arm_moves_in_not_one_the_model_suggests(shown):
    """ARM's hub turns about y, but gravity along y gives it no torque: it stays at zero while
    the strip sags and swings in x-y, the plane through the hub's axis (the plane normal to the
    joint axes, x-z, would show the strip edge-on)."""
    q = shown.results["q"]
    assert np.all(q[:, shown.loaded.index("hub")] == 0.0) and np.abs(q[:, shown.scene.elastic]).max() > 1e-4
    plane = shown.view().plane
    np.testing.assert_array_equal([plane.across, plane.up], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])


def test_the_plane_is_found_from_the_drawn_points_whatever_its_orientation(rng):
    """Points in an oblique plane that holds the vertical (y against gravity): y upwards, the
    other axis the plane's horizontal, named as the combination of x, z it is; the same points
    lifted out of the plane by more than FLAT of their size are in none; a plane normal to
    gravity is seen from above; points on a line lie in the plane through it and the vertical."""
    horizontal = np.array([0.6, 0.0, 0.8])
    points = rng.uniform(-1, 1, (50, 1)) * horizontal + rng.uniform(-1, 1, (50, 1)) * [0.0, 1.0, 0.0]
    plane, off, size = geometry.plane_of(points, np.array([0.0, 1.0, 0.0]))
    assert off < 1e-15 * size
    np.testing.assert_array_equal(plane.up, [0.0, 1.0, 0.0])
    np.testing.assert_allclose(plane.across, horizontal, atol=1e-12)
    np.testing.assert_allclose(np.cross(plane.across, plane.up), plane.normal, atol=1e-15)
    assert animation._coordinate(plane.across) == "0.6 x + 0.8 z"
    lifted = points.copy()
    lifted[0] += 3e-6 * size * plane.normal
    assert geometry.plane_of(lifted, np.array([0.0, 1.0, 0.0]))[0] is None
    flat = np.column_stack([rng.uniform(-1, 1, (50, 2)), np.zeros(50)])
    above = geometry.plane_of(flat, np.array([0.0, 0.0, 1.0]))[0]
    assert above.above
    np.testing.assert_array_equal(np.array([above.across, above.up, above.normal]), np.eye(3))
    line = geometry.plane_of(rng.uniform(-1, 1, (20, 1)) * [1.0, 0.0, 0.0], np.array([0.0, 0.0, 1.0]))[0]
    np.testing.assert_array_equal(np.array([line.across, line.up]), [[1.0, 0.0, 0.0], [0.0, 0.0, 1.0]])


def test_a_plane_upside_down_is_drawn_with_its_vertical_axis_reversed(planar_run):
    """With gravity along +y the planar arm is drawn with y downwards and x still rightwards
    (seen from -z), as the 3D view turns it half a turn about its first axis."""
    import dataclasses

    subject = animation.subject(planar_run)
    model = dataclasses.replace(subject.model, gravity=tuple(-g for g in subject.model.gravity))
    view = dataclasses.replace(subject, model=model).view()
    np.testing.assert_array_equal([view.plane.across, view.plane.up, view.plane.normal],
                                  [[1.0, 0.0, 0.0], [0.0, -1.0, 0.0], [0.0, 0.0, -1.0]])
    canvas = animation.Canvas(view, np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0]]), view.title("t = 0 s"), dpi=40)
    try:
        assert canvas.ax.yaxis_inverted() and not canvas.ax.xaxis_inverted()
        assert (canvas.ax.get_xlabel(), canvas.ax.get_ylabel()) == ("x [m]", "y [m]")
    finally:
        canvas.close()


# the reference arm's frame and still in make test, the others in make check-c
@pytest.mark.parametrize("case, view, axes", [pytest.param("arm", ["--view", "20,-60"], "3d", marks=pytest.mark.long),
                                              ("reference", [], "3d"),
                                              pytest.param("planar", [], "rectilinear", marks=pytest.mark.long)])
def test_no_text_of_a_frame_or_a_still_falls_outside_the_figure(case, view, axes, request, tmp_path, kept,
                                                                monkeypatch):
    """Every text drawn (title, tick labels, axis labels, legend), measured by the renderer, lies
    within the image: the 3D axes' lowest labels fell below it."""
    from drawn_text import outside

    results = str(request.getfixturevalue("arm_run")[0] if case == "arm" else request.getfixturevalue(f"{case}_run"))
    found = []
    rgba = animation.Canvas.rgba
    monkeypatch.setattr(animation.Canvas, "rgba", lambda canvas: found.append(outside(canvas.fig)) or rgba(canvas))
    assert main(["animate", results, "--every", "4", "--magnify", "30", *view, "--out", str(tmp_path / "a.gif")]) == 0
    assert main(["animate", results, "--still", "0,0.02", "--dpi", "100", *view, "--out", str(tmp_path / "a.png")]) == 0
    assert len(found) > 1 and len(kept) == 2 and {fig.axes[0].name for fig in kept} == {axes}
    assert found == [[]] * len(found)
    assert outside(kept[1]) == []


def test_a_title_wider_than_the_figure_is_broken_into_lines(arm_run, tmp_path, kept):
    """A long label (a model's description, say) is drawn in lines within the figure, and the
    axes keep their size (a 3D axes was shrunk in vain to fit it)."""
    from drawn_text import outside

    data = dict(results_io.load(arm_run[0]))
    label = "; ".join(["a flexible strip on a hub with a block and a tip mass"] * 3)
    data["meta"] = results_io.encode({**results_io.metadata(data), "label": label})
    results_io.save(data, tmp_path / "long.npz")
    for view in ("20,-60", "auto"):
        assert main(["animate", str(tmp_path / "long.npz"), "--model", str(arm_run[1]), "--still", "0", "--dpi", "60",
                     "--view", view, "--overwrite", "--out", str(tmp_path / "a.png")]) == 0
    for fig in kept:
        title = fig.axes[0].get_title()
        assert "\n" in title and title.replace("\n", " ") == label + ": deformed arm"
        assert outside(fig) == []
        assert fig.axes[0].get_position().width > 0.5
    assert [fig.axes[0].name for fig in kept] == ["3d", "rectilinear"]


def test_a_horizontal_plane_is_seen_from_above_and_says_so_only_under_gravity(planar_run):
    """The planar example with gravity along -z moves in the plane normal to it: seen from above,
    x rightwards and y upwards, the figure saying that gravity points into the page; without
    gravity the same view says nothing of it."""
    import dataclasses

    from drawn_text import drawn_text

    subject = animation.subject(planar_run)
    notes = []
    down = subject.model.gravity[1]  # -g
    for g in ((0, 0, down), (0, 0, 0)):
        model = dataclasses.replace(subject.model, gravity=g)
        view = dataclasses.replace(subject, model=model).view(magnify=1.0)
        np.testing.assert_array_equal([view.plane.across, view.plane.up], [[1.0, 0.0, 0.0], [0.0, 1.0, 0.0]])
        canvas = animation.Canvas(view, np.array([[0.0, 0.0, 0.0], [1.0, 1.0, 0.0]]), "t = 0 s", dpi=40)
        try:
            notes.append([text for text, _ in drawn_text(canvas.fig) if "gravity" in text])
        finally:
            canvas.close()
    assert notes == [["seen from above: gravity into the page"], []]
