"""Programmed laws that switch (Min, Max, Abs, Heaviside, Piecewise) in constraints and drives.

A hub turning about z carries a flexible link (n_rfe 2) in the vertical plane; its angle is
prescribed by a law that switches at t = T. The piecewise model must move as the two models of
its branches switched at T (the first run to T, the second continuing from its state), NumPy and
C must agree on both sides of the switch, and a law whose rate jumps at the switch is built with
a warning naming the constraint and the instant (the impulse there is not applied).
"""

from __future__ import annotations

import os
import subprocess
import sys

import numpy as np
import pytest
import sympy as sp
from test_model_file import BASE

import gpmegen
from gpmegen.analysis.run.model_files import load_model_file
from gpmegen.errors import DerivationError, ModelError
from gpmegen.model import Body, Constraint, FlexibleLink, Joint, Model, Parameter, Point
from gpmegen.model.chain import TIME, CircularSection, symbol
from gpmegen.model.shapes import solid_cylinder
from gpmegen.runtime import integrators
from gpmegen.symbolic import derive
from gpmegen.symbolic.piecewise import as_piecewise

PARAMETERS = (
    Parameter("g", 9.81, "m/s^2"), Parameter("W", 3.0, "rad/s", "hub speed after the switch"),
    Parameter("T", 0.25, "s", "switching instant"), Parameter("L", 0.4, "m"), Parameter("r", 0.005, "m"),
    Parameter("d", 0.002, "N m s/rad"), Parameter("ab", 20.0, "1/s", "Baumgarte gains"),
)
P = {p.name: p.symbol for p in PARAMETERS}
t, W, T = TIME, P["W"], P["T"]
THETA = symbol("theta1")
T_SWITCH, SPEED = 0.25, 3.0


def spin_up(s):
    """Hub angle while it spins up to W in the time T (C1 at T, where it is W·T/2)."""
    return W / T * (s**2 / 2 + (T / (2 * sp.pi)) ** 2 * (sp.cos(2 * sp.pi * s / T) - 1))


# law written with Min, its branch before T, its branch after T, θ̇(0)
LAWS = {
    "spin_up": (spin_up(sp.Min(t, T)) + W * (t - sp.Min(t, T)), spin_up(t), W * (t - T / 2), 0.0),
    "ramp": (W * sp.Min(t, T), W * t, W * T, SPEED),
}


def hub_model(name, law, drives=()):
    chain = (
        Joint("theta1", "revolute", "z"),
        Body("hub", solid_cylinder(0.5, 0.03, 0.02, "z")),
        FlexibleLink("1", P["L"], CircularSection(P["r"]), 2700, 7e10, 2.6e10, n_rfe=2,
                     damping=(P["d"], P["d"], P["d"])),
        Point("E"),
    )
    return Model(name, PARAMETERS, chain, (0, -P["g"], 0), drives,
                 (Constraint("spin", THETA - law, 0, P["ab"], P["ab"]),), ("theta1",))


@pytest.fixture(scope="module")
def env(tmp_path_factory, shared_cache):
    """A private generated folder for the whole module, and the run's shared C cache."""
    with pytest.MonkeyPatch.context() as mp:
        mp.setenv("GPMEGEN_GENERATED", str(tmp_path_factory.mktemp("generated")))
        mp.setenv("GPMEGEN_CACHE", str(shared_cache))
        yield


@pytest.fixture(scope="module")
def hubs(env):
    """``hubs(law, part)``: (C model, NumPy model, build messages) of the law's piecewise model
    (part 0) or of one of its branches (1: before T, 2: after T)."""
    built = {}

    def get(law, part=0):
        if (law, part) not in built:
            model = hub_model(f"hub_{law}_{part}", LAWS[law][part])
            messages = []
            c = gpmegen.load(model=model, backend="c", progress=messages.append)
            built[law, part] = (c, gpmegen.load(model=model, backend="numpy", build=False), messages)
        return built[law, part]

    return get


def start(law, n):
    q, qd = np.zeros(n), np.zeros(n)
    qd[0] = LAWS[law][3]
    return q, qd


def _close(a, b, tol):
    return np.max(np.abs(np.asarray(a) - np.asarray(b))) <= tol * max(1.0, np.max(np.abs(np.asarray(b))))


# the spin-up law's three models (the piecewise one and its branches) are built in make check-c;
# the ramp's in make test
@pytest.mark.parametrize("law", [pytest.param(law, marks=[pytest.mark.long] if law == "spin_up" else [])
                                 for law in LAWS])
