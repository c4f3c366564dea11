"""Physics tests of the reference manipulator against an independent brute-force oracle.

``tests/oracle.py`` derives M, h, g, C and the drive straight from the formulas of
``shared/reference-model.md`` (product-rule derivatives of 4x4 transforms, traces with the
pseudo-inertias), sharing no code with ``gpmegen``.

* ``test_oracle_*``: checks of the oracle on its own (closed forms, finite differences, limiting
  cases, energy conservation of its own dynamics and failure of the paper's misprinted velocity
  term). They run without the package: ``python -m pytest tests/test_oracle_agreement.py -k
  "not package"``.
* ``test_package_*``: the package's public contract (``gpmegen.load``) against the oracle. They
  are skipped while ``gpmegen`` cannot be imported.
"""

from __future__ import annotations

import math
import sys
from pathlib import Path

import numpy as np
import pytest
from scipy.integrate import solve_ivp

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)

import oracle as ref  # noqa: E402  (tests/oracle.py, found through the line above)

try:
    import gpmegen
except ModuleNotFoundError as exc:  # only "the package is not there", not errors inside it
    if exc.name != "gpmegen":
        raise
    gpmegen = None

needs_package = pytest.mark.skipif(gpmegen is None, reason="gpmegen is not importable yet")

NRFES = (1, 2, 5)
N_STATES = 4
REL_TOL = 1e-10

# --------------------------------------------------------------------------------------------
# helpers
# --------------------------------------------------------------------------------------------


def random_state(nrfe: int, rng: np.random.Generator):
    """Angles within ±1 rad, flexible angles ±0.2 rad, x3 ±0.3 m, velocities ±2."""
    n = 3 + 3 * (nrfe - 1)
    q = np.empty(n)
    q[0:2] = rng.uniform(-1.0, 1.0, 2)
    q[2:-1] = rng.uniform(-0.2, 0.2, n - 3)
    q[-1] = rng.uniform(-0.3, 0.3)
    qd = rng.uniform(-2.0, 2.0, n)
    return q, qd


def states(nrfe: int, seed: int = 12345):
    """N_STATES random (t, q, qd); the times cover the ramp (t < t0 = 5 s) and the plateau."""
    rng = np.random.default_rng(seed + nrfe)
    times = [0.7, 2.9, 5.6, 8.0] + list(rng.uniform(0.0, 8.0, max(0, N_STATES - 4)))
    out = []
    for t in times[:N_STATES]:
        q, qd = random_state(nrfe, rng)
        out.append((float(t), q, qd))
    assert any(t < 5.0 for t, _, _ in out) and any(t > 5.0 for t, _, _ in out)
    return out


def rel_err(a, b):
    """||a - b|| / ||b||."""
    a = np.asarray(a, dtype=float)
    b = np.asarray(b, dtype=float)
    return np.linalg.norm(a - b) / np.linalg.norm(b)


def integrate(accel, n, q0, qd0, span, n_samples=41):
    """Integrate q'' = accel(t, q, qd) with DOP853 (rtol = atol = 1e-12); return (ts, Q, QD)."""

    def rhs(t, y):
        return np.concatenate([y[n:], accel(t, y[:n], y[n:])])

    sol = solve_ivp(
        rhs, (0.0, span), np.concatenate([q0, qd0]), method="DOP853",
        rtol=1e-12, atol=1e-12, dense_output=True,
    )
    assert sol.status == 0, sol.message
    ts = np.linspace(0.0, span, n_samples)
    Y = sol.sol(ts)
    return ts, Y[:n].T, Y[n:].T


def energy_history(orc, Q, QD):
    E = np.array([orc.total_energy(q, qd) for q, qd in zip(Q, QD)])
    K = np.array([orc.kinetic_energy(q, qd) for q, qd in zip(Q, QD)])
    return E, K


def finite_difference(fun, x, eps):
    """Central differences of fun (array-valued) w.r.t. each component of x; shape (n, *out)."""
    x = np.asarray(x, dtype=float)
    cols = []
    for k in range(x.size):
        e = np.zeros_like(x)
        e[k] = eps
        cols.append((np.asarray(fun(x + e)) - np.asarray(fun(x - e))) / (2 * eps))
    return np.array(cols)


