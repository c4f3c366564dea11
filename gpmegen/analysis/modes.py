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
from ..model.chain import Body, Model, Point
from ..fileio import atomic_write, atomic_write_bytes
from ..model.reference import PARAMETERS, reference_arm
from ..model.shapes import shape_quantities, solid_cylinder
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
    chain = [reference_arm(P, nrfe), Point("tip", (0, 0, 0))]
    if with_slider:
        slider = Body("slider", solid_cylinder(P["m3"], P["R3"], P["L3"], "x"),
                      shape_quantities(mass=P["m3"], radius=P["R3"], length=P["L3"]))
        chain += [slider, Point("E", (P["L3"], 0, 0))]
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

    def format(self, count: int | None = 10) -> str:
        """The lowest ``count`` modes (all when None) as text: frequency, kind and the
        coordinate with the largest amplitude."""
        lines = [f"{'mode':>4} {'frequency (Hz)':>15} {'kind':>11}  largest coordinate"]
        for k in range(len(self.frequencies) if count is None else min(count, len(self.frequencies))):
            j = int(np.argmax(np.abs(self.shapes[:, k])))
            lines.append(f"{k + 1:4d} {self.frequencies[k]:15.6g} {self.kinds[k]:>11}  {self.coordinates[j]}")
        return "\n".join(lines)


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


def locked_modes(model, q_start=None, free=None):
    """Natural modes of ``model`` about its equilibrium with the joints locked: the equilibrium
    by :func:`gpmegen.runtime.statics.locked` from ``q_start`` (default: the paper's start
    θ1 = 0, ψ2 = 45°, x3 = 0 for the reference manipulator, else all zero), then
    :func:`natural_frequencies`. Returns ``(q_eq, Modes)``."""
    from .study import START_JOINTS, joint_start

    if q_start is None:
        if set(START_JOINTS) <= set(model.coordinates):
            q_start = joint_start(model)
        else:
            q_start = np.zeros(model.n_dof)
    q_eq = statics.locked(model, q_start, free=free)
    return q_eq, natural_frequencies(model, q_eq, free=free)


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


# The continuum limit of the RFEM arm for each quantity: the rfes carry their sections' rotary
# inertia, so bending converges to the Rayleigh beam, not to Euler–Bernoulli (beam.py).
LIMIT_KEYS = {"tip_deflection": "tip_deflection", "vertical_bending": "vertical_bending_rotary",
              "horizontal_bending": "horizontal_bending_rotary", "torsion": "torsion"}


@dataclass
class ConvergenceTable:
    """Clamped arm without slider against beam theory.

    ``nrfe`` (k,); for each quantity ``q`` of :data:`QUANTITIES`: ``values[q]`` (k,) the RFEM
    values; ``analytic[q]`` the Euler–Bernoulli / Saint-Venant value and ``errors[q]`` (k,)
    the relative errors ``(value - analytic)/analytic``; ``orders[q]`` the observed order of
    convergence, the least-squares slope of ``-log|error|`` against ``log nrfe`` over all rows,
    and ``local_orders[q]`` (k-1,) the slopes between consecutive rows. ``limit[q]``,
    ``errors_limit``, ``orders_limit``, ``local_orders_limit``: the same against the continuum
    limit of the RFEM model (bending with the sections' rotary inertia, a Rayleigh beam; the
    other two equal to ``analytic``). ``orders_sde``: the fitted order against the limit in
    ``n_sde = nrfe - 1`` (the modified RFEM's error goes as ``n_sde⁻²``). ``build_seconds``
    (k,) the time to build (or load) each model; ``static`` how the deflection was solved."""

    nrfe: np.ndarray
    values: dict
    analytic: dict
    errors: dict
    orders: dict
    local_orders: dict
    limit: dict
    errors_limit: dict
    orders_limit: dict
    local_orders_limit: dict
    orders_sde: dict
    build_seconds: np.ndarray
    static: str = "linear"

    def format(self) -> str:
        """The table as text, one block per quantity."""
        lines = [f"clamped arm (no slider) against beam theory; static deflection: {self.static}; "
                 f"frequencies at zero gravity about the straight arm",
                 "err EB: against Euler-Bernoulli / Saint-Venant; err limit: against the same with the "
                 "sections' rotary inertia (Rayleigh beam), the RFEM's continuum limit"]
        for key, label, unit in QUANTITIES:
            lines.append("")
            head = f"{label}: analytic {self.analytic[key]:.8g} {unit}"
            if self.limit[key] != self.analytic[key]:
                head += f", with rotary inertia {self.limit[key]:.8g} {unit}"
            lines.append(head)
            lines.append(f"{'nrfe':>5} {'value':>14} {'err EB':>11} {'order':>7} {'err limit':>11} {'order':>7}")
            for k, n in enumerate(self.nrfe):
                o1 = f"{self.local_orders[key][k - 1]:7.3f}" if k else " " * 7
                o2 = f"{self.local_orders_limit[key][k - 1]:7.3f}" if k else " " * 7
                lines.append(f"{n:5d} {self.values[key][k]:14.8g} {self.errors[key][k]:11.3e} {o1} "
                             f"{self.errors_limit[key][k]:11.3e} {o2}")
            lines.append(f"observed order, log-log fit over all nrfe: {self.orders[key]:.3f} (EB), "
                         f"{self.orders_limit[key]:.3f} (limit); over n_sde = nrfe - 1: "
                         f"{self.orders_sde[key]:.3f} (limit)")
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


