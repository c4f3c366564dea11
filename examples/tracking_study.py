"""The paper's question as a study: does a feedforward from the flexible model track better than
one from the rigid model, on a flexible plant finer than both?

The motion (examples/tracking_study.toml): the reference arm's end-effector E turns with the
column by THETA while dropping by A on the circle of radius r_E about it, rest to rest over T s.
Its driving functions, the inputs on the three joints that realize it, are found on

- the rigid arm (n_rfe 1): E's path realized by the actuated realization (its joints then follow
  the rigid inverse kinematics, the references of examples/tracking_study_joints.toml);
- a flexible arm (n_rfe ``--nrfe-model``, default 3), twice: realizing E's path itself, and
  realizing the rigid arm's joint references (examples/tracking_study_joints.toml). E's path on
  the flexible arm is non-minimum phase (its internal dynamics have a real unstable pair, 45.6
  and 362 1/s at n_rfe 3 at the start), so its bounded inputs come from the stable inversion
  (``gpmegen invert``, over [-0.1 s, the run's end]); the joints' realization runs forward.

Four controllers then drive a flexible plant of n_rfe ``--nrfe-plant`` (default 8), without
constraints, from the statics with the joints locked:

(a) the rigid driving functions fed forward plus PD about the rigid joint references;
(b) the flexible model's inversion of E's path fed forward plus the same PD about the joints'
    motion of that inversion (examples/tracking_study_pd_inverse.toml), the plant started with
    its joints where the inversion rests before the motion (the arm raised against its sag);
(b') the flexible model's realization of the rigid joint references fed forward plus the PD
    of (a);
(c) computed torque with the rigid arm as the controller's model (the same natural frequency).

``gpmegen.metrics`` measures each against the rigid realization (E's programmed path): the path
error of E (max, RMS), the programmed constraints' values on the plant (turn, circle, height, of
examples/tracking_study.toml at the plant's n_rfe), the residual vibration of E after the motion
(p-p, RMS) and the effort. Writes ``metrics.csv``, ``metrics.md`` and ``tracking.png`` into
``--out`` (default results/), beside the driving functions' results files and the inversion.

    python examples/tracking_study.py
"""

from __future__ import annotations

import argparse
import shutil
import warnings
from pathlib import Path

import numpy as np

import gpmegen
from gpmegen import cli
from gpmegen.analysis.run import tracking

HERE = Path(__file__).parent
MOTION = HERE / "tracking_study.toml"           # E's path held by constraints
JOINTS = HERE / "tracking_study_joints.toml"    # the joints held on the rigid references
PD = HERE / "tracking_study_pd.toml"            # the plant under PD (plus a feedforward)
PD_INVERSE = HERE / "tracking_study_pd_inverse.toml"   # the plant under PD about the inversion's joints
INVERSION = "flexible_inversion.npz"            # the name PD_INVERSE's table signals read, beside it
CT = HERE / "tracking_study_ct.toml"            # the plant under computed torque
T_END = 3.5      # s: the motion lasts T = 2 s, then 1.5 s of residual vibration
AFTER = 2.0      # s: the end of the motion
PRE = 0.1        # s: the inversion's window before the motion (its inputs leave rest by < 1 % in it)
LABELS = ("(a) rigid feedforward + PD", "(b) flexible inversion of E's path + PD",
          "(b') flexible realization of the joints + PD", "(c) computed torque, rigid model")


def feedforwards(out: Path, nrfe_model: int, t_end: float, backend) -> tuple[Path, Path]:
    """The rigid and the flexible driving functions as results files in ``out``: RK4 at 1 ms
    (rigid) and 0.1 ms (flexible), saved every 1 ms."""
    rigid = gpmegen.simulate(MOTION, nrfe=1, t_end=t_end, dt=1e-3, start="none", backend=backend)
    flexible = gpmegen.simulate(JOINTS, nrfe=nrfe_model, t_end=t_end, dt=1e-4, save_every=10, start="locked",
                                backend=backend)
    paths = out / "rigid_realization.npz", out / f"flexible_realization_nrfe{nrfe_model}.npz"
    for run, path in zip((rigid, flexible), paths):
        if run.status != "complete":
            raise SystemExit(f"{path.name}: {run.status}")
        run.save(path, overwrite=True)
    return paths


def inversion(out: Path, nrfe_model: int, t_end: float) -> Path:
    """The flexible arm's stable inversion of E's path, ``out``/INVERSION, over [-PRE, t_end] (at
    least PRE past the motion's end, so that it rests at both ends), with PD_INVERSE copied beside
    it for the plant (b) to read it."""
    path = out / INVERSION
    post = max(PRE, t_end - AFTER)
    args = ["invert", str(MOTION), "--nrfe", str(nrfe_model), "--t1", f"{AFTER:g}", "--pre", f"{PRE:g}",
            "--post", f"{post:g}", "--out", str(path), "--overwrite"]
    if cli.main(args) != 0:
        raise SystemExit(f"{path.name}: the stable inversion failed")
    shutil.copyfile(PD_INVERSE, out / PD_INVERSE.name)
    return path


