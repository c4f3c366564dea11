"""Property-based agreement of generated models with the brute-force oracle on random chains.

Random ``gpmegen.model.Model``s (``random_model(seed)``, Hypothesis draws the seeds): 1-5 chain
items mixing revolute joints about x/y/z or a random unit vector, prismatic joints along them
(optionally with a spring and a damper), constant offsets (translation and up to two rotations about principal axes),
rigid bodies (primitive shapes of ``gpmegen.model.shapes``, or ``from_inertia_tensor`` with a
random physically valid inertia tensor, orientation and centre), flexible links (rectangular or
circular section, n_rfe 1-4, optional torsion constant and damping) and points; a random
gravity vector (zero, along -y, or any direction) and possibly a drive (an expression of ``t``
and a parameter) on one coordinate, flexible ones included. Quantities are plain numbers or
named parameters with random defaults, so both paths of the code generator are used.

Each model is built with ``gpmegen.load`` into a temporary folder. Its *expanded* chain
(``expand(model).elements``, flexible links already discretized by the package) is evaluated
numerically and translated into the generic chain format of ``tests/oracle.py``; the oracle
never sees the package's kinematics or dynamics, only the flat list of joints, offsets, bodies
and points. The gravity vector is handled by a constant rotation prepended to the oracle's
chain that turns -g into the oracle's +y axis (M and h do not change under a constant rotation
of the base; positions are rotated back).

Checked at random states, at the parameter defaults and again with every parameter changed at
run time (``with_params``, no rebuild): M (and that it is symmetric positive definite), the
parts of f each at its own scale (drive, velocity term, damping, gravity + springs, gravity
alone), the point positions and the energies.
"""

from __future__ import annotations

import hashlib
import math
import random
import sys
from pathlib import Path

import numpy as np
import pytest
import sympy as sp
from hypothesis import HealthCheck, Phase, assume, event, example, given, note, settings
from hypothesis import strategies as st

import gpmegen
from gpmegen.model import shapes
from gpmegen.model.chain import (
    GROUND_NAME,
    TIME,
    Body,
    Branch,
    CircularSection,
    Drive,
    FlexibleLink,
    Joint,
    Model,
    Offset,
    Parameter,
    Point,
    RectangularSection,
)
from gpmegen.model.expand import expand

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)

import oracle as ref  # noqa: E402  (tests/oracle.py)

# 60 builds of random models: a long test (make check-c)
pytestmark = pytest.mark.long

REL_TOL = 1e-10
MAX_EXAMPLES = 60
MAX_DOF = 12


# ============================================================================================
# Strategy: random models
# ============================================================================================


class _Drawer:
    """The random choices of one model, from ``random.Random(seed)``: the model is a pure
    function of its seed (``random_model(seed)`` reproduces a failure).

    Hypothesis draws the seeds. (Drawing every choice through Hypothesis was tried: with a few
    dozen examples its generator mostly re-mutates the numbers of a handful of structures, and
    shrinking, which would rebuild a model at every step, is off anyway.)

    ``quantity(lo, hi)`` is a plain number or, about half the time, a new parameter with that
    default value."""

    def __init__(self, seed):
        self.rnd = random.Random(seed)
        self.parameters: list[Parameter] = []

    def choice(self, options):
        return self.rnd.choice(list(options))

    def flip(self, p=0.5):
        return self.rnd.random() < p

    def number(self, lo, hi):
        """Uniform in [lo, hi], rounded to 6 significant digits (readable reproducers)."""
        return float(f"{self.rnd.uniform(lo, hi):.6g}")

    def quantity(self, lo, hi, param=None):
        value = self.number(lo, hi)
        if not (self.flip() if param is None else param):
            return value
        p = Parameter(f"par{len(self.parameters)}", value)
        self.parameters.append(p)
        return p.symbol