def _relative(values, reference, nrfe):
    errors = {k: (values[k] - reference[k]) / reference[k] for k in values}
    x = np.log(np.asarray(nrfe, dtype=float))
    local = {k: -np.diff(np.log(np.abs(e))) / np.diff(x) for k, e in errors.items()}
    orders = {k: observed_order(nrfe, e) if len(nrfe) > 1 else float("nan") for k, e in errors.items()}
    return errors, orders, local


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
    reference = None
    for n in nrfe_values:
        start = time.perf_counter()
        model = load_clamped_arm(n, directory=directory, params=params)
        seconds.append(time.perf_counter() - start)
        if progress is not None:
            progress(n, seconds[-1])
        if reference is None:
            reference = beam.arm_reference(model.params)
        for key, value in arm_quantities(model, static).items():
            values[key].append(value)
    values = {k: np.array(v) for k, v in values.items()}
    analytic = {k: getattr(reference, k) for k in values}
    limit = {k: getattr(reference, LIMIT_KEYS[k]) for k in values}
    errors, orders, local = _relative(values, analytic, nrfe_values)
    errors_limit, orders_limit, local_limit = _relative(values, limit, nrfe_values)
    orders_sde = {k: observed_order(np.array(nrfe_values) - 1, e) if len(nrfe_values) > 1 else float("nan")
                  for k, e in errors_limit.items()}
    return ConvergenceTable(np.array(nrfe_values), values, analytic, errors, orders, local,
                            limit, errors_limit, orders_limit, local_limit, orders_sde,
                            np.array(seconds), static)


