"""SymPy derivation of a model's kinematics, dynamics and programmed constraints.

Pure functions of the model: nothing here touches files.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import sympy as sp

from ..model.expand import FlatChain, expand
from . import computed_torque as _computed_torque
from . import constraints as _constraints
from . import dynamics as _dynamics
from . import recursive as _recursive
from . import task_torque as _task_torque
from .constraints import state_expressions
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
    # the controller states' rates (n_z,), 1/s times the state's unit, in the order of the model's
    controller_rates: sp.Matrix = field(default_factory=lambda: sp.zeros(0, 1))
    # one line per switch where a programmed constraint's or a computed-torque reference's law jumps
    warnings: tuple = ()


def derive(model) -> Derivation:
    """Validate and expand ``model``, then derive its equations of motion and constraints."""
    chain = expand(model)
    program = Program()
    kin = forward(chain, program)
    dyn = _dynamics.derive(kin, model.gravity, model.drives, model.forces, model.elements)
    warnings: tuple = ()
    defaults = {p.symbol: sp.Float(p.default) for p in model.parameters}
    if model.computed_torque is not None:   # the law joins the drives, before the recursion reads them
        dyn.drive_forces = dyn.drive_forces + _computed_torque.derive(kin, model.computed_torque)
        warnings = tuple(_computed_torque.warnings(model.computed_torque, defaults))
    if model.task_torque is not None:
        dyn.drive_forces = dyn.drive_forces + _task_torque.derive(kin, model.task_torque)
        warnings = tuple(_task_torque.warnings(model.task_torque, defaults))
    con = _constraints.derive(kin, model.constraints)
    warnings = con.warnings + warnings
    rec = _recursive.derive(kin, dyn, model.gravity)
    rates = sp.Matrix(state_expressions(kin, [c.rate for c in model.controllers])) if model.controllers else None
    return Derivation(chain, program, kin, dyn, con, rec, *([rates] if rates is not None else []), warnings=warnings)


__all__ = ["Derivation", "derive"]
