"""Command line: ``gpmegen build | statics | simulate | invert | sweep | plot | animate | modes | linearize |
metrics | convergence | demo``.

Usage and model errors exit with status 2, runtime failures with 1, an interruption (Ctrl-C,
SIGTERM) with 130; each prints one line naming the problem and the fix, never a traceback.
"""

# Each command imports what it runs inside its own function: the console starts on every command
# (and for --help), and the package's stages (SymPy, the code generator, Matplotlib) are loaded
# only by the commands that use them.
from __future__ import annotations

import argparse
import contextlib
import difflib
import functools
import gc
import os
import re
import sys
import time
import warnings
from pathlib import Path

import numpy as np

from . import limits, outputs
from .analysis.figures.plots import IncompatibleResults
from .analysis.run.runspec import METHODS, RunSpec
from .errors import BuildError, DerivationError, GpmegenError, ModelError, ModelWarning, OutputError, RunSpecError
from .status import Ending


def _count(hint: str):
    """argparse type: a whole number ≥ 1 that fits a machine integer; ``hint`` follows a refusal."""

    def count(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{text!r} is not a whole number ({hint})") from None
        if value < 1:
            raise argparse.ArgumentTypeError(f"{value} is below 1 ({hint})")
        if value > sys.maxsize:
            raise argparse.ArgumentTypeError(f"{text} is more than any count can hold (at most {sys.maxsize})")
        return value

    return count


positive_int = _count("give a count of 1 or more")
# n_rfe: the hint is about the arm, and only there
rfe_count = _count("use 1 for a rigid link, 2 or more for a flexible one")


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
unit_interval = _finite_number(lambda v: 0 <= v <= 1, "must be a number from 0 to 1")
# a GIF frame lasts a whole number of ms and at most 655 s (its delay is 16 bits of 10 ms)
frame_rate = _finite_number(lambda v: 0.01 <= v <= 1000,
                            "frames per second is outside 0.01 to 1000; give e.g. --fps 20")
finite_time = _finite_number(np.isfinite, "is not a finite time; give it in seconds")
end_time = _finite_number(lambda v: v >= 0, "is below zero or not finite; give the end time in seconds")


def path_argument(text: str) -> str:
    """argparse type: a path, refused when empty (an empty path is not "the default")."""
    if not text.strip():
        raise argparse.ArgumentTypeError("an empty path names no file or folder; give one, or leave the argument "
                                         "out for the default")
    return text


def parameter_override(text: str):
    """argparse type: ``NAME=VALUE``, the value a number or an expression of numbers as a model
    file's parameter values are (``tdr0=2*pi``), read by the model file's expression parser."""
    from .model.file.expressions import parse
    from .model.requirements import evaluate

    name, sep, value = text.partition("=")
    if not sep:
        raise argparse.ArgumentTypeError(f"{text!r}: write a parameter override as NAME=VALUE")
    name = name.strip()
    unknown = f"the value of {name!r} may use numbers, pi and functions such as sqrt, not names; write e.g. 2*pi"
    try:
        number = evaluate(parse(value, {}, lambda other, scope: f"{other!r}: {unknown}"), {})
    except ModelError as exc:
        raise argparse.ArgumentTypeError(f"{text!r}: {exc}") from None
    if number is None:
        raise argparse.ArgumentTypeError(f"{text!r}: the value of {name!r} is not a finite real number")
    return name, number


def method_name(text: str) -> str:
    """argparse type: an integrator's name in any case (``DOP853`` → ``dop853``)."""
    by_lower = {method.lower(): method for method in METHODS}
    if text.lower() in by_lower:
        return by_lower[text.lower()]
    close = difflib.get_close_matches(text.lower(), by_lower, 1)
    hint = f"; did you mean {by_lower[close[0]]}?" if close else ""
    raise argparse.ArgumentTypeError(f"{text!r} is not an integrator (choose from {', '.join(METHODS)}){hint}")


def figure_formats(text: str) -> tuple:
    """argparse type: comma-separated figure formats among png, pdf and svg (``png,pdf``)."""
    from .analysis.figures.plots import FORMATS

    formats = tuple(dict.fromkeys(f.strip().lower() for f in text.split(",")))
    wrong = [f for f in formats if f not in FORMATS]
    if wrong or not formats:
        raise argparse.ArgumentTypeError(f"{text!r}: figure formats are {', '.join(FORMATS)}, separated by commas "
                                         f"(e.g. png,pdf)")
    return formats


def number_list(text: str) -> tuple:
    """argparse type: finite numbers separated by commas (``0,2.5,5``)."""
    try:
        values = tuple(float(v) for v in text.split(","))
    except ValueError:
        raise argparse.ArgumentTypeError(f"{text!r} is not a list of numbers separated by commas (e.g. 0,2.5,5)") \
            from None
    if not all(np.isfinite(values)):
        raise argparse.ArgumentTypeError(f"{text!r}: every number must be finite")
    return values


def camera(text: str):
    """argparse type of animate's --view: auto, 3d, 2d, or the 3D camera's elevation and azimuth in
    degrees, ``elev,azim`` (a tuple)."""
    if text.strip().lower() in ("auto", "3d", "2d"):
        return text.strip().lower()
    try:
        values = number_list(text)
    except argparse.ArgumentTypeError:
        values = ()
    if len(values) != 2:
        raise argparse.ArgumentTypeError(f"{text!r}: give auto, 3d, 2d or the 3D camera's elevation and azimuth in "
                                         f"degrees, e.g. 20,-60")
    return values


class UsageError(GpmegenError):
    """A problem with the command line itself (exit status 2)."""


def progress(message: str) -> None:
    print(f"gpmegen: {message}", file=sys.stderr, flush=True)


@contextlib.contextmanager
def _warnings_as_lines():
    """A :class:`ModelWarning` printed as one line, as the command line's other warnings are
    (Python's own format adds the source line it was raised at)."""
    with warnings.catch_warnings():
        shown = warnings.showwarning

        def show(message, category, filename, lineno, file=None, line=None):
            if issubclass(category, ModelWarning):
                progress(f"warning: {message}")
            else:
                shown(message, category, filename, lineno, file, line)

        warnings.showwarning = show
        yield


def _check_results_path(out: Path, overwrite: bool = False, inputs=(), also=()) -> None:
    """Refuse, before any work, a results path that cannot take a run's files (complete or
    partial) and ``also`` (paths written with them): not .npz, a folder, one of the command's
    ``inputs``, in a folder that cannot be written, or holding the results of an earlier run
    (unless ``overwrite``)."""
    from .analysis.post import results as results_io

    if out.suffix != ".npz":
        raise UsageError(f"--out {out}: results are written as .npz (a .csv is written beside it)")
    for path in (*results_io.targets(out), *results_io.targets(out, complete=False)):
        if path.is_dir():
            raise UsageError(f"results file {out}: {path} is a folder; choose another name ending in .npz")
    outputs.check(results_io.targets(out, complete=False), inputs, overwrite=True)  # a partial pair is remade
    outputs.check([*results_io.targets(out), *also], inputs, overwrite, what="an earlier run's results",
                  fix="pass --overwrite to replace them, or choose another --out")
    outputs.writable_folder(out.parent)


def _case(model_file, nrfe):
    """The case a command runs (:func:`gpmegen.analysis.run.opening.case_for`)."""
    from .analysis.run.opening import case_for

    return case_for(model_file, nrfe)


def transform_kinds(text: str) -> tuple:
    """argparse type: the body transforms to generate, T,T_i,T_ij separated by commas, or none."""
    from .symbolic.transforms import check_kinds

    if text.strip() == "none":
        return ()
    try:
        return check_kinds([k.strip() for k in text.split(",")])
    except ValueError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def cmd_build(args) -> int:
    from .codegen import build
    from .folder import check_replaceable, read_manifest
    from .runtime.loader import default_directory
    from .symbolic.transforms import DEFAULT as DEFAULT_TRANSFORMS

    out = Path(args.out) if args.out is not None else default_directory()  # where the other commands look
    cases = [_case(args.model_file, n) for n in (args.nrfe or [None])]
    models = [case.model for case in cases]  # a bad model is refused before anything is written
    for model in models:  # a folder without gpmegen's manifest is always built again, so refused at once
        if args.force or read_manifest(out / model.name) is None:
            check_replaceable(out / model.name)
            # and a build too long for the limits, before --out is created
            limits.check_build(limits.model_coordinates(model), model.name, jacobians=args.jacobians)
    outputs.writable_folder(out)
    backends = ("numpy", "c")  # both are always rendered: the NumPy module is the C one's oracle
    transforms, asked = DEFAULT_TRANSFORMS, ""
    if args.transforms is not None:
        transforms, asked = args.transforms, f" --transforms {','.join(args.transforms) or 'none'}"
    if args.jacobians:
        asked += " --jacobians"
    total = time.perf_counter()
    for case, model in zip(cases, models):
        result = case.located(functools.partial(build, model, out, backends, force=args.force, progress=progress,
                                                command=case.command + asked, transforms=transforms,
                                                jacobians=args.jacobians))
        case.record_start(result.folder)
        sizes = ", ".join(f"{name} {size / 1024:.0f} KiB" for name, size in result.files.items())
        state = "up to date, skipped (use --force to rebuild)" if result.skipped else f"built in {result.seconds:.2f} s"
        print(f"{result.model}: n_dof = {result.n_dof}, {state}; {result.folder}: {sizes}")
    if len(cases) > 1:
        print(f"total {time.perf_counter() - total:.2f} s")
    return 0


def cmd_export(args) -> int:
    from .fileio import atomic_write_bytes
    from .model.urdf_export import urdf_text

    case = _case(args.model_file, args.nrfe)
    out = Path(args.out)
    if args.format == "casadi":
        return _export_casadi(case, out, args)
    if args.format == "fmu":
        return _export_fmu(case, out, args)
    if args.inputs:
        raise UsageError("--inputs is for --format casadi and fmu (a URDF holds no inputs); leave it out")
    if out.is_dir():
        raise UsageError(f"--out {out} is a folder; give the file to write, e.g. --out {out / 'arm.urdf'}")
    outputs.check([out], [args.model_file], args.overwrite)
    text = case.located(functools.partial(urdf_text, case.model))
    print(f"wrote {atomic_write_bytes(out, text.encode('utf-8'))}: {case.model.name} as URDF")
    return 0


def _export_casadi(case, out, args) -> int:
    """``export --format casadi``: the model's CasADi functions in the folder ``out``."""
    from .codegen import casadi_export

    casadi_export.require_casadi()  # before the derivation, which takes a while
    outputs.check([out], [args.model_file], overwrite=True)  # never over the model file; its own files below
    command = "gpmegen export " + " ".join(
        [*([str(args.model_file)] if args.model_file else []), *(["--nrfe", str(args.nrfe)] if args.nrfe else []),
         "--format casadi", f"--out {out}", *(["--inputs", ",".join(args.inputs)] if args.inputs else [])])
    made = case.located(functools.partial(casadi_export.export, case.model, out, args.inputs or (), command,
                                          args.overwrite))
    print(f"wrote {out}: {case.model.name} as CasADi functions {', '.join(made)} (.casadi) and their source "
          f"{casadi_export.SOURCE}")
    return 0


def _export_fmu(case, out, args) -> int:
    """``export --format fmu``: the model as an FMU (FMI 2.0 Model Exchange and Co-Simulation) in the file ``out``."""
    from .codegen import fmu_export

    outputs.check([out], [args.model_file], overwrite=True)  # never over the model file
    made = case.located(functools.partial(fmu_export.export, case, out, args.inputs or (), args.overwrite,
                                          progress=progress))
    print(f"wrote {made}: {case.model.name} as an FMU (FMI 2.0 Model Exchange and Co-Simulation, "
          f"binary for {fmu_export.PLATFORM} and sources)")
    return 0


def input_names(text: str) -> tuple:
    """argparse type: coordinate names separated by commas."""
    names = tuple(name.strip() for name in text.split(","))
    if not all(names):
        raise argparse.ArgumentTypeError(f"{text!r} holds an empty name; give coordinates separated by commas, "
                                         f"e.g. theta1,theta2")
    return names


def _default_backend() -> str:
    """"c" when a C compiler is found, else "numpy" (and says so)."""
    from .runtime.loader import default_backend

    return default_backend(progress)


def _start(case, start):
    """``start``, or the case's default start; a start the case does not take is a usage error."""
    start = start or case.starts[0]
    if start not in case.starts:
        raise UsageError(case.start_refusal)
    return start


def run_spec(args, start=None) -> RunSpec:
    """The one :class:`RunSpec` of a command's run options (those its parser has) and ``start``."""
    actuated = getattr(args, "actuated", None)
    return RunSpec(t_end=args.t_end, dt=args.dt, method=args.method, save_every=args.save_every,
                   save_dt=getattr(args, "save_dt", None), rtol=getattr(args, "rtol", None),
                   atol=getattr(args, "atol", None), rho_inf=getattr(args, "rho_inf", None), start=start,
                   repartition=getattr(args, "repartition", False),
                   actuated=() if actuated == ["none"] else actuated,
                   internal_dynamics=getattr(args, "internal_dynamics", False))


def _run_and_report(case, spec, backend, overrides, out, overwrite=False, inputs=()):
    """Run ``case`` as ``spec`` says (:func:`gpmegen.analysis.run.runs.run`) and print its summary;
    ``backend`` None: C when a compiler is found; ``inputs``: the paths the command reads, never
    written over. Returns the results; SimulationStopped when the run ended early."""
    from .analysis.post.results import metadata
    from .analysis.run import runs
    from .analysis.run.cases import FileCase
    from .runtime import integrate

    _check_results_path(out, overwrite, inputs)
    backend = backend or _default_backend()
    actuated = spec.actuated if spec.actuated is not None else case.actuators
    refusal = integrate.compiled_only(spec.method, backend, bool(actuated))
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
    from .runtime.integrate import Effort

    if settings["method"] == "rk4":
        how = f"rk4, dt = {settings['dt']:g} s"
    elif settings["method"] == "genalpha":
        how = f"genalpha, dt = {settings['dt']:g} s, rho_inf = {settings['rho_inf']:g}"
    else:
        how = f"{settings['method']}, rtol = {settings['rtol']:g}, atol = {settings['atol']:g}"
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


class SimulationStopped(GpmegenError):
    """The run ended early (diverged or interrupted); partial results were written.
    ``interrupted``: by Ctrl-C or SIGTERM (exit status 130), else it diverged (1)."""

    def __init__(self, message, interrupted=False):
        super().__init__(message)
        self.interrupted = interrupted


def cmd_simulate(args) -> int:
    if args.extrapolate or len(args.nrfe or ()) > 1:
        given = [option for option, value in (("--save-dt", args.save_dt), ("--rtol", args.rtol),
                                              ("--atol", args.atol), ("--rho-inf", args.rho_inf),
                                              ("--actuated", args.actuated)) if value is not None]
        if args.internal_dynamics:
            given.append("--internal-dynamics")
        if args.feedforward is not None:
            given.append("--feedforward")
        if given:
            raise UsageError(f"{', '.join(given)}: not taken by runs at several --nrfe, which save every --dt x "
                             f"--save-every with the methods' defaults; leave {'them' if len(given) > 1 else 'it'} out")
        return cmd_extrapolate(args)
    args.nrfe = args.nrfe[0] if args.nrfe else None
    from .analysis.post.results import default_name

    case = _case(args.model_file, args.nrfe)
    if args.feedforward is not None:
        case = case.feed_forward(args.feedforward)
    spec = run_spec(args, _start(case, args.statics))
    name = default_name(case.results_stem, spec.start, spec.method,
                        case.actuators if spec.actuated is None else spec.actuated)
    out = Path(args.out if args.out is not None else f"results/{name}")
    _run_and_report(case, spec, args.backend, dict(args.param or []), out, overwrite=args.overwrite,
                    inputs=[args.model_file] + ([args.feedforward] if args.feedforward is not None else []))
    return 0


def cmd_invert(args) -> int:
    """Stable inversion: the bounded inputs of the actuated realization over a rest-to-rest motion."""
    from .analysis.post import results as results_io
    from .analysis.run import inversions

    case = _case(args.model_file, args.nrfe)
    out = Path(args.out if args.out is not None else f"results/{case.results_stem}_inversion.npz")
    _check_results_path(out, args.overwrite, [args.model_file])
    if not args.t1 > args.t0:
        raise UsageError(f"--t1 ({args.t1:g} s) must come after --t0 ({args.t0:g} s)")
    res, inv, written = inversions.invert(case, _start(case, args.statics), args.t0, args.t1, args.pre, args.post,
                                          args.nodes, dict(args.param or []), args.actuated, out, progress)
    units = results_io.metadata(res).get("force_units", {})
    peak = ", ".join(f"{name} {np.max(np.abs(res['u'][:, j])):.4g} {units.get(str(name), '')}".rstrip()
                     for j, name in enumerate(res["actuators"]))
    print(f"{case.label} (stable inversion, {len(inv.t)} nodes, residual {inv.residual:.1e}): the inputs start "
          f"{inv.lead:.4g} s before t0 = {args.t0:g} s and act until {inv.lag:.4g} s after t1 = {args.t1:g} s; "
          f"max|u|: {peak}; wrote {', '.join(map(str, written))}")
    return 0


def cmd_extrapolate(args) -> int:
    """``simulate --extrapolate``: the run at each --nrfe, then the outputs' limit and errors."""
    from .analysis.discretization import extrapolate
    from .analysis.discretization.levels import run_levels
    from .analysis.figures import extrapolate_plots
    from .errors import ExtrapolationError

    nrfe = sorted(set(args.nrfe or ()))
    if not args.extrapolate or len(nrfe) < 2 or nrfe[0] < 2:
        raise UsageError("several --nrfe need --extrapolate, and --extrapolate needs at least two distinct --nrfe "
                         "of 2 or more (e.g. --nrfe 5 10 20 --extrapolate)")
    _check_terms(nrfe, args.terms)
    cases = [_case(args.model_file, n) for n in nrfe]
    try:
        extrapolate.check_flexible(cases[0].model)
    except ExtrapolationError as exc:
        raise UsageError(str(exc)) from None
    start = _start(cases[0], args.statics)
    out = Path(args.out if args.out is not None else f"results/{cases[0].results_stem}_extrapolated.npz")
    from .analysis.discretization.levels import level_path
    from .analysis.post import results as results_io

    levels = [path for n in nrfe for path in results_io.targets(level_path(out, n))]
    _check_results_path(out, args.overwrite, [args.model_file], also=[out.with_suffix(".png"), *levels])
    backend = args.backend or _default_backend()
    levels = run_levels(args.model_file, nrfe, run_spec(args, start), backend, dict(args.param or []), out, progress,
                        args.workers)
    data = extrapolate.extrapolate(levels, terms=args.terms)  # a level that stopped early: ExtrapolationError
    print("\n".join(extrapolate.summary(data)))
    print(f"wrote {extrapolate.save(data, out)}, {extrapolate_plots.plot(data, out.with_suffix('.png'))}")
    return 0


def _check_terms(nrfe, terms) -> None:
    """--terms 2 needs three levels: refused before any run."""
    if len(nrfe) < terms + 1:
        raise UsageError(f"--terms {terms} removes {terms} terms of the discretization error and needs {terms + 1} "
                         f"distinct --nrfe or more (e.g. --nrfe 10 20 40)")


def cmd_statics(args) -> int:
    case = _case(args.model_file, args.nrfe)
    begun = case.started("numpy", _start(case, args.statics), dict(args.param or []), progress)
    model, q = begun.model, begun.q
    for name, value, rate in zip(model.coordinates, q, begun.qd):
        print(f"{name:>10s} = {value: .9f}" + (f"   {name}_dot = {rate: .9f}" if begun.qd.any() else ""))
    for name, (x, y, z) in zip(model.points, model.point_positions(q)):
        print(f"{name} = ({x:.9f}, {y:.9f}, {z:.9f}) m")
    if case.constants(model):
        print(case.constants(model))
    if case.source is not None:  # the holding forces' units come from the model (a built folder has none)
        from .analysis.post import driving

        print(driving.format_holding(case.source, model, q, case.metadata(model).get("constraint_units")))
    return 0


def cmd_plot(args) -> int:
    from .analysis.figures import plots, run_figures
    from .analysis.post import results as results_io

    runs = [results_io.load(p) for p in args.results]
    plots.check_compatible(runs, args.results)  # before any folder or figure is made
    outputs.check(run_figures.targets(runs, Path(args.out), args.format), args.results, args.overwrite)
    outputs.writable_folder(Path(args.out))
    for path in run_figures.plot_all(runs, Path(args.out), args.format, names=args.results):
        print(path)
    return 0


def cmd_demo(args) -> int:
    """The paper's study: rigid and flexible arms, 10 s, figures."""
    from .analysis.run.reference_case import ReferenceCase

    outs = {nrfe: Path(args.results) / f"run_nrfe{nrfe}.npz" for nrfe in (1, 5)}
    for out in outs.values():
        _check_results_path(out, args.overwrite)
    outputs.writable_folder(Path(args.figures))
    backend = _default_backend()
    spec = RunSpec(t_end=args.t_end, dt=1e-5 if backend == "c" else 1e-4, start="locked")
    if backend != "c":
        progress("no C compiler found: the demo runs the NumPy backend with dt = 1e-4 s (the paper's 1e-5 s "
                 "would take hours in Python)")
    results = []
    for nrfe, out in outs.items():
        res = _run_and_report(ReferenceCase(nrfe), spec, backend, {}, out, overwrite=True)
        results.append(res)
    from .analysis.figures import run_figures

    # The figures' names follow from the runs; the results are kept when the figures are refused.
    outputs.check(run_figures.targets(results, Path(args.figures)), (), args.overwrite)
    for path in run_figures.plot_all(results, Path(args.figures)):
        print(path)
    return 0


def cmd_modes(args) -> int:
    """Natural frequencies and mode shapes about the static equilibrium."""
    from .analysis.figures import modes_output
    from .analysis.post import modes
    from .runtime import statics

    out = Path(args.out)
    case = _case(args.model_file, args.nrfe)
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
    if args.lock == "joints":
        if statics.spring_coordinates(begun.model, begun.q).size == 0:
            raise UsageError(f"{nothing}; {fix}")
        _, result = modes.locked_modes(begun.model, begun.q)
        where = "joints locked at the start"
    else:
        result = modes.constrained_modes(begun.model, begun.q)
        if len(result.frequencies) == 0:
            raise UsageError(f"{nothing} along the constraints; {fix}, or use --lock joints")
        where = "programmed constraints holding (constrained equilibrium, joints without springs held)"
    print(f"{case.label}, {where}:")
    print(result.format(args.count))
    print(modes_output.write_modes_csv(result, out / f"{stem}.csv"))
    print(modes_output.plot_mode_shapes(result, out / f"{stem}.png", count=min(6, args.count)))
    return 0


def cmd_linearize(args) -> int:
    """The state-space model about the statics or at instants of a run, written as NPZ or .mat."""
    from . import api
    from .analysis.run import linear

    out = Path(args.out)
    if out.suffix not in (".npz", ".mat"):
        raise UsageError(f"--out {out}: write the linear model as .npz or .mat (e.g. --out lin.mat)")
    if (args.at is None) != (args.times is None):
        raise UsageError("--at RESULTS.npz and --times t1,t2,... go together: the run and the instants in it")
    outputs.check(linear.targets(out, len(args.times or ())), [args.model_file, args.at], args.overwrite)
    outputs.writable_folder(out.parent)
    models = api.linearize(args.model_file, nrfe=args.nrfe, start=args.statics, params=dict(args.param or []),
                           backend=args.backend or _default_backend(), progress=progress, at=args.at,
                           times=args.times)
    models = models if isinstance(models, list) else [models]
    for lin, target in zip(models, linear.targets(out, len(models))):
        print(lin.summary())
        print(linear.format_eigenvalues(lin.eigenvalues))
        print(f"wrote {linear.save(lin, target)}")
    return 0


MANIPULATOR = "manipulator"  # metrics --reference: the built-in reference arm


def cmd_metrics(args) -> int:
    """Tracking metrics of runs against a reference: printed, and with --out a CSV and a figure."""
    from . import api
    from .analysis.figures import tracking_plots
    from .analysis.post import results as results_io
    from .analysis.run import tracking

    try:
        runs = [results_io.load(p) for p in args.results]
    except results_io.ResultsError as exc:
        raise UsageError(str(exc)) from None
    reference = None if args.reference == MANIPULATOR and not Path(MANIPULATOR).exists() else args.reference
    if reference is not None and not Path(reference).exists():
        raise UsageError(f"--reference {reference}: no such file or folder; give a model file, a folder made by "
                         f"'gpmegen build --out', a results file (.npz) or {MANIPULATOR} (the reference arm)")
    out = Path(args.out) if args.out is not None else None
    if out is not None:
        outputs.check([out / "metrics.csv", *tracking_plots.targets(out, args.format)],
                      [*args.results, *([reference] if reference else [])], args.overwrite)
        outputs.writable_folder(out)
    try:
        found = api.metrics(args.results, reference, after=args.after, nrfe=args.nrfe,
                            backend=args.backend or _default_backend(), progress=progress)
    except (tracking.TrackingError, results_io.ResultsError) as exc:
        raise UsageError(str(exc)) from None
    print(tracking.table(found))
    if out is not None:
        label = Path(reference).name if reference is not None else "the reference manipulator"
        print(f"wrote {tracking.write_csv(found, out / 'metrics.csv')}")
        for path in tracking_plots.path_error(runs, found, label, out, args.format):
            print(f"wrote {path}")
    return 0


CLAMPED_LEVELS = (2, 3, 5, 8, 10, 15, 20)  # convergence's n_rfe against beam theory
OUTPUT_LEVELS = (3, 5, 9)  # convergence --output's n_rfe: n_sde 2, 4, 8


def cmd_convergence(args) -> int:
    """Tip deflection and first frequencies of a clamped link against n_rfe, beside beam theory:
    the reference arm, or each flexible link of a model file; with --output, the discretization
    error of any comparable output of a run (or of the start) of the model."""
    import tempfile

    from .analysis.discretization import convergence
    from .analysis.figures import modes_output

    if args.output:
        return cmd_convergence_of_outputs(args)
    out = Path(args.out)
    studies = {"convergence": convergence.Clamped()}
    if args.model_file:
        model = _case(args.model_file, None).model
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


def cmd_animate(args) -> int:
    """The arm moving (GIF or MP4; in 2D when it stays in one plane, else in 3D), or a still figure
    of it at chosen times."""
    from .analysis.figures import animation

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


def cmd_convergence_of_outputs(args) -> int:
    """``convergence --output``: the model at each --nrfe (a run, or its start at --t-end 0), and
    per output the estimated discretization error of each level, of the limit, and the order."""
    from .analysis.discretization import extrapolate
    from .analysis.discretization.levels import run_levels
    from .errors import ExtrapolationError

    nrfe = sorted(set(args.nrfe or OUTPUT_LEVELS))
    if len(nrfe) < 2 or nrfe[0] < 2:
        raise UsageError("--output needs at least two distinct --nrfe of 2 or more (e.g. --nrfe 4 8 16)")
    _check_terms(nrfe, args.terms)
    case = _case(args.model_file, nrfe[0])
    try:
        extrapolate.check_flexible(case.model)
        extrapolate.select(args.output, extrapolate.joint_names(case.model), extrapolate.point_names(case.model))
    except ExtrapolationError as exc:
        raise UsageError(str(exc)) from None
    at_start = args.t_end == 0
    start = _start(case, args.statics or ("locked" if at_start and "locked" in case.starts else None))
    levels = run_levels(args.model_file, nrfe, run_spec(args, start), args.backend or _default_backend(),
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


class Parser(argparse.ArgumentParser):
    """argparse with errors in one line, with "did you mean" for a mistyped subcommand or option."""

    def error(self, message):
        self.exit(2, f"{self.prog}: error: {message}{self._suggestion(message)} (see {self.prog} --help)\n")

    def _suggestion(self, message) -> str:
        wrong = re.search(r"invalid choice: '([^']*)'", message)
        if wrong and self._subparsers is not None:
            close = difflib.get_close_matches(wrong.group(1), self._commands(), 1)
            return f"; did you mean {close[0]!r}?" if close else ""
        if message.startswith("unrecognized arguments: "):
            options = [o for a in self._actions for o in a.option_strings]
            guesses = [difflib.get_close_matches(word.split("=")[0], options, 1)
                       for word in message.split(": ", 1)[1].split() if word.startswith("-")]
            close = [g[0] for g in guesses if g]
            return f"; did you mean {' '.join(close)}?" if close else ""
        return ""

    def _commands(self) -> list:
        return [name for a in self._actions if isinstance(a, argparse._SubParsersAction) for name in a.choices]

    def parse_args(self, args=None, namespace=None):
        """As argparse's, but an option that the chosen subcommand does not know is reported by
        that subcommand (which knows its options, to suggest one)."""
        parsed, extras = self.parse_known_args(args, namespace)
        if extras:
            sub = next((a.choices[parsed.command] for a in self._actions
                        if isinstance(a, argparse._SubParsersAction) and getattr(parsed, "command", None) in a.choices),
                       self)
            sub.error(f"unrecognized arguments: {' '.join(extras)}")
        return parsed


def sweep_param(text: str):
    """argparse type: a swept parameter, NAME=v1,v2,… | NAME=start:stop:count | NAME=low:high."""
    from .analysis.sweep import SweepError, plan

    try:
        return plan.parse_param(text)
    except SweepError as exc:
        raise argparse.ArgumentTypeError(str(exc)) from None


def cmd_sweep(args) -> int:
    """Many runs of one case over parameter values and rfe counts; a summary table."""
    from .analysis import sweep

    params = dict(args.param or [])
    if len(params) != len(args.param or []):
        raise UsageError("a parameter is given twice with --param; give each once, with all its values")
    # A sweep's folder is its own (gpmegen.analysis.sweep.plan.claim): a run of the same sweep
    # resumes it, any other is refused; it must not hold the model file.
    outputs.check([args.out], [args.model_file], overwrite=True)
    if not Path(args.out).is_file():
        outputs.writable_folder(Path(args.out))
    try:
        summary = sweep.sweep(args.out, params, run_spec(args, args.statics), model_file=args.model_file,
                              nrfe=args.nrfe, samples=args.samples, seed=args.seed, sampling=args.sampling,
                              backend=args.backend or _default_backend(), workers=args.workers,
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


def build_parser() -> argparse.ArgumentParser:
    from .help_pages import DESCRIPTIONS, EPILOGS
    from .version import __version__

    parser = Parser(
        prog="gpmegen",
        description="Reference dynamics models (GPME) of manipulators with flexible links, as generated code.",
        epilog="gpmegen COMMAND --help describes a command, with examples and the files it writes. Exit status: 0 "
               "done, 1 failure, 2 usage or model error, 130 interrupted.",
    )
    parser.add_argument("--version", action="version", version=f"gpmegen {__version__}")
    sub = parser.add_subparsers(dest="command", metavar="COMMAND", parser_class=Parser)
    sub.required = True

    def command(name, help):
        return sub.add_parser(name, help=help, description=DESCRIPTIONS[name], epilog=EPILOGS[name],
                              formatter_class=argparse.RawDescriptionHelpFormatter)

    b = command("build", "generate the NumPy and C modules of the reference manipulator or a model file")
    b.add_argument("model_file", nargs="?", type=path_argument,
                   help="a model description (.toml) or a robot description (.urdf); default: the reference "
                        "manipulator")
    b.add_argument("--nrfe", type=rfe_count, nargs="+", default=None,
                   help="number of rigid finite elements (1: rigid; default 5, or the file's); several allowed")
    b.add_argument("--out", type=path_argument, default=None,
                   help="output folder (default: where the other commands look for models: $GPMEGEN_GENERATED, "
                        "else generated/ of the source checkout when inside it, else ./generated/)")
    b.add_argument("--force", action="store_true", help="rebuild even when the inputs are unchanged")
    b.add_argument("--transforms", type=transform_kinds, default=None, metavar="T,T_i,T_ij",
                   help="body transforms to generate: T (4x4 per body, the default), its first derivatives T_i and "
                        "second derivatives T_ij (large: O(n_dof²) matrices per body), or none")
    b.add_argument("--jacobians", action="store_true",
                   help="also generate the derivatives of the GPME, so that the acceleration Jacobians "
                        "dqdd/dq, dqdd/dqd are exact (large: O(n_dof²) values; without them the implicit "
                        "integrators use central differences)")
    b.set_defaults(func=cmd_build)

    ex = command("export", "the discretized chain as a URDF robot, the model's functions for CasADi, or an FMU")
    ex.add_argument("model_file", nargs="?", type=path_argument,
                    help="a model description (.toml or .urdf); default: the reference manipulator")
    ex.add_argument("--format", choices=("urdf", "casadi", "fmu"), required=True,
                    help="the format to write: urdf (a file), casadi (a folder of CasADi functions) or fmu (an "
                         "FMI 2.0 FMU, a file NAME.fmu)")
    ex.add_argument("--nrfe", type=rfe_count, default=None,
                    help="number of rigid finite elements (1: rigid; default 5, or the file's)")
    ex.add_argument("--out", type=path_argument, required=True,
                    help="the file to write, e.g. arm.urdf or arm.fmu; with --format casadi, the folder, e.g. "
                         "arm_casadi")
    ex.add_argument("--inputs", type=input_names, default=None, metavar="NAME,NAME",
                    help="--format casadi and fmu: coordinates that take an input u (a generalized force, added "
                         "to the model's drives), in the order of u; default none")
    ex.set_defaults(func=cmd_export)

    def study_options(p, levels=False):
        p.add_argument("model_file", nargs="?", type=path_argument,
                       help="a model description (.toml) or a folder made by 'build --out'; default: the reference "
                            "manipulator")
        p.add_argument("--nrfe", type=rfe_count, default=None, nargs="+" if levels else None,
                       help="rigid finite elements of the arm (1: rigid; default 5, or the file's)"
                            + ("; several with --extrapolate" if levels else ""))
        p.add_argument("--statics", choices=("locked", "constrained", "none"), default=None,
                       help="start: the statics with the joints locked (default for the reference case), the "
                            "equilibrium of the constrained system, or none: a model file's [initial] "
                            "configuration as given, undeformed (its default)")
        p.add_argument("--param", type=parameter_override, action="append", metavar="NAME=VALUE",
                       help="override a parameter (repeatable); the value is a number or an expression as in "
                            "model files, e.g. --param tdr0=2*pi")

    def run_options(p):
        """How a run integrates: simulate's options, which a sweep's runs take too."""
        p.add_argument("--t-end", type=end_time, default=10.0, help="end time in s (default 10)")
        p.add_argument("--dt", type=positive_float, default=1e-5,
                       help="RK4 step in s (default 1e-5, the paper's); with --save-every, the save interval of "
                            "every method")
        p.add_argument("--save-every", type=positive_int, default=None,
                       help="keep every k-th step of --dt (default: the steps in 1 ms, at least 1)")
        p.add_argument("--method", type=method_name, default="rk4", metavar="{" + ",".join(METHODS) + "}",
                       help="integrator, in any case: fixed-step rk4 (the paper's, default), genalpha (implicit, "
                            "order 2, numerically damped, step --dt, in C), dop853 (adaptive, order 8, in C), radau "
                            "(implicit, adaptive, order 5, in C: for stiff, finely divided links) or scipy-radau "
                            "(implicit, SciPy on the model from Python)")
        p.add_argument("--backend", choices=("numpy", "c"), default=None,
                       help="generated code to run (default: c when a compiler is present)")
        p.add_argument("--repartition", action="store_true",
                       help="choose the dependent coordinates anew when their block of D becomes ill-conditioned")

    s = command("simulate", "statics, then the constrained motion (rk4, dop853, radau, genalpha); "
                                "at several --nrfe, extrapolated")
    study_options(s, levels=True)
    run_options(s)
    s.add_argument("--save-dt", type=positive_float, default=None,
                   help="save interval in s (default --dt x --save-every); for rk4 a whole number of steps")
    s.add_argument("--rtol", type=positive_float, default=None,
                   help="relative tolerance of the adaptive methods (default 1e-8)")
    s.add_argument("--atol", type=positive_float, default=None,
                   help="absolute tolerance of the adaptive methods, in the units of q and q' (default 1e-10)")
    s.add_argument("--rho-inf", type=unit_interval, default=None,
                   help="genalpha's numerical damping: its spectral radius at large steps, 0 (most damped) to 1 "
                        "(none; default 0.9)")
    s.add_argument("--out", type=path_argument, default=None,
                   help="results file .npz (default results/<run_nrfe<N> or the file's name>_<start>_<method>.npz)")
    s.add_argument("--overwrite", action="store_true", help="replace the results of an earlier run at --out")
    s.add_argument("--actuated", nargs="+", metavar="COORDINATE", default=None,
                   help="realize the programmed constraints by inputs on these coordinates alone, one per "
                        "constraint (e.g. --actuated psi2 x3), instead of ideally; default: a model file's "
                        "actuators (--actuated none: ideally), else none")
    s.add_argument("--feedforward", type=path_argument, default=None, metavar="RUN.npz",
                   help="add the inputs u of an actuated run (simulate --actuated, or invert) to the drives of the "
                        "model's coordinates of the same names, interpolated linearly in t")
    s.add_argument("--internal-dynamics", action="store_true",
                   help="with an actuated realization: save the linearized internal dynamics' eigenvalues at "
                        "every saved sample (internal_eigenvalues)")
    s.add_argument("--extrapolate", action="store_true",
                   help="run every --nrfe (at least two) and extrapolate the outputs to the continuum limit, "
                        "with the discretization error of each run and of the limit")
    s.add_argument("--terms", type=int, choices=(1, 2), default=1,
                   help="terms of the discretization error removed: 1 (C/n_sde^2, default) or 2 (C/n_sde^2 + "
                        "D/n_sde^4, from three levels or more; for motions whose phase error is large at the coarser "
                        "levels)")
    s.add_argument("--workers", type=positive_int, default=None,
                   help="with --extrapolate: levels run at once, on threads of this process where their loops "
                        "are compiled, else on local processes (default: one per core, at most one per level; 1 "
                        "runs them one after the other in this process)")
    s.set_defaults(func=cmd_simulate)

    inv = command("invert", "stable inversion: bounded inputs of the actuated realization, with pre- and "
                            "post-actuation")
    study_options(inv)
    inv.add_argument("--actuated", nargs="+", metavar="COORDINATE", default=None,
                     help="the inputs' coordinates, one per constraint (default: a model file's actuators)")
    inv.add_argument("--t0", type=finite_time, default=0.0, help="the programmed motion rests before t0 (s, default 0)")
    inv.add_argument("--t1", type=finite_time, required=True, help="and after t1 (s)")
    inv.add_argument("--pre", type=positive_float, default=0.1, help="pre-actuation window before t0 (s, default 0.1)")
    inv.add_argument("--post", type=positive_float, default=0.1, help="post-actuation window after t1 (s, default 0.1)")
    inv.add_argument("--nodes", type=positive_int, default=200, help="initial mesh nodes of the BVP (default 200)")
    inv.add_argument("--out", type=path_argument, default=None,
                     help="results file .npz (default results/<case>_inversion.npz)")
    inv.set_defaults(func=cmd_invert)

    st = command("statics", "print the static start configuration")
    study_options(st)
    st.set_defaults(func=cmd_statics)

    pl = command("plot", "figures from results files of one model")
    pl.add_argument("results", nargs="+", type=path_argument, help="results .npz files (e.g. results/*.npz)")
    pl.add_argument("--out", type=path_argument, default="figures", help="folder for the figures (default figures/)")
    pl.add_argument("--format", type=figure_formats, default=("png",), metavar="png,pdf,svg",
                    help="figure formats, separated by commas: png (200 dpi), pdf and svg (vector); default png")
    pl.set_defaults(func=cmd_plot)

    m = command("modes", "natural frequencies and mode shapes about the static equilibrium")
    m.add_argument("model_file", nargs="?", type=path_argument,
                   help="a model description (.toml) or a folder made by 'build --out'; default: the reference "
                        "manipulator")
    m.add_argument("--nrfe", type=rfe_count, default=None,
                   help="rigid finite elements of the arm (≥ 2 to have modes; default 5, or the file's)")
    m.add_argument("--lock", choices=("joints", "constraints"), default="joints",
                   help="linearize with the joints locked, or with the programmed constraints holding")
    m.add_argument("--count", type=positive_int, default=10, help="modes to print (default 10)")
    m.add_argument("--param", type=parameter_override, action="append", metavar="NAME=VALUE",
                   help="override a parameter (repeatable); a number or an expression, e.g. --param d2=0.01")
    m.add_argument("--out", type=path_argument, default="figures",
                   help="folder for the CSV and the figure (default figures/)")
    m.set_defaults(func=cmd_modes)

    li = command("linearize", "the state-space model x' = A x + B u about the statics or at instants of a run")
    study_options(li)
    li.add_argument("--at", type=path_argument, default=None, metavar="RESULTS.npz",
                    help="instead: at saved states of this run of the model (with --times)")
    li.add_argument("--times", type=number_list, default=None, metavar="T1,T2,...",
                    help="with --at: the instants (s); each takes the saved state nearest to it")
    li.add_argument("--backend", choices=("numpy", "c"), default=None,
                    help="generated code to evaluate (default: c when a compiler is present)")
    li.add_argument("--out", type=path_argument, required=True,
                    help="lin.npz or lin.mat (MATLAB; names as cell arrays); several --times: lin_1.mat, ...")
    li.set_defaults(func=cmd_linearize)

    c = command("convergence", "discretization error against n_rfe: clamped links beside beam theory, "
                                   "or any output (--output)")
    c.add_argument("model_file", nargs="?", type=path_argument,
                   help="a model description (.toml): each of its flexible links clamped; default: the reference arm")
    c.add_argument("--nrfe", type=rfe_count, nargs="+", default=None,
                   help="n_rfe values (default 2 3 5 8 10 15 20, up to 40 takes minutes; with --output 3 5 9)")
    c.add_argument("--output", nargs="+", metavar="OUTPUT", default=None,
                   help="instead of the clamped links against beam theory: the discretization error of these "
                        "outputs of the model: points, joints, deflection, velocities, forces, or a joint or "
                        "point by name")
    c.add_argument("--t-end", type=end_time, default=0.0,
                   help="with --output: over a run of this many s (default 0: at the start, the statics)")
    c.add_argument("--dt", type=positive_float, default=1e-4, help="with --output: RK4 step in s (default 1e-4)")
    c.add_argument("--save-every", type=positive_int, default=None, help="with --output: keep every k-th step "
                                                                           "(default: the steps in 1 ms, at least 1)")
    c.add_argument("--method", type=method_name, default="rk4", metavar="{" + ",".join(METHODS) + "}",
                   help="with --output: integrator, as for simulate")
    c.add_argument("--backend", choices=("numpy", "c"), default=None,
                   help="with --output: generated code to run (default: c when a compiler is present)")
    c.add_argument("--statics", choices=("locked", "constrained", "none"), default=None,
                   help="with --output: the start, as for simulate (default at --t-end 0: locked, where the model "
                        "takes it)")
    c.add_argument("--terms", type=int, choices=(1, 2), default=1,
                   help="with --output: terms of the discretization error removed, as for simulate --extrapolate")
    c.add_argument("--workers", type=positive_int, default=None,
                   help="with --output: levels run at once, on threads or local processes as for simulate "
                        "--extrapolate (default: one per core)")
    c.add_argument("--static", choices=("linear", "nonlinear"), default="linear",
                   help="static deflection from the linear stiffness solve or full Newton–Raphson")
    c.add_argument("--param", type=parameter_override, action="append", metavar="NAME=VALUE",
                   help="override a parameter of the arm (repeatable), e.g. --param E2=2.1e11")
    c.add_argument("--directory", type=path_argument, default=None,
                   help="keep the built clamped-arm models here (default: temporary)")
    c.add_argument("--out", type=path_argument, default="figures", help="folder for convergence.png (default figures/)")
    c.set_defaults(func=cmd_convergence)

    d = command("demo", "the paper's study: rigid and flexible arms, figures")
    d.add_argument("--t-end", type=positive_float, default=10.0, help="simulated time in s (default 10)")
    d.add_argument("--results", type=path_argument, default="results", help="folder for results (default results/)")
    d.add_argument("--figures", type=path_argument, default="figures", help="folder for figures (default figures/)")
    d.set_defaults(func=cmd_demo)
    sw = command("sweep", "many runs over parameter values and rfe counts, on all cores or a Dask cluster")
    sw.add_argument("model_file", nargs="?", type=path_argument,
                    help="a model description (.toml; a folder made by 'build --out' holds no model to vary); "
                         "default: the reference manipulator")
    sw.add_argument("--nrfe", type=rfe_count, nargs="+", default=None,
                    help="rigid finite elements of the arm, one sweep of the parameters for each (default 5, or "
                         "the file's)")
    sw.add_argument("--param", type=sweep_param, action="append", metavar="NAME=SPEC",
                    help="a parameter's values: NAME=v1,v2,… or NAME=start:stop:count (every combination is run), "
                         "or NAME=low:high with --samples (repeatable)")
    sw.add_argument("--samples", type=positive_int, default=None,
                    help="draw this many points within the NAME=low:high ranges instead of a grid")
    sw.add_argument("--seed", type=int, default=0, help="seed of --samples (default 0)")
    sw.add_argument("--sampling", choices=("lhs", "random"), default="lhs",
                    help="--samples as a Latin hypercube (default) or independent uniform draws")
    sw.add_argument("--statics", choices=("locked", "constrained", "none"), default=None,
                    help="start of every run, as for simulate")
    run_options(sw)
    sw.add_argument("--out", type=path_argument, required=True,
                    help="folder of the sweep: runs/ (one results file per run), summary.csv, summary.parquet")
    sw.add_argument("--workers", type=positive_int, default=None,
                    help="local processes (default: one per core; 1 runs in this process)")
    sw.add_argument("--scheduler", type=path_argument, default=None, metavar="ADDRESS",
                    help="run on the Dask cluster of this scheduler (tcp://HOST:PORT or a scheduler file)")
    sw.set_defaults(func=cmd_sweep)
    mt = command("metrics", "tracking metrics of runs against a reference motion: constraint values, path error, "
                            "residual vibration, control effort")
    mt.add_argument("results", nargs="+", type=path_argument, help="results .npz files of simulate")
    mt.add_argument("--reference", type=path_argument, required=True, metavar="REF",
                    help="the model whose programmed constraints define the motion (a model file, a folder made "
                         "by 'build --out', or manipulator: the built-in reference arm), or a run (.npz: its "
                         "end-effector path)")
    mt.add_argument("--nrfe", type=rfe_count, default=None,
                    help="rfes of a reference model file or of the reference arm (default: the first run's)")
    mt.add_argument("--after", type=_finite_number(lambda v: v >= 0, "must be zero or more"), default=None,
                    metavar="T", help="residual vibration from T s on (default: the end of the programmed motion, "
                                      "where it is known)")
    mt.add_argument("--backend", choices=("numpy", "c"), default=None,
                    help="generated code of the reference model (default: c when a compiler is present)")
    mt.add_argument("--out", type=path_argument, default=None,
                    help="folder for metrics.csv and the figure tracking.<format> (default: print only)")
    mt.add_argument("--format", type=figure_formats, default=("png",), metavar="png,pdf,svg",
                    help="figure formats (default png)")
    mt.set_defaults(func=cmd_metrics)
    an = command("animate", "the arm moving (GIF or MP4; 2D when it stays in a plane, else 3D), or a still figure "
                            "of the deformed arm")
    an.add_argument("results", type=path_argument, help="a results .npz file of simulate or invert")
    an.add_argument("--out", type=path_argument, required=True,
                    help="arm.gif or arm.mp4 (ffmpeg); with --still a figure .png, .pdf or .svg")
    an.add_argument("--still", type=number_list, default=None, metavar="T1,T2,...",
                    help="draw the arm at these times (s), overlaid in one figure, instead of an animation")
    an.add_argument("--magnify", type=_finite_number(lambda v: v >= 0, "must be zero (the rigid arm) or more"),
                    default=1.0, metavar="K",
                    help="scale the elastic coordinates (the flexible links' sdes, not sprung joints) by K "
                         "(default 1: as computed)")
    an.add_argument("--fps", type=frame_rate, default=20.0, help="frames per second (default 20)")
    an.add_argument("--every", type=positive_int, default=None,
                    help="show every k-th saved sample (default: the step that plays the run in real time)")
    an.add_argument("--view", type=camera, default="auto", metavar="auto|3d|2d|ELEV,AZIM",
                    help="auto (default): 2D, face-on, when the arm stays in one plane over the run, else 3D; 3d; "
                         "2d (refused when the arm leaves every plane); or 3D from the camera's elevation and "
                         "azimuth in degrees (3d is 20,-60)")
    an.add_argument("--dpi", type=positive_int, default=None, help="resolution (default 100, 200 for --still)")
    an.add_argument("--bodies", choices=("skeleton", "boxes", "both"), default="skeleton",
                    help="rigid bodies as the skeleton through their frames (default), the boxes of their "
                         "inertias, or both (the boxes light)")
    an.add_argument("--model", type=path_argument, default=None,
                    help="the model file that made the results (default: the one their metadata names)")
    an.set_defaults(func=cmd_animate)
    for p in (ex, inv, pl, m, li, c, d, an, mt):  # simulate has its own
        p.add_argument("--overwrite", action="store_true",
                       help="replace the files of an earlier command at the output path (never the command's own "
                            "inputs)")
    for p in (b, s, inv, st, m, li, c, d, sw):
        p.add_argument("--no-limits", action="store_true",
                       help="start even work estimated to take more than an hour or more memory than is available")
    return parser


def main(argv=None) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        with limits.lifted() if getattr(args, "no_limits", False) else contextlib.nullcontext(), \
                _warnings_as_lines():
            return args.func(args)
    except SimulationStopped as exc:
        print(f"gpmegen {args.command}: {'' if exc.interrupted else 'error: '}{exc}", file=sys.stderr)
        return 130 if exc.interrupted else 1
    except (UsageError, RunSpecError, limits.LimitError, IncompatibleResults, OutputError) as exc:
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
        if _caused_by_interrupt(exc):
            print(f"gpmegen {args.command}: interrupted", file=sys.stderr)
            return 130
        if os.environ.get("GPMEGEN_DEBUG"):
            raise
        print(f"gpmegen {args.command}: internal error: {type(exc).__name__}: {exc} (this is a bug; rerun with "
              f"GPMEGEN_DEBUG=1 for the traceback and report it)", file=sys.stderr)
        return 1


def _caused_by_interrupt(exc: BaseException) -> bool:
    """Whether Ctrl-C or SIGTERM is behind ``exc``: an extension module whose initialization the
    interrupt stops (a command imports what it runs when it runs) reports it as an ImportError
    raised from the KeyboardInterrupt."""
    seen = set()
    while exc is not None and id(exc) not in seen:
        if isinstance(exc, KeyboardInterrupt):
            return True
        seen.add(id(exc))
        exc = exc.__cause__ or exc.__context__
    return False


def quick_exit(code: int) -> int:
    """``code``, with the objects made so far set aside from the garbage collector: the
    interpreter's collections at exit would otherwise walk SymPy's millions of them (2.8 s after a
    run's last line at load 10, 0.3 s without), and a stopped run is to end promptly."""
    gc.freeze()
    return code


if __name__ == "__main__":
    sys.exit(quick_exit(main()))