def _rotation_matrix(a, b, c):
    """A numeric rotation (z-y-x angles) as a NumPy array."""
    return ref.rotation("z", a)[:3, :3] @ ref.rotation("y", b)[:3, :3] @ ref.rotation("x", c)[:3, :3]


def _rigid_body(d: _Drawer, name):
    Q = d.quantity
    kind = d.choice(["cylinder", "bar", "rod", "point_mass", "tensor", "tensor"])
    mass = Q(0.1, 20.0)
    if kind == "cylinder":
        H = shapes.solid_cylinder(mass, Q(0.01, 0.2), Q(0.05, 1.5), d.choice("xyz"))
    elif kind == "bar":
        H = shapes.bar(mass, Q(0.05, 1.5), Q(0.005, 0.2), Q(0.005, 0.2))
    elif kind == "rod":
        H = shapes.rod(mass, Q(0.05, 1.5), Q(0.005, 0.2))
    elif kind == "point_mass":
        H = shapes.point_mass(mass, tuple(Q(-0.5, 0.5) for _ in range(3)))
    else:
        # principal second moments ∫x'², ∫y'², ∫z'² dm > 0 give principal moments of inertia
        # that satisfy the triangle inequalities; then a random orientation
        s = [d.number(1e-4, 0.5) for _ in range(3)]
        principal = np.diag([s[1] + s[2], s[0] + s[2], s[0] + s[1]])
        R = _rotation_matrix(*(d.number(-math.pi, math.pi) for _ in range(3)))
        inertia = R @ principal @ R.T
        inertia = 0.5 * (inertia + inertia.T)
        center = tuple(Q(-0.5, 0.5) for _ in range(3))
        H = shapes.from_inertia_tensor(mass, center, [[float(v) for v in row] for row in inertia])
    return Body(name, H)


def _flexible_link(d: _Drawer, label):
    Q = d.quantity
    if d.flip():
        section = RectangularSection(Q(0.005, 0.05), Q(0.002, 0.03))
    else:
        section = CircularSection(Q(0.003, 0.03))
    young = Q(1e9, 2.1e11)
    if d.flip():
        shear = young / (2 * (1 + d.number(0.2, 0.4)))  # an expression of young's parameter
    else:
        shear = Q(4e8, 8e10)
    torsion = Q(1e-11, 1e-8) if d.flip() else None
    damping = tuple(Q(0.0, 2.0) for _ in range(3)) if d.flip() else (0, 0, 0)
    return FlexibleLink(
        label=label, length=Q(0.2, 2.0), section=section, density=Q(1000.0, 8000.0),
        young_modulus=young, shear_modulus=shear, n_rfe=d.choice([1, 2, 3, 4]),
        torsion_constant=torsion, damping=damping,
    )


# "tilted": about or along a random unit vector (not a principal axis)
JOINT_TYPES = tuple((kind, axis) for kind in ("revolute", "prismatic") for axis in ("x", "y", "z", "tilted"))


def _joint(d: _Drawer, name, exclude=()):
    """A joint whose (kind, axis) differs from those in ``exclude``: two joints of the same
    kind and axis with no body between would (without a rotation between) move the same way,
    and M would be singular."""
    kind, axis = d.choice([c for c in JOINT_TYPES if c not in exclude])
    if axis == "tilted":
        v = np.array([d.number(-1.0, 1.0) for _ in range(3)]) + (0.0, 0.0, 0.1)   # never all zero
        axis = tuple(float(a) for a in v / np.linalg.norm(v))
    stiffness = d.quantity(0.0, 500.0) if d.flip(0.4) else 0
    damping = d.quantity(0.0, 5.0) if d.flip(0.4) else 0
    return Joint(name, kind, axis, stiffness, damping)


def _offset(d: _Drawer):
    translation = tuple(d.quantity(-1.0, 1.0) for _ in range(3))
    rotations = tuple((d.choice("xyz"), d.quantity(-math.pi, math.pi)) for _ in range(d.choice([0, 1, 2])))
    return Offset(translation, rotations)


