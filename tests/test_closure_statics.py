"""The sign of a closure's reported reaction, from statics alone: a bar of mass m and length L on
a planar free joint (slides x and y, then a turn about z) is held at rest, horizontal, by a
closure to a point G of the ground at its pivot P. The ground then carries the bar's weight, a
force (0, -m g, 0), and the moment of that weight about G, (0, 0, -m g L / 2): the reaction on
the body of the second point from the body of the first, as docs/model-file.md states, is that
with points = [P, G], and its opposite with points = [G, P]. Then statics, modes and linearize on
closed loops: the four-bar's constrained equilibrium, its one mode and its linear model against
its motion on the loop."""

from __future__ import annotations

import sys
import warnings
from pathlib import Path

import numpy as np
import pytest
import scipy.optimize

import gpmegen
from gpmegen.analysis.run.model_files import read_model_file
from gpmegen.cli import main
from gpmegen.errors import ModelWarning
from gpmegen.runtime import consistent

G, M, L = 9.81, 0.7, 0.4

HELD_BAR = f"""
schema = 1
name = "held_bar"
gravity = [0, "-g", 0]

[parameters]
g = {G}
m = {M}
L = {L}

[[chain]]
point = "G"

[[chain]]
joint = "x"
type = "prismatic"
axis = "x"

[[chain]]
joint = "y"
type = "prismatic"
axis = "y"

[[chain]]
joint = "theta"
type = "revolute"
axis = "z"

[[chain]]
body = "bar"
shape = {{ type = "bar", mass = "m", length = "L", width = 0.02, thickness = 0.01 }}

[[chain]]
point = "P"

[[closures]]
name = "pin"
points = POINTS
type = "revolute"
axis = "x"
"""


@pytest.mark.parametrize("points, sign", [('["P", "G"]', 1.0), ('["G", "P"]', -1.0)])
def test_the_ground_carries_the_weight_and_its_moment(tmp_path, points, sign):
    path = tmp_path / "held_bar.toml"
    path.write_text(HELD_BAR.replace("POINTS", points))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)  # the out-of-plane rows, dropped
        run = gpmegen.simulate(str(path), t_end=0.002, dt=1e-3, save_every=1, backend="numpy",
                               directory=str(tmp_path / "generated"))
    assert run.status == "complete"
    np.testing.assert_allclose(run["q"], 0.0, atol=1e-12)   # held at rest
    weight = M * G
    np.testing.assert_allclose(run["closure_pin_force"], np.tile([0.0, -sign * weight, 0.0], (3, 1)),
                               rtol=0, atol=1e-12 * weight)
    np.testing.assert_allclose(run["closure_pin_moment"], np.tile([0.0, 0.0, -sign * weight * L / 2], (3, 1)),
                               rtol=0, atol=1e-12 * weight)


# ---- statics, modes and linearize on closed loops ---------------------------------------------

_HERE = str(Path(__file__).resolve().parent)
if _HERE not in sys.path:
    sys.path.insert(0, _HERE)

from test_closures import L1, L2, L3, TILTED, exact_four_bar, four_bar_text  # noqa: E402

ROOT = Path(__file__).resolve().parents[1]
# the example's masses; the crank, free, held by a spring k1 to its rest angle and a damper c1
M1, M2, M3, K1, REST, C1 = 0.5, 1.0, 0.8, 2.0, 0.3, 0.05
SPRUNG = {'prescribed = "w*t"\n': f'stiffness = "k1"\nrest = {REST}\ndamping = "c1"\n',
          'w = {': f'k1 = {K1}\nc1 = {C1}\nw = {{',
          'name = "four_bar"': 'name = "four_bar_sprung"'}


def loop_potential(theta1):
    """Gravity and spring energy of the four-bar on its loop, as a function of the crank's angle
    alone (the coupler and rocker from the closed-form position analysis; bars' centres at mid
    length)."""
    coupler, rocker = exact_four_bar(theta1)
    y1 = L1 / 2 * np.sin(theta1)
    y2 = L1 * np.sin(theta1) + L2 / 2 * np.sin(theta1 + coupler)
    y3 = L3 / 2 * np.sin(rocker)
    return G * (M1 * y1 + M2 * y2 + M3 * y3) + K1 * (theta1 - REST) ** 2 / 2


@pytest.fixture(scope="module", params=["planar", "tilted"])
def sprung(request, tmp_path_factory):
    """The four-bar example with its crank free, on a spring and a damper (planar; or in its
    plane turned about x0 with gravity, closed by the revolute whose rows are then redundant, the
    same mechanism): the path of its file and a folder to build into."""
    folder = tmp_path_factory.mktemp("sprung")
    path = folder / "four_bar_sprung.toml"
    if request.param == "planar":
        path.write_text(four_bar_text(**SPRUNG))
    else:
        text = four_bar_text(**TILTED)
        for old, new in SPRUNG.items():
            if "name" in old:
                old, new = 'name = "four_bar_tilted"', 'name = "four_bar_tilted_sprung"'
            assert text.count(old) == 1
            text = text.replace(old, new)
        path.write_text(text)
    return path, str(folder / "generated")


