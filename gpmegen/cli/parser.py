"""The command line's argparse parser: every command, its options and the function that runs it."""
from __future__ import annotations

import argparse
import difflib
import re

from ..analysis.run.runspec import integrator_options
from ..runtime import integrators
from ..runtime.integrators.registry import spoken
from .build import cmd_build, cmd_export
from .figures import cmd_animate, cmd_plot
from .runs import cmd_demo, cmd_invert, cmd_simulate, cmd_statics, cmd_sweep
from .studies import cmd_convergence, cmd_linearize, cmd_metrics, cmd_modes
from .types import (
    camera,
    end_time,
    figure_formats,
    finite_number,
    finite_time,
    frame_rate,
    input_names,
    method_name,
    number_list,
    parameter_override,
    path_argument,
    positive_float,
    positive_int,
    rfe_count,
    sweep_param,
    transform_kinds,
    unit_interval,
)


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


#: The command line's parser of each kind of integrator option (an Option's ``kind``).
OPTION_KINDS = {"positive": positive_float, "fraction": unit_interval}


def build_parser() -> argparse.ArgumentParser:
    from ..help_pages import DESCRIPTIONS, EPILOGS
    from ..version import __version__

    parser = Parser(
        prog="gpmegen",
        description="Reference dynamics models (GPME) of manipulators with flexible links, as generated code.",
        epilog="gpmegen COMMAND --help describes a command, with examples and the files it writes. Exit status: 0 "
               "done, 1 failure, 2 usage or model error, 130 interrupted.",
    )
    parser.add_argument("--version", action="version", version=f"gpmegen {__version__}")
    methods = "{" + ",".join(integrators.names()) + "}"
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
        p.add_argument("--method", type=method_name, default="rk4", metavar=methods,
                       help="integrator, in any case: "
                            + spoken([integrators.get(name).summary for name in integrators.names()]))
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
    for option in integrator_options():  # the integrators' own: --rtol, --atol, --rho-inf
        s.add_argument(option.flag, type=OPTION_KINDS[option.kind], default=None, help=option.help)
    s.add_argument("--out", type=path_argument, default=None,
                   help="results file .npz (default results/<run_nrfe<N> or the file's name>_<start>_<method>.npz)")
    s.add_argument("--overwrite", action="store_true", help="replace the results of an earlier run at --out")
    s.add_argument("--actuated", nargs="+", metavar="COORDINATE", default=None,
                   help="realize the programmed constraints by inputs on these coordinates alone, one per "
                        "constraint (e.g. --actuated psi2 x3), instead of ideally; default: a model file's "
                        "actuators (--actuated none: ideally), else none; --method rk4 integrates it in the compiled "
                        "loop on the C backend (in Python on the NumPy one), dop853 in the compiled loop, radau and "
                        "genalpha refuse it")
    s.add_argument("--feedforward", type=path_argument, default=None, metavar="RUN.npz",
                   help="add the inputs u of an actuated run (simulate --actuated, or invert) to the drives of the "
                        "model's coordinates of the same names, interpolated linearly in t")
    s.add_argument("--controller-model", type=path_argument, default=None, metavar="FILE",
                   help="the model file of the computed-torque law's controller model, in place of the one the "
                        "plant's [controller] table names (its nrfe kept)")
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
    pl.add_argument("--reference", type=path_argument, default=None, metavar="REF",
                    help="also measure the runs against REF as 'gpmegen metrics --reference' does (a model file, a "
                         "folder made by 'build --out', manipulator, or a run .npz): the path-error figure and "
                         "metrics.csv and metrics.md beside the figures")
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
    c.add_argument("--method", type=method_name, default="rk4", metavar=methods,
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
    mt.add_argument("--after", type=finite_number(lambda v: v >= 0, "must be zero or more"), default=None,
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
    an.add_argument("--magnify", type=finite_number(lambda v: v >= 0, "must be zero (the rigid arm) or more"),
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
