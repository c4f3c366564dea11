"""Simeon's flexible slider-crank: gpmegen at several n_rfe, extrapolated, against the IVP test set.

The "crank" problem of the Test Set for IVP solvers (Bari; Simeon, Math. Modelling of Systems 2,
1996): a rigid crank (0.15 m) turned at 150 rad/s, a steel connecting rod (0.30 m, 8 x 8 mm,
E = 2e11 Pa, ρ = 7870 kg/m³) that bends and stretches, a slider of 0.075552 kg; no gravity, no
damping. The test set's published solution at t = 0.1 s (its routine of reference values) gives
the rod's angle, the slider's position and the rod's four elastic coordinates: q1, q2 the
amplitudes of the transverse shapes sin(πx/L) and sin(2πx/L) in the frame of the rod's chord (q1
is the midpoint's transverse deflection), q3, q4 the axial displacements of the midpoint and of
the tip (a quadratic axial field), and their rates.

- gpmegen: examples/slider_crank_flexible.toml (sdes that bend and stretch) at several n_rfe,
  Radau IIA in C, started from the test set's initial values: the rod straight, its transverse
  velocity field q̇1 sin(πx/L) + q̇2 sin(2πx/L) and its axial field (q3, q4 and their rates) put
  onto the sdes (the kink rates of the polygon through the sdes, the stretch of each sde's
  segment); the rod's angle and the slider's motion are solved from the closure. Its values at
  t = 0.1 s are extrapolated to n_rfe → ∞ (gpmegen.analysis.richardson, the engine of
  gpmegen.analysis.extrapolate), with the observed order.
- the test set's model differs from RFEM's (the differences its values cannot remove): two
  transverse modes (pinned-pinned sines in the chord frame) against RFEM's every mode up to its
  resolution; a linear stiffness K q without geometric stiffening (the rod's axial force does not
  change its bending stiffness; its option ipar(1) = 1 adds a quadratic term), where RFEM's chain
  of rigid elements turned by finite angles carries it; the rotary inertia of the section only in
  the rigid rod's J2; and an axial mass matrix 15 times the consistent mass of its quadratic
  axial shape functions (entries 8, 1, 2 of ρAL where ∫NᵢNⱼ gives 8/15, 1/15, 2/15), which lowers
  its axial frequency by √15 (the quasi-static stretch is unchanged: its load uses ∫N ρA).
- Exudyn (optional, --exudyn): the same mechanism with the rod as ANCF Cable2D elements at its
  tuned settings (benchmarks/four_bar_flexible.py), for the limit of a third model.

    .venv/bin/python benchmarks/slider_crank.py
    .venv/bin/python benchmarks/slider_crank.py --nrfe 4 8 16 --exudyn 16
"""

from __future__ import annotations

import argparse
import math
import os
import sys
import time
from pathlib import Path

import numpy as np

ROOT = Path(__file__).resolve().parents[1]
MODEL = ROOT / "examples" / "slider_crank_flexible.toml"
L1, L2, OMEGA, T_END = 0.15, 0.30, 150.0, 0.1

#: The test set's consistent initial values (its routine init, "close to smooth motion"):
#: φ2, x3 and the elastic coordinates q1..q4 with their rates (φ1 = 0, φ̇1 = 150 rad/s).
INITIAL = {"phi2": 0.0, "x3": 0.450016933, "q": (0.0, 0.0, 0.103339863e-04, 0.169327969e-04),
           "phi2_rate": -0.749957670e+02, "x3_rate": -0.268938672e-05,
           "q_rate": (0.444896105, 0.463434311e-02, -0.178591076e-05, -0.268938672e-05)}

#: The test set's reference solution at t = 0.1 s (its routine solut).
REFERENCE = {"phi2": -3.311734987910881e-01, "x3": 1.697373326718410e-01,
             "q": (1.893192460247178e-04, 2.375751865617931e-05, -5.323907988763734e-06, -8.363283141616840e-06),
             "phi2_rate": 6.025346682645789e+01, "x3_rate": -8.753116989887888e+00,
             "q_rate": (-3.005536801092212e-02, -5.500488291932075e-03, 4.978243404809343e-04, 1.104933470696396e-03)}

#: What is compared at t = 0.1 s: name -> (the test set's value, unit).
COMPARED = {"phi2": (REFERENCE["phi2"], "rad"), "x3": (REFERENCE["x3"], "m"),
            "midpoint deflection": (REFERENCE["q"][0], "m"), "tip stretch": (REFERENCE["q"][3], "m"),
            "phi2 rate": (REFERENCE["phi2_rate"], "rad/s"), "x3 rate": (REFERENCE["x3_rate"], "m/s"),
            "midpoint deflection rate": (REFERENCE["q_rate"][0], "m/s")}


def sde_positions(nrfe: int) -> np.ndarray:
    """The sdes' places along the undeformed rod (m): the modified RFEM's rfes are Δ/2, Δ, …, Δ/2
    long with Δ = L/(n_rfe - 1)."""
    delta = L2 / (nrfe - 1)
    return delta / 2 + delta * np.arange(nrfe - 1)


