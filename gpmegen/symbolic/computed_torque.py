"""The computed-torque law's generalized forces, derived with the plant
(:class:`gpmegen.model.computed_torque.ComputedTorque`).

The controller model is derived in a program of its own (its mass matrix ``M_c`` and its forces
without drives ``f_c = h - g - C q - damping``, force elements included), and the definitions
those need are copied into the plant's program, each renamed to a new intermediate of the plant:
so the two models' intermediates never share a name, and the law becomes part of the plant's
drive forces, emitted into both backends and every compiled loop like any feedback law. The
controller's coordinate and velocity symbols are the plant's of the same names (both are
:func:`gpmegen.symbolic.names.coordinate` of the name); its elastic coordinates the plant reads as
0, its parameters as their default values (numbers) but those the law's ``params`` sets, which it
reads as their expressions of the plant's parameters (run-time parameters of the plant).

A reference that switches (``Min``, ``Max``, ``Abs``, ``Heaviside``, ``Piecewise``: a move that
ends) is differentiated branch by branch as a programmed constraint is
(:mod:`gpmegen.symbolic.piecewise`): the impulse of ``q̈_r`` at a switch where ``q̇_r`` or
``q_r`` jumps is not applied, and :func:`warnings` says where that happens.
"""

from __future__ import annotations

import unicodedata

import sympy as sp

from ..errors import DerivationError
from ..model.computed_torque import ComputedTorque, joint_coordinates
from ..model.expand import expand
from ..model.names import TIME
from . import dynamics as _dynamics
from . import names
from .constraints import state_expressions
from .kinematics import Kinematics, forward
from .piecewise import PRINTABLE_HINT, as_piecewise, exact, jump_warnings, unprintable
from .program import Program

# what a jump in a reference leaves out, and what to write instead
CONSEQUENCE = ("the impulse there is not applied and the gains pull the motion back onto the reference: make "
               "the reference continuously differentiable there (see docs/model-file.md)")


def _field(law: ComputedTorque, k: int) -> str:
    """The reference field of the law's ``k``-th coordinate, for messages."""
    name = law.signals[k] if k < len(law.signals) else ""
    return f"controller.computed_torque[{k}].reference" + (f": signal {name!r}" if name else "")


def reference_rates(law: ComputedTorque) -> list[tuple]:
    """``(q_r, q̇_r, q̈_r)`` per coordinate of the law, expressions of ``t`` and parameters
    (rad or m, per s, per s²), switches written as Piecewise and differentiated branch by branch.
    A reference whose rates generated code could not evaluate (floor, Mod) is refused."""
    out = []
    for k, reference in enumerate(law.references):
        r = as_piecewise(reference)
        rd = sp.diff(r, TIME)
        rdd = sp.diff(rd, TIME)
        function = unprintable((rdd,))
        if function is not None:
            raise DerivationError(f"{_field(law, k)}: it uses {function}, whose derivatives generated code cannot "
                                  f"evaluate; write it with {PRINTABLE_HINT}", ("controller", "computed_torque", k,
                                                                                "reference"))
        out.append((r, rd, rdd))
    return out


def warnings(law: ComputedTorque, defaults, fields=None, symbols=None) -> list[str]:
    """One line per switch where a reference's value or velocity jumps (and one for the switches
    that cannot be decided), naming the field and the reference as ``<symbol>_r`` (``fields``
    and ``symbols``: one per reference, default the joint law's fields and ``q``); ``defaults``:
    the plant's parameter symbols -> numbers."""
    out = []
    for k, reference in enumerate(law.references):
        r = as_piecewise(exact(reference))
        field = _field(law, k) if fields is None else fields[k]
        symbol = "q" if symbols is None else symbols[k]
        # the dot composed with its letter where Unicode has the pair (ẋ), else combining (q̇)
        checked = ((f"{symbol}_r", r), (unicodedata.normalize("NFC", f"{symbol}\u0307_r"), sp.diff(r, TIME)))
        out += jump_warnings(field, checked, defaults, CONSEQUENCE)
    return out


def controller_terms(law: ComputedTorque, program: Program) -> tuple[sp.Matrix, sp.Matrix, tuple]:
    """``(M_c, f_c, coordinates)`` of the controller model as expressions of ``program``'s
    intermediates (copied in) and the plant's state symbols; ``f_c`` without drives (n_c,)."""
    (mass, forces), coordinates = controller_outputs(law.controller, program,
                                                     lambda kin, dyn: [dyn.mass_matrix, dyn.forces], law.params)
    return mass, forces, coordinates


def controller_outputs(controller, program: Program, outputs, params=(), dynamics=True) -> tuple[list, tuple]:
    """``(matrices, coordinates)``: the matrices ``outputs(kin, dyn)`` gives of the controller
    model's kinematics and dynamics (its forces without drives), as expressions of ``program``'s
    intermediates (copied in) and the plant's state symbols; ``coordinates`` the controller's.
    ``params``: ``(name, expression of the plant's parameters)`` for the controller's parameters
    set so; the others are their default values. ``dynamics`` False: outputs of the kinematics
    alone, the dynamics not derived (``dyn`` None)."""
    chain = expand(controller)
    own = Program()
    kin = forward(chain, own)
    dyn = _dynamics.derive(kin, controller.gravity, (), controller.forces) if dynamics else None
    joints = set(joint_coordinates(controller))
    given = dict(params)   # the controller's parameters set from the plant's: read at run time
    mapping = {p.symbol: sp.sympify(given[p.name]) if p.name in given else sp.Float(float(p.default))
               for p in controller.parameters}
    for name in chain.coordinates:
        if name not in joints:   # elastic: held at rest
            mapping[names.coordinate(name)] = sp.S.Zero
            mapping[names.velocity(name)] = sp.S.Zero
    matrices = [sp.Matrix(m) for m in outputs(kin, dyn)]
    for sym, expr in own.closure([e for m in matrices for e in m]):
        mapping[sym] = program.define(expr.xreplace(mapping))
    return [m.xreplace(mapping) for m in matrices], chain.coordinates


def derive(kin: Kinematics, law: ComputedTorque) -> sp.Matrix:
    """The law's generalized force on the plant whose kinematics is ``kin`` (n,): on each
    coordinate the law names ``(M_c v - f_c)`` of the controller's same coordinate, elsewhere 0."""
    mass, forces, coordinates = controller_terms(law, kin.program)
    commanded = dict(zip(law.coordinates, state_expressions(kin, law.commanded(reference_rates(law)))))
    return on_plant(kin, mass, forces, coordinates, commanded)


def on_plant(kin: Kinematics, mass, forces, coordinates, commanded: dict) -> sp.Matrix:
    """``u = M_c v - f_c`` (``v``: ``commanded[name]`` on the coordinates it names, 0 on the
    controller's others) placed on the plant's coordinates of those names (n,), 0 elsewhere."""
    v = sp.Matrix([commanded.get(name, sp.S.Zero) for name in coordinates])
    u = mass * v - forces
    index = {name: j for j, name in enumerate(kin.chain.coordinates)}
    out = sp.zeros(len(kin.q), 1)
    for k, name in enumerate(coordinates):
        if name in commanded:
            out[index[name]] = kin.program.define(u[k])
    return out
