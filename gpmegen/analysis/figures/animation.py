"""The arm moving (``gpmegen animate``): a GIF (Pillow) or an MP4 (ffmpeg) of a results file's
motion, or a still figure of the deformed arm at chosen times, drawn from the geometry of
:mod:`gpmegen.analysis.figures.arm_geometry` with matplotlib: in 3D, or in 2D, face-on, when the arm
stays in one plane over the run.

Frames are rendered by Agg and encoded here, so the bytes are the same for the same results and
options (the GIF holds no date; the MP4 is written with ffmpeg's bit-exact flags). Every file is
written atomically.
"""

from __future__ import annotations

import shutil
import subprocess
import tempfile
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np
import sympy as sp

from ... import limits
from ...errors import GpmegenError
from ...fileio import atomic_write
from ..post import results as results_io
from ..run.opening import case_of_path, case_of_source
from . import arm_geometry as geometry
from .plots import _FILE_METADATA, _SVG_SALT, _freeze_layout, _pyplot, broken, literal

MOVIES = ("gif", "mp4")
STILLS = ("png", "pdf", "svg")
FIGURE_SIZE = (6.4, 5.4)  # inches
BODIES = ("skeleton", "boxes", "both")  # how rigid bodies are drawn (--bodies); the first is the default
BODY, LIGHT_BODY, SKELETON, LINK, POINT, TRACE = "0.35", "0.75", "0.1", "C1", "C3", "C0"


class AnimationError(GpmegenError):
    """An animation or still figure that could not be made (the encoder failed)."""


class RequestError(AnimationError):
    """An animation or still figure asked for in a way that cannot be made (a usage error)."""


def format_of(out, still: bool) -> str:
    """The format of ``out`` by its suffix: a movie (gif, mp4) or, with ``still``, a figure."""
    fmt = Path(out).suffix.lower().lstrip(".")
    allowed = STILLS if still else MOVIES
    if fmt not in allowed:
        kind = "a still figure (--still)" if still else "an animation"
        raise RequestError(f"--out {out}: {kind} is written as {', '.join('.' + f for f in allowed)}; choose one "
                           f"of those suffixes")
    if fmt == "mp4" and shutil.which("ffmpeg") is None:
        raise RequestError(f"--out {out}: writing .mp4 needs ffmpeg, which is not on PATH; write a .gif instead, "
                           f"or install ffmpeg")
    return fmt


CAMERA = (20.0, -60.0)  # elevation and azimuth (degrees) of the 3D view unless --view gives them
VIEWS = ("auto", "3d", "2d")  # --view: 2D when the arm moves in one plane, else 3D; or either


@dataclass(frozen=True)
class View:
    """How the arm is shown: ``elev``, ``azim`` (degrees) of the camera, the ``vertical`` axis of
    {0} drawn upwards (against gravity: "y", or "-y" when gravity points along +y), ``magnify`` the
    factor on the deformation, ``label`` of the model, ``bodies`` one of :data:`BODIES`: the
    skeleton through the body frames, the boxes of the bodies' inertias, or both (boxes light);
    ``plane``: the plane the arm moves in, drawn face-on in 2D (None: the 3D view)."""

    elev: float
    azim: float
    vertical: str
    magnify: float
    label: str
    bodies: str = BODIES[0]
    plane: geometry.Plane | None = None

    @property
    def boxes(self) -> bool:
        """Whether the bodies' boxes are drawn."""
        return self.bodies != "skeleton"

    def title(self, text: str) -> str:
        scale = "" if self.magnify == 1 else f"; elastic deformation magnified {self.magnify:g}×"
        return f"{self.label}: {text}{scale}"


def gravity(model, params) -> np.ndarray:
    """The gravity vector (3,) of ``model`` at the parameter values ``params``."""
    values = {p.symbol: params[p.name] for p in model.parameters}
    return np.array([float(sp.sympify(v).subs(values)) for v in model.gravity])


def vertical_axis(model, params) -> str:
    """The axis of {0} nearest to gravity, signed to point against it ("z" when there is none):
    drawn upwards."""
    g = gravity(model, params)
    if not np.any(g):
        return "z"
    k = int(np.argmax(np.abs(g)))
    return ("-" if g[k] > 0 else "") + "xyz"[k]


def against_gravity(model, params) -> np.ndarray:
    """The unit vector (3,) against gravity, +z when there is none: upwards in the 2D view."""
    g = gravity(model, params)
    return -g / np.linalg.norm(g) if np.any(g) else np.array([0.0, 0.0, 1.0])


