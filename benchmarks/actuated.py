"""Per-step time of the actuated realization's RK4 and DOP853: the compiled loops against the
Python loops and against the ideal realization's compiled loop, in one process.

Run: ``.venv/bin/python benchmarks/actuated.py [--rounds 5] [--steps 20000] [--python-steps 1000]``.
Models: tests/models/two_link_traced.toml (two coordinates, one constraint; input on theta2)
from its [initial] configuration made consistent, and the reference arm at n_rfe = 5 (inputs on
psi2 and x3) from its locked start. Each loop takes steps of 1e-5 s from that start: the compiled
ones ``--steps``, the Python ones ``--python-steps`` (the same grid, fewer of its steps), in calls
of at most ``span`` steps each from the start (the two links: 10,000; the arm: 150, as its
actuated realization diverges within about 210 steps: its internal dynamics are unstable at
n_rfe = 5, and a call's own cost, some 10 µs, is then spread over fewer steps); CPU time of the process, the
best of 3 runs per round, rounds in alternation. Before the times, each
compiled actuated run is checked against the Python loop over the NumPy backend on the Python
run's steps. DOP853 (rtol 1e-8, atol 1e-10) runs over ``DOP853_SPAN`` s from the same start: the
compiled loop against SciPy's DOP853 driving the C model's actuated rates from Python (the
Python loop), per accepted step, the two runs' final states compared first. The load average is
printed before and after.
"""

from __future__ import annotations

import argparse
import copy
import os
import statistics
import time
from pathlib import Path

import numpy as np

import gpmegen
from gpmegen.analysis.run import reference_case, study
from gpmegen.runtime import integrators

ROOT = Path(__file__).resolve().parents[1]
DT = 1e-5
RTOL, ATOL = 1e-8, 1e-10
# DOP853's span, s: the arm's actuated realization diverges after about 2 ms (see above)
DOP853_SPAN = {"two_link": 0.2, "arm": 1.5e-3}


def two_link(backend):
    """(model, inputs, q0, qd0, span) of the two links."""
    file = gpmegen.read_model_file(ROOT / "tests" / "models" / "two_link_traced.toml")
    model = gpmegen.load(model=file.model, backend=backend)
    begun = study.file_start(model, {"theta1": 0.6, "theta2": -1.0})
    return model, ["theta2"], begun.q, begun.qd, 10000


def arm(backend):
    """(model, inputs, q0, qd0, span) of the reference arm at n_rfe = 5."""
    model, q0 = reference_case.initial_state(gpmegen.load("manipulator", nrfe=5, backend=backend), "locked")
    return model, ["psi2", "x3"], q0, np.zeros(model.n_dof), 150


