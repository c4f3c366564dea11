"""Natural frequencies about an equilibrium, and the convergence of the RFEM arm to beam theory.

- :func:`clamped_arm_model`: the reference arm alone, clamped at its root, horizontal;
- :func:`natural_frequencies`: linearized free vibration ``K φ = ω² M φ`` on chosen coordinates;
- :func:`classify`: vertical bending / horizontal bending / torsion by the dominant coordinates;
- :func:`convergence_table`: static tip deflection and first frequencies of the clamped arm
  against Euler–Bernoulli / Saint-Venant values (:mod:`gpmegen.analysis.beam`) for several
  ``n_rfe``, with the observed order of convergence.
"""

from __future__ import annotations

import math
import time
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
import scipy.linalg

from ..errors import ModelError
from ..model.chain import Body, FlexibleLink, Model, Point, RectangularSection
from ..model.reference import PARAMETERS
from ..model.shapes import solid_cylinder
from ..runtime import statics
from . import beam

ARM_PARAMETERS = ("g", "L2", "b2", "t2", "rho2", "E2", "G2", "J2", "d2")
SLIDER_PARAMETERS = ("m3", "L3", "R3")

# Coordinate families by name prefix: psi (about z) bends the arm in its vertical plane, theta
# (about y) in the horizontal plane, phi (about x) twists it. Joints follow the same axes
# (theta1 turns the column about y: horizontal; psi2 lifts the arm: vertical).
FAMILIES = (("psi", "vertical"), ("theta", "horizontal"), ("phi", "torsion"))
KINDS = ("vertical", "horizontal", "torsion")


def clamped_arm_model(nrfe: int, with_slider: bool = False) -> Model:
    """The reference arm alone, clamped at its root and horizontal along x0, gravity
    ``(0, -g, 0)``; ``with_slider`` adds the slider as a rigid body fixed at the arm's tip (at
    ``x3 = 0``). Coordinates ``psi2_r, theta2_r, phi2_r`` (r = 1..nrfe-1); points ``tip`` (the
    arm's tip) and, with the slider, ``E``. Parameters and their names as in the reference."""
    if isinstance(nrfe, bool) or not isinstance(nrfe, int) or nrfe < 2:
        raise ModelError(f"the clamped arm needs nrfe ≥ 2 (nrfe = 1 has no coordinate), got {nrfe!r}")
    names = ARM_PARAMETERS + (SLIDER_PARAMETERS if with_slider else ())
    parameters = tuple(p for p in PARAMETERS if p.name in names)
    P = {p.name: p.symbol for p in parameters}
    chain = [
        FlexibleLink(
            label="2",
            length=P["L2"],
            section=RectangularSection(P["b2"], P["t2"]),
            density=P["rho2"],
            young_modulus=P["E2"],
            shear_modulus=P["G2"],
            torsion_constant=P["J2"],
            n_rfe=nrfe,
            damping=(P["d2"], P["d2"], P["d2"]),
        ),
        Point("tip", (0, 0, 0)),
    ]
    if with_slider:
        chain += [Body("slider", solid_cylinder(P["m3"], P["R3"], P["L3"], "x")), Point("E", (P["L3"], 0, 0))]
    return Model(
        name=f"clamped_arm{'_slider' if with_slider else ''}_nrfe{nrfe}",
        parameters=parameters,
        chain=tuple(chain),
        gravity=(0, -P["g"], 0),
        description="the reference arm clamped at its root" + (", slider at its tip" if with_slider else ""),
    )


def load_clamped_arm(nrfe: int, with_slider: bool = False, directory=None, params: dict | None = None):
    """The generated clamped arm (:func:`clamped_arm_model`), built into ``directory`` when
    missing (default: gpmegen's generated folder)."""
    from .. import load

    return load(model=clamped_arm_model(nrfe, with_slider), directory=directory, params=params)


# --- linearized free vibration -----------------------------------------------------------------

@dataclass
class Modes:
    """Natural modes about an equilibrium, lowest first.

    ``frequencies`` (k,) Hz; ``shapes`` (n_dof, k), zero on the held coordinates, each column
    normalized to unit modal mass (``φᵀ M φ = 1``); ``free`` the indices of the coordinates
    that move; ``coordinates`` the model's coordinate names; ``kinds`` from :func:`classify`."""

    frequencies: np.ndarray
    shapes: np.ndarray
    free: np.ndarray
    coordinates: tuple
    kinds: list = field(default_factory=list)

    def first(self, kind: str) -> float:
        """Lowest frequency (Hz) of a mode of ``kind`` ('vertical', 'horizontal', 'torsion')."""
        for f, k in zip(self.frequencies, self.kinds):
            if k == kind:
                return float(f)
        raise ValueError(f"no {kind} mode among the {len(self.frequencies)} modes found")


