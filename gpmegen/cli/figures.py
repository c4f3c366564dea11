"""Commands that draw results: ``plot`` (figures) and ``animate`` (a movie or a still)."""
from __future__ import annotations

from pathlib import Path

from .. import outputs
from .common import UsageError, progress


def cmd_plot(args) -> int:
    from ..analysis.figures import plots, run_figures, tracking_plots
    from ..analysis.run import tracking
    from .studies import load_results, measured, reference_label, tracking_reference

    runs = load_results(args.results)
    plots.check_compatible(runs, args.results)  # before any folder or figure is made
    out = Path(args.out)
    reference = tracking_reference(args.reference) if args.reference is not None else None
    tables = [out / "metrics.csv", out / "metrics.md"] if args.reference is not None else []
    extra = [*tables, *tracking_plots.targets(out, args.format)] if args.reference is not None else []
    outputs.check([*run_figures.targets(runs, out, args.format), *extra],
                  [*args.results, *([reference] if reference else [])], args.overwrite)
    outputs.writable_folder(out)
    found = measured(args.results, reference) if args.reference is not None else None  # before any figure
    for path in run_figures.plot_all(runs, out, args.format, names=args.results):
        print(path)
    if found is not None:
        print(tracking.write_csv(found, tables[0]))
        print(tracking.write_markdown(found, tables[1]))
        for path in tracking_plots.path_error(runs, found, reference_label(reference), out, args.format):
            print(path)
    return 0


def cmd_animate(args) -> int:
    """The arm moving (GIF or MP4; in 2D when it stays in one plane, else in 3D), or a still figure
    of it at chosen times."""
    from ..analysis.figures import animation

    try:
        animation.format_of(args.out, still=args.still is not None)  # before anything is loaded
        outputs.check([args.out], [args.results, args.model], args.overwrite)
        outputs.writable_folder(Path(args.out).parent)
        shown = animation.subject(args.results, args.model, progress)
        view = shown.view(args.view, args.magnify, args.bodies)
        t, q = shown.results["t"], shown.results["q"]
        if args.still is not None:
            print(animation.still(shown.scene, shown.loaded, t, q, view, args.still, args.out, dpi=args.dpi or 200))
            return 0
        every = args.every or animation.real_time_every(t, args.fps)
        print(animation.movie(shown.scene, shown.loaded, t, q, view, args.out, args.fps, every,
                              dpi=args.dpi or 100, progress=progress))
    except animation.RequestError as exc:
        raise UsageError(str(exc)) from None
    return 0
