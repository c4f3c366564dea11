"""Common subexpression elimination over one generated function, deterministic.

SymPy's ``cse`` orders its choices by set iteration, so its output can change with
``PYTHONHASHSEED``. Here every walk follows the definitions in order and each expression's
``args`` in SymPy's canonical order, so the same input gives the same code byte for byte.
"""

from __future__ import annotations

from collections import Counter

import sympy as sp
from sympy.functions.elementary.piecewise import ExprCondPair

from ..symbolic import names as internal
from ..symbolic.program import is_trivial


def eliminate(definitions, outputs):
    """Hoist every repeated non-trivial subexpression of ``definitions`` (``(symbol, expr)``
    pairs in order) and ``outputs`` (expressions) into a new definition, merge definitions
    whose values come out equal (the inertia constants of identical rfes, for one), and rename
    all intermediate symbols ``_x0, _x1, …`` in order of definition.

    Returns ``(definitions, outputs)`` with the new names."""
    counts: Counter = Counter()

    def count(expr):
        for arg in expr.args:
            if is_trivial(arg):
                continue
            if isinstance(arg, ExprCondPair):  # a branch of a Piecewise, not a value: its parts may be hoisted
                count(arg)
                continue
            counts[arg] += 1
            if counts[arg] == 1:
                count(arg)

    for _, expr in definitions:
        count(expr)
    for expr in outputs:
        count(expr)

    names: dict = {}
    result = []
    hoisted: dict = {}

    def new_symbol():
        return internal.intermediate(len(result))

    def rewrite(expr):
        if is_trivial(expr):
            return expr.xreplace(names) if expr.free_symbols & names.keys() else expr
        if expr in hoisted:
            return hoisted[expr]
        args = [rewrite(a) for a in expr.args]
        new = expr.func(*args) if any(a is not b for a, b in zip(args, expr.args)) else expr
        if counts[expr] >= 2:
            sym = new_symbol()
            result.append((sym, new))
            hoisted[expr] = sym
            return sym
        return new

    defined: dict = {}  # value -> its symbol: two definitions with one value become one
    for sym, expr in definitions:
        value = rewrite(expr)
        if is_trivial(value):
            names[sym] = value
            continue
        if value in defined:
            names[sym] = defined[value]
            continue
        new = new_symbol()
        result.append((new, value))
        names[sym] = defined[value] = new
    return result, [rewrite(sp.sympify(e)) for e in outputs]