def plot_convergence(table: ConvergenceTable, path) -> Path:
    """Log–log plot of the relative error of each quantity against ``nrfe``; writes ``path``
    (PNG) and returns it."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    fig, ax = plt.subplots(figsize=(7.0, 5.2))
    n = np.array(table.nrfe, dtype=float)
    for (key, label, unit), marker, color in zip(QUANTITIES, "osd^", ("C0", "C1", "C2", "C3")):
        ax.loglog(n, np.abs(table.errors[key]), marker=marker, color=color,
                  label=f"{label} (fitted order {table.orders[key]:.2f})")
        if table.limit[key] != table.analytic[key]:
            ax.loglog(n, np.abs(table.errors_limit[key]), marker=marker, color=color, ls="--", mfc="none",
                      label=f"  same, against the beam with rotary inertia ({table.orders_limit[key]:.2f})")
    # the modified RFEM's error goes as n_sde^-2 = (n_rfe - 1)^-2: a guide through the last point
    last = np.abs(table.errors["tip_deflection"][-1])
    ax.loglog(n[n > 1], last * ((n[n > 1] - 1) / (n[-1] - 1)) ** -2.0, "k:", lw=1,
              label="guide: (n_rfe - 1)^-2")
    ax.set_xticks(n)
    ax.set_xticklabels([str(int(v)) for v in n])
    ax.minorticks_off()
    ax.set_xlabel("number of rigid finite elements n_rfe (-)")
    ax.set_ylabel("relative error |RFEM - beam theory| / beam theory (-)")
    ax.set_title("Clamped arm: RFEM against beam theory\n(solid: Euler–Bernoulli / Saint-Venant; "
                 "dashed: with the sections' rotary inertia)", fontsize=10)
    ax.grid(True, which="major", alpha=0.3)
    ax.legend(fontsize=7.5, loc="lower left")
    fig.tight_layout()
    atomic_write(path, lambda fh: fig.savefig(fh, format=Path(path).suffix[1:] or "png", dpi=150))
    plt.close(fig)
    return path




def constrained_modes(model, q_eq, hold=None, step=1e-7) -> Modes:
    """Natural modes with the programmed constraints holding, about the constrained equilibrium
    ``q_eq``, projected onto the independent coordinates: with ``B = [I; -D_dc⁻¹ D_ic]``,
    ``K_r = Bᵀ (K - Σ λ_k ∂²Φ_k/∂q²) B`` and ``M_r = Bᵀ M B``. ``λ`` solves ``Dᵀλ = g + C q``;
    ``Σ λ_k ∂²Φ_k/∂q² = ∂(Dᵀλ)/∂q`` is taken by central differences of the emitted ``D``
    (relative step ``step``). ``hold``: independent coordinates kept fixed (default: those
    without a spring, e.g. the column's neutral rotation). Shapes are full-coordinate
    vectors ``B v`` normalized to unit modal mass."""
    from ..runtime.gpme import tangent_basis

    q_eq = np.asarray(q_eq, dtype=float)
    n = model.n_dof
    zero = np.zeros(n)
    _, _, D, _ = model.constraint_terms(0.0, q_eq, zero)
    lam, *_ = np.linalg.lstsq(D.T, model.static_residual(q_eq), rcond=None)
    curvature = np.zeros((n, n))
    for j in range(n):
        h = step * max(1.0, abs(q_eq[j]))
        up, down = q_eq.copy(), q_eq.copy()
        up[j] += h
        down[j] -= h
        curvature[:, j] = (model.constraint_terms(0.0, up, zero)[2].T @ lam
                           - model.constraint_terms(0.0, down, zero)[2].T @ lam) / (2 * h)
    K = model.stiffness_jacobian(q_eq) - 0.5 * (curvature + curvature.T)
    M = model.mass_matrix(q_eq)
    B = tangent_basis(D, model.dependent, model.independent)
    if hold is None:
        springs = set(statics.spring_coordinates(model, q_eq).tolist())
        hold = [k for k in model.independent if k not in springs]
    keep = [c for c, k in enumerate(model.independent) if k not in set(hold)]
    B = B[:, keep]
    Kr, Mr = B.T @ K @ B, B.T @ M @ B
    omega2, vectors = scipy.linalg.eigh(0.5 * (Kr + Kr.T), 0.5 * (Mr + Mr.T))
    frequencies = np.sign(omega2) * np.sqrt(np.abs(omega2)) / (2.0 * math.pi)
    shapes = B @ vectors
    modes = Modes(frequencies, shapes, np.asarray(model.independent)[keep], tuple(model.coordinates))
    modes.kinds = classify(modes.coordinates, shapes)
    return modes


def write_modes_csv(modes: Modes, path) -> Path:
    """Frequencies, kinds and shapes as CSV: one row per mode, one column per coordinate."""
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    header = ",".join(["mode", "frequency_Hz", "kind", *modes.coordinates])
    rows = [",".join([str(k + 1), f"{f:.9g}", modes.kinds[k], *(f"{v:.9g}" for v in modes.shapes[:, k])])
            for k, f in enumerate(modes.frequencies)]
    return atomic_write_bytes(path, ("\n".join([header, *rows]) + "\n").encode())


def plot_mode_shapes(modes: Modes, path, count: int = 6) -> Path:
    """The first ``count`` mode shapes along the arm: the sde rotations ψ, θ, φ against the sde
    index, one panel per mode."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    count = min(count, len(modes.frequencies))
    fig, axes = plt.subplots(count, 1, figsize=(7, 1.9 * count + 0.6), sharex=True, squeeze=False)
    names = modes.coordinates
    for k in range(count):
        ax = axes[k, 0]
        for rot, style in (("psi", "o-"), ("theta", "s--"), ("phi", "^:")):
            idx = [j for j, c in enumerate(names) if c.startswith(rot) and "_" in c]
            if idx:
                ax.plot(range(1, len(idx) + 1), modes.shapes[idx, k], style, label=f"{rot} (rad)")
        ax.set_ylabel(f"{modes.frequencies[k]:.4g} Hz\n{modes.kinds[k]}", fontsize=8)
        ax.axhline(0, color="k", lw=0.5)
        ax.grid(True, alpha=0.3)
    n_sde = sum(1 for c in names if c.startswith("psi") and "_" in c)
    axes[-1, 0].set_xticks(range(1, n_sde + 1))
    axes[0, 0].legend(fontsize=7, ncol=3)
    axes[-1, 0].set_xlabel("sde along the arm (1 = at the root)")
    fig.suptitle("Mode shapes: sde rotations (unit modal mass)")
    path = atomic_write(path, lambda fh: fig.savefig(fh, format=Path(path).suffix[1:], dpi=120, bbox_inches="tight"))
    plt.close(fig)
    return path


__all__ = [
    "clamped_arm_model", "load_clamped_arm", "Modes", "natural_frequencies", "locked_modes", "classify",
    "ConvergenceTable", "convergence_table", "tip_deflection", "arm_quantities",
    "observed_order", "plot_convergence", "QUANTITIES", "LIMIT_KEYS", "constrained_modes",
    "write_modes_csv", "plot_mode_shapes",
]
