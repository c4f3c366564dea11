"""RK4's region of absolute stability and the largest step it allows for a set of eigenvalues.

A classical RK4 step multiplies a mode ``ẋ = λ x`` by ``R(hλ)``, ``R(z) = 1 + z + z²/2 + z³/6 +
z⁴/24``; the mode stays bounded while ``|R(hλ)| ≤ 1``. Along the ray of ``λ`` the step leaves the
region where ``|R(r e^{iθ})| = 1`` first for ``r > 0``: ``2√2`` on the imaginary axis (an undamped
mode, the old ``2√2/ω``), 2.785 on the negative real axis (an overdamped one), and less than either
in between for some angles. The stable step of a linearized system is the smallest ``r(θ)/|λ|``.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.optimize

# RK4's stability polynomial, lowest power first.
COEFFICIENTS = np.array([1.0, 1.0, 1.0 / 2, 1.0 / 6, 1.0 / 24])
# The region lies within |z| < 3 (its farthest point, at about 2.96, lies between the axes); scanned on this
# many points before the crossing is refined.
OUTER = 3.2
SCAN = 3000
# |R|² - 1 counts as past the boundary above this: near the origin on the imaginary axis |R|² is
# 1 - y⁶/72, which round-off could otherwise lift above 1.
PAST = 1e-9
# Eigenvalues below this fraction of the largest modulus are zero (a free rotation), and a real
# part below it times |λ| is taken as zero (an undamped mode, split by round-off).
NEGLIGIBLE = 1e-9


def amplification(z):
    """``|R(z)|`` of one RK4 step for ``z = hλ`` (complex, any shape)."""
    z = np.asarray(z, dtype=complex)
    return np.abs(np.polynomial.polynomial.polyval(z, COEFFICIENTS))


def boundary_radius(theta: float) -> float:
    """The ``r > 0`` (dimensionless) where the ray ``r e^{iθ}`` first leaves RK4's stability region,
    ``θ`` in ``[π/2, π]`` (the closed left half-plane)."""
    ray = np.exp(1j * theta)
    r = np.linspace(0.0, OUTER, SCAN + 1)[1:]
    excess = amplification(r * ray) ** 2 - 1.0
    k = int(np.argmax(excess > PAST))
    low = r[k - 1] if k else 0.0
    return float(scipy.optimize.brentq(lambda x: float(amplification(x * ray)) ** 2 - 1.0, max(low, r[0] / 2), r[k],
                                       xtol=1e-15, rtol=4 * np.finfo(float).eps))


def stable_step(values) -> tuple[float, complex | None]:
    """The largest RK4 step ``h`` (s) that keeps ``hλ`` in the stability region for every eigenvalue
    ``λ`` (1/s) of ``values`` with ``Re λ ≤ 0``, and the ``λ`` that sets it; ``(inf, None)`` when none
    bounds it. Eigenvalues with a positive real part (a motion that grows whatever the step, such as a
    pendulum above its pivot) and zero ones are left out."""
    values = np.asarray(values, dtype=complex).ravel()
    scale = float(np.max(np.abs(values), initial=0.0))
    best, which = math.inf, None
    for value in values:
        modulus = abs(value)
        if modulus <= NEGLIGIBLE * scale or value.real > NEGLIGIBLE * modulus:
            continue
        theta = max(abs(math.atan2(value.imag, value.real)), math.pi / 2)
        h = boundary_radius(theta) / modulus
        if h < best:
            best, which = h, complex(value)
    return best, which


__all__ = ["amplification", "boundary_radius", "stable_step"]