def _has_joint(item):
    return isinstance(item, Joint) or (isinstance(item, FlexibleLink) and item.n_rfe > 1)


def _has_body(item):
    return isinstance(item, (Body, FlexibleLink))


def _drive_expression(d: _Drawer):
    Q = d.quantity
    a = Q(-20.0, 20.0, param=True)  # a drive always goes through a parameter
    form = d.choice(["sin", "ramp", "quintic", "exp"])
    if form == "sin":
        return a * sp.sin(Q(0.1, 10.0) * TIME + Q(-math.pi, math.pi))
    if form == "ramp":
        return a * TIME / (1 + TIME**2)
    if form == "quintic":
        s = sp.Min(TIME / Q(0.5, 5.0), 1)
        return a * s**3 * (10 - 15 * s + 6 * s**2)
    return a * (1 - sp.exp(-Q(0.1, 3.0) * TIME))


ITEM_KINDS = ("joint",) * 4 + ("flex",) * 2 + ("body",) * 2 + ("offset",) * 2 + ("point",)


def _random_chain(d: _Drawer):
    items = []
    counters = {"joint": 0, "body": 0, "flex": 0, "point": 0}
    run = set()  # (kind, axis) of the joints met since the last body

    def make(kind):
        if kind == "offset":
            return _offset(d)
        counters[kind] += 1
        k = counters[kind]
        if kind == "joint":
            joint = _joint(d, f"j{k}", run)
            run.add((joint.kind, joint.axis if isinstance(joint.axis, str) else "tilted"))
            return joint
        if kind == "point":
            return Point(f"P{k}", tuple(d.quantity(-1.0, 1.0) for _ in range(3)))
        run.clear()
        return _rigid_body(d, f"b{k}") if kind == "body" else _flexible_link(d, f"f{k}")

    for _ in range(d.choice([1, 2, 3, 3, 4, 4, 5, 5, 5])):
        # at most three joints in a row: then a body
        items.append(make("body" if len(run) >= 3 else d.choice(ITEM_KINDS)))
    # at least one joint
    if not any(_has_joint(i) for i in items):
        items.insert(d.rnd.randint(0, len(items)), make("joint"))
    # the last joint moves a body (else a row of M is zero)
    last = max(k for k, i in enumerate(items) if _has_joint(i))
    if isinstance(items[last], Joint) and not any(_has_body(i) for i in items[last + 1:]):
        items.insert(d.rnd.randint(last + 1, len(items)), make("body"))
    # often a tip point, so that most models have an end-effector
    if d.flip():
        items.append(make("point"))
    return tuple(items)


def random_model(seed: int) -> Model:
    """A random model, a pure function of ``seed`` (at most MAX_DOF coordinates)."""
    for attempt in range(100):
        d = _Drawer(seed + 2**32 * attempt)
        chain = _random_chain(d)
        g_kind = d.choice(["zero", "down", "vector", "vector"])
        if g_kind == "zero":
            gravity = (0, 0, 0)
        elif g_kind == "down":
            gravity = (0, -d.quantity(1.0, 20.0), 0)
        else:
            gravity = tuple(d.quantity(-10.0, 10.0) for _ in range(3))
        coordinates = expand(Model("probe", tuple(d.parameters), chain, gravity)).coordinates
        if len(coordinates) <= MAX_DOF:
            break
    drives = ()
    if d.flip():
        drives = (Drive(d.choice(coordinates), _drive_expression(d)),)
    parameters = tuple(d.parameters)
    key = repr((parameters, chain, gravity, drives)).encode()
    name = "rc_" + hashlib.sha256(key).hexdigest()[:16]
    return Model(name, parameters, chain, gravity, drives, description=f"random_model({seed})")


# ============================================================================================
# Adapter: expanded chain -> oracle chain
# ============================================================================================


def _num(expr, values):
    value = sp.sympify(expr).xreplace(values)
    return float(sp.N(value, 30))


