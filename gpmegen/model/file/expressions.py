"""Expressions of model files: lexical, name, condition, size and power checks, then a parse
with SymPy's parser in a namespace that holds only the allowed names (user text is never
``eval``-ed or ``sympify``-ed as such).

:func:`parse` raises :class:`~gpmegen.errors.ModelError` with the problem alone; the reader adds
the file, line and field."""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from tokenize import TokenError

import sympy as sp
from sympy.parsing.sympy_parser import auto_number, convert_xor, parse_expr

from ...errors import ModelError
from ..requirements import evaluate

FUNCTIONS = {
    "sin": sp.sin, "cos": sp.cos, "tan": sp.tan, "exp": sp.exp, "log": sp.log, "sqrt": sp.sqrt,
    "Abs": sp.Abs, "Min": sp.Min, "Max": sp.Max, "atan2": sp.atan2, "Heaviside": sp.Heaviside,
    "Piecewise": sp.Piecewise,
}
CONSTANTS = {"pi": sp.pi}
# What the parser makes of comparisons when it does not evaluate.
COMPARISON_NAMES = {"Lt": sp.Lt, "Le": sp.Le, "Gt": sp.Gt, "Ge": sp.Ge}
COMPARISONS = ("<", "<=", ">", ">=")
PIECEWISE_EXAMPLE = "Piecewise((t, t < T), (T, True))"
# What sympy_parser's auto_number emits (Integer, Float) and may emit (Rational, Symbol).
PARSER_NAMES = {"Integer": sp.Integer, "Float": sp.Float, "Rational": sp.Rational, "Symbol": sp.Symbol}
# Names the parser's namespace or the derivation's internal symbols already use.
TAKEN_NAMES = frozenset(FUNCTIONS) | frozenset(CONSTANTS) | frozenset(PARSER_NAMES)

MAX_EXPRESSION_LENGTH = 2000
MAX_EXPONENT = 100          # |exponent| of a power with a constant exponent
MAX_CONSTANT_BASE = 1e50    # |base| of a constant power: bounds exact integer arithmetic
MAX_DEPTH = 40              # nesting of an expression tree

_TOKEN = re.compile(
    r"(?P<space>\s+)|(?P<number>(?:\d+\.?\d*|\.\d+)(?:[eE][+-]?\d+)?)"
    r"|(?P<name>[A-Za-z_][A-Za-z0-9_]*)|(?P<op>\*\*|<=|>=|[-+*/^(),<>])"
)


def _unevaluated(function):
    """``function`` that never evaluates (the parser may already pass ``evaluate=False``)."""
    def call(*args, evaluate=False):
        return function(*args, evaluate=False)
    return call


@dataclass
class _Parenthesis:
    """An open parenthesis while conditions are checked: a ``Piecewise(`` call, one of its
    ``(value, condition)`` pairs, or any other."""

    kind: str
    commas: int = 0
    comparisons: int = 0
    default: bool = False   # pair: its condition is True; Piecewise: its last pair's is


