"""Mass matrix, velocity terms, gravity, springs, dampers, drives and the stiffness Jacobian
by composite bodies along the chain (Lagrange's equations in the paper's notation).

With the world pseudo-inertia of body ``b``, ``J_b = T_b H_b T_bᵀ = [[Σ, c], [cᵀ, m]]``
(``Σ = ∫ r rᵀ dm``, ``c = m r_C`` in {0}) and the world inertia tensor ``I = tr(Σ)·1 - Σ``:

- ``m_ij = Σ_b tr(T_i H T_jᵀ) = tr(Δ_i J^c_j Δ_jᵀ) = ω_i·n_j + v_i·l_j`` for ``i ≤ j``, with
  ``(n_j, l_j) = (I^c ω_j + c^c × v_j,  m^c v_j + ω_j × c^c)`` of the composite ``J^c_j`` of
  all bodies after joint ``j`` (composite-rigid-body algorithm);
- ``h_i = -Σ_b Σ_m Σ_n tr(T_i H T_mnᵀ) q̇_m q̇_n = -S_i·F_i`` with ``F_i`` the sum over
  bodies after ``i`` of ``I_b a_b + V_b ×* I_b V_b`` (rate of momentum at ``q̈ = 0``);
- ``g_i = ∂E_p/∂q_i = -g⃗·l_i``, ``E_p = -g⃗·Σ c_b``;
- stiffness Jacobian ``K_ij = ∂(g + C q)_i/∂q_j = -g⃗·(ω_i × l_j) + C_ij`` for ``i ≤ j``
  (from ``T_ij = Δ_i Δ_j T``), symmetric.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from .kinematics import Kinematics


@dataclass
class Dynamics:
    """Outputs of the dynamics as expressions of intermediate symbols; shapes in brackets."""

    mass_matrix: sp.Matrix        # (n, n)
    velocity_terms: sp.Matrix     # h (n,)
    gravity_terms: sp.Matrix      # g (n,)
    spring_forces: sp.Matrix      # C q (n,)
    damping_forces: sp.Matrix     # (n,)
    drive_forces: sp.Matrix       # Q(t) (n,)
    stiffness_jacobian: sp.Matrix  # ∂(g + C q - Q)/∂q (n, n)
    potential_energy: sp.Expr     # gravity part, J
    spring_energy: sp.Expr        # J
    columns: tuple = ()           # (n_j, l_j) per joint: m_ij = ω_i·n_j + v_i·l_j for i ≤ j
    bodies: tuple = ()            # (level, m, c, I, n, l) per body: mass, first moment and inertia about {0}'s
                                  # origin, rate of momentum at q̈ = 0 (torque n about the origin, force l)

    def mass_product(self, kin: Kinematics, a: sp.Matrix, define_all) -> sp.Matrix:
        """``M a`` (n,) for a vector ``a`` (n,) of expressions, in O(n) intermediates:
        ``(M a)_i = ω_i·Σ_{j≥i} a_j n_j + v_i·Σ_{j≥i} a_j l_j + n_i·Σ_{j<i} a_j ω_j + l_i·Σ_{j<i} a_j v_j``
        (the upper triangle of M by columns, the lower one by symmetry)."""
        n = len(self.columns)
        after_n, after_l = [None] * n, [None] * n
        sum_n, sum_l = sp.zeros(3, 1), sp.zeros(3, 1)
        for j in reversed(range(n)):
            n_j, l_j = self.columns[j]
            sum_n, sum_l = define_all(sum_n + a[j] * n_j), define_all(sum_l + a[j] * l_j)
            after_n[j], after_l[j] = sum_n, sum_l
        product = []
        sum_w, sum_v = sp.zeros(3, 1), sp.zeros(3, 1)
        for i, ji in enumerate(kin.joints):
            n_i, l_i = self.columns[i]
            product.append(ji.omega.dot(after_n[i]) + ji.v.dot(after_l[i]) + n_i.dot(sum_w) + l_i.dot(sum_v))
            sum_w, sum_v = define_all(sum_w + a[i] * ji.omega), define_all(sum_v + a[i] * ji.v)
        return sp.Matrix(n, 1, product)

    @property
    def forces(self) -> sp.Matrix:
        """``f = Q + h - g - C q - D q̇`` (n,)."""
        return self.drive_forces + self.velocity_terms - self.gravity_terms - self.spring_forces - self.damping_forces


def _world_inertia(body, define_all):
    """(m, c, I) of a body in {0}: mass, first moment and inertia tensor about the origin."""
    R, p, H = body.R, body.p, body.H
    m = H[3, 3]
    hc = H[0:3, 3]
    sigma_body = H[0:3, 0:3]
    c = define_all(R * hc + m * p)
    rh = R * hc
    sigma = R * sigma_body * R.T + rh * p.T + p * rh.T + m * p * p.T
    sigma = define_all(sigma)
    inertia = sp.eye(3) * (sigma[0, 0] + sigma[1, 1] + sigma[2, 2]) - sigma
    inertia = define_all(inertia)
    return m, c, inertia


def _apply(m, c, inertia, w, u):
    """Spatial inertia times twist: (I ω + c × v, m v + ω × c)."""
    return inertia * w + c.cross(u), m * u + w.cross(c)


def derive(kin: Kinematics, gravity, drives) -> Dynamics:
    """Dynamics of the chain whose kinematics is ``kin``; ``gravity`` is the vector g⃗ in {0}
    (expressions), ``drives`` a sequence of Drive."""
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
        torque = define_all(n_a + body.w.cross(n_w) + body.u.cross(l_w))
        force = define_all(l_a + body.w.cross(l_w))
        per_body.append((body.level, m, c, inertia, torque, force))

    # Composites, from the tip back: after joint j are the bodies with level > j.
    zero = sp.zeros(3, 1)
    comp_m, comp_c, comp_i = sp.S.Zero, zero, sp.zeros(3, 3)
    comp_n, comp_f = zero, zero
    composite = [None] * n
    bodies_by_level = {}
    for level, *rest in per_body:
        bodies_by_level.setdefault(level, []).append(rest)
    for j in reversed(range(n)):
        for m, c, inertia, torque, force in bodies_by_level.get(j + 1, []):
            comp_m = define(comp_m + m)
            comp_c = define_all(comp_c + c)
            comp_i = define_all(comp_i + inertia)
            comp_n = define_all(comp_n + torque)
            comp_f = define_all(comp_f + force)
        composite[j] = (comp_m, comp_c, comp_i, comp_n, comp_f)
    # Each body enters once, at j = level - 1, and stays in every composite nearer the base;
    # bodies before the first joint (level 0) never move and enter no term.

    M = sp.zeros(n, n)
    K = sp.zeros(n, n)
    h = sp.zeros(n, 1)
    grav = sp.zeros(n, 1)
    columns = []
    for j, jt in enumerate(kin.joints):
        m_c, c_c, i_c, n_c, f_c = composite[j]
        n_j, l_j = _apply(m_c, c_c, i_c, jt.omega, jt.v)
        columns.append((define_all(n_j), define_all(l_j)))
        h[j] = define(-(jt.omega.dot(n_c) + jt.v.dot(f_c)))
        grav[j] = define(-gvec.dot(columns[j][1]))
    for j in range(n):
        n_j, l_j = columns[j]
        for i in range(j + 1):
            ji = kin.joints[i]
            M[i, j] = M[j, i] = define(ji.omega.dot(n_j) + ji.v.dot(l_j))
            if any(gvec):
                K[i, j] = K[j, i] = define(-gvec.dot(ji.omega.cross(l_j)))

    spring = sp.Matrix([jt.stiffness * (kin.q[j] - jt.rest) for j, jt in enumerate(kin.joints)])
    damping = sp.Matrix([jt.damping * kin.qd[j] for j, jt in enumerate(kin.joints)])
    for j, jt in enumerate(kin.joints):
        K[j, j] = K[j, j] + jt.stiffness
    index = {jt.name: j for j, jt in enumerate(kin.joints)}
    drive = sp.zeros(n, 1)
    for d in drives:
        drive[index[d.coordinate]] += sp.sympify(d.expression)

    potential = -sum((gvec.dot(c) for _, _, c, *_ in per_body), sp.S.Zero)
    spring_energy = sum((jt.stiffness * (kin.q[j] - jt.rest) ** 2 / 2 for j, jt in enumerate(kin.joints)), sp.S.Zero)
    return Dynamics(M, h, grav, spring, damping, drive, K, potential, spring_energy, tuple(columns), tuple(per_body))
