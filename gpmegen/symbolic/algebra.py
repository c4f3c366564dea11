"""Products of small symbolic matrices that leave exact zeros out.

SymPy's ``Matrix * Matrix`` (and ``dot``, which goes through it) multiplies every stored entry
of both factors by zero to catch infinities (``0·∞ = nan``), and ``cross`` forms every product;
each new product asks SymPy's assumptions about its factors (``0·x`` asks whether ``x`` is
finite). The derivation's entries are finite (real symbols, their sums, products, sines and
cosines), and its rotations, axes and inertias hold many exact zeros, so these skip every term
with an exact zero factor and add the rest with one ``Add``: the same expressions SymPy gives
(``Add`` and ``Mul`` are canonical, ``x + 0`` is ``x``), built without the products by zero.
"""

from __future__ import annotations

import sympy as sp

ZERO = sp.S.Zero


def _nonzero(x) -> bool:
    return x is not ZERO   # SymPy's integer zero is one object; a float zero is kept, as SymPy does


def mul(a: sp.Matrix, b: sp.Matrix) -> sp.Matrix:
    """``a * b`` of two matrices (SymPy's entries, without the terms of an exact zero factor)."""
    rows, inner, cols = a.rows, a.cols, b.cols
    if b.rows != inner:
        raise sp.ShapeError(f"matrices of shapes {a.shape} and {b.shape} cannot be multiplied")
    left = [[(k, x) for k in range(inner) if _nonzero(x := a[i, k])] for i in range(rows)]
    right = [[b[k, j] for j in range(cols)] for k in range(inner)]
    entries = []
    for i in range(rows):
        for j in range(cols):
            terms = [x * right[k][j] for k, x in left[i] if _nonzero(right[k][j])]
            entries.append(sp.Add(*terms) if terms else ZERO)
    return sp.Matrix(rows, cols, entries)


def dot(a: sp.Matrix, b: sp.Matrix):
    """``a·b`` of two vectors of as many entries (SymPy's ``a.dot(b)``, without zero terms)."""
    if len(a) != len(b):
        raise sp.ShapeError(f"vectors of {len(a)} and {len(b)} entries have no dot product")
    terms = [x * y for x, y in zip(a, b) if _nonzero(x) and _nonzero(y)]
    return sp.Add(*terms) if terms else ZERO


def _difference(x1, y1, x2, y2):
    """``x1·y1 - x2·y2``, a product of an exact zero left out."""
    first = x1 * y1 if _nonzero(x1) and _nonzero(y1) else None
    second = x2 * y2 if _nonzero(x2) and _nonzero(y2) else None
    if first is None:
        return -second if second is not None else ZERO
    return first - second if second is not None else first


def cross(a: sp.Matrix, b: sp.Matrix) -> sp.Matrix:
    """``a × b`` of two 3-vectors, shaped as ``a`` (SymPy's ``a.cross(b)``)."""
    return sp.Matrix(a.rows, a.cols, [_difference(a[1], b[2], a[2], b[1]),
                                      _difference(a[2], b[0], a[0], b[2]),
                                      _difference(a[0], b[1], a[1], b[0])])