def _condition_problem(tokens) -> str | None:
    """Why the comparisons or ``True`` among ``tokens`` ((kind, text) pairs) are out of place,
    or None. They may only be a Piecewise pair's condition: one comparison, or ``True`` alone in
    the last pair, which every Piecewise has."""
    example = f"as in {PIECEWISE_EXAMPLE}"
    frames: list[_Parenthesis] = []
    for k, (_, tok) in enumerate(tokens):
        before = tokens[k - 1][1] if k else None
        after = tokens[k + 1][1] if k + 1 < len(tokens) else None
        top = frames[-1] if frames else _Parenthesis("top")
        if top.kind == "Piecewise" and tok not in ("(", ",", ")") or (
                tok == "(" and top.kind == "Piecewise" and before not in ("(", ",")):
            return f"each argument of Piecewise is a pair (value, condition), {example}"
        if tok == "(":
            if top.kind == "Piecewise" and top.default:
                return f"a pair after (value, True) is never used; make (value, True) the last pair, {example}"
            frames.append(_Parenthesis("Piecewise" if before == "Piecewise" else
                                       "pair" if top.kind == "Piecewise" else "other"))
        elif tok == ",":
            top.commas += 1
        elif tok in COMPARISONS:
            if top.kind != "pair" or top.commas != 1 or top.comparisons:
                return (f"the comparison {tok!r} may only be the condition of a Piecewise pair, one per pair and "
                        f"not in parentheses, {example}")
            top.comparisons += 1
        elif tok == "True":
            if top.kind != "pair" or top.commas != 1 or before != "," or after != ")":
                return f"True may only be the whole condition of the last Piecewise pair, {example}"
            top.default = True
        elif tok == ")" and frames:
            frames.pop()
            if top.kind == "pair":
                if top.commas != 1 or not (top.comparisons or top.default):
                    return (f"a Piecewise pair is (value, condition) with one comparison (< <= > >=) as the "
                            f"condition, or True in the last pair, {example}")
                frames[-1].default = top.default
            elif top.kind == "Piecewise" and not top.default:
                return f"Piecewise must end with the pair (value, True), the value where no condition holds, {example}"
    return None


def _exponent(number: str) -> int:
    m = re.search(r"[eE]([+-]?\d+)$", number)
    return abs(int(m.group(1))) if m else 0



def depth(expr) -> int:
    """Nesting depth of an expression tree (iterative: deep trees must not hit the recursion limit)."""
    deepest, stack = 0, [(expr, 1)]
    while stack:
        node, d = stack.pop()
        deepest = max(deepest, d)
        stack.extend((a, d + 1) for a in node.args)
    return deepest


def _size_text(expr) -> str:
    """The value of a constant expression to three digits, as far as it can be computed."""
    try:
        return str(sp.N(expr, 3))
    except (ArithmeticError, ValueError, TypeError):
        return "too large to compute"


def _held(expr) -> str:
    """``expr = its value`` to three digits; only the value where an integer in it has more
    digits than Python prints (``(10**49)**100``)."""
    try:
        return f"{expr} = {_size_text(expr)}"
    except ValueError:
        return f"a number of {_size_text(expr)}"


def _fail(message: str):
    raise ModelError(message)


