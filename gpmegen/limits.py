"""Bounds on resources: the time and memory that building a model, compiling it or running it
will take, estimated before it starts from sizes already known, and the refusal of what this
machine cannot finish.

The estimates interpolate measurements on the 2-core development machine linearly in log-log
and extrapolate beyond them with the slope of the last two. Builds, compiles and saved samples
are calibrated by their CPU time, the RK4 steps by README "Performance": times of a quiet
machine, so a busy one only takes longer than estimated and nothing that could finish within
the limit is refused. The other integrators' runs count in GPME solves of that cost (a quarter
of an RK4 step): generalized-α's estimated, DOP853's bounded from below by its stable step,
Radau's (compiled or SciPy's) by the period of the lowest natural frequency (see
:data:`ESTIMATORS`). Work whose estimate exceeds :data:`MAX_SECONDS`, or the memory the
system reports available (``MemAvailable``), raises :class:`LimitError`: one line with the
estimate, the limit and what to change. ``--no-limits`` on the command line, or in Python::

    with gpmegen.limits.lifted():
        model = gpmegen.load("manipulator", nrfe=60)

runs it anyway. Counts that do not fit a machine integer (a run of more than 2**62 steps) are
refused always: no override would make them finish.
"""

from __future__ import annotations

import contextlib
import contextvars
import math
import os
from typing import NamedTuple

from .errors import GpmegenError

#: Estimated wall time above which work is refused (s).
MAX_SECONDS = 3600.0
#: Steps, samples and sizes beyond this cannot be counted (C ``long``, NumPy indices).
MAX_COUNT = 2**62
OVERRIDE = "pass --no-limits (in Python: with gpmegen.limits.lifted(): ...) to start it anyway"

# --- calibration (2-core machine; seconds and bytes) -------------------------------------------
#: Derivation and rendering of both backends against n_dof (the reference manipulator, CPU time;
#: n_rfe 1, 5, 10, 20, 30, 50).
BUILD_SECONDS = ((3, 0.2), (15, 0.8), (30, 2.3), (60, 8.2), (90, 16.1), (150, 44.1))
#: Peak resident memory of the build process against n_dof (benchmarks/build_time.py).
BUILD_BYTES = ((3, 102e6), (15, 121e6), (30, 158e6), (60, 252e6), (90, 393e6), (150, 775e6))
#: The same with the acceleration Jacobians (--jacobians): BUILD_SECONDS and BUILD_BYTES times
#: the ratio measured with and without them in one run (CPU 4.3, 8.6, 12.0, 17.9 times at n_dof
#: 3, 9, 15, 30; memory 1.0, 1.3, 1.9, 4.0 times); beyond 30, extrapolated by that slope.
BUILD_JACOBIAN_SECONDS = ((3, 0.9), (15, 9.6), (30, 41.0))
BUILD_JACOBIAN_BYTES = ((3, 102e6), (15, 230e6), (30, 632e6))
#: C compile (the hot part at -O3 and the rest at -O0, CPU time of both) against the size of
#: model.c in bytes (n_rfe = 1, 5, 10, 20, 30, 50; benchmarks/build_time.py). Long functions are
#: compiled in blocks (codegen/blocks.py), so the compile grows about as the file.
COMPILE_SECONDS = ((64.5e3, 0.3), (287e3, 1.5), (884e3, 4.5), (3.19e6, 9.9), (6.46e6, 18.5), (17.08e6, 44.8))
#: Peak resident memory of the largest compiler (the hot part's) against the size of model.c.
COMPILE_BYTES = ((64.5e3, 102e6), (287e3, 121e6), (884e3, 280e6), (3.19e6, 331e6), (6.46e6, 393e6),
                 (17.08e6, 826e6))
#: One RK4 step against n_dof: the C loop (its GPME solves by the O(n) recursion), and the NumPy
#: loop of ``gpmegen simulate --backend numpy`` (benchmarks/runtime.py --nrfe 1 5 10 and --versus
#: 20, quiet machine).
STEP_SECONDS = {"c": ((3, 0.80e-6), (15, 3.70e-6), (30, 7.05e-6), (60, 21.2e-6)),
                "numpy": ((3, 241e-6), (15, 531e-6), (30, 1032e-6))}
