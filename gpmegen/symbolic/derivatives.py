"""Forward differentiation of the straight-line :class:`~gpmegen.symbolic.program.Program`.

Every intermediate ``x = e(y, z, …)`` the differentiated outputs depend on gets its derivative
intermediates ``∂x/∂v_k = Σ_y ∂e/∂y · ∂y/∂v_k`` for each variable ``v_k``, defined in the same
program right after the existing ones; derivatives that are zero are never formed. So the
derivative program is as deep as the original one and at most ``len(variables)`` times as wide,
and expressions are never expanded through the chain.

Laws that switch are differentiated branch by branch, as the constraint rates are
(:mod:`gpmegen.symbolic.constraints`): the Dirac delta at a switch is dropped.

The GPME Jacobian needs, besides ``∂f``, the derivatives of products with given vectors
(``M a``, ``Dᵀλ``, ``D a``): :func:`gpme_residuals` writes them as O(n) expressions before
differentiating, so their Jacobians take O(n²) intermediates, not the O(n³) of ``∂M/∂q``.
"""

from __future__ import annotations

import sympy as sp

from .program import Program


class Tangents:
    """Derivatives of expressions of ``program`` with respect to ``variables`` (symbols), each
    intermediate's derivatives formed once and shared by every output that needs them."""

    def __init__(self, program: Program, variables):
        self.program = program
        self.variables = tuple(variables)
        self._seed = {v: {k: sp.S.One} for k, v in enumerate(self.variables)}
        self._done: dict = {}   # intermediate symbol -> {variable index: derivative (symbol or trivial)}

    def _of_symbol(self, s) -> dict:
        return self._seed.get(s) or self._done.get(s, {})

    def _differentiate(self, expr) -> dict:
        """``{k: ∂expr/∂v_k}`` for the nonzero derivatives, from those of its free symbols."""
        result: dict = {}
        for s in sorted(expr.free_symbols, key=sp.default_sort_key):
            inner = self._of_symbol(s)
            if not inner:
                continue
            partial = _without_impulses(sp.diff(expr, s))
            if partial == 0:
                continue
            for k, d in inner.items():
                result[k] = result.get(k, sp.S.Zero) + partial * d
        return {k: v for k, v in sorted(result.items()) if v != 0}

    def jacobian(self, outputs) -> sp.Matrix:
        """``(len(outputs), len(variables))`` matrix of the derivatives of ``outputs``
        (expressions of the program's symbols), as intermediates of the program."""
        outputs = [sp.sympify(e) for e in outputs]
        for s, e in self.program.closure(outputs):
            if s not in self._done:
                self._done[s] = {k: self.program.define(v) for k, v in self._differentiate(e).items()}
        J = sp.zeros(len(outputs), len(self.variables))
        for i, e in enumerate(outputs):
            for k, v in self._differentiate(e).items():
                J[i, k] = self.program.define(v)
        return J


def _without_impulses(expr):
    """``expr`` with its Dirac deltas (the derivative of a jump) set to zero."""
    return expr.replace(sp.DiracDelta, lambda *args: sp.S.Zero) if expr.has(sp.DiracDelta) else expr


def constraint_rhs(con):
    """Right sides ``c`` (m,) of the constraint rows ``D q̈ = c``: ``-γ - 2αΦ̇ - β²Φ`` (order 0),
    ``-γ - αΨ`` (order 1), ``-γ`` (order 2); as :func:`gpmegen.runtime.gpme.constraint_rhs`."""
    rhs = []
    for k, order in enumerate(con.orders):
        c = -con.gamma[k]
        if order == 0:
            c -= 2 * con.alpha[k] * con.rate[k] + con.beta[k] ** 2 * con.value[k]
        elif order == 1:
            c -= con.alpha[k] * con.value[k]
        rhs.append(c)
    return sp.Matrix(len(rhs), 1, rhs)


def gpme_residuals(d, a, lam):
    """The GPME residuals whose derivatives give ``∂q̈``: ``F = f - M a + Dᵀλ`` (n,) and
    ``C = c - D a`` (m,) at given accelerations ``a`` (n,) and multipliers ``λ`` (m,) (symbols),
    with ``M q̈ - f = Dᵀλ`` the sign of :func:`gpmegen.runtime.gpme.multipliers`."""
    dyn, con = d.dynamics, d.constraints
    n, m = len(a), len(lam)
    mass_a = dyn.mass_product(d.kinematics, sp.Matrix(a), d.program.define_all)
    F = dyn.forces - mass_a + (con.jacobian.T * sp.Matrix(lam) if m else sp.zeros(n, 1))
    C = constraint_rhs(con) - (con.jacobian * sp.Matrix(a) if m else sp.zeros(0, 1))
    return F, C


def gpme_jacobians(d, a, lam):
    """``(∂F/∂q, ∂F/∂q̇, ∂C/∂q, ∂C/∂q̇)`` of :func:`gpme_residuals`, shapes (n, n) and (m, n)."""
    kin = d.kinematics
    n = len(kin.q)
    F, C = gpme_residuals(d, a, lam)
    tangents = Tangents(d.program, list(kin.q) + list(kin.qd))
    JF = tangents.jacobian(list(F))
    JC = tangents.jacobian(list(C)) if len(C) else sp.zeros(0, 2 * n)
    return JF[:, :n], JF[:, n:], JC[:, :n], JC[:, n:]