# Initial states for the energy tests (drive off, no damping, no constraints).
def energy_initial_state(nrfe):
    n = 3 + 3 * (nrfe - 1)
    q0 = np.zeros(n)
    qd0 = np.zeros(n)
    q0[0], q0[1], q0[-1] = 0.3, 0.5, 0.1
    qd0[0], qd0[1], qd0[-1] = 1.5, -1.0, 0.5
    if nrfe > 1:
        k = np.arange(n - 3)
        q0[2:-1] = 0.01 * np.sin(k + 1.0)
        qd0[2:-1] = 0.2 * np.cos(k + 1.0)
    return q0, qd0


# ============================================================================================
# The oracle on its own
# ============================================================================================

P = ref.REFERENCE_PARAMS


def rigid_end_effector(q, p=P):
    """E for the rigid arm, by hand: Ry(θ1) [(0, h1, 0) + Rz(ψ2) (L2 + x3 + L3, 0, 0)]."""
    th, psi, x3 = q
    L = p["L2"] + x3 + p["L3"]
    return np.array([
        math.cos(th) * math.cos(psi) * L,
        p["h1"] + math.sin(psi) * L,
        -math.sin(th) * math.cos(psi) * L,
    ])


def test_oracle_generic_chain_polar_point_mass():
    """The generic chain format on a textbook case: a point mass m on a rotating (about z) and
    extending (along x) arm, offset by a raw 4x4 array, with a spring and a damper on the angle.
    Lagrange by hand: M = diag(m r², m), h = (-2 m r ṙ θ̇, m r θ̇²), g = (m g r cos θ, m g sin θ)."""
    m, grav, c, d = 1.7, 9.81, 3.0, 0.4
    chain = ref.Chain(
        steps=[
            ref.translation(0.0, 0.5, 0.0),  # a constant transform given as a bare array
            ref.Joint("revolute", "z", 0, c, d),
            ref.Joint("prismatic", "x", 1),
            ref.Body("bob", ref.pseudo_inertia(m, (0.0, 0.0, 0.0), (0.0, 0.0, 0.0))),
            ref.Point("bob", (0.0, 0.0, 0.0)),
        ],
        n_dof=2, g=grav, drive=lambda t: np.array([t, 0.0]),
    )
    th, r, thd, rd, t = 0.6, 1.3, -0.8, 0.5, 0.25
    q, qd = np.array([th, r]), np.array([thd, rd])
    np.testing.assert_allclose(chain.mass_matrix(q), np.diag([m * r**2, m]), atol=1e-15)
    expected = np.array([
        t - 2 * m * r * rd * thd - m * grav * r * math.cos(th) - c * th - d * thd,
        m * r * thd**2 - m * grav * math.sin(th),
    ])
    np.testing.assert_allclose(chain.forces(t, q, qd), expected, rtol=1e-14, atol=1e-14)
    np.testing.assert_allclose(
        chain.point("bob", q), [r * math.cos(th), 0.5 + r * math.sin(th), 0.0], atol=1e-15
    )
    assert chain.kinetic_energy(q, qd) == pytest.approx(0.5 * m * (rd**2 + r**2 * thd**2), rel=1e-14)
    assert chain.potential_energy(q) == pytest.approx(m * grav * (0.5 + r * math.sin(th)) + 0.5 * c * th**2, rel=1e-14)


@pytest.mark.parametrize("nrfe", NRFES)
def test_oracle_end_effector_reference_point(nrfe):
    orc = ref.oracle(nrfe)
    q = np.zeros(orc.n_dof)
    q[1] = math.radians(45.0)
    np.testing.assert_allclose(orc.end_effector(q), [1.06066, 1.66066, 0.0], atol=1e-5)


def test_oracle_end_effector_closed_form():
    orc = ref.oracle(1)
    rng = np.random.default_rng(1)
    for _ in range(5):
        q, _ = random_state(1, rng)
        np.testing.assert_allclose(orc.end_effector(q), rigid_end_effector(q), atol=1e-13)


def test_oracle_coordinates_and_sizes():
    assert ref.oracle(1).coordinates == ("theta1", "psi2", "x3")
    orc = ref.oracle(3)
    assert orc.n_dof == 9
    assert orc.coordinates == (
        "theta1", "psi2", "psi2_1", "theta2_1", "phi2_1", "psi2_2", "theta2_2", "phi2_2", "x3",
    )
    assert ref.rfe_lengths(5, 1.0) == [0.125, 0.25, 0.25, 0.25, 0.125]
    assert ref.rfe_lengths(1, 1.0) == [1.0]


