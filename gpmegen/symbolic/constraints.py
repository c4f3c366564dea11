"""Programmed constraints: values, Jacobian ``D`` and the velocity-product term ``γ``.

For each constraint the generated code returns ``Φ`` (value), ``Φ̇`` (rate, position
constraints only), the row ``D`` and ``γ`` such that the constraint's highest derivative is
``D q̈ + γ`` (``Φ̈`` for a position constraint, ``Ψ̇`` for a first-order one, the constraint
itself for a second-order one). The GPME rows are then ``D q̈ = -γ - 2αΦ̇ - β²Φ``,
``D q̈ = -γ - αΨ`` (paper eqs. 13 and 16) or ``D q̈ = -γ``. A second-order constraint has no
value at a state ``(t, q, q̇)`` (it needs ``q̈``): its ``Φ`` and ``Φ̇`` are 0.

Expressions name point coordinates ``x_P, y_P, z_P``, point velocities ``vx_P, vy_P, vz_P``,
point accelerations ``ax_P, ay_P, az_P``, coordinates by name, their velocities ``<name>_dot``
and accelerations ``<name>_ddot``, time ``t`` and parameters. Point velocities and
accelerations come from the kinematics, so ``p̈ = J_P q̈ + a_P`` is never differentiated
symbolically through the chain: an acceleration's coefficient enters ``D`` through ``J_P`` (or
the coordinate's column), and ``γ`` is the constraint with ``p̈ → a_P`` and ``q̈ → 0``.

Laws that switch (``Min``, ``Max``, ``Abs``, ``Heaviside``, ``Piecewise``) are differentiated
branch by branch (:mod:`gpmegen.symbolic.piecewise`): the Dirac delta at a switch is dropped,
i.e. the impulse there is not applied. Where that matters (``Φ`` or ``Φ̇`` of a position
constraint, ``Ψ`` of a first-order one jumps at a switch) the derivation says so in
``warnings``: after the switch the Baumgarte terms pull the motion back onto the constraint.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..errors import DerivationError
from ..model.chain import (
    AXES,
    TIME,
    acceleration_symbol,
    axis_symbols,
    point_acceleration_symbols,
    point_symbols,
    point_velocity_symbols,
    symbol,
    velocity_symbol,
)
from .kinematics import Kinematics
from .names import point_acceleration
from .piecewise import PRINTABLE_HINT, as_piecewise, exact, jump_warnings, unprintable


@dataclass
class ConstraintTerms:
    """Per constraint (m of them): ``value`` (m,), ``rate`` (m,), ``jacobian`` (m, n),
    ``gamma`` (m,), and the Baumgarte gains ``alpha``, ``beta`` (m,) as expressions;
    ``warnings``: messages about the switches where a law jumps (see the module's doc)."""

    names: tuple
    orders: tuple
    value: sp.Matrix
    rate: sp.Matrix
    jacobian: sp.Matrix
    gamma: sp.Matrix
    alpha: sp.Matrix
    beta: sp.Matrix
    warnings: tuple = ()   # one line each: switches where an impulse is not applied


class _Symbols:
    """What the user symbols of constraint expressions stand for on the chain whose kinematics
    is ``kin``: ``internal`` (user symbol -> internal expression), ``rate_of`` (user symbol ->
    its time derivative at q̈ = 0, a user symbol) and where the coefficients of rates and
    accelerations enter ``D`` (``velocity_column`` and ``acceleration_column``: symbol -> j;
    ``velocity_jacobian`` and ``acceleration_jacobian``: symbol -> (n,) components). The axes of
    points' frames (:func:`gpmegen.model.chain.axis_symbols`, a closure's) are defined only
    where ``expressions`` use them."""

    def __init__(self, kin: Kinematics, expressions):
        n = self.n = len(kin.q)
        names = kin.chain.coordinates
        internal = self.internal = {}
        rate_of = self.rate_of = {}
        self.velocity_column, self.acceleration_column = {}, {}
        self.velocity_jacobian, self.acceleration_jacobian = {}, {}
        for j, name in enumerate(names):
            internal[symbol(name)] = kin.q[j]
            internal[velocity_symbol(name)] = kin.qd[j]
            internal[acceleration_symbol(name)] = sp.S.Zero   # its velocity-product part
            rate_of[symbol(name)] = velocity_symbol(name)
            self.velocity_column[velocity_symbol(name)] = self.acceleration_column[acceleration_symbol(name)] = j
        for pname, pt in kin.points.items():
            xs, vs, accs = point_symbols(pname), point_velocity_symbols(pname), point_acceleration(pname)
            for k, a in enumerate(point_acceleration_symbols(pname)):
                internal[xs[k]] = pt.position[k]
                internal[vs[k]] = pt.velocity[k]
                internal[accs[k]] = internal[a] = pt.acceleration[k]
                rate_of[xs[k]] = vs[k]
                rate_of[vs[k]] = accs[k]
                self.velocity_jacobian[vs[k]] = self.acceleration_jacobian[a] = [pt.jacobian[j][k] for j in range(n)]
        used = {s for e in expressions for s in sp.sympify(e).free_symbols}
        for pname, pt in kin.points.items():
            for axis in AXES:
                es = axis_symbols(pname, axis)
                if used & set(es):
                    self._axis(kin, pt, axis, es)

    def _axis(self, kin, pt, axis, es):
        """The unit vector ``e`` along ``axis`` of point ``pt``'s frame, its rate ``ω × e`` and the
        velocity-product part of its second derivative ``α × e + ω × (ω × e)``."""
        define_all = kin.program.define_all
        e = pt.R[:, AXES.index(axis)]
        rate = define_all(pt.w.cross(e))
        second = define_all(pt.alpha.cross(e) + pt.w.cross(rate))
        moving = kin.chain.topology.supports[pt.joint] if pt.joint >= 0 else ()
        columns = [define_all(jt.omega.cross(e)) if jt.index in moving else sp.zeros(3, 1) for jt in kin.joints]
        columns += [sp.zeros(3, 1)] * (self.n - len(columns))
        for k in range(3):
            v, a = (sp.Symbol(f"{kind}{es[k].name}", real=True) for kind in ("v", "a"))
            self.internal[es[k]], self.internal[v], self.internal[a] = e[k], rate[k], second[k]
            self.rate_of[es[k]], self.rate_of[v] = v, a
            self.velocity_jacobian[v] = [columns[j][k] for j in range(self.n)]

    def rate(self, expr):
        """Velocity-product part of d/dt expr (the q̈ part is D q̈), in user symbols."""
        return sp.diff(expr, TIME) + sum(
            (sp.diff(expr, s) * self.rate_of[s] for s in sorted(expr.free_symbols, key=str) if s in self.rate_of),
            sp.S.Zero,
        )

    def jacobian_row(self, expr, column, jacobian):
        """Coefficients of q̈ in ``expr``'s highest derivative, for expr linear in the rates that
        ``column`` and ``jacobian`` map (velocities: of d/dt expr; accelerations: of expr
        itself), in internal symbols."""
        row = [sp.S.Zero] * self.n
        for s in sorted(expr.free_symbols, key=str):
            if s in column:
                row[column[s]] += sp.diff(expr, s)
            elif s in jacobian:
                coeff = sp.diff(expr, s)
                for j, component in enumerate(jacobian[s]):
                    row[j] += coeff * component
        return [v.xreplace(self.internal) for v in row]


def state_expressions(kin: Kinematics, expressions) -> list:
    """``expressions`` of the user's state symbols (coordinates, ``<name>_dot``, points'
    positions and velocities, as a first-order constraint names them; a drive's feedback law)
    in the kinematics' internal symbols, switches kept as written."""
    symbols = _Symbols(kin, expressions)
    return [sp.sympify(e).xreplace(symbols.internal) for e in expressions]


def constant_rows(kin: Kinematics, constraints) -> list[str]:
    """For each position constraint: "zero" where it vanishes identically on the chain (its value
    and its row of ``D`` are exact zeros once written in the kinematics' intermediates: a
    closure's out-of-plane rows in a planar linkage), "constant" where its row of ``D`` does but
    its value does not, else "". Defines intermediates in ``kin.program``: give it a program of
    its own."""
    symbols = _Symbols(kin, [c.expression for c in constraints])
    out = []
    for c in constraints:
        expr = as_piecewise(c.expression)
        row = symbols.jacobian_row(symbols.rate(expr), symbols.velocity_column, symbols.velocity_jacobian)
        if c.order != 0 or any(v != 0 for v in row):
            out.append("")
        else:
            out.append("zero" if expr.xreplace(symbols.internal) == 0 else "constant")
    return out


def derive(kin: Kinematics, constraints) -> ConstraintTerms:
    """Terms of the programmed constraints on the chain whose kinematics is ``kin``."""
    define = kin.program.define
    symbols = _Symbols(kin, [c.expression for c in constraints])
    internal, rate, jacobian_row = symbols.internal, symbols.rate, symbols.jacobian_row
    velocity_column, acceleration_column = symbols.velocity_column, symbols.acceleration_column
    velocity_jacobian, acceleration_jacobian = symbols.velocity_jacobian, symbols.acceleration_jacobian
    n = len(kin.q)

    defaults = {p.symbol: sp.Float(p.default) for p in kin.chain.model.parameters}
    values, rates, rows, gammas, warnings = [], [], [], [], []
    for k, c in enumerate(constraints):
        expr = as_piecewise(c.expression)
        if c.order == 2:
            first = sp.S.Zero
            row = jacobian_row(expr, acceleration_column, acceleration_jacobian)
        else:
            first = rate(expr) if c.order == 0 else expr  # Φ̇, or Ψ itself
            row = jacobian_row(first, velocity_column, velocity_jacobian)
        if all(v == 0 for v in row):
            raise DerivationError(
                f"constraint {c.name!r} does not depend on any coordinate, so no motion can hold "
                f"it: check that it names a point or a coordinate", ("constraints", k, "expression"))
        second = expr if c.order == 2 else rate(first)   # γ: the velocity-product part
        _check_printable(c.name, (first, second), ("constraints", k, "expression"))
        law = as_piecewise(exact(c.expression))
        # a second-order constraint that jumps makes the accelerations jump: no impulse is lost
        checked = (("Φ", law), ("Φ̇", rate(law))) if c.order == 0 else (("Ψ", law),) if c.order == 1 else ()
        warnings += _jump_warnings(c.name, checked, defaults, "continuously differentiable" if c.order == 0 else
                                   "continuous")
        values.append(define(expr.xreplace(internal)) if c.order < 2 else sp.S.Zero)
        rates.append(define(first.xreplace(internal)) if c.order == 0 else sp.S.Zero)
        rows.append([define(v) for v in row])
        gammas.append(define(second.xreplace(internal)))
    m = len(values)
    return ConstraintTerms(
        names=tuple(c.name for c in constraints),
        orders=tuple(int(c.order) for c in constraints),   # 2.0 -> 2: printed into C as an int
        value=sp.Matrix(m, 1, values),
        rate=sp.Matrix(m, 1, rates),
        jacobian=sp.Matrix(m, n, [v for r in rows for v in r]) if m else sp.zeros(0, n),
        gamma=sp.Matrix(m, 1, gammas),
        alpha=sp.Matrix(m, 1, [sp.sympify(c.alpha) for c in constraints]),
        beta=sp.Matrix(m, 1, [sp.sympify(c.beta) for c in constraints]),
        warnings=tuple(warnings),
    )


def _check_printable(name, derivatives, subject):
    """Refuse a law whose derivatives generated code could not evaluate (:func:`unprintable`).
    ``subject``: the path of the law's field."""
    function = unprintable(derivatives)
    if function is not None:
        raise DerivationError(f"constraint {name!r}: its law uses {function}, whose derivative generated code "
                              f"cannot evaluate; write the law with {PRINTABLE_HINT}", subject)


def _jump_warnings(name, checked, defaults, smooth) -> list[str]:
    """Messages about the switches where a quantity of constraint ``name`` jumps
    (:func:`~gpmegen.symbolic.piecewise.jump_warnings`); ``smooth`` says what the law should be
    instead."""
    consequence = ("the impulse there is not applied and the Baumgarte terms pull the motion back onto the "
                   f"constraint: make the law {smooth} there (see docs/model-file.md)")
    return jump_warnings(f"constraint {name!r}", checked, defaults, consequence)
