"""Pseudo-inertia matrices ``H = ∫ [x y z 1]ᵀ[x y z 1] dm`` (4x4) of primitive shapes.

Each function returns a SymPy ImmutableMatrix of the given (symbolic or numeric) quantities,
in the body's own frame; kg·m² for the second moments, kg·m for the first, kg in the corner.
"""

from __future__ import annotations

import sympy as sp

from .chain import AXES


def pseudo_inertia(mass, center=(0, 0, 0), second_moments=(0, 0, 0), products=(0, 0, 0)):
    """H from the mass (kg), centre of mass (m), second moments ``∫x², ∫y², ∫z² dm`` about the
    frame origin and products ``∫xy, ∫xz, ∫yz dm`` (kg·m²)."""
    m = sp.sympify(mass)
    xx, yy, zz = (sp.sympify(v) for v in second_moments)
    xy, xz, yz = (sp.sympify(v) for v in products)
    cx, cy, cz = (m * sp.sympify(v) for v in center)
    return sp.ImmutableMatrix(
        [[xx, xy, xz, cx], [xy, yy, yz, cy], [xz, yz, zz, cz], [cx, cy, cz, m]]
    )


def from_inertia_tensor(mass, center, inertia):
    """H from the mass (kg), centre of mass (m) and the 3x3 inertia tensor about the centre of
    mass in the body frame (kg·m²): ``∫ r rᵀ dm = ½ tr(I)·1 - I`` about the centre, then shifted."""
    inertia = sp.Matrix(inertia)
    c = sp.Matrix([sp.sympify(v) for v in center])
    m = sp.sympify(mass)
    second = sp.eye(3) * inertia.trace() / 2 - inertia + m * c * c.T
    return pseudo_inertia(
        m, center, (second[0, 0], second[1, 1], second[2, 2]), (second[0, 1], second[0, 2], second[1, 2])
    )


def shape_quantities(**quantities) -> tuple:
    """``Body.quantities`` of a body made from a shape: ``(("shape", name), value)`` pairs in the
    order given (the order of the shape's keys in a model file)."""
    return tuple((("shape", name), value) for name, value in quantities.items())


def solid_cylinder(mass, radius, length, axis):
    """Solid cylinder of ``radius`` whose axis runs along ``axis`` from 0 to ``length``."""
    k = AXES.index(axis)
    moments = [mass * radius**2 / 4] * 3
    moments[k] = mass * length**2 / 3
    center = [0, 0, 0]
    center[k] = length / 2
    return pseudo_inertia(mass, center, moments)


def bar(mass, length, width, thickness):
    """Slender bar along x from 0 to ``length``; ``thickness`` along y, ``width`` along z."""
    return pseudo_inertia(
        mass, (length / 2, 0, 0), (mass * length**2 / 3, mass * thickness**2 / 12, mass * width**2 / 12)
    )


def rod(mass, length, radius):
    """Solid round rod along x from 0 to ``length``."""
    return solid_cylinder(mass, radius, length, "x")


def point_mass(mass, position=(0, 0, 0)):
    """A point mass at ``position``."""
    x, y, z = (sp.sympify(v) for v in position)
    return pseudo_inertia(mass, position, (mass * x**2, mass * y**2, mass * z**2),
                          (mass * x * y, mass * x * z, mass * y * z))