def parse(text: str, scope: dict, unknown) -> sp.Expr:
    """``text`` parsed safely as a SymPy expression; ``scope`` maps the names it may use to their
    symbols, ``unknown(name, scope)`` says why another name is not allowed. Raises ModelError
    with the problem only (the caller adds the place)."""
    if len(text) > MAX_EXPRESSION_LENGTH:
        _fail(f"expression longer than {MAX_EXPRESSION_LENGTH} characters; split it with parameters")
    if not text.strip():
        _fail("empty expression; give a number or an expression such as \"L2/2\"")
    tokens = []
    pos = 0
    while pos < len(text):
        m = _TOKEN.match(text, pos)
        if not m:
            _fail(f"character {text[pos]!r} is not allowed in an expression; use numbers, "
                  f"names, + - * / ** ^ ( ), commas and (in Piecewise conditions) < <= > >=")
        pos = m.end()
        if m.lastgroup != "space":
            tokens.append((m.lastgroup, m.group()))
    for k, (kind, tok) in enumerate(tokens):
        nxt = tokens[k + 1] if k + 1 < len(tokens) else (None, None)
        if kind == "number" and not (math.isfinite(float(tok)) and _exponent(tok) <= 308):
            _fail(f"number {tok} is out of range; use numbers between 1e-308 and 1e308 in size")
        if kind == "number" and nxt[0] in ("name", "number"):
            _fail(f"{tok}{nxt[1]!s} in {text!r}: write products with '*' (e.g. {tok}*{nxt[1]})")
        if kind != "name":
            continue
        if tok == "True":
            continue  # placed by _condition_problem
        if "__" in tok:
            _fail(f"name {tok!r} is not allowed (double underscore); use parameter, coordinate "
                  f"and point names")
        calls = nxt[1] == "("
        if tok in FUNCTIONS:
            if not calls:
                _fail(f"function {tok} must be called, as {tok}(...)")
        elif tok in scope or tok in CONSTANTS:
            if calls:
                _fail(f"{tok!r} is not a function; write a '*' for a product, as {tok}*(...)")
        else:
            _fail(unknown(tok, scope))
    problem = _condition_problem(tokens)
    if problem:
        _fail(problem)
    glob = {"__builtins__": {}, **PARSER_NAMES, **FUNCTIONS, **CONSTANTS}
    local = dict(scope)
    transformations = (auto_number, convert_xor)
    try:
        # first unevaluated, so that the size check runs before any arithmetic
        lazy = {name: _unevaluated(fn) for name, fn in FUNCTIONS.items()}
        raw = parse_expr(text, local_dict=dict(local), transformations=transformations, evaluate=False,
                         global_dict={**glob, **lazy, **COMPARISON_NAMES, "Add": sp.Add, "Mul": sp.Mul,
                                      "Pow": sp.Pow})
        check_powers(raw)
        expr = parse_expr(text, local_dict=local, global_dict=glob, transformations=transformations)
    except ModelError:
        raise
    except Exception as exc:  # SyntaxError, TypeError from a wrong call, RecursionError, ...
        if isinstance(exc, TypeError) and "comparison" in str(exc):
            detail = "a condition compares values that are not real"
        elif isinstance(exc, TypeError):
            detail = "a function is given the wrong number of arguments"
        elif isinstance(exc, TokenError):
            detail = "unbalanced parentheses"
        elif isinstance(exc, SyntaxError):
            detail = exc.msg
        else:
            detail = str(exc).splitlines()[0] if str(exc) else type(exc).__name__
        raise ModelError(f"expression {text!r} does not parse ({detail}); check the parentheses, "
                         f"operators and function arguments") from None
    if not isinstance(expr, sp.Expr):
        _fail(f"expression {text!r} is not a single scalar; write one value")
    if expr.has(sp.zoo, sp.oo, -sp.oo, sp.nan, sp.I):
        _fail(f"expression {text!r} is not a finite real value ({expr}); check divisions "
              f"by zero and roots of negative numbers")
    check_size(expr, text)
    return expr


def check_size(expr, text: str):
    """Refuse expressions that would overflow a double or nest deeper than generated code and
    the derivation can follow."""
    levels = depth(expr)
    if levels > MAX_DEPTH:
        _fail(f"expression {text[:60]!r}… nests {levels} levels deep (at most {MAX_DEPTH}); "
              f"split it with parameters")
    for node in sp.postorder_traversal(expr):
        # every constant the generated code computes must be a double: exp(1000) is not
        if isinstance(node, sp.Expr) and not node.free_symbols and evaluate(node, {}) is None:
            _fail(f"expression {text[:60]!r} holds {_held(node)}, beyond a double; "
                  f"use numbers between 1e-308 and 1e308 in size")
    for power in expr.atoms(sp.Pow):
        if power.exp.is_Number and abs(float(power.exp)) > MAX_EXPONENT:
            _fail(f"expression {text[:60]!r} raises to the power {power.exp}; at most "
                  f"{MAX_EXPONENT} in size")


def check_powers(raw):
    """Refuse powers whose exact evaluation would not end (``9^9^9^9``)."""
    for node in sp.postorder_traversal(raw):
        if not isinstance(node, sp.Pow):
            continue
        for part, limit, what in ((node.exp, MAX_EXPONENT, "exponent"), (node.base, MAX_CONSTANT_BASE, "base")):
            if what == "base" and node.exp.free_symbols:
                continue
            if part.free_symbols:
                continue
            try:
                size = abs(complex(sp.N(part, 15)))
            except (TypeError, ValueError, OverflowError):
                size = math.inf
            if not size <= limit:
                _fail(f"the {what} {part} of a constant power is too large (limit "
                      f"{limit:g}); write the value as a number")
