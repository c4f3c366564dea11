"""Programmed laws that switch: ``Min``, ``Max``, ``Abs``, ``sign`` and ``Heaviside`` written as
``Piecewise``, and the switches where a law's derivative would hold an impulse.

SymPy differentiates ``Min``, ``Max`` and ``Abs`` into ``Heaviside`` and ``sign``, and those into
``DiracDelta``, which no generated code can evaluate. Written as ``Piecewise`` first, a law is
differentiated branch by branch: between switches its rates are exact; at the switching instant
itself they are those of the branch whose condition holds there (``Abs(u)`` becomes
``u·sign(u)``, whose rate at ``u = 0`` is 0). What this leaves out is the Dirac delta at the
switch, an impulse of the size of the jump there. The rule: **that impulse is not applied**. A
jump in the highest derivative (``Φ̈`` of a position constraint, ``Ψ̇`` of a first-order one) is
an ordinary jump in acceleration. A jump in ``Φ̇`` (or in ``Φ``, or in ``Ψ``) would need a jump
in ``q̇``: the motion keeps its velocity through the switch, the constraint's rate is off by the
jump just after it, and the Baumgarte terms pull the motion back onto the constraint.
:func:`jumps` finds such switches so that the derivation can warn about them.

``Heaviside(x)`` is 1/2 at ``x = 0`` (SymPy's convention; ``Heaviside(x, h0)`` gives ``h0``),
here and in both printers.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..model.names import TIME

SWITCHING = (sp.Min, sp.Max, sp.Abs, sp.sign, sp.Heaviside)


def as_piecewise(expr) -> sp.Expr:
    """``expr`` with every Min, Max, Abs, sign and Heaviside written as Piecewise, so that its
    derivatives are taken branch by branch. ``Abs(u)`` becomes ``u·sign(u)``: ``u`` once, not
    once per branch, or nested Abs would grow exponentially."""
    expr = sp.sympify(expr)
    if not expr.args:
        return expr
    args = [as_piecewise(a) for a in expr.args]
    if isinstance(expr, sp.Abs):
        return args[0] * _piecewise(sp.sign, expr.args, args)
    if isinstance(expr, SWITCHING):
        return _piecewise(expr.func, expr.args, args)
    return expr.func(*args) if any(a is not b for a, b in zip(args, expr.args)) else expr


def _piecewise(function, arguments, rewritten) -> sp.Piecewise:
    """``function(*arguments)`` as a Piecewise whose values hold the ``rewritten`` arguments
    and whose conditions the ``arguments`` as they are: conditions are never differentiated,
    and a Piecewise in a condition costs time exponential in the nesting."""
    # named by position: Min and Max order their arguments by name, and a bare Dummy's name is a
    # process-wide count, whose string order flips where it gains a digit (_Dummy_99, _Dummy_100),
    # so one switch was written with >= in one place and <= in another, and at the switch itself
    # its derivatives there took different branches
    symbols = [sp.Dummy(f"argument{k:04d}", real=True) for k in range(len(arguments))]
    form = function(*symbols).rewrite(sp.Piecewise)
    values, conditions = dict(zip(symbols, rewritten)), dict(zip(symbols, arguments))
    return sp.Piecewise(*[(e.xreplace(values), c.xreplace(conditions)) for e, c in form.args])


# Beyond these sizes a jump is not worked out (piecewise_fold doubles the branches per switch,
# simplify slows with size): the switch is reported as one that may jump.
MAX_FOLDED = 6        # Piecewise in a jump
MAX_OPERATIONS = 400  # operations in a jump


@dataclass(frozen=True)
class Switch:
    """A switch of a law, on the surface ``where = 0``: located at ``variable = value``
    (``value`` free of ``variable``) or not (both None). ``certain``: the law jumps there; else
    it may (the switch is not located, or the jump too large to decide)."""

    where: sp.Expr
    variable: sp.Symbol | None = None
    value: sp.Expr | None = None
    certain: bool = False

    def describe(self, defaults) -> str:
        """``at t = T (0.5 s with the parameter defaults)`` or ``where x_E**2 - 0.1 = 0``, for
        messages; ``defaults``: parameter symbol -> number."""
        if self.value is None:
            return f"where {_decimal(self.where)} = 0"
        unit = " s" if self.variable == TIME else ""
        if self.value.is_number:
            return f"at {self.variable} = {float(self.value):.6g}{unit}"
        number = self.value.xreplace(defaults)
        known = f" ({float(number):.6g}{unit} with the parameter defaults)" if number.is_number else ""
        return f"at {self.variable} = {_decimal(self.value)}{known}"


def exact(expr) -> sp.Expr:
    """``expr`` with its floats as the binary fractions they stand for, exactly."""
    expr = sp.sympify(expr)
    return expr.xreplace({f: sp.Rational(f) for f in expr.atoms(sp.Float)})


def _decimal(expr):
    """``expr`` with the binary fractions of floats (see :func:`exact`) as decimals again."""
    return expr.xreplace({r: sp.Float(r, 6) for r in expr.atoms(sp.Rational) if r.q > 10**6})


def _surface(relation, variables, defaults):
    """``(variable, value, sign)``: ``lhs - rhs`` of ``relation`` changes sign at
    ``variable = value`` and has the sign ``sign·(variable - value)``, ``variable`` being the
    first of ``variables`` it holds. ``()`` when it holds none (a switch between parameter
    values, not in the motion); None when it is not linear in ``variable`` or the sign of its
    slope is unknown even with the parameter ``defaults``."""
    g = relation.lhs - relation.rhs
    held = [v for v in variables if v in g.free_symbols]
    if not held:
        return ()
    variable = held[0]
    slope = sp.diff(g, variable)
    sign = slope.xreplace(defaults)
    if slope.has(variable) or not (sign.is_number and sign.is_real and sign != 0):
        return None
    return variable, -g.subs(variable, 0) / slope, 1 if sign > 0 else -1


def _where(relation) -> sp.Expr:
    """``lhs - rhs`` of ``relation`` or its negative, the one without a leading minus: one
    expression per switching surface."""
    g = sp.expand(relation.lhs - relation.rhs)
    return -g if g.could_extract_minus_sign() else g


def _truth(relation, sign):
    """Whether ``relation`` holds where ``lhs - rhs`` has the sign ``sign`` (±1)."""
    return relation.func(sp.Integer(sign), sp.S.Zero)


def _settled(expr, defaults):
    """``expr`` with the conditions between parameters alone decided by their defaults (which
    of two switching instants comes first, say)."""
    fixed = {r: r.xreplace(defaults) for r in expr.atoms(sp.core.relational.Relational)
             if r.free_symbols <= defaults.keys()}
    return expr.xreplace({r: v for r, v in fixed.items() if v in (sp.true, sp.false)})


def _is_zero(expr):
    """True, False, or None when ``expr`` is too large to decide."""
    if len(expr.atoms(sp.Piecewise)) > MAX_FOLDED:
        return None
    expr = sp.piecewise_fold(expr)
    branches = [e for e, _ in expr.args] if isinstance(expr, sp.Piecewise) else [expr]
    if sum(sp.count_ops(e) for e in branches) > MAX_OPERATIONS:
        return None
    return all(sp.simplify(e) == 0 for e in branches)


def jumps(expr, variables, defaults) -> list[Switch]:
    """The switches of ``expr`` across which it jumps, then those it may jump across (that
    cannot be located or decided), each in a fixed order. ``variables``: the symbols a switch may
    move with, in order of preference (``t`` first); ``defaults``: parameter symbol -> number,
    which decide the side of a switch whose slope depends on parameters and the order of
    switches. Give ``expr`` :func:`exact`: with floats, a number and the same number computed
    again need not cancel at a switch."""
    located: dict = {}
    switches: list = []
    for relation in sorted(expr.atoms(sp.core.relational.Relational), key=sp.default_sort_key):
        surface = _surface(relation, variables, defaults)
        if surface is None:
            switches.append(Switch(_where(relation)))
        elif surface:
            variable, value, sign = surface
            located.setdefault((variable, value), []).append((relation, sign))
    for (variable, value), relations in located.items():
        before = {r: _truth(r, -sign) for r, sign in relations}
        after = {r: _truth(r, sign) for r, sign in relations}
        zero = _is_zero(_settled((expr.xreplace(after) - expr.xreplace(before)).subs(variable, value), defaults))
        if not zero:
            switches.append(Switch(_where(relations[0][0]), variable, value, certain=zero is False))
    return sorted(dict.fromkeys(switches), key=lambda s: not s.certain)


#: What a law whose derivatives generated code cannot evaluate is told to use instead.
PRINTABLE_HINT = "smooth functions, Min, Max, Abs, Heaviside or Piecewise"


def unprintable(derivatives):
    """The first function whose derivative SymPy leaves unevaluated or impulsive (floor, Mod,
    DiracDelta, an undefined function) in ``derivatives``, which generated code could not
    evaluate; None when there is none."""
    for d in derivatives:
        stuck = sorted(d.atoms(sp.Derivative, sp.DiracDelta), key=sp.default_sort_key)
        if stuck:
            return stuck[0].expr.func if isinstance(stuck[0], sp.Derivative) else stuck[0].func
    return None


def jump_warnings(subject, checked, defaults, consequence) -> list[str]:
    """Messages, each ``subject: ...``, about the switches where a quantity of one law jumps:
    one per located switch (naming the first of ``checked``, ``(label, expression)`` pairs given
    :func:`exact`, that jumps there), and one for all the switches that could not be located or
    decided; ``consequence`` says what the impulse left out does and what to write instead."""
    variables = list(dict.fromkeys([TIME] + sorted((s for _, e in checked for s in e.free_symbols
                                                    if s != TIME and s not in defaults), key=str)))
    messages, seen, undecided = [], set(), {}
    for label, expr in checked:
        for switch in jumps(expr, variables, defaults):
            if not switch.certain:
                undecided.setdefault(switch.describe(defaults), None)
            elif switch.where not in seen:
                seen.add(switch.where)
                messages.append(f"{subject}: {label} jumps {switch.describe(defaults)}; {consequence}")
    if undecided:
        places = list(undecided)
        where = ", ".join(places[:3]) + (f" and {len(places) - 3} more places" if len(places) > 3 else "")
        labels = " or ".join(label for label, _ in checked)
        messages.append(f"{subject}: its law switches {where}, and gpmegen cannot tell whether {labels} "
                        f"jumps there; if it does, {consequence}")
    return messages


__all__ = ["SWITCHING", "Switch", "as_piecewise", "exact", "jump_warnings", "jumps"]
