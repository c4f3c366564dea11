"""An optimal point-to-point motion of a flexible arm, on the model's CasADi export.

The arm of examples/flexible_arm.toml (a hub turning about z, a thin strip bending in the plane
of the motion, a payload at its tip) turns by THETA_F in T seconds from rest, driven by the
torque u on theta1. The motion is optimized by direct multiple shooting (CasADi's Opti, IPOPT)
on the exported accelerations qdd(t, q, qd, u, p): u constant over each of N intervals, each
interval integrated by RK4 in SUBSTEPS steps, and the cost

    J = sum_k h u_k^2  +  W_RATE sum_k (u_k - u_{k-1})^2 / h  +  W (kinetic + spring energy at T)

(effort, its changes, from and back to zero torque, and the vibration left when the torque stops),
with theta1(T) = THETA_F. It is done twice:
on the flexible arm (n_rfe = 4) and on the same arm rigid (n_rfe = 1). Both torques are then
applied to the flexible arm by gpmegen's own simulation (DOP853 on the generated code, the torque
a drive of the model) over T + 1 s, the torque off after T; printed: the agreement of that
simulation with the optimizer's states, and the residual vibration, the RMS of the tip's
deflection (its distance from the hub's line through the joint) over the second after T.

    python examples/optimal_motion.py --out optimal_motion --figure optimal_motion.png
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from pathlib import Path

import casadi
import numpy as np
import sympy as sp

import gpmegen
from gpmegen.model.chain import TIME

MODEL_FILE = Path(__file__).with_name("flexible_arm.toml")
THETA_F = np.pi / 2  # rad
T = 1.5              # s, the motion's duration
N = 60               # intervals of constant torque
SUBSTEPS = 5         # RK4 steps per interval (5 ms: within RK4's stable step of the arm's highest mode, 60 Hz)
W = 1e4              # weight of the residual energy (N^2 m^2 s per J)
W_RATE = 0.01        # weight of the torque's changes (s^2)
AFTER = 1.0          # s of free vibration after T, where it is measured


def export(folder: Path, nrfe: int) -> tuple[dict, list]:
    """The arm's CasADi functions with n_rfe ``nrfe`` (input u: the torque on theta1), and the
    parameter defaults."""
    functions = gpmegen.export_casadi(folder / f"casadi_nrfe{nrfe}", MODEL_FILE, nrfe=nrfe, inputs=("theta1",),
                                      overwrite=True)
    return functions, json.loads((folder / f"casadi_nrfe{nrfe}" / "casadi.json").read_text())["defaults"]


def optimize(functions: dict, p: list) -> dict:
    """The optimal motion by direct multiple shooting: states X (2n, N + 1), torques U (N,)."""
    qdd_function = functions["qdd"]
    n = qdd_function.size1_in(1)
    h = T / N
    x, u, t0 = casadi.SX.sym("x", 2 * n), casadi.SX.sym("u"), casadi.SX.sym("t0")

    def rate(t, x):
        return casadi.vertcat(x[n:], qdd_function(t, x[:n], x[n:], u, p))

    y, dt = x, h / SUBSTEPS
    for k in range(SUBSTEPS):
        t = t0 + k * dt
        k1 = rate(t, y)
        k2 = rate(t + dt / 2, y + dt / 2 * k1)
        k3 = rate(t + dt / 2, y + dt / 2 * k2)
        k4 = rate(t + dt, y + dt * k3)
        y = y + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
    step = casadi.Function("step", [t0, x, u], [y])

    opti = casadi.Opti()
    X, U = opti.variable(2 * n, N + 1), opti.variable(1, N)
    opti.subject_to(X[:, 0] == 0)  # at rest, undeformed
    for k in range(N):
        opti.subject_to(X[:, k + 1] == step(k * h, X[:, k], U[k]))
    opti.subject_to(X[0, N] == THETA_F)
    energies = functions["energies"](X[:n, N], X[n:, N], p)
    effort = h * casadi.sumsqr(U) + W_RATE * casadi.sumsqr(casadi.diff(casadi.horzcat(0, U, 0), 1, 1)) / h
    opti.minimize(effort + W * (energies[0] + energies[2]))
    ramp = np.linspace(0, 1, N + 1)
    opti.set_initial(X[0, :], THETA_F * ramp * ramp * (3 - 2 * ramp))
    opti.solver("ipopt", {"print_time": False}, {"print_level": 0, "sb": "yes", "tol": 1e-10})
    started = time.perf_counter()
    solution = opti.solve()
    return dict(X=np.atleast_2d(solution.value(X)), U=np.atleast_1d(solution.value(U)),
                effort=float(solution.value(h * casadi.sumsqr(U))), cost=float(solution.value(opti.f)),
                residual_energy=float(solution.value(energies[0] + energies[2])),
                iterations=int(solution.stats()["iter_count"]), seconds=time.perf_counter() - started)


def driven(model: gpmegen.Model, name: str) -> gpmegen.Model:
    """``model`` with the torque on theta1 a drive: u_k (parameters) over the k-th interval of
    [0, T], zero after T."""
    h = T / N
    values = [sp.Symbol(f"u_{k}", real=True) for k in range(N)]
    torque = sp.Piecewise(*[(values[k], TIME < (k + 1) * h) for k in range(N)], (0, True))
    parameters = tuple(gpmegen.Parameter(f"u_{k}", 0.0, "N m", f"torque on interval {k}") for k in range(N))
    return dataclasses.replace(model, name=name, parameters=model.parameters + parameters,
                               drives=(gpmegen.Drive("theta1", torque),))


def simulate(model: gpmegen.Model, torques, directory: Path):
    """gpmegen's run of ``model`` driven by ``torques`` over [0, T + AFTER]: times, q (k, n), the
    tip's deflection (k,)."""
    params = {f"u_{k}": float(v) for k, v in enumerate(torques)}
    run = gpmegen.simulate(model, params=params, t_end=T + AFTER, method="dop853", save_dt=T / N / 10,
                           rtol=1e-10, atol=1e-12, directory=directory)
    theta, tip = run.coordinate("theta1"), run["end_effector"]
    deflection = -np.sin(theta) * tip[:, 0] + np.cos(theta) * tip[:, 1]
    return run.t, run["q"], deflection


