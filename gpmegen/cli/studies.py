"""Commands that study a model: ``modes``, ``linearize``, ``metrics`` and ``convergence``."""
from __future__ import annotations

from pathlib import Path

from .. import outputs
from .common import UsageError, check_terms, default_backend, open_case, progress, run_spec, start_of


def cmd_modes(args) -> int:
    """Natural frequencies and mode shapes about the static equilibrium."""
    from ..analysis.figures import modes_output
    from ..analysis.post import modes

    out = Path(args.out)
    case = open_case(args.model_file, args.nrfe)
    stem = f"modes_{case.name}_{args.lock}"
    outputs.check([out / f"{stem}.csv", out / f"{stem}.png"], [args.model_file], args.overwrite)
    outputs.writable_folder(out)
    start = "locked" if args.lock == "joints" else "constrained"
    begun = case.started("numpy", start, dict(args.param or []), progress)
    # A rigid model (or one whose springs the constraints hold) has nothing to vibrate: said in
    # one line, before anything is written, rather than an empty table and a figure that fails.
    nothing = (f"{case.label} has no mode with --lock {args.lock}: no coordinate that carries a spring "
               f"(a flexible link's sde, a sprung joint) is free to move")
    fix = "make a link flexible or give a joint a spring"
    result = modes.start_modes(begun.model, begun.q, args.lock)
    if result is None and args.lock == "joints":
        raise UsageError(f"{nothing}; {fix}")
    if result is None:
        raise UsageError(f"{nothing} along the constraints; {fix}, or use --lock joints")
    where = ("joints locked at the start" if args.lock == "joints" else
             "programmed constraints holding (constrained equilibrium, joints without springs held)")
    print(f"{case.label}, {where}:")
    print(result.format(args.count))
    print(modes_output.write_modes_csv(result, out / f"{stem}.csv"))
    print(modes_output.plot_mode_shapes(result, out / f"{stem}.png", count=min(6, args.count)))
    return 0


def cmd_linearize(args) -> int:
    """The state-space model about the statics or at instants of a run, written as NPZ or .mat."""
    from .. import api
    from ..analysis.run import linear

    out = Path(args.out)
    if out.suffix not in (".npz", ".mat"):
        raise UsageError(f"--out {out}: write the linear model as .npz or .mat (e.g. --out lin.mat)")
    if (args.at is None) != (args.times is None):
        raise UsageError("--at RESULTS.npz and --times t1,t2,... go together: the run and the instants in it")
    outputs.check(linear.targets(out, len(args.times or ())), [args.model_file, args.at], args.overwrite)
    outputs.writable_folder(out.parent)
    models = api.linearize(args.model_file, nrfe=args.nrfe, start=args.statics, params=dict(args.param or []),
                           backend=args.backend or default_backend(), progress=progress, at=args.at,
                           times=args.times)
    models = models if isinstance(models, list) else [models]
    for lin, target in zip(models, linear.targets(out, len(models))):
        print(lin.summary())
        print(linear.format_eigenvalues(lin.eigenvalues))
        print(f"wrote {linear.save(lin, target)}")
    return 0


def cmd_metrics(args) -> int:
    """Tracking metrics of runs against a reference: printed, and with --out a CSV and a figure."""
    from ..analysis.figures import tracking_plots
    from ..analysis.run import tracking

    runs = load_results(args.results)
    reference = tracking_reference(args.reference)
    out = Path(args.out) if args.out is not None else None
    if out is not None:
        outputs.check([out / "metrics.csv", *tracking_plots.targets(out, args.format)],
                      [*args.results, *([reference] if reference else [])], args.overwrite)
        outputs.writable_folder(out)
    found = measured(args.results, reference, args.after, args.nrfe, args.backend)
    print(tracking.table(found))
    if out is not None:
        print(f"wrote {tracking.write_csv(found, out / 'metrics.csv')}")
        for path in tracking_plots.path_error(runs, found, reference_label(reference), out, args.format):
            print(f"wrote {path}")
    return 0


def load_results(paths) -> list:
    """The results files ``paths``, a damaged or foreign one a usage error."""
    from ..analysis.post import results as results_io

    try:
        return [results_io.load(p) for p in paths]
    except results_io.ResultsError as exc:
        raise UsageError(str(exc)) from None


def tracking_reference(value):
    """``--reference`` of ``metrics`` and ``plot``: the path it names, or None for the built-in
    reference arm (``manipulator`` where no such file is); a missing path a usage error."""
    from ..analysis.run.opening import REFERENCE as MANIPULATOR  # the built-in reference arm

    reference = None if value == MANIPULATOR and not Path(MANIPULATOR).exists() else value
    if reference is not None and not Path(reference).exists():
        raise UsageError(f"--reference {reference}: no such file or folder; give a model file, a folder made by "
                         f"'gpmegen build --out', a results file (.npz) or {MANIPULATOR} (the reference arm)")
    return reference


