"""Stable inversion: the bounded inputs of a flexible link whose tip is moved rest to rest by a
torque at its hub (non-minimum phase), against the non-causal inverse of the linear system
computed independently in the frequency domain."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.errors import SimulationError
from gpmegen.runtime import internal, inversion

LINK = Path(__file__).resolve().parent / "models" / "flexible_link.toml"
MOVE = {"d": 0.01, "Y": 0.001, "T": 0.2}  # a 1 mm move in 0.2 s: the linear range


def link(nrfe, **params):
    file = gpmegen.read_model_file(LINK, nrfe=nrfe)
    return gpmegen.load(model=file.model, params=params, backend="numpy").with_actuators(file.actuators)


def smooth_step_acceleration(t, Y, T):
    """ÿ of y = Y s(t/T), s(τ) = 35τ⁴ - 84τ⁵ + 70τ⁶ - 20τ⁷ on [0, 1] (constant outside)."""
    tau = np.clip(t / T, 0.0, 1.0)
    inside = (t > 0) & (t < T)
    return np.where(inside, Y / T**2 * (420 * tau**2 - 1680 * tau**3 + 2100 * tau**4 - 840 * tau**5), 0.0)


def linear_inverse(model, t):
    """u(t) of the linear system M q̈ + C q̇ + K q = S u, y = D q about the straight link, inverted
    non-causally: U(ω) = FFT(ÿ_d)(ω) / H(iω) with H(s) = s² D (M s² + C s + K)⁻¹ S, on a long
    periodic window (the motion is at rest far from it)."""
    n = model.n_dof
    q = np.zeros(n)
    M, K = model.mass_matrix(q), model.stiffness_jacobian(q)
    C = np.diag([0.0 if name == "theta1" else MOVE["d"] for name in model.coordinates])
    D = model.constraint_terms(0.0, q, q)[2]
    S = np.zeros((n, 1))
    S[model.index("theta1"), 0] = 1.0
    dt = t[1] - t[0]
    acc = smooth_step_acceleration(t, MOVE["Y"], MOVE["T"])
    omega = 2 * np.pi * np.fft.rfftfreq(len(t), dt)
    U = np.zeros(len(omega), dtype=complex)
    spectrum = np.fft.rfft(acc)
    for k, w in enumerate(omega[1:], start=1):
        s = 1j * w
        H = s**2 * (D @ np.linalg.solve(M * s**2 + C * s + K, S))[0, 0]
        U[k] = spectrum[k] / H
    return np.fft.irfft(U, len(t))


def test_stable_inversion_matches_the_non_causal_linear_inverse(env):
    """The BVP's inputs equal the frequency-domain inverse of the linearized link (within its
    nonlinearity, 1 mm on 1 m), start before the motion (pre-actuation) and stay bounded, and
    they hold the equations and the constraint along the solution."""
    model = link(2, **MOVE)
    assert len(internal.unstable(internal.eigenvalues(model, 0.0, np.zeros(model.n_dof),
                                                      np.zeros(model.n_dof)))) == 1
    inv = inversion.stable_inversion(model, np.zeros(model.n_dof), 0.0, MOVE["T"], 0.1, 0.1, nodes=80, tol=1e-6)
    window = np.arange(-2.0, 2.0, 1e-4)
    expected = np.interp(inv.t, window, linear_inverse(model, window))
    scale = np.max(np.abs(expected))
    assert np.max(np.abs(inv.u[:, 0] - expected)) < 1e-4 * scale  # measured 2.3e-6
    assert inv.lead > 0.005 and inv.lag > 0.005  # s: the inputs act before and after the motion
    for k in range(0, len(inv.t), 7):
        M, f, phi, _, _, _ = model.gpme_terms(inv.t[k], inv.q[k], inv.qd[k])
        qdd = model.actuation(inv.t[k], inv.q[k], inv.qd[k])[0]
        assert abs((M @ qdd - f)[0] - inv.u[k, 0]) < 1e-9 * scale
        assert np.max(np.abs((M @ qdd - f)[1:])) < 1e-9 * scale
        assert abs(phi[0]) < 1e-8
    assert np.max(np.abs(inv.q[:, 1:])) < 0.01  # rad: the elastic coordinates stay small


def test_stable_inversion_needs_hyperbolic_internal_dynamics(env):
    """Undamped sdes leave eigenvalues on the imaginary axis: refused, saying what to change."""
    model = link(2, Y=0.001)
    with pytest.raises(SimulationError, match="hyperbolic internal dynamics.*damp the sdes"):
        inversion.stable_inversion(model, np.zeros(model.n_dof), 0.0, 0.2, 0.1, 0.1)


def test_cli_invert_writes_the_bounded_inputs(env, tmp_path, capsys):
    """``gpmegen invert`` writes the inputs and says how long before the motion they start; a
    case whose internal dynamics keep a neutral coordinate (the rigid arm's column) is refused."""
    from gpmegen import cli
    from gpmegen.analysis.post import results as results_io

    out = tmp_path / "inv.npz"
    args = ["invert", str(LINK), "--nrfe", "2", "--t1", "0.2", "--out", str(out)]
    assert cli.main(args + [f"--param={k}={v}" for k, v in MOVE.items()]) == 0
    line = capsys.readouterr().out
    res = results_io.load(out)
    settings = results_io.metadata(res)["settings"]
    assert f"the inputs start {settings['lead']:.4g} s before t0 = 0 s" in line and settings["lead"] > 0.005
    assert list(res["actuators"]) == ["theta1"] and res["t"][0] == pytest.approx(-0.1)
    assert np.max(np.abs(res["u"][res["t"] < 0])) > 0.01 * np.max(np.abs(res["u"]))  # pre-actuation
    assert cli.main(["invert", str(LINK), "--nrfe", "2", "--t1", "0.2", "--param", "Y=0.001",
                     "--out", str(tmp_path / "undamped.npz")]) == 1
    assert "stable inversion needs hyperbolic internal dynamics" in capsys.readouterr().err


@pytest.mark.parametrize("t0, t1, where, t_moving", [(0.05, 0.2, "before t0", 0.0), (0.0, 0.15, "after t1", 0.2)])
def test_invert_refuses_a_law_that_moves_before_or_after_the_motion(env, tmp_path, capsys, t0, t1, where, t_moving):
    """The move runs from 0 to T = 0.2 s; a window [t0, t1] that cuts it off was inverted as if the
    motion rested outside it, returning inputs whose start (or end) is not at rest. Refused in one
    line naming where the law moves and the fix, before the boundary-value problem is solved."""
    from gpmegen import cli

    out = tmp_path / "inv.npz"
    args = ["invert", str(LINK), "--nrfe", "2", "--t0", str(t0), "--t1", str(t1), "--out", str(out)]
    assert cli.main(args + [f"--param={k}={v}" for k, v in MOVE.items()]) == 1
    errors = [line for line in capsys.readouterr().err.splitlines() if "error" in line]
    assert len(errors) == 1
    err = errors[0]
    assert f"the programmed motion moves {where}" in err and "at rest outside [t0, t1]" in err
    moving = float(err.split("change at t = ")[1].split(" s")[0])
    assert moving == pytest.approx(t_moving, abs=0.01)  # the windows are sampled every 0.5 ms
    assert not out.exists()


def test_the_boundary_value_solve_says_how_far_it_is(env, monkeypatch):
    """The solve printed nothing for 79 s: it now says the mesh it works on, at most every
    PROGRESS_LINES s (0 here, so every evaluation, without waiting on the clock)."""
    monkeypatch.setattr(inversion, "PROGRESS_LINES", 0.0)
    lines = []
    model = link(2, **MOVE)
    inversion.stable_inversion(model, np.zeros(model.n_dof), 0.0, MOVE["T"], 0.1, 0.1, nodes=80,
                               progress=lines.append)
    assert lines and all(line.startswith("stable inversion: solving on a mesh of ") for line in lines)
    assert {int(line.split("mesh of ")[1].split()[0]) for line in lines} >= {80}


TRACKING = Path(__file__).resolve().parents[1] / "examples" / "tracking_study.toml"


def tracking_arm(nrfe):
    """The tracking study's arm, E held on its path by inputs on its three joints, and its start."""
    start = gpmegen.statics(TRACKING, nrfe=nrfe, start="none", backend="numpy")
    return start.model.with_actuators(["theta1", "psi2", "x3"]), start.q


def test_the_first_guess_holds_the_programmed_motion_at_rest_at_every_node(env):
    """The boundary-value solve starts from the quasi-static motion: at each mesh time E's path
    constraints hold and the unactuated coordinates are in static balance; outside the motion it
    is the rest states themselves. (The straight blend of the two rest states used before was off
    E's path by centimetres mid-motion, and from it Newton left the states where the inputs hold
    the constraints at n_rfe 3.)"""
    model, q0 = tracking_arm(2)
    n = model.n_dof
    start = np.concatenate([inversion.rest(model, q0, 0.0), np.zeros(n)])
    end = np.concatenate([inversion.rest(model, start[:n], 2.0), np.zeros(n)])
    mesh = np.linspace(-0.1, 2.1, 45)
    guess = inversion.quasi_static(model, mesh, start, end, 0.0, 2.0)
    free = [k for k in range(n) if k not in set(model.actuators.tolist())]
    for t, q in zip(mesh, guess[:n].T):
        assert np.max(np.abs(model.constraint_terms(t, q, np.zeros(n))[0])) < 1e-10
        assert np.max(np.abs(model.static_residual(q)[free])) < 1e-8 * np.max(np.abs(model.static_residual(q)))
    assert np.array_equal(guess[:n, mesh <= 0.0], np.repeat(start[:n, None], np.sum(mesh <= 0.0), axis=1))
    assert np.array_equal(guess[:n, mesh >= 2.0], np.repeat(end[:n, None], np.sum(mesh >= 2.0), axis=1))
    blend = np.clip(mesh / 2.0, 0.0, 1.0)
    straight = start[:n, None] + (end - start)[:n, None] * blend[None, :]
    off = max(np.max(np.abs(model.constraint_terms(t, q, np.zeros(n))[0])) for t, q in zip(mesh, straight.T))
    assert off > 0.01   # m (or m²): what the straight blend left to Newton


@pytest.mark.long   # about 20 s of CPU: the BVP on the n_rfe 3 arm
@pytest.mark.filterwarnings("ignore:overflow", "ignore:invalid value")
def test_the_tracking_arm_at_nrfe_3_is_inverted(env):
    """E's path on the tracking study's arm at n_rfe 3 (internal dynamics ±45.6, ±362 1/s and a
    lightly damped pair, -0.0185 ± 52.3j 1/s): from the straight blend the solve diverged in its
    first Newton iteration (at 200 nodes as at 1000); from the quasi-static motion it converges,
    and the inputs hold E on its path along the solution."""
    model, q0 = tracking_arm(3)
    inv = inversion.stable_inversion(model, q0, 0.0, 2.0, 0.1, 0.1, nodes=200)
    assert inv.residual <= 1e-6
    for k in range(0, len(inv.t), 25):
        assert np.max(np.abs(model.constraint_terms(inv.t[k], inv.q[k], inv.qd[k])[0])) < 1e-6
    assert 20.0 < np.abs(inv.u[:, 1]).max() < 25.0   # N·m on psi2: near the rigid arm's 23.3


def test_python_invert_is_the_commands(env, tmp_path, capsys):
    """``gpmegen.invert`` returns what ``gpmegen invert`` writes, to the bit, and writes nothing;
    a window or option out of range is one line (an unknown option a TypeError, as in Python)."""
    from gpmegen import cli
    from gpmegen.analysis.post import results as results_io
    from gpmegen.errors import ModelError

    out = tmp_path / "inv.npz"
    assert cli.main(["invert", str(LINK), "--nrfe", "2", "--t1", "0.2", "--nodes", "80", "--out", str(out)]
                    + [f"--param={k}={v}" for k, v in MOVE.items()]) == 0
    written = results_io.load(out)
    # NumPy's numbers and one coordinate's name are taken as the command's numbers and list
    run = gpmegen.invert(LINK, nrfe=2, t1=np.float64(0.2), nodes=np.int64(80), actuated="theta1", params=MOVE)
    assert [str(a) for a in run["actuators"]] == ["theta1"]
    for name in ("t", "q", "qd", "u", "drive_forces"):
        assert np.array_equal(run[name], written[name]), name
    assert sorted(p.name for p in tmp_path.iterdir()) == ["inv.csv", "inv.npz"]
    for kwargs, message in [({"t1": 0.2, "t0": 0.3}, "t1 (0.2 s) must come after t0 (0.3 s)"),
                            ({"t1": float("nan")}, "t1 = nan is not a finite number of seconds"),
                            ({"t1": 0.2, "pre": 0.0}, "must be positive windows"),
                            ({"t1": 0.2, "nodes": 1.5}, "give a whole number of mesh nodes"),
                            ({"t1": True}, "t1 = True is not a finite number of seconds")]:
        with pytest.raises(ModelError) as caught:
            gpmegen.invert(LINK, nrfe=2, **kwargs)
        assert message in str(caught.value) and "\n" not in str(caught.value), str(caught.value)
    with pytest.raises(TypeError, match="unknown option 'mesh'; its options are nrfe, directory, start"):
        gpmegen.invert(LINK, nrfe=2, t1=0.2, mesh=3)
