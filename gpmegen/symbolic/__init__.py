"""SymPy derivation of a model's kinematics, dynamics and programmed constraints.

Pure functions of the model: nothing here touches files.
"""

from __future__ import annotations

from dataclasses import dataclass

from ..model.expand import FlatChain, expand
from . import constraints as _constraints
from . import dynamics as _dynamics
from . import recursive as _recursive
from .kinematics import Kinematics, forward
from .program import Program


@dataclass
class Derivation:
    """Everything code generation needs: the chain, the program of intermediate symbols, and
    the outputs as expressions of them."""

    chain: FlatChain
    program: Program
    kinematics: Kinematics
    dynamics: _dynamics.Dynamics
    constraints: _constraints.ConstraintTerms
    recursive: _recursive.RecursiveTerms


def derive(model) -> Derivation:
    """Validate and expand ``model``, then derive its equations of motion and constraints."""
    chain = expand(model)
    program = Program()
    kin = forward(chain, program)
    dyn = _dynamics.derive(kin, model.gravity, model.drives, model.forces)
    con = _constraints.derive(kin, model.constraints)
    rec = _recursive.derive(kin, dyn, model.gravity)
    return Derivation(chain, program, kin, dyn, con, rec)


__all__ = ["Derivation", "derive"]
