"""The two examples of second-order programmed constraints, run and drawn for the README.

Run: ``.venv/bin/python benchmarks/order2_examples.py [--out docs/figures] [--t-end 6] [--dt 1e-5]``.

- ``examples/manipulator_tangential.toml`` (n_rfe = 5): E on the circle at the prescribed height,
  its speed along the circle from a prescribed tangential acceleration; from the locked statics.
- ``examples/curvature_arm.toml`` (n_rfe = 3): the tip path of prescribed curvature at constant
  speed; from the locked statics, in motion (the shoulder turning at ``w0``).

Prints, for each, how well the constraints hold along the run (the second-order ones checked
from positions alone, :mod:`gpmegen.analysis.post.point_motion`), and writes one figure each.

``--drift`` instead prints how the lower-order integrals of second-order constraints drift:
``tests/models/reaching_arm_ddot.toml`` holds the position constraints of ``reaching_arm.toml``
as ``Φ̈ = 0``; along its run (RK4, steps 1e-3 and 1e-4 s) ``Φ`` and ``Φ̇`` of the position
constraints are evaluated at the saved states, beside the Baumgarte-held original.
"""

from __future__ import annotations

import argparse
from pathlib import Path

import numpy as np

import gpmegen
from gpmegen.analysis.post import point_motion
from gpmegen.analysis.run import study
from gpmegen.analysis.run.model_files import read_model_file
from gpmegen.runtime import integrators

ROOT = Path(__file__).resolve().parents[1]


def start(path, backend="c", nrfe=None):
    """The loaded model of the example file ``path`` and its locked-statics start q0 (n,)."""
    file = read_model_file(path, nrfe)
    model = gpmegen.load(model=file.model, backend=backend)
    begun = study.file_start(model, file.initial_values(model.params), "locked")
    return begun.model, begun.q


def run(model, q0, qd0, t_end, dt, save_every):
    """RK4 from ``(q0, qd0)``; the results dict of :func:`gpmegen.analysis.run.study.collect`."""
    t, y, outcome = integrators.rk4.rk4(model, q0, qd0, t_end, dt, save_every)
    settings = dict(method="rk4", dt=dt, save_every=save_every, t_end=t_end, start="locked", backend=model.backend,
                    dependent=[model.coordinates[k] for k in model.dependent], repartitions=[])
    return study.collect(model, t, y, str(outcome), settings)


def motion_of(model, point, res):
    """Velocity and acceleration (k, 3) of ``point`` at the saved states, from positions alone."""
    v, a = np.zeros((len(res["t"]), 3)), np.zeros((len(res["t"]), 3))
    for k, t in enumerate(res["t"]):
        q, qd = res["q"][k], res["qd"][k]
        _, v[k], a[k] = point_motion.point_motion(model, point, q, qd, model.accelerations(t, q, qd))
    return v, a


def tangential(t_end, dt, out):
    model, q0 = start(ROOT / "examples" / "manipulator_tangential.toml", nrfe=5)
    res = run(model, q0, np.zeros(model.n_dof), t_end, dt, max(1, round(1e-3 / dt)))
    p = model.params
    v, a = motion_of(model, "E", res)
    E = res["end_effector"]
    tangent = np.column_stack([E[:, 2], np.zeros(len(E)), -E[:, 0]]) / p["r_Ea"]
    speed = np.sum(v * tangent, axis=1)
    t = res["t"]
    prescribed = p["a0"] * p["Ta"] / (2 * np.pi) * (1 - np.cos(2 * np.pi * t / p["Ta"]))
    along = np.sum(a * tangent, axis=1) - p["a0"] * np.sin(2 * np.pi * t / p["Ta"])
    print(f"tangential: max |circle, height| = {np.max(np.abs(res['phi'][:, :2])):.2e} m², m; "
          f"max |tangential acceleration error| = {np.max(np.abs(along)):.2e} m/s²; "
          f"max |speed - prescribed| = {np.max(np.abs(speed - prescribed)):.2e} m/s")
    fig, ax = _figure((14, 3.6), 3)
    ax[0].plot(t, speed, label="speed of E along the circle")
    ax[0].plot(t, prescribed, "--", label=r"$\int a_t\,dt$ prescribed")
    ax[0].set(xlabel="t [s]", ylabel="[m/s]", title="speed along the circle")
    ax[0].legend(fontsize=8)
    for name in ("theta1", "psi2", "x3"):
        ax[1].plot(t, res["q"][:, model.index(name)], label=name + (" [m]" if name == "x3" else " [rad]"))
    ax[1].set(xlabel="t [s]", title="joint coordinates")
    ax[1].legend(fontsize=8)
    ax[2].plot(t, 1e3 * res["q"][:, model.index("psi2_1")], lw=0.5)
    ax[2].set(xlabel="t [s]", ylabel="[mrad]", title="first sde of the arm, psi2_1")
    _save(fig, out / "order2_tangential.png")