#: GPME solves a generalized-α step takes against n_dof (its modified Newton's iterations and the
#: rate at its end; the paper's study at dt 1e-4 from the locked start, benchmarks/run_estimates.py
#: and benchmarks/integrators.py), and one more for its projection onto the constraints.
GENALPHA_SOLVES_PER_STEP = ((3, 3.0 + 1), (15, 5.0 + 1), (60, 6.2 + 1))
#: One Jacobian of the GPME with the LU factorization of Newton's matrix, in C, against n_dof
#: (central differences of the compiled solve, 4 n + 1 solves, in a model built without
#: --jacobians; benchmarks/run_estimates.py, quiet machine). Generalized-α takes one at its start
#: and refreshes it rarely (1 to 3 in the paper's study): a run is estimated with
#: :data:`JACOBIANS_PER_RUN`.
JACOBIAN_SECONDS = ((3, 15e-6), (15, 74e-6), (30, 0.25e-3), (60, 1.38e-3))
JACOBIANS_PER_RUN = 3
#: The largest |h λ| in DOP853's region of absolute stability (the radius of the part about the
#: origin, over the directions of the left half-plane: 6.79 at 116° from the real axis; 5.96 on
#: the imaginary axis, 6.39 on the real one; from its stability polynomial, tests/test_limits_runs.py).
#: A mode of |λ| = ω needs steps of at most this over ω, whatever its damping.
DOP853_STABILITY_RADIUS = 6.79
#: GPME solves of an accepted DOP853 step: 12 stages, the first the rate at the last one's end.
DOP853_SOLVES_PER_STEP = 12
#: The fewest steps per period of the lowest natural frequency an implicit adaptive method (radau,
#: scipy-radau) takes while that mode moves: a step over a whole period of a vibration cannot
#: follow it to any tolerance (its collocation polynomial of degree 3 through the step would not
#: see the oscillation), so it is cut until it does. The real count is far higher (tens a period
#: at rtol 1e-8: tests/test_limits_runs.py). A motion whose vibrations have all died out below
#: atol could step past it: such a long run is refused though it could finish, and
#: ``--no-limits`` starts it.
STEPS_PER_LOWEST_PERIOD = 1
#: The fewest GPME solves of an accepted Radau IIA step: one Newton iteration on its 3 stages and
#: the rate at its end.
RADAU_SOLVES_PER_STEP = 4
#: One saved sample against n_dof: the derived quantities (E, Φ, drive, constraint forces,
#: energies) evaluated after the run, and its share of the .npz and .csv writing.
SAMPLE_SECONDS = {"c": ((3, 34e-6), (15, 54e-6)), "numpy": ((3, 80e-6), (15, 226e-6))}
#: What a run of a sweep takes beyond its integration: its start (statics) and the writing of its
#: results (n_rfe = 1 and 5, C, runs of 10 steps: 0.01 to 0.04 s each).
RUN_SECONDS = 0.02
#: Memory of the process before a run (interpreter, NumPy, SymPy, the loaded model).
BASE_BYTES = 110e6

_lifted = contextvars.ContextVar("gpmegen_limits_lifted", default=False)


class LimitError(GpmegenError):
    """Work refused before it starts: its estimated time or memory is beyond the limits."""


@contextlib.contextmanager
def lifted():
    """Within this block, nothing is refused for its estimated time or memory."""
    token = _lifted.set(True)
    try:
        yield
    finally:
        _lifted.reset(token)


def are_lifted() -> bool:
    """Whether this code runs within :func:`lifted` (a sweep's workers are told so)."""
    return _lifted.get()


def available_memory() -> float | None:
    """Memory the system can give to a new task without swapping (bytes; ``MemAvailable``), or
    None when the system does not say."""
    try:
        with open("/proc/meminfo") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return _within_address_space(float(line.split()[1]) * 1024)
    except (OSError, ValueError, IndexError):
        pass
    try:
        found = float(os.sysconf("SC_AVPHYS_PAGES") * os.sysconf("SC_PAGE_SIZE"))
    except (OSError, ValueError, AttributeError):
        return None
    return _within_address_space(found)


def _within_address_space(available: float) -> float:
    """``available`` bytes, or fewer when this process's address space is limited (``ulimit -v``):
    what is left of that limit."""
    try:
        import resource

        limit = resource.getrlimit(resource.RLIMIT_AS)[0]
        if limit == resource.RLIM_INFINITY:
            return available
        with open("/proc/self/statm") as fh:
            used = int(fh.read().split()[0]) * os.sysconf("SC_PAGE_SIZE")
        return min(available, max(0.0, float(limit - used)))
    except (ImportError, OSError, ValueError, IndexError):
        return available