def natural_frequencies(model, q_eq, free=None) -> Modes:
    """Natural frequencies and mode shapes of ``model`` linearized about the equilibrium
    ``q_eq`` (n,): ``K = ∂(g + C q)/∂q`` and ``M`` at ``q_eq`` restricted to ``free``
    (indices; default: the coordinates with a spring, i.e. every joint without one held), and
    ``K φ = ω² M φ`` solved by ``scipy.linalg.eigh``. K is symmetrized (the gravity part is a
    Hessian, symmetric up to round-off). Negative ω² (an unstable equilibrium) give negative
    frequencies ``-sqrt(-ω²)/(2π)``."""
    q_eq = np.asarray(q_eq, dtype=float)
    if free is None:
        free = statics.spring_coordinates(model, q_eq)
    free = np.asarray(free, dtype=int)
    if free.size == 0:
        raise ModelError("natural_frequencies: no free coordinate; pass the indices to vibrate as 'free'")
    sub = np.ix_(free, free)
    K = model.stiffness_jacobian(q_eq)[sub]
    M = model.mass_matrix(q_eq)[sub]
    K = 0.5 * (K + K.T)
    M = 0.5 * (M + M.T)
    omega2, vectors = scipy.linalg.eigh(K, M)
    frequencies = np.sign(omega2) * np.sqrt(np.abs(omega2)) / (2.0 * math.pi)
    shapes = np.zeros((model.n_dof, free.size))
    shapes[free] = vectors
    modes = Modes(frequencies, shapes, free, tuple(model.coordinates))
    modes.kinds = classify(modes.coordinates, shapes)
    return modes


def classify(coordinates, shapes) -> list[str]:
    """Kind of each mode (column of ``shapes``, (n_dof, k)): 'vertical' bending when the ψ
    coordinates (names starting ``psi``) carry the largest share of ``Σ φ_j²``, 'horizontal'
    bending for θ (``theta``), 'torsion' for φ (``phi``); 'other' when another coordinate
    (e.g. ``x3``) dominates."""
    shapes = np.asarray(shapes, dtype=float)
    if shapes.ndim == 1:
        shapes = shapes[:, None]
    family = np.array([next((kind for prefix, kind in FAMILIES if name.startswith(prefix)), "other")
                       for name in coordinates])
    kinds = []
    for col in shapes.T:
        share = {kind: float(np.sum(col[family == kind] ** 2)) for kind in KINDS + ("other",)}
        kinds.append(max(share, key=share.get))
    return kinds


# --- convergence to beam theory ----------------------------------------------------------------

QUANTITIES = (
    ("tip_deflection", "static tip deflection, self weight", "m"),
    ("vertical_bending", "1st vertical bending frequency", "Hz"),
    ("horizontal_bending", "1st horizontal bending frequency", "Hz"),
    ("torsion", "1st torsional frequency", "Hz"),
)


@dataclass
class ConvergenceTable:
    """Clamped arm without slider against beam theory.

    ``nrfe`` (k,); ``values[q]`` and ``errors[q]`` (k,) the RFEM value and its relative error
    ``(value - analytic)/analytic`` for each quantity ``q`` of :data:`QUANTITIES`;
    ``analytic[q]`` the beam-theory value; ``orders[q]`` the observed order of convergence, the
    least-squares slope of ``-log|error|`` against ``log nrfe`` over all rows;
    ``local_orders[q]`` (k-1,) the slopes between consecutive rows; ``build_seconds`` (k,)."""

    nrfe: np.ndarray
    values: dict
    analytic: dict
    errors: dict
    orders: dict
    local_orders: dict
    build_seconds: np.ndarray
    static: str = "linear"

    def format(self) -> str:
        """The table as text, one block per quantity."""
        lines = [f"clamped arm (no slider) against beam theory; static deflection: {self.static}; "
                 f"frequencies at zero gravity about the straight arm"]
        for key, label, unit in QUANTITIES:
            lines.append("")
            lines.append(f"{label} (analytic {self.analytic[key]:.6g} {unit})")
            lines.append(f"{'nrfe':>5} {'value':>14} {'rel. error':>12} {'local order':>12}")
            for k, n in enumerate(self.nrfe):
                local = f"{self.local_orders[key][k - 1]:12.3f}" if k else " " * 12
                lines.append(f"{n:5d} {self.values[key][k]:14.8g} {self.errors[key][k]:12.3e} {local}")
            lines.append(f"observed order (log-log fit over nrfe): {self.orders[key]:.3f}")
        return "\n".join(lines)