def pixels(dpi: int, size=FIGURE_SIZE) -> tuple[int, int]:
    """The width and height in pixels of a figure of ``size`` (inches) at ``dpi``."""
    return round(size[0] * dpi), round(size[1] * dpi)


class Canvas:
    """One axes with the artists of poses: 3D, showing {0} with ``view.vertical`` upwards, or 2D,
    the plane ``view.plane`` face-on, one scale on all axes. ``points`` (k, 3) are everything drawn
    over the frames (the axes hold them all). The layout is made once, with room for ``title``
    (the longest title a frame has), so that every frame has the same axes and nothing is cut off
    at the figure's edges."""

    def __init__(self, view: View, points, title: str = "", size=FIGURE_SIZE, dpi=100):
        plt = _pyplot()
        self.plt = plt
        self.bodies = view.bodies
        self.fig = plt.figure(figsize=size, dpi=dpi, layout=None if view.plane is None else "constrained")
        points = np.asarray(points, dtype=float).reshape(-1, 3)
        points = points[np.isfinite(points).all(axis=1)]
        if view.plane is None:
            self._space(view, points)
        else:
            self._plane(view.plane, points)
        self.title(title)
        if view.plane is None:  # the layout engines leave a 3D axes' labels where they fall
            _within(self.fig, self.ax)
        _freeze_layout(self.fig)

    def _space(self, view: View, points):
        from matplotlib.ticker import MaxNLocator

        # a cyclic permutation of x, y, z (it keeps the frame right-handed) puts the vertical axis last
        order = {"x": (1, 2, 0), "y": (2, 0, 1), "z": (0, 1, 2)}[view.vertical.lstrip("-")]
        self.project = np.eye(3)[:, list(order)]
        ax = self.ax = self.fig.add_axes((0.0, 0.0, 1.0, 1.0), projection="3d")  # made to fit: _within
        low, high = _fitted(points @ self.project)
        labels = [f"{'xyz'[k]} [m]" for k in order]
        ax.set(xlim=(low[0], high[0]), ylim=(low[1], high[1]), zlim=(low[2], high[2]),
               xlabel=labels[0], ylabel=labels[1], zlabel=labels[2])
        ax.set_box_aspect(high - low)
        for axis, width in zip((ax.xaxis, ax.yaxis, ax.zaxis), high - low):  # ticks as dense on each: short axes
            axis.set_major_locator(MaxNLocator(nbins=max(2, round(7 * width / np.max(high - low)))))  # had them overlap
        if view.vertical.startswith("-"):  # upside down: turned half a turn about the first axis
            ax.set_ylim(high[1], low[1])
            ax.set_zlim(high[2], low[2])
        ax.view_init(elev=view.elev, azim=view.azim)

    def _plane(self, plane: geometry.Plane, points):
        # an axis of {0} drawn backwards keeps its coordinate (the axis reversed, as the 3D view does)
        columns = [np.abs(d) if np.count_nonzero(d) == 1 else d for d in (plane.across, plane.up)]
        self.project = np.column_stack(columns)
        ax = self.ax = self.fig.add_subplot()
        low, high = _fitted(points @ self.project)
        ax.set_xlim(*((high[0], low[0]) if plane.across.sum() < 0 and np.count_nonzero(plane.across) == 1
                      else (low[0], high[0])))
        ax.set_ylim(*((high[1], low[1]) if plane.up.sum() < 0 and np.count_nonzero(plane.up) == 1
                      else (low[1], high[1])))
        ax.set_aspect("equal", adjustable="box")
        ax.set_xlabel(f"{_coordinate(plane.across)} [m]")
        ax.set_ylabel(f"{_coordinate(plane.up)} [m]")
        ax.grid(True, alpha=0.3)
        if plane.above:
            ax.text(0.99, 0.01, "seen from above: gravity into the page", transform=ax.transAxes, ha="right",
                    va="bottom", fontsize=8, color="0.3")

    def title(self, text: str):
        """Set the title to ``text``, in lines broken between words where it is wider than the
        figure; returns it."""
        title = self.ax.set_title(text, fontsize=9)
        room = self.fig.bbox.width - 2 * 4.0 * self.fig.dpi / 72  # _within's margins
        title.set_text(broken(text, room, title.get_window_extent(self.fig.canvas.get_renderer()).width))
        return title

    def _plot(self, xyz, **style):
        """One line through the points ``xyz`` (k, 3) of {0}."""
        return self.ax.plot(*(np.asarray(xyz) @ self.project).T, **style)[0]

    def draw(self, pose: geometry.Pose, colour=None):
        """Add the artists of ``pose``, all in ``colour`` when given; returns them."""
        artists = []
        if self.bodies != "boxes":
            artists.append(self._plot(pose.lines, color=colour or SKELETON, lw=1.8, marker="o", ms=3.5))
        if self.bodies != "skeleton":
            light = self.bodies == "both"
            artists.append(self._plot(_with_breaks(pose.edges), color=colour or (LIGHT_BODY if light else BODY),
                                      lw=0.6 if light else 0.8, alpha=0.4 if light and colour else 1.0))
        for chain in pose.chains:
            artists.append(self._plot(chain, color=colour or LINK, lw=2.2, marker="o", ms=2.5))
        if len(pose.points):
            artists.append(self._plot(pose.points, ls="", marker="o", ms=4, color=colour or POINT))
        return artists

    def trace(self, paths):
        """Add the paths (k, n_traced, 3) of the traced points; returns their artists."""
        return [self._plot(paths[:, j], color=TRACE, lw=0.8, ls="--") for j in range(paths.shape[1])]

    def rgba(self) -> np.ndarray:
        """The figure as it is drawn now, (h, w, 4) uint8."""
        self.fig.canvas.draw()
        return np.asarray(self.fig.canvas.buffer_rgba()).copy()

    def close(self):
        self.plt.close(self.fig)


