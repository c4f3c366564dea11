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
  t = 0.1 s are extrapolated to n_rfe → ∞ (gpmegen.analysis.post.richardson, the engine of
  gpmegen.analysis.discretization.extrapolate), with the observed order.
- the test set's model differs from RFEM's (the differences its values cannot remove): two
  transverse modes (pinned-pinned sines in the chord frame) against RFEM's every mode up to its
  resolution; a linear stiffness K q without geometric stiffening (the rod's axial force does not
  change its bending stiffness; its option ipar(1) = 1 adds a quadratic term), where RFEM's chain
  of rigid elements turned by finite angles carries it; the rotary inertia of the section only in
  the rigid rod's J2; and an axial mass matrix 15 times the consistent mass of its quadratic
  axial shape functions (entries 8, 1, 2 of ρAL where ∫NᵢNⱼ gives 8/15, 1/15, 2/15), which lowers
  its axial frequency by √15 (the quasi-static stretch is unchanged: its load uses ∫N ρA).
- Exudyn (--exudyn): the rod as ANCF Cable2D elements (geometrically exact, extensible),
  started from the test set's initial values on its nodes, generalized-α at the four-bar
  benchmark's settings; a third model, for what the two geometrically exact ones share.
- the test set's model itself, written here from its equations (galerkin_run; it reproduces the
  published values at 0.1 s to 7 digits and more): gpmegen's midpoint deflection against it over
  the whole 0.1 s, and what the test set's own quadratic stiffness option changes.

    .venv/bin/python benchmarks/slider_crank.py
    .venv/bin/python benchmarks/slider_crank.py --nrfe 4 8 --rtol 1e-8
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
    from gpmegen.analysis.run.cases import FileCase

    class TestSetStart(FileCase):
        def initial(self, params):
            return start_values(self.nrfe)

    return TestSetStart(str(MODEL), nrfe)


def rod_geometry(names, q, nrfe: int, length: float = L2, crank: float = L1) -> dict:
    """A planar flexible link's base B on the crank's tip, its tip R and its material midpoint M
    (m) from the coordinates ``q`` named ``names`` (the link labelled "2", from the crank's tip at
    θ2 against the crank θ1): its rfes laid from B, each sde first stretching along the rfe before
    it (when the link stretches), then turning."""
    value = dict(zip(names, q))
    angle = value["theta1"] + value["theta2"]
    pin = np.array([crank * math.cos(value["theta1"]), crank * math.sin(value["theta1"])])
    delta = length / (nrfe - 1)
    lengths = [delta / 2] + [delta] * (nrfe - 2) + [delta / 2]
    point, done, middle = pin.copy(), 0.0, None
    for k, piece in enumerate(lengths):
        if k:
            point = point + value.get(f"u2_{k}", 0.0) * np.array([math.cos(angle), math.sin(angle)])
            angle += value[f"psi2_{k}"]
        direction = np.array([math.cos(angle), math.sin(angle)])
        if middle is None and done + piece >= length / 2 - 1e-12:
            middle = point + (length / 2 - done) * direction
        point, done = point + piece * direction, done + piece
    return {"B": pin, "R": point, "M": middle}


def midpoint_deflection(base, tip, middle) -> float:
    """The midpoint's transverse deflection from the chord base → tip (m), positive on the chord's
    left (the test set's q1)."""
    chord = tip - base
    normal = np.array([-chord[1], chord[0]]) / float(np.hypot(*chord))
    return float(normal @ (middle - base))


def rod_outputs(names, q, nrfe: int) -> dict:
    """The compared quantities of one state: the chord's angle φ2, the slider's x3, the
    midpoint's transverse deflection from the chord (positive on the chord's left, the test
    set's q1) and the chord's stretch (the test set's q4)."""
    g = rod_geometry(names, q, nrfe)
    chord = g["R"] - g["B"]
    return {"phi2": math.atan2(chord[1], chord[0]), "x3": float(g["R"][0]),
            "midpoint deflection": midpoint_deflection(g["B"], g["R"], g["M"]),
            "tip stretch": float(np.hypot(*chord)) - L2}


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
    from gpmegen.analysis.run import runs
    from gpmegen.analysis.run.runspec import RunSpec

    run = runs.run(case(nrfe), RunSpec(start="none", t_end=T_END, dt=save_dt, save_every=1, method="radau",
                                       save_dt=save_dt, rtol=rtol, atol=atol), "c", {}, None, lambda message: None)
    res = run.results
    names = [str(c) for c in res["coordinates"]]
    series = [outputs_at(names, q, qd, nrfe) for q, qd in zip(res["q"], res["qd"])]
    over_time = {key: np.array([s[key] for s in series]) for key in series[0]}
    return res, over_time, run.wall