def steps_of(model, q0, qd0, steps, span):
    """``steps`` steps of DT in RK4 calls of ``span`` steps from the start: (CPU seconds per step, final q)."""
    span = min(steps, span)
    start = time.process_time()
    for _ in range(steps // span):
        _, q, _, _, status = model.rk4(q0, qd0, span * DT, DT, save_every=span)
    seconds = time.process_time() - start
    if status != 0:
        raise SystemExit(f"{model}: the run ended {status!r}")
    return seconds / (steps // span * span), q[-1]


def python_loop(model, q0, qd0, steps, span):
    """The Python loop (integrators.rk4.rk4_steps) over ``model``'s rates, as :func:`steps_of`."""
    y0 = integrators.loop.start_state(model, q0, qd0)
    span = min(steps, span)
    g = integrators.loop.grid(0.0, span * DT, DT)
    start = time.process_time()
    for _ in range(steps // span):
        _, y, status = integrators.rk4.rk4_steps(integrators.loop.state_derivative(model), y0, g, 0, span, span)
    seconds = time.process_time() - start
    if status != 0:
        raise SystemExit(f"{model}: the Python loop ended {status!r}")
    return seconds / (steps // span * span), y[-1, :model.n_dof]


def dop853_steps(model, q0, qd0, t_end, python=False):
    """DOP853 over ``[0, t_end]`` to :data:`RTOL`, :data:`ATOL`: (CPU seconds per accepted step,
    final state): the compiled loop, or with ``python`` SciPy's DOP853 over ``model``'s rates."""
    from scipy.integrate import solve_ivp

    y0 = integrators.loop.start_state(model, q0, qd0)
    start = time.process_time()
    if python:
        solution = solve_ivp(integrators.loop.state_derivative(model), (0.0, t_end), y0, method="DOP853",
                             rtol=RTOL, atol=ATOL)
        seconds, steps, y, ok = time.process_time() - start, len(solution.t) - 1, solution.y[:, -1], solution.success
    else:
        counts = np.zeros(5, dtype=np.int64)
        rows, status = model.dop853(0.0, y0, np.array([t_end]), RTOL, ATOL, np.zeros(1), counts)
        seconds, steps, y, ok = time.process_time() - start, int(counts[0]), rows[-1], status == 0
    if not ok:
        raise SystemExit(f"{model}: DOP853 did not reach {t_end} s")
    return seconds / steps, y[:model.n_dof]


def former(model):
    """``model`` (C backend, actuators set) as the actuated realization ran before its compiled
    loop: the Python loop over the C terms, solved by gpme.actuated in NumPy (what
    gpmegen.runtime.actuated does for a model that is not on the C backend)."""
    other = copy.copy(model)
    other.backend = "numpy"  # the terms still come from its C evaluator
    return other


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    parser.add_argument("--steps", type=int, default=20000)
    parser.add_argument("--python-steps", type=int, default=1000)
    args = parser.parse_args()
    print(f"load average before: {os.getloadavg()}")
    for name, make in (("two_link_traced (n = 2, m = 1)", two_link), ("reference arm n_rfe = 5", arm)):
        c, inputs, q0, qd0, span = make("c")
        numpy = make("numpy")[0]
        t_dop = DOP853_SPAN[make.__name__]
        loops = {
            "actuated, compiled DOP853": lambda: dop853_steps(c.with_actuators(inputs), q0, qd0, t_dop),
            "actuated, DOP853 Python loop (SciPy, C terms)": lambda: dop853_steps(c.with_actuators(inputs), q0, qd0,
                                                                                  t_dop, python=True),
            "actuated, compiled RK4": lambda: steps_of(c.with_actuators(inputs), q0, qd0, args.steps, span),
            "actuated, Python loop over the C terms": lambda: python_loop(c.with_actuators(inputs), q0, qd0,
                                                                          args.python_steps, span),
            "actuated, Python loop, C terms, NumPy solve": lambda: python_loop(former(c.with_actuators(inputs)), q0,
                                                                               qd0, args.python_steps, span),
            "actuated, Python loop (NumPy backend)": lambda: python_loop(numpy.with_actuators(inputs), q0, qd0,
                                                                         args.python_steps, span),
            "ideal, compiled RK4": lambda: steps_of(c, q0, qd0, args.steps, span),
        }
        check = min(span, args.python_steps)
        compiled = steps_of(c.with_actuators(inputs), q0, qd0, check, span)[1]
        reference = python_loop(numpy.with_actuators(inputs), q0, qd0, check, span)[1]
        difference = np.max(np.abs(compiled - reference)) / max(np.max(np.abs(reference)), 1.0)
        print(f"\n{name}: n_dof = {c.n_dof}, inputs on {', '.join(inputs)}; compiled against the Python loop "
              f"after {check} steps: {difference:.1e} (relative)")
        compiled = dop853_steps(c.with_actuators(inputs), q0, qd0, t_dop)[1]
        reference = dop853_steps(c.with_actuators(inputs), q0, qd0, t_dop, python=True)[1]
        difference = np.max(np.abs(compiled - reference)) / max(np.max(np.abs(reference)), 1.0)
        print(f"  DOP853 to {t_dop:g} s, compiled against SciPy's over the C rates: {difference:.1e} (relative)")
        times = {label: [] for label in loops}
        for _ in range(args.rounds):
            for label, run in loops.items():
                times[label].append(min(run()[0] for _ in range(3)))
        for label, per_step in times.items():
            print(f"  {label:44s} best {1e6 * min(per_step):9.2f} µs/step, "
                  f"median {1e6 * statistics.median(per_step):9.2f}")
        best = {label: min(per_step) for label, per_step in times.items()}
        compiled, ideal = best["actuated, compiled RK4"], best["ideal, compiled RK4"]
        print(f"  the former path / compiled: {best['actuated, Python loop, C terms, NumPy solve'] / compiled:.0f}x; "
              f"compiled actuated / ideal: {compiled / ideal:.2f}x; DOP853 Python loop / compiled: "
              f"{best['actuated, DOP853 Python loop (SciPy, C terms)'] / best['actuated, compiled DOP853']:.0f}x")
    print(f"\nload average after: {os.getloadavg()}")


if __name__ == "__main__":
    main()
