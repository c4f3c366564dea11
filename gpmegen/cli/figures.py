"""Commands that draw results: ``plot`` (figures) and ``animate`` (a movie or a still)."""
from __future__ import annotations

from pathlib import Path

from .. import outputs
from .common import UsageError, progress


def cmd_plot(args) -> int:
    from ..analysis.figures import plots, run_figures
    from ..analysis.post import results as results_io

    runs = [results_io.load(p) for p in args.results]
    plots.check_compatible(runs, args.results)  # before any folder or figure is made
    outputs.check(run_figures.targets(runs, Path(args.out), args.format), args.results, args.overwrite)
    outputs.writable_folder(Path(args.out))
    for path in run_figures.plot_all(runs, Path(args.out), args.format, names=args.results):
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
