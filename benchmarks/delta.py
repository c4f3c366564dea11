"""The Delta robot with flexible forearms: build time, run time, and what the forearms'
flexibility does to the motor torques that realize the platform's programmed path.

examples/delta_flexible.toml: the platform's centre moves on a half circle (radius 60 mm,
0.25 s, rest to rest) in a horizontal plane; the motors' angles are dependent coordinates and the
programmed constraints are realized ideally (the GPME): their multipliers are the force that
drives the platform along its path. The motor torques come from the same model at each saved
state (:func:`motor_torques`): the torques on the three motors alone, with the platform joints'
reactions, that give the platform its programmed acceleration,

    [M   -S  -D_cᵀ] [q̈  ]   [f          ]
    [D    0   0   ] [τ  ] = [-γ - Baumgarte terms]
                    [λ_c]

(S selects the motors, D_c holds the platform joints' rows, D all rows). For the rigid Delta
(n_rfe 1) this is its inverse dynamics and its q̈ is the run's (tests/test_delta.py checks both
against the closed-form inverse kinematics, the statics and the power balance). For the flexible
Delta it is evaluated along the run, whose forearms bend under the motion of their ends but do
not carry the platform's weight and inertia (the programmed constraints push the platform).

The variant :func:`motor_driven_text` drives the motors instead, along the rigid Delta's
closed-form inverse kinematics: its multipliers are the motor torques, its forearms carry the
platform's loads along themselves, and its flexible platform leaves the path; the second table
gives its torques and the platform's residual vibration.

What it measures, at each n_rfe (--nrfe) and each factor on the forearms' bending stiffness
(--stiffness, parameter k_EI):

- the build (derivation, code generation, C compile) and the run's wall time per second of
  motion (RK4 on the C backend, step --dt);
- the peak motor torque, its largest difference from the rigid Delta's torque over the move, and
  after the move (t > T, the platform at rest) the torques' residual oscillation (peak to peak)
  and the forearms' residual vibration: a forearm's midspan deflection from its elbow-to-tip
  chord, peak to peak, over the last --tail seconds; with the motors driven, the
  platform's largest distance from its path and its residual vibration (peak to peak, at rest).

    .venv/bin/python benchmarks/delta.py                       # the tables and docs/figures/delta_torques.png
    .venv/bin/python benchmarks/delta.py --nrfe 2 3 --stiffness 1 0.1 --no-figure
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

import numpy as np

import gpmegen
from gpmegen.runtime import gpme

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "examples" / "delta_flexible.toml"
MOTORS = ("theta1", "theta2", "theta3")


def motor_torques(model, t, q, qd) -> tuple[np.ndarray, np.ndarray]:
    """(τ (k, 3) N·m, q̈ (k, n)): the motors' torques (on theta1, theta2, theta3) that hold the
    programmed path with the platform joints' rows realized ideally, and the accelerations they
    give, at the states ``(t, q, qd)`` (k of each) of ``model`` (a loaded model of the example)."""
    names = model.constraint_names
    closure = [k for k, name in enumerate(names) if not name.startswith("path_")]
    motors = [model.coordinates.index(name) for name in MOTORS]
    torques, accelerations = [], []
    for tk, qk, qdk in zip(np.atleast_1d(t), np.atleast_2d(q), np.atleast_2d(qd)):
        M, f, phi, phid, D, gamma = model.gpme_terms(tk, qk, qdk)
        n, m, c = M.shape[0], D.shape[0], len(closure)
        S = gpme.selection(n, motors)
        A = np.block([[M, -S, -D[closure].T], [D, np.zeros((m, len(motors) + c))]])
        rhs = gpme.constraint_rhs(phi, phid, gamma, model.alpha, model.beta, model.constraint_orders)
        x = np.linalg.solve(A, np.concatenate([f, rhs]))
        accelerations.append(x[:n])
        torques.append(x[n:n + len(motors)])
    return np.array(torques), np.array(accelerations)


def motor_driven_text() -> str:
    """The example with the motors driven instead of the platform: its three path constraints
    replaced by the motor angles of the rigid Delta's inverse kinematics along the same path
    (``theta_i - θ_i(p(t))``, the elbow's circle met by the forearm's sphere), so that the
    motors follow the rigid Delta's angles, the multipliers are the motor torques, and the
    platform of a flexible Delta leaves its path by what the forearms bend."""
    text = MODEL.read_text()
    start, end = text.index("[[constraints]]"), text.index("# a guess near the start")
    s = "pi*(Min(t/T, 1) - sin(2*pi*Min(t/T, 1))/(2*pi))"
    blocks = []
    for leg, angle in enumerate(("0", "2*pi/3", "4*pi/3"), start=1):
        px, py = f"(R_arc*cos({s} - {angle}) - r_b + r_p)", f"(R_arc*sin({s} - {angle}))"
        a, b = f"(-2*L_u*{px})", "(2*L_u*z_0)"
        c = f"(L_f^2 - L_u^2 - {px}^2 - {py}^2 - z_0^2)"
        x = f"({c}/sqrt({a}^2 + {b}^2))"
        blocks.append(f'[[constraints]]\nname = "motor{leg}"\n'
                      f'expression = "theta{leg} - (atan2({b}, {a}) + atan2(sqrt(1 - {x}^2), {x}))"\n'
                      'alpha = "alpha_P"\nbeta = "beta_P"\n\n')
    text = text[:start] + "".join(blocks) + text[end:]
    return text.replace('name = "delta_flexible_nrfe{nrfe}"', 'name = "delta_motors_nrfe{nrfe}"')


def platform_path(t, model_file=MODEL) -> np.ndarray:
    """The platform centre's programmed position (k, 3) m at the times ``t``, from the model
    file's parameters: the half circle by the cycloidal law of u = min(t/T, 1)."""
    import tomllib

    p = {k: float(v["value"]) for k, v in tomllib.loads(Path(model_file).read_text())["parameters"].items()}
    u = np.minimum(np.asarray(t) / p["T"], 1.0)
    s = np.pi * (u - np.sin(2 * np.pi * u) / (2 * np.pi))
    return np.column_stack([p["R_arc"] * np.cos(s), p["R_arc"] * np.sin(s), np.full_like(s, p["z_0"])])


