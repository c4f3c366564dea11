"""Runtime of the NumPy and C backends: q̈ per call, compile time, RK4 per step.

Two NumPy figures per step: ``bare``, four ``accelerations`` calls and the stage sums in a
Python loop (a lower bound), and ``loop``, the NumPy RK4 of ``gpmegen simulate --backend numpy``
(``gpmegen.runtime.integrators.rk4.rk4``), which computes what the C loop computes: q, q̇ and the work of
the drive and of the constraint forces, with a finite-state check per step. The speed-up is
given against both; like for like is the second.

Run: ``.venv/bin/python benchmarks/runtime.py [--nrfe 1 5 10] [--quick]``. Models are loaded
the usual way (``GPMEGEN_GENERATED`` / ``GPMEGEN_CACHE`` choose the folders); the compile time
is the one recorded when the library was built (a cache hit reports the original build).

``--versus 5 20`` then compares one ``accelerations`` call from Python with ``pinocchio.aba`` on a
serial chain of as many revolute joints (the ``pin`` package; a plain chain of rods about
alternating axes, not the flexible arm: the articulated-body algorithm's cost depends on the
number and kind of joints, not on the inertias), in the same process and interleaved, beside the
same call through the checked cffi path and the bare C call, and times batched evaluation:
``accelerations`` of N = 1000 states in one call, per state.

For the reference case (n_rfe = 5) it then times the paper's run, 10 s at dt = 1e-5 (a million
RK4 steps), entirely in C: for real when the per-step time says it takes under a minute, else
extrapolated. ``--quick`` always extrapolates. The state is the paper's start with the flexible
coordinates zero (not the static sag): the time per step does not depend on it.
"""

from __future__ import annotations

import argparse
import os
import time
import timeit

import numpy as np

import gpmegen
from gpmegen.runtime.integrators.loop import grid
from gpmegen.runtime.integrators.rk4 import rk4

PAPER_DT, PAPER_T_END = 1e-5, 10.0


def start_state(model):
    q = np.zeros(model.n_dof)
    q[model.index("psi2")] = np.pi / 4
    return q, np.zeros(model.n_dof)


def per_call(fn, budget=0.5):
    """Seconds per call: the best of 5 repeats of a batch sized to ``budget`` / 5."""
    fn()
    n, elapsed = 1, 0.0
    while elapsed < 0.02:
        n *= 4
        elapsed = timeit.timeit(fn, number=n)
    number = max(1, int(n * budget / 5 / elapsed))
    return min(timeit.repeat(fn, number=number, repeat=5)) / number


def numpy_rk4_step(model, q, qd, t=0.1, dt=PAPER_DT):
    k1 = model.accelerations(t, q, qd)
    k2 = model.accelerations(t + dt / 2, q + dt / 2 * qd, qd + dt / 2 * k1)
    k3 = model.accelerations(t + dt / 2, q + dt / 2 * (qd + dt / 2 * k1), qd + dt / 2 * k2)
    k4 = model.accelerations(t + dt, q + dt * (qd + dt / 2 * k2), qd + dt * k3)
    return (q + dt / 6 * (qd + 2 * (qd + dt / 2 * k1) + 2 * (qd + dt / 2 * k2) + qd + dt * k3),
            qd + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4))


def numpy_loop_per_step(model, q, qd, budget=1.5, repeat=3):
    """Seconds per step of the NumPy RK4 integrator (no progress bar, no constraint watch):
    the best of ``repeat`` runs of a length sized to ``budget`` / ``repeat``."""
    t0 = time.perf_counter()
    rk4(model, q, qd, 20 * PAPER_DT, PAPER_DT, save_every=20)
    n_steps = max(20, int(budget / repeat / ((time.perf_counter() - t0) / 20)))
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        _, _, outcome = rk4(model, q, qd, n_steps * PAPER_DT, PAPER_DT, save_every=n_steps)
        best = min(best, time.perf_counter() - t0)
        assert outcome.complete, outcome
    return best / n_steps


def c_rk4_per_step(model, q, qd, n_steps, repeat=5):
    """Seconds per step of the C loop: the best of ``repeat`` runs of ``n_steps`` steps (the
    same best-of rule as ``per_call``, so that the ratio compares like with like). Every run
    must reach its end: one that stopped early would look fast."""
    best = float("inf")
    for _ in range(repeat):
        t0 = time.perf_counter()
        _, _, _, _, status = model.rk4(q, qd, n_steps * PAPER_DT, PAPER_DT, save_every=max(1, n_steps))
        best = min(best, time.perf_counter() - t0)
        assert status == 0, f"C rk4 stopped with status {status}"
    return best / n_steps