def interpolate(points, x: float) -> float:
    """y at ``x`` from measured ``(x, y)`` points (x increasing): linear in log-log between the two
    nearest, extrapolated with their slope outside; inf when it overflows."""
    k = 0
    while k < len(points) - 2 and x > points[k + 1][0]:
        k += 1
    (x0, y0), (x1, y1) = points[k], points[k + 1]
    slope = math.log(y1 / y0) / math.log(x1 / x0)
    try:
        return y0 * (max(x, 1e-300) / x0) ** slope
    except OverflowError:
        return math.inf


def duration(seconds: float) -> str:
    """``seconds`` as a number and in the unit a reader thinks in: "5.4e+08 s (17 years)"."""
    if not math.isfinite(seconds):
        return "forever"
    for unit, size in (("years", 365.25 * 86400), ("days", 86400), ("h", 3600), ("min", 60)):
        if seconds >= 2 * size:
            return f"{seconds:.2g} s ({seconds / size:.3g} {unit})"
    return f"{seconds:.2g} s"


def _gigabytes(n_bytes: float) -> str:
    return f"{n_bytes / 1e9:.3g} GB"


def check(work: str, seconds: float, n_bytes: float, fix: str, at_least: bool = False) -> None:
    """Raise LimitError when ``work`` (what would run, e.g. "building n_dof = 1500") is estimated
    to take more than :data:`MAX_SECONDS` (``at_least``: ``seconds`` is a lower bound) or more
    memory than is available; ``fix`` says what to change. Nothing is refused inside
    :func:`lifted`."""
    if _lifted.get():
        return
    available = available_memory()
    beyond = []
    if seconds > MAX_SECONDS:
        beyond.append(f"the limit of {MAX_SECONDS:.0f} s")
    if available is not None and n_bytes > available:
        beyond.append(f"the {_gigabytes(available)} of memory available")
    if beyond:
        bound = "at least" if at_least else "about"
        raise LimitError(f"{work} would take {bound} {duration(seconds)} and need about {_gigabytes(n_bytes)} of "
                         f"memory, beyond {' and '.join(beyond)}; {fix}, or {OVERRIDE}")


def build_seconds(n_dof: int, jacobians: bool = False) -> float:
    """CPU time (s) of deriving and generating a model of ``n_dof`` coordinates (with its
    acceleration Jacobians: far more, as they are derived too)."""
    return interpolate(BUILD_JACOBIAN_SECONDS if jacobians else BUILD_SECONDS, n_dof)


def check_build(n_dof: int, model: str, detail: str = "", jacobians: bool = False) -> None:
    """Refuse deriving and generating ``model`` (a name) of ``n_dof`` coordinates (with its
    ``jacobians``) when it cannot finish; ``detail`` is said beside n_dof (e.g. the number of
    chain elements)."""
    check(f"building {model} ({detail}n_dof = {n_dof}{', with its Jacobians' if jacobians else ''})",
          build_seconds(n_dof, jacobians), interpolate(BUILD_JACOBIAN_BYTES if jacobians else BUILD_BYTES, n_dof),
          "use fewer rfes (nrfe) or fewer joints" + (", or build without --jacobians" if jacobians else ""))


def check_compile(source_bytes: int, source) -> None:
    """Refuse compiling a generated C file of ``source_bytes`` that cannot finish."""
    check(f"compiling {source} ({source_bytes / 1e6:.3g} MB of C)", interpolate(COMPILE_SECONDS, source_bytes),
          interpolate(COMPILE_BYTES, source_bytes), "use fewer rfes (nrfe) or the NumPy backend (--backend numpy)")


def solve_seconds(n_dof: int, backend: str = "c") -> float:
    """One GPME solve (s): a quarter of an RK4 step, whose four stages are four solves."""
    return interpolate(STEP_SECONDS["c" if backend == "c" else "numpy"], n_dof) / 4


def jacobian_seconds(n_dof: int) -> float:
    """One Jacobian of the GPME and the LU factorization of an n_dof matrix, in C (s)."""
    return interpolate(JACOBIAN_SECONDS, n_dof)


def steps(t_end: float, dt: float) -> int:
    """The number of fixed steps of ``dt`` in ``t_end`` (s); LimitError, always, when it cannot be
    counted."""
    n = t_end / dt if dt > 0 else math.inf
    if not n <= MAX_COUNT:
        raise LimitError(f"t_end = {t_end:g} s with dt = {dt:g} s is {n:.3g} steps, more than any run can count "
                         f"({MAX_COUNT:.3g}); use a larger --dt or a shorter --t-end")
    return int(round(n))