def _within(fig, ax, pad: float = 4.0, tries: int = 12):
    """Shrink ``ax`` until everything it draws (title, tick labels, axis labels) lies within
    ``fig``, ``pad`` points from its edges: a 3D axes draws its box inside its position, centred,
    with its labels around, so each shrink by the overflow moves them in (by half of it at least)."""
    renderer = fig.canvas.get_renderer()
    width, height = fig.bbox.width, fig.bbox.height
    margin = pad * fig.dpi / 72
    for _ in range(tries):
        drawn = ax.get_tightbbox(renderer)
        over = np.maximum([margin - drawn.x0, margin - drawn.y0, drawn.x1 - width + margin,
                           drawn.y1 - height + margin], 0.0) / [width, height, width, height]
        if not over.any():
            return
        x0, y0, x1, y1 = ax.get_position().extents
        ax.set_position([x0 + over[0], y0 + over[1], x1 - over[2] - x0 - over[0], y1 - over[3] - y0 - over[1]])


def _fitted(coordinates) -> tuple[np.ndarray, np.ndarray]:
    """The lowest and highest value along each axis of the axes holding ``coordinates`` (k, d): one
    scale on all, a thin range widened about its middle (so that its ticks fit) and a margin."""
    low, high = coordinates.min(axis=0), coordinates.max(axis=0)
    width = np.maximum(high - low, 0.3 * np.max(high - low)) + 0.1 * max(np.max(high - low), 1e-3)
    return (low + high - width) / 2, (low + high + width) / 2


def _coordinate(direction) -> str:
    """The name of the coordinate along the unit vector ``direction`` of {0}: an axis ("x"), else
    the combination of x, y, z that it is ("0.6 x + 0.8 y")."""
    if np.count_nonzero(direction) == 1:
        return "xyz"[int(np.flatnonzero(direction)[0])]
    terms = [(c, name) for c, name in zip(direction, "xyz") if abs(c) >= 5e-4]
    text = " ".join(f"{'-' if c < 0 else '+'} {abs(c):.3g} {name}" for c, name in terms)
    return text[2:] if text.startswith("+") else "-" + text[2:]


def _with_breaks(edges) -> np.ndarray:
    """Segments (k, 2, 3) as one polyline with NaN rows between them (one artist for all)."""
    if not len(edges):
        return np.full((1, 3), np.nan)
    gaps = np.full((len(edges), 1, 3), np.nan)
    return np.concatenate([edges, gaps], axis=1).reshape(-1, 3)


def frames(t, every: int) -> np.ndarray:
    """The indices of the samples shown: every ``every``-th from the first."""
    return np.arange(0, len(t), every)


def traces(scene, loaded, q) -> np.ndarray:
    """The positions (k, n_traced, 3) of the traced points at every sample ``q`` (k, n), as
    computed (never magnified: the path the programmed constraints hold)."""
    index = [scene.points.index(p) for p in scene.traced]
    return np.array([loaded.point_positions(x)[index] for x in q]).reshape(len(q), len(index), 3)