def pinocchio_chain(n_joints: int):
    """(model, data) of a serial chain of ``n_joints`` revolute joints about alternating z and y
    axes, each carrying a 1 kg rod 0.1 m long along x."""
    import pinocchio as pin

    model, parent = pin.Model(), 0
    rod = pin.Inertia(1.0, np.array([0.05, 0.0, 0.0]), np.diag([1e-5, 0.1**2 / 12, 0.1**2 / 12]))
    for k in range(n_joints):
        joint = pin.JointModelRZ() if k % 2 == 0 else pin.JointModelRY()
        placement = pin.SE3(np.eye(3), np.array([0.1 if k else 0.0, 0.0, 0.0]))
        parent = model.addJoint(parent, joint, placement, f"j{k}")
        model.appendBodyToJoint(parent, rod, pin.SE3.Identity())
    return model, model.createData()


def raw_call(model, q, qd):
    """A call of the library's gpme_accelerations through cffi with every argument prepared:
    about what the C costs (an empty cffi call takes about 0.1 µs)."""
    ev = model.evaluator
    dep, ind = ev._partition_pointers(model)
    arguments = (0.1, ev.ffi.from_buffer("double[]", q), ev.ffi.from_buffer("double[]", qd), ev._params(model.p), dep,
                 ind, ev.ffi.new("double[]", model.n_dof))
    function = ev.lib.gpme_accelerations
    return lambda: function(*arguments)