def forearm_deflections(model, q) -> np.ndarray:
    """(k, 3) m: each forearm's midspan deflection, the distance from the chord between its
    elbow (its first rfe's origin) and its tip (point F1, F2, F3) of the polyline through its rfe
    origins and its tip, at half the chord; ``model`` loaded with the body transforms
    (``gpmegen.load(..., transforms=("T",))``)."""
    out = np.zeros((len(q), 3))
    bodies = list(model.bodies)
    points = list(model.points)
    for k, qk in enumerate(q):
        frames = model.transforms(qk)
        tips = model.point_positions(qk)
        for leg in range(3):
            origins = [frames[j][:3, 3] for j, name in enumerate(bodies) if name.startswith(f"rfe{leg + 1}_")]
            nodes = np.array(origins + [tips[points.index(f"F{leg + 1}")]]) - origins[0]
            length = np.linalg.norm(nodes[-1])
            along = nodes @ (nodes[-1] / length)
            across = nodes - np.outer(along, nodes[-1] / length)
            out[k, leg] = np.linalg.norm([np.interp(length / 2, along, across[:, i]) for i in range(3)])
    return out


def run_case(nrfe, stiffness, dt, t_end, directory, backend="c"):
    """One run of the example at ``nrfe`` with ``k_EI = stiffness`` (RK4, saved every ms):
    (results, motor torques (k, 3), wall time of the run in s, the NumPy model it was analysed on)."""
    start = time.perf_counter()
    run = gpmegen.simulate(str(MODEL), nrfe=nrfe, t_end=t_end, dt=dt, save_every=max(1, round(1e-3 / dt)),
                           backend=backend, directory=directory, params={"k_EI": stiffness}, start="constrained")
    wall = time.perf_counter() - start
    model = gpmegen.load(model=gpmegen.load_model_file(MODEL, nrfe=nrfe), backend="numpy", directory=directory,
                         transforms=("T",)).with_params(k_EI=stiffness)
    tau, _ = motor_torques(model, run["t"], run["q"], run["qd"])
    return run, tau, wall, model


