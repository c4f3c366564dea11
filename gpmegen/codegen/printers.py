"""Printers of SymPy expressions as Python (``math``) and C99 code.

The generator's own symbols keep their names (``_x12``, ``_q_theta1``, ``_qd_x3``; see
:mod:`gpmegen.symbolic.names`) and so does time ``t``; parameters print as the locals that hold
them, ``_p_<name>``. Integer powers print as products, which is both exact and fast. Piecewise
prints as conditional expressions (Python) and ternaries (C); Heaviside(0) is 1/2 in both, or its
second argument.
"""

from __future__ import annotations

import sympy as sp
from sympy.printing.c import C99CodePrinter
from sympy.printing.pycode import PythonCodePrinter

from ..symbolic import names


def _small_power(printer, expr):
    base, exp = expr.as_base_exp()
    if exp.is_Integer and 2 <= int(exp) <= 4 and base.is_Symbol:
        b = printer.parenthesize(base, sp.printing.precedence.PRECEDENCE["Mul"] + 1)
        # parenthesized: the Mul printer treats a Pow as binding tighter than '/'
        return "(" + "*".join([b] * int(exp)) + ")"
    return None


class PythonPrinter(PythonCodePrinter):
    """Scalar Python using the ``math`` module."""

    def __init__(self, parameters):
        # order="none": print terms in SymPy's canonical argument order instead of sorting them
        # again for display, which costs most of the printing time and changes nothing
        super().__init__({"fully_qualified_modules": True, "standard": "python3", "order": "none"})
        self._parameters = set(parameters)

    def _print_Symbol(self, expr):
        name = expr.name
        return names.parameter_local(name) if name in self._parameters else name

    def _print_Pow(self, expr, rational=False):
        return _small_power(self, expr) or super()._print_Pow(expr, rational)

    def _print_Min(self, expr):
        return "min(" + ", ".join(self._print(a) for a in expr.args) + ")"

    def _print_Max(self, expr):
        return "max(" + ", ".join(self._print(a) for a in expr.args) + ")"


class CPrinter(C99CodePrinter):
    """C99 with ``math.h``; π as a literal so no feature macro is needed."""

    def __init__(self, parameters):
        super().__init__({"order": "none"})
        self._parameters = set(parameters)

    def _print_Symbol(self, expr):
        name = expr.name
        return names.parameter_local(name) if name in self._parameters else name

    def _print_Pow(self, expr, rational=False):
        return _small_power(self, expr) or super()._print_Pow(expr)

    def _print_Pi(self, expr):
        return "3.14159265358979323846"

    def _print_Piecewise(self, expr):
        """Nested ternaries on one line (SymPy's own spread over lines); the last condition is
        True, as the model checks (Heaviside and ITE print through here too)."""
        *pairs, (code, otherwise) = expr.args
        if otherwise != sp.true:
            raise ValueError(f"Piecewise without a last (value, True) pair: {expr}")
        code = f"({self._print(code)})"
        for value, condition in reversed(pairs):
            code = f"(({self._print(condition)}) ? ({self._print(value)}) : {code})"
        return code

    def _print_Rational(self, expr):
        return f"{float(expr.p)!r}/{float(expr.q)!r}"

    def _print_Integer(self, expr):
        return f"{int(expr)}.0" if abs(int(expr)) < 2**53 else f"{float(expr)!r}"