def extrapolated(nrfe, finals) -> dict:
    """Each compared quantity at t = 0.1 s extrapolated across the levels (n_sde = n_rfe - 1):
    name -> the richardson Estimate."""
    from gpmegen.analysis.post import richardson

    n_sde = np.array(nrfe) - 1
    return {key: richardson.richardson(n_sde, np.array([f[key] for f in finals])) for key in COMPARED}


# The test set's rod model (Simeon's), written here from its equations for the comparison over
# time and for the effect of its options: rigid coordinates p = (φ1, φ2, x3), elastic q = (q1, q2:
# the transverse sines; q3, q4: the quadratic axial field's midpoint and tip), the matrices of its
# Galerkin rod (per unit ρAL, ρbhL... as the test set scales them) and its constraints: the rod's
# tip (L2 + q4 along φ2) on the x0 axis at x3, φ1 = ωt.
RHO, E, BH = 7870.0, 2.0e11, 0.008
M2, M3, J1, J2 = RHO * BH * BH * L2, 0.075552, 0.002727, 0.0045339259


def _galerkin_matrices():
    """The test set's rod matrices: mass MQ, stiffness KQ, gyroscopic BQ and the vectors c1, c2,
    c12, c21 (its integrals of the shape functions over the rod)."""
    pi, facm, fack, facb = math.pi, RHO * BH * BH * L2, E * BH * BH / L2, BH * BH * L2
    mq = facm * np.array([[0.5, 0, 0, 0], [0, 0.5, 0, 0], [0, 0, 8.0, 1.0], [0, 0, 1.0, 2.0]])
    kq = np.zeros((4, 4))
    kq[0, 0] = fack * pi**4 / 24 * (BH / L2) ** 2
    kq[1, 1] = fack * pi**4 * 2 / 3 * (BH / L2) ** 2
    kq[2:, 2:] = fack * np.array([[16 / 3, -8 / 3], [-8 / 3, 7 / 3]])
    bq = np.zeros((4, 4))
    bq[0, 2], bq[0, 3], bq[1, 3] = -facb * 16 / pi**3, facb * (8 / pi**3 - 1 / pi), facb * 0.5 / pi
    bq[2:, :2] = -bq[:2, 2:].T
    c1 = facb * np.array([0, 0, 2 / 3, 1 / 6])
    c2 = facb * np.array([2 / pi, 0, 0, 0])
    c12 = L2 * facb * np.array([0, 0, 1 / 3, 1 / 6])
    c21 = L2 * facb * np.array([1 / pi, -0.5 / pi, 0, 0])
    return mq, kq, bq, c1, c2, c12, c21


