"""The paper's figures (joint coordinates, coordinates and path of E) plus constraint violation
and energy balance, for one or more runs of one model drawn together.

Each run keeps its colour and line style in every figure (:func:`styles`); the legend sits under
the axes; titles name the model, and the figure of a source a figure corresponds to (the paper's
figure number for the reference arm: its model's presentation) appears, in a caption line, only
when every run names the same. Figures are byte-reproducible: the layout is made once and
rounded, the files carry no dates and SVG ids come from a fixed salt.
"""

from __future__ import annotations

import re

import numpy as np

from ...errors import GpmegenError
from ..post.energy import balance_residual
from ..post.results import metadata

FORMATS = ("png", "pdf", "svg")
DPI = 200
# Metadata that would differ between two runs (dates) is left out; the rest is fixed.
_FILE_METADATA = {"png": {}, "pdf": {"CreationDate": None}, "svg": {"Date": None}}
_SVG_SALT = "gpmegen"
# The reference case's rigid and flexible arm ask for C0 and C2 (metadata "colour"): they come
# last, so that another run (a second start) does not take the colour of an arm missing from it.
PALETTE = ("C1", "C3", "C4", "C5", "C6", "C8", "C9", "C7", "C0", "C2")
LINESTYLES = ("-", "--", "-.", ":")
MARKERS = ("o", "s", "^", "D", "v", "P")
LEGEND_COLUMNS = 3
LEGEND_PAD, LEGEND_ROW, CAPTION_ROW = 0.1, 0.22, 0.23  # in: the strip under the axes
WINDOWS = 200   # the violation plot shows the largest |Φ| in each of this many windows of the run


class IncompatibleResults(GpmegenError):
    """Results of different models (or with different constraints) asked for one figure."""


def _pyplot():
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def literal(text) -> str:
    """``text`` as matplotlib draws it as it is: each ``$`` escaped, so that no part of it is read
    as mathtext. Text from a results file is drawn so: a label may hold broken TeX, or braces
    nested deeper than matplotlib's parser can recurse."""
    return str(text).replace("$", r"\$")


def start_tag(meta) -> str:
    """The tag of a run's start point: mathtext where its case writes it so (the paper's
    ``$E'_r$``) and matplotlib can parse it, else its text as it is."""
    from matplotlib import cbook
    from matplotlib.mathtext import MathTextParser

    tag = str(meta.get("start_tag", "start"))
    if not cbook.is_math_text(tag):
        return tag
    try:
        MathTextParser("path").parse(tag)
    except (ValueError, RecursionError):  # what its parser raises on broken or deeply nested TeX
        return literal(tag)
    return tag


def label(results) -> str:
    """A legend label, drawn as it is: the run's case's label (the model's name by default) and
    its start unless it is the locked statics; with what tells it from the runs it is drawn
    beside, where :func:`distinguished` put it there."""
    if LEGEND in results:
        return results[LEGEND]
    meta = metadata(results)
    text, start = literal(meta.get("label", meta["model"])), meta["start"]
    return text if start == "locked" else f"{text} (no statics)" if start == "none" else f"{text} ({start} start)"


LEGEND = "_legend"  # a run's label among others, set by distinguished() on a copy of its results
# The settings that can tell runs of one model apart, as a legend names them.
DISTINGUISHING = (("method", "{}"), ("dt", "dt {:g} s"), ("rtol", "rtol {:g}"), ("rho_inf", "ρ∞ {:g}"),
                  ("backend", "{}"))


def distinguished(runs: list) -> list:
    """Copies of ``runs`` whose legend labels name what differs between them where their own
    labels are alike: the settings of :data:`DISTINGUISHING` and the parameter values (runs by
    rk4, genalpha and dop853 of one model had one label for all three)."""
    base = [label(r) for r in runs]
    if len(set(base)) == len(base):
        return runs
    metas = [metadata(r) for r in runs]
    settings = [m.get("settings", {}) for m in metas]
    params = [m.get("params", {}) for m in metas]
    differ = []
    for key, form in DISTINGUISHING:
        values = [s.get(key) for s in settings]
        if len({repr(v) for v in values}) > 1:
            differ.append(lambda k, key=key, form=form: form.format(settings[k][key])
                          if settings[k].get(key) is not None else None)
    for name in sorted({n for p in params for n in p}):
        if len({repr(p.get(name)) for p in params}) > 1:
            differ.append(lambda k, name=name: f"{name} = {params[k][name]:.6g}" if name in params[k] else None)
    out = []
    for k, r in enumerate(runs):
        extra = [literal(text) for text in (d(k) for d in differ) if text]  # parameter names are the user's
        out.append({**r, LEGEND: base[k] + (f", {', '.join(extra)}" if extra else "")})
    return out