def test_oracle_elementary_derivatives():
    for kind in ("revolute", "prismatic"):
        for axis in "xyz":
            a = 0.37
            for order in (1, 2):
                fd = finite_difference(
                    lambda x: ref.elementary(kind, axis, x[0], order - 1), [a], 1e-6
                )[0]
                np.testing.assert_allclose(ref.elementary(kind, axis, a, order), fd, atol=1e-9)
    # right-handedness: Rz(90°) maps x to y, Rx(90°) maps y to z, Ry(90°) maps z to x
    ex, ey, ez = np.eye(4)[:, 0], np.eye(4)[:, 1], np.eye(4)[:, 2]
    np.testing.assert_allclose(ref.rotation("z", math.pi / 2) @ ex, ey, atol=1e-15)
    np.testing.assert_allclose(ref.rotation("x", math.pi / 2) @ ey, ez, atol=1e-15)
    np.testing.assert_allclose(ref.rotation("y", math.pi / 2) @ ez, ex, atol=1e-15)


def test_oracle_transform_derivatives_finite_differences():
    orc = ref.oracle(3)
    chain = orc.chain
    q, _ = random_state(3, np.random.default_rng(2))
    for name, _, _, Ti, Tmn in chain.bodies(q):
        fd_T = finite_difference(lambda x: chain.body_transform(name, x), q, 1e-6)
        np.testing.assert_allclose(Ti, fd_T, atol=1e-8)
        fd_Ti = finite_difference(
            lambda x: [b[3] for b in chain.bodies(x) if b[0] == name][0], q, 1e-6
        )
        np.testing.assert_allclose(Tmn, fd_Ti, atol=1e-8)


def test_oracle_pseudo_inertias_by_quadrature():
    """The closed forms of the table against a midpoint-rule integration of the solids."""
    k = 60
    u = (np.arange(k) + 0.5) / k

    def cylinder(m, R, length, axis):
        # polar coordinates in the section, `axis` along the cylinder
        r = R * np.sqrt(u)  # equal-area rings
        phi = 2 * np.pi * u
        s = length * u
        rr, pp, ss = np.meshgrid(r, phi, s, indexing="ij")
        a, b_ = rr * np.cos(pp), rr * np.sin(pp)
        xyz = {"y": (a, ss, b_), "x": (ss, a, b_)}[axis]
        pts = np.stack([*xyz, np.ones_like(ss)], -1).reshape(-1, 4)
        return m * pts.T @ pts / len(pts)

    np.testing.assert_allclose(
        ref.column_pseudo_inertia(P["m1"], P["R1"], P["h1"]),
        cylinder(P["m1"], P["R1"], P["h1"], "y"), rtol=2e-3, atol=1e-6,
    )
    np.testing.assert_allclose(
        ref.slider_pseudo_inertia(P["m3"], P["R3"], P["L3"]),
        cylinder(P["m3"], P["R3"], P["L3"], "x"), rtol=2e-3, atol=1e-6,
    )
    ell = 0.25
    xx, yy, zz = np.meshgrid(ell * u, P["t2"] * (u - 0.5), P["b2"] * (u - 0.5), indexing="ij")
    pts = np.stack([xx, yy, zz, np.ones_like(xx)], -1).reshape(-1, 4)
    m = P["rho2"] * P["b2"] * P["t2"] * ell
    np.testing.assert_allclose(
        ref.bar_pseudo_inertia(P["rho2"], P["b2"], P["t2"], ell), m * pts.T @ pts / len(pts),
        rtol=1e-3, atol=1e-12,
    )


def test_oracle_spring_constants():
    """c_ψ = E b t³/(12Δ), c_θ = E t b³/(12Δ), c_φ = G J/Δ, by hand for Δ = 0.5 m."""
    C = ref.oracle(3).chain.stiffness()
    c_psi = 7.0e10 * 0.04 * 0.01**3 / 12 / 0.5
    c_theta = 7.0e10 * 0.01 * 0.04**3 / 12 / 0.5
    c_phi = 2.6e10 * 1.124e-8 / 0.5
    assert c_psi == pytest.approx(466.6666666666667)
    assert c_theta == pytest.approx(7466.666666666667)
    assert c_phi == pytest.approx(584.48)
    np.testing.assert_allclose(
        np.diag(C), [0, 0, c_psi, c_theta, c_phi, c_psi, c_theta, c_phi, 0], rtol=1e-14
    )
    assert np.count_nonzero(C - np.diag(np.diag(C))) == 0


