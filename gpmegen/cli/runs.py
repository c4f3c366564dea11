"""Commands that run a case: ``simulate`` (and its extrapolation over several n_rfe), ``invert``,
``statics``, ``demo`` and ``sweep``; the summary a run prints."""
from __future__ import annotations

from pathlib import Path

import numpy as np

from .. import extras, outputs
from ..analysis.run.runspec import RunSpec
from ..status import Ending
from .common import (
    SimulationStopped,
    UsageError,
    check_results_path,
    check_terms,
    default_backend,
    open_case,
    progress,
    run_spec,
    start_of,
)


def _run_and_report(case, spec, backend, overrides, out, overwrite=False, inputs=()):
    """Run ``case`` as ``spec`` says (:func:`gpmegen.analysis.run.runs.run`) and print its summary;
    ``backend`` None: C when a compiler is found; ``inputs``: the paths the command reads, never
    written over. Returns the results; SimulationStopped when the run ended early."""
    from ..analysis.post.results import metadata
    from ..analysis.run import runs
    from ..analysis.run.cases import FileCase
    from ..runtime import integrators

    check_results_path(out, overwrite, inputs)
    backend = backend or default_backend()
    actuated = spec.actuated if spec.actuated is not None else case.actuators
    refusal = integrators.get(spec.method).refusal(backend, bool(actuated))
    if refusal:
        raise UsageError(refusal)
    done = runs.run(case, spec, backend, overrides, out, progress)
    res, model, written = done.results, done.model, done.written
    status = str(res["status"])
    phi = np.abs(res["phi"]).max(axis=0) if len(res["t"]) else []
    violation = f"max|Φ| = {', '.join(f'{v:.2e}' for v in phi)}" if len(model.constraint_names) else "no constraints"
    names = model.coordinates if isinstance(case, FileCase) else case.shown(model)
    final = _coordinate_values(names, [res["q"][-1, model.index(name)] for name in names])
    realization = f", actuated on {', '.join(model.coordinates[k] for k in model.actuators)}" if len(
        model.actuators) else ""
    print(f"{case.label} ({model.backend}, {_integration(metadata(res)['settings'], realization)}): "
          f"{_outcome(status, res['t'][-1])} in {done.wall:.1f} s; {violation}; "
          f"wrote {', '.join(map(str, written))}; state at t = {res['t'][-1]:.6g} s:\n{final}")
    if status != "complete":
        kept = f"results up to t = {res['t'][-1]:.6g} s kept in {written[0]} (partial)"
        if out.exists():
            kept += f"; {out} is left as it was"
        raise SimulationStopped(f"{status}; {kept}", interrupted=status == Ending.INTERRUPTED.value)
    return res


def _integration(settings: dict, realization: str = "") -> str:
    """How a run was integrated, as its summary says it: the method, its step or tolerances, the
    ``realization`` (", actuated on …" or nothing), the save interval and what it took
    (``settings``: the results' meta settings)."""
    from ..analysis.run.runspec import integrator_options
    from ..runtime import integrators
    from ..runtime.integrators import Effort

    method = integrators.get(settings["method"])
    step = [f"dt = {settings['dt']:g} s"] if method.fixed_step else []
    taken = [f"{option.name} = {settings[option.name]:g}" for option in integrator_options()
             if option in method.options]
    how = ", ".join([method.name, *step, *taken])
    return f"{how}{realization}; saved every {settings['save_dt']:g} s; {Effort(**settings['effort']).describe()}"


def _outcome(status: str, t_last: float) -> str:
    """How a run ended, as its summary says it: ``complete at t = 10 s``, ``DIVERGED after t = 0.53 s``
    or ``INTERRUPTED after t = 2.1 s`` (``status``: the results' status text; ``t_last``: the time
    of the last state computed, in s)."""
    ending = status.split(":")[0]
    if ending == Ending.COMPLETE.value:
        return f"complete at t = {t_last:.6g} s"
    return f"{ending.upper()} after t = {t_last:.6g} s"


def _coordinate_values(names, values, per_line=4) -> str:
    """``name = value`` for each coordinate, a few to a line, aligned, indented: the final state
    of a run."""
    cells = [f"{name} = {value: .6f}" for name, value in zip(names, values)]
    width = max(map(len, cells))
    lines = ["  " + "   ".join(c.ljust(width) for c in cells[k:k + per_line]).rstrip()
             for k in range(0, len(cells), per_line)]
    return "\n".join(lines)