def _galerkin_rates(y, matrices, nonlinear):
    """The test set's equations of motion (index 1: constraints at the acceleration level) at the
    state ``y`` = (p, q, ṗ, q̇): its time derivative. ``nonlinear``: the test set's option of a
    quadratic stiffness term (ipar(1) = 1), its geometric coupling of bending and stretch."""
    mq, kq, bq, c1, c2, c12, c21 = matrices
    p1, p2, _ = y[:3]
    q, v1, v2, qd = y[3:7], y[7], y[8], y[10:14]
    s12, c12a = math.sin(p1 - p2), math.cos(p1 - p2)
    m = np.zeros((7, 7))
    m[0, 0] = J1 + M2 * L1**2
    m[0, 1] = 0.5 * L1 * L2 * M2 * c12a + RHO * L1 * (s12 * (c2 @ q) + c12a * (c1 @ q))
    m[1, 1] = J2 + q @ mq @ q + 2 * RHO * (c12 @ q)
    m[2, 2] = M3
    m[0, 3:] = RHO * L1 * (-s12 * c1 + c12a * c2)
    m[1, 3:] = RHO * c21 + RHO * (q @ bq)
    m[3:, 3:] = mq
    m = np.triu(m) + np.triu(m, 1).T
    f = np.zeros(7)
    f[0] = (-0.5 * L1 * L2 * M2 * v2**2 * s12 + RHO * L1 * v2**2 * (-s12 * (c1 @ q) + c12a * (c2 @ q))
            - 2 * RHO * L1 * v2 * (c12a * (c1 @ qd) + s12 * (c2 @ qd)))
    f[1] = (0.5 * L1 * L2 * M2 * v1**2 * s12 + RHO * L1 * v1**2 * (s12 * (c1 @ q) - c12a * (c2 @ q))
            - 2 * RHO * v2 * (c12 @ qd) - 2 * v2 * (qd @ mq @ q) - RHO * (qd @ bq @ qd))
    f[3:] = (v2**2 * (mq @ q) + RHO * (v2**2 * c12 + L1 * v1**2 * (c12a * c1 + s12 * c2) + 2 * v2 * (bq @ qd))
             - kq @ q)
    if nonlinear:
        k, b = 0.5 * E * BH * BH / L2**2 * math.pi**2, 80 / (9 * math.pi**2)
        f[3] -= k * (q[0] * q[3] - b * q[1] * (-4 * q[2] + 2 * q[3]))
        f[4] -= k * (4 * q[1] * q[3] - b * q[0] * (-4 * q[2] + 2 * q[3]))
        f[5] -= k * 4 * b * q[0] * q[1]
        f[6] -= k * (0.5 * q[0] ** 2 + 2 * q[1] ** 2 - 2 * b * q[0] * q[1])
    sp1, cp1, sp2, cp2, arm = math.sin(p1), math.cos(p1), math.sin(p2), math.cos(p2), L2 + q[3]
    g = np.zeros((3, 7))
    g[0, :2], g[0, 6] = (L1 * cp1, arm * cp2), sp2
    g[1, :3], g[1, 6] = (L1 * sp1, arm * sp2, 1.0), -cp2
    g[2, 0] = 1.0
    extra = np.array([-L1 * sp1 * v1**2 - arm * sp2 * v2**2 + 2 * v2 * cp2 * qd[3],
                      L1 * cp1 * v1**2 + arm * cp2 * v2**2 + 2 * v2 * sp2 * qd[3], 0.0])
    kkt = np.block([[m, g.T], [g, np.zeros((3, 3))]])
    w = np.linalg.solve(kkt, np.concatenate([f, -extra]))[:7]
    return np.concatenate([y[7:], w])


def galerkin_run(t, nonlinear=False):
    """The test set's model from its initial values (DOP853, rtol 1e-11): the compared
    quantities at the instants ``t`` (the midpoint deflection is q1, the tip stretch q4)."""
    from scipy.integrate import solve_ivp

    matrices = _galerkin_matrices()
    y0 = np.concatenate([[0.0, INITIAL["phi2"], INITIAL["x3"]], INITIAL["q"],
                         [OMEGA, INITIAL["phi2_rate"], INITIAL["x3_rate"]], INITIAL["q_rate"]])
    sol = solve_ivp(lambda _, y: _galerkin_rates(y, matrices, nonlinear), (0.0, float(t[-1])), y0, t_eval=t,
                    method="DOP853", rtol=1e-11, atol=1e-14)
    y = sol.y
    return {"phi2": y[1], "x3": y[2], "midpoint deflection": y[3], "tip stretch": y[6],
            "phi2 rate": y[8], "x3 rate": y[9], "midpoint deflection rate": y[10]}


