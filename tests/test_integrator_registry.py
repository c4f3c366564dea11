"""The integrator registry: an integrator defined in this file alone (explicit Euler) runs through
the public API and the command line's choices, and converges at its order; the registry's own
answers (unknown names, what each integrator refuses) in one line."""

import math
from pathlib import Path

import numpy as np
import pytest

import gpmegen
from gpmegen.analysis.run.runspec import RunSpec
from gpmegen.cli.parser import build_parser
from gpmegen.errors import RunSpecError
from gpmegen.runtime import integrators
from gpmegen.runtime.integrators import loop
from gpmegen.status import Ending, Outcome

PENDULUM = (Path(__file__).parent / "models" / "pendulum.toml").read_text()
#: Small swing about the hanging rest (the bob on its rod of 1 m along x at θ = 0, gravity along -y).
REST, SWING = -math.pi / 2, 1e-3


class Euler(integrators.Integrator):
    """Explicit Euler with a fixed step, in Python: order 1."""

    name = "euler"
    summary = "euler (explicit, order 1)"
    saves_on_steps = True

    def run(self, model, q0, qd0, spec, progress=None, watch=None):
        rhs, g = loop.state_derivative(model), loop.grid(0.0, spec.t_end, spec.dt)
        y = loop.start_state(model, q0, qd0)
        ts, ys = [g.time(0)], [y]
        for k in range(1, g.n_steps + 1):
            y = y + g.step(k) * rhs(g.time(k - 1), y)
            if k % spec.save_every == 0 or k == g.n_steps:
                ts.append(g.time(k))
                ys.append(y)
        effort = integrators.Effort(g.n_steps, 0, g.n_steps, 0, 0)
        return np.array(ts), np.array(ys), Outcome(Ending.COMPLETE, g.t_end), effort


@pytest.fixture
def euler():
    integrators.register(Euler)
    yield
    integrators.unregister("euler")


def test_a_registered_integrator_runs_through_the_api_at_its_order(euler, tmp_path):
    """θ(t) = θ_rest + θ0 cos(ω t), ω = √(g/L), for a small swing: Euler's error at t = 1 s halves
    with the step (its amplitude grows by h ω²/2 per second, far above the swing's own
    nonlinearity, θ0²/16 of the frequency)."""
    path = tmp_path / "pendulum.toml"
    bob = '[[chain]]\npoint = "tip"\nposition = [1.0, 0, 0]\n\n[initial]'  # a point: the API's end-effector
    path.write_text(PENDULUM.replace("theta1 = -0.5", f"theta1 = {REST + SWING!r}").replace("[initial]", bob))
    omega = math.sqrt(9.81)
    errors = []
    for dt in (4e-3, 2e-3, 1e-3):
        run = gpmegen.simulate(str(path), method="euler", start="none", t_end=1.0, dt=dt, save_every=1,
                               backend="numpy")
        assert run.status == "complete" and run.meta["settings"]["method"] == "euler"
        exact = REST + SWING * np.cos(omega * run.t)
        errors.append(np.abs(run.q[:, 0] - exact).max())
    orders = [math.log2(coarse / fine) for coarse, fine in zip(errors, errors[1:])]
    assert all(0.9 < p < 1.1 for p in orders), (errors, orders)


def test_a_registered_integrator_is_a_choice_of_the_command_line_and_of_a_spec(euler, capsys):
    assert integrators.names()[-1] == "euler"
    assert RunSpec(method="euler").adaptive is False
    assert build_parser().parse_args(["simulate", "--method", "EULER"]).method == "euler"
    with pytest.raises(SystemExit):
        build_parser().parse_args(["simulate", "--help"])
    shown = " ".join(capsys.readouterr().out.split())
    assert "{rk4,genalpha,dop853,radau,scipy-radau,euler}" in shown
    assert "or euler (explicit, order 1)" in shown


def test_an_unknown_integrator_is_refused_in_one_line_with_the_known_ones():
    with pytest.raises(RunSpecError) as caught:
        integrators.get("euler")
    assert str(caught.value) == "'euler' is not an integrator (choose from rk4, genalpha, dop853, radau, scipy-radau)"


@pytest.mark.parametrize("name, numpy, actuated", [("rk4", True, True), ("genalpha", False, False),
                                                   ("dop853", False, True), ("radau", False, False),
                                                   ("scipy-radau", True, True)])
def test_what_each_integrator_refuses(name, numpy, actuated):
    """The compiled loops run on the C backend alone; of them only DOP853's runs the actuated
    realization (RK4 and SciPy's Radau run it on either backend)."""
    integrator = integrators.get(name)
    assert (integrator.refusal("numpy", False) is None) == numpy
    assert (integrator.refusal("c", True) is None) == actuated
    assert integrator.refusal("c", False) is None


class Implicit(Euler):
    """Euler under another name that says its steps are not bound by the stiff modes."""

    name = "implicit-euler"
    summary = "implicit-euler (a test's own)"
    stiff = True


def test_rk4s_refusal_names_the_registered_methods_that_take_longer_steps(euler):
    """An unstable RK4 step names every registered stiff or adaptive method with its help phrase:
    one registered here appears without an edit to rk4, explicit Euler (fixed step, explicit)
    does not."""
    from gpmegen.runtime.integrators.rk4 import unstable_step

    undamped = np.array([1000j, -1000j])   # RK4's stable step: 2√2/1000 s
    integrators.register(Implicit)
    try:
        refusal = unstable_step(1e-2, undamped)
    finally:
        integrators.unregister(Implicit.name)
    assert unstable_step(1e-3, undamped) is None
    for name in ("genalpha", "radau", "dop853", "scipy-radau"):
        assert integrators.get(name).summary in refusal
    assert refusal.endswith(f"or {Implicit.summary}") and "euler (explicit" not in refusal
    assert Implicit.summary not in unstable_step(1e-2, undamped)
