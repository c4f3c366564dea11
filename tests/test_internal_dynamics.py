"""Internal (zero) dynamics of the actuated realization: against the transmission zeros of the
linearized input-output system and, for one flexible link with its tip held, against the
continuum beam's non-minimum-phase zeros."""

from __future__ import annotations

import re
from pathlib import Path

import numpy as np
import pytest
import scipy.linalg
from scipy.optimize import brentq

import gpmegen
from gpmegen import cli
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.runtime import internal

LINK = Path(__file__).resolve().parent / "models" / "flexible_link.toml"


def link(nrfe):
    """The flexible link on its hub, straight (an equilibrium: no gravity, tip on the x0 axis),
    its hub actuated."""
    file = gpmegen.read_model_file(LINK, nrfe=nrfe)
    model = gpmegen.load(model=file.model, backend="numpy").with_actuators(file.actuators)
    return model, np.zeros(model.n_dof)


def transmission_zeros(M, K, D, actuators):
    """Finite zeros of ``M δq̈ + K δq = S u``, ``y = D δq``: the generalized eigenvalues of the
    Rosenbrock system matrix ``[[A, B], [C, 0]]`` against ``[[I, 0], [0, 0]]``."""
    n, m = M.shape[0], D.shape[0]
    S = np.zeros((n, m))
    S[actuators, np.arange(m)] = 1.0
    A = np.block([[np.zeros((n, n)), np.eye(n)], [-np.linalg.solve(M, K), np.zeros((n, n))]])
    B = np.vstack([np.zeros((n, m)), np.linalg.solve(M, S)])
    C = np.hstack([D, np.zeros((m, n))])
    system = np.block([[A, B], [C, np.zeros((m, m))]])
    E = scipy.linalg.block_diag(np.eye(2 * n), np.zeros((m, m)))
    values = scipy.linalg.eig(system, E, right=False)
    return values[np.isfinite(values)]


def continuum_zeros(EI, rho_a, length, count):
    """Zeros of a pinned-free Euler–Bernoulli beam, hub torque in, tip displacement out.

    Derived here: holding the tip's displacement u(L) = 0 by the hub torque leaves the beam
    u'''' = -(ρA/EI) s² u with u(0) = 0 (hub on its axis; its slope is free, the torque takes
    the moment) and a free tip, u''(L) = u'''(L) = 0, besides u(L) = 0. For real s, with
    s² = 4a⁴ EI/ρA, the solution meeting the three tip conditions is cosh(aξ) sin(aξ) +
    sinh(aξ) cos(aξ) (ξ from the tip), so u(0) = 0 gives tan(aL) = -tanh(aL) and the zeros
    s = ±2a²√(EI/ρA), aL = 2.3650, 5.4978, … (≈ (4k - 1)π/4). For imaginary s the condition
    becomes sinh(βL) + sin(βL) = 0, which has no positive root: the zeros are real pairs, the
    positive ones non-minimum phase (cf. the real zero pairs of the tip transfer function in
    Cannon & Schmitz, Int. J. Robotics Research 3(3), 1984)."""
    roots = [brentq(lambda x: np.tan(x) + np.tanh(x), (4 * k - 1) * np.pi / 4 - 0.3, (4 * k - 1) * np.pi / 4 + 0.3)
             for k in range(1, count + 1)]
    return np.array([2 * (r / length) ** 2 * np.sqrt(EI / rho_a) for r in roots])


def test_internal_dynamics_are_the_transmission_zeros(env):
    """The eigenvalues from the null space of D and the unactuated rows equal the Rosenbrock
    zeros built from the generated stiffness Jacobian (no differences) at the equilibrium."""
    model, q = link(3)
    values = internal.eigenvalues(model, 0.0, q, np.zeros(model.n_dof))
    D = model.constraint_terms(0.0, q, np.zeros(model.n_dof))[2]
    zeros = transmission_zeros(model.mass_matrix(q), model.stiffness_jacobian(q), D, model.actuators)
    assert len(values) == len(zeros) == 2 * (model.n_dof - 1)
    scale = np.max(np.abs(zeros))
    for z in zeros:
        assert np.min(np.abs(values - z)) < 1e-6 * scale
    growing = internal.unstable(values)
    assert len(growing) == 2 and np.all(np.abs(growing.imag) < 1e-6 * scale)  # real pairs: non-minimum phase
    assert np.allclose(np.sort(growing.real), np.sort(-np.sort(values.real)[:2]), rtol=1e-6)


