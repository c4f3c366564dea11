"""The convergence of the RFEM arm to beam theory: the reference arm alone, clamped at its root
(:func:`clamped_arm_model`), or a flexible link of any model so (:func:`clamped_link_model`), its
static tip deflection and first frequencies for several ``n_rfe`` against Euler–Bernoulli /
Saint-Venant values (:mod:`gpmegen.analysis.post.beam`), with the observed order of convergence
(:func:`convergence_table`). Its figure: :func:`gpmegen.analysis.figures.modes_output.plot_convergence`.
"""

from __future__ import annotations

import time
from dataclasses import dataclass, replace

import numpy as np

from ...errors import ModelError
from ...model.chain import FlexibleLink, Joint, Model, Parameter, Point, symbol
from ...model.reference import reference_model
from ...model.requirements import evaluate
from ...model.rfem import check_nrfe, section_properties
from ...runtime import statics
from ..post import beam
from ..post.modes import natural_frequencies
from ..run.loading import load


def clamped_arm_model(nrfe: int, with_slider: bool = False) -> Model:
    """The reference arm (the flexible link of :func:`gpmegen.model.reference_model`) alone,
    clamped at its root and horizontal along x0, with the reference's gravity; ``with_slider``
    adds what the link carries beyond its tip, the joints there held at zero (the slider at
    ``x3 = 0``). Coordinates ``psi2_r, theta2_r, phi2_r`` (r = 1..nrfe-1); points ``tip`` (the
    link's tip) and, with the slider, ``E``. The reference's parameters."""
    check_nrfe(nrfe, "the clamped arm (nrfe = 1 has no coordinate)", minimum=2)
    whole = reference_model(nrfe)
    at = next(k for k, element in enumerate(whole.chain) if isinstance(element, FlexibleLink))
    chain = [whole.chain[at], Point("tip", (0, 0, 0))]
    if with_slider:
        chain += [element for element in whole.chain[at + 1:] if not isinstance(element, Joint)]
    return Model(
        name=f"clamped_arm{'_slider' if with_slider else ''}_nrfe{nrfe}",
        parameters=whole.parameters,
        chain=tuple(chain),
        gravity=whole.gravity,
        description="the reference arm clamped at its root" + (", slider at its tip" if with_slider else ""),
    )


def arm_reference(params: dict) -> beam.ArmReference:
    """Beam-theory values of the reference arm clamped (:func:`link_reference` of its flexible
    link) at the parameter values ``params`` (``model.params`` of a loaded model)."""
    return link_reference(flexible_links(reference_model(2))[0], params)


GRAVITY = 9.81  # m/s², the clamped link's weight when its model has no parameter g


def flexible_links(model) -> list:
    """The flexible links of ``model``'s chain, from the base outwards."""
    return [element for element in model.chain if isinstance(element, FlexibleLink)]


def clamped_link_model(model: Model, label: str, nrfe: int) -> Model:
    """The flexible link ``label`` of ``model`` alone with ``nrfe`` rfes, clamped at its root and
    horizontal along x0, gravity ``(0, -g, 0)`` with the model's parameter ``g`` (else a parameter
    ``g`` of 9.81 m/s²); coordinates ``psi<label>_r, theta<label>_r, phi<label>_r``, point ``tip``
    at the link's tip; the model's parameters."""
    check_nrfe(nrfe, f"flexible link {label!r} clamped (nrfe = 1 has no coordinate)", minimum=2)
    link = next((element for element in flexible_links(model) if element.label == label), None)
    if link is None:
        raise ModelError(f"model {model.name} has no flexible link {label!r}; its flexible links are "
                         f"{', '.join(repr(element.label) for element in flexible_links(model)) or 'none'}")
    parameters = tuple(model.parameters)
    if "g" not in {p.name for p in parameters}:
        parameters += (Parameter("g", GRAVITY, "m/s^2", "gravitational acceleration on the clamped link"),)
    return Model(
        name=f"{model.name[:20]}_link{label}_clamped_nrfe{nrfe}",
        parameters=parameters,
        chain=(replace(link, n_rfe=nrfe), Point("tip", (0, 0, 0))),
        gravity=(0, -symbol("g"), 0),
        description=f"flexible link {label!r} of {model.name}, clamped at its root",
    )


def link_numbers(link: FlexibleLink, params: dict) -> dict[str, float]:
    """The length ``L`` (m), ``EIz``, ``EIy``, ``GJ`` (N·m²), ``rhoA`` (kg/m), ``rhoIz``, ``rhoIy``
    (kg·m) of ``link`` and the gravity ``g`` (m/s²) at the parameter values ``params`` (name ->
    number, with ``g``): read from the link's own expressions, whatever its parameters' names."""
    values = {symbol(name): float(value) for name, value in params.items()}
    p = section_properties(link)
    terms = {"L": link.length, "EIz": p.EIz, "EIy": p.EIy, "GJ": p.GJ, "rhoA": p.rhoA, "rhoIz": p.rhoIz,
             "rhoIy": p.rhoIy, "g": symbol("g")}
    return {key: evaluate(x, values) for key, x in terms.items()}


def link_reference(link: FlexibleLink, params: dict) -> beam.ArmReference:
    """Beam-theory values of ``link`` clamped (:func:`gpmegen.analysis.post.beam.link_reference`) at
    the parameter values ``params`` (name -> number, with ``g``)."""
    return beam.link_reference(*link_numbers(link, params).values())


