"""Command line: ``gpmegen build | statics | simulate | plot | modes | convergence | demo``.

Usage errors exit with status 2, runtime failures with 1; either prints one line naming the
problem and the fix, never a traceback.
"""

from __future__ import annotations

import argparse
import contextlib
import functools
import os
import sys
import time
from pathlib import Path

import numpy as np

from . import limits
from .errors import BuildError, DerivationError, GpmegenError, ModelError


def positive_int(text: str) -> int:
    """argparse type: a whole number ≥ 1 that fits a machine integer."""
    try:
        value = int(text)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a whole number (use 1 for the rigid arm)") from None
    if value < 1:
        raise argparse.ArgumentTypeError(f"{value} is below 1 (use 1 for the rigid arm, 2 or more for a flexible arm)")
    if value > sys.maxsize:
        raise argparse.ArgumentTypeError(f"{text} is more than any count can hold (at most {sys.maxsize})")
    return value


def _finite_number(accept, problem):
    """argparse type: a finite number for which ``accept(value)`` holds, else ``problem``."""

    def parse(text: str) -> float:
        try:
            value = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a number") from None
        if not (accept(value) and value != float("inf")):
            raise argparse.ArgumentTypeError(f"{text} {problem}")
        return value

    return parse


positive_float = _finite_number(lambda v: v > 0, "must be a positive finite number")
end_time = _finite_number(lambda v: v >= 0, "is below zero or not finite; give the end time in seconds")


def path_argument(text: str) -> str:
    """argparse type: a path, refused when empty (an empty path is not "the default")."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path names no file or folder; give one, or leave the argument "
                                         "out for the default")
    return text


def parameter_override(text: str):
    name, sep, value = text.partition("=")
    if not sep:
        raise argparse.ArgumentTypeError(f"{text!r}: write a parameter override as NAME=VALUE")
    try:
        return name.strip(), float(value)
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r}: the value of {name.strip()!r} is not a number") from None


class UsageError(GpmegenError):
    """A problem with the command line itself (exit status 2)."""


def progress(message: str) -> None:
    print(f"gpmegen: {message}", file=sys.stderr, flush=True)


def _writable_folder(path: Path) -> None:
    """Refuse early an output folder that cannot be written, so nothing is half-written."""
    import tempfile

    probe = path
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise UsageError(f"output folder {path}: {probe} is a file, not a folder; choose another --out")
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as exc:
        raise UsageError(f"output folder {path} is not writable ({exc.strerror}); choose another --out") from None


def _check_results_path(out: Path) -> None:
    """Refuse, before any work, a results path that cannot take a run's files (complete or
    partial): not .npz, a folder, or in a folder that cannot be written."""
    from .analysis import results as results_io

    if out.suffix != ".npz":
        raise UsageError(f"--out {out}: results are written as .npz (a .csv is written beside it)")
    for path in (*results_io.targets(out), *results_io.targets(out, complete=False)):
        if path.is_dir():
            raise UsageError(f"results file {out}: {path} is a folder; choose another name ending in .npz")
    _writable_folder(out.parent)


def _case(model_file, nrfe):
    """The case a command runs: a model file with ``nrfe`` rfes (None: its own), or the
    reference manipulator (default 5 rfes)."""
    if model_file:
        from .analysis.cases import FileCase

        return FileCase(model_file, nrfe)
    from .analysis.reference_case import ReferenceCase

    return ReferenceCase(nrfe or 5)


def cmd_build(args) -> int:
    from .codegen import build

    out = Path(args.out)
    cases = [_case(args.model_file, n) for n in (args.nrfe or [None])]
    models = [case.model for case in cases]  # a bad model is refused before anything is written
    _writable_folder(out)
    backends = ("numpy", "c")  # both are always rendered: the NumPy module is the C one's oracle
    total = time.perf_counter()
    for case, model in zip(cases, models):
        result = case.located(functools.partial(build, model, out, backends, force=args.force, progress=progress,
                                                command=case.command))
        sizes = ", ".join(f"{name} {size / 1024:.0f} KiB" for name, size in result.files.items())
        state = "up to date, skipped (use --force to rebuild)" if result.skipped else f"built in {result.seconds:.2f} s"
        print(f"{result.model}: n_dof = {result.n_dof}, {state}; {result.folder}: {sizes}")
    if len(cases) > 1:
        print(f"total {time.perf_counter() - total:.2f} s")
    return 0


def _default_backend() -> str:
    """"c" when a C compiler is found, else "numpy" (and says so)."""
    from .runtime.ccompile import find_compiler

    try:
        find_compiler()
        return "c"
    except BuildError as exc:
        progress(f"{exc}; using the NumPy backend")
        return "numpy"


def _start(case, start):
    """``start``, or the case's default start; a start the case does not take is a usage error."""
    start = start or case.starts[0]
    if start not in case.starts:
        raise UsageError(case.start_refusal)
    return start


