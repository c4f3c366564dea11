"""Forward kinematics over the model's tree, as named intermediate symbols.

For each frame the homogeneous transform ``T = [R p; 0 1]`` from the frame to {0}. For joint ``i``
the world twist ``Δ_i = T_i S_i T_i⁻¹ = [ω̂_i v_i; 0 0]`` (``S_i`` the generator of its axis), so
that ``∂T_b/∂q_i = Δ_i T_b`` for every body ``b`` that joint ``i`` supports (moves), and
``∂²T_b/∂q_i∂q_j = Δ_i Δ_j T_b`` for ``i ≤ j`` both supporting it. The body twist ``Ω = Σ Δ_j q̇_j``
and the velocity-product part of ``Ω̇`` (``Σ_j [Ω_parent(j), Δ_j] q̇_j``, i.e. ``Σ T_mn q̇_m q̇_n`` of
the paper) are built from the base outwards the same way, each joint from its parent's frame
(:mod:`gpmegen.model.topology`; a serial chain: the joint before it). A Branch element starts
again from its parent point's frame, every twist being taken at {0}'s origin.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ..model.chain import AXES, GROUND_NAME, Body, Branch, Joint, Offset, Point
from ..model.expand import FlatChain
from . import names
from .algebra import cross, mul
from .program import Program


def rotation(axis: str, c, s) -> sp.Matrix:
    """Elementary rotation about a principal axis, given its cosine and sine."""
    if axis == "x":
        return sp.Matrix([[1, 0, 0], [0, c, -s], [0, s, c]])
    if axis == "y":
        return sp.Matrix([[c, 0, s], [0, 1, 0], [-s, 0, c]])
    return sp.Matrix([[c, -s, 0], [s, c, 0], [0, 0, 1]])


def rotation_about(axis, c, s) -> sp.Matrix:
    """Rotation about a joint axis (a principal axis' letter or a unit vector ``n``), given its
    cosine and sine: Rodrigues' ``c·1 + s·[n]× + (1 - c)·n nᵀ`` for a vector."""
    if isinstance(axis, str):
        return rotation(axis, c, s)
    n = sp.Matrix(axis)
    cross = sp.Matrix([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    return c * sp.eye(3) + s * cross + (1 - c) * n * n.T


@dataclass
class JointTwist:
    """Joint ``index`` of the chain: its world twist ``(ω, v)`` and spring (to ``rest``)/damper."""

    index: int
    name: str
    kind: str
    omega: sp.Matrix
    v: sp.Matrix
    stiffness: sp.Expr
    damping: sp.Expr
    rest: sp.Expr = sp.S.Zero
    armature: sp.Expr = sp.S.Zero   # a rigidly geared motor's reflected inertia n² J_m on M's diagonal


@dataclass
class BodyState:
    """A body moved by joint ``joint`` (``-1``: fixed to the ground) and the joints that support
    it: rotation ``R``, origin ``p``, pseudo-inertia ``H`` (body frame), twist ``(w, u)`` and
    velocity-product spatial acceleration ``(alpha, a)``."""

    name: str
    joint: int
    R: sp.Matrix
    p: sp.Matrix
    H: sp.Matrix
    w: sp.Matrix
    u: sp.Matrix
    alpha: sp.Matrix
    a: sp.Matrix


@dataclass
class PointState:
    """A point moved by joint ``joint`` (``-1``: the ground): position, velocity and
    velocity-product acceleration in {0}, and the Jacobian columns ``∂position/∂q_j`` (zero for
    the joints that do not support ``joint``); the frame it is attached to: its rotation ``R``
    to {0}, angular velocity ``w`` and the velocity-product part ``alpha`` of its angular
    acceleration (what a closure's orientation rows need)."""

    name: str
    joint: int
    position: sp.Matrix
    velocity: sp.Matrix
    acceleration: sp.Matrix
    jacobian: list = field(default_factory=list)
    R: sp.Matrix | None = None
    w: sp.Matrix | None = None
    alpha: sp.Matrix | None = None


@dataclass
class Kinematics:
    chain: FlatChain
    program: Program
    q: list
    qd: list
    params: dict
    joints: list
    bodies: list
    points: dict


def coordinate_symbols(chain: FlatChain):
    """Internal symbols of ``q`` and ``q̇`` (see :mod:`.names`)."""
    q = [names.coordinate(n) for n in chain.coordinates]
    qd = [names.velocity(n) for n in chain.coordinates]
    return q, qd


def forward(chain: FlatChain, program: Program) -> Kinematics:
    """Walk the chain from the base, defining transforms, joint twists, body twists and
    velocity-product accelerations as intermediate symbols; each element starts from the frame
    of what it hangs from (the element before it, or a Branch's parent point)."""
    define, define_all = program.define, program.define_all
    q, qd = coordinate_symbols(chain)
    supports = chain.topology.supports
    zero = sp.zeros(3, 1)
    ground = (sp.eye(3), sp.zeros(3, 1), zero, zero, zero, zero, -1)
    R, p, w, u, alpha, a, current = ground   # the frame; its twist (ω, v at the origin of {0}),
    # the velocity-product part of its rate, and the joint that moves it (-1: the ground)
    joints, bodies, points, frames = [], [], {}, {}
    for element in chain.elements:
        if isinstance(element, Branch):
            R, p, w, u, alpha, a, current = ground if element.parent == GROUND_NAME else frames[element.parent]
        elif isinstance(element, Offset):
            t = sp.Matrix([sp.sympify(v) for v in element.translation])
            if any(t):
                p = define_all(p + mul(R, t))
            for axis, angle in element.rotations:
                angle = sp.sympify(angle)
                if angle != 0:
                    R = define_all(mul(R, rotation(axis, define(sp.cos(angle)), define(sp.sin(angle)))))
        elif isinstance(element, Joint):
            j = len(joints)
            # the joint's axis in {0}: a column of R for a principal axis, else R n
            if isinstance(element.axis, str):
                axis = R[:, AXES.index(element.axis)]
            else:
                axis = define_all(mul(R, sp.Matrix(element.axis)))
            if element.kind == "revolute":
                c, s = define(sp.cos(q[j])), define(sp.sin(q[j]))
                omega = axis  # the rotation leaves its own axis in place
                R = define_all(mul(R, rotation_about(element.axis, c, s)))
                v = define_all(cross(p, omega))
                # [Ω, Δ_j] for Δ_j = (ω_j, v_j): motion cross product (w, u) × (ω, v)
                d_alpha, d_a = cross(w, omega), cross(w, v) + cross(u, omega)
            else:
                omega = zero
                v = axis
                p = define_all(p + v * q[j])
                d_alpha, d_a = zero, cross(w, v)
            joints.append(JointTwist(j, element.name, element.kind, omega, v,
                                     sp.sympify(element.stiffness), sp.sympify(element.damping),
                                     sp.sympify(element.rest), element.armature))
            alpha = define_all(alpha + d_alpha * qd[j])
            a = define_all(a + d_a * qd[j])
            w = define_all(w + omega * qd[j])
            u = define_all(u + v * qd[j])
            current = j
        elif isinstance(element, Body):
            H = define_all(sp.Matrix(element.pseudo_inertia))
            bodies.append(BodyState(element.name, current, R, p, H, w, u, alpha, a))
        elif isinstance(element, Point):
            r = sp.Matrix([sp.sympify(v) for v in element.position])
            position = define_all(p + mul(R, r))
            velocity = define_all(cross(w, position) + u)
            # p̈ = Ω̇ p + Ω Ω p; its velocity-product part: α×p + a + ω×ṗ
            acceleration = define_all(cross(alpha, position) + a + cross(w, velocity))
            moving = supports[current] if current >= 0 else ()
            jac = [define_all(cross(jt.omega, position) + jt.v) if jt.index in moving else zero for jt in joints]
            jac += [zero] * (chain.n_dof - len(jac))
            points[element.name] = PointState(element.name, current, position, velocity, acceleration, jac,
                                              R, w, alpha)
            frames[element.name] = (R, position, w, u, alpha, a, current)
    params = {p.name: p.symbol for p in chain.model.parameters}
    return Kinematics(chain, program, q, qd, params, joints, bodies, points)
