"""Every command on a tree: ``examples/flexible_gripper.toml`` (a prescribed wrist, two flexible
fingers hanging from one palm point as two branches, their fingertips held at their distance by
one constraint across the branches) through ``build``, ``statics``, ``simulate`` with every
method, ``modes``, ``linearize``, ``plot``, ``animate --still``, ``sweep`` and ``convergence``, and
through the Python API. The model is built once for the module; the runs are made once and shared.
The driving functions of a tree with flexible links (``invert``) on ``tests/models/flexible_fork.toml``:
one hub, two flexible strips as two branches, the tip of one moved rest to rest by the hub's torque."""

from __future__ import annotations

import contextlib
import io
import json
import re
import tomllib
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.post import energy
from gpmegen.analysis.post import results as results_io
from gpmegen.analysis.run.model_files import read_model_file
from gpmegen.cli import main
from gpmegen.runtime import inversion

ROOT = Path(__file__).resolve().parents[1]
GRIPPER = ROOT / "examples" / "flexible_gripper.toml"
FORK = ROOT / "tests" / "models" / "flexible_fork.toml"
METHODS = ("rk4", "genalpha", "dop853", "radau", "scipy-radau")
T_END = 0.1
FIGURES = {"joint_coordinates", "end_effector", "path", "constraint_violation", "energy_balance",
           "driving_functions", "constraint_multipliers", "elastic_deformation"}


def _params() -> dict[str, float]:
    table = tomllib.loads(GRIPPER.read_text())["parameters"]
    return {k: float(v["value"]) for k, v in table.items()}


def _run(argv) -> tuple[str, str]:
    """A command as the shell runs it: its exit status 0, no traceback; (stdout, stderr)."""
    out, err = io.StringIO(), io.StringIO()
    with contextlib.redirect_stdout(out), contextlib.redirect_stderr(err):
        code = main([str(a) for a in argv])
    assert "Traceback" not in out.getvalue() + err.getvalue(), err.getvalue()
    assert code == 0, f"{argv}: exit {code}\n{err.getvalue()}"
    return out.getvalue(), err.getvalue()


@pytest.fixture(scope="module")
def built(env):
    """The gripper built once into the module's generated folder (the one ``simulate`` loads)."""
    out, _ = _run(["build", GRIPPER, "--out", env[0]])
    return env[0], out


@pytest.fixture(scope="module")
def work(built, tmp_path_factory):
    return tmp_path_factory.mktemp("gripper")


@pytest.fixture(scope="module")
def runs(built, work):
    """``simulate`` with each method, made once when a test first asks for it: the results."""
    done = {}

    def run(method):
        if method not in done:
            path = work / f"{method}.npz"
            step = ["--dt", 1e-4, "--save-every", 10] if method in ("rk4", "genalpha") else []
            _run(["simulate", GRIPPER, "--t-end", T_END, "--method", method, *step, "--out", path])
            done[method] = results_io.load(path)
        return done[method]

    return run


@pytest.fixture(scope="module")
def loaded(built):
    """The gripper through the Python API on the NumPy backend."""
    return gpmegen.load(model=read_model_file(GRIPPER).model, backend="numpy", directory=built[0])


def test_build_writes_the_tree_once_and_skips_it_when_unchanged(built):
    folder, out = built
    model = read_model_file(GRIPPER).model
    assert model.name == "flexible_gripper_nrfe3" and "n_dof = 7" in out
    assert {"manifest.json", "model.c", "model_numpy.py"} <= {p.name for p in (folder / model.name).iterdir()}
    again, _ = _run(["build", GRIPPER, "--out", folder])
    assert "up to date, skipped" in again