def reference_label(reference) -> str:
    """How the path-error figure names the reference of :func:`tracking_reference`."""
    return Path(reference).name if reference is not None else "the reference manipulator"


def measured(paths, reference, after=None, nrfe=None, backend=None) -> list:
    """The tracking metrics of the results files ``paths`` against ``reference`` (see
    :func:`gpmegen.api.metrics`); what cannot be measured a usage error."""
    from .. import api
    from ..analysis.post import results as results_io
    from ..analysis.run import tracking

    try:
        return api.metrics(paths, reference, after=after, nrfe=nrfe, backend=backend or default_backend(),
                           progress=progress)
    except (tracking.TrackingError, results_io.ResultsError) as exc:
        raise UsageError(str(exc)) from None


CLAMPED_LEVELS = (2, 3, 5, 8, 10, 15, 20)  # convergence's n_rfe against beam theory
OUTPUT_LEVELS = (3, 5, 9)  # convergence --output's n_rfe: n_sde 2, 4, 8


def cmd_convergence(args) -> int:
    """Tip deflection and first frequencies of a clamped link against n_rfe, beside beam theory:
    the reference arm, or each flexible link of a model file; with --output, the discretization
    error of any comparable output of a run (or of the start) of the model."""
    import tempfile

    from ..analysis.discretization import convergence
    from ..analysis.figures import modes_output

    if args.output:
        return cmd_convergence_of_outputs(args)
    out = Path(args.out)
    studies = {"convergence": convergence.Clamped()}
    if args.model_file:
        model = open_case(args.model_file, None).model
        links = convergence.flexible_links(model)
        if not links:
            raise UsageError(f"{args.model_file}: model {model.name} has no flexible link, so there is nothing to "
                             f"converge; add a [[chain]] flexible link or study another model")
        studies = {f"convergence_{model.name}_link{link.label}": convergence.Clamped(model, link.label)
                   for link in links}
    outputs.check([out / f"{stem}.png" for stem in studies], [args.model_file], args.overwrite)
    outputs.writable_folder(out)
    with tempfile.TemporaryDirectory(prefix="gpmegen-convergence-") as tmp:
        directory = Path(args.directory) if args.directory else Path(tmp)
        for stem, clamped in studies.items():
            table = convergence.convergence_table(args.nrfe or CLAMPED_LEVELS, directory=directory, static=args.static,
                                                  params=dict(args.param or []), clamped=clamped,
                                                  progress=lambda n, s: progress(f"n_rfe = {n} built in {s:.1f} s"))
            print(table.format())
            print(modes_output.plot_convergence(table, out / f"{stem}.png"))
    return 0


def cmd_convergence_of_outputs(args) -> int:
    """``convergence --output``: the model at each --nrfe (a run, or its start at --t-end 0), and
    per output the estimated discretization error of each level, of the limit, and the order."""
    from ..analysis.discretization import extrapolate
    from ..analysis.discretization.levels import run_levels
    from ..errors import ExtrapolationError

    nrfe = sorted(set(args.nrfe or OUTPUT_LEVELS))
    if len(nrfe) < 2 or nrfe[0] < 2:
        raise UsageError("--output needs at least two distinct --nrfe of 2 or more (e.g. --nrfe 4 8 16)")
    check_terms(nrfe, args.terms)
    case = open_case(args.model_file, nrfe[0])
    try:
        extrapolate.check_flexible(case.model)
        extrapolate.select(args.output, extrapolate.joint_names(case.model), extrapolate.point_names(case.model))
    except ExtrapolationError as exc:
        raise UsageError(str(exc)) from None
    at_start = args.t_end == 0
    start = start_of(case, args.statics or ("locked" if at_start and "locked" in case.starts else None))
    levels = run_levels(args.model_file, nrfe, run_spec(args, start), args.backend or default_backend(),
                        dict(args.param or []), None, progress, args.workers)
    selections = extrapolate.select(args.output, extrapolate.joint_names(levels[0].model),
                                    list(levels[0].loaded.points))
    data = extrapolate.extrapolate(levels, [o for o in extrapolate.OUTPUTS if o in {c.output for c in selections}],
                                   terms=args.terms)
    where = f"at the start ({start})" if at_start else f"over {args.t_end:g} s from the start ({start})"
    grid = "" if str(data["grid"]) == "common" else f"; the levels' samples {data['grid']}"
    print(f"{case.name}, n_rfe {', '.join(map(str, nrfe))}, {where}{grid}; per output, its discretization error:")
    print("\n".join(extrapolate.report(data, selections)))
    return 0