def versus_pinocchio(values, rounds, batch=1000):
    """One accelerations call against pinocchio.aba on as many joints, and batched evaluation.
    The call from Python (through the fast-call extension where it is built) is set beside the
    checked path through cffi (the call before the extension) and the bare C call."""
    import pinocchio as pin

    print(f"\n{'n_rfe':>5} {'n_dof':>5} {'C q̈ [µs]':>9} {'cffi q̈ [µs]':>11} {'raw C [µs]':>10} {'aba [µs]':>9} "
          f"{'ratio':>6} {'batched q̈ [µs/state]':>21} {'C step [µs]':>11} {'load':>5}")
    for n in values:
        c_model = gpmegen.load("manipulator", nrfe=n, backend="c")
        if c_model.evaluator.fastcall_unavailable:
            print(f"(single calls go through cffi: {c_model.evaluator.fastcall_unavailable})")
        q, qd = start_state(c_model)
        pin_model, pin_data = pinocchio_chain(c_model.n_dof)
        rng = np.random.default_rng(1)
        pq, pv, tau = (rng.standard_normal(c_model.n_dof) for _ in range(3))
        Q, QD = np.tile(q, (batch, 1)), np.tile(qd, (batch, 1))
        Q[:, 0] += np.linspace(0.0, 0.1, batch)  # distinct states
        raw = raw_call(c_model, q, qd)
        best = [float("inf")] * 6
        for _ in range(rounds):
            figures = (per_call(lambda: c_model.accelerations(0.1, q, qd), 0.2),
                       per_call(lambda: c_model._checked_accelerations(0.1, q, qd), 0.2),
                       per_call(raw, 0.2),
                       per_call(lambda: pin.aba(pin_model, pin_data, pq, pv, tau), 0.2),
                       per_call(lambda: c_model.accelerations(0.1, Q, QD), 0.3) / batch,
                       c_rk4_per_step(c_model, q, qd, 2000))
            best = [min(a, b) for a, b in zip(best, figures)]
        ours, checked, bare, aba, batched, step = best
        print(f"{n:>5} {c_model.n_dof:>5} {ours * 1e6:>9.2f} {checked * 1e6:>11.2f} {bare * 1e6:>10.2f} "
              f"{aba * 1e6:>9.2f} {ours / aba:>5.2f}× {batched * 1e6:>21.2f} {step * 1e6:>11.2f} "
              f"{os.getloadavg()[0]:>5.1f}", flush=True)
    print(f"C q̈: model.accelerations(t, q, qd); cffi q̈: the same through the checked cffi path; raw C: "
          f"gpme_accelerations through cffi with its arguments prepared; ratio: C q̈ / aba, both called from Python "
          f"(best of {rounds} interleaved rounds); batched: one call for {batch} states, per state; C step: one RK4 "
          f"step inside the C loop; load: the 1-minute load average after the row.")


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--nrfe", type=int, nargs="+", default=[1, 5, 10])
    ap.add_argument("--quick", action="store_true", help="never run the million-step loop")
    ap.add_argument("--rounds", type=int, default=4, help="interleaved measuring rounds (best kept)")
    ap.add_argument("--versus", type=int, nargs="*", default=[], metavar="NRFE",
                    help="compare with pinocchio.aba at these n_rfe (e.g. 5 20), then stop")
    args = ap.parse_args()
    if args.versus:
        versus_pinocchio(args.versus, args.rounds)
        return

    print(f"{'n_rfe':>5} {'n_dof':>5} {'compile [s]':>11} {'cache':>5} {'numpy q̈ [µs]':>13} {'C q̈ [µs]':>9} "
          f"{'numpy bare step':>15} {'numpy loop step':>15} {'C step [µs]':>11} {'bare/C':>7} {'loop/C':>7}")
    rows = {}
    for n in args.nrfe:
        numpy_model = gpmegen.load("manipulator", nrfe=n, backend="numpy")
        c_model = gpmegen.load("manipulator", nrfe=n, backend="c")
        q, qd = start_state(c_model)
        c_steps = max(2000, int(0.05 / (4 * per_call(lambda: c_model.accelerations(0.1, q, qd), 0.05))))
        # Rounds that interleave the two backends, keeping each figure's best: on a shared machine
        # a slow spell then hits both rather than one, and the ratio compares like with like.
        best = [float("inf")] * 5
        for _ in range(args.rounds):
            figures = (per_call(lambda: numpy_model.accelerations(0.1, q, qd), 0.2),
                       per_call(lambda: c_model.accelerations(0.1, q, qd), 0.2),
                       per_call(lambda: numpy_rk4_step(numpy_model, q, qd), budget=0.4),
                       numpy_loop_per_step(numpy_model, q, qd, budget=0.6),
                       c_rk4_per_step(c_model, q, qd, c_steps))
            best = [min(a, b) for a, b in zip(best, figures)]
        acc_np, acc_c, step_np, loop_np, step_c = best
        rows[n] = (c_model, step_c)
        cache = "hit" if not c_model.compiled else "miss"
        print(f"{n:>5} {c_model.n_dof:>5} {c_model.compile_seconds:>11.2f} {cache:>5} "
              f"{acc_np * 1e6:>13.1f} {acc_c * 1e6:>9.2f} {step_np * 1e6:>15.1f} {loop_np * 1e6:>15.1f} "
              f"{step_c * 1e6:>11.2f} {step_np / step_c:>6.0f}× {loop_np / step_c:>6.0f}×", flush=True)
    print("q̈: one model.accelerations call from Python (the C figure includes the cffi call); steps in µs.")
    print("numpy bare step: four accelerations calls and the stage sums in a Python loop (no work integrals);")
    print("numpy loop step: gpmegen.runtime.integrators.rk4.rk4, the NumPy integrator, which like the C loop also")
    print("integrates the work of the drive and of the constraint forces; C step: inside the C rk4 loop.")
    print(f"Each figure is the best of {args.rounds} rounds that alternate the backends, each a best of repeats.")

    if 5 in rows:
        c_model, step_c = rows[5]
    else:
        c_model = gpmegen.load("manipulator", nrfe=5, backend="c")
        step_c = c_rk4_per_step(c_model, *start_state(c_model), 20000)
    n_steps = grid(0.0, PAPER_T_END, PAPER_DT).n_steps
    estimate = step_c * n_steps
    print(f"\npaper run, n_rfe = 5: {PAPER_T_END:g} s at dt = {PAPER_DT:g} ({n_steps} RK4 steps), C: "
          f"extrapolated {estimate:.1f} s", flush=True)
    if not args.quick and estimate < 60:
        q, qd = start_state(c_model)
        t0 = time.perf_counter()
        t, _, _, _, status = c_model.rk4(q, qd, PAPER_T_END, PAPER_DT, save_every=100)
        wall = time.perf_counter() - t0
        print(f"actual: {wall:.1f} s ({wall / n_steps * 1e6:.2f} µs/step), status {status}, "
              f"{len(t)} states saved, reached t = {t[-1]:g} s")


if __name__ == "__main__":
    main()
