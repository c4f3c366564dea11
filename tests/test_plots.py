"""Figures: one style per run in every figure, titles that name the model, readable violation
and energy plots, refusal of results of different models before any file is written, 200 dpi
PNG plus PDF and SVG, and the same bytes for the same input."""

from __future__ import annotations

import matplotlib
import numpy as np
import pytest

from gpmegen.analysis.figures import plots, run_figures
from gpmegen.analysis.post import results as results_io
from gpmegen.analysis.run import runs
from gpmegen.analysis.run.reference_case import ReferenceCase
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.cli import main

matplotlib.use("Agg")


def _quiet(message):
    pass


@pytest.fixture(scope="module")
def pair(tmp_path_factory):
    """Short runs of the rigid and a flexible arm (NumPy backend), as saved and loaded."""
    folder = tmp_path_factory.mktemp("runs")
    loaded = []
    for nrfe in (1, 2):
        out = folder / f"run_nrfe{nrfe}.npz"
        runs.run(ReferenceCase(nrfe), RunSpec(start="locked", t_end=0.05, dt=1e-3, save_every=5, method="rk4"),
                 "numpy", {}, out, _quiet)
        loaded.append(results_io.load(out))
    return folder, loaded


def _with_meta(results, **changes):
    return dict(results, meta=results_io.encode({**results_io.metadata(results), **changes}))


def _drawn(fig):
    """The colours of the lines in ``fig``'s axes, the black and grey reference lines left out."""
    from matplotlib.colors import to_hex

    return {to_hex(line.get_color()) for ax in fig.axes for line in ax.get_lines()} - {"#000000", "#808080"}


# make check-c: every figure of the pair drawn again (runs told apart:
# test_runs_of_one_model_by_different_methods_get_labels_that_tell_them_apart)
@pytest.mark.long
def test_each_run_keeps_its_colour_and_line_style_in_every_figure(pair):
    """The flexible arm used to be orange in Figs. 2-3 and green in Fig. 4."""
    from matplotlib.colors import to_hex

    _, loaded = pair
    plt = plots._pyplot()
    style = plots.styles(loaded)
    assert [s["color"] for s in style] == ["C0", "C2"]  # the reference case's rigid and flexible colours
    assert style[0]["linestyle"] != style[1]["linestyle"]
    stems = [stem for stem, _ in run_figures.figures(loaded)]
    assert {"driving_functions", "elastic_deformation", "constraint_multipliers"} <= set(stems)
    for stem, draw in run_figures.figures(loaded):
        fig = draw(plt, loaded, style)
        # the elastic deformation is drawn for the runs with springs only (here the flexible arm)
        shown = [k for k, r in enumerate(loaded) if stem != "elastic_deformation" or np.any(r["spring_forces"])]
        try:
            assert _drawn(fig) == {to_hex(style[k]["color"]) for k in shown}, stem
            legend = {text.get_text(): to_hex(line.get_color())
                      for text, line in zip(fig.legends[0].get_texts(), fig.legends[0].get_lines())}
            assert {plots.label(loaded[k]): legend[plots.label(loaded[k])] for k in shown} == \
                   {plots.label(loaded[k]): to_hex(style[k]["color"]) for k in shown}, stem
            # the legend is the figure's, outside every axes
            assert not any(ax.get_legend() for ax in fig.axes), stem
        finally:
            plt.close(fig)


def test_runs_asking_for_the_same_colour_get_different_ones(pair):
    """Two flexible runs (locked and constrained starts) both ask for the flexible arm's colour."""
    _, (rigid, flexible) = pair
    twin = _with_meta(flexible, start="constrained")
    colours = [s["color"] for s in plots.styles([rigid, flexible, twin])]
    assert colours[:2] == ["C0", "C2"] and len(set(colours)) == 3


