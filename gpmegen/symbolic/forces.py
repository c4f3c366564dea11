"""Forces along the line between two points (:class:`gpmegen.model.chain.ForceElement`).

For an element between points A and B: ``d = r_B - r_A`` in {0}, its length ``L = |d|``,
direction ``e = d/L``, rate ``L̇ = e·(v_B - v_A)`` and, with ``J_P`` a point's translational
Jacobian (the kinematics' columns ``ω_j × r_P + v_j`` of the joints that move it), the
derivatives ``s_j = ∂L/∂q_j = e·(J_B - J_A)_j``. A force ``F`` that pushes A and B apart when
positive (``F e`` on B, ``-F e`` on A) does the virtual work ``F δL``: its generalized force is
``Q_j = F s_j``.

- spring-damper: ``F = k (L0 - L) - c L̇``. The spring's part is potential energy
  ``V = k (L - L0)²/2`` and enters the springs' slot of ``f`` (subtracted) as
  ``∂V/∂q_j = k (L - L0) s_j``, with the statics' residual and its stiffness
  ``∂²V/∂q_i∂q_j = k s_i s_j + k (L - L0) ∂s_i/∂q_j``, where
  ``∂s_i/∂q_j = ((J_B - J_A)_i·(J_B - J_A)_j - s_i s_j)/L + e·(H^B_ij - H^A_ij)`` and
  ``H^P_ij = ∂²r_P/∂q_i∂q_j = ω_a × J_P,b`` for ``a`` the one of ``i, j`` that supports the
  other (both move P), zero otherwise. The damper's part ``-c L̇`` joins the drives' ``Q``,
  whose power the integrators integrate with the state (``work_drive``).
- actuator: ``F`` a law of ``t``, parameters and the state, in the drives' ``Q`` as well.

``L = 0`` makes ``e`` 0/0: the generated code gives NaN there (the run stops as a non-finite
state, named by :func:`gpmegen.runtime.integrators.loop.chunked`'s caller); points that coincide
identically are refused when the model is derived.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..errors import DerivationError
from ..model.expand import expand
from .algebra import cross, dot
from .constraints import state_expressions
from .kinematics import Kinematics, forward
from .program import Program


@dataclass
class ForceTerms:
    """The force elements' terms as expressions of intermediate symbols."""

    length: list        # L per element, m
    rate: list          # L̇ per element, m/s
    force: list         # F per element, N, positive pushing the points apart
    spring: sp.Matrix   # ∂V/∂q (n,), the springs' slot of f
    applied: sp.Matrix  # the dampers' and actuators' generalized force (n,), the drives' slot
    stiffness: sp.Matrix  # ∂²V/∂q² (n, n)
    potential: sp.Expr  # Σ k (L - L0)²/2, J


def coincident(kin: Kinematics, element) -> bool:
    """Whether the two points of ``element`` coincide identically on the chain (``r_B - r_A``
    written in the kinematics' intermediates is exact zeros)."""
    a, b = (kin.points[name] for name in element.points)
    return all(v == 0 for v in b.position - a.position)


def check_coincident(kin: Kinematics, forces) -> None:
    """Refuse an element whose points coincide identically (its direction is nowhere defined): a
    DerivationError about the element's ``points``, which a model file's case places at its line
    (:meth:`gpmegen.model.toml_file.ModelFile.locate`)."""
    for k, element in enumerate(forces):
        if coincident(kin, element):
            first, second = element.points
            raise DerivationError(f"force {element.name!r}: points {first!r} and {second!r} coincide in every "
                             f"configuration, so the force has no line; place them apart", ("forces", k, "points"))


def check_apart(model) -> None:
    """Refuse a force element of ``model`` (a valid Model) whose points coincide in every
    configuration, from its kinematics derived for that alone: a model file's case checks this
    as the file is read (:class:`gpmegen.analysis.run.cases.FileCase`), before any derivation is
    said, so that the one line names the file and the element."""
    if model.forces:
        check_coincident(forward(expand(model), Program()), model.forces)


def _second(kin: Kinematics, point, i: int, j: int) -> sp.Matrix:
    """``∂²r_P/∂q_i∂q_j`` of the point ``point`` (a PointState): ``ω_a × J_P,b`` with ``a`` the
    joint of ``i, j`` that supports the other, both moving P; zero otherwise."""
    supports = kin.chain.topology.supports
    moving = supports[point.joint] if point.joint >= 0 else ()
    if i not in moving or j not in moving:
        return sp.zeros(3, 1)
    a, b = (i, j) if i in supports[j] else (j, i)
    return cross(kin.joints[a].omega, point.jacobian[b])


def derive(kin: Kinematics, forces) -> ForceTerms:
    """The terms of the force elements ``forces`` on the chain whose kinematics is ``kin``."""
    check_coincident(kin, forces)
    define, define_all = kin.program.define, kin.program.define_all
    n = len(kin.q)
    laws = dict(zip((k for k, f in enumerate(forces) if f.kind == "actuator"),
                    state_expressions(kin, [f.force for f in forces if f.kind == "actuator"])))
    lengths, rates, values = [], [], []
    spring, applied, K = sp.zeros(n, 1), sp.zeros(n, 1), sp.zeros(n, n)
    potential = sp.S.Zero
    for k, element in enumerate(forces):
        a, b = (kin.points[name] for name in element.points)
        d = define_all(b.position - a.position)
        length = define(sp.sqrt(dot(d, d)))
        e = define_all(d / length)
        rate = define(dot(e, b.velocity - a.velocity))
        columns = [define_all(b.jacobian[j] - a.jacobian[j]) for j in range(n)]
        s = [define(dot(e, c)) for c in columns]
        if element.kind == "actuator":
            force = nonconservative = define(laws[k])
            conservative = sp.S.Zero
        else:
            stiffness, rest, damping = (sp.sympify(v) for v in (element.stiffness, element.rest_length,
                                                                 element.damping))
            stretch = define(length - rest)
            conservative = define(stiffness * stretch)   # k (L - L0), the spring's tension
            nonconservative = define(-damping * rate)    # the damper's push
            force = define(nonconservative - conservative)
            potential += stiffness * stretch ** 2 / 2
        lengths.append(length)
        rates.append(rate)
        values.append(force)
        moving = [j for j in range(n) if s[j] != 0]
        for j in moving:
            # F s_j: the dampers' and actuators' part joins the drives, the spring's the springs
            if nonconservative != 0:
                applied[j] += define(nonconservative * s[j])
            if conservative != 0:
                spring[j] += define(conservative * s[j])
        if conservative == 0:
            continue
        stiffness = sp.sympify(element.stiffness)
        for i in moving:
            for j in moving:
                if j < i:
                    continue
                curvature = (dot(columns[i], columns[j]) - s[i] * s[j]) / length
                curvature += dot(e, _second(kin, b, i, j) - _second(kin, a, i, j))
                value = define(stiffness * s[i] * s[j] + conservative * curvature)
                K[i, j] += value
                if i != j:
                    K[j, i] += value
    return ForceTerms(lengths, rates, values, spring, applied, K, potential)
