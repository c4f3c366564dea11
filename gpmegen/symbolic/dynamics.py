"""Mass matrix, velocity terms, gravity, springs, dampers, drives and the stiffness Jacobian
by composite bodies over the model's tree (Lagrange's equations in the paper's notation).

With the world pseudo-inertia of body ``b``, ``J_b = T_b H_b T_bᵀ = [[Σ, c], [cᵀ, m]]``
(``Σ = ∫ r rᵀ dm``, ``c = m r_C`` in {0}) and the world inertia tensor ``I = tr(Σ)·1 - Σ``:

- ``m_ij = Σ_b tr(T_i H T_jᵀ) = tr(Δ_i J^c_j Δ_jᵀ) = ω_i·n_j + v_i·l_j`` for ``i`` supporting
  ``j`` (an ancestor of ``j`` or ``j`` itself, :mod:`gpmegen.model.topology`), with
  ``(n_j, l_j) = (I^c ω_j + c^c × v_j,  m^c v_j + ω_j × c^c)`` of the composite ``J^c_j`` of
  the bodies joint ``j`` moves: its own and its children's composites (composite-rigid-body
  algorithm); ``m_ij = 0`` when neither joint supports the other, as no body moves with both;
- ``h_i = -Σ_b Σ_m Σ_n tr(T_i H T_mnᵀ) q̇_m q̇_n = -S_i·F_i`` with ``F_i`` the sum over
  bodies joint ``i`` moves of ``I_b a_b + V_b ×* I_b V_b`` (rate of momentum at ``q̈ = 0``);
- a geared motor on joint ``i`` adds its reflected inertia ``n² J_m`` to ``m_ii`` (Spong's
  model: the rotor's kinetic energy is ``n² J_m q̇_i² / 2``, its gyroscopic coupling with the
  links neglected); a series-elastic joint's motor is a coordinate of its own moving no body,
  whose only entry of ``M`` is that inertia, tied to the joint by a spring and damper;
- ``g_i = ∂E_p/∂q_i = -g⃗·l_i``, ``E_p = -g⃗·Σ c_b``;
- stiffness Jacobian ``K_ij = ∂(g + C q)_i/∂q_j = -g⃗·(ω_i × l_j) + C_ij`` for ``i`` supporting
  ``j`` (from ``T_ij = Δ_i Δ_j T``), symmetric, zero where ``m_ij`` is, but for the springs of
  force elements between points (:mod:`.forces`), which may couple joints of two branches.

In a serial chain joint ``i`` supports every later joint, and the sums run over ``j ≥ i``.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..model.topology import GROUND
from . import elements as _elements
from . import forces as _forces
from .algebra import cross, dot, mul
from .constraints import state_expressions
from .kinematics import Kinematics


@dataclass
class Dynamics:
    """Outputs of the dynamics as expressions of intermediate symbols; shapes in brackets."""

    mass_matrix: sp.Matrix        # (n, n)
    velocity_terms: sp.Matrix     # h (n,)
    gravity_terms: sp.Matrix      # g (n,)
    spring_forces: sp.Matrix      # C q (n,)
    damping_forces: sp.Matrix     # (n,)
    drive_forces: sp.Matrix       # Q(t, q, q̇) (n,): the drives' laws, feedback included
    stiffness_jacobian: sp.Matrix  # ∂(g + C q)/∂q (n, n), drives off
    potential_energy: sp.Expr     # gravity part, J
    spring_energy: sp.Expr        # J
    columns: tuple = ()           # (n_j, l_j) per joint: m_ij = ω_i·n_j + v_i·l_j for i supporting j
    bodies: tuple = ()            # (joint, m, c, I, n, l) per body: the joint that moves it (-1: the
                                  # ground), mass, first moment and inertia about {0}'s origin, rate of
                                  # momentum at q̈ = 0 (torque n about the origin, force l)
    elements: _forces.ForceTerms | None = None  # the force elements' terms, already in the slots above
    limited: tuple = ()           # (coordinate, law before the clip, limit) per drive with a limit

    def mass_product(self, kin: Kinematics, a: sp.Matrix, define_all) -> sp.Matrix:
        """``M a`` (n,) for a vector ``a`` (n,) of expressions, in O(n) intermediates:
        ``(M a)_i = ω_i·Σ_{j∈sub(i)} a_j n_j + v_i·Σ_{j∈sub(i)} a_j l_j + n_i·Σ_{j∈anc(i)} a_j ω_j
        + l_i·Σ_{j∈anc(i)} a_j v_j`` with ``sub(i)`` the subtree of joint ``i`` (itself included)
        and ``anc(i)`` its ancestors (the columns of M where ``i`` supports ``j``, the rows
        where ``j`` supports ``i`` by symmetry); each sum is its children's or parent's plus one
        term."""
        n = len(self.columns)
        topology = kin.chain.topology
        after_n, after_l = [None] * n, [None] * n
        for j in reversed(range(n)):
            n_j, l_j = self.columns[j]
            sum_n, sum_l = _sum([after_n[c] for c in topology.children[j]], define_all), \
                _sum([after_l[c] for c in topology.children[j]], define_all)
            after_n[j], after_l[j] = define_all(sum_n + a[j] * n_j), define_all(sum_l + a[j] * l_j)
        product = []
        passed_w, passed_v = [None] * n, [None] * n   # Σ a_k ω_k (v_k) over joint i's supports
        for i, ji in enumerate(kin.joints):
            n_i, l_i = self.columns[i]
            parent = topology.parent[i]
            if parent == GROUND:
                sum_w, sum_v = sp.zeros(3, 1), sp.zeros(3, 1)
            else:
                sum_w, sum_v = passed_w[parent], passed_v[parent]
            product.append(dot(ji.omega, after_n[i]) + dot(ji.v, after_l[i]) + dot(n_i, sum_w) + dot(l_i, sum_v)
                           + ji.armature * a[i])
            passed_w[i], passed_v[i] = define_all(sum_w + a[i] * ji.omega), define_all(sum_v + a[i] * ji.v)
        return sp.Matrix(n, 1, product)

    @property
    def forces(self) -> sp.Matrix:
        """``f = Q + h - g - C q - D q̇`` (n,)."""
        return self.drive_forces + self.velocity_terms - self.gravity_terms - self.spring_forces - self.damping_forces


def _sum(vectors, define_all):
    """The sum of 3-vectors (zero for none), each partial sum after the first named once."""
    if not vectors:
        return sp.zeros(3, 1)
    total = vectors[0]
    for v in vectors[1:]:
        total = define_all(total + v)
    return total


def _world_inertia(body, define_all):
    """(m, c, I) of a body in {0}: mass, first moment and inertia tensor about the origin."""
    R, p, H = body.R, body.p, body.H
    m = H[3, 3]
    hc = H[0:3, 3]
    sigma_body = H[0:3, 0:3]
    c = define_all(mul(R, hc) + m * p)
    rh = mul(R, hc)
    sigma = mul(mul(R, sigma_body), R.T) + mul(rh, p.T) + mul(p, rh.T) + mul(m * p, p.T)
    sigma = define_all(sigma)
    inertia = sp.eye(3) * (sigma[0, 0] + sigma[1, 1] + sigma[2, 2]) - sigma
    inertia = define_all(inertia)
    return m, c, inertia


def _apply(m, c, inertia, w, u):
    """Spatial inertia times twist: (I ω + c × v, m v + ω × c)."""
    return mul(inertia, w) + cross(c, u), m * u + cross(w, c)


def _add_composite(total, part, define, define_all):
    """``total + part`` of two (m, c, I, n, l) composites, each sum named."""
    m, c, inertia, torque, force = part
    return (define(total[0] + m), define_all(total[1] + c), define_all(total[2] + inertia),
            define_all(total[3] + torque), define_all(total[4] + force))


def derive(kin: Kinematics, gravity, drives, forces=(), registered=()) -> Dynamics:
    """Dynamics of the chain whose kinematics is ``kin``; ``gravity`` is the vector g⃗ in {0}
    (expressions), ``drives`` a sequence of Drive, ``forces`` of ForceElement
    (:mod:`.forces`: their springs join the joints' springs, their dampers and actuators the
    drives), ``registered`` the elements of registered kinds (:mod:`.elements`: the same slots)."""
    program = kin.program
    define, define_all = program.define, program.define_all
    n = len(kin.joints)
    gvec = sp.Matrix([sp.sympify(v) for v in gravity])

    # Body quantities: world inertia and the velocity-product rate of momentum.
    per_body = []
    for body in kin.bodies:
        m, c, inertia = _world_inertia(body, define_all)
        n_w, l_w = _apply(m, c, inertia, body.w, body.u)
        n_w, l_w = define_all(n_w), define_all(l_w)
        n_a, l_a = _apply(m, c, inertia, body.alpha, body.a)
        # (ω, v) ×* (n, l) = (ω × n + v × l, ω × l)
        torque = define_all(n_a + cross(body.w, n_w) + cross(body.u, l_w))
        force = define_all(l_a + cross(body.w, l_w))
        per_body.append((body.joint, m, c, inertia, torque, force))

    # Composites, from the tips back: joint j moves its own bodies and its children's composites.
    topology = kin.chain.topology
    zero = sp.zeros(3, 1)
    composite = [None] * n
    bodies_of = {}
    for joint, *rest in per_body:
        bodies_of.setdefault(joint, []).append(rest)
    for j in reversed(range(n)):
        parts = [composite[c] for c in topology.children[j]]
        comp_m, comp_c, comp_i, comp_n, comp_f = parts[0] if parts else (sp.S.Zero, zero, sp.zeros(3, 3), zero, zero)
        for part in parts[1:]:
            comp_m, comp_c, comp_i, comp_n, comp_f = _add_composite((comp_m, comp_c, comp_i, comp_n, comp_f), part,
                                                                    define, define_all)
        for body in bodies_of.get(j, []):
            comp_m, comp_c, comp_i, comp_n, comp_f = _add_composite((comp_m, comp_c, comp_i, comp_n, comp_f), body,
                                                                    define, define_all)
        composite[j] = (comp_m, comp_c, comp_i, comp_n, comp_f)
    # Each body enters once, at the joint that moves it, and stays in the composite of every joint
    # that supports that one; bodies fixed to the ground never move and enter no term.

    M = sp.zeros(n, n)
    K = sp.zeros(n, n)
    h = sp.zeros(n, 1)
    grav = sp.zeros(n, 1)
    columns = []
    for j, jt in enumerate(kin.joints):
        m_c, c_c, i_c, n_c, f_c = composite[j]
        n_j, l_j = _apply(m_c, c_c, i_c, jt.omega, jt.v)
        columns.append((define_all(n_j), define_all(l_j)))
        h[j] = define(-(dot(jt.omega, n_c) + dot(jt.v, f_c)))
        grav[j] = define(-dot(gvec, columns[j][1]))
    for j in range(n):
        n_j, l_j = columns[j]
        for i in topology.supports[j]:   # ascending, as range(j + 1) in a serial chain
            ji = kin.joints[i]
            motor = ji.armature if i == j else sp.S.Zero
            M[i, j] = M[j, i] = define(dot(ji.omega, n_j) + dot(ji.v, l_j) + motor)
            if any(gvec):
                K[i, j] = K[j, i] = define(-dot(gvec, cross(ji.omega, l_j)))

    spring = sp.Matrix([jt.stiffness * (kin.q[j] - jt.rest) for j, jt in enumerate(kin.joints)])
    damping = sp.Matrix([jt.damping * kin.qd[j] for j, jt in enumerate(kin.joints)])
    for j, jt in enumerate(kin.joints):
        K[j, j] = K[j, j] + jt.stiffness
    spring_energy = sum((jt.stiffness * (kin.q[j] - jt.rest) ** 2 / 2 for j, jt in enumerate(kin.joints)), sp.S.Zero)
    for c in kin.chain.couplings:   # series-elastic joints: k (q - θ) on the joint, its opposite on the motor
        stretch, rate = kin.q[c.joint] - kin.q[c.motor], kin.qd[c.joint] - kin.qd[c.motor]
        spring[c.joint] += c.stiffness * stretch
        spring[c.motor] -= c.stiffness * stretch
        damping[c.joint] += c.damping * rate
        damping[c.motor] -= c.damping * rate
        for a, b in ((c.joint, c.joint), (c.motor, c.motor)):
            K[a, b] += c.stiffness
        for a, b in ((c.joint, c.motor), (c.motor, c.joint)):
            K[a, b] -= c.stiffness
        spring_energy += c.stiffness * stretch ** 2 / 2
    index = {jt.name: j for j, jt in enumerate(kin.joints)}
    drive = sp.zeros(n, 1)
    laws = state_expressions(kin, [d.expression for d in drives])   # feedback laws name the state
    for d, law in zip(drives, laws):
        drive[index[d.coordinate]] += d.applied(law)
    limited = tuple((d.coordinate, law, sp.sympify(d.limit)) for d, law in zip(drives, laws) if d.limit is not None)

    potential = -sum((dot(gvec, c) for _, _, c, *_ in per_body), sp.S.Zero)
    elements = None
    if forces:
        elements = _forces.derive(kin, forces)
        spring, drive, K = spring + elements.spring, drive + elements.applied, K + elements.stiffness
        spring_energy += elements.potential
    if registered:
        terms = _elements.derive(kin, registered)
        spring, drive, K = spring + terms.spring, drive + terms.applied, K + terms.stiffness
        spring_energy += terms.potential
    return Dynamics(M, h, grav, spring, damping, drive, K, potential, spring_energy, tuple(columns), tuple(per_body),
                    elements, limited)