def test_terms_on_each_side_are_the_branch_models_on_both_backends(law, hubs, rng):
    """Φ, Φ̇, D, γ of the piecewise model are those of the branch model of the side the time is
    on (derivatives taken branch by branch, no impulse), and the C module computes what the
    NumPy one does."""
    model, numpy_model, _ = hubs(law)
    for side, times in ((1, (0.0, 0.1, 0.249)), (2, (0.251, 0.4, 1.3))):
        branch, numpy_branch, _ = hubs(law, side)
        for time in times:
            q, qd = rng.normal(size=model.n_dof), rng.normal(size=model.n_dof)
            terms = model.constraint_terms(time, q, qd)
            for a, b in zip(terms, numpy_model.constraint_terms(time, q, qd)):
                assert _close(a, b, 1e-12)
            for a, b in zip(terms, branch.constraint_terms(time, q, qd)):
                assert _close(a, b, 1e-12)
            assert _close(model.mass_matrix(q), numpy_model.mass_matrix(q), 1e-12)
            assert _close(model.forces(time, q, qd), numpy_model.forces(time, q, qd), 1e-12)
            assert _close(model.accelerations(time, q, qd), numpy_branch.accelerations(time, q, qd), 1e-10)


@pytest.mark.long
def test_spin_up_runs_like_its_two_branches_switched_at_T(hubs):
    """A law that is C1 at the switch (its Φ̈ even continuous): RK4 on the piecewise model
    against the first branch to T and the second from its state on, in C and NumPy."""
    model, numpy_model, _ = hubs("spin_up")
    first, numpy_first, _ = hubs("spin_up", 1)
    second, numpy_second, _ = hubs("spin_up", 2)
    q0, qd0 = start("spin_up", model.n_dof)
    dt, n_half = 1e-4, int(round(T_SWITCH / 1e-4))
    _, q, qd, _, status = model.rk4(q0, qd0, 2 * n_half * dt, dt, save_every=2 * n_half)
    assert status == 0
    _, q1, qd1, w1, _ = first.rk4(q0, qd0, n_half * dt, dt, save_every=n_half)
    _, q2, qd2, _, _ = second.rk4(q1[-1], qd1[-1], T_SWITCH + n_half * dt, dt, save_every=n_half, t0=T_SWITCH,
                                  w0=w1[-1])
    assert abs(q[-1][0] - SPEED * 1.5 * T_SWITCH) < 1e-6   # θ(2T) = W(2T - T/2): on the law
    assert _close(np.r_[q[-1], qd[-1]], np.r_[q2[-1], qd2[-1]], 1e-9)
    _, y, _ = integrators.rk4.rk4(numpy_model, q0, qd0, 2 * T_SWITCH, dt)
    _, y1, _ = integrators.rk4.rk4(numpy_first, q0, qd0, T_SWITCH, dt)
    n = model.n_dof
    _, y2, _ = integrators.rk4.rk4(numpy_second, y1[-1, :n], y1[-1, n:2 * n], 2 * T_SWITCH, dt, t0=T_SWITCH)
    assert _close(y[-1, :2 * n], y2[-1, :2 * n], 1e-9)
    assert _close(y[-1, :2 * n], np.r_[q[-1], qd[-1]], 1e-9)


@pytest.mark.parametrize("backend", [0, 1], ids=["c", "numpy"])
def test_ramp_runs_like_its_two_branches_switched_at_T(hubs, backend):
    """``W·Min(t, T)``: Φ̇ jumps at T. With the impulse not applied, the piecewise model is the
    ramp model up to T and the hold model from the same state on; an adaptive integrator that
    finds the switch by itself agrees with the two runs switched exactly at T. (RK4 with a step
    ending at T differs by O(dt) there: one of its stages at T sees the other side.)"""
    model, first, second = (hubs("ramp", part)[backend] for part in (0, 1, 2))
    q0, qd0 = start("ramp", model.n_dof)
    tight = dict(rtol=1e-12, atol=1e-12)
    _, y, status = integrators.scipy_radau.adaptive(model, q0, qd0, 2 * T_SWITCH, **tight)
    assert status.complete
    _, y1, _ = integrators.scipy_radau.adaptive(first, q0, qd0, T_SWITCH, **tight)
    n = model.n_dof
    _, y2, _ = integrators.scipy_radau.adaptive(second, y1[-1, :n], y1[-1, n:2 * n], 2 * T_SWITCH, t0=T_SWITCH, **tight)
    assert abs(y1[-1, n] - SPEED) < 1e-6          # still turning at W when the hold starts
    assert abs(y[-1, n]) < 0.2 * SPEED            # then pulled back to rest by the Baumgarte terms
    assert _close(y[-1, :2 * n], y2[-1, :2 * n], 1e-9)