def cmd_simulate(args) -> int:
    if args.extrapolate or len(args.nrfe or ()) > 1:
        given = [option for option, value in (("--save-dt", args.save_dt), ("--rtol", args.rtol),
                                              ("--atol", args.atol), ("--rho-inf", args.rho_inf),
                                              ("--actuated", args.actuated)) if value is not None]
        if args.internal_dynamics:
            given.append("--internal-dynamics")
        given += [option for option, value in (("--feedforward", args.feedforward),
                                               ("--controller-model", args.controller_model)) if value is not None]
        if given:
            raise UsageError(f"{', '.join(given)}: not taken by runs at several --nrfe, which save every --dt x "
                             f"--save-every with the methods' defaults; leave {'them' if len(given) > 1 else 'it'} out")
        return cmd_extrapolate(args)
    args.nrfe = args.nrfe[0] if args.nrfe else None
    from ..analysis.post.results import default_name

    case = open_case(args.model_file, args.nrfe)
    if args.feedforward is not None:
        case = case.feed_forward(args.feedforward)
    if args.controller_model is not None:
        case = case.controlled_by(args.controller_model)
    spec = run_spec(args, start_of(case, args.statics))
    name = default_name(case.results_stem, spec.start, spec.method,
                        case.actuators if spec.actuated is None else spec.actuated)
    out = Path(args.out if args.out is not None else f"results/{name}")
    _run_and_report(case, spec, args.backend, dict(args.param or []), out, overwrite=args.overwrite,
                    inputs=[args.model_file] + [a for a in (args.feedforward, args.controller_model) if a is not None])
    return 0


def cmd_invert(args) -> int:
    """Stable inversion: the bounded inputs of the actuated realization over a rest-to-rest motion."""
    from ..analysis.post import results as results_io
    from ..analysis.run import inversions

    case = open_case(args.model_file, args.nrfe)
    out = Path(args.out if args.out is not None else f"results/{case.results_stem}_inversion.npz")
    check_results_path(out, args.overwrite, [args.model_file])
    if not args.t1 > args.t0:
        raise UsageError(f"--t1 ({args.t1:g} s) must come after --t0 ({args.t0:g} s)")
    window = inversions.Window(args.t1, args.t0, args.pre, args.post)
    res, inv = inversions.invert(case, start_of(case, args.statics), window, args.nodes, dict(args.param or []),
                                 args.actuated, progress)
    written = results_io.save(res, out)
    units = results_io.metadata(res).get("force_units", {})
    peak = ", ".join(f"{name} {np.max(np.abs(res['u'][:, j])):.4g} {units.get(str(name), '')}".rstrip()
                     for j, name in enumerate(res["actuators"]))
    print(f"{case.label} (stable inversion, {len(inv.t)} nodes, residual {inv.residual:.1e}): the inputs start "
          f"{inv.lead:.4g} s before t0 = {args.t0:g} s and act until {inv.lag:.4g} s after t1 = {args.t1:g} s; "
          f"max|u|: {peak}; wrote {', '.join(map(str, written))}")
    return 0


def cmd_extrapolate(args) -> int:
    """``simulate --extrapolate``: the run at each --nrfe, then the outputs' limit and errors."""
    from ..analysis.discretization import extrapolate
    from ..analysis.discretization.levels import run_levels
    from ..analysis.figures import extrapolate_plots
    from ..errors import ExtrapolationError

    nrfe = sorted(set(args.nrfe or ()))
    if not args.extrapolate or len(nrfe) < 2 or nrfe[0] < 2:
        raise UsageError("several --nrfe need --extrapolate, and --extrapolate needs at least two distinct --nrfe "
                         "of 2 or more (e.g. --nrfe 5 10 20 --extrapolate)")
    check_terms(nrfe, args.terms)
    cases = [open_case(args.model_file, n) for n in nrfe]
    try:
        extrapolate.check_flexible(cases[0].model)
    except ExtrapolationError as exc:
        raise UsageError(str(exc)) from None
    start = start_of(cases[0], args.statics)
    out = Path(args.out if args.out is not None else f"results/{cases[0].results_stem}_extrapolated.npz")
    from ..analysis.discretization.levels import level_path
    from ..analysis.post import results as results_io

    levels = [path for n in nrfe for path in results_io.targets(level_path(out, n))]
    check_results_path(out, args.overwrite, [args.model_file], also=[out.with_suffix(".png"), *levels])
    backend = args.backend or default_backend()
    levels = run_levels(args.model_file, nrfe, run_spec(args, start), backend, dict(args.param or []), out, progress,
                        args.workers)
    data = extrapolate.extrapolate(levels, terms=args.terms)  # a level that stopped early: ExtrapolationError
    print("\n".join(extrapolate.summary(data)))
    print(f"wrote {extrapolate.save(data, out)}, {extrapolate_plots.plot(data, out.with_suffix('.png'))}")
    return 0