@dataclass(frozen=True)
class Clamped:
    """What a convergence study clamps: the reference arm (``model`` None) or the flexible link
    ``label`` of ``model``."""

    model: Model | None = None
    label: str = "2"

    @property
    def title(self) -> str:
        if self.model is None:
            return "clamped arm (no slider)"
        return f"flexible link {self.label!r} of {self.model.name}, clamped"

    def build(self, nrfe: int) -> Model:
        if self.model is None:
            return clamped_arm_model(nrfe)
        return clamped_link_model(self.model, self.label, nrfe)

    def reference(self, params: dict) -> beam.ArmReference:
        if self.model is None:
            return arm_reference(params)
        return link_reference(next(link for link in flexible_links(self.model) if link.label == self.label), params)


def load_clamped_arm(nrfe: int, with_slider: bool = False, directory=None, params: dict | None = None):
    """The generated clamped arm (:func:`clamped_arm_model`), built into ``directory`` when
    missing (default: gpmegen's generated folder)."""
    return load(clamped_arm_model(nrfe, with_slider), "numpy", params, directory=directory)


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
    (k,) the time to build (or load) each model; ``static`` how the deflection was solved. A
    quantity the link does not have (no mode of that kind: a link free in ``psi`` alone neither
    bends horizontally nor twists) is left out of every dict and named in ``absent``."""

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
    subject: str = "clamped arm (no slider)"
    absent: tuple = ()

    @property
    def quantities(self) -> tuple:
        """The entries of :data:`QUANTITIES` the table holds."""
        return tuple(entry for entry in QUANTITIES if entry[0] in self.values)

    def format(self) -> str:
        """The table as text, one block per quantity."""
        lines = [f"{self.subject} against beam theory; static deflection: {self.static}; "
                 f"frequencies at zero gravity about the straight arm",
                 "err EB: against Euler-Bernoulli / Saint-Venant; err limit: against the same with the "
                 "sections' rotary inertia (Rayleigh beam), the RFEM's continuum limit"]
        for key, label, unit in self.quantities:
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
        if self.absent:
            labels = ", ".join(label for key, label, _ in QUANTITIES if key in self.absent)
            lines += ["", f"not compared: {labels} (no mode of that kind: the link's freedoms do not have it)"]
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
    move by a relative ~1e-5 through the geometric stiffness of the self weight), each of the
    first mode of its kind by shape; NaN for a kind no mode has."""
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
                      progress=None, clamped: Clamped = Clamped()) -> ConvergenceTable:
    """Build the ``clamped`` link (default: the reference arm without slider) for each ``nrfe``
    (≥ 2) into ``directory`` (default: gpmegen's generated folder) and compare it with beam
    theory (:meth:`Clamped.reference`). ``params`` overrides the model's parameters; ``static``
    as in :func:`tip_deflection`; ``progress(nrfe, seconds)`` is called after each build.
    Returns a :class:`ConvergenceTable`."""
    nrfe_values = [int(n) for n in nrfe_values]
    values = {key: [] for key, _, _ in QUANTITIES}
    seconds = []
    reference = None
    for n in nrfe_values:
        start = time.perf_counter()
        model = load(clamped.build(n), "numpy", params, directory=directory)
        seconds.append(time.perf_counter() - start)
        if progress is not None:
            progress(n, seconds[-1])
        if reference is None:
            reference = clamped.reference(model.params)
        for key, value in arm_quantities(model, static).items():
            values[key].append(value)
    values = {k: np.array(v) for k, v in values.items()}
    absent = tuple(k for k, v in values.items() if np.all(np.isnan(v)))
    mixed = [k for k, v in values.items() if k not in absent and np.any(np.isnan(v))]
    if mixed:  # a kind found at some levels only: the shapes changed kind with n_rfe
        raise ModelError(f"{clamped.title}: no mode of the kind of {', '.join(mixed)} at some n_rfe "
                         f"({', '.join(str(n) for n, x in zip(nrfe_values, values[mixed[0]]) if np.isnan(x))}); "
                         f"compare levels of 3 rfes or more")
    values = {k: v for k, v in values.items() if k not in absent}
    analytic = {k: getattr(reference, k) for k in values}
    limit = {k: getattr(reference, LIMIT_KEYS[k]) for k in values}
    errors, orders, local = _relative(values, analytic, nrfe_values)
    errors_limit, orders_limit, local_limit = _relative(values, limit, nrfe_values)
    orders_sde = {k: observed_order(np.array(nrfe_values) - 1, e) if len(nrfe_values) > 1 else float("nan")
                  for k, e in errors_limit.items()}
    return ConvergenceTable(np.array(nrfe_values), values, analytic, errors, orders, local,
                            limit, errors_limit, orders_limit, local_limit, orders_sde,
                            np.array(seconds), static, clamped.title, absent)


__all__ = [
    "clamped_arm_model", "load_clamped_arm", "clamped_link_model", "flexible_links", "link_reference",
    "link_numbers", "arm_reference",
    "Clamped", "ConvergenceTable", "convergence_table", "tip_deflection",
    "arm_quantities", "observed_order", "QUANTITIES", "LIMIT_KEYS",
]
