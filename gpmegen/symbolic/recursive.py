"""What the articulated-body recursion of the C backend (``templates/recursive.c.j2``) reads, as
expressions of intermediate symbols: the tree's joints and links in ground coordinates.

Everything is a spatial vector in {0}, angular part first, the linear part taken at {0}'s
origin (Plücker coordinates), so no transform between links is needed. Link ``j`` holds the
bodies that joint ``j`` moves directly (the joint that moves them, :mod:`gpmegen.model.topology`;
none for the massless frames between joints), and hangs from link ``parent[j]``; bodies fixed to
the ground never move and enter no link. Per joint or link:

- the axis ``S_j = (ω_j, v_j)`` of joint ``j``, its world twist (:class:`.kinematics.JointTwist`;
  ``(0, axis)`` for a prismatic joint);
- the spatial inertia ``[[I_O, [c]×], [[c]×ᵀ, m 1]]`` of link ``j`` about the origin, ``c = m r_C``,
  as the 10 numbers ``m, c, I_O`` (:data:`LINK`);
- its bias force ``b_j = I_j (a_j⁰ - (0, g⃗)) + V_j ×* I_j V_j``: the rate of momentum of the
  link at ``q̈ = 0`` (``a_j⁰`` the velocity-product part of its spatial acceleration, as
  :mod:`.dynamics` forms it for ``h``) plus its weight, as a force ``(n, f)``;
- the joint forces ``τ = Q(t, q, q̇) - C q - D q̇`` (drives, springs, dampers);
- the armature of each joint, a geared motor's reflected inertia ``n² J_m``, which adds to the
  joint's pivot ``d_j = S_jᵀ I^A_j S_j + n² J_m`` (Featherstone's rotor inertia: it adds to
  ``M``'s diagonal entry alone), only in a model with motors.

With the link accelerations ``a_j = a_j⁰ - (0, g⃗) + Σ_{k supporting j} S_k q̈_k`` the link forces
are ``I_j Σ_{k supporting j} S_k q̈_k + b_j``, so the recursion works on ``q̈`` alone, from a base at rest:
it needs O(n) of these numbers where ``M`` has O(n²) entries, and never projects the bias
forces onto the joints as ``f`` does.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..model.topology import GROUND
from .dynamics import Dynamics
from .kinematics import Kinematics

#: The 10 numbers of a link's spatial inertia, in order: mass, first moment ``c = m r_C`` and
#: the upper triangle of the inertia tensor about the origin of {0}.
LINK = ("m", "cx", "cy", "cz", "Ixx", "Ixy", "Ixz", "Iyy", "Iyz", "Izz")


@dataclass
class RecursiveTerms:
    """Shapes in brackets: ``axes`` (n, 6), ``links`` (n, 10), ``bias`` (n, 6), ``joint_forces``
    (n,); ``massive``: per link, whether it holds a body (n,), and ``parent``: per link, the link
    it hangs from (n,; -1: the ground), both known when the code is generated; ``armature``
    (n,): each joint's motor inertia, None in a model without motors."""

    axes: sp.Matrix
    links: sp.Matrix
    bias: sp.Matrix
    joint_forces: sp.Matrix
    massive: tuple
    parent: tuple
    armature: sp.Matrix | None = None


def derive(kin: Kinematics, dyn: Dynamics, gravity) -> RecursiveTerms:
    """The recursion's inputs for the chain of ``kin`` with dynamics ``dyn``; ``gravity``: g⃗ in
    {0} (expressions)."""
    define = kin.program.define
    n = len(kin.joints)
    g = sp.Matrix([sp.sympify(v) for v in gravity])
    axes = sp.Matrix(n, 6, [v for jt in kin.joints for v in (*jt.omega, *jt.v)])
    links, bias = sp.zeros(n, len(LINK)), sp.zeros(n, 6)
    massive = [False] * n
    for joint, m, c, inertia, torque, force in dyn.bodies:
        if joint != GROUND:
            links[joint, :] += sp.Matrix([[m, *c, *(inertia[i, k] for i in range(3) for k in range(i, 3))]])
            # its weight as a bias: I (0, -g) = (-c × g, -m g)
            bias[joint, :] += sp.Matrix([[*(torque - c.cross(g)), *(force - m * g)]])
            massive[joint] = True
    armature = sp.Matrix([jt.armature for jt in kin.joints])
    # a link of several bodies: their sums, each named once
    return RecursiveTerms(axes, links.applyfunc(define), bias.applyfunc(define),
                          (dyn.drive_forces - dyn.spring_forces - dyn.damping_forces).applyfunc(define),
                          tuple(massive), kin.chain.topology.parent, armature if any(armature) else None)