def test_the_fingers_hang_from_the_palm_point_as_the_file_places_them(loaded):
    """At the start (straight fingers opened by ±a0 about the wrist's angle th0) each fingertip is
    Lf from the palm point along its finger, so the two branches start at the same point."""
    p = _params()
    q = np.zeros(loaded.n_dof)
    q[[loaded.index("theta1"), loaded.index("a"), loaded.index("b")]] = p["th0"], p["a0"], -p["a0"]
    points = dict(zip(loaded.points, loaded.point_positions(q)))
    th = p["th0"]
    palm = p["L_palm"] * np.array([np.cos(th), np.sin(th), 0.0])
    np.testing.assert_allclose(points["palm"], palm, rtol=0, atol=1e-15)
    for tip, a in (("tipA", p["a0"]), ("tipB", -p["a0"])):
        expected = palm + p["Lf"] * np.array([np.cos(th + a), np.sin(th + a), 0.0])
        np.testing.assert_allclose(points[tip], expected, rtol=0, atol=1e-15)
    # the grip constraint vanishes there, and couples the two branches' pivots
    phi, _, D, _ = loaded.constraint_terms(0.0, q, np.zeros(loaded.n_dof))
    grip = list(loaded.constraint_names).index("grip")
    assert abs(phi[grip]) < 1e-15
    assert D[grip, loaded.index("a")] != 0 and D[grip, loaded.index("b")] != 0


def test_statics_reports_both_fingertips_and_the_grip_multiplier(built):
    out, _ = _run(["statics", GRIPPER])
    for name in ("palm", "tipA", "tipB", "grip", "prescribed_theta1"):
        assert name in out
    p = _params()
    tips = {line.split(" = ")[0]: np.array([float(x) for x in line.split("(")[1].split(")")[0].split(",")])
            for line in out.splitlines() if line.startswith("tip")}
    assert np.linalg.norm(tips["tipA"] - tips["tipB"]) == pytest.approx(2 * p["Lf"] * np.sin(p["a0"]), abs=1e-8)


@pytest.mark.parametrize("method", METHODS)
def test_every_method_holds_the_grip_across_the_branches_to_1e_10(runs, loaded, method):
    res = runs(method)
    assert str(res["status"]) == "complete" and res["t"][-1] == pytest.approx(T_END)
    assert [str(c) for c in res["constraint_names"]] == ["grip", "prescribed_theta1"]
    assert np.max(np.abs(res["phi"])) < 1e-10
    # the distance itself, from the fingertips where the saved coordinates put them
    p = _params()
    tips = np.array([loaded.point_positions(q) for q in res["q"]])
    names = list(loaded.points)
    distance = np.linalg.norm(tips[:, names.index("tipA")] - tips[:, names.index("tipB")], axis=1)
    assert np.max(np.abs(distance - 2 * p["Lf"] * np.sin(p["a0"]))) < 1e-9
    # and the fingers do swing: the pivots turn by more than 0.1 rad
    assert np.ptp(res["q"][:, list(loaded.coordinates).index("a")]) > 0.1


@pytest.mark.parametrize("method", METHODS)
def test_every_method_closes_the_energy_balance(runs, method):
    res = runs(method)
    residual = np.abs(energy.balance_residual(res)).max()
    exchanged = np.abs(res["work_constraints"]).max()   # the wrist's prescribed motion feeds the energy
    assert exchanged > 1e-4
    assert residual < 1e-5 * exchanged


def test_the_methods_agree_on_the_motion(runs, loaded):
    reference = runs("rk4")
    for method in METHODS[1:]:
        res = runs(method)
        np.testing.assert_allclose(res["t"], reference["t"], rtol=0, atol=1e-12)
        np.testing.assert_allclose(res["q"], reference["q"], rtol=0, atol=1e-5, err_msg=method)


def test_modes_finds_each_finger_bending(built, work):
    out, _ = _run(["modes", GRIPPER, "--count", 4, "--out", work / "modes"])
    rows = [line.split() for line in out.splitlines() if line.strip()[:1].isdigit()]
    assert len(rows) == 4
    # the two fingers are alike: their modes come in pairs, one on each finger
    first, second = rows[0], rows[1]
    assert float(first[1]) == pytest.approx(float(second[1]), rel=1e-2)
    assert {first[-1], second[-1]} == {"psiA_1", "psiB_1"}
    assert (work / "modes" / "modes_flexible_gripper_joints.png").stat().st_size > 1000


# make check-c: a tree linearized through the command line (linearize: test_linearize.py)
@pytest.mark.long
def test_linearize_writes_the_tree_linear_model(built, work):
    out, _ = _run(["linearize", GRIPPER, "--out", work / "lin.npz"])
    assert "wrote" in out
    with np.load(work / "lin.npz") as lin:
        A = lin["A"]
    assert A.shape[0] == A.shape[1] and np.all(np.isfinite(A))