def build_time(nrfe, directory) -> float:
    """Wall time (s) of building the example at ``nrfe`` from nothing: derivation, code
    generation and the C compile, into ``directory`` with a C cache of its own."""
    before = os.environ.get("GPMEGEN_CACHE")
    os.environ["GPMEGEN_CACHE"] = str(Path(directory) / "cache")
    try:
        start = time.perf_counter()
        gpmegen.load(model=gpmegen.load_model_file(MODEL, nrfe=nrfe), backend="c", directory=directory)
        return time.perf_counter() - start
    finally:
        if before is None:
            del os.environ["GPMEGEN_CACHE"]
        else:
            os.environ["GPMEGEN_CACHE"] = before


def measures(run, tau, tau_rigid, deflection, T, tail) -> dict:
    """The table's numbers of one run against the rigid Delta's torques on the same times."""
    t = run["t"]
    rest = t >= t[-1] - tail - 1e-12
    difference = tau - tau_rigid
    return {"peak": np.abs(tau).max(), "difference": np.abs(difference).max(),
            "move_difference": np.abs(difference[t <= T]).max(),
            "residual_torque": np.ptp(difference[rest], axis=0).max(),
            "deflection": deflection.max(), "residual_deflection": np.ptp(deflection[rest], axis=0).max()}