def gravity_frame(gvec):
    """A rotation R0 (4x4) with (R0 r)_y = -ĝ·r, and |g|: the oracle's E_p = |g| y' equals
    -g⃗·r_C."""
    gvec = np.asarray(gvec, dtype=float)
    g = float(np.linalg.norm(gvec))
    R0 = np.eye(4)
    if g == 0.0:
        return R0, 0.0
    y = -gvec / g
    a = np.eye(3)[int(np.argmin(np.abs(y)))]
    x = a - (a @ y) * y
    x /= np.linalg.norm(x)
    z = np.cross(x, y)
    R0[:3, :3] = np.array([x, y, z])
    return R0, g


def to_oracle(model: Model, params: dict):
    """The oracle's chain for ``model`` at parameter values ``params`` (name -> float), with
    the rotation R0 prepended for the gravity vector."""
    values = {p.symbol: sp.Float(params[p.name], 30) for p in model.parameters}
    flat = expand(model)
    gvec = [_num(v, values) for v in model.gravity]
    R0, g = gravity_frame(gvec)
    steps = [ref.Fixed(R0)]
    index = {}
    for e in flat.elements:
        if isinstance(e, Offset):
            T = ref.translation(*(_num(v, values) for v in e.translation))
            for axis, angle in e.rotations:
                T = T @ ref.rotation(axis, _num(angle, values))
            steps.append(ref.Fixed(T))
        elif isinstance(e, Joint):
            index[e.name] = len(index)
            axis = e.axis if isinstance(e.axis, str) else np.array([float(a) for a in e.axis])
            steps.append(ref.Joint(e.kind, axis, index[e.name],
                                   _num(e.stiffness, values), _num(e.damping, values)))
        elif isinstance(e, Body):
            H = np.array([[_num(v, values) for v in row] for row in sp.Matrix(e.pseudo_inertia).tolist()])
            steps.append(ref.Body(e.name, H))
        elif isinstance(e, Point):
            steps.append(ref.Point(e.name, tuple(_num(v, values) for v in e.position)))
        elif isinstance(e, Branch):   # from a point, or from {0} turned as the chain's start
            steps += [ref.Branch(e.parent)] if e.parent != GROUND_NAME else [ref.Branch(None), ref.Fixed(R0)]
        else:  # pragma: no cover - expand() yields nothing else
            raise TypeError(e)
    n = len(index)
    drive_funs = []
    for d in model.drives:
        fun = sp.lambdify(TIME, sp.sympify(d.expression).xreplace(values), "math")
        drive_funs.append((index[d.coordinate], fun))

    def drive(t):
        out = np.zeros(n)
        for k, fun in drive_funs:
            out[k] += float(fun(t))
        return out

    chain = ref.Chain(steps=steps, n_dof=n, g=g, drive=drive, coordinates=tuple(index))
    return chain, R0[:3, :3]


# ============================================================================================
# Comparison
# ============================================================================================


def rel_err(a, b, scale=None):
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    scale = np.linalg.norm(b) if scale is None else scale
    if scale == 0.0:
        return float(np.linalg.norm(a - b))
    return float(np.linalg.norm(a - b) / scale)


def random_states(flat, rng, count):
    """(t, q, qd): joint angles within ±π, prismatic joints ±0.5 m, sde rotations of flexible
    links ±0.25 rad, velocities ±2."""
    explicit = {e.name for e in flat.model.chain if isinstance(e, Joint)}
    joints = [e for e in flat.elements if isinstance(e, Joint)]
    out = []
    for _ in range(count):
        q = np.array([
            rng.uniform(-0.5, 0.5) if e.kind == "prismatic"
            else rng.uniform(-math.pi, math.pi) if e.name in explicit
            else rng.uniform(-0.25, 0.25)
            for e in joints
        ])
        qd = rng.uniform(-2.0, 2.0, len(joints))
        out.append((float(rng.uniform(0.0, 6.0)), q, qd))
    return out