def joint_names(results) -> list:
    """The coordinates to draw as joints: those the run's case names, else the first three."""
    return metadata(results).get("joints") or [str(c) for c in results["coordinates"]][:3]


def family(results) -> str:
    """The model a run belongs to, whatever its number of rfes: its name without a trailing
    ``nrfe<N>`` (``arm_nrfe3`` → ``arm``)."""
    return re.sub(r"[_-]?nrfe\d+$", "", metadata(results)["model"]) or metadata(results)["model"]


def _kind(results) -> tuple:
    """What must be equal for two runs to share figures: the model and its constraints."""
    return family(results), tuple(str(c) for c in results["constraint_names"])


def check_compatible(runs: list, names=None) -> None:
    """Refuse (IncompatibleResults, one line) runs of different models or constraints; ``names``
    (e.g. the files) say which run is which."""
    names = list(names) if names is not None else [f"run {k + 1}" for k in range(len(runs))]
    groups: dict = {}
    for name, r in zip(names, runs):
        groups.setdefault(_kind(r), []).append(str(name))
    if len(groups) > 1:
        parts = "; ".join(f"{', '.join(members)}: model {model}, "
                          f"{len(cons)} constraint{'s' if len(cons) != 1 else ''}"
                          + (f" ({', '.join(cons)})" if cons else "")
                          for (model, cons), members in groups.items())
        raise IncompatibleResults(f"results of different models or constraints cannot share figures ({parts}); "
                                  f"plot each group on its own, with its own --out folder")


def styles(runs: list) -> list[dict]:
    """One style per run, the same in every figure: the colour its case asks for (rigid and
    flexible arm) unless an earlier run took it, else the next free one; line styles in turn."""
    taken, out = set(), []
    for k, r in enumerate(runs):
        wish = metadata(r).get("colour")
        free = next((c for c in PALETTE if c not in taken), PALETTE[k % len(PALETTE)])
        colour = wish if wish and wish not in taken else free
        taken.add(colour)
        out.append({"color": colour, "linestyle": LINESTYLES[k % len(LINESTYLES)],
                    "marker": MARKERS[k % len(MARKERS)]})
    return out


def _line(style) -> dict:
    """A run's style for a plain line (no markers)."""
    return {"color": style["color"], "linestyle": style["linestyle"]}


# A signal whose samples turn (a local extremum) at more than this share of them vibrates faster
# than they can draw: a line through them fills a band (a smooth motion turns a few times).
RINGING = 0.2


def ringing(values) -> bool:
    """Whether the samples ``values`` (k,) vibrate faster than a line through them can show."""
    step = np.diff(values)
    return len(values) > 2 * WINDOWS and np.count_nonzero(step[1:] * step[:-1] < 0) > RINGING * len(values)