def test_oracle_drive_ramp():
    orc = ref.oracle(2)
    q, qd = np.zeros(orc.n_dof), np.zeros(orc.n_dof)
    # with q = qd = 0 the arm is horizontal: gravity acts on psi2 (and the sdes), never on theta1
    Q = lambda t: orc.forces(t, q, qd) - orc.forces(0.0, q, qd)  # noqa: E731
    assert Q(2.5)[0] == pytest.approx(0.5, abs=1e-15)  # s = 1/2: 1/8 (10 - 7.5 + 1.5) = 1/2
    assert Q(1.0)[0] == pytest.approx(0.2**3 * (10 - 3 + 0.24), abs=1e-15)
    for t in (5.0, 6.0, 10.0):
        assert Q(t)[0] == pytest.approx(1.0, abs=1e-15)
    assert np.all(Q(3.0)[1:] == 0.0)
    # zero slope at both ends of the ramp
    eps = 1e-6
    assert abs(ref.drive_torque(eps, 1.0, 5.0)) < 1e-15
    assert abs(ref.drive_torque(5.0 - eps, 1.0, 5.0) - 1.0) < 1e-15


def test_oracle_rigid_mass_matrix_and_gravity_closed_form():
    """Rigid arm (nrfe = 1) at ψ2 = 0, x3 = 0 by hand (inertias about the axes of the joints)."""
    orc = ref.oracle(1)
    m2 = P["rho2"] * P["b2"] * P["t2"] * P["L2"]
    m1, m3, L2, L3 = P["m1"], P["m3"], P["L2"], P["L3"]
    slider_x2 = L2**2 + L2 * L3 + L3**2 / 3  # ∫(L2 + x)² dm / m3, x in [0, L3]
    M = orc.mass_matrix([0.4, 0.0, 0.0])
    J_theta = m1 * P["R1"] ** 2 / 2 + m2 * (L2**2 / 3 + P["b2"] ** 2 / 12) + m3 * (slider_x2 + P["R3"] ** 2 / 4)
    J_psi = m2 * (L2**2 / 3 + P["t2"] ** 2 / 12) + m3 * (slider_x2 + P["R3"] ** 2 / 4)
    np.testing.assert_allclose(M, np.diag([J_theta, J_psi, m3]), rtol=1e-14, atol=1e-14)

    g = P["g"]
    for psi, x3 in ((0.0, 0.0), (0.7, 0.2), (-1.0, -0.3)):
        f = orc.forces(0.0, [0.3, psi, x3], [0.0, 0.0, 0.0])
        expected = -np.array([
            0.0,
            g * math.cos(psi) * (m2 * L2 / 2 + m3 * (L2 + x3 + L3 / 2)),
            g * math.sin(psi) * m3,
        ])
        np.testing.assert_allclose(f, expected, rtol=1e-13, atol=1e-13)


@pytest.mark.parametrize("nrfe", (1, 3))
def test_oracle_mass_matrix_is_kinetic_energy_hessian(nrfe):
    """½ qdᵀ M qd equals the kinetic energy summed from Ṫ = Σ T_i q̇_i; M is SPD."""
    orc = ref.oracle(nrfe)
    rng = np.random.default_rng(3)
    for _ in range(3):
        q, qd = random_state(nrfe, rng)
        M = orc.mass_matrix(q)
        assert 0.5 * qd @ M @ qd == pytest.approx(orc.kinetic_energy(q, qd), rel=1e-13)
        np.testing.assert_allclose(M, M.T, rtol=0, atol=1e-14 * np.abs(M).max())
        np.linalg.cholesky(M)