def movie(scene, loaded, t, q, view: View, out, fps: float, every: int, dpi: int = 100, progress=None) -> Path:
    """Write the animation of the samples ``t`` (k,), ``q`` (k, n) to ``out`` (.gif or .mp4)."""
    fmt = format_of(out, still=False)
    shown = frames(t, every)
    limits.check_frames(*pixels(dpi), len(shown), len(shown))
    drawn = geometry.poses(scene, loaded, q[shown], view.magnify, view.boxes)
    paths = traces(scene, loaded, q)
    canvas = Canvas(view, geometry.everything(drawn, paths), view.title(f"t = {t[shown[-1]]:.2f} s"), dpi=dpi)
    images, step = [], max(1, len(shown) // 10)
    try:
        for n, (k, pose) in enumerate(zip(shown, drawn)):
            artists = canvas.draw(pose) + canvas.trace(paths[:k + 1])
            title = canvas.title(view.title(f"t = {t[k]:.2f} s"))
            images.append(canvas.rgba())
            for artist in artists:
                artist.remove()
            title.set_text("")
            if progress and ((n + 1) % step == 0 or n + 1 == len(shown)):
                progress(f"frame {n + 1} / {len(shown)}")
    finally:
        canvas.close()
    write = _gif(images, fps) if fmt == "gif" else _mp4(images, fps)
    return atomic_write(out, write)


def _gif(images, fps):
    from PIL import Image

    def write(fh):
        # one palette for all frames, from frames spread over the run (the colours of the traces
        # appear late): no flicker between frames, and the same bytes every time
        sample = np.concatenate([images[k][:, :, :3] for k in np.linspace(0, len(images) - 1, 6).astype(int)])
        palette = Image.fromarray(sample).quantize(colors=256, method=Image.Quantize.FASTOCTREE,
                                                   dither=Image.Dither.NONE)
        frames = [Image.fromarray(a[:, :, :3]).quantize(palette=palette, dither=Image.Dither.NONE) for a in images]
        frames[0].save(fh, format="GIF", save_all=True, append_images=frames[1:], duration=round(1000 / fps), loop=0)

    return write


def _mp4(images, fps):
    def write(fh):
        h, w = images[0].shape[:2]
        with tempfile.TemporaryDirectory(prefix="gpmegen-mp4-") as tmp:
            target = Path(tmp) / "arm.mp4"
            command = ["ffmpeg", "-loglevel", "error", "-y", "-f", "rawvideo", "-pix_fmt", "rgba", "-s", f"{w}x{h}",
                       "-r", f"{fps:g}", "-i", "-", "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", "-pix_fmt", "yuv420p",
                       "-map_metadata", "-1", "-fflags", "+bitexact", "-flags:v", "+bitexact", str(target)]
            done = subprocess.run(command, input=b"".join(a.tobytes() for a in images), capture_output=True)
            if done.returncode:
                why = done.stderr.decode(errors="replace").strip().splitlines()
                raise AnimationError(f"ffmpeg could not write the MP4 ({why[-1] if why else done.returncode}); "
                                     f"write a .gif instead")
            with open(target, "rb") as made:
                shutil.copyfileobj(made, fh)

    return write


def still(scene, loaded, t, q, view: View, times, out, dpi: int = 200) -> Path:
    """A figure of the arm at the samples nearest to each of ``times`` (s), overlaid, one colour
    each, with the traced points' path over the whole run; written to ``out`` (.png/.pdf/.svg)."""
    fmt = format_of(out, still=True)
    shown = [nearest(t, when) for when in times]
    limits.check_frames(*pixels(dpi), 1, 0)
    drawn = geometry.poses(scene, loaded, q[shown], view.magnify, view.boxes)
    paths = traces(scene, loaded, q)
    canvas = Canvas(view, geometry.everything(drawn, paths), view.title("deformed arm"), dpi=dpi)
    try:
        plt = canvas.plt
        colours = plt.get_cmap("viridis")(np.linspace(0.0, 0.85, len(shown)))
        handles = []
        for k, pose, colour in zip(shown, drawn, colours):
            handles.append(canvas.draw(pose, colour=tuple(colour))[0])
            handles[-1].set_label(f"t = {t[k]:.3g} s")
        canvas.trace(paths)
        canvas.ax.legend(handles=handles, loc="upper left" if view.plane is None else "best", fontsize=8,
                         frameon=False)

        def write(fh):
            import matplotlib

            with matplotlib.rc_context({"svg.hashsalt": _SVG_SALT}):
                canvas.fig.savefig(fh, format=fmt, dpi=dpi, metadata=_FILE_METADATA[fmt])

        return atomic_write(out, write)
    finally:
        canvas.close()


def nearest(t, when: float) -> int:
    """The index of the sample of ``t`` nearest to ``when`` (s); AnimationError outside the run."""
    if not t[0] - 1e-9 <= when <= t[-1] + 1e-9:
        raise RequestError(f"--still {when:g}: the results run from t = {t[0]:g} s to {t[-1]:g} s; choose times "
                             f"within them")
    return int(np.argmin(np.abs(np.asarray(t) - when)))



@dataclass(frozen=True)
class Subject:
    """What a results file shows: its ``results``, the ``loaded`` model bound to the run's
    parameter values, its ``scene`` and the symbolic ``model``."""

    results: dict
    loaded: object
    scene: geometry.Scene
    model: object

    def view(self, camera="auto", magnify: float = 1.0, bodies: str = BODIES[0]) -> View:
        """The view of the run with the deformation magnified ``magnify`` times: ``camera`` one of
        :data:`VIEWS` or the 3D view's (elevation, azimuth) in degrees. "auto" draws the arm in
        2D when it moves in one plane (see :meth:`plane`), else in 3D; "2d" refuses an arm that
        does not (RequestError, one line)."""
        label = literal(results_io.metadata(self.results).get("label") or self.loaded.module.MODEL)
        vertical = vertical_axis(self.model, self.loaded.params)
        plane = None
        if camera in ("auto", "2d"):
            plane, off, size = self.plane(magnify)
            if plane is None and camera == "2d":
                raise RequestError(f"--view 2d: the arm does not move in one plane (it leaves the nearest one by "
                                   f"{off:.3g} m, {off / size:.2g} of its size); draw it with --view 3d or auto")
        elev, azim = CAMERA if camera in VIEWS else camera
        return View(elev, azim, vertical, magnify, label, bodies, plane)

    def plane(self, magnify: float = 1.0) -> tuple[geometry.Plane | None, float, float]:
        """The plane the drawn arm (skeleton, rfe chains, named points; not the boxes) stays in at
        every saved sample of the run, with the deformation magnified ``magnify`` times, within
        :data:`~gpmegen.analysis.figures.arm_geometry.FLAT` of its size; None when it leaves every plane.
        With the largest distance from the nearest plane (m) and the arm's size (m): see
        :func:`~gpmegen.analysis.figures.arm_geometry.plane_of`."""
        q = self.results["q"]
        drawn = geometry.poses(self.scene, self.loaded, q, magnify)
        points = geometry.drawn_points(drawn, traces(self.scene, self.loaded, q))
        plane, off, size = geometry.plane_of(points, against_gravity(self.model, self.loaded.params))
        if plane is not None and not np.any(gravity(self.model, self.loaded.params)):
            plane = replace(plane, above=False)  # seen from +z, with no gravity to say so of
        return plane, off, size


def subject(path, model_path=None, progress=None) -> Subject:
    """The results file at ``path`` with the model that made it: the one its metadata names, or
    ``model_path`` (a model file) when given. One-line errors when there is none to draw."""
    results = results_io.load(path)
    meta = results_io.metadata(results)
    case = case_of_path(model_path) if model_path else case_of_source(meta.get("model_source"), path)
    model = case.model  # a built folder alone holds no model to draw: refused here in one line
    loaded = case.load("numpy", {}, progress or (lambda line: None))
    loaded = loaded.with_params(**{k: v for k, v in meta.get("params", {}).items() if k in loaded.params})
    if loaded.coordinates != tuple(str(c) for c in results["coordinates"]):
        raise RequestError(f"{path}: the results' coordinates are not those of model {loaded.module.MODEL}; give "
                             f"the model file that made them with --model")
    return Subject(results, loaded, geometry.scene(model, loaded), model)


def real_time_every(t, fps: float) -> int:
    """The sample step that plays the run in real time at ``fps`` frames per second."""
    step = float(np.median(np.diff(t))) if len(t) > 1 else 1.0
    return max(1, int(round(1.0 / (fps * step)))) if step > 0 else 1