def trace(ax, t, values, style, lw=1.2) -> bool:
    """``values`` (k,) against ``t`` in a run's ``style``: a line; for a :func:`ringing` signal
    (a flexible arm's kHz vibration saved every ms) its envelope, the least and largest in each of
    :data:`WINDOWS` windows, shaded in the run's colour, and the windows' mean as the line, so
    that the vibration neither becomes a solid block nor hides the other runs' curves. Returns
    whether it shaded an envelope (for the caption: :data:`SHADED`)."""
    if not ringing(values):
        ax.plot(t, values, **_line(style), lw=lw)
        return False
    chunks = np.array_split(np.arange(len(t)), min(WINDOWS, len(t)))
    middle = np.array([t[c[len(c) // 2]] for c in chunks])
    ax.fill_between(middle, [values[c].min() for c in chunks], [values[c].max() for c in chunks],
                    color=style["color"], alpha=0.25, lw=0)
    ax.plot(middle, [values[c].mean() for c in chunks], **_line(style), lw=lw)
    return True


SHADED = "shaded: the band of a vibration too fast for the samples"


def _shaded(caption, shaded: bool):
    """``caption`` (or None) with :data:`SHADED` where a panel shaded an envelope."""
    if not shaded:
        return caption
    return f"{caption.rstrip('.')}; {SHADED}." if caption else SHADED[0].upper() + SHADED[1:] + "."


def _title(runs, title) -> str:
    """``title`` naming the model of the runs (see :func:`family`)."""
    return f"{title}: {literal(family(runs[0]))}"


def _caption(runs, figure) -> str | None:
    """The source figure (e.g. "paper Fig. 2") when every run names the same one, else None."""
    sources = {metadata(r).get("figures", {}).get(figure) for r in runs}
    source = sources.pop() if len(sources) == 1 else None
    return f"Corresponds to {literal(source)}." if source else None


def _coordinate(results, name):
    names = [str(c) for c in results["coordinates"]]
    return results["q"][:, names.index(name)] if name in names else None


def _finish(fig, title, handles, caption=None):
    """Title, one legend under the axes (outside the data) and the caption line under it, in a
    strip added at the bottom of the figure, outside the layout. The legend has up to
    :data:`LEGEND_COLUMNS` columns, as many as fit the figure's width (runs told apart by their
    settings and parameters have long labels, which ran off both sides), and a label wider than
    the figure alone is broken into lines."""
    fig.suptitle(title)
    legend, rows = _legend(fig, handles)
    foot = LEGEND_PAD + LEGEND_ROW * rows + (CAPTION_ROW if caption else 0.0)  # in
    height = fig.get_figheight() + foot
    fig.set_figheight(height)
    fig.get_layout_engine().set(rect=(0, foot / height, 1, 1 - foot / height))
    legend.set_bbox_to_anchor((0.5, foot / height), transform=fig.transFigure)
    if caption:
        fig.text(0.5, 0.04 / height, caption, ha="center", va="bottom", fontsize=9, style="italic", color="0.3")
    _freeze_layout(fig)


def _legend(fig, handles):
    """The figure's legend of ``handles`` in as many columns (up to :data:`LEGEND_COLUMNS`) as fit
    its width, labels broken into lines where one column does not; with its number of lines."""
    renderer = fig.canvas.get_renderer()
    room = fig.bbox.width - 2 * LEGEND_PAD * fig.dpi
    for columns in range(min(len(handles), LEGEND_COLUMNS), 0, -1):
        legend = fig.legend(handles=handles, loc="upper center", ncols=columns, fontsize=9, frameon=False)
        legend.set_in_layout(False)
        if legend.get_window_extent(renderer).width <= room or columns == 1:
            break
        legend.remove()
    texts = legend.get_texts()
    widths = [text.get_window_extent(renderer).width for text in texts]
    room_for_text = room - (legend.get_window_extent(renderer).width - max(widths))
    if columns > 1 or max(widths) <= room_for_text:
        return legend, -(-len(handles) // columns)
    for text, width in zip(texts, widths):
        text.set_text(broken(text.get_text(), room_for_text, width))
    return legend, sum(text.get_text().count("\n") + 1 for text in texts)


def broken(text: str, room: float, width: float) -> str:
    """``text``, drawn ``width`` wide, in lines broken between words to fit ``room`` (the same
    unit): as it is when it fits."""
    import textwrap

    if width <= room:
        return text
    return "\n".join(textwrap.wrap(text, max(10, int(len(text) * room / width))))


def _freeze_layout(fig):
    """Make the layout once and keep it, its positions rounded to 1e-5 of the figure: the layout
    solver's last digits can differ between two figures of the same data (the order it meets
    the axes in), which would change the bytes of the file."""
    fig.canvas.draw()
    fig.set_layout_engine("none")
    for ax in fig.axes:
        ax.set_position(np.round(ax.get_position().bounds, 5))


def _run_handles(runs, style, marker=False):
    from matplotlib.lines import Line2D

    return [Line2D([], [], **(s if marker else _line(s)), label=label(r)) for r, s in zip(runs, style)]


def _figure(plt, rows, cols, height, width=8.0, **kwargs):
    """A figure of ``rows`` x ``cols`` axes, ``width`` x ``height`` in before :func:`_finish` adds
    the strip for the legend and the caption."""
    fig, axes = plt.subplots(rows, cols, figsize=(width, height), squeeze=False, layout="constrained", **kwargs)
    return fig, axes


def joint_coordinates(plt, runs, style):
    """Paper Fig. 2: the joint coordinates against time, one panel each."""
    joints = joint_names(runs[0])
    pretty = metadata(runs[0]).get("joint_labels", {})
    fig, axes = _figure(plt, len(joints), 1, 2.2 * len(joints) + 1.0, sharex=True)
    shaded = False
    for r, s in zip(runs, style):
        for ax, name in zip(axes[:, 0], joints):
            v = _coordinate(r, name)
            if v is not None:
                shaded |= trace(ax, r["t"], v, s)
    for ax, name in zip(axes[:, 0], joints):
        ax.set_ylabel(literal(pretty.get(name, name)))
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("t [s]")
    _finish(fig, _title(runs, "Joint coordinates"), _run_handles(runs, style),
            _shaded(_caption(runs, "joint_coordinates"), shaded))
    return fig


def end_effector(plt, runs, style):
    """Paper Fig. 3: the coordinates of E against time, with a prescribed coordinate if any."""
    from matplotlib.lines import Line2D

    fig, axes = _figure(plt, 3, 1, 7.5, sharex=True)
    axes = axes[:, 0]
    extra, shaded = [], False
    for r, s in zip(runs, style):
        for i, ax in enumerate(axes):
            shaded |= trace(ax, r["t"], r["end_effector"][:, i], s)
        prescribed = metadata(r).get("prescribed")
        if prescribed and "prescribed" in r:
            axes[prescribed["axis"]].plot(r["t"], r["prescribed"], ":", color="k", lw=1)
            if not extra:
                extra.append(Line2D([], [], linestyle=":", color="k", lw=1, label=literal(prescribed["label"])))
    for ax, name in zip(axes, ("x_E [m]", "y_E [m]", "z_E [m]")):
        ax.set_ylabel(name)
        ax.grid(True, alpha=0.3)
    axes[-1].set_xlabel("t [s]")
    _finish(fig, _title(runs, "Coordinates of the end-effector E"), _run_handles(runs, style) + extra,
            _shaded(_caption(runs, "end_effector"), shaded))
    return fig


def path(plt, runs, style):
    """Paper Fig. 4: the path of E in the x0z0 and x0y0 planes, starting points marked."""
    fig, axes = _figure(plt, 1, 2, 5.0, width=11.0)
    a1, a2 = axes[0]
    for r, s in zip(runs, style):
        E, meta = r["end_effector"], metadata(r)
        for ax, (i, j) in ((a1, (0, 2)), (a2, (0, 1))):
            ax.plot(E[:, i], E[:, j], **_line(s), lw=1)
            ax.plot(E[0, i], E[0, j], "o", ms=7, color=s["color"])
            # the case may place the tag; else a start at the right of the path is tagged on its left
            inward = 1 if "tag_offset" in meta else _inward(E[:, i], E[0, i])
            ax.annotate(start_tag(meta), (E[0, i], E[0, j]), textcoords="offset points",
                        xytext=meta.get("tag_offset", (8 * inward, -14)), ha="left" if inward > 0 else "right",
                        fontsize=12)
    a1.set_xlabel("x0 [m]"), a1.set_ylabel("z0 [m]"), a1.set_aspect("equal", "datalim")
    a2.set_xlabel("x0 [m]"), a2.set_ylabel("y0 [m]")
    a1.set_title("x0z0 plane", fontsize=10)
    a2.set_title("x0y0 plane", fontsize=10)
    for ax in (a1, a2):
        ax.grid(True, alpha=0.3)
    _finish(fig, _title(runs, "Path of the end-effector E"), _run_handles(runs, style),
            _caption(runs, "path"))
    return fig


def _inward(values, start) -> int:
    """+1 when ``start`` lies in the lower half of the range of ``values``, else -1: the side of
    the start point on which its tag stays within the axes."""
    low, high = np.min(values), np.max(values)
    return 1 if start <= (low + high) / 2 else -1


def window_maxima(t, values, windows=WINDOWS):
    """The largest of ``values`` in each of ``windows`` consecutive windows of samples, at the
    time of the window's middle sample: (times, maxima)."""
    chunks = np.array_split(np.arange(len(t)), min(windows, len(t)))
    return (np.array([t[c[len(c) // 2]] for c in chunks]), np.array([values[c].max() for c in chunks]))


def log_floor(values) -> float:
    """Where zeros are drawn on a log axis: a decade below the smallest positive of ``values``
    (1e-18 when there is none)."""
    values = np.concatenate([np.ravel(v) for v in values])
    positive = values[values > 0]
    return 10.0 ** (np.floor(np.log10(positive.min())) - 1) if positive.size else 1e-18


def _violation_panel(ax, runs, style, i) -> bool:
    """|Φ| of constraint ``i`` of every run on ``ax``; whether exact zeros were drawn (on the floor)."""
    curves = [window_maxima(r["t"], np.abs(r["phi"][:, i])) for r in runs]
    floor = log_floor([top for _, top in curves])
    for (t, top), s in zip(curves, style):
        ax.semilogy(t, np.maximum(top, floor), **s, lw=1, ms=4, markevery=max(1, len(t) // 12))
    zeros = any((top == 0).any() for _, top in curves)
    if zeros:
        ax.axhline(floor, color="0.5", lw=0.8, linestyle=":")
        ax.annotate("exact 0", (1, floor), xycoords=("axes fraction", "data"), xytext=(-4, 3),
                    textcoords="offset points", ha="right", fontsize=8, color="0.4")
    return zeros


def constraint_violation(plt, runs, style):
    """|Φ| of each constraint (one panel each) on a log axis: the largest value in each window of
    the run, markers thinned out; exact zeros drawn on a marked floor line."""
    names = [str(c) for c in runs[0]["constraint_names"]]
    units = metadata(runs[0]).get("constraint_units", {})
    fig, axes = _figure(plt, len(names), 1, 2.2 * len(names) + 1.2, sharex=True)
    zeros = [_violation_panel(ax, runs, style, i) for i, ax in enumerate(axes[:, 0])]
    for ax, name in zip(axes[:, 0], names):
        ax.set_ylabel(literal(f"|Φ {name}|" + (f" [{units[name]}]" if name in units else "")))
        ax.grid(True, alpha=0.3)
    axes[-1, 0].set_xlabel("t [s]")
    caption = f"Largest |Φ| in each of {min(WINDOWS, len(runs[0]['t']))} windows of the run"
    _finish(fig, _title(runs, "Constraint violation"), _run_handles(runs, style, marker=True),
            caption + ("; exact zeros on the dotted line." if any(zeros) else "."))
    return fig


ENERGY_PANELS = (
    ("ΔT kinetic [J]", lambda r: r["kinetic_energy"] - r["kinetic_energy"][0]),
    ("ΔV gravity [J]", lambda r: r["gravity_energy"] - r["gravity_energy"][0]),
    ("ΔV springs [J]", lambda r: r["spring_energy"] - r["spring_energy"][0]),
    ("W drive [J]", lambda r: r["work_drive"]),
    ("W constraints [J]", lambda r: r["work_constraints"]),
    ("W dampers [J]", lambda r: r["work_dampers"] if "work_dampers" in r else np.zeros(len(r["t"]))),
    ("residual ΔE − W [J]", lambda r: balance_error(r)),
)


def balance_error(results):
    """ΔE − W, J: :func:`gpmegen.analysis.post.energy.balance_residual` (the dampers' work is a term of
    the balance, not part of the error)."""
    return balance_residual(results)


def energy_balance(plt, runs, style):
    """Each energy term and work since the start in its own panel, the balance error in the last."""
    fig, axes = _figure(plt, 4, 2, 9.5, width=10.0, sharex=True)
    axes[-1, -1].set_visible(False)
    for ax, (name, value) in zip(axes.ravel(), ENERGY_PANELS):
        for r, s in zip(runs, style):
            ax.plot(r["t"], value(r), **_line(s), lw=1.2)
        ax.set_ylabel(name)
        ax.grid(True, alpha=0.3)
    for ax in axes[-1]:
        ax.set_xlabel("t [s]")
    _finish(fig, _title(runs, "Energy balance"), _run_handles(runs, style),
            "ΔE = ΔT + ΔV gravity + ΔV springs against W = W drive + W constraints + W dampers; "
            "the residual is what the balance leaves.")
    return fig


def force_elements(plt, runs, style):
    """Each force element between points in a column of three panels: its length, rate and force
    (positive pushing its points apart) against time."""
    names = [str(n) for n in runs[0]["force_names"]]
    fig, axes = _figure(plt, 3, len(names), 6.5, width=max(8.0, 4.0 * len(names)), sharex=True)
    for j, name in enumerate(names):
        for r, s in zip(runs, style):
            column = [str(n) for n in r["force_names"]].index(name)
            for i in range(3):
                axes[i, j].plot(r["t"], r["force_elements"][:, column, i], **_line(s), lw=1.2)
        for i, quantity in enumerate(("L [m]", "dL/dt [m/s]", "F [N]")):
            axes[i, j].set_ylabel(literal(f"{name}: {quantity}"))
            axes[i, j].grid(True, alpha=0.3)
        axes[-1, j].set_xlabel("t [s]")
    _finish(fig, _title(runs, "Forces between points"), _run_handles(runs, style),
            "Length, rate and force of each force element; F > 0 pushes its two points apart.")
    return fig


def _saver(fig, fmt):
    def write(fh):
        import matplotlib

        with matplotlib.rc_context({"svg.hashsalt": _SVG_SALT}):
            fig.savefig(fh, format=fmt, dpi=DPI, metadata=_FILE_METADATA[fmt])

    return write