def _run_and_report(case, start, t_end, dt, save_every, method, backend, overrides, out, repartition=False):
    """Run ``case`` (:func:`gpmegen.analysis.runs.run`) and print its summary; ``backend`` None:
    C when a compiler is found. Returns the results; SimulationStopped when the run ended early."""
    from .analysis import runs

    _check_results_path(out)
    backend = backend or _default_backend()
    done = runs.run(case, start, t_end, dt, save_every, method, backend, overrides, out, progress,
                    repartition=repartition)
    res, model, written = done.results, done.model, done.written
    status = str(res["status"])
    phi = np.abs(res["phi"]).max(axis=0) if len(res["t"]) else []
    final = ", ".join(f"{name} = {res['q'][-1, model.index(name)]:.6f}" for name in case.shown(model))
    print(f"{case.label} ({model.backend}, {method}, dt = {dt:g} s): t = {res['t'][-1]:.6g} s in {done.wall:.1f} s; "
          f"{final}; max|Φ| = {', '.join(f'{v:.2e}' for v in phi)}; wrote {', '.join(map(str, written))}")
    if status != "complete":
        kept = f"results up to t = {res['t'][-1]:.6g} s kept in {written[0]} (partial)"
        if out.exists():
            kept += f"; {out} is left as it was"
        raise SimulationStopped(f"{status}; {kept}")
    return res


class SimulationStopped(GpmegenError):
    """The run ended early (diverged or interrupted); partial results were written."""


def cmd_simulate(args) -> int:
    if args.extrapolate or len(args.nrfe or ()) > 1:
        return cmd_extrapolate(args)
    args.nrfe = args.nrfe[0] if args.nrfe else None
    case = _case(args.model_file, args.nrfe)
    start = _start(case, args.statics)
    out = Path(args.out if args.out is not None else f"results/{case.results_stem}.npz")
    _run_and_report(case, start, args.t_end, args.dt, args.save_every, args.method, args.backend,
              dict(args.param or []), out, repartition=args.repartition)
    return 0


def cmd_extrapolate(args) -> int:
    """``simulate --extrapolate``: the run at each --nrfe, then the outputs' limit and errors."""
    from .analysis import extrapolate, extrapolate_plots
    from .errors import ExtrapolationError

    nrfe = sorted(set(args.nrfe or ()))
    if not args.extrapolate or len(nrfe) < 2 or nrfe[0] < 2:
        raise UsageError("several --nrfe need --extrapolate, and --extrapolate needs at least two distinct --nrfe "
                         "of 2 or more (e.g. --nrfe 5 10 20 --extrapolate)")
    cases = [_case(args.model_file, n) for n in nrfe]
    try:
        extrapolate.check_flexible(cases[0].model)
    except ExtrapolationError as exc:
        raise UsageError(str(exc)) from None
    start = _start(cases[0], args.statics)
    out = Path(args.out if args.out is not None else f"results/{cases[0].results_stem}_extrapolated.npz")
    _check_results_path(out)
    backend = args.backend or _default_backend()
    levels, _ = extrapolate.run_levels(cases, start, args.t_end, args.dt, args.save_every, args.method, backend,
                                       dict(args.param or []), out, progress)
    data = extrapolate.extrapolate(levels)  # a level that stopped early: ExtrapolationError, exit status 1
    print("\n".join(extrapolate.summary(data)))
    print(f"wrote {extrapolate.save(data, out)}, {extrapolate_plots.plot(data, out.with_suffix('.png'))}")
    return 0


def cmd_statics(args) -> int:
    case = _case(args.model_file, args.nrfe)
    model, q = case.start("numpy", _start(case, args.statics), dict(args.param or []), progress)
    for name, value in zip(model.coordinates, q):
        print(f"{name:>10s} = {value: .9f}")
    for name, (x, y, z) in zip(model.points, model.point_positions(q)):
        print(f"{name} = ({x:.9f}, {y:.9f}, {z:.9f}) m")
    if case.constants(model):
        print(case.constants(model))
    return 0


def cmd_plot(args) -> int:
    from .analysis import plots
    from .analysis import results as results_io

    runs = [results_io.load(p) for p in args.results]
    _writable_folder(Path(args.out))
    for path in plots.plot_all(runs, Path(args.out), args.format):
        print(path)
    return 0


