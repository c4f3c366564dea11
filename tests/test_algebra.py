"""The derivation's zero-skipping matrix products give SymPy's own expressions, object for object."""

import random

import pytest
import sympy as sp

from gpmegen.symbolic.algebra import cross, dot, mul


def _entry(rnd, symbols):
    kind = rnd.randrange(6)
    if kind < 2:
        return sp.S.Zero
    if kind == 2:
        return sp.Integer(rnd.choice([-1, 1, 2]))
    if kind == 3:
        return sp.Float(round(rnd.uniform(-2, 2), 3))
    a, b = rnd.sample(symbols, 2)
    return rnd.choice([a * b, a + b, sp.cos(a) - b, -a])


@pytest.mark.parametrize("seed", range(20))
def test_products_equal_sympys(seed):
    rnd = random.Random(seed)
    symbols = list(sp.symbols("a b c d e", real=True))
    A = sp.Matrix(3, 3, [_entry(rnd, symbols) for _ in range(9)])
    B = sp.Matrix(3, 2, [_entry(rnd, symbols) for _ in range(6)])
    u = sp.Matrix(3, 1, [_entry(rnd, symbols) for _ in range(3)])
    v = sp.Matrix(3, 1, [_entry(rnd, symbols) for _ in range(3)])
    assert list(mul(A, B)) == list(A * B) and mul(A, B).shape == (3, 2)
    assert list(mul(u, v.T)) == list(u * v.T)
    assert dot(u, v) == u.dot(v)
    assert list(cross(u, v)) == list(u.cross(v))
    assert cross(u.T, v).shape == (1, 3)
    # the difference, not only equal-looking: a wrong sign or a dropped term is caught
    assert sp.expand(dot(u, cross(u, v))) == 0


def test_shapes_checked():
    with pytest.raises(sp.ShapeError):
        mul(sp.ones(3, 2), sp.ones(3, 2))
    with pytest.raises(sp.ShapeError):
        dot(sp.ones(3, 1), sp.ones(2, 1))