def cmd_statics(args) -> int:
    case = open_case(args.model_file, args.nrfe)
    begun = case.started("numpy", start_of(case, args.statics), dict(args.param or []), progress)
    model, q = begun.model, begun.q
    for name, value, rate in zip(model.coordinates, q, begun.qd):
        print(f"{name:>10s} = {value: .9f}" + (f"   {name}_dot = {rate: .9f}" if begun.qd.any() else ""))
    for name, (x, y, z) in zip(model.points, model.point_positions(q)):
        print(f"{name} = ({x:.9f}, {y:.9f}, {z:.9f}) m")
    if case.constants(model):
        print(case.constants(model))
    if case.source is not None:  # the holding forces' units come from the model (a built folder has none)
        from ..analysis.post import driving

        print(driving.format_holding(case.source, model, q, case.metadata(model).get("constraint_units")))
    return 0


def cmd_demo(args) -> int:
    """The paper's study: rigid and flexible arms, 10 s, figures."""
    from ..analysis.run.reference_case import ReferenceCase

    outs = {nrfe: Path(args.results) / f"run_nrfe{nrfe}.npz" for nrfe in (1, 5)}
    for out in outs.values():
        check_results_path(out, args.overwrite)
    outputs.writable_folder(Path(args.figures))
    backend = default_backend()
    spec = RunSpec(t_end=args.t_end, dt=1e-5 if backend == "c" else 1e-4, start="locked")
    if backend != "c":
        progress("no C compiler found: the demo runs the NumPy backend with dt = 1e-4 s (the paper's 1e-5 s "
                 "would take hours in Python)")
    results = []
    for nrfe, out in outs.items():
        res = _run_and_report(ReferenceCase(nrfe), spec, backend, {}, out, overwrite=True)
        results.append(res)
    from ..analysis.figures import run_figures

    # The figures' names follow from the runs; the results are kept when the figures are refused.
    outputs.check(run_figures.targets(results, Path(args.figures)), (), args.overwrite)
    for path in run_figures.plot_all(results, Path(args.figures)):
        print(path)
    return 0


def cmd_sweep(args) -> int:
    """Many runs of one case over parameter values and rfe counts; a summary table."""
    from ..analysis import sweep

    params = dict(args.param or [])
    if len(params) != len(args.param or []):
        raise UsageError("a parameter is given twice with --param; give each once, with all its values")
    # A sweep's folder is its own (gpmegen.analysis.sweep.plan.claim): a run of the same sweep
    # resumes it, any other is refused; it must not hold the model file.
    outputs.check([args.out], [args.model_file], overwrite=True)
    if args.scheduler:  # before the folder is made: a refused sweep leaves nothing behind
        extras.require("distributed", "a sweep on a Dask cluster (--scheduler)")
    if not Path(args.out).is_file():
        outputs.writable_folder(Path(args.out))
    try:
        summary = sweep.sweep(args.out, params, run_spec(args, args.statics), model_file=args.model_file,
                              nrfe=args.nrfe, samples=args.samples, seed=args.seed, sampling=args.sampling,
                              backend=args.backend or default_backend(), workers=args.workers,
                              scheduler=args.scheduler, progress=progress)
    except sweep.SweepError as exc:
        raise UsageError(str(exc)) from None
    except KeyboardInterrupt as exc:
        if str(exc):
            progress(str(exc))
        raise
    print(f"{summary.runs} runs complete ({summary.skipped} kept from before) in {summary.wall:.1f} s on "
          f"{summary.workers} worker{'s' if summary.workers > 1 else ''}; wrote {', '.join(map(str, summary.written))}")
    return 0