def cmd_demo(args) -> int:
    """The paper's study: rigid and flexible arms, 10 s, figures."""
    from .analysis.reference_case import ReferenceCase

    outs = {nrfe: Path(args.results) / f"run_nrfe{nrfe}.npz" for nrfe in (1, 5)}
    for out in outs.values():
        _check_results_path(out)
    _writable_folder(Path(args.figures))
    backend = _default_backend()
    dt = 1e-5 if backend == "c" else 1e-4
    save_every = max(1, int(round(1e-3 / dt)))
    if backend != "c":
        progress("no C compiler found: the demo runs the NumPy backend with dt = 1e-4 s (the paper's 1e-5 s "
                 "would take hours in Python)")
    results = []
    for nrfe, out in outs.items():
        res = _run_and_report(ReferenceCase(nrfe), "locked", args.t_end, dt, save_every, "rk4", backend, {}, out)
        results.append(res)
    from .analysis import plots

    for path in plots.plot_all(results, Path(args.figures)):
        print(path)
    return 0


def cmd_modes(args) -> int:
    """Natural frequencies and mode shapes about the static equilibrium."""
    from .analysis import modes, modes_output, reference_case

    out = Path(args.out)
    _writable_folder(out)
    model = reference_case.ReferenceCase(args.nrfe).load("numpy", dict(args.param or []), progress)
    if args.lock == "joints":
        q_eq, result = modes.locked_modes(model, reference_case.joint_start(model))
        where = "joints locked at the paper's start"
    else:
        model, q_eq = reference_case.initial_state(model, "constrained", dict(args.param or []))
        result = modes.constrained_modes(model, q_eq)
        where = "programmed constraints holding (constrained equilibrium, column rotation held)"
    print(f"n_rfe = {args.nrfe}, {where}:")
    print(result.format(args.count))
    stem = f"modes_nrfe{args.nrfe}_{args.lock}"
    print(modes_output.write_modes_csv(result, out / f"{stem}.csv"))
    print(modes_output.plot_mode_shapes(result, out / f"{stem}.png", count=min(6, args.count)))
    return 0