def check_agreement(loaded, chain, R0, states):
    """Everything the package computes against the oracle at ``states``."""
    n = chain.n_dof
    zero = np.zeros(n)
    C, D = chain.stiffness(), chain.damping()
    sprung = np.diag(C) != 0
    for t, q, qd in states:
        note(f"t={t!r}, q={q.tolist()!r}, qd={qd.tolist()!r}")
        # ---- mass matrix, symmetric positive definite -------------------------------------
        M = np.asarray(loaded.mass_matrix(q), dtype=float)
        M_ref = chain.mass_matrix(q)
        assert M.shape == (n, n)
        assert rel_err(M, M_ref) < REL_TOL, (M, M_ref)
        np.testing.assert_allclose(M, M.T, rtol=0, atol=1e-13 * np.abs(M).max())
        np.linalg.cholesky(0.5 * (M + M.T))
        assert np.linalg.eigvalsh(0.5 * (M + M.T)).min() > 0.0

        # ---- f by parts, each at its own scale --------------------------------------------
        def f(t_, q_, qd_):
            return np.asarray(loaded.forces(t_, q_, qd_), dtype=float)

        h_ref, g_ref, Q_ref = chain.velocity_term(q, qd), chain.gravity(q), chain.Q(t)
        Cq, Dqd = C @ q, D @ qd
        # ||f|| may be dominated by stiff springs: each part is compared on its own scale, with
        # a floor of 1e-4 of the whole, and a round-off floor on the scale of the bodies'
        # pseudo-inertias in {0} (a part that vanishes, e.g. h of a single rotor, is computed
        # from terms of that size): parts that vanish are not compared to round-off alone
        inertia = sum(np.linalg.norm(T @ H @ T.T) for _, H, T, _, _ in chain.bodies(q))
        roundoff = 1e-5 * inertia * (1.0 + qd @ qd + chain.g)
        total = sum(np.linalg.norm(v) for v in (Q_ref, h_ref, g_ref, Cq, Dqd))

        def part(a, b):
            return rel_err(a, b, np.linalg.norm(b) + 1e-4 * total + roundoff)

        total += roundoff

        f_full = f(t, q, qd)
        assert f_full.shape == (n,)
        f_ref = chain.forces(t, q, qd)
        assert rel_err(f_full, f_ref, total) < REL_TOL, (f_full, f_ref)
        # velocity term (even in qd) and damping (odd in qd), separated with the package alone
        f_minus, f_rest = f(t, q, -qd), f(t, q, zero)
        assert part(0.5 * (f_full + f_minus) - f_rest, h_ref) < REL_TOL, "velocity term"
        assert part(0.5 * (f_full - f_minus), -Dqd) < REL_TOL, "damping"
        # drive
        Q_pkg = np.asarray(loaded.drive_forces(t, q, qd), dtype=float)
        assert part(Q_pkg, Q_ref) < REL_TOL, ("drive", Q_pkg, Q_ref)
        # gravity + springs, and gravity alone where no spring is stretched
        assert part(f_rest - Q_pkg, -(g_ref + Cq)) < REL_TOL, "gravity + springs"
        assert part(loaded.static_residual(q), g_ref + Cq) < REL_TOL, "static residual"
        q0 = np.where(sprung, 0.0, q)
        g0_ref = chain.gravity(q0)
        assert rel_err(loaded.static_residual(q0), g0_ref,
                       np.linalg.norm(g0_ref) + 1e-4 * np.linalg.norm(g_ref) + roundoff) < REL_TOL, "gravity"

        # ---- points -------------------------------------------------------------------------
        if loaded.points:
            P = np.asarray(loaded.point_positions(q), dtype=float)
            P_ref = np.array([R0.T @ chain.point(name, q) for name in loaded.points])
            assert P.shape == P_ref.shape
            np.testing.assert_allclose(P, P_ref, rtol=0, atol=1e-12 * (1.0 + np.abs(P_ref).max()))
            np.testing.assert_allclose(loaded.end_effector(q), P_ref[0], rtol=0,
                                       atol=1e-12 * (1.0 + np.abs(P_ref).max()))

        # ---- energies -------------------------------------------------------------------------
        K, V, S = (float(v) for v in loaded.energies(q, qd))
        K_ref = chain.kinetic_energy(q, qd)
        V_ref = chain.gravity_energy(q)
        S_ref = chain.spring_energy(q)
        assert abs(K - K_ref) <= REL_TOL * abs(K_ref) + 1e-300
        # E_p = -g⃗·Σ m r_C can cancel to ~0: compare on the scale of its terms
        V_scale = chain.g * sum(np.linalg.norm((T @ H)[:, 3]) for _, H, T, _, _ in chain.bodies(q))
        assert abs(V - V_ref) <= REL_TOL * V_scale + 1e-300
        assert abs(S - S_ref) <= REL_TOL * abs(S_ref) + 1e-300