def tip_deflection(model, static: str = "linear") -> float:
    """Downward deflection (m) of the point ``tip`` of a horizontal clamped arm under its
    weight: ``static='linear'`` solves ``K(0) q = -(g + C q)(0)`` and measures the tip
    displacement to first order (exactly linear beam theory); ``'nonlinear'`` solves the full
    equilibrium with :func:`gpmegen.runtime.statics.locked` (large-rotation kinematics and
    gravity continuation)."""
    q0 = np.zeros(model.n_dof)
    tip = model.points.index("tip")
    y0 = model.point_positions(q0)[tip, 1]
    if static == "linear":
        q_lin = np.linalg.solve(model.stiffness_jacobian(q0), -model.static_residual(q0))
        eps = 1e-6  # the tip position is evaluated along the linear solution, scaled down
        return -(model.point_positions(eps * q_lin)[tip, 1] - y0) / eps
    if static == "nonlinear":
        q = statics.locked(model, q0, free=np.arange(model.n_dof))
        return -(model.point_positions(q)[tip, 1] - y0)
    raise ValueError(f"unknown static {static!r}: use 'linear' or 'nonlinear'")


def arm_quantities(model, static: str = "linear") -> dict:
    """The four quantities of :data:`QUANTITIES` for a loaded clamped arm without slider;
    frequencies at zero gravity about the straight arm (pure beam theory; under gravity they
    move by a relative ~1e-5 through the geometric stiffness of the self weight)."""
    modes = natural_frequencies(model.with_params(g=0.0), np.zeros(model.n_dof))
    return {
        "tip_deflection": tip_deflection(model, static),
        "vertical_bending": modes.first("vertical"),
        "horizontal_bending": modes.first("horizontal"),
        "torsion": modes.first("torsion"),
    }


def observed_order(nrfe, errors) -> float:
    """Least-squares slope of ``-log|error|`` against ``log nrfe`` (the order p of
    ``|error| ≈ c·nrfe^-p``)."""
    x = np.log(np.asarray(nrfe, dtype=float))
    y = np.log(np.abs(np.asarray(errors, dtype=float)))
    return float(-np.polyfit(x, y, 1)[0])


def convergence_table(nrfe_values, directory=None, params: dict | None = None, static: str = "linear",
                      progress=None) -> ConvergenceTable:
    """Build the clamped arm without slider for each ``nrfe`` (≥ 2) into ``directory`` (default:
    gpmegen's generated folder) and compare it with beam theory (:func:`beam.arm_reference`).
    ``params`` overrides the reference parameters; ``static`` as in :func:`tip_deflection`;
    ``progress(nrfe, seconds)`` is called after each build. Returns a
    :class:`ConvergenceTable`."""
    nrfe_values = [int(n) for n in nrfe_values]
    values = {key: [] for key, _, _ in QUANTITIES}
    seconds = []
    analytic = None
    for n in nrfe_values:
        start = time.perf_counter()
        model = load_clamped_arm(n, directory=directory, params=params)
        seconds.append(time.perf_counter() - start)
        if progress is not None:
            progress(n, seconds[-1])
        if analytic is None:
            analytic = vars(beam.arm_reference(model.params))
        for key, value in arm_quantities(model, static).items():
            values[key].append(value)
    values = {k: np.array(v) for k, v in values.items()}
    errors = {k: (values[k] - analytic[k]) / analytic[k] for k in values}
    x = np.log(np.array(nrfe_values, dtype=float))
    local = {k: -np.diff(np.log(np.abs(errors[k]))) / np.diff(x) for k in values}
    orders = {k: observed_order(nrfe_values, errors[k]) if len(nrfe_values) > 1 else float("nan") for k in values}
    return ConvergenceTable(np.array(nrfe_values), values, analytic, errors, orders, local,
                            np.array(seconds), static)


def plot_convergence(table: ConvergenceTable, path) -> Path:
    """Log–log plot of the relative error of each quantity against ``nrfe``; writes ``path``
    (PNG) and returns it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(6.4, 4.8))
    for (key, label, unit), marker in zip(QUANTITIES, "osd^"):
        ax.loglog(table.nrfe, np.abs(table.errors[key]), marker=marker,
                  label=f"{label} (order {table.orders[key]:.2f})")
    n = np.array(table.nrfe, dtype=float)
    ref = np.abs(table.errors["tip_deflection"][0]) * (n / n[0]) ** -2.0
    ax.loglog(n, ref, "k:", lw=1, label="slope -2")
    ax.set_xlabel("number of rigid finite elements n_rfe (-)")
    ax.set_ylabel("relative error |value - beam theory| / beam theory (-)")
    ax.set_title("Clamped arm: RFEM against Euler–Bernoulli / Saint-Venant")
    ax.grid(True, which="both", alpha=0.3)
    ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=150)
    plt.close(fig)
    return path


__all__ = [
    "clamped_arm_model", "load_clamped_arm", "Modes", "natural_frequencies", "classify",
    "ConvergenceTable", "convergence_table", "tip_deflection", "arm_quantities",
    "observed_order", "plot_convergence", "QUANTITIES",
]