@pytest.mark.parametrize("nrfe", (1, 3))
def test_oracle_velocity_term_is_lagrange(nrfe):
    """h = -(dM/dt) q̇ + ∂/∂q (½ q̇ᵀ M q̇), with the derivatives of M by finite differences:
    an independent check of the corrected velocity term (and of its sign)."""
    orc = ref.oracle(nrfe)
    rng = np.random.default_rng(4)
    q, qd = random_state(nrfe, rng)
    dM = finite_difference(orc.mass_matrix, q, 1e-5)  # dM[k] = ∂M/∂q_k
    Mdot = np.einsum("kij,k->ij", dM, qd)
    h_lagrange = -Mdot @ qd + 0.5 * np.einsum("kij,i,j->k", dM, qd, qd)
    h = orc.forces(0.0, q, qd) - orc.forces(0.0, q, np.zeros_like(qd))
    assert rel_err(h, h_lagrange) < 1e-8


@pytest.mark.parametrize("nrfe", (1, 3))
def test_oracle_static_forces_are_potential_gradient(nrfe):
    """-(g + C q) = -∂E_p/∂q with E_p = Σ m g y_C + ½ Σ c q² (gravity along -y0)."""
    orc = ref.oracle(nrfe, {"tdr0": 0.0})
    q, _ = random_state(nrfe, np.random.default_rng(5))
    f_static = orc.forces(3.0, q, np.zeros_like(q))
    grad = finite_difference(lambda x: np.array(orc.potential_energy(x)), q, 1e-6)
    assert rel_err(f_static, -grad) < 1e-8
    # at q = 0 the column's centre is at h1/2, the horizontal arm's and the slider's at h1
    assert orc.potential_energy(np.zeros_like(q)) == pytest.approx(
        P["g"] * (P["m1"] * P["h1"] / 2 + (P["rho2"] * P["b2"] * P["t2"] * P["L2"] + P["m3"]) * P["h1"])
    )


def test_oracle_flexible_arm_at_rest_equals_rigid_arm():
    """nrfe = 5 with undeformed sdes (q_flex = q̇_flex = 0) equals the rigid arm on (θ1, ψ2, x3):
    the rfes' pseudo-inertias add up to the whole bar's."""
    rigid, flex = ref.oracle(1), ref.oracle(5)
    idx = [0, 1, flex.n_dof - 1]
    rng = np.random.default_rng(6)
    for t in (1.0, 6.0):
        qr, qdr = random_state(1, rng)
        q = np.zeros(flex.n_dof)
        qd = np.zeros(flex.n_dof)
        q[idx], qd[idx] = qr, qdr
        np.testing.assert_allclose(flex.end_effector(q), rigid.end_effector(qr), atol=1e-14)
        Mf = flex.mass_matrix(q)
        assert rel_err(Mf[np.ix_(idx, idx)], rigid.mass_matrix(qr)) < 1e-13
        assert rel_err(flex.forces(t, q, qd)[idx], rigid.forces(t, qr, qdr)) < 1e-13


def test_oracle_damping_is_linear_in_velocity():
    orc0, orc = ref.oracle(2), ref.oracle(2, {"d2": 0.3})
    q, qd = random_state(2, np.random.default_rng(7))
    diff = orc.forces(1.0, q, qd) - orc0.forces(1.0, q, qd)
    expected = np.zeros_like(qd)
    expected[2:5] = -0.3 * qd[2:5]
    np.testing.assert_allclose(diff, expected, atol=1e-12)


def test_oracle_energy_conserved_in_own_dynamics():
    """Drive off, no damping, no constraints: the oracle's own M and f conserve its total
    energy. This would catch the paper's misprinted velocity term (see the next test)."""
    orc = ref.oracle(1, {"tdr0": 0.0})
    q0, qd0 = energy_initial_state(1)
    ts, Q, QD = integrate(orc.accelerations, orc.n_dof, q0, qd0, 1.0)
    E, K = energy_history(orc, Q, QD)
    assert K.max() - K.min() > 0.1 * abs(E[0])  # energy really moves between kinds
    assert np.abs(E - E[0]).max() / abs(E[0]) < 1e-8