def test_constrained_statics_of_the_four_bar_minimizes_its_potential_on_the_loop(sprung):
    """The constrained statics (Newton on g + C q = Dᵀλ, Φ = 0, gravity in steps) of the four-bar
    under gravity with a spring on its crank: the crank's angle is the minimum of the potential
    on the loop's one coordinate (an independent 1-D minimization over the closed-form loop) to
    1e-8 rad, the coupler and rocker on the loop there."""
    path, folder = sprung
    start = gpmegen.statics(str(path), start="constrained", backend="numpy", directory=folder)
    best = scipy.optimize.minimize_scalar(loop_potential, bracket=(-0.5, 0.5), tol=1e-12).x
    assert abs(best - REST) > 0.1   # gravity moved it well away from the spring's rest
    theta1 = start.q[start.model.index("theta1")]
    assert abs(theta1 - best) < 1e-8
    coupler, rocker = exact_four_bar(theta1)
    np.testing.assert_allclose(start.q[[start.model.index("theta2"), start.model.index("theta3")]],
                               [coupler, rocker], rtol=0, atol=1e-10)


def test_constrained_modes_of_the_four_bar_are_its_one_degree_of_freedom(sprung, capsys, tmp_path):
    """gpmegen modes --lock constraints: one mode, at the frequency of the loop's one coordinate,
    sqrt(V''/m) / 2π, with V'' the second difference of the potential on the loop and m the
    crank's effective inertia 2T at unit crank rate (the other rates from the loop's velocity
    constraint)."""
    path, folder = sprung
    start = gpmegen.statics(str(path), start="constrained", backend="numpy", directory=folder)
    model = start.model
    theta1 = start.q[model.index("theta1")]
    h = 1e-4
    stiffness = (loop_potential(theta1 + h) - 2 * loop_potential(theta1) + loop_potential(theta1 - h)) / h ** 2
    rates = consistent.project_velocities(model, start.q, np.eye(model.n_dof)[model.index("theta1")])
    inertia = 2 * model.energies(start.q, rates)[0]
    expected = np.sqrt(stiffness / inertia) / (2 * np.pi)
    assert main(["modes", str(path), "--lock", "constraints", "--out", str(tmp_path)]) == 0
    out = capsys.readouterr().out
    rows = [line.split() for line in out.splitlines() if line.strip()[:1].isdigit()]
    assert len(rows) == 1
    assert abs(float(rows[0][1]) - expected) < 1e-5 * expected


def reduced_motion_jacobian(model, t, q, qd):
    """∂(q̈_ind, ...) / ∂(q_ind, q̇_ind) of the motion on the loop by central differences: each
    independent coordinate or rate moved, the dependent coordinates put back on Φ = 0 and their
    rates on the velocity constraints, q̈'s independent rows."""
    ind = np.asarray(model.independent)
    k = len(ind)

    def reduced(x):
        qq, rr = q.copy(), qd.copy()
        qq[ind], rr[ind] = x[:k], x[k:]
        qq = consistent.project_onto_constraints(model, qq, t, tol=1e-14)
        rr = consistent.project_velocities(model, qq, rr, t)
        return model.accelerations(t, qq, rr)[ind]

    x0 = np.concatenate([q[ind], qd[ind]])
    J = np.zeros((k, 2 * k))
    for j in range(2 * k):
        step = 1e-6 * max(1.0, abs(x0[j]))
        up, down = x0.copy(), x0.copy()
        up[j] += step
        down[j] -= step
        J[:, j] = (reduced(up) - reduced(down)) / (2 * step)
    return J


def check_linear_model(path, folder):
    """linearize about the constrained statics of the model file ``path``: the state matrix's
    acceleration rows against central differences of the motion on the loop, the states its
    independent coordinates and rates; returns the linear model."""
    lin = gpmegen.linearize(str(path), start="constrained", backend="numpy", directory=folder)
    model = gpmegen.load(model=read_model_file(path).model, backend="numpy", directory=folder, jacobians=True)
    independent = [model.index(name) for name in lin.states[:len(lin.states) // 2]]
    model = model.with_partition([k for k in range(model.n_dof) if k not in independent])
    k = len(independent)
    expected = reduced_motion_jacobian(model, lin.t, lin.q, lin.qd)
    np.testing.assert_allclose(lin.A[:k, k:], np.eye(k))
    scale = np.abs(expected).max()
    assert scale > 1.0
    np.testing.assert_allclose(lin.A[k:], expected, rtol=0, atol=1e-6 * scale)
    return lin


def test_linearize_on_the_four_bar_is_the_derivative_of_its_motion_on_the_loop(sprung):
    """The four-bar with its crank on a spring and a damper (planar, and turned with redundant
    rows): one state and its rate, the damper's damping, the undamped frequency that of the
    constrained mode."""
    lin = check_linear_model(*sprung)
    assert lin.states == ("theta1", "theta1_dot")
    assert lin.A[1, 1] < 0   # the damper


def test_linearize_on_the_flexible_four_bar_is_the_derivative_of_its_motion_on_the_loop(tmp_path):
    """The flexible four-bar (crank prescribed, turning at the statics): its coupler's elastic
    coordinates are the states."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ModelWarning)
        lin = check_linear_model(ROOT / "examples" / "four_bar_flexible.toml", str(tmp_path / "generated"))
    assert lin.states[:2] == ("psi2_1", "psi2_2")