def test_internal_dynamics_approach_the_beam_zeros(env):
    """The positive real zeros approach the continuum's as n_rfe grows, the error falling about
    as 1/n_sde² (the rfes carry rotary inertia: a Rayleigh beam, slightly below)."""
    p = gpmegen.read_model_file(LINK).model.parameters
    values = {q.name: float(q.default) for q in p}
    EI = values["E_al"] * values["b"] * values["h"] ** 3 / 12
    exact = continuum_zeros(EI, values["rho"] * values["b"] * values["h"], values["L"], 2)
    errors = []
    for nrfe in (3, 5, 8):
        model, q = link(nrfe)
        growing = np.sort(internal.unstable(internal.eigenvalues(model, 0.0, q, np.zeros(model.n_dof))).real)
        errors.append(abs(growing[0] / exact[0] - 1))
        assert growing[1] == pytest.approx(exact[1], rel=0.15)
    assert errors[0] > errors[1] > errors[2]
    assert errors[-1] < 0.01
    assert errors[0] / errors[2] > 0.6 * (7 / 2) ** 2


def test_a_run_diverging_by_its_internal_dynamics_says_so(tmp_path, capsys):
    """The flexible arm actuated on ψ2 and x3: the unstable eigenvalues are printed at the start,
    the run stops with its partial results and names the cause; the rigid arm is stable."""
    common = ["simulate", "--t-end", "0.2", "--dt", "1e-4", "--save-every", "10", "--backend", "numpy",
              "--actuated", "psi2", "x3"]
    out = tmp_path / "flexible.npz"
    assert cli.main(common + ["--nrfe", "3", "--out", str(out)]) == 1
    err = capsys.readouterr().err
    assert "internal dynamics of the inputs on psi2, x3 at the start: 2 unstable eigenvalue(s), fastest" in err
    assert "time constant" in err and "non-minimum phase" in err.splitlines()[-1]
    assert (tmp_path / "flexible.partial.npz").exists() and not out.exists()
    assert cli.main(common + ["--nrfe", "1", "--t-end", "0.02", "--out", str(tmp_path / "rigid.npz")]) == 0
    assert "at the start: stable" in capsys.readouterr().err


def test_model_file_actuators(env, tmp_path, capsys):
    """``actuators`` of a model file realize its constraints by default (``--actuated none``:
    ideally); a coordinate that is not one, or a count other than one per constraint, is
    refused with the file's line."""
    assert gpmegen.read_model_file(LINK).actuators == ("theta1",)
    common = ["simulate", str(LINK), "--nrfe", "2", "--t-end", "0.01", "--dt", "1e-4", "--backend", "numpy"]
    assert cli.main(common + ["--out", str(tmp_path / "a.npz")]) == 0
    assert "internal dynamics of the inputs on theta1 at the start" in capsys.readouterr().err
    assert list(np.load(tmp_path / "a.npz")["actuators"]) == ["theta1"]
    assert cli.main(common + ["--out", str(tmp_path / "b.npz"), "--actuated", "none"]) == 0
    assert "lambda" in np.load(tmp_path / "b.npz").files
    text = LINK.read_text(encoding="utf-8")
    for bad, message in (('["theta7"]', "'theta7' is not a coordinate; did you mean 'theta1'?"),
                         ('["theta1", "psi1_1"]', "one input per constraint, got 2")):
        path = tmp_path / "bad.toml"
        path.write_text(text.replace('actuators = ["theta1"]', f"actuators = {bad}"), encoding="utf-8")
        with pytest.raises(gpmegen.ModelError, match=r"bad.toml:\d+: actuators: .*" + re.escape(message)):
            gpmegen.read_model_file(path)


def test_internal_dynamics_along_a_run_of_the_rigid_arm():
    """On request the eigenvalues are saved at every sample. For the rigid arm actuated on ψ2 and
    x3 the internal dynamics are the column's: d(I θ̇1)/dt = τ_drive with I = M[θ1, θ1], whose
    linearization I δθ̈1 + İ δθ̇1 = 0 has the eigenvalues 0 and -İ/I (İ by differences of M
    along q̇); without actuators the request is refused."""
    from gpmegen.analysis.run import reference_case, study

    model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=1, backend="numpy"), "locked")
    actuated = model.with_actuators(["psi2", "x3"])
    res = study.simulate(actuated, q0, RunSpec(t_end=2.0, dt=1e-3, save_every=125, internal_dynamics=True))
    values = res["internal_eigenvalues"]
    assert values.shape == (len(res["t"]), 2)
    rates = []
    for k in range(len(res["t"])):
        q, qd, h = res["q"][k], res["qd"][k], 1e-6
        inertia = actuated.mass_matrix(q)[0, 0]
        rate = (actuated.mass_matrix(q + h * qd)[0, 0] - actuated.mass_matrix(q - h * qd)[0, 0]) / (2 * h) / inertia
        near = values[k][np.argsort(np.abs(values[k] + rate))]
        # 1e-5: where İ = 0 the double zero is split by the differences' round-off (its square root)
        assert abs(near[0] + rate) < 1e-5 and abs(near[1]) < 1e-5
        rates.append(rate)
    assert np.max(np.abs(rates)) > 0.03  # 1/s: the arm's motion changes the column's inertia
    with pytest.raises(gpmegen.ModelError, match="internal dynamics belong to an actuated realization"):
        study.simulate(model, q0, RunSpec(t_end=0.01, dt=1e-3, internal_dynamics=True, save_every=1))