def test_a_jump_in_the_rate_is_built_with_one_warning_naming_constraint_and_instant(hubs):
    *_, ramp = hubs("ramp")
    warnings = [m for m in ramp if m.startswith("warning:")]
    assert len(warnings) == 1, ramp
    assert warnings[0].startswith("warning: constraint 'spin': Φ̇ jumps at t = T (0.25 s with the "
                                  "parameter defaults); the impulse there is not applied"), warnings[0]
    assert "\n" not in warnings[0]
    for law, part in (("spin_up", 0), ("spin_up", 1), ("ramp", 1)):
        assert not [m for m in hubs(law, part)[2] if "warning" in m]


X_E = symbol("x_E")


@pytest.mark.parametrize("law, expected", [
    (sp.Heaviside(t - T), ["Φ jumps at t = T (0.25 s with the parameter defaults)"]),
    (sp.Piecewise((t**2, t < T), (2 * T * t - T**2, t < 2 * T), (3 * T**2, True)), ["Φ̇ jumps at t = 2*T (0.5 s"]),
    (sp.Abs(t - T), ["Φ̇ jumps at t = T"]),
    (sp.Abs(t - T) ** 3, []),
    (sp.Max(t - T, 0) ** 2, []),
    (sp.Min(X_E, 0.3), ["Φ̇ jumps at x_E = 0.3;"]),
    # a clamp: the outer switch's condition holds the inner switch, and is not located
    (sp.Max(0, sp.Min(1, t / T)),
     ["Φ̇ jumps at t = T", "its law switches where Min(1, t/T) = 0, and gpmegen cannot"]),
    (sp.Abs(X_E**2 - 0.1), ["its law switches where x_E**2 - 0.1 = 0, and gpmegen cannot tell whether Φ or Φ̇"]),
    # kinks at x_E = k/10; at t = T a jump too large to work out (seven switches in it) may be one
    (sp.Min(t, T) * sp.Mul(*[sp.Abs(X_E - k / 10) - 1 for k in range(7)]),
     [f"Φ̇ jumps at x_E = {k / 10:g};" for k in range(7)]
     + ["its law switches at t = T (0.25 s with the parameter defaults), and gpmegen cannot tell"]),
])
def test_warnings_follow_where_the_law_is_not_continuously_differentiable(law, expected):
    warnings = derive(hub_model("probe", law)).constraints.warnings
    assert len(warnings) == len(expected), warnings
    for warning, beginning in zip(warnings, expected):
        assert warning.startswith(f"constraint 'spin': {beginning}"), warning


def test_first_order_law_warns_where_psi_jumps():
    model = hub_model("probe", 0)
    rate = Constraint("turn", symbol("theta1_dot") - W * sp.Heaviside(T - t), 1, P["ab"])
    model = Model(model.name, model.parameters, model.chain, constraints=(rate,), dependent=("theta1",))
    (warning,) = derive(model).constraints.warnings
    assert warning.startswith("constraint 'turn': Ψ jumps at t = T") and "make the law continuous" in warning


# the hub of test_model_file's file (a joint about z and a flexible link, n_rfe 2), spun up by a
# law written with Piecewise
SPIN_UP = "Piecewise((W/T*(t^2/2 + (T/(2*pi))^2*(cos(2*pi*t/T) - 1)), t <= T), (W*(t - T/2), True))"
FILE = (BASE.replace('name = "arm"', 'name = "hub_file"').replace("g = 9.81\n", "g = 9.81\nW = 3.0\nT = 0.25\n")
        .replace('"y_E - 0.1"', f'"theta1 - {SPIN_UP}"'))

DRIVES = '''
[[drives]]
coordinate = "theta1"
expression = "Max(t - T, 0) + 2*Abs(t - 2*T)"

[[drives]]
coordinate = "psi1_1"
expression = "Heaviside(t - T) + Heaviside(t - 2*T, 1)"

[[drives]]
coordinate = "theta1_1"
expression = "Piecewise((t^2, t < T), (-t, t >= 2*T), (W, True))"

[[drives]]
coordinate = "phi1_1"
expression = "Piecewise((Min(t, 3*T) - T, t > T), (0, True))"
'''


def expected_drives(time, w=SPEED, s=T_SWITCH):
    """The drives of DRIVES evaluated by NumPy (Heaviside(0) = 1/2 unless given)."""
    return np.array([
        max(time - s, 0) + 2 * abs(time - 2 * s),
        np.heaviside(time - s, 0.5) + np.heaviside(time - 2 * s, 1.0),
        time**2 if time < s else (-time if time >= 2 * s else w),
        min(time, 3 * s) - s if time > s else 0.0,
    ])


