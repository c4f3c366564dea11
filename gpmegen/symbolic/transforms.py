"""The body transforms ``T`` of the paper and their derivatives ``T_i = ∂T/∂q_i``,
``T_ij = ∂²T/∂q_i∂q_j``, from the world twists of :func:`gpmegen.symbolic.kinematics.forward`.

A body moves with the joints that support the joint moving it only
(:mod:`gpmegen.model.topology`): ``T_i = Δ_i T`` for ``i`` among them and ``T_ij = Δ_i Δ_j T``
for ``i ≤ j`` both among them (the later joint's twist acts first, since ``Δ_j`` depends on
``q_i`` and not the other way round); both vanish otherwise and ``T_ij`` is symmetric in
``i, j``. In a serial chain these are the joints before the body.
"""

from __future__ import annotations

import sympy as sp

from .kinematics import BodyState, JointTwist, Kinematics

#: The transforms a build can generate, in the order of their functions; ``T`` alone by default.
KINDS = ("T", "T_i", "T_ij")
DEFAULT = ("T",)

_BOTTOM = sp.Matrix([[0, 0, 0, 1]])


def twist_matrix(joint: JointTwist) -> sp.Matrix:
    """``Δ = [ω̂ v; 0 0]`` (4x4) of a joint's world twist."""
    w, v = joint.omega, joint.v
    hat = sp.Matrix([[0, -w[2], w[1]], [w[2], 0, -w[0]], [-w[1], w[0], 0]])
    return sp.Matrix.vstack(sp.Matrix.hstack(hat, v), sp.zeros(1, 4))


def transform(body: BodyState) -> sp.Matrix:
    """``T = [R p; 0 1]`` (4x4) from the body's frame to {0}."""
    return sp.Matrix.vstack(sp.Matrix.hstack(body.R, body.p), _BOTTOM)


def first_derivatives(kin: Kinematics) -> list[list[sp.Matrix]]:
    """``T_i`` of each body: ``[body][i]`` 4x4, the non-zero entries defined as intermediates
    (``T_ij`` is made of them)."""
    deltas = [twist_matrix(j) for j in kin.joints]
    zero = sp.zeros(4, 4)
    moved = [set(kin.chain.topology.moved_by(b.joint)) for b in kin.bodies]
    return [[kin.program.define_all(deltas[i] * transform(b)) if i in moving else zero
             for i in range(len(kin.q))] for b, moving in zip(kin.bodies, moved)]


def second_derivatives(kin: Kinematics, first: list[list[sp.Matrix]]) -> list[list[list[sp.Matrix]]]:
    """``T_ij`` of each body: ``[body][i][j]`` 4x4 from its ``first`` derivatives."""
    deltas = [twist_matrix(j) for j in kin.joints]
    n, zero = len(kin.q), sp.zeros(4, 4)
    moved = [set(kin.chain.topology.moved_by(b.joint)) for b in kin.bodies]

    def entry(b, i, j):
        i, j = min(i, j), max(i, j)
        return deltas[i] * first[b][j] if i in moved[b] and j in moved[b] else zero

    return [[[entry(b, i, j) for j in range(n)] for i in range(n)] for b in range(len(kin.bodies))]


def check_kinds(kinds) -> tuple:
    """``kinds`` as a tuple in :data:`KINDS` order; ValueError naming an unknown one."""
    unknown = [k for k in kinds if k not in KINDS]
    if unknown:
        raise ValueError(f"unknown transform {', '.join(map(repr, unknown))}; choose among {', '.join(KINDS)}")
    return tuple(k for k in KINDS if k in kinds)