def sample_bytes(n_dof: int, n_constraints: int, backend: str) -> float:
    """Memory held per saved sample at the end of a run: the states collected by the integrator
    and their concatenation, the derived quantities, and the table of the .csv (bytes)."""
    doubles = 6 * n_dof + 2 * n_constraints + 20
    python_lists = 150 + 16 * n_dof if backend == "numpy" else 0  # a float and an array per sample
    return 8.0 * doubles + python_lists


class Integration(NamedTuple):
    """What a run's integration will take, known before it starts: ``steps`` and ``seconds`` of
    wall time on a quiet machine; ``at_least``: a lower bound (an adaptive method, whose steps
    cannot be known before) rather than an estimate; ``what``: the steps in words."""

    steps: float
    seconds: float
    at_least: bool
    what: str


#: How each integrator's run is known before it starts, by ``--method`` name: filled by
#: :func:`gpmegen.runtime.integrators.register` with the integrators themselves, whose
#: ``estimate(n_dof, t_end, dt, omega, backend)`` returns an :class:`Integration` or None (nothing
#: can be said); ``dt`` the fixed step (for adaptive methods the save grid's unit), ``omega`` the
#: natural frequency at the start that bounds its steps (rad/s; None when not computed), as its
#: ``frequency`` says: the "highest", whose stability bounds an explicit step, or the "lowest"
#: vibrating one, whose period an implicit step does not exceed (:data:`STEPS_PER_LOWEST_PERIOD`);
#: its ``stiff``: its steps are not bound by the stiff modes. An implicit adaptive integrator (no
#: stable step bounds it) can bound its steps from below by its largest step, each costing its
#: solves (:func:`solve_seconds`) and its Jacobians and factorizations (:func:`jacobian_seconds`).
ESTIMATORS: dict = {}


def _frequency(method: str) -> str | None:
    """The natural frequency the estimate of ``method`` needs: "highest", "lowest" or None."""
    integrator = ESTIMATORS.get(method)
    return integrator.frequency if integrator is not None else None


def integration_estimate(n_dof: int, t_end: float, dt: float, method: str, backend: str,
                         omega: float | None = None) -> Integration | None:
    """What the integration alone of a run of ``method`` will take (see :data:`ESTIMATORS`), or
    None when nothing can be said before it starts."""
    integrator = ESTIMATORS.get(method)
    return integrator.estimate(n_dof, t_end, dt, omega, backend) if integrator is not None else None


class RunEstimate(NamedTuple):
    """A run before it starts: ``work`` in words, its ``seconds`` and memory ``n_bytes``,
    ``at_least``: the time a lower bound rather than an estimate, and ``stiff``: that bound the
    stable step of an explicit method (which the stiff methods do not have)."""

    work: str
    seconds: float
    n_bytes: float
    at_least: bool = False
    stiff: bool = False


