"""An LQR on a flexible arm, designed on its linear model, run in the nonlinear loop, against a
PD law on the joint.

The arm of examples/flexible_arm.toml (a hub turning about z in the horizontal plane, a thin
aluminium strip bending in that plane, a payload at its tip; n_rfe = NRFE) is linearized about
its undeformed rest (``gpmegen.linearize``: x = (theta1, the strip's sde rotations psi, and their
rates), the input u a torque on theta1) and an LQR gain K designed on that model with
python-control (``LinearModel.state_space``, ``control.lqr``). The gain becomes the arm's drive,
a feedback law of the state written from K,

    u = -K (x - x_ref(t)),   x_ref = (theta_ref(t), 0, ..., theta_ref'(t), 0, ...),

theta_ref a smooth rest-to-rest turn by THETA_F in T s (a 7th-order step), the gains its
parameters; the PD law is the same drive with the gains on the hub's angle and rate alone (K's
own), the strip's deflections not fed back. Both run on the nonlinear model (DOP853) to T +
AFTER s, and ``gpmegen.metrics`` measures them against the reference motion, the arm whose tip
is held on the ray at angle theta_ref(t) (a programmed constraint): the tip's path error and its
residual vibration after T, the torque's effort. Printed: the gain, the closed-loop poles of the
linear model, and both runs' metrics.

    python examples/lqr_flexible_arm.py
"""

from __future__ import annotations

import argparse
import dataclasses
from pathlib import Path

import control
import numpy as np
import sympy as sp

import gpmegen
from gpmegen.analysis.run import tracking
from gpmegen.model.chain import TIME, point_symbols, symbol, velocity_symbol

MODEL_FILE = Path(__file__).with_name("flexible_arm.toml")
NRFE = 3             # two sdes: the strip's first two bending modes
THETA_F = 0.5        # rad, the turn
T = 1.0              # s, its duration
AFTER = 2.0          # s after T, where the residual vibration is measured
Q_ANGLE = 3e4        # LQR weight of the hub's angle error (1/rad²; R = 1 per (N·m)²)
Q_DEFLECTION = 1e4   # of each sde rotation (1/rad²): the deflection's share of the cost
Q_RATE = 1.0         # of each rate (s²/rad²)


def step(t):
    """The 7th-order smooth step s(t/T) from 0 to 1 (rest to rest, jerk zero at both ends), and
    its rate in 1/s, as SymPy expressions of t."""
    s = sp.Min(sp.Max(TIME / T, 0), 1)
    shape = s ** 4 * (35 - 84 * s + 70 * s ** 2 - 20 * s ** 3)
    rate = 140 * s ** 3 * (1 - s) ** 3 / T
    return shape, rate


def design(nrfe: int, backend) -> tuple:
    """The linear model about rest and the LQR gain K (1, 2k) on it: ``(linear, K, poles)``."""
    linear = gpmegen.linearize(str(MODEL_FILE), nrfe=nrfe, start="none", inputs=("theta1",), backend=backend)
    system = linear.state_space()
    k = len(linear.states) // 2
    weights = [Q_ANGLE] + [Q_DEFLECTION] * (k - 1) + [Q_RATE] * k
    K, _, poles = control.lqr(system, np.diag(weights), np.eye(1))
    return linear, np.asarray(K), np.asarray(poles)


def controlled(arm: gpmegen.Model, states) -> gpmegen.Model:
    """``arm`` with the torque on theta1 the state feedback ``-Σ k_j (x_j - x_ref_j)``, one gain
    parameter ``k_<state>`` per state (default 0), x_ref the turn on theta1 and its rate."""
    shape, rate = step(TIME)
    reference = {"theta1": THETA_F * shape, "theta1_dot": THETA_F * rate}
    law = 0
    for name in states:
        value = velocity_symbol(name[:-4]) if name.endswith("_dot") else symbol(name)
        law -= symbol(f"k_{name}") * (value - reference.get(name, 0))
    gains = tuple(gpmegen.Parameter(f"k_{name}", 0.0, "N m per unit of the state", f"gain on {name}")
                  for name in states)
    return dataclasses.replace(arm, name="flexible_arm_feedback", parameters=arm.parameters + gains,
                               drives=(gpmegen.Drive("theta1", law),))