def _mutant_accelerations(orc, variant):
    """The oracle's dynamics with a wrong velocity term. The reference document says the paper
    flips the sign and keeps an extra 2ΣΣ tr{T_m H T_inᵀ} term; the exact printed form is not
    quoted, so each error is tried alone and both together ("paper")."""
    chain = orc.chain

    def accel(t, q, qd):
        n = chain.n_dof
        M = np.zeros((n, n))
        h = np.zeros(n)
        gv = np.zeros(n)
        for _, H, _, Ti, Tmn in chain.bodies(q):
            TiH = Ti @ H
            M += np.einsum("iab,jab->ij", TiH, Ti)
            correct = -np.einsum("iab,mnab,m,n->i", TiH, Tmn, qd, qd)
            extra = 2 * np.einsum("mab,inab,m,n->i", TiH, Tmn, qd, qd)  # 2 ΣΣ tr{T_m H T_inᵀ}
            h += {"flipped": -correct, "extra": correct - extra, "paper": -correct + extra}[variant]
            gv += chain.g * TiH[:, 1, 3]
        return np.linalg.solve(M, h - gv - chain.stiffness() @ q)

    return accel


@pytest.mark.parametrize("variant", ("flipped", "extra", "paper"))
def test_oracle_misprinted_velocity_term_breaks_energy(variant):
    """The energy test has teeth: with the sign flipped and/or the extra 2ΣΣ tr{T_m H T_inᵀ}
    term kept, the total energy drifts by far more than the tolerance."""
    orc = ref.oracle(1, {"tdr0": 0.0})
    q0, qd0 = energy_initial_state(1)
    try:
        ts, Q, QD = integrate(_mutant_accelerations(orc, variant), orc.n_dof, q0, qd0, 0.3)
    except AssertionError:
        return  # the wrong model did not even integrate: it fails too
    E, _ = energy_history(orc, Q, QD)
    assert np.abs(E - E[0]).max() / abs(E[0]) > 1e-4


# ============================================================================================
# The package against the oracle
# ============================================================================================

_MODELS: dict = {}


def load(nrfe, **overrides):
    """gpmegen.load with the numpy backend, cached per (nrfe, overrides)."""
    key = (nrfe, tuple(sorted(overrides.items())))
    if key not in _MODELS:
        kwargs = {"params": dict(overrides)} if overrides else {}
        _MODELS[key] = gpmegen.load("manipulator", nrfe=nrfe, backend="numpy", **kwargs)
    return _MODELS[key]


def oracle_for(model, nrfe):
    return ref.oracle(nrfe, dict(model.params))


@needs_package
@pytest.mark.parametrize("nrfe", NRFES)
def test_package_coordinates_and_params(nrfe):
    model = load(nrfe)
    assert model.n_dof == 3 + 3 * (nrfe - 1)
    assert tuple(str(c) for c in model.coordinates) == ref.coordinate_names(nrfe)
    for name, value in ref.REFERENCE_PARAMS.items():
        assert float(model.params[name]) == pytest.approx(value, rel=1e-15), name


@needs_package
@pytest.mark.parametrize("nrfe", NRFES)
def test_package_mass_matrix_agrees_with_oracle(nrfe):
    model = load(nrfe)
    orc = oracle_for(model, nrfe)
    for _, q, _ in states(nrfe):
        M = np.asarray(model.mass_matrix(q), dtype=float)
        assert M.shape == (model.n_dof, model.n_dof)
        assert rel_err(M, orc.mass_matrix(q)) < REL_TOL
        np.testing.assert_allclose(M, M.T, rtol=0, atol=1e-13 * np.abs(M).max())
        assert np.linalg.eigvalsh(0.5 * (M + M.T)).min() > 0.0


@needs_package
@pytest.mark.parametrize("nrfe", NRFES)
def test_package_forces_agree_with_oracle(nrfe):
    model = load(nrfe)
    orc = oracle_for(model, nrfe)
    for t, q, qd in states(nrfe):
        f = np.asarray(model.forces(t, q, qd), dtype=float)
        assert f.shape == (model.n_dof,)
        assert rel_err(f, orc.forces(t, q, qd)) < REL_TOL, (t, q, qd)


@needs_package
@pytest.mark.parametrize("nrfe", NRFES)
def test_package_force_parts_agree_with_oracle(nrfe):
    """Each part of f at its own scale (the stiff springs dominate ||f|| for nrfe > 1, so the
    total alone would hide small errors in the drive, gravity or velocity terms)."""
    model = load(nrfe)
    orc = oracle_for(model, nrfe)
    zero = np.zeros(model.n_dof)
    for t, q, qd in states(nrfe, seed=999):
        f = lambda t_, q_, qd_: np.asarray(model.forces(t_, q_, qd_), dtype=float)  # noqa: E731
        # velocity term h(q, qd)
        assert rel_err(f(t, q, qd) - f(t, q, zero), orc.forces(t, q, qd) - orc.forces(t, q, zero)) < 1e-9
        # drive Q(t) - Q(0)
        np.testing.assert_allclose(
            f(t, q, zero) - f(0.0, q, zero), orc.forces(t, q, zero) - orc.forces(0.0, q, zero),
            rtol=0, atol=1e-9 * (1.0 + np.abs(f(0.0, q, zero)).max()),
        )
        # gravity alone: undeformed arm, at rest, drive not yet on
        q0 = q.copy()
        q0[2:-1] = 0.0
        assert rel_err(f(0.0, q0, zero), orc.forces(0.0, q0, zero)) < REL_TOL


