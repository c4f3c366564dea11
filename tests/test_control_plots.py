"""Figures of control in ``gpmegen plot`` (gpmegen/analysis/figures/control_plots.py): the saved
tracking error and the drives' forces, drawn when the runs hold them and not otherwise, the same
bytes twice; ``plot --reference`` writes the metrics of ``gpmegen metrics`` beside the figures.

The runs: the perfect-model arm under computed torque started off its reference
(tests/models/ct_arm.toml), and the cart of tests/test_tracking.py, ideal under its programmed
step and as a plant under a PD law towards it."""

from __future__ import annotations

from pathlib import Path

import matplotlib
import numpy as np
import pytest
from test_tracking import CONSTRAINT, DRIVE, T_END, cart

import gpmegen
from gpmegen.analysis.figures import control_plots, plots
from gpmegen.analysis.figures.figure_list import stems
from gpmegen.analysis.post import results as results_io
from gpmegen.cli import main

matplotlib.use("Agg")
ARM = Path(__file__).parent / "models" / "ct_arm.toml"
# the cart's step switches by Min/Max at t = T (tests/test_tracking.py)
pytestmark = pytest.mark.filterwarnings("ignore:constraint 'move'. its law switches")


@pytest.fixture(scope="module")
def files(tmp_path_factory, env):
    """Saved runs: ``arm.npz`` under computed torque, ``cart.npz`` (ideal), ``plant.npz`` (PD) and
    ``soft.npz`` (PD with a quarter of the stiffness), with the cart's model files."""
    folder = tmp_path_factory.mktemp("control")
    gpmegen.simulate(ARM, t_end=0.5, dt=1e-3, save_every=5, backend="c", params={"e0": 0.1}).save(folder / "arm.npz")
    (folder / "cart.toml").write_text(cart("cart_move", CONSTRAINT))
    (folder / "plant.toml").write_text(cart("cart_pd", DRIVE))
    for name, file, params in (("cart", "cart", {}), ("plant", "plant", {}), ("soft", "plant", {"kp": 100.0})):
        gpmegen.simulate(str(folder / f"{file}.toml"), backend="numpy", t_end=T_END, dt=1e-3, save_every=5,
                         params=params).save(folder / f"{name}.npz")
    return folder


def _load(files, name):
    return results_io.load(files / f"{name}.npz")


def test_control_figures_are_drawn_when_the_runs_hold_their_data(files):
    arm, ideal, plant = (_load(files, name) for name in ("arm", "cart", "plant"))
    assert stems([arm])[-2:] == ["tracking_error", "control_effort"]
    assert "tracking_error" not in stems([plant]) and "control_effort" in stems([plant])   # drives, no law
    assert not {"tracking_error", "control_effort"} & set(stems([ideal]))   # constrained, ideal, no drive


def test_the_tracking_error_figure_draws_the_saved_error(files):
    """Each panel's line is the run's saved q_r - q of its coordinate; the effort figure marks
    each drive's peak |u| at its time."""
    arm = _load(files, "arm")
    plt = plots._pyplot()
    style = plots.styles([arm])
    fig = control_plots.tracking_error(plt, [arm], style)
    try:
        lines = [ax.get_lines()[0] for ax in fig.axes]
        assert len(lines) == 2
        for k, line in enumerate(lines):
            np.testing.assert_array_equal(line.get_ydata(), arm["tracking_error"][:, k])
        assert "theta1" in fig.axes[0].get_ylabel() and "[rad]" in fig.axes[0].get_ylabel()
    finally:
        plt.close(fig)
    fig = control_plots.control_effort(plt, [arm], style)
    try:
        for ax, k in zip(fig.axes, (0, 1)):
            u = arm["drive_forces"][:, k]
            marker = ax.get_lines()[1]
            peak = int(np.argmax(np.abs(u)))
            assert marker.get_xdata()[0] == arm["t"][peak] and marker.get_ydata()[0] == u[peak]
    finally:
        plt.close(fig)


def test_plot_writes_them_the_same_bytes_twice(files, tmp_path, capsys):
    written = []
    for folder in ("a", "b"):
        assert main(["plot", str(files / "arm.npz"), "--out", str(tmp_path / folder), "--format", "png,svg"]) == 0
        written.append(sorted(Path(p) for p in capsys.readouterr().out.split()))
    names = {p.name for p in written[0]}
    assert {"tracking_error.png", "control_effort.svg"} <= names and "tracking.png" not in names
    for a, b in zip(*written, strict=True):
        assert a.read_bytes() == b.read_bytes(), a.name


def test_plot_reference_writes_the_metrics_of_gpmegen_metrics(files, tmp_path, capsys):
    runs = [str(files / "plant.npz"), str(files / "soft.npz")]   # two controllers on one plant
    reference = str(files / "cart.toml")
    assert main(["metrics", *runs, "--reference", reference, "--out", str(tmp_path / "metrics")]) == 0
    assert main(["plot", *runs, "--reference", reference, "--out", str(tmp_path / "figures")]) == 0
    printed = capsys.readouterr().out.split()
    figures = tmp_path / "figures"
    assert (figures / "metrics.csv").read_bytes() == (tmp_path / "metrics" / "metrics.csv").read_bytes()
    assert {str(figures / name) for name in ("metrics.csv", "metrics.md", "tracking.png", "control_effort.png")} \
        <= set(printed)
    csv = (figures / "metrics.csv").read_text().splitlines()
    table = (figures / "metrics.md").read_text().splitlines()
    assert table[0] == "| run | quantity | of | value | unit |" and len(table) == len(csv) + 1
    plant_path_error = next(r for r in csv if r.startswith(f"{runs[0]},path_error_max,"))
    row = next(r for r in table if f"| {runs[0]} | path_error_max |" in r)
    assert float(row.split("|")[4]) == pytest.approx(float(plant_path_error.split(",")[3]), rel=1e-5)


def test_plot_reference_refused_in_one_line_before_anything_is_written(files, tmp_path, capsys):
    out = tmp_path / "figures"
    code = main(["plot", str(files / "plant.npz"), "--reference", str(tmp_path / "absent.toml"), "--out", str(out)])
    err = capsys.readouterr().err.strip().splitlines()
    assert code == 2 and len(err) == 1 and "--reference" in err[0] and "no such file" in err[0]
    assert not out.exists()