def test_file_drives_print_and_evaluate_right_on_both_backends(env, tmp_path):
    path = tmp_path / "drives.toml"
    path.write_text(FILE.replace('"hub_file"', '"hub_drives"') + DRIVES)
    model = load_model_file(path)
    c = gpmegen.load(model=model, backend="c")
    numpy_model = gpmegen.load(model=model, backend="numpy", build=False)
    source = (c.folder / "model.c").read_text()
    ternaries = [line for line in source.splitlines() if " ? " in line and "const double" in line]
    assert ternaries and all(line.endswith(";") for line in ternaries)   # each on one line
    assert "Heaviside" not in source and "Piecewise" not in source
    order = [c.index(name) for name in ("theta1", "psi1_1", "theta1_1", "phi1_1")]
    rest = np.zeros(c.n_dof)
    for time in (0.0, 0.1, T_SWITCH, 0.3, 2 * T_SWITCH, 0.6, 3 * T_SWITCH, 1.0):
        expected = expected_drives(time)
        drives = c.drive_forces(time, rest, rest)
        assert np.array_equal(drives[order], numpy_model.drive_forces(time, rest, rest)[order]), time
        assert _close(drives[order], expected, 1e-14), (time, drives[order], expected)


def test_file_piecewise_law_is_the_min_law(hubs, tmp_path, rng):
    """The spin-up written in the file with Piecewise derives without a warning and gives the
    constraint terms of the Python model written with Min, on both sides of the switch."""
    path = tmp_path / "hub.toml"
    path.write_text(FILE)
    assert derive(load_model_file(path)).constraints.warnings == ()
    from_file = gpmegen.load(model=load_model_file(path), backend="numpy")
    _, with_min, _ = hubs("spin_up")
    for time in (0.1, 0.3, 0.9):
        q, qd = rng.normal(size=with_min.n_dof), rng.normal(size=with_min.n_dof)
        for a, b in zip(from_file.constraint_terms(time, q, qd), with_min.constraint_terms(time, q, qd)):
            assert _close(a, b, 1e-12)


@pytest.mark.parametrize("law, error, message", [
    (sp.Piecewise((t, t < T)), ModelError, "a Piecewise has no last pair (value, True)"),
    (sp.DiracDelta(t - T), ModelError, "DiracDelta is an impulse"),
    (sp.floor(t / T), DerivationError, "its law uses floor, whose derivative generated code cannot evaluate"),
])
def test_laws_that_cannot_become_code_are_refused_in_one_line(law, error, message):
    with pytest.raises(error) as info:
        derive(hub_model("probe", law))
    assert message in str(info.value) and "\n" not in str(info.value)


# make check-c: derivations in three processes (any model: test_codegen.py)
@pytest.mark.long
def test_piecewise_generation_is_deterministic_whatever_the_hash_seed(tmp_path):
    path = tmp_path / "hub.toml"
    path.write_text(FILE.replace('"theta1 - Piecewise', '"theta1 - Abs(t - T) - Max(t, 2*T) - Piecewise') + DRIVES)
    code = ("import hashlib, sys; from gpmegen.codegen import render; from gpmegen.analysis.run.model_files import "
            "load_model_file; f = render(load_model_file(sys.argv[1]), ('numpy', 'c'));"
            "print(hashlib.sha256(''.join(f[k] for k in sorted(f)).encode()).hexdigest())")
    digests = {subprocess.run([sys.executable, "-c", code, str(path)], capture_output=True, text=True, check=True,
                              env=dict(os.environ, PYTHONHASHSEED=seed)).stdout for seed in ("0", "1")}
    assert len(digests) == 1


def test_a_switch_is_written_one_way_whatever_sympys_dummy_count():
    """Min and Max order their arguments by name; the stand-ins of the arguments were bare
    Dummies, named by a count that runs through the whole process, so that Min(t/T, 1) became
    Piecewise((1, t/T >= 1), ...) or Piecewise((t/T, t/T <= 1), ...) depending on how many Dummies
    the process had made (the form flips where the count gains a digit). Two occurrences of one
    switch could then take different branches at the switch itself: the Delta driven by its
    motors left its path at t = T in a test run after other tests. One form now, across such a
    boundary, and the rate of a cycloidal move is 0 at its end."""
    t, T = sp.symbols("t T", positive=True)
    u = sp.Min(t / T, 1)
    forms = {str(as_piecewise(u))}
    target = 10 ** len(str(sp.Dummy._count + 20))   # the next count that gains a digit
    while sp.Dummy._count < target - 1:
        sp.Dummy()
    forms.add(str(as_piecewise(u)))   # its two stand-ins counted target - 1 and target
    assert len(forms) == 1, forms
    law = as_piecewise(u - sp.sin(2 * sp.pi * u) / (2 * sp.pi))
    assert sp.diff(law, t).subs({t: 1, T: 1}) == 0