# ============================================================================================
# The property
# ============================================================================================


@pytest.fixture(scope="module")
def build_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("random_chains")


def _oracle_mass_matrix_is_regular(chain, states):
    """Degenerate draws (two coincident joint axes with no body between, a point mass on a
    revolute axis, ...) have a singular M: skip them before paying for a build."""
    for _, q, _ in states:
        w = np.linalg.eigvalsh(chain.mass_matrix(q))
        if not w.min() > 1e-9 * w.max():
            return False
    return True


@settings(
    max_examples=MAX_EXAMPLES,
    deadline=None,
    derandomize=True,
    database=None,
    # no shrinking: every step of it is a build (~1 s); a failure prints its whole model
    # (note) and the failing state, which is reproducer enough
    phases=[Phase.explicit, Phase.generate],
    suppress_health_check=[HealthCheck.too_slow, HealthCheck.data_too_large,
                           HealthCheck.filter_too_much, HealthCheck.function_scoped_fixture],
)
@given(model_seed=st.integers(0, 2**32 - 1), state_seed=st.integers(0, 2**32 - 1))
@example(model_seed=10, state_seed=1)  # one joint, any gravity vector, a point
@example(model_seed=12, state_seed=2)  # two flexible links, a joint, a drive, gravity along -y: 7 dof
@example(model_seed=35, state_seed=3)  # a flexible link, three joints (one tilted), a drive: 12 dof
def test_random_chain_agrees_with_oracle(build_dir, model_seed, state_seed):
    model = random_model(model_seed)
    note(repr(model))
    flat = expand(model)
    rng = np.random.default_rng(state_seed)
    states = random_states(flat, rng, 3)
    chain, R0 = to_oracle(model, model.defaults)
    assume(_oracle_mass_matrix_is_regular(chain, states))
    event(f"n_dof {flat.n_dof if flat.n_dof < 4 else '4-7' if flat.n_dof < 8 else '8-12'}")
    event(f"flexible links {sum(isinstance(e, FlexibleLink) for e in model.chain)}")
    event(f"parameters {'0' if not model.parameters else '1-4' if len(model.parameters) < 5 else '5+'}")
    event(f"gravity {'zero' if not any(model.gravity) else 'vector'}")
    event(f"points {len(flat.points)}")
    event(f"drive {bool(model.drives)}")

    loaded = gpmegen.load(model=model, directory=build_dir, backend="numpy")
    assert loaded.coordinates == flat.coordinates
    assert loaded.points == flat.points
    assert loaded.parameter_names == model.parameter_names
    check_agreement(loaded, chain, R0, states)

    # The parameter path: change every parameter at run time (no rebuild). Factors within
    # [0.8, 1.25] keep masses, lengths and moduli physically valid.
    if model.parameters:
        overrides = {p.name: p.default * rng.uniform(0.8, 1.25) for p in model.parameters}
        changed = loaded.with_params(**overrides)
        chain2, R02 = to_oracle(model, {**model.defaults, **overrides})
        check_agreement(changed, chain2, R02, states[:1])