def deflection_of(functions: dict, p: list, q) -> np.ndarray:
    """The tip's deflection at the states ``q`` (n, k) by the exported ``points``."""
    tips = np.array([np.asarray(functions["points"](q[:, k], p)).ravel() for k in range(q.shape[1])])
    return -np.sin(q[0]) * tips[:, 0] + np.cos(q[0]) * tips[:, 1]


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--out", type=Path, default=Path("optimal_motion"), help="folder of the exports and builds")
    parser.add_argument("--figure", type=Path, default=None, help="write the figure of both motions here (.png)")
    args = parser.parse_args(argv)
    flexible_fns, p_flexible = export(args.out, 4)
    rigid_fns, p_rigid = export(args.out, 1)
    flexible, rigid = optimize(flexible_fns, p_flexible), optimize(rigid_fns, p_rigid)
    model = gpmegen.load_model_file(MODEL_FILE, nrfe=4)
    arm = driven(model, "flexible_arm_driven")
    generated = args.out / "generated"
    report = {}
    runs = {}
    n = flexible["X"].shape[0] // 2
    h = T / N
    nodes = np.arange(N + 1) * h
    for label, optimum in (("flexible", flexible), ("rigid", rigid)):
        t, q, deflection = simulate(arm, optimum["U"], generated)
        runs[label] = (t, q, deflection)
        after = t >= T - 1e-12
        at_nodes = np.searchsorted(t, nodes - 1e-9)
        entry = dict(effort=optimum["effort"], iterations=optimum["iterations"], seconds=optimum["seconds"],
                     peak_torque=float(np.abs(optimum["U"]).max()),
                     residual_rms=float(np.sqrt(np.mean(deflection[after] ** 2))),
                     residual_peak=float(np.abs(deflection[after]).max()),
                     theta_at_T=float(q[at_nodes[-1], 0]))
        if label == "flexible":  # the optimizer's states against gpmegen's run at the nodes
            entry["agreement_theta"] = float(np.abs(q[at_nodes, 0] - optimum["X"][0]).max())
            entry["agreement_deflection"] = float(np.abs(
                deflection[at_nodes] - deflection_of(flexible_fns, p_flexible, optimum["X"][:n])).max())
        else:  # the rigid optimum on the rigid arm (the optimizer's model) reaches THETA_F at rest
            entry["rigid_theta_at_T"] = float(optimum["X"][0, -1])
        report[label] = entry
    report["ratio"] = report["rigid"]["residual_rms"] / report["flexible"]["residual_rms"]
    for label in ("flexible", "rigid"):
        e = report[label]
        print(f"optimized on the {label} model: effort {e['effort']:.4f} N^2 m^2 s, peak torque "
              f"{e['peak_torque']:.3f} N m ({e['iterations']} IPOPT iterations, {e['seconds']:.1f} s); on the "
              f"flexible arm: theta1(T) = {e['theta_at_T']:.5f} rad, residual tip deflection RMS "
              f"{1e3 * e['residual_rms']:.4f} mm, peak {1e3 * e['residual_peak']:.4f} mm")
    print(f"residual vibration (RMS) of the rigid model's optimum / the flexible model's: {report['ratio']:.0f}")
    print(f"gpmegen's run (DOP853) against the optimizer's states at the {N + 1} nodes: theta1 within "
          f"{report['flexible']['agreement_theta']:.1e} rad, tip deflection within "
          f"{report['flexible']['agreement_deflection']:.1e} m")
    if args.figure:
        figure(runs, flexible, rigid, args.figure)
        print(f"wrote {args.figure}")
    return report


def figure(runs, flexible, rigid, path: Path):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(3, 1, figsize=(7, 7.5), sharex=True)
    h = T / N
    for (label, optimum), style in zip((("flexible", flexible), ("rigid", rigid)), ("-", "--")):
        t, q, deflection = runs[label]
        name = f"optimized on the {label} model"
        axes[0].step(np.arange(N + 1) * h, np.append(optimum["U"], optimum["U"][-1]), style, where="post",
                     label=name)
        axes[1].plot(t, q[:, 0], style, label=name)
        axes[2].plot(t, 1e3 * deflection, style, label=name)
    for ax in axes:
        ax.axvline(T, color="0.6", lw=0.8)
        ax.grid(alpha=0.3)
    axes[0].set_ylabel("torque u (N m)")
    axes[1].set_ylabel("hub angle θ1 (rad)")
    axes[2].set_ylabel("tip deflection (mm)")
    axes[2].set_xlabel("t (s); the torque stops at the grey line")
    axes[0].legend(loc="upper right", fontsize=8)
    axes[0].set_title("flexible arm, both torques simulated by gpmegen on the flexible model", fontsize=10)
    fig.tight_layout()
    fig.savefig(path, dpi=90)
    plt.close(fig)


if __name__ == "__main__":
    main()