@needs_package
@pytest.mark.parametrize("nrfe", NRFES)
def test_package_end_effector_agrees_with_oracle(nrfe):
    model = load(nrfe)
    orc = oracle_for(model, nrfe)
    q = np.zeros(model.n_dof)
    q[1] = math.radians(45.0)
    E = np.asarray(model.end_effector(q), dtype=float)
    assert E.shape == (3,)
    np.testing.assert_allclose(E, [1.06066, 1.66066, 0.0], atol=1e-5)
    for _, q, _ in states(nrfe):
        np.testing.assert_allclose(model.end_effector(q), orc.end_effector(q), rtol=0, atol=1e-12)


@needs_package
def test_package_param_overrides_agree_with_oracle():
    """Overrides reach every term: the oracle is built from model.params of the overridden model."""
    overrides = {"tdr0": 0.0, "m3": 3.0, "L2": 1.2, "g": 0.0, "b2": 0.05}
    model = load(2, **overrides)
    for name, value in overrides.items():
        assert float(model.params[name]) == value
    orc = oracle_for(model, 2)
    for t, q, qd in states(2, seed=7):
        assert rel_err(model.mass_matrix(q), orc.mass_matrix(q)) < REL_TOL
        assert rel_err(model.forces(t, q, qd), orc.forces(t, q, qd)) < REL_TOL
        # no drive: f does not depend on t
        np.testing.assert_allclose(model.forces(t, q, qd), model.forces(0.0, q, qd), rtol=1e-14, atol=1e-12)


@needs_package
def test_package_damping_agrees_with_oracle():
    model0 = load(2)
    if "d2" not in model0.params:
        pytest.skip("the package has no sde damping parameter named d2")
    model = load(2, d2=0.3)
    orc = oracle_for(model, 2)
    for t, q, qd in states(2, seed=8):
        assert rel_err(model.forces(t, q, qd), orc.forces(t, q, qd)) < REL_TOL
        diff = np.asarray(model.forces(t, q, qd)) - np.asarray(model0.forces(t, q, qd))
        expected = np.zeros_like(qd)
        expected[2:5] = -0.3 * qd[2:5]
        np.testing.assert_allclose(diff, expected, rtol=0, atol=1e-9)


# Time spans of the package energy test. nrfe = 2 has sde modes up to ~125 Hz; at rtol = atol
# = 1e-12 DOP853 needs ~4,500 steps (~54,000 right-hand sides) per simulated second. With the
# generated NumPy module that is ~3 s for the full 1 s, so no shorter span is needed.
ENERGY_SPAN = {1: 1.0, 2: 1.0}


@needs_package
@pytest.mark.parametrize("nrfe", (1, pytest.param(2, marks=pytest.mark.long)))
def test_package_dynamics_conserve_oracle_energy(nrfe):
    """Drive off, no damping, no constraints: integrate q̈ = M⁻¹ f of the package and check that
    the oracle's kinetic + potential energy stays constant."""
    model = load(nrfe, tdr0=0.0)
    orc = oracle_for(model, nrfe)
    if "d2" in model.params:
        assert float(model.params["d2"]) == 0.0

    def accel(t, q, qd):
        return np.linalg.solve(model.mass_matrix(q), model.forces(t, q, qd))

    q0, qd0 = energy_initial_state(nrfe)
    ts, Q, QD = integrate(accel, model.n_dof, q0, qd0, ENERGY_SPAN[nrfe])
    E, K = energy_history(orc, Q, QD)
    assert K.max() - K.min() > 1e-3 * abs(E[0])  # a non-trivial motion
    assert np.abs(E - E[0]).max() / abs(E[0]) < 1e-8
