"""Names of the generator's own symbols and of the locals of generated code.

Every one begins with an underscore, which no name of a model can (a letter first:
:func:`gpmegen.model.chain.check_name`). So no parameter, coordinate or point is ever taken for
one of them: SymPy holds two symbols of one name as one (a parameter ``x5`` would become an
intermediate quantity), and generated code would define a local twice. An underscore and a
lowercase letter begin every name here, which C leaves to the program at block scope (an
underscore and an uppercase letter are reserved).
"""

from __future__ import annotations

import sympy as sp

PREFIX = "_"

#: The function of a generated NumPy module that gives a table signal's value, ``_signal(k, t)``:
#: the runtime supplies it (:mod:`gpmegen.runtime.signals`).
SIGNAL_FUNCTION = f"{PREFIX}signal"


def intermediate(k: int) -> sp.Symbol:
    """The ``k``-th intermediate quantity of a derivation or of a generated function: ``_x<k>``."""
    return sp.Symbol(f"{PREFIX}x{k}", real=True)


def coordinate(name: str) -> sp.Symbol:
    """The symbol and local of coordinate ``name`` (rad or m): ``_q_<name>``."""
    return sp.Symbol(f"{PREFIX}q_{name}", real=True)


def velocity(name: str) -> sp.Symbol:
    """The symbol and local of the velocity of coordinate ``name``: ``_qd_<name>``."""
    return sp.Symbol(f"{PREFIX}qd_{name}", real=True)


def acceleration(name: str) -> sp.Symbol:
    """The symbol and local of a given acceleration of coordinate ``name``: ``_qdd_<name>``."""
    return sp.Symbol(f"{PREFIX}qdd_{name}", real=True)


def multiplier(constraint: str) -> sp.Symbol:
    """The symbol and local of the multiplier of constraint ``constraint``: ``_lam_<constraint>``."""
    return sp.Symbol(f"{PREFIX}lam_{constraint}", real=True)


def point_acceleration(point: str) -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """Placeholders for the velocity-product part of a point's acceleration in {0}:
    ``_ax_<point>, _ay_<point>, _az_<point>``."""
    return tuple(sp.Symbol(f"{PREFIX}a{a}_{point}", real=True) for a in "xyz")


def parameter_local(name: str) -> str:
    """The local that holds parameter ``name`` in generated code: ``_p_<name>``."""
    return f"{PREFIX}p_{name}"