def reference_motion(arm: gpmegen.Model) -> gpmegen.Model:
    """``arm`` with its tip held on the ray at angle theta_ref(t) through the joint: the motion
    both laws are to make, its constraint value the tip's distance from the ray (m)."""
    x, y, _ = point_symbols("tip")
    angle = THETA_F * step(TIME)[0]
    ray = gpmegen.Constraint("tip_on_ray", y * sp.cos(angle) - x * sp.sin(angle), 0, sp.Integer(20), sp.Integer(20))
    return dataclasses.replace(arm, name="flexible_arm_turn", constraints=(ray,))


def main(argv=None) -> dict:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nrfe", type=int, default=NRFE, help=f"rigid finite elements of the strip (default {NRFE})")
    parser.add_argument("--backend", choices=("numpy", "c"), default=None, help="default: c where a compiler is")
    parser.add_argument("--out", type=Path, default=None, help="folder for metrics.csv and tracking.png")
    args = parser.parse_args(argv)
    linear, K, poles = design(args.nrfe, args.backend)
    print(f"states: {', '.join(linear.states)}")
    print("LQR gain K: " + ", ".join(f"{name} {k:.6g}" for name, k in zip(linear.states, K[0])))
    joint = np.array([name in ("theta1", "theta1_dot") for name in linear.states])
    pd_poles = np.linalg.eigvals(linear.A - linear.B @ (K * joint))
    for label, values in (("LQR", poles), ("PD", pd_poles)):
        values = sorted(values, key=lambda p: (abs(p), p.imag))
        print(f"closed-loop poles of the linear model, {label} (1/s): " + ", ".join(f"{p:.4g}" for p in values))
    arm = gpmegen.load_model_file(MODEL_FILE, nrfe=args.nrfe)
    plant = controlled(arm, linear.states)
    lqr = {f"k_{name}": float(k) for name, k in zip(linear.states, K[0])}
    pd = {f"k_{name}": float(k) * keep for name, k, keep in zip(linear.states, K[0], joint)}
    runs = {}
    for label, gains in (("PD on the joint", pd), ("LQR", lqr)):
        run = gpmegen.simulate(plant, params=gains, t_end=T + AFTER, method="dop853", save_dt=1e-3, rtol=1e-9,
                               atol=1e-9, backend=args.backend)
        print(f"{label}: {run.status}")
        runs[label] = run
    found = gpmegen.metrics(list(runs.values()), reference_motion(arm), after=T, backend=args.backend)
    report = {}
    for label, m in zip(runs, found):
        m.name = label
        peak, mean, energy = m.effort["theta1"]
        report[label] = {"vibration_peak_to_peak": m.vibration[0], "vibration_rms": m.vibration[1],
                         "path_error_max": m.path[0], "path_error_rms": m.path[1], "torque_peak": peak,
                         "effort_energy": energy}
    print(tracking.table(found))
    ratio = report["PD on the joint"]["vibration_rms"] / report["LQR"]["vibration_rms"]
    print(f"residual vibration of the tip after {T:g} s, RMS: PD {report['PD on the joint']['vibration_rms']:.3g} m, "
          f"LQR {report['LQR']['vibration_rms']:.3g} m ({ratio:.3g} times less)")
    if args.out is not None:
        from gpmegen.analysis.figures import tracking_plots
        print(f"wrote {tracking.write_csv(found, args.out / 'metrics.csv')}")
        for path in tracking_plots.path_error([run.arrays for run in runs.values()], found,
                                              "tip held on the ray at theta_ref(t)", args.out, labels=list(runs)):
            print(f"wrote {path}")
    return {"K": K, "poles": poles, "pd_poles": pd_poles, "metrics": report, "ratio": ratio}


if __name__ == "__main__":
    main()
