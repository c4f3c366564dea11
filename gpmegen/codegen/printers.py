"""Printers of SymPy expressions as Python (``math``) and C99 code.

The generator's own symbols keep their names (``_x12``, ``_q_theta1``, ``_qd_x3``; see
:mod:`gpmegen.symbolic.names`) and so does time ``t``; parameters print as the locals that hold
them, ``_p_<name>``; a table signal prints as the call of the function that the runtime supplies,
``_signal(k, t)`` (Python) and ``gpmegen_signal(k, t)`` (C), ``k`` its index in the model's
signals. Integer powers print as products, which is both exact and fast. Piecewise
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

    def __init__(self, parameters, signals=()):
        # order="none": print terms in SymPy's canonical argument order instead of sorting them
        # again for display, which costs most of the printing time and changes nothing
        super().__init__({"fully_qualified_modules": True, "standard": "python3", "order": "none"})
        self._parameters = set(parameters)
        self._signals = {name: k for k, name in enumerate(signals)}

    def _print_Symbol(self, expr):
        name = expr.name
        if name in self._signals:
            return f"{names.SIGNAL_FUNCTION}({self._signals[name]}, t)"
        return names.parameter_local(name) if name in self._parameters else name

    def _print_Pow(self, expr, rational=False):
        return _small_power(self, expr) or super()._print_Pow(expr, rational)

    def _print_Min(self, expr):
        return "min(" + ", ".join(self._print(a) for a in expr.args) + ")"

    def _print_Max(self, expr):
        return "max(" + ", ".join(self._print(a) for a in expr.args) + ")"


class CPrinter(C99CodePrinter):
    """C99 with ``math.h``; π and e as literals so no feature macro is needed (SymPy would print
    ``pi/4`` as ``M_PI_4``, ``sqrt(2)`` as ``M_SQRT2``: POSIX names that ``-std=c99`` leaves
    undeclared)."""

    def __init__(self, parameters, signals=()):
        super().__init__({"order": "none"})
        self.math_macros = {}
        self._parameters = set(parameters)
        self._signals = {name: k for k, name in enumerate(signals)}

    def _print_Symbol(self, expr):
        name = expr.name
        if name in self._signals:
            return f"gpmegen_signal({self._signals[name]}, t)"
        return names.parameter_local(name) if name in self._parameters else name

    def _print_Pow(self, expr, rational=False):
        return _small_power(self, expr) or super()._print_Pow(expr)

    def _print_Pi(self, expr):
        return "3.14159265358979323846"

    def _print_Exp1(self, expr):
        return "2.71828182845904523536"

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


#: The name under which generated CasADi source imports ``casadi``: an underscore first, like every
#: name of the generator's own (:mod:`gpmegen.symbolic.names`), so no model name meets it.
CASADI = "_ca"


class CasadiPrinter(PythonPrinter):
    """Python building CasADi SX expressions: the functions of ``casadi`` in place of ``math``,
    ``if_else`` in place of conditional expressions (an SX has no truth value) and the logical
    operators as CasADi's functions; π and E as literals."""

    _FUNCTIONS = {"sin": "sin", "cos": "cos", "tan": "tan", "asin": "asin", "acos": "acos", "atan": "atan",
                  "atan2": "atan2", "sinh": "sinh", "cosh": "cosh", "tanh": "tanh", "exp": "exp", "log": "log",
                  "sqrt": "sqrt", "Abs": "fabs", "sign": "sign", "floor": "floor", "ceiling": "ceil"}

    def __init__(self, parameters):
        super().__init__(parameters)
        self.known_functions = {name: f"{CASADI}.{fn}" for name, fn in self._FUNCTIONS.items()}

    def _print_known(self, expr):
        name = self.known_functions.get(type(expr).__name__)
        if name is None:
            raise ValueError(f"no CasADi function for {type(expr).__name__} in {expr}")
        return f"{name}(" + ", ".join(self._print(a) for a in expr.args) + ")"

    def _print_Pow(self, expr, rational=False):
        small = _small_power(self, expr)
        if small:
            return small
        base, exp = expr.as_base_exp()
        if exp == sp.S.Half:
            return f"{CASADI}.sqrt({self._print(base)})"
        if exp == -sp.S.Half:
            return f"1/{CASADI}.sqrt({self._print(base)})"
        return f"({self._print(base)})**({self._print(exp)})"

    def _print_Min(self, expr):
        code = self._print(expr.args[0])
        for a in expr.args[1:]:
            code = f"{CASADI}.fmin({code}, {self._print(a)})"
        return code

    def _print_Max(self, expr):
        code = self._print(expr.args[0])
        for a in expr.args[1:]:
            code = f"{CASADI}.fmax({code}, {self._print(a)})"
        return code

    def _print_Heaviside(self, expr):
        x = self._print(expr.args[0])
        h0 = self._print(expr.args[1]) if len(expr.args) > 1 else "0.5"
        return f"{CASADI}.if_else(({x}) > 0, 1.0, {CASADI}.if_else(({x}) < 0, 0.0, {h0}))"

    def _print_Piecewise(self, expr):
        """Nested ``if_else``; the last condition is True, as the model checks."""
        *pairs, (code, otherwise) = expr.args
        if otherwise != sp.true:
            raise ValueError(f"Piecewise without a last (value, True) pair: {expr}")
        code = self._print(code)
        for value, condition in reversed(pairs):
            code = f"{CASADI}.if_else({self._print(condition)}, {self._print(value)}, {code})"
        return code

    def _print_ITE(self, expr):
        return self._print(expr.rewrite(sp.Piecewise))

    def _print_Relational(self, expr):
        op = {"==": "==", "!=": "!=", "<": "<", "<=": "<=", ">": ">", ">=": ">="}[expr.rel_op]
        return f"({self._print(expr.lhs)} {op} {self._print(expr.rhs)})"

    def _print_And(self, expr):
        code = self._print(expr.args[0])
        for a in expr.args[1:]:
            code = f"{CASADI}.logic_and({code}, {self._print(a)})"
        return code

    def _print_Or(self, expr):
        code = self._print(expr.args[0])
        for a in expr.args[1:]:
            code = f"{CASADI}.logic_or({code}, {self._print(a)})"
        return code

    def _print_Not(self, expr):
        return f"{CASADI}.logic_not({self._print(expr.args[0])})"

    def _print_BooleanTrue(self, expr):
        return "1.0"

    def _print_BooleanFalse(self, expr):
        return "0.0"

    def _print_Mod(self, expr):
        """SymPy's Mod, floored (the sign of the divisor): ``a - b floor(a / b)``."""
        a, b = (self._print(x) for x in expr.args)
        return f"(({a}) - ({b})*{CASADI}.floor(({a})/({b})))"

    def _print_Pi(self, expr):
        return repr(float(sp.pi))

    def _print_Exp1(self, expr):
        return repr(float(sp.E))


for _name in CasadiPrinter._FUNCTIONS:
    setattr(CasadiPrinter, f"_print_{_name}", CasadiPrinter._print_known)