def transverse(x, amplitudes):
    """The test set's transverse field Σ qᵢ sin(iπx/L) at ``x`` (its two modes)."""
    return sum(a * np.sin((i + 1) * math.pi * np.asarray(x) / L2) for i, a in enumerate(amplitudes))


def axial(x, mid, tip):
    """The test set's quadratic axial field through u(0) = 0, u(L/2) = ``mid``, u(L) = ``tip``."""
    xi = np.asarray(x) / L2
    return mid * 4 * xi * (1 - xi) + tip * xi * (2 * xi - 1)


def kinks(nrfe: int, amplitudes) -> np.ndarray:
    """The sde rotations of the polygon through the rod's ends and its sdes that carries the
    transverse field (in the chord frame, 0 at both ends): the change of slope at each sde."""
    x = np.concatenate([[0.0], sde_positions(nrfe), [L2]])
    slopes = np.diff(transverse(x, amplitudes)) / np.diff(x)
    return np.diff(slopes)


def stretches(nrfe: int, mid: float, tip: float) -> np.ndarray:
    """Each sde's stretch: the axial field's growth over its segment [(k - 1)Δ, kΔ]."""
    edges = np.linspace(0.0, L2, nrfe)
    return np.diff(axial(edges, mid, tip))


def start_values(nrfe: int) -> tuple[dict, dict]:
    """The test set's initial state on gpmegen's coordinates at ``nrfe``: the rod straight, its
    stretch, the sdes' rates; the dependent coordinates (θ2, x3) are solved from the closure."""
    q3, q4 = INITIAL["q"][2:]
    rates = INITIAL["q_rate"]
    u, u_rate = stretches(nrfe, q3, q4), stretches(nrfe, rates[2], rates[3])
    psi_rate = kinks(nrfe, rates[:2])
    q = {"theta1": 0.0, "theta2": 0.0, "x3": L1 + L2 + float(np.sum(u))}
    qd = {}
    for k in range(nrfe - 1):
        q[f"u2_{k + 1}"] = float(u[k])
        qd[f"u2_{k + 1}"] = float(u_rate[k])
        qd[f"psi2_{k + 1}"] = float(psi_rate[k])
    return q, qd


def case(nrfe: int):
    """The model file at ``nrfe`` started from the test set's initial values."""
    from gpmegen.analysis.cases import FileCase

    class TestSetStart(FileCase):
        def initial(self, params):
            return start_values(self.nrfe)

    return TestSetStart(str(MODEL), nrfe)


def rod_geometry(names, q, nrfe: int) -> dict:
    """The rod's crank pin B, tip R and material midpoint M (planar, m) from the coordinates
    ``q`` named ``names``: the rfes laid from B, each sde first stretching along the rfe before
    it, then turning."""
    value = dict(zip(names, q))
    angle = value["theta1"] + value["theta2"]
    pin = np.array([L1 * math.cos(value["theta1"]), L1 * math.sin(value["theta1"])])
    lengths = [L2 / (nrfe - 1) / 2] + [L2 / (nrfe - 1)] * (nrfe - 2) + [L2 / (nrfe - 1) / 2]
    point, done, middle = pin.copy(), 0.0, None
    for k, length in enumerate(lengths):
        if k:
            point = point + value[f"u2_{k}"] * np.array([math.cos(angle), math.sin(angle)])
            angle += value[f"psi2_{k}"]
        direction = np.array([math.cos(angle), math.sin(angle)])
        if middle is None and done + length >= L2 / 2 - 1e-12:
            middle = point + (L2 / 2 - done) * direction
        point, done = point + length * direction, done + length
    return {"B": pin, "R": point, "M": middle}


def rod_outputs(names, q, nrfe: int) -> dict:
    """The compared quantities of one state: the chord's angle φ2, the slider's x3, the
    midpoint's transverse deflection from the chord (positive on the chord's left, the test
    set's q1) and the chord's stretch (the test set's q4)."""
    g = rod_geometry(names, q, nrfe)
    chord = g["R"] - g["B"]
    length = float(np.hypot(*chord))
    normal = np.array([-chord[1], chord[0]]) / length
    return {"phi2": math.atan2(chord[1], chord[0]), "x3": float(g["R"][0]),
            "midpoint deflection": float(normal @ (g["M"] - g["B"])), "tip stretch": length - L2}


def outputs_at(names, q, qd, nrfe: int) -> dict:
    """:func:`rod_outputs` and their rates (central differences along q̇, a step of 1e-8 s)."""
    h = 1e-8
    now = rod_outputs(names, q, nrfe)
    ahead, behind = rod_outputs(names, q + h * qd, nrfe), rod_outputs(names, q - h * qd, nrfe)
    for key in ("phi2", "x3", "midpoint deflection"):
        now[f"{key} rate"] = (ahead[key] - behind[key]) / (2 * h)
    return now


