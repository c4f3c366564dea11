"""The elements of a model: parameters, joints, offsets, bodies, points, flexible links,
drives (geared motors, series-elastic joints, torque limits) and programmed constraints.

A chain is a tuple of elements read from the base outwards. A ``Joint`` or ``Offset`` moves the
current frame; a ``Body`` or ``Point`` is attached to the current frame; a ``FlexibleLink`` is
expanded by :mod:`gpmegen.model.rfem` into rigid finite elements and spring-damping joints and
leaves the current frame at its tip. A ``Branch`` makes a tree: the elements after it start
again from a point defined before it (or from the ground), so the chain lists a tree's branches
one after the other (:mod:`gpmegen.model.topology`). Quantities are SymPy expressions of parameter symbols (or
plain numbers); nothing here does algebra beyond naming symbols.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from .names import (  # noqa: F401 (re-exported: the model's names are read from here too)
    AXES,
    GROUND_NAME,
    NAME_PATTERN,
    RESERVED_NAMES,
    SOLVER_NAMESPACE,
    SYMPY_NAMES,
    TIME,
    acceleration_symbol,
    as_expr,
    axis_symbols,
    check_model_name,
    check_name,
    point_acceleration_symbols,
    point_symbols,
    point_velocity_symbols,
    symbol,
    velocity_symbol,
)
from .sections import (  # noqa: F401 (re-exported)
    PAPER_FREEDOMS,
    SDE_FREEDOMS,
    SDE_JOINTS,
    CircularSection,
    FlexibleLink,
    ISection,
    RectangularSection,
    StiffnessSection,
    TubeSection,
)

JOINT_KINDS = ("revolute", "prismatic")


@dataclass(frozen=True)
class Parameter:
    """A named model constant with a default value; overridable at run time without rebuilding."""

    name: str
    default: float
    unit: str = ""
    doc: str = ""

    @property
    def symbol(self) -> sp.Symbol:
        return symbol(self.name)


@dataclass(frozen=True)
class Motor:
    """A motor driving a joint through a rigid gearbox (Spong's model): rotor ``inertia`` J_m
    about its own axis (kg·m², or kg for a linear motor) and ``gear`` ratio n (motor turns per
    joint turn). Its kinetic energy ``n² J_m q̇² / 2`` is that of the reflected inertia ``n² J_m``
    on the joint's diagonal entry of ``M``; the rotor's gyroscopic coupling with the links is
    neglected."""

    inertia: sp.Expr
    gear: sp.Expr = sp.S.One

    @property
    def reflected_inertia(self) -> sp.Expr:
        """``n² J_m``: the motor's inertia seen from the joint side of the gear."""
        return sp.sympify(self.gear) ** 2 * sp.sympify(self.inertia)


@dataclass(frozen=True)
class SeriesElastic:
    """A spring of ``stiffness`` k and a damper of ``damping`` c between a joint and its motor
    (Spong's flexible joint): the motor becomes a coordinate ``<joint>_motor`` of its own, the
    motor angle reflected through the gear (``θ_m / n``), with inertia ``n² J_m``, and the joint
    feels ``k (θ - q) + c (θ̇ - q̇)`` (N·m with k in N·m/rad; the motor the opposite)."""

    stiffness: sp.Expr
    damping: sp.Expr = sp.S.Zero


#: The suffix of a series-elastic joint's motor coordinate: ``<joint>_motor``.
MOTOR_SUFFIX = "_motor"


@dataclass(frozen=True)
class Joint:
    """One coordinate: rotation about (revolute, rad) or translation along (prismatic, m) an
    axis of the current frame: a principal axis ``"x"``, ``"y"``, ``"z"`` or a constant unit
    vector ``(ax, ay, az)`` of numbers (:func:`gpmegen.model.expand.expand` normalizes it and
    writes a principal one as its letter). ``stiffness``, ``rest`` and ``damping`` add the
    generalized force ``-stiffness*(q - rest) - damping*qd`` (a spring to ``q = rest``, rad or m).
    ``motor``: a geared :class:`Motor` on the joint; with ``series_elastic`` (a
    :class:`SeriesElastic`) it drives the joint through a spring instead of rigidly."""

    name: str
    kind: str
    axis: str | tuple
    stiffness: sp.Expr = sp.S.Zero
    damping: sp.Expr = sp.S.Zero
    rest: sp.Expr = sp.S.Zero
    motor: Motor | None = None
    series_elastic: SeriesElastic | None = None

    @property
    def armature(self) -> sp.Expr:
        """The inertia a rigidly geared motor adds to the joint's diagonal entry of ``M``
        (``n² J_m``; zero without a motor, or when the motor has a coordinate of its own)."""
        if self.motor is None or self.series_elastic is not None:
            return sp.S.Zero
        return self.motor.reflected_inertia


@dataclass(frozen=True)
class Offset:
    """A constant transform: translate by ``translation`` (m), then rotate about the principal
    axes in ``rotations`` (sequence of ``(axis, angle in rad)``), all in the current frame."""

    translation: tuple = (0, 0, 0)
    rotations: tuple = ()


@dataclass(frozen=True)
class Body:
    """A rigid body attached to the current frame; ``pseudo_inertia`` is the 4x4 matrix
    ``∫ [x y z 1]ᵀ[x y z 1] dm`` in that frame (SymPy Matrix of parameter expressions).

    ``quantities``: the mass, sizes and moments the body was described with, as ``(key,
    expression)`` pairs keyed as a model file writes them (``("shape", "radius")``), so that any
    parameter values can be checked against them (:mod:`gpmegen.model.requirements`); empty:
    the mass ``pseudo_inertia[3, 3]`` alone is checked."""

    name: str
    pseudo_inertia: sp.ImmutableMatrix
    quantities: tuple = ()


@dataclass(frozen=True)
class Point:
    """A named point (end-effector, sensor) fixed in the current frame at ``position`` (m)."""

    name: str
    position: tuple = (0, 0, 0)


@dataclass(frozen=True)
class Branch:
    """The start of a branch: the elements after it, up to the next ``Branch``, hang from the
    point named ``parent``, defined earlier in the chain. Their first frame has its origin at the
    point and the orientation of the frame the point is attached to (for a point after a
    flexible link: its last rfe); ``parent="ground"`` starts from the base frame {0}."""

    parent: str


@dataclass(frozen=True)
class Drive:
    """A generalized force (N·m or N) on ``coordinate``, an expression of ``t``, parameters and,
    as a feedback law, of the state: coordinates, their velocities ``<name>_dot``, points'
    positions ``x_P`` and velocities ``vx_P`` (:func:`symbol`, :func:`velocity_symbol`,
    :func:`point_symbols`, :func:`point_velocity_symbols`); never of accelerations. ``limit``
    (an expression of parameters, positive): the force applied is the law clipped to
    ``[-limit, limit]``."""

    coordinate: str
    expression: sp.Expr
    limit: sp.Expr | None = None

    def applied(self, law: sp.Expr) -> sp.Expr:
        """The force applied for ``law`` (the drive's expression in the derivation's symbols):
        the law clipped to ``[-limit, limit]`` when the drive has a ``limit``."""
        if self.limit is None:
            return law
        return sp.Min(sp.Max(law, -self.limit), self.limit)


@dataclass(frozen=True)
class Controller:
    """A controller state: a first-order state ``state`` integrated with the mechanics, whose
    time derivative is ``rate``, an expression of ``t``, parameters, the state a drive's law
    reads (:class:`Drive`), signals and the controller states (their :func:`symbol`); never of
    accelerations. ``initial``: its value at the start (an expression of parameters). A drive's
    law reads it by its name: a PID's integral, a filtered signal."""

    state: str
    rate: sp.Expr
    initial: sp.Expr = sp.Integer(0)

    @property
    def symbol(self) -> sp.Symbol:
        return symbol(self.state)


#: The most table signals one model may have (the solver library keeps their tables in an array
#: of this size: ``GPMEGEN_MAX_SIGNALS`` of ``gpmegen_solver.h``).
MAX_SIGNALS = 32


@dataclass(frozen=True)
class Signal:
    """A reference signal of time read from a table at run time: ``table``, the path of a
    results file (``.npz``, absolute or relative to the working directory), and ``column``, the
    column of it (``u_<coordinate>``, ``lambda_<constraint>``, ``<coordinate>``,
    ``<coordinate>_dot``, ``drive_<coordinate>``), interpolated linearly in t
    (:mod:`gpmegen.runtime.signals`). A drive's law names it by ``name`` (its :func:`symbol`);
    the generated code calls it as a function of t that the runtime supplies. (A signal given by
    an expression is no Signal: the model file writes its expression where its name stands.)"""

    name: str
    table: str
    column: str

    @property
    def symbol(self) -> sp.Symbol:
        return symbol(self.name)


@dataclass(frozen=True)
class Constraint:
    """A programmed constraint.

    ``order=0``: position constraint ``Φ(points, q, t) = 0``, stabilized by
    ``Φ̈ + 2 α Φ̇ + β² Φ = 0``. ``order=1``: first-order constraint, linear in velocities
    (point velocities ``vx_P…`` and coordinate velocities ``<name>_dot``), stabilized by
    ``Ψ̇ + α Ψ = 0``. ``order=2``: second-order constraint, linear in accelerations (point
    accelerations ``ax_P…`` and coordinate accelerations ``<name>_ddot``), held as it stands
    (no gains). ``alpha`` and ``beta`` are expressions of parameters.
    """

    name: str
    expression: sp.Expr
    order: int = 0
    alpha: sp.Expr = sp.S.Zero
    beta: sp.Expr = sp.S.Zero


CLOSURE_TYPES = ("point", "revolute", "prismatic")


def _other_axes(axis: str) -> tuple[str, str]:
    """The two axes after ``axis`` in cyclic order (x: y, z; y: z, x; z: x, y)."""
    k = AXES.index(axis)
    return AXES[(k + 1) % 3], AXES[(k + 2) % 3]


def closure_rows(kind: str, axis: str | None) -> tuple[str, ...]:
    """The labels of the rows a closure of ``kind`` writes (all of them, before any is dropped):
    ``x``, ``y``, ``z`` the coincidence of its two points along {0}'s axes; ``ab`` (two axis
    letters) the orientation row ``a₁·b₂``, the ``a`` axis of the first point's frame against
    the ``b`` axis of the second's; ``b1`` the slide row ``(r₂ - r₁)·b₁``."""
    if kind == "point":
        return AXES
    b, c = _other_axes(axis)
    if kind == "revolute":
        return (*AXES, axis + b, axis + c)
    return (b + "1", c + "1", axis + b, axis + c, b + c)


@dataclass(frozen=True)
class Closure:
    """A loop closed between two points on different bodies (either may be on the ground):
    ``kind`` "point" (they coincide: a spherical joint), "revolute" (they coincide and the
    frames' ``axis`` stay parallel) or "prismatic" (the frames keep their relative orientation
    and the second point moves along the first frame's ``axis`` only). ``rows``: the labels of
    its rows that the model's constraints hold (:func:`closure_rows`; the others vanish
    identically and were dropped), each the position constraint named ``<name>_<label>`` with
    the Baumgarte gains ``alpha``, ``beta``."""

    name: str
    points: tuple
    kind: str = "point"
    axis: str | None = None
    rows: tuple = ()
    alpha: sp.Expr = sp.S.Zero
    beta: sp.Expr = sp.S.Zero

    def row_name(self, label: str) -> str:
        return f"{self.name}_{label}"

    def row_expression(self, label: str) -> sp.Expr:
        """The row ``label``'s expression in the point and axis symbols of the two points."""
        first, second = self.points
        r1, r2 = point_symbols(first), point_symbols(second)
        if label in AXES:
            k = AXES.index(label)
            return r2[k] - r1[k]
        if label.endswith("1"):
            e1 = axis_symbols(first, label[0])
            return sum(((b - a) * e for a, b, e in zip(r1, r2, e1)), sp.S.Zero)
        e1, e2 = axis_symbols(first, label[0]), axis_symbols(second, label[1])
        return sum((a * b for a, b in zip(e1, e2)), sp.S.Zero)

    def describe(self, label: str) -> str:
        """The row ``label`` in words, e.g. ``x_C2 - x_C1`` or ``z axis at C1 · x axis at C2``."""
        first, second = self.points
        if label in AXES:
            return f"{label}_{second} - {label}_{first}"
        if label.endswith("1"):
            return f"({second} - {first}) · {label[0]} axis at {first}"
        return f"{label[0]} axis at {first} · {label[1]} axis at {second}"

    def constraints(self, labels=None) -> tuple:
        """Its rows (``labels``, default :attr:`rows`) as position constraints."""
        return tuple(Constraint(self.row_name(label), self.row_expression(label), 0, self.alpha, self.beta)
                     for label in (self.rows if labels is None else labels))


FORCE_TYPES = ("spring-damper", "actuator")


@dataclass(frozen=True)
class ForceElement:
    """A force along the line between two points (either may be on the ground), ``points``
    ``(A, B)``: with ``d = r_B - r_A`` in {0}, its length ``L = |d|``, direction ``e = d/L`` and
    rate ``L̇ = e·(v_B - v_A)``, a force ``F`` (N) that **pushes A and B apart when positive**
    (``F e`` on B, ``-F e`` on A; negative: tension). ``kind`` "spring-damper":
    ``F = stiffness (rest_length - L) - damping L̇`` (expressions of parameters; the spring
    stores ``stiffness (L - rest_length)²/2``); "actuator": ``F = force``, a law of ``t``,
    parameters and the state as a drive's feedback law names it, never of accelerations."""

    name: str
    points: tuple
    kind: str = "spring-damper"
    stiffness: sp.Expr = sp.S.Zero
    rest_length: sp.Expr = sp.S.Zero
    damping: sp.Expr = sp.S.Zero
    force: sp.Expr = sp.S.Zero


Chain = tuple


@dataclass(frozen=True)
class Model:
    """A whole model: its parameters, chain, gravity, drives and programmed constraints.

    ``gravity`` is the gravitational acceleration vector in {0} (m/s²) as expressions;
    ``dependent`` names the dependent coordinates of the constraint partition (``None``: chosen
    automatically at run time). ``closures``: the loops closed (:class:`Closure`), whose rows
    are among ``constraints``. ``signals``: the table signals (:class:`Signal`) its drives may
    name. ``forces``: the forces between points (:class:`ForceElement`). ``controllers``: the
    controller states (:class:`Controller`) its drives may read. ``computed_torque``: a
    :class:`gpmegen.model.computed_torque.ComputedTorque` law on some coordinates, or None;
    ``task_torque``: a :class:`gpmegen.model.task_torque.TaskTorque` law, or None.
    ``start_constants``: the parameters its start sets
    (:class:`gpmegen.model.start_constants.StartConstants`), or None; left out of ``repr``, and
    so of the input hash, since the generated code does not depend on it.
    ``elements``: the entries of the element kinds registered from outside
    (:class:`gpmegen.model.elements.Element`), each adding its own terms.
    ``presentation``: how its runs are shown in figures
    (:class:`gpmegen.model.presentation.Presentation`), or None; left out of ``repr`` too: text
    for figures only, never for the generated code.
    """

    name: str
    parameters: tuple
    chain: Chain
    gravity: tuple = (0, 0, 0)
    drives: tuple = ()
    constraints: tuple = ()
    dependent: tuple | None = None
    description: str = ""
    closures: tuple = ()
    signals: tuple = ()
    forces: tuple = ()
    controllers: tuple = ()
    computed_torque: object = None
    task_torque: object = None
    elements: tuple = ()
    start_constants: object = field(default=None, repr=False)
    presentation: object = field(default=None, repr=False)

    @property
    def parameter_names(self) -> tuple[str, ...]:
        return tuple(p.name for p in self.parameters)

    @property
    def p_names(self) -> tuple[str, ...]:
        """The entries of the generated functions' vector ``p``: the parameters, then the
        controller states, whose current values the integrators put there at every stage."""
        return self.parameter_names + tuple(c.state for c in self.controllers)

    @property
    def defaults(self) -> dict[str, float]:
        return {p.name: float(p.default) for p in self.parameters}