def test_titles_name_the_model_and_only_the_reference_case_cites_the_paper(pair):
    _, loaded = pair
    plt = plots._pyplot()
    mine = [_with_meta(r, model=f"crane_nrfe{k + 1}", figures={}, label=f"crane {k + 1}")
            for k, r in enumerate(loaded)]
    for runs_, cited in ((loaded, True), (mine, False)):
        fig = plots.joint_coordinates(plt, runs_, plots.styles(runs_))
        texts = [fig._suptitle.get_text()] + [t.get_text() for t in fig.texts]
        plt.close(fig)
        assert texts[0] == ("Joint coordinates: manipulator" if cited else "Joint coordinates: crane")
        assert any("paper Fig. 2" in t for t in texts) is cited
        assert not any("paper" in t for t in texts[:1])


def test_window_maxima_are_the_largest_values_of_each_window():
    rng = np.random.default_rng(3)
    t = np.linspace(0, 1, 1001)
    values = rng.random(1001)
    times, tops = plots.window_maxima(t, values, windows=7)
    chunks = np.array_split(np.arange(1001), 7)
    assert tops.tolist() == [values[c].max() for c in chunks]
    assert all(t[c[0]] <= tm <= t[c[-1]] for tm, c in zip(times, chunks))


def test_exact_zeros_are_drawn_on_a_floor_a_decade_below_the_smallest_violation(pair):
    """Exact zeros used to be clipped to 1e-18 (a barcode of 1e5 samples)."""
    _, (rigid, _) = pair
    samples = 100 * plots.WINDOWS
    phi = np.full((samples, len(rigid["constraint_names"])), 2e-14)
    phi[: samples // 2, 0] = 0.0            # the first half of the first constraint holds exactly
    phi[samples // 2:, 0] = 3e-15
    zeroed = dict(rigid, t=np.linspace(0.0, 1.0, samples), phi=phi)
    assert plots.log_floor([phi[:, 0]]) == pytest.approx(1e-16)
    plt = plots._pyplot()
    fig = plots.constraint_violation(plt, [zeroed], plots.styles([zeroed]))
    try:
        first = fig.axes[0]
        data = [line for line in first.get_lines() if line.get_marker() not in ("None", "", None)][0]
        y = data.get_ydata()
        assert len(y) == plots.WINDOWS and np.all(y > 0)  # decimated, log-safe
        assert set(np.round(y / 1e-16, 9)) == {1.0, 30.0}  # zeros on the floor, the rest as they are
        assert len(fig.axes) == len(rigid["constraint_names"])  # one panel per constraint
        assert first.get_yscale() == "log"
        assert any("exact zeros" in t.get_text() for t in fig.texts)
    finally:
        plt.close(fig)


def test_energy_terms_and_the_balance_error_have_panels_of_their_own(pair):
    _, (rigid, flexible) = pair
    plt = plots._pyplot()
    fig = plots.energy_balance(plt, [rigid, flexible], plots.styles([rigid, flexible]))
    try:
        labels = [ax.get_ylabel() for ax in fig.axes]
        assert labels[:len(plots.ENERGY_PANELS)] == [name for name, _ in plots.ENERGY_PANELS]
        assert labels[len(plots.ENERGY_PANELS) - 1] == "residual ΔE − W [J]"
        for ax, (_, value) in zip(fig.axes, plots.ENERGY_PANELS):
            for line, r in zip(ax.get_lines(), (rigid, flexible)):
                np.testing.assert_array_equal(line.get_ydata(), value(r))
    finally:
        plt.close(fig)
    # the balance error of a run is its energy change less the work, computed independently
    total = rigid["kinetic_energy"] + rigid["gravity_energy"] + rigid["spring_energy"]
    expected = (total - total[0]) - (rigid["work_drive"] + rigid["work_constraints"] + rigid["work_dampers"])
    np.testing.assert_allclose(plots.balance_error(rigid), expected, rtol=0, atol=0)
    # and it is small against the work done: the power balance holds (RK4, dt = 1e-3 s)
    assert np.abs(expected).max() < 1e-6 * np.abs(rigid["work_constraints"]).max()


@pytest.mark.long
def test_figures_are_png_at_200_dpi_pdf_and_svg_and_the_same_bytes_every_time(pair, tmp_path):
    _, loaded = pair
    first = run_figures.plot_all(loaded, tmp_path / "a", ("png", "pdf", "svg"))
    second = run_figures.plot_all(loaded, tmp_path / "b", ("png", "pdf", "svg"))
    assert {p.name for p in first} == {f"{stem}.{fmt}" for stem, _ in run_figures.figures(loaded)
                                       for fmt in ("png", "pdf", "svg")}
    _same_bytes_and_formats(first, second)


def test_a_figure_is_png_at_200_dpi_pdf_and_svg_and_the_same_bytes_every_time(pair, tmp_path):
    """The formats and their sameness on the first figure, drawn twice as plot_all draws it (every
    figure: the test above, in make check-c)."""
    from gpmegen.fileio import atomic_write_all

    _, loaded = pair
    runs = plots.distinguished(loaded)
    plt, style = plots._pyplot(), plots.styles(runs)
    stem, draw = run_figures.figures(runs)[0]

    def write(folder):
        fig = draw(plt, runs, style)
        try:
            return atomic_write_all({folder / f"{stem}.{fmt}": plots._saver(fig, fmt) for fmt in plots.FORMATS})
        finally:
            plt.close(fig)

    _same_bytes_and_formats(write(tmp_path / "a"), write(tmp_path / "b"))


def _same_bytes_and_formats(first: list, second: list) -> None:
    """The files of two drawings are byte for byte the same, PNG at 200 dpi, PDF and SVG without dates."""
    from PIL import Image

    assert {p.suffix for p in first} == {".png", ".pdf", ".svg"}
    for a, b in zip(first, second, strict=True):
        assert a.read_bytes() == b.read_bytes(), a.name
    for path in first:
        data = path.read_bytes()
        if path.suffix == ".png":
            dpi = Image.open(path).info["dpi"]
            assert [round(d) for d in dpi] == [200, 200]
        elif path.suffix == ".pdf":
            assert data.startswith(b"%PDF") and b"CreationDate" not in data
        else:
            assert b"<svg" in data and b"<dc:date>" not in data


def test_plot_refuses_results_of_different_models_before_writing_anything(pair, tmp_path, capsys):
    """Results with different numbers of constraints used to crash plot after three of five figures."""
    folder, (rigid, _) = pair
    other = _with_meta(dict(rigid, phi=rigid["phi"][:, :1], constraint_names=np.array(["circle"])),
                       model="crane_nrfe1")
    path = tmp_path / "crane.npz"
    results_io.save(other, path)
    out = tmp_path / "figures"
    assert main(["plot", str(folder / "run_nrfe1.npz"), str(path), "--out", str(out), "--format", "png,svg"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and err[0].startswith("gpmegen plot: error: results of different models")
    assert "crane.npz: model crane, 1 constraint (circle)" in err[0]
    assert "model manipulator, 2 constraints (circle, height)" in err[0]
    assert not out.exists()


# make check-c: every figure of two runs drawn through the command line: about 11 s of CPU
@pytest.mark.long
def test_results_of_one_model_with_any_number_of_rfes_share_figures(pair, tmp_path, capsys):
    folder, _ = pair
    out = tmp_path / "figures"
    argv = ["plot", str(folder / "run_nrfe1.npz"), str(folder / "run_nrfe2.npz"), "--out", str(out)]
    assert main([*argv, "--format", "PDF,svg"]) == 0
    written = capsys.readouterr().out.split()
    assert sorted(written) == sorted(str(out / f"{stem}.{fmt}") for stem in
                                     ("joint_coordinates", "end_effector", "path", "constraint_violation",
                                      "energy_balance", "driving_functions", "elastic_deformation",
                                      "constraint_multipliers") for fmt in ("pdf", "svg"))
    assert {plots.family(results_io.load(folder / f"run_nrfe{n}.npz")) for n in (1, 2)} == {"manipulator"}


def test_runs_of_one_model_by_different_methods_get_labels_that_tell_them_apart(pair, tmp_path):
    """Runs by rk4, genalpha and dop853 of one model had one legend entry for all three: the labels
    name what differs (method, step, parameter values), and every figure's legend has three."""
    _, (rigid, _) = pair
    settings = results_io.metadata(rigid)["settings"]
    params = results_io.metadata(rigid)["params"]
    variants = [_with_meta(rigid, settings={**settings, "method": m, "dt": dt}) for m, dt in
                (("rk4", 1e-3), ("genalpha", 1e-3), ("genalpha", 1e-4))]
    variants.append(_with_meta(rigid, params={**params, "m3": 2 * params["m3"]}))
    labels = [plots.label(r) for r in plots.distinguished(variants)]
    assert len(set(labels)) == 4, labels
    assert "genalpha, dt 0.0001 s" in labels[2] and "m3 = " in labels[3] and "m3 = " in labels[0]
    assert [plots.label(r) for r in plots.distinguished([rigid])] == [plots.label(rigid)]
    import matplotlib.pyplot as plt

    for stem, draw in run_figures.figures(variants):
        fig = draw(plt, plots.distinguished(variants), plots.styles(variants))
        texts = {t.get_text() for legend in fig.legends for t in legend.get_texts()}
        assert set(labels) <= texts, stem
        plt.close(fig)


def test_a_vibration_faster_than_the_samples_is_drawn_as_its_band_not_a_block(pair):
    """A flexible arm's 1.6 kHz ringing saved every 1 ms, drawn as a line, became a solid block that
    hid the rigid arm's curve: such a signal is drawn as its envelope, shaded, with its mean as the
    line (at most WINDOWS points); a smooth one stays a line through every sample."""
    import matplotlib.pyplot as plt
    from matplotlib.collections import PolyCollection

    _, (rigid, flexible) = pair
    t = np.arange(10001) * 1e-3
    smooth = 0.3 * np.sin(2 * np.pi * t / 10)
    ringing = smooth + 1e-3 * np.sin(2 * np.pi * 1600 * t + 0.3)
    assert plots.ringing(ringing) and not plots.ringing(smooth)

    def run(results, theta):
        q = np.zeros((len(t), results["q"].shape[1]))
        q[:, 0] = theta
        return {**results, "t": t, "q": q}

    runs_ = [run(rigid, smooth), run(flexible, ringing)]
    style = plots.styles(runs_)
    fig = plots.joint_coordinates(plt, runs_, style)
    ax = fig.axes[0]
    lines = {len(line.get_xdata()) for line in ax.get_lines()}
    assert lines == {len(t), plots.WINDOWS}
    bands = [c for c in ax.collections if isinstance(c, PolyCollection)]
    assert len(bands) == 1
    band = bands[0].get_paths()[0].vertices[:, 1]
    assert band.max() >= ringing.max() - 1e-12 and band.min() <= ringing.min() + 1e-12
    assert any("Shaded: the band" in text.get_text() or "shaded: the band" in text.get_text() for text in fig.texts)
    plt.close(fig)


BROKEN_TEX = r"$\frac{a$"
NESTED = "$" + "{" * 3000 + "x" + "}" * 3000 + "$"


ODD_META = {"label": BROKEN_TEX, "start_tag": NESTED, "joint_labels": {"theta1": NESTED},
            "prescribed": {"axis": 1, "label": BROKEN_TEX}, "constraint_units": {"circle": NESTED},
            "figures": {"path": BROKEN_TEX}, "force_units": {"theta1": NESTED}, "lambda_units": {"height": NESTED}}


@pytest.mark.long
def test_text_from_a_results_file_is_drawn_as_it_is_in_every_figure(pair, tmp_path, capsys):
    """Every figure plot writes, of a results file whose texts are broken TeX and 3,000 nested
    braces (the test below looks at one figure's text, in make test)."""
    _, (rigid, _) = pair
    path = tmp_path / "odd.npz"
    results_io.save(_with_meta(rigid, **ODD_META), path)
    assert main(["plot", str(path), "--out", str(tmp_path / "figures")]) == 0
    captured = capsys.readouterr()
    assert captured.err == "" and len(captured.out.split()) == len(run_figures.figures([rigid]))


def test_text_from_a_results_file_is_drawn_as_it_is_never_read_as_tex(pair, tmp_path):
    """A run label with broken TeX was an internal error (matplotlib's ParseSyntaxException), and
    one of 3,000 nested braces a RecursionError: text from a results file is drawn literally
    (the reference case's start tag, $E'_r$, stays mathtext where it parses)."""
    _, (rigid, _) = pair
    path = tmp_path / "odd.npz"
    results_io.save(_with_meta(rigid, **ODD_META), path)
    plt = plots._pyplot()
    fig = plots.joint_coordinates(plt, [results_io.load(path)], plots.styles([rigid]))
    fig.canvas.draw()  # where TeX would be parsed, and fail
    [shown] = fig.legends[0].get_texts()
    plt.close(fig)
    assert shown._preprocess_math(shown.get_text()) == (BROKEN_TEX, False)  # drawn as it is, not as TeX
    nested = plots.label(_with_meta(rigid, label=NESTED))
    assert nested == plots.literal(NESTED) and not matplotlib.cbook.is_math_text(nested)


def test_the_reference_case_s_start_tag_is_still_mathtext(pair):
    _, (rigid, _) = pair
    tag = plots.start_tag(results_io.metadata(rigid))
    assert tag == "$E'_r$" and matplotlib.cbook.is_math_text(tag)


def _every_figure(runs):
    """(stem, figure) of every figure plot writes for ``runs``, each closed once looked at."""
    runs = plots.distinguished(runs)
    plt = plots._pyplot()
    style = plots.styles(runs)
    for stem, draw in run_figures.figures(runs):
        fig = draw(plt, runs, style)
        try:
            yield stem, fig
        finally:
            plt.close(fig)


def test_no_text_of_any_figure_falls_outside_it(pair):
    """Every figure plot writes (those of the demo, the driving functions, the elastic deformation
    and the multipliers): every text drawn, measured by the renderer, lies within the figure."""
    from drawn_text import outside

    made = []
    for stem, fig in _every_figure(pair[1]):
        made.append(stem)
        assert outside(fig) == [], stem
    assert {"joint_coordinates", "end_effector", "path", "constraint_violation", "energy_balance"} <= set(made)


# make check-c: every figure of six runs drawn and measured (text inside the figure:
# test_no_text_of_any_figure_falls_outside_it)
@pytest.mark.long
def test_long_legend_labels_stay_within_the_figure_whole(pair):
    """Runs told apart by their method, step, tolerance and two parameters have labels too long
    for three columns, or one: they ran off both sides of every figure. Their legend has fewer
    columns and labels broken into lines, every word kept, and nothing falls outside."""
    from drawn_text import outside

    base = pair[1][1]
    meta = results_io.metadata(base)
    variants = []
    for k, method in enumerate(("rk4", "genalpha", "dop853", "radau")):
        settings = {**meta["settings"], "method": method, "dt": 1e-3 / (k + 1), "rtol": 1e-6 * (k + 1)}
        params = {**meta["params"], "young_modulus_of_the_second_link": 7e10 * (k + 1), "density_of_it": 2700 + k}
        variants.append(_with_meta(base, settings=settings, params=params))
    labels = [plots.label(r) for r in plots.distinguished(variants)]
    assert min(len(label) for label in labels) > 110
    broken = []
    for stem, fig in _every_figure(variants):
        assert outside(fig) == [], stem
        [legend] = fig.legends
        drawn = [text.get_text() for text in legend.get_texts()][:len(labels)]  # the runs first
        assert [text.replace("\n", " ") for text in drawn] == labels
        broken.append(all("\n" in text for text in drawn))
    assert any(broken)  # in the 8 in wide figures
