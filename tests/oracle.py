"""Independent brute-force reference ("oracle") for the dynamics of serial chains and trees.

Written straight from the formulas of ``shared/reference-model.md`` with plain NumPy; it shares
no code with ``gpmegen`` on purpose, so that agreement between the two means something.

Chain format
------------
A chain is a list of steps, applied left to right from the inertial frame {0}:

* ``Fixed(T)``                      a constant 4x4 homogeneous transform;
* ``Joint(kind, axis, index, c, d)`` an elementary transform ``Rx/Ry/Rz(q[index])`` (``kind``
  ``"revolute"``; about a unit vector ``axis``: Rodrigues' rotation) or ``Tr`` along ``axis`` by
  ``q[index]`` (``"prismatic"``), with an optional
  linear spring ``c`` and damper ``d`` acting on that coordinate (generalized force
  ``-c q - d qd``);
* ``Body(name, H)``                 a body with the numeric 4x4 pseudo-inertia ``H`` attached to
  the current frame;
* ``Point(name, xyz)``              a point fixed in the current frame;
* ``Branch(point)``                 the steps after it start again from the frame of the named
  point (the current frame where the point was defined, translated to it), or from {0} for
  ``None``: a tree, listed one branch after the other.

For a body ``b`` the transform ``T_b(q)`` is the ordered product of the elementary matrices on
its path from {0} (in a serial chain: all those met before it), so a joint off that path does
not move it. ``T_i = dT_b/dq_i`` and ``T_mn = d2T_b/dq_m dq_n`` are computed exactly by the product
rule: the joint's elementary matrix is replaced by its analytic first or second derivative (no
twists, no recursion, no composite bodies). Then (Lagrange's equations, corrected velocity term):

    M_ij = sum_b tr(T_i H T_j^T)
    h_i  = -sum_b sum_m sum_n tr(T_i H T_mn^T) qd_m qd_n
    g_i  = dE_p/dq_i,   E_p = sum_b m_b g y_C,b      (y up, gravity along -y)
    f    = Q(t) + h - g - C q - D qd

This is slow (O(n_dof^2) matrix products per body) and meant only as a test reference.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from functools import reduce

import numpy as np

# --------------------------------------------------------------------------------------------
# Reference parameters (SI units), same names as ``model.params`` of the package.
# --------------------------------------------------------------------------------------------

REFERENCE_PARAMS: dict[str, float] = {
    "g": 9.81,
    "m1": 10.0,
    "h1": 0.6,
    "R1": 0.05,
    "L2": 1.0,
    "b2": 0.04,
    "t2": 0.01,
    "rho2": 2700.0,
    "E2": 7.0e10,
    "G2": 2.6e10,
    "J2": 1.124e-8,
    "m3": 2.0,
    "L3": 0.5,
    "R3": 0.02,
    "tdr0": 1.0,
    "t0": 5.0,
}

# Optional: damping of each sde rotation (the reference case has none).
OPTIONAL_PARAMS: dict[str, float] = {"d2": 0.0}


# --------------------------------------------------------------------------------------------
# Elementary matrices and their analytic derivatives
# --------------------------------------------------------------------------------------------

_AXES = {"x": 0, "y": 1, "z": 2}
# Plane of rotation (i, j) for a right-handed rotation about each axis: R[i,i]=c, R[i,j]=-s,
# R[j,i]=s, R[j,j]=c.  x: (y, z); y: (z, x); z: (x, y).
_ROT_PLANE = {"x": (1, 2), "y": (2, 0), "z": (0, 1)}


def translation(x: float, y: float, z: float) -> np.ndarray:
    """Tr(x, y, z) as a 4x4 homogeneous matrix."""
    T = np.eye(4)
    T[:3, 3] = (x, y, z)
    return T


def rotation(axis: str, angle: float) -> np.ndarray:
    """Right-handed elementary rotation Rx/Ry/Rz(angle) as a 4x4 homogeneous matrix."""
    return elementary("revolute", axis, angle, 0)


def elementary(kind: str, axis, value: float, order: int) -> np.ndarray:
    """The joint's elementary matrix (order 0) or its ``order``-th derivative w.r.t. ``value``;
    ``axis`` is "x", "y", "z" or a unit 3-vector."""
    if not isinstance(axis, str):
        return _about_vector(kind, np.asarray(axis, float), value, order)
    if kind == "revolute":
        c, s = np.cos(value), np.sin(value)
        # d/da (cos, sin) = (-sin, cos); d2/da2 (cos, sin) = (-cos, -sin)
        cc, ss = {0: (c, s), 1: (-s, c), 2: (-c, -s)}[order]
        ax = _AXES[axis]
        T = np.zeros((4, 4))
        if order == 0:
            T[ax, ax] = 1.0
            T[3, 3] = 1.0
        i, j = _ROT_PLANE[axis]
        T[i, i] = cc
        T[i, j] = -ss
        T[j, i] = ss
        T[j, j] = cc
        return T
    if kind == "prismatic":
        ax = _AXES[axis]
        if order == 0:
            T = np.eye(4)
            T[ax, 3] = value
            return T
        T = np.zeros((4, 4))
        if order == 1:
            T[ax, 3] = 1.0
        return T
    raise ValueError(f"unknown joint kind {kind!r}")


def _about_vector(kind: str, n: np.ndarray, value: float, order: int) -> np.ndarray:
    """Rotation about (Rodrigues: ``c·1 + s·[n]x + (1 - c)·n nᵀ``) or translation along the unit
    vector ``n``, or its ``order``-th derivative."""
    T = np.zeros((4, 4))
    if kind == "prismatic":
        T[:3, 3] = n * {0: value, 1: 1.0, 2: 0.0}[order]
        if order == 0:
            T[:3, :3] = np.eye(3)
            T[3, 3] = 1.0
        return T
    c, s = np.cos(value), np.sin(value)
    cc, ss = {0: (c, s), 1: (-s, c), 2: (-c, -s)}[order]
    cross = np.array([[0, -n[2], n[1]], [n[2], 0, -n[0]], [-n[1], n[0], 0]])
    T[:3, :3] = cc * np.eye(3) + ss * cross + ((order == 0) - cc) * np.outer(n, n)
    T[3, 3] = float(order == 0)
    return T


# --------------------------------------------------------------------------------------------
# Chain description
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Fixed:
    T: np.ndarray


@dataclass(frozen=True)
class Joint:
    kind: str  # "revolute" | "prismatic"
    axis: object  # "x" | "y" | "z" | a unit 3-vector
    index: int  # coordinate index in q
    c: float = 0.0  # linear spring constant
    d: float = 0.0  # linear damper constant


@dataclass(frozen=True)
class Body:
    name: str
    H: np.ndarray  # 4x4 pseudo-inertia in the body frame


@dataclass(frozen=True)
class Point:
    name: str
    xyz: tuple


@dataclass(frozen=True)
class Branch:
    point: str | None  # None: {0}


def _const_drive(n: int) -> Callable[[float], np.ndarray]:
    return lambda t: np.zeros(n)


@dataclass
class Chain:
    """A serial chain of steps with ``n_dof`` coordinates, gravity ``g`` along -y0 and a drive
    ``Q(t)`` (generalized forces, shape (n_dof,))."""

    steps: Sequence
    n_dof: int
    g: float = 9.81
    drive: Callable[[float], np.ndarray] | None = None
    coordinates: tuple = field(default_factory=tuple)

    # ---- kinematics -------------------------------------------------------------------------

    def _factors(self, q):
        """Yield (step, factors) for every Body/Point step, where factors is the list of
        (kind, payload) entries preceding it: ("fixed", T) or ("joint", Joint)."""
        factors = []
        frames = {}   # point name -> the factors of a frame at the point
        for step in self.steps:
            if isinstance(step, np.ndarray):
                step = Fixed(step)
            if isinstance(step, Fixed):
                factors.append(("fixed", np.asarray(step.T, dtype=float)))
            elif isinstance(step, Joint):
                factors.append(("joint", step))
            elif isinstance(step, Branch):
                factors = [] if step.point is None else list(frames[step.point])
            elif isinstance(step, (Body, Point)):
                if isinstance(step, Point):
                    frames[step.name] = factors + [("fixed", translation(*step.xyz))]
                yield step, list(factors)
            else:
                raise TypeError(f"unknown chain step {step!r}")

    @staticmethod
    def _product(factors, q, orders):
        """Product of the factors, the k-th joint factor differentiated orders[k] times."""
        mats = []
        for k, (kind, payload) in enumerate(factors):
            if kind == "fixed":
                mats.append(payload)
            else:
                mats.append(elementary(payload.kind, payload.axis, q[payload.index], orders.get(k, 0)))
        return reduce(np.matmul, mats, np.eye(4))

    def _body_derivatives(self, factors, q):
        """T, T_i (n,4,4), T_mn (n,n,4,4) of one body by the product rule."""
        n = self.n_dof
        T = self._product(factors, q, {})
        Ti = np.zeros((n, 4, 4))
        Tmn = np.zeros((n, n, 4, 4))
        joints = [(k, p.index) for k, (kind, p) in enumerate(factors) if kind == "joint"]
        for k, i in joints:
            Ti[i] += self._product(factors, q, {k: 1})
        for k, m in joints:
            for k2, nn in joints:
                if k == k2:
                    Tmn[m, nn] += self._product(factors, q, {k: 2})
                else:
                    Tmn[m, nn] += self._product(factors, q, {k: 1, k2: 1})
        return T, Ti, Tmn

    def bodies(self, q):
        """List of (name, H, T, T_i, T_mn) for every body at configuration q."""
        q = np.asarray(q, dtype=float)
        out = []
        for step, factors in self._factors(q):
            if isinstance(step, Body):
                T, Ti, Tmn = self._body_derivatives(factors, q)
                out.append((step.name, np.asarray(step.H, dtype=float), T, Ti, Tmn))
        return out

    def body_transform(self, name, q):
        q = np.asarray(q, dtype=float)
        for step, factors in self._factors(q):
            if isinstance(step, Body) and step.name == name:
                return self._product(factors, q, {})
        raise KeyError(name)

    def point(self, name, q):
        """Position (3,) of a named point in {0}."""
        q = np.asarray(q, dtype=float)
        for step, factors in self._factors(q):
            if isinstance(step, Point) and step.name == name:
                T = self._product(factors, q, {})
                return (T @ np.append(np.asarray(step.xyz, dtype=float), 1.0))[:3]
        raise KeyError(name)

    def joints(self):
        return [s for s in self.steps if isinstance(s, Joint)]

    # ---- dynamics ---------------------------------------------------------------------------

    def stiffness(self):
        C = np.zeros((self.n_dof, self.n_dof))
        for j in self.joints():
            C[j.index, j.index] += j.c
        return C

    def damping(self):
        D = np.zeros((self.n_dof, self.n_dof))
        for j in self.joints():
            D[j.index, j.index] += j.d
        return D

    def Q(self, t):
        if self.drive is None:
            return np.zeros(self.n_dof)
        return np.asarray(self.drive(t), dtype=float)

    def mass_matrix(self, q):
        """M_ij = sum_b tr(T_i H T_j^T)."""
        M = np.zeros((self.n_dof, self.n_dof))
        for _, H, _, Ti, _ in self.bodies(q):
            for i in range(self.n_dof):
                for j in range(self.n_dof):
                    M[i, j] += np.trace(Ti[i] @ H @ Ti[j].T)
        return M

    def velocity_term(self, q, qd):
        """h_i = -sum_b sum_m sum_n tr(T_i H T_mn^T) qd_m qd_n."""
        qd = np.asarray(qd, dtype=float)
        n = self.n_dof
        h = np.zeros(n)
        for _, H, _, Ti, Tmn in self.bodies(q):
            # tr(A B^T) = sum of the elementwise product of A and B
            W = np.einsum("iab,mnab->imn", Ti @ H, Tmn)
            h -= np.einsum("imn,m,n->i", W, qd, qd)
        return h

    def gravity(self, q):
        """g_i = dE_p/dq_i with E_p = sum_b g * (T_b H e4)_y = sum_b m_b g y_C,b."""
        gv = np.zeros(self.n_dof)
        for _, H, _, Ti, _ in self.bodies(q):
            gv += self.g * (Ti @ H)[:, 1, 3]
        return gv

    def forces(self, t, q, qd):
        """f = Q(t) + h - g - C q - D qd."""
        q = np.asarray(q, dtype=float)
        qd = np.asarray(qd, dtype=float)
        return (
            self.Q(t)
            + self.velocity_term(q, qd)
            - self.gravity(q)
            - self.stiffness() @ q
            - self.damping() @ qd
        )

    def dynamics(self, q, qd, t=0.0):
        """(M, f) in one pass over the bodies (for integration)."""
        q = np.asarray(q, dtype=float)
        qd = np.asarray(qd, dtype=float)
        n = self.n_dof
        M = np.zeros((n, n))
        h = np.zeros(n)
        gv = np.zeros(n)
        for _, H, _, Ti, Tmn in self.bodies(q):
            TiH = Ti @ H
            M += np.einsum("iab,jab->ij", TiH, Ti)
            h -= np.einsum("iab,mnab,m,n->i", TiH, Tmn, qd, qd)
            gv += self.g * TiH[:, 1, 3]
        f = self.Q(t) + h - gv - self.stiffness() @ q - self.damping() @ qd
        return M, f

    def accelerations(self, t, q, qd):
        M, f = self.dynamics(q, qd, t)
        return np.linalg.solve(M, f)

    # ---- energies ---------------------------------------------------------------------------

    def kinetic_energy(self, q, qd):
        """1/2 sum_b tr(Tdot H Tdot^T), Tdot = sum_i T_i qd_i."""
        qd = np.asarray(qd, dtype=float)
        E = 0.0
        for _, H, _, Ti, _ in self.bodies(q):
            Td = np.einsum("iab,i->ab", Ti, qd)
            E += 0.5 * np.trace(Td @ H @ Td.T)
        return E

    def gravity_energy(self, q):
        """sum_b m_b g y_C,b = sum_b g (T H)[1, 3]."""
        return sum(self.g * (T @ H)[1, 3] for _, H, T, _, _ in self.bodies(q))

    def spring_energy(self, q):
        q = np.asarray(q, dtype=float)
        return 0.5 * sum(j.c * q[j.index] ** 2 for j in self.joints())

    def potential_energy(self, q):
        """Gravity plus springs: sum_b m_b g y_C,b + 1/2 sum c q^2."""
        return self.gravity_energy(q) + self.spring_energy(q)

    def total_energy(self, q, qd):
        return self.kinetic_energy(q, qd) + self.potential_energy(q)


# --------------------------------------------------------------------------------------------
# Pseudo-inertias
# --------------------------------------------------------------------------------------------


def pseudo_inertia(m, second_moments, centre) -> np.ndarray:
    """H = int [x y z 1]^T [x y z 1] dm with zero products of inertia.

    second_moments = (int x^2 dm, int y^2 dm, int z^2 dm), centre = (x_C, y_C, z_C)."""
    H = np.zeros((4, 4))
    H[0, 0], H[1, 1], H[2, 2] = second_moments
    H[:3, 3] = m * np.asarray(centre, dtype=float)
    H[3, :3] = H[:3, 3]
    H[3, 3] = m
    return H


def column_pseudo_inertia(m1, R1, h1):
    """Solid cylinder, radius R1, axis y from y=0 to h1."""
    return pseudo_inertia(m1, (m1 * R1**2 / 4, m1 * h1**2 / 3, m1 * R1**2 / 4), (0, h1 / 2, 0))


def bar_pseudo_inertia(rho, b, t, length):
    """Bar x in [0, length], section b (along z) x t (along y)."""
    m = rho * b * t * length
    return pseudo_inertia(m, (m * length**2 / 3, m * t**2 / 12, m * b**2 / 12), (length / 2, 0, 0))


def slider_pseudo_inertia(m3, R3, L3):
    """Solid cylinder, radius R3, axis x from x=0 to L3."""
    return pseudo_inertia(m3, (m3 * L3**2 / 3, m3 * R3**2 / 4, m3 * R3**2 / 4), (L3 / 2, 0, 0))


# --------------------------------------------------------------------------------------------
# The reference manipulator
# --------------------------------------------------------------------------------------------


def drive_torque(t, tdr0, t0):
    """Eq. 17: quintic ramp tdr0 * s^3 (10 - 15 s + 6 s^2), s = min(t/t0, 1) (and >= 0)."""
    s = min(max(t / t0, 0.0), 1.0)
    return tdr0 * s**3 * (10.0 - 15.0 * s + 6.0 * s**2)


def coordinate_names(nrfe: int) -> tuple:
    names = ["theta1", "psi2"]
    for r in range(1, nrfe):
        names += [f"psi2_{r}", f"theta2_{r}", f"phi2_{r}"]
    names.append("x3")
    return tuple(names)


def rfe_lengths(nrfe: int, L2: float) -> list:
    """Lengths of the rfes: [L2] for the rigid arm, else [Δ/2, Δ, ..., Δ, Δ/2]."""
    if nrfe == 1:
        return [L2]
    n_sde = nrfe - 1
    delta = L2 / n_sde
    return [delta / 2] + [delta] * (n_sde - 1) + [delta / 2]


def build_reference_chain(nrfe: int, params: dict | None = None) -> Chain:
    """The reference three-link manipulator with the arm cut into ``nrfe`` rfes.

    ``params`` may hold any subset of REFERENCE_PARAMS (and optionally ``d2``, the damping of
    every sde rotation); unknown keys (e.g. constraint constants) are ignored."""
    if nrfe < 1:
        raise ValueError("nrfe must be >= 1")
    P = dict(REFERENCE_PARAMS)
    P.update(OPTIONAL_PARAMS)
    if params:
        P.update({k: float(v) for k, v in params.items() if k in P})
    n_sde = nrfe - 1
    n = 3 + 3 * n_sde
    lengths = rfe_lengths(nrfe, P["L2"])

    steps: list = [
        Joint("revolute", "y", 0),  # T1 = Ry(θ1)
        Body("column", column_pseudo_inertia(P["m1"], P["R1"], P["h1"])),
        Fixed(translation(0.0, P["h1"], 0.0)),
        Joint("revolute", "z", 1),  # Rz(ψ2)
        Body("rfe0", bar_pseudo_inertia(P["rho2"], P["b2"], P["t2"], lengths[0])),
    ]
    if n_sde:
        delta = P["L2"] / n_sde
        b, t = P["b2"], P["t2"]
        Iz = b * t**3 / 12
        Iy = t * b**3 / 12
        c_psi = P["E2"] * Iz / delta
        c_theta = P["E2"] * Iy / delta
        c_phi = P["G2"] * P["J2"] / delta
        d = P["d2"]
        for r in range(1, n_sde + 1):
            k = 2 + 3 * (r - 1)
            steps += [
                Fixed(translation(lengths[r - 1], 0.0, 0.0)),
                Joint("revolute", "z", k, c_psi, d),  # ψ(2,r)
                Joint("revolute", "y", k + 1, c_theta, d),  # θ(2,r)
                Joint("revolute", "x", k + 2, c_phi, d),  # φ(2,r)
                Body(f"rfe{r}", bar_pseudo_inertia(P["rho2"], b, t, lengths[r])),
            ]
    steps += [
        Fixed(translation(lengths[-1], 0.0, 0.0)),  # Tr(ℓ_last + x3) = Tr(ℓ_last) Tr(x3)
        Joint("prismatic", "x", n - 1),
        Body("slider", slider_pseudo_inertia(P["m3"], P["R3"], P["L3"])),
        Point("E", (P["L3"], 0.0, 0.0)),
    ]

    tdr0, t0 = P["tdr0"], P["t0"]

    def drive(time):
        Q = np.zeros(n)
        Q[0] = drive_torque(time, tdr0, t0)
        return Q

    return Chain(steps=steps, n_dof=n, g=P["g"], drive=drive, coordinates=coordinate_names(nrfe))


class ReferenceOracle:
    """Convenience wrapper: the reference manipulator as an oracle with the package's method
    names (``mass_matrix``, ``forces``, ``end_effector``) plus energies."""

    def __init__(self, nrfe: int, params: dict | None = None):
        self.nrfe = nrfe
        self.chain = build_reference_chain(nrfe, params)
        self.n_dof = self.chain.n_dof
        self.coordinates = self.chain.coordinates

    def mass_matrix(self, q):
        return self.chain.mass_matrix(q)

    def forces(self, t, q, qd):
        return self.chain.forces(t, q, qd)

    def dynamics(self, t, q, qd):
        return self.chain.dynamics(q, qd, t)

    def accelerations(self, t, q, qd):
        return self.chain.accelerations(t, q, qd)

    def end_effector(self, q):
        return self.chain.point("E", q)

    def kinetic_energy(self, q, qd):
        return self.chain.kinetic_energy(q, qd)

    def potential_energy(self, q):
        return self.chain.potential_energy(q)

    def total_energy(self, q, qd):
        return self.chain.total_energy(q, qd)


def oracle(nrfe: int, params: dict | None = None) -> ReferenceOracle:
    return ReferenceOracle(nrfe, params)