def exudyn_run(elements: int, step: float, t, atol: float = 1e-6):
    """The slider-crank in Exudyn, started from the test set's initial values: the rod as
    ``elements`` ANCF Cable2D elements (E·A, E·I of the section, ρA; no rotary inertia), the crank
    rigid with its angle held to ωt (benchmarks/four_bar_flexible.py), the slider a mass point
    joined to the rod's last node and held on the x0 axis; generalized-α at ``step`` with the
    four-bar's settings. The compared quantities (positions only) at the instants ``t`` and the
    wall seconds of its solve; None when its Newton iteration gave up."""
    import exudyn
    from exudyn import utilities as xu
    from exudyn.beams import GenerateBeamElementsAlongLine
    from four_bar_flexible import exudyn_crank, exudyn_solve

    mbs = exudyn.SystemContainer().AddSystem()
    ground = mbs.AddObject(xu.ObjectGround())
    crank = exudyn_crank(mbs, ground, OMEGA, L1)
    cable = xu.ObjectANCFCable2D(massPerLength=RHO * BH * BH, bendingStiffness=E * BH**4 / 12,
                                 axialStiffness=E * BH * BH)
    nodes = GenerateBeamElementsAlongLine(mbs, [L1, 0, 0], [L1 + L2, 0, 0], elements, cable)["nodes"]
    # the test set's start on the nodes: the axial field as displacement and slope, the rigid motion
    # (the crank pin's velocity, the chord turning at φ̇2) with the transverse and axial rate fields
    mid, tip = INITIAL["q"][2:]
    rate2, rates = INITIAL["phi2_rate"], INITIAL["q_rate"]
    h = 1e-7
    for k, node in enumerate(nodes):
        x = L2 * k / elements
        u, du = axial(x, mid, tip), (axial(x + h, mid, tip) - axial(x - h, mid, tip)) / (2 * h)
        u_rate = axial(x, *rates[2:])
        du_rate = (axial(x + h, *rates[2:]) - axial(x - h, *rates[2:])) / (2 * h)
        w_rate = float(transverse(x, rates[:2]))
        dw_rate = float((transverse(x + h, rates[:2]) - transverse(x - h, rates[:2])) / (2 * h))
        mbs.SetNodeParameter(node, "initialCoordinates", [float(u), 0.0, float(du), 0.0])
        mbs.SetNodeParameter(node, "initialVelocities",
                             [float(u_rate), OMEGA * L1 + rate2 * (x + float(u)) + w_rate,
                              float(du_rate), dw_rate + rate2 * (1 + float(du))])
    mbs.AddObject(xu.RevoluteJoint2D(markerNumbers=[
        mbs.AddMarker(xu.MarkerBodyPosition(bodyNumber=crank, localPosition=[L1, 0, 0])),
        mbs.AddMarker(xu.MarkerNodePosition(nodeNumber=nodes[0]))]))
    slider = mbs.AddNode(xu.NodePoint2D(referenceCoordinates=[L1 + L2, 0], initialCoordinates=[tip, 0],
                                        initialVelocities=[INITIAL["x3_rate"], 0]))
    mbs.AddObject(xu.MassPoint2D(mass=M3, nodeNumber=slider))
    mbs.AddObject(xu.RevoluteJoint2D(markerNumbers=[mbs.AddMarker(xu.MarkerNodePosition(nodeNumber=nodes[-1])),
                                                    mbs.AddMarker(xu.MarkerNodePosition(nodeNumber=slider))]))
    fixed = mbs.AddMarker(xu.MarkerNodeCoordinate(nodeNumber=mbs.AddNode(xu.NodePointGround()), coordinate=0))
    mbs.AddObject(xu.CoordinateConstraint(markerNumbers=[
        fixed, mbs.AddMarker(xu.MarkerNodeCoordinate(nodeNumber=slider, coordinate=1))]))
    sensors = [mbs.AddSensor(xu.SensorNode(nodeNumber=nodes[k], storeInternal=True,
                                           outputVariableType=exudyn.OutputVariableType.Position))
               for k in (0, elements // 2, elements)]
    wall = exudyn_solve(mbs, step, float(t[-1]), atol)
    if wall is None:
        return None, float("nan")
    base, middle, end = (mbs.GetSensorStoredData(sensor) for sensor in sensors)
    chord = end[:, 1:3] - base[:, 1:3]
    values = {"phi2": np.arctan2(chord[:, 1], chord[:, 0]), "x3": end[:, 1],
              "midpoint deflection": np.array([midpoint_deflection(b[1:3], e[1:3], m[1:3])
                                               for b, m, e in zip(base, middle, end)]),
              "tip stretch": np.hypot(chord[:, 0], chord[:, 1]) - L2}
    return {key: np.interp(t, base[:, 0], v) for key, v in values.items()}, wall


def figure(t, series, nrfe, limit, galerkin, path, exudyn=None):
    """The midpoint's transverse deflection over time: per n_rfe, gpmegen's limit, the test set's
    model (linear stiffness) and its published value at 0.1 s; below, the differences from the
    test set's model, and Exudyn's (``exudyn``: its deflection, None: none) from gpmegen's limit."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 5.6), sharex=True)
    top.plot(t * 1e3, galerkin * 1e3, "k", lw=2.5, alpha=0.4, label="IVP test set's model (2 + 2 Galerkin modes)")
    for n, s in zip(nrfe, series):
        top.plot(t * 1e3, s["midpoint deflection"] * 1e3, lw=0.8, label=f"gpmegen n_rfe = {n}")
    top.plot(t * 1e3, limit * 1e3, "k--", lw=0.9, label="gpmegen, extrapolated")
    top.plot([T_END * 1e3], [REFERENCE["q"][0] * 1e3], "kx", ms=9, mew=2, label="test set's value at 0.1 s")
    top.set_ylabel("midpoint deflection (mm)")
    top.set_title("flexible slider-crank (Simeon): the rod's midpoint from its chord")
    top.legend(fontsize=7)
    peak = np.max(np.abs(galerkin))
    for n, s in zip(nrfe, series):
        bottom.semilogy(t * 1e3, np.abs(s["midpoint deflection"] - galerkin) / peak, lw=0.7, label=f"n_rfe = {n}")
    bottom.semilogy(t * 1e3, np.abs(limit - galerkin) / peak, "k", lw=0.9, label="gpmegen limit")
    if exudyn is not None:
        bottom.semilogy(t * 1e3, np.abs(exudyn - limit) / peak, "C3:", lw=0.9,
                        label="Exudyn ANCF - gpmegen limit (not the test set)")
    bottom.set_ylim(bottom=1e-6)
    bottom.set_ylabel("|difference from test set's model| / peak")
    bottom.set_xlabel("t (ms)")
    bottom.legend(fontsize=7)
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
    parser.add_argument("--exudyn", type=int, nargs="*", default=[8, 16],
                        help="Exudyn's runs (ANCF elements, even; none: skip; needs exudyn)")
    parser.add_argument("--exudyn-step", type=float, default=5e-6, help="their step (s)")
    parser.add_argument("--figure", type=Path, default=ROOT / "figures" / "slider_crank.png")
    args = parser.parse_args(argv)
    if min(args.nrfe) < 2 or len(set(args.nrfe)) < 2:
        parser.error(f"--nrfe needs two or more different levels of at least 2 rfes, got {args.nrfe}")
    from gpmegen.analysis.post import richardson

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
    start = time.perf_counter()
    galerkin = galerkin_run(t)
    nonlinear = galerkin_run(t, nonlinear=True)
    print(f"the test set's model (written here from its equations; DOP853 rtol 1e-11, {time.perf_counter() - start:.1f}"
          f" s for both): at 0.1 s " + ", ".join(f"{key} {galerkin[key][-1]:.10g}" for key in COMPARED))
    print("  with its quadratic stiffness term (ipar(1) = 1, from the same start): "
          + ", ".join(f"{key} {nonlinear[key][-1]:.6g}" for key in COMPARED))
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
    over_time = richardson.richardson(np.array(nrfe) - 1, np.array([s["midpoint deflection"] for s in series]))
    limit, model = over_time.limit, galerkin["midpoint deflection"]
    peak = float(np.max(np.abs(model)))
    print(f"\nthe midpoint deflection over the 0.1 s against the test set's model (its peak {peak:.4e} m): "
          "max over t of |difference| / peak")
    for n, s in zip(nrfe, series):
        print(f"  n_rfe {n}: {np.max(np.abs(s['midpoint deflection'] - model)) / peak:.2e}")
    print(f"  gpmegen limit: {np.max(np.abs(limit - model)) / peak:.2e} (estimated error of the limit "
          f"{np.max(np.abs(over_time.limit_error)) / peak:.1e}, observed order {over_time.order:.2f}); "
          f"gpmegen's peak {np.max(np.abs(limit)):.4e} m")
    print(f"  the test set's model with its quadratic stiffness: "
          f"{np.max(np.abs(nonlinear['midpoint deflection'] - model)) / peak:.2e}")
    exudyn = None
    for elements in args.exudyn:
        values, seconds = exudyn_run(elements, args.exudyn_step, t)
        if values is None:
            print(f"Exudyn {elements} elements: its solver gave up")
            continue
        middle = exudyn = values["midpoint deflection"]
        print(f"Exudyn {elements} ANCF elements, step {args.exudyn_step:g} s ({seconds:.1f} s): at 0.1 s "
              + ", ".join(f"{key} {values[key][-1]:.7g}" for key in values)
              + f"; midpoint deflection - gpmegen's limit: at 0.1 s {middle[-1] - limit[-1]:.2e} m, over the run "
              f"at most {np.max(np.abs(middle - limit)) / peak:.2e} of the peak; - the test set's model: at most "
              f"{np.max(np.abs(middle - model)) / peak:.2e}")
    print(f"load average {load()}")
    print(f"\nfigure: {figure(t, series, nrfe, limit, model, args.figure, exudyn)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