def cmd_convergence(args) -> int:
    """Tip deflection and first frequencies of the clamped arm against n_rfe, beside beam theory."""
    import tempfile

    from .analysis import convergence, modes_output

    out = Path(args.out)
    _writable_folder(out)
    with tempfile.TemporaryDirectory(prefix="gpmegen-convergence-") as tmp:
        directory = Path(args.directory) if args.directory else Path(tmp)
        table = convergence.convergence_table(args.nrfe, directory=directory, static=args.static,
                                        progress=lambda n, s: progress(f"n_rfe = {n} built in {s:.1f} s"))
    print(table.format())
    print(modes_output.plot_convergence(table, out / "convergence.png"))
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(
        prog="gpmegen",
        description="Reference dynamics models (GPME) of manipulators with flexible links, as generated code.",
    )
    sub = parser.add_subparsers(dest="command", metavar="COMMAND")
    sub.required = True

    b = sub.add_parser("build", help="generate the NumPy and C modules of the reference manipulator")
    b.add_argument("model_file", nargs="?", type=path_argument,
                   help="a model description (.toml); default: the reference manipulator")
    b.add_argument("--nrfe", type=positive_int, nargs="+", default=None,
                   help="number of rigid finite elements (1: rigid; default 5, or the file's); several allowed")
    b.add_argument("--out", type=path_argument, default="generated", help="output folder (default: generated/)")
    b.add_argument("--backend", choices=("numpy", "c", "all"), default="all",
                   help="backends to generate (both are always written; the NumPy one is the C one's oracle)")
    b.add_argument("--force", action="store_true", help="rebuild even when the inputs are unchanged")
    b.set_defaults(func=cmd_build)

    def study_options(p, levels=False):
        p.add_argument("model_file", nargs="?", type=path_argument,
                       help="a model description (.toml); default: the reference manipulator")
        p.add_argument("--nrfe", type=positive_int, default=None, nargs="+" if levels else None,
                       help="rigid finite elements of the arm (1: rigid; default 5, or the file's)"
                            + ("; several with --extrapolate" if levels else ""))
        p.add_argument("--statics", choices=("locked", "constrained", "initial"), default=None,
                       help="start: the paper's locked-joint statics (default for the reference case), the "
                            "equilibrium of the constrained system, or a model file's [initial] configuration "
                            "(its default)")
        p.add_argument("--param", type=parameter_override, action="append", metavar="NAME=VALUE",
                       help="override a parameter (repeatable), e.g. --param tdr0=2")

    s = sub.add_parser("simulate", help="statics, then the constrained motion (RK4 or adaptive)")
    study_options(s, levels=True)
    s.add_argument("--t-end", type=end_time, default=10.0, help="end time in s (default 10)")
    s.add_argument("--dt", type=positive_float, default=1e-5, help="RK4 step in s (default 1e-5, the paper's)")
    s.add_argument("--save-every", type=positive_int, default=100, help="keep every k-th step (default 100)")
    s.add_argument("--method", choices=("rk4", "DOP853", "RK45", "Radau", "LSODA"), default="rk4",
                   help="integrator: fixed-step rk4 (paper) or an adaptive scipy method")
    s.add_argument("--backend", choices=("numpy", "c"), default=None,
                   help="generated code to run (default: c when a compiler is present)")
    s.add_argument("--out", type=path_argument, default=None,
                   help="results file .npz (default results/run_nrfe<N>.npz or results/<file>.npz)")
    s.add_argument("--repartition", action="store_true",
                   help="choose the dependent coordinates anew when their block of D becomes ill-conditioned")
    s.add_argument("--extrapolate", action="store_true",
                   help="run every --nrfe (at least two) and extrapolate the outputs to the continuum limit, "
                        "with the discretization error of each run and of the limit")
    s.set_defaults(func=cmd_simulate)

    st = sub.add_parser("statics", help="print the static start configuration")
    study_options(st)
    st.set_defaults(func=cmd_statics)

    pl = sub.add_parser("plot", help="the paper's figures from results files")
    pl.add_argument("results", nargs="+", type=path_argument, help="results .npz files (e.g. results/*.npz)")
    pl.add_argument("--out", type=path_argument, default="figures", help="folder for the figures (default figures/)")
    pl.add_argument("--format", choices=("png", "pdf", "svg"), default="png")
    pl.set_defaults(func=cmd_plot)

    m = sub.add_parser("modes", help="natural frequencies and mode shapes about the static equilibrium")
    m.add_argument("--nrfe", type=positive_int, default=5, help="rigid finite elements of the arm (≥ 2 to have modes)")
    m.add_argument("--lock", choices=("joints", "constraints"), default="joints",
                   help="linearize with the joints locked, or with the programmed constraints holding")
    m.add_argument("--count", type=positive_int, default=10, help="modes to print (default 10)")
    m.add_argument("--param", type=parameter_override, action="append", metavar="NAME=VALUE")
    m.add_argument("--out", type=path_argument, default="figures",
                   help="folder for the CSV and the figure (default figures/)")
    m.set_defaults(func=cmd_modes)

    c = sub.add_parser("convergence", help="clamped arm against n_rfe, beside Euler–Bernoulli and Saint-Venant")
    c.add_argument("--nrfe", type=positive_int, nargs="+", default=[2, 3, 5, 8, 10, 15, 20],
                   help="n_rfe values (default 2 3 5 8 10 15 20; up to 40 takes minutes)")
    c.add_argument("--static", choices=("linear", "nonlinear"), default="linear",
                   help="static deflection from the linear stiffness solve or full Newton–Raphson")
    c.add_argument("--directory", type=path_argument, default=None,
                   help="keep the built clamped-arm models here (default: temporary)")
    c.add_argument("--out", type=path_argument, default="figures", help="folder for convergence.png (default figures/)")
    c.set_defaults(func=cmd_convergence)

    d = sub.add_parser("demo", help="the paper's study: rigid and flexible arms, figures")
    d.add_argument("--t-end", type=positive_float, default=10.0, help="simulated time in s (default 10)")
    d.add_argument("--results", type=path_argument, default="results", help="folder for results (default results/)")
    d.add_argument("--figures", type=path_argument, default="figures", help="folder for figures (default figures/)")
    d.set_defaults(func=cmd_demo)
    for p in (b, s, st, m, c, d):
        p.add_argument("--no-limits", action="store_true",
                       help="start even work estimated to take more than an hour or more memory than is available")
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with limits.lifted() if getattr(args, "no_limits", False) else contextlib.nullcontext():
            return args.func(args)
    except (UsageError, limits.LimitError) as exc:
        print(f"gpmegen {args.command}: error: {exc}", file=sys.stderr)
        return 2
    except (ModelError, DerivationError, BuildError) as exc:
        print(f"gpmegen {args.command}: error: {exc}", file=sys.stderr)
        return 1 if isinstance(exc, BuildError) else 2
    except GpmegenError as exc:
        print(f"gpmegen {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt:
        print(f"gpmegen {args.command}: interrupted", file=sys.stderr)
        return 130
    except MemoryError:
        print(f"gpmegen {args.command}: error: out of memory; ask for a smaller model or run (without "
              f"--no-limits, work that needs more memory than is available is refused before it starts)",
              file=sys.stderr)
        return 1
    except OSError as exc:
        where = f" {exc.filename}" if getattr(exc, "filename", None) else ""
        print(f"gpmegen {args.command}: error:{where} {exc.strerror or exc}", file=sys.stderr)
        return 1
    except Exception as exc:  # a defect: say so in one line, the traceback on request
        if os.environ.get("GPMEGEN_DEBUG"):
            raise
        print(f"gpmegen {args.command}: internal error: {type(exc).__name__}: {exc} (this is a bug; rerun with "
              f"GPMEGEN_DEBUG=1 for the traceback and report it)", file=sys.stderr)
        return 1


if __name__ == "__main__":
    sys.exit(main())
