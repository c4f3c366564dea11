"""A straight-line program of named intermediate symbols.

The derivation never expands a transform of the last rfe into one huge expression: every
non-trivial matrix entry at every chain level becomes a named intermediate symbol defined by a
small expression of earlier ones. Outputs are expressions of those symbols; code generation
takes for each function only the definitions it needs.
"""

from __future__ import annotations

import sympy as sp

from . import names


def is_trivial(expr) -> bool:
    """Numbers, symbols and negated symbols are used as they are, never given a name."""
    if expr.is_Atom:
        return True
    if expr.is_Mul and len(expr.args) == 2 and expr.args[0] is sp.S.NegativeOne and expr.args[1].is_Symbol:
        return True
    return False


class Program:
    """Ordered definitions ``symbol = expression`` of intermediate quantities."""

    def __init__(self):
        self.definitions: dict[sp.Symbol, sp.Expr] = {}

    def define(self, expr) -> sp.Expr:
        """Return ``expr`` if trivial, else a new intermediate symbol standing for it."""
        expr = sp.sympify(expr)
        if is_trivial(expr):
            return expr
        name = names.intermediate(len(self.definitions))
        self.definitions[name] = expr
        return name

    def define_all(self, values):
        """``define`` applied to each entry of a sequence or Matrix; returns a Matrix."""
        m = sp.Matrix(values)
        return m.applyfunc(self.define)

    def closure(self, outputs) -> list[tuple[sp.Symbol, sp.Expr]]:
        """The definitions the given expressions depend on, in definition order."""
        needed: set = set()
        stack = [s for e in outputs for s in sp.sympify(e).free_symbols if s in self.definitions]
        while stack:
            s = stack.pop()
            if s in needed:
                continue
            needed.add(s)
            stack.extend(d for d in self.definitions[s].free_symbols if d in self.definitions and d not in needed)
        return [(s, e) for s, e in self.definitions.items() if s in needed]
