"""LinearModel.state_space (python-control): the same A and B, the same poles, and an LQR gain
designed on it that stabilizes the nonlinear model in closed loop at the rate its closed-loop
eigenvalue says.

The model is the pendulum of tests/models/pendulum.toml (a 1 kg point mass on a massless 1 m rod
about z, gravity g along -y), hanging at theta1 = -π/2: there A = [[0, 1], [-g, 0]] and
B = [[0], [1]] (a torque on theta1, m L² = 1 kg m²)."""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run import linear
from gpmegen.errors import MissingExtraError, ModelError

control = pytest.importorskip("control")

MODELS = Path(__file__).parent / "models"
HANGING = -math.pi / 2


def pendulum(name: str, start: float, drive: str = "") -> str:
    """tests/models/pendulum.toml named ``name``, with the gains and set point of a feedback law,
    a point at the bob, started at ``theta1 = start`` and ``drive`` added."""
    text = (MODELS / "pendulum.toml").read_text().replace('name = "pendulum"', f'name = "{name}"')
    text = text.replace("[parameters]\n", f"[parameters]\nk1 = 0.0\nk2 = 0.0\ntheta_ref = {HANGING!r}\n")
    text = text.replace("[initial]", '[[chain]]\ntranslation = [1.0, 0, 0]\n\n[[chain]]\npoint = "tip"\n\n[initial]')
    return text.replace("q = { theta1 = -0.5 }", f"q = {{ theta1 = {start!r} }}") + drive


LAW = """
[[drives]]
coordinate = "theta1"
expression = "-(k1*(theta1 - theta_ref) + k2*theta1_dot)"
"""


@pytest.fixture(scope="module")
def files(tmp_path_factory, env):
    folder = tmp_path_factory.mktemp("state_space")
    (folder / "pendulum.toml").write_text(pendulum("hanging", HANGING))
    (folder / "closed.toml").write_text(pendulum("hanging_lqr", HANGING + 0.05, LAW))
    return folder


@pytest.fixture(scope="module")
def lin(files):
    model = gpmegen.load(model=gpmegen.load_model_file(files / "pendulum.toml"), backend="numpy", jacobians=True)
    return linear.linearize(model, 0.0, np.array([HANGING]), np.zeros(1), inputs=("theta1",), where="hanging")


def test_linear_model_is_the_hanging_pendulum(lin):
    assert lin.A == pytest.approx(np.array([[0.0, 1.0], [-9.81, 0.0]]), abs=1e-12)
    assert lin.B == pytest.approx(np.array([[0.0], [1.0]]), abs=1e-14)


def test_state_space_holds_the_linear_model(lin):
    sys_ = lin.state_space()
    assert np.array_equal(sys_.A, lin.A) and np.array_equal(sys_.B, lin.B)
    assert np.array_equal(sys_.C, np.eye(2)) and np.array_equal(sys_.D, np.zeros((2, 1)))
    assert sys_.state_labels == ["theta1", "theta1_dot"] and sys_.input_labels == ["theta1"]
    assert np.sort_complex(sys_.poles()) == pytest.approx(np.sort_complex(lin.eigenvalues), abs=1e-12)
    picked = lin.state_space(outputs=["theta1_dot"])
    assert np.array_equal(picked.C, [[0.0, 1.0]]) and picked.output_labels == ["theta1_dot"]
    with pytest.raises(ModelError, match="'psi'"):
        lin.state_space(outputs=["psi"])


def test_missing_python_control_is_one_line(lin, monkeypatch):
    monkeypatch.setitem(sys.modules, "control", None)   # import control raises ImportError
    with pytest.raises(MissingExtraError, match=r"^LinearModel.state_space needs python-control, which is not "
                                                r"installed: pip install 'gpmegen\[control\]'$"):
        lin.state_space()


def test_lqr_gain_stabilizes_the_nonlinear_pendulum_at_its_rate(lin, files):
    K, _, poles = control.lqr(lin.state_space(), np.diag([1.0, 100.0]), np.eye(1))
    closed = np.linalg.eigvals(lin.A - lin.B @ K)
    assert np.all(closed.real < 0)
    assert np.sort(closed.real) == pytest.approx(np.sort(np.asarray(poles).real), rel=1e-9)
    assert np.all(np.abs(closed.imag) == 0)   # two real poles: the slow one sets the late decay
    slow = float(np.max(closed.real))
    run = gpmegen.simulate(str(files / "closed.toml"), backend="numpy", t_end=4.0, dt=1e-3,
                           params={"k1": float(K[0, 0]), "k2": float(K[0, 1])})
    assert run.status == "complete"
    error = np.abs(run.coordinate("theta1") - HANGING)
    t = run["t"]
    late = (t >= 2.0) & (t <= 4.0)   # the fast pole's share has fallen by e^(-7.8·2) there
    rate = np.polyfit(t[late], np.log(error[late]), 1)[0]
    assert rate == pytest.approx(slow, rel=1e-3)   # measured: 2e-6 off (its sin θ ≈ θ within 4e-4)
    assert error[-1] < 0.05 * math.exp(0.9 * slow * 4.0)


@pytest.mark.long
@pytest.mark.requires_cc   # its runs are DOP853, compiled
@pytest.mark.filterwarnings("ignore:constraint 'tip_on_ray'")
def test_lqr_example_damps_the_arm_that_pd_leaves_ringing(tmp_path, capsys, env):
    """examples/lqr_flexible_arm.py: the LQR's slowest closed-loop pair is damped (ζ > 0.2), the
    PD law's (the same joint gains, no deflection fed back) barely (ζ < 0.05), and on the
    nonlinear arm the LQR leaves less than a third of the PD law's residual vibration."""
    import importlib.util

    path = Path(__file__).resolve().parents[1] / "examples" / "lqr_flexible_arm.py"
    spec = importlib.util.spec_from_file_location("lqr_flexible_arm", path)
    example = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(example)
    report = example.main(["--out", str(tmp_path)])

    def damping(poles):
        slow = min(poles, key=abs)
        return -slow.real / abs(slow)

    assert np.all(np.asarray(report["poles"]).real < 0) and np.all(report["pd_poles"].real < 0)
    assert damping(report["poles"]) > 0.2 and damping(report["pd_poles"]) < 0.05
    assert report["ratio"] > 3
    assert (tmp_path / "metrics.csv").exists() and "LQR" in capsys.readouterr().out