def start_of(run: Path) -> dict:
    """The joints psi2_0, x3_0 (rad, m) where the run at ``run`` is at t = 0: the parameters of
    PD_INVERSE's start."""
    data = np.load(run)
    coordinates = [str(c) for c in data["coordinates"]]
    return {f"{c}_0": float(np.interp(0.0, data["t"], data["q"][:, coordinates.index(c)])) for c in ("psi2", "x3")}


def controlled(paths, inverse: Path, nrfe_plant: int, t_end: float, backend) -> list:
    """The plant's four runs (a), (b), (b'), (c): DOP853, saved every 1 ms."""
    shared = dict(nrfe=nrfe_plant, t_end=t_end, method="dop853", save_dt=1e-3, rtol=1e-8, atol=1e-9,
                  start="locked", backend=backend)
    plant_b = inverse.parent / PD_INVERSE.name
    runs = [gpmegen.simulate(PD, feedforward=str(paths[0]), **shared),
            gpmegen.simulate(plant_b, feedforward=str(inverse), params=start_of(inverse), **shared),
            gpmegen.simulate(PD, feedforward=str(paths[1]), **shared),
            gpmegen.simulate(CT, **shared)]
    for label, run in zip(LABELS, runs):
        if run.status != "complete":
            raise SystemExit(f"{label}: {run.status}")
    return runs


def markdown(found: list) -> str:
    """One row per controller: E's path error, the constraints' max |Φ|, the residual vibration
    and the peak inputs."""
    head = ("| controller | path error of E max / RMS (mm) | max abs(turn) (rad) | max abs(circle) (m²) | "
            "max abs(height) (m) | residual vibration p-p / RMS (mm) | peak abs(u): θ1 (N·m), ψ2 (N·m), x3 (N) |")
    lines = [head, "|" + "---|" * 7]
    for m in found:
        peaks = ", ".join(f"{m.effort[c][0]:.3g}" for c in ("theta1", "psi2", "x3"))
        lines.append(f"| {m.name} | {1e3 * m.path[0]:.3g} / {1e3 * m.path[1]:.3g} | "
                     f"{m.constraints['turn'][0]:.3g} | {m.constraints['circle'][0]:.3g} | "
                     f"{m.constraints['height'][0]:.3g} | {1e3 * m.vibration[0]:.3g} / {1e3 * m.vibration[1]:.3g} | "
                     f"{peaks} |")
    return "\n".join(lines) + "\n"


def study(out: Path, nrfe_model: int = 3, nrfe_plant: int = 8, t_end: float = T_END, after: float = AFTER,
          backend=None) -> list:
    """Run the study into ``out``; returns the four controllers' metrics, (a), (b), (b'), (c)."""
    out.mkdir(parents=True, exist_ok=True)
    with warnings.catch_warnings():
        # the motion's references switch where the smooth step starts and ends: C³ there by design
        warnings.filterwarnings("ignore", message=".*its law switches where.*")
        paths = feedforwards(out, nrfe_model, t_end, backend)
        runs = controlled(paths, inversion(out, nrfe_model, t_end), nrfe_plant, t_end, backend)
        path = tracking.reference_of(str(paths[0]), [r.arrays for r in runs])
        constrained = tracking.reference_of(gpmegen.load_model_file(MOTION, nrfe=nrfe_plant), [runs[0].arrays],
                                            backend or "c")
    found = []
    for label, run in zip(LABELS, runs):
        m = tracking.measure(run.arrays, path, label, after)
        phi = tracking.constraint_values(run.arrays, constrained.model)
        for i, c in enumerate(constrained.model.constraint_names):
            m.constraints[c] = (float(abs(phi[:, i]).max()), tracking.rms(m.t, phi[:, i]))
        found.append(m)
    tracking.write_csv(found, out / "metrics.csv")
    (out / "metrics.md").write_text(markdown(found), encoding="utf-8")
    from gpmegen.analysis.figures import tracking_plots
    tracking_plots.path_error([r.arrays for r in runs], found, "the rigid arm's realization of E's path", out,
                              labels=list(LABELS))
    return found


def main(argv=None) -> list:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, default=Path("results"), help="folder for the table and figure")
    parser.add_argument("--nrfe-model", type=int, default=3, help="the flexible model's n_rfe (default 3)")
    parser.add_argument("--nrfe-plant", type=int, default=8, help="the plant's n_rfe (default 8)")
    parser.add_argument("--t-end", type=float, default=T_END, help=f"s (default {T_END:g})")
    parser.add_argument("--backend", choices=("numpy", "c"), default=None, help="default: c where a compiler is")
    args = parser.parse_args(argv)
    found = study(args.out, args.nrfe_model, args.nrfe_plant, args.t_end, backend=args.backend)
    print(tracking.table(found))
    print(markdown(found))
    print(f"wrote {args.out / 'metrics.csv'}, {args.out / 'metrics.md'}, {args.out / 'tracking.png'}")
    return found


if __name__ == "__main__":
    main()