def figure(path, t, tau_rigid, flexible, T):
    """Motor torques of the rigid Delta and of the flexible ones (``flexible``: label -> τ)."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7.5, 6.5), sharex=True, height_ratios=(3, 2))
    colours = ("C0", "C1", "C2")
    for j, name in enumerate(MOTORS):
        top.plot(t, tau_rigid[:, j], color=colours[j], lw=2.5, alpha=0.35, label=f"{name}, rigid")
    styles = ("-", "--", "-.", ":")
    for (label, tau), style in zip(flexible.items(), styles):
        for j, name in enumerate(MOTORS):
            top.plot(t, tau[:, j], color=colours[j], lw=0.9, ls=style, label=f"{name}, {label}" if j == 0 else None)
            bottom.plot(t, tau[:, j] - tau_rigid[:, j], color=colours[j], lw=0.9, ls=style,
                        label=label if j == 0 else None)
    for axis in (top, bottom):
        axis.axvline(T, color="0.6", lw=0.8)
        axis.grid(alpha=0.3)
    top.set_ylabel("motor torque τ [N·m]")
    top.set_title("Delta robot, platform on a half circle in 0.25 s: motor torques, rigid and flexible forearms",
                  fontsize=9)
    top.legend(fontsize=7, ncol=2)
    bottom.set_ylabel("τ flexible - τ rigid [N·m]")
    bottom.set_xlabel("t [s]  (the move ends at the grey line; the platform then rests)")
    bottom.legend(fontsize=7, title="theta1, theta2, theta3 in colour", title_fontsize=7)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


def main(argv=None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--nrfe", type=int, nargs="+", default=[2, 3, 5], help="n_rfe of the flexible runs")
    parser.add_argument("--stiffness", type=float, nargs="+", default=[10.0, 1.0, 0.1, 0.01],
                        help="factors k_EI on the forearms' bending stiffness, at the --study n_rfe")
    parser.add_argument("--study", type=int, default=3, help="n_rfe of the stiffness study")
    parser.add_argument("--dt", type=float, default=2e-5, help="RK4 step of the flexible runs (s)")
    parser.add_argument("--t-end", type=float, default=0.4, help="end of the runs (s); the move takes T = 0.25 s")
    parser.add_argument("--tail", type=float, default=0.1, help="the last seconds, at rest, of the residual measures")
    parser.add_argument("--figure", default=str(ROOT / "docs" / "figures" / "delta_torques.png"))
    parser.add_argument("--no-figure", action="store_true")
    args = parser.parse_args(argv)
    T = 0.25
    with tempfile.TemporaryDirectory() as scratch:
        print("build (derivation, code generation, C compile), wall s:")
        for nrfe in sorted({1, *args.nrfe, args.study}):
            print(f"  n_rfe {nrfe}: {build_time(nrfe, Path(scratch) / f'build{nrfe}'):.1f}")
        directory = Path(scratch) / "runs"
        rigid, tau_rigid, wall, _ = run_case(1, 1.0, 1e-4, args.t_end, directory)
        rigid, tau_rigid, wall, _ = run_case(1, 1.0, 1e-4, args.t_end, directory)   # built: its run alone
        print(f"rigid (n_rfe 1, dt 1e-4): {wall / args.t_end:.2f} s per s of motion; peak |τ| "
              f"{np.abs(tau_rigid).max():.4f} N·m")
        cases = [(nrfe, 1.0) for nrfe in args.nrfe] + [(args.study, k) for k in args.stiffness if k != 1.0]
        print("n_rfe | k_EI | wall per s of motion [s] | peak |τ| [N·m] | max |τ - τ_rigid| (move) [N·m] | "
              "residual τ, peak to peak [N·m] | forearm deflection, max [mm] | residual, peak to peak [mm]")
        shown = {}
        for nrfe, k in cases:
            gpmegen.load(model=gpmegen.load_model_file(MODEL, nrfe=nrfe), backend="c", directory=directory)
            run, tau, wall, model = run_case(nrfe, k, args.dt, args.t_end, directory)
            m = measures(run, tau, tau_rigid, forearm_deflections(model, run["q"]), T, args.tail)
            print(f"{nrfe} | {k:g} | {wall / args.t_end:.2f} | {m['peak']:.4f} | {m['move_difference']:.2e} | "
                  f"{m['residual_torque']:.2e} | {1e3 * m['deflection']:.4f} | {1e3 * m['residual_deflection']:.2e}",
                  flush=True)
            if nrfe == args.study:
                shown[f"n_rfe {nrfe}, k_EI {k:g}"] = tau
        print("\nmotors driven along the rigid Delta's inverse kinematics (the multipliers are the torques):")
        motors_file = Path(scratch) / "delta_motors.toml"
        motors_file.write_text(motor_driven_text())
        print("n_rfe | k_EI | peak |τ| [N·m] | max |τ - τ_rigid| (move) [N·m] | platform off its path, max [mm] | "
              "platform's residual vibration, peak to peak [mm]")
        for nrfe, k in [(1, 1.0)] + cases:
            step = 1e-4 if nrfe == 1 else args.dt
            run = gpmegen.simulate(str(motors_file), nrfe=nrfe, t_end=args.t_end, dt=step,
                                   save_every=max(1, round(1e-3 / step)), backend="c", directory=directory,
                                   params={"k_EI": k}, start="constrained")
            names = list(run["constraint_names"])
            tau = run["lambda"][:, [names.index(f"motor{leg}") for leg in (1, 2, 3)]]
            off = run["end_effector"] - platform_path(run["t"], MODEL)
            rest = run["t"] >= run["t"][-1] - args.tail - 1e-12
            print(f"{nrfe} | {k:g} | {np.abs(tau).max():.4f} | {np.abs(tau - tau_rigid)[run['t'] <= T].max():.2e} | "
                  f"{1e3 * np.linalg.norm(off, axis=1).max():.2e} | {1e3 * np.ptp(off[rest], axis=0).max():.2e}",
                  flush=True)
        if not args.no_figure and shown:
            figure(args.figure, rigid["t"], tau_rigid, shown, T)
            print(f"wrote {args.figure}")


if __name__ == "__main__":
    main()