def gpmegen_level(nrfe: int, rtol: float, atol: float, save_dt: float):
    """One level's run with Radau IIA in C to ``T_END``: (results, the outputs over time, wall s)."""
    from gpmegen.analysis import runs

    run = runs.run(case(nrfe), "none", T_END, save_dt, 1, "radau", "c", {}, None, lambda message: None,
                   save_dt=save_dt, rtol=rtol, atol=atol)
    res = run.results
    names = [str(c) for c in res["coordinates"]]
    series = [outputs_at(names, q, qd, nrfe) for q, qd in zip(res["q"], res["qd"])]
    over_time = {key: np.array([s[key] for s in series]) for key in series[0]}
    return res, over_time, run.wall


def extrapolated(nrfe, finals) -> dict:
    """Each compared quantity at t = 0.1 s extrapolated across the levels (n_sde = n_rfe - 1):
    name -> the richardson Estimate."""
    from gpmegen.analysis import richardson

    n_sde = np.array(nrfe) - 1
    return {key: richardson.richardson(n_sde, np.array([f[key] for f in finals])) for key in COMPARED}


def figure(t, series, nrfe, path):
    """The midpoint's transverse deflection over time per n_rfe, the test set's value at 0.1 s."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 3.6))
    for n, s in zip(nrfe, series):
        ax.plot(t * 1e3, s["midpoint deflection"] * 1e3, lw=0.9, label=f"gpmegen n_rfe = {n}")
    ax.plot([T_END * 1e3], [REFERENCE["q"][0] * 1e3], "kx", ms=9, mew=2, label="IVP test set at 0.1 s")
    ax.set_xlabel("t (ms)")
    ax.set_ylabel("midpoint deflection (mm)")
    ax.set_title("flexible slider-crank (Simeon): the rod's midpoint from its chord")
    ax.legend(fontsize=7)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=110)
    return path


def load() -> str:
    """The load averages over 1, 5 and 15 minutes."""
    return " ".join(f"{x:.2f}" for x in os.getloadavg())


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--nrfe", type=int, nargs="+", default=[4, 8, 16], help="gpmegen's levels (≥ 2 each)")
    parser.add_argument("--rtol", type=float, default=1e-9, help="Radau's relative tolerance")
    parser.add_argument("--atol", type=float, default=1e-11, help="Radau's absolute tolerance")
    parser.add_argument("--save-dt", type=float, default=2e-4, help="saved interval (s), divides 0.1 s")
    parser.add_argument("--exudyn", type=int, nargs="*", default=[],
                        help="also Exudyn's ANCF rod with these numbers of elements (needs exudyn)")
    parser.add_argument("--figure", type=Path, default=ROOT / "figures" / "slider_crank.png")
    args = parser.parse_args(argv)
    if min(args.nrfe) < 2 or len(set(args.nrfe)) < 2:
        parser.error(f"--nrfe needs two or more different levels of at least 2 rfes, got {args.nrfe}")
    nrfe = sorted(set(args.nrfe))
    print(f"load average {load()} on {os.cpu_count()} cores")
    finals, series, t = [], [], None
    for n in nrfe:
        start = time.perf_counter()
        res, over_time, wall = gpmegen_level(n, args.rtol, args.atol, args.save_dt)
        if str(res["status"]) != "complete" or abs(res["t"][-1] - T_END) > 1e-12:
            print(f"n_rfe {n}: the run did not finish ({res['status']}); try other tolerances")
            return 1
        finals.append({key: float(v[-1]) for key, v in over_time.items()})
        series.append(over_time)
        t = res["t"]
        print(f"n_rfe {n:3d} ({res['q'].shape[1]} dof): run {wall:.2f} s (with build or load "
              f"{time.perf_counter() - start:.1f} s); closure held to {np.max(np.abs(res['phi'])):.1e}")
    estimates = extrapolated(nrfe, finals)
    exudyn_values = {}
    if args.exudyn:
        from four_bar_flexible import exudyn_slider_crank

        for elements in args.exudyn:
            values, seconds = exudyn_slider_crank(elements, INITIAL)
            exudyn_values[elements] = (values, seconds)
            print(f"Exudyn {elements} ANCF elements: {seconds:.2f} s")
    print(f"\nat t = {T_END} s (Radau IIA rtol {args.rtol:g} atol {args.atol:g}); difference: gpmegen - test set")
    header = "| quantity | test set | " + " | ".join(f"n_rfe {n}" for n in nrfe) + \
        " | extrapolated | its estimated error | observed order | limit - test set | (limit - test set) / test set |"
    print(header)
    print("|" + "---|" * (header.count("|") - 1))
    for key, (reference, unit) in COMPARED.items():
        est = estimates[key]
        cells = " | ".join(f"{f[key]:.6g}" for f in finals)
        print(f"| {key} [{unit}] | {reference:.6g} | {cells} | {float(est.limit):.6g} | "
              f"{float(est.limit_error):.1e} | {est.order:.2f} | {float(est.limit) - reference:.2e} | "
              f"{(float(est.limit) - reference) / abs(reference):+.2%} |")
    for elements, (values, _) in exudyn_values.items():
        print(f"| Exudyn {elements} elements | " + " | ".join(f"{key} {values[key]:.6g}" for key in values) + " |")
    print(f"load average {load()}")
    print(f"\nfigure: {figure(t, series, nrfe, args.figure)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
