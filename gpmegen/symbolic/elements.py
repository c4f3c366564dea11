"""The terms of the elements of registered kinds (:class:`gpmegen.model.elements.Element`,
``Model.elements``): each gives its potential energy and its other generalized forces as
expressions of the state as a model file names it; here they are written in the kinematics'
symbols and placed in the slots of ``f``, as the joints' springs and the drives are."""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..errors import DerivationError
from .constraints import state_expressions
from .kinematics import Kinematics


@dataclass
class ElementTerms:
    """The elements' terms as expressions of the kinematics' symbols."""

    spring: sp.Matrix     # ∂V/∂q (n,), the springs' slot of f (subtracted)
    applied: sp.Matrix    # their other generalized forces (n,), the drives' slot
    stiffness: sp.Matrix  # ∂²V/∂q² (n, n)
    potential: sp.Expr    # V, J


def derive(kin: Kinematics, elements) -> ElementTerms:
    """The terms of ``elements`` on the chain whose kinematics is ``kin``; a generalized force
    on a name that is no coordinate is a DerivationError about ``elements[k]``."""
    n = len(kin.joints)
    index = {jt.name: j for j, jt in enumerate(kin.joints)}
    potential = sum(state_expressions(kin, [e.potential() for e in elements]), sp.S.Zero)
    spring = sp.Matrix([sp.diff(potential, q) for q in kin.q])
    stiffness = sp.Matrix(n, n, lambda i, j: sp.diff(spring[i], kin.q[j]))
    applied = sp.zeros(n, 1)
    for k, element in enumerate(elements):
        forces = element.applied()
        for name, law in zip(forces, state_expressions(kin, list(forces.values()))):
            if name not in index:
                raise DerivationError(f"element {element!r}: no coordinate {name!r} to act on; the coordinates are "
                                      f"{', '.join(index)}", ("elements", k))
            applied[index[name]] += law
    return ElementTerms(spring, applied, stiffness, potential)