def run_estimate(n_dof: int, n_constraints: int, spec, backend: str, omega: float | None = None) -> RunEstimate:
    """The :class:`RunEstimate` of the run ``spec`` (a :class:`gpmegen.analysis.run.runspec.RunSpec`:
    its method, see :data:`ESTIMATORS`, step ``dt``, end time, and every ``save_every``-th state
    kept, or every ``save_dt`` s when given to a method other than rk4, whose ``save_every`` it
    sets) on ``backend`` ("c" or "numpy"). An integrator whose work cannot be said before it
    starts (no estimator, or no frequency to bound its steps) is taken at zero seconds, a lower
    bound: what its saved samples take is still known."""
    t_end, dt, method = spec.t_end, spec.dt, spec.method
    save_dt = None if method in ESTIMATORS and ESTIMATORS[method].saves_on_steps else spec.save_dt
    integration = integration_estimate(n_dof, t_end, dt, method, backend, omega)
    stiff = integration is not None and integration.at_least and _frequency(method) != "lowest"
    if integration is None:
        integration = Integration(0, 0.0, True, f"a {method} run of n_dof = {n_dof}")
    samples = (steps(t_end, save_dt) if save_dt else steps(t_end, dt) // max(1, int(spec.save_every))) + 2
    backend = "c" if backend == "c" else "numpy"
    seconds = integration.seconds + samples * interpolate(SAMPLE_SECONDS[backend], n_dof)
    n_bytes = BASE_BYTES + samples * sample_bytes(n_dof, n_constraints, backend)
    return RunEstimate(f"{integration.what}, saving {samples:.3g} samples,", seconds, n_bytes, integration.at_least,
                       stiff)


def check_run(n_dof: int, n_constraints: int, spec, backend: str, omega: float | None = None) -> None:
    """Refuse the run ``spec`` that cannot finish (see :func:`run_estimate`): a fixed-step one by
    its estimate, an adaptive one when even its lower bound is beyond the limits."""
    method = spec.method
    estimate = run_estimate(n_dof, n_constraints, spec, backend, omega)
    if estimate.stiff:
        others = " or ".join(m for m, integrator in ESTIMATORS.items() if integrator.stiff and m != method)
        fix = f"use a shorter --t-end, fewer rfes, or --method {others} (steps the stiff modes do not bound)"
    elif _frequency(method) == "lowest":
        fix = ("use a shorter --t-end (its steps do not exceed the lowest mode's period) or a larger "
               "--save-every (or --save-dt)")
    else:
        fix = "use a shorter --t-end, a larger --dt or a larger --save-every (or --save-dt)"
    check(f"running {estimate.work}", estimate.seconds, estimate.n_bytes, fix, at_least=estimate.at_least)


def check_sweep(runs: list[tuple[int, RunEstimate]], workers: int) -> None:
    """Refuse a sweep that cannot finish: ``runs`` lists ``(count, estimate)`` of each of its
    models (``estimate`` of one run, from :func:`run_estimate`), made ``workers``
    at a time, each run taking :data:`RUN_SECONDS` beyond its integration; its memory is that of
    ``workers`` runs at once. A count beyond :data:`MAX_COUNT` is refused always."""
    total = sum(n for n, _ in runs)
    if total > MAX_COUNT:
        raise LimitError(f"a sweep of {total:.3g} runs is more than can be counted ({MAX_COUNT:.3g}); give fewer "
                         f"values or --samples")
    seconds = sum(n * (RUN_SECONDS + estimate.seconds) for n, estimate in runs) / workers
    n_bytes = workers * max(estimate.n_bytes for _, estimate in runs)
    check(f"a sweep of {total} runs on {workers} worker{'s' if workers > 1 else ''}", seconds, n_bytes,
          "give fewer values or --samples, a shorter --t-end, a larger --dt or --save-every, or more workers")


#: Bytes per entry of the sparse Jacobian of SciPy's solve_bvp: its value and two int64 indices,
#: and the value and an index in its compressed copy.
BVP_ENTRY_BYTES = 36


def check_inversion(n_dof: int, nodes: int) -> None:
    """Refuse a stable inversion (SciPy's solve_bvp, NumPy backend) on ``nodes`` mesh nodes that
    cannot finish. Each node holds two blocks of (2 n_dof)² in the collocation's sparse Jacobian
    (:data:`BVP_ENTRY_BYTES` each) and takes, at the least, one Newton iteration: its residual
    and its Jacobian by differences, 4 n_dof + 1 GPME solves."""
    if nodes > MAX_COUNT:
        raise LimitError(f"a stable inversion on {nodes:.3g} mesh nodes is more than can be counted; give fewer "
                         f"--nodes")
    n_bytes = BASE_BYTES + nodes * 2 * (2 * n_dof) ** 2 * BVP_ENTRY_BYTES
    seconds = nodes * (4 * n_dof + 1) * solve_seconds(n_dof, "numpy")
    check(f"a stable inversion on {nodes:.3g} mesh nodes of n_dof = {n_dof}", seconds, n_bytes,
          "give fewer --nodes (the mesh is refined where needed, up to 20 times the nodes given)", at_least=True)


#: Copies of a frame's RGBA pixels alive while it is drawn and encoded (Agg's buffer, the copy
#: taken, the RGB and palette images of the encoder).
FRAME_COPIES = 3


def check_frames(width: int, height: int, frames: int, held: int) -> None:
    """Refuse an animation or figure of ``frames`` frames of ``width`` x ``height`` pixels, of
    which ``held`` are kept in memory until the file is written, that cannot fit."""
    frame = 4.0 * width * height
    n_bytes = BASE_BYTES + frame * (FRAME_COPIES + held)
    check(f"drawing {frames} frame{'s' if frames > 1 else ''} of {width} x {height} pixels "
          f"({frame / 1e6:.3g} MB each, {held} held until written)", 0.0, n_bytes,
          "give a smaller --dpi, or fewer frames with a larger --every")