# make check-c: every figure of a tree run: about 7 s of CPU
@pytest.mark.long
def test_plot_draws_every_figure_of_a_tree_run(runs, work):
    runs("rk4")
    out, _ = _run(["plot", work / "rk4.npz", "--out", work / "figures"])
    pngs = {p.stem for p in (work / "figures").glob("*.png")}
    assert pngs == FIGURES
    assert all(p.stat().st_size > 1000 for p in (work / "figures").glob("*.png"))


def test_animate_still_draws_the_gripper(runs, work, env):
    runs("rk4")
    still = work / "still.png"
    _run(["animate", work / "rk4.npz", "--still", "0,0.05,0.1", "--out", still])
    assert still.stat().st_size > 1000


def test_a_sweep_over_the_tip_mass_runs_both_values(built, work):
    out_dir = work / "sweep"
    _run(["sweep", GRIPPER, "--param", "m_tip=0.02,0.04", "--t-end", 0.02, "--dt", 1e-4, "--workers", 1,
          "--out", out_dir])
    rows = (out_dir / "summary.csv").read_text().splitlines()
    assert len(rows) == 3
    header = rows[0].split(",")
    values = sorted(float(row.split(",")[header.index("m_tip")]) for row in rows[1:])
    assert values == [0.02, 0.04]
    assert all("complete" in row for row in rows[1:])
    json.loads((out_dir / "sweep.json").read_text())


@pytest.mark.requires_cc
def test_the_api_accelerations_of_the_tree_agree_with_the_numpy_backend(built, loaded, rng):
    c_model = gpmegen.load(model=read_model_file(GRIPPER).model, backend="c", directory=built[0])
    start = np.zeros(loaded.n_dof)
    p = _params()
    start[[loaded.index("theta1"), loaded.index("a"), loaded.index("b")]] = p["th0"], p["a0"], -p["a0"]
    for t in (0.0, 0.13, 0.4):
        q = start + 0.05 * rng.standard_normal(loaded.n_dof)
        qd = rng.standard_normal(loaded.n_dof)
        expected = loaded.accelerations(t, q, qd)
        assert np.all(np.isfinite(expected))
        np.testing.assert_allclose(c_model.accelerations(t, q, qd), expected, rtol=1e-9,
                                   atol=1e-9 * np.abs(expected).max())


@pytest.mark.requires_cc
def test_a_grip_written_with_a_root_singular_at_q_0_keeps_its_c_backend(env, tmp_path):
    """The grip as the root of the tips' distance is singular where the tips meet, at q = 0, one
    of the states where a freshly compiled library is tried before it is loaded: the library is
    tried at the other state, loaded, and agrees with the NumPy backend."""
    text = GRIPPER.read_text()
    squared = '"(x_tipA - x_tipB)^2 + (y_tipA - y_tipB)^2 - (2*Lf*sin(a0))^2"'
    assert squared in text
    path = tmp_path / "gripper_root.toml"
    path.write_text(text.replace(squared, '"sqrt((x_tipA - x_tipB)^2 + (y_tipA - y_tipB)^2) - 2*Lf*sin(a0)"')
                    .replace('name = "flexible_gripper_nrfe{nrfe}"', 'name = "gripper_root_nrfe{nrfe}"'))
    model = read_model_file(path).model
    numpy_model = gpmegen.load(model=model, backend="numpy", directory=tmp_path)
    zero = np.zeros(numpy_model.n_dof)
    with pytest.raises(gpmegen.errors.EvaluationError, match="divides by zero"):   # undefined at q = 0
        numpy_model.constraint_terms(0.0, zero, zero)
    c_model = gpmegen.load(model=model, backend="c", directory=tmp_path)
    p = _params()
    q = zero.copy()
    q[[c_model.index("theta1"), c_model.index("a"), c_model.index("b")]] = p["th0"], p["a0"], -p["a0"]
    qd = np.linspace(-1.0, 1.0, c_model.n_dof)
    expected = numpy_model.accelerations(0.2, q, qd)
    np.testing.assert_allclose(c_model.accelerations(0.2, q, qd), expected, rtol=1e-9,
                               atol=1e-9 * np.abs(expected).max())