def curving(t_end, dt, out):
    model, q0 = start(ROOT / "examples" / "curvature_arm.toml")
    qd0 = np.zeros(model.n_dof)
    qd0[model.index("theta1")] = model.params["w0"]
    res = run(model, q0, qd0, t_end, dt, max(1, round(1e-3 / dt)))
    p = model.params
    v, a = motion_of(model, "P", res)
    t = res["t"]
    kappa = p["k0"] * (1 + p["k1"] * np.sin(2 * np.pi * t / p["Tk"]))
    speed = np.hypot(v[:, 0], v[:, 1])
    print(f"curvature: max |kappa - prescribed| = {np.max(np.abs(point_motion.curvature(v, a) - kappa)):.2e} 1/m; "
          f"speed {speed.min():.9f} .. {speed.max():.9f} m/s")
    P = res["end_effector"]
    fig, ax = _figure((10, 4), 2)
    ax[0].plot(P[:, 0], P[:, 1])
    ax[0].plot(P[0, 0], P[0, 1], "o", label="start")
    ax[0].plot(0, 0, "k+", label="shoulder")
    ax[0].set(xlabel="x0 [m]", ylabel="y0 [m]", title="path of P", aspect="equal")
    ax[0].legend(fontsize=8)
    ax[1].plot(t, point_motion.curvature(v, a), label="from the motion")
    ax[1].plot(t, kappa, "--", label=r"$\kappa(t)$ prescribed")
    ax[1].set(xlabel="t [s]", ylabel="[1/m]", title="curvature of the path")
    ax[1].legend(fontsize=8)
    _save(fig, out / "order2_curvature.png")


def _figure(size, panels):
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt.subplots(1, panels, figsize=size)


def _save(fig, path):
    import matplotlib.pyplot as plt

    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
    print(f"wrote {path}")


def drift(t_end):
    """max |Φ| and |Φ̇| of the reaching arm's position constraints up to 1, 3, ... s, along the run
    of their second-order form (no gains) and of themselves (Baumgarte gains)."""
    models = ROOT / "tests" / "models"
    position, q0 = start(models / "reaching_arm.toml")
    second, _ = start(models / "reaching_arm_ddot.toml")
    n, qd0 = position.n_dof, np.zeros(position.n_dof)
    marks = [m for m in (1.0, 3.0, 10.0, 30.0) if m <= t_end]
    print(f"{'run':<28}{'dt [s]':>8}" + "".join(f"{f'|Φ| ≤{m:g} s':>14}{f'|Φ̇| ≤{m:g} s':>14}" for m in marks))
    for label, model in (("second order (Φ̈ = 0)", second), ("position (Baumgarte 10, 10)", position)):
        for dt in (1e-3, 1e-4):
            t, y, _ = integrators.rk4.rk4(model, q0, qd0, t_end, dt, max(1, round(0.01 / dt)))
            terms = [position.constraint_terms(tk, y[k, :n], y[k, n:2 * n]) for k, tk in enumerate(t)]
            phi = np.array([np.max(np.abs(c[0])) for c in terms])
            rate = np.array([np.max(np.abs(c[1])) for c in terms])
            print(f"{label:<28}{dt:>8g}" + "".join(f"{phi[t <= m].max():>14.2e}{rate[t <= m].max():>14.2e}"
                                                   for m in marks))


def main(argv=None):
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=ROOT / "docs" / "figures")
    parser.add_argument("--t-end", type=float, default=6.0)
    parser.add_argument("--dt", type=float, default=1e-5)
    parser.add_argument("--drift", action="store_true", help="print the drift of lower-order integrals instead")
    args = parser.parse_args(argv)
    if args.drift:
        drift(args.t_end)
        return
    args.out.mkdir(parents=True, exist_ok=True)
    tangential(args.t_end, args.dt, args.out)
    curving(args.t_end, args.dt, args.out)


if __name__ == "__main__":
    main()