def test_convergence_of_the_fingertips_is_second_order_and_the_limit_holds_the_grip(built):
    """``convergence --output`` on the tree at its constrained statics, n_rfe 2, 3, 5 (n_sde 1, 2,
    4): each fingertip's error falls fourfold per halving of the sde spacing (order 2, the RFEM's),
    and the extrapolated tips keep the grip's distance 2 Lf sin(a0) across the branches."""
    out, _ = _run(["convergence", GRIPPER, "--nrfe", 2, 3, 5, "--output", "tipA", "tipB", "--statics",
                   "constrained", "--backend", "numpy", "--workers", 1])
    limits = {}
    for tip in ("tipA", "tipB"):
        line = next(text for text in out.splitlines() if text.startswith(tip + " "))
        errors = [float(x) for x in re.findall(r"n_rfe \d+: ([0-9.e+-]+)", line)]
        assert len(errors) == 3 and errors[0] > 1e-5   # the coarse level is visibly off
        assert errors[1] == pytest.approx(errors[0] / 4, rel=0.05)
        assert errors[2] == pytest.approx(errors[1] / 4, rel=0.05)
        assert float(re.search(r"limit: ([0-9.e+-]+);", line).group(1)) < 1e-3 * errors[0]
        assert float(re.search(r"observed order ([0-9.]+)", line).group(1)) == pytest.approx(2.0, abs=0.05)
        limits[tip] = np.array([float(x) for x in re.search(r"limit \(([^)]*)\) ±", line).group(1).split(",")])
    p = _params()
    assert np.linalg.norm(limits["tipA"] - limits["tipB"]) == pytest.approx(2 * p["Lf"] * np.sin(p["a0"]), rel=1e-6)


def _smooth_step(t, Y, T):
    """The fork's programmed y of tip A: Y s(t/T), s(τ) = 35τ⁴ - 84τ⁵ + 70τ⁶ - 20τ⁷ on [0, 1]."""
    tau = np.clip(t / T, 0.0, 1.0)
    return Y * tau**4 * (35 - 84 * tau + 70 * tau**2 - 20 * tau**3)


@pytest.mark.long
def test_the_driving_function_of_a_tree_realizes_the_motion_when_applied_as_a_drive(env):
    """Stable inversion on the fork (non-minimum phase: the torque at the hub, the tip of strip A
    on the other side of its bending): the solution holds the programmed tip; then the model
    without its constraint, driven only by the inverted torque from the solution's start, moves
    tip A along the law to 1e-3 of the move (RK4), while strip B, on its own branch, swings."""
    file = read_model_file(FORK)
    model = gpmegen.load(model=file.model, backend="numpy").with_actuators(file.actuators)
    Y, T = (float(model.p[list(model.parameter_names).index(k)]) for k in ("Y", "T"))
    inv = inversion.stable_inversion(model, np.zeros(model.n_dof), 0.0, T, 0.1, 0.1, nodes=80, tol=1e-6)
    tip = list(model.points).index("tipA")
    held = np.array([model.point_positions(q)[tip, 1] for q in inv.q])
    np.testing.assert_allclose(held, _smooth_step(inv.t, Y, T), rtol=0, atol=1e-9)
    assert np.max(np.abs(inv.q[:, model.index("pivotB")])) > 1e-6   # the other branch moves along

    theta1 = model.index("theta1")

    def rate(t, x):
        q, qd = x[:model.n_dof], x[model.n_dof:]
        f = model.forces(t, q, qd).copy()
        f[theta1] += np.interp(t, inv.t, inv.u[:, 0])
        return np.concatenate([qd, np.linalg.solve(model.mass_matrix(q), f)])

    x, t, dt = np.concatenate([inv.q[0], inv.qd[0]]), inv.t[0], 2e-4
    worst = 0.0
    for _ in range(int(round((inv.t[-1] - t) / dt))):
        k1 = rate(t, x)
        k2 = rate(t + dt / 2, x + dt / 2 * k1)
        k3 = rate(t + dt / 2, x + dt / 2 * k2)
        k4 = rate(t + dt, x + dt * k3)
        x, t = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4), t + dt
        worst = max(worst, abs(model.point_positions(x[:model.n_dof])[tip, 1] - _smooth_step(t, Y, T)))
    assert worst < 1e-3 * Y   # measured 1.0e-7 m of the 1 mm move; undriven, it stays 1 mm off
