"""gpmegen's public face in Python: what a user imports from ``gpmegen``.

- :func:`load`: a model (a model file, any :class:`~gpmegen.model.Model`, or ``"manipulator"``,
  the reference arm), built into generated code when missing or stale, opened on the C backend where a C compiler is
  found, else (or with ``backend="numpy"``) on the NumPy one;
- :func:`statics`, :func:`simulate`: a model's consistent start and its constrained motion (as
  ``gpmegen statics`` and ``gpmegen simulate``), the latter as :class:`Results`;
- :func:`load_model_file`, :func:`read_model_file`: models from TOML files (and URDF files);
  :func:`import_urdf`: a URDF with its joints' limits as data; :func:`urdf_text`: a model as URDF;
- the model's elements (:class:`Model`, :class:`Joint`, :class:`FlexibleLink`, ...) and the
  reference case (:func:`reference_model`);
- :func:`export_casadi`: the model's functions as CasADi functions, saved as ``.casadi`` files;
- :func:`export_fmu`: the model as an FMU (FMI 2.0 Model Exchange and Co-Simulation);
- :func:`linearize`: the state-space model ``ẋ = A x + B u`` about the statics or at instants of a run;
- :func:`invert`: the bounded inputs of a programmed motion's actuated realization (stable inversion);
- :func:`metrics`: tracking metrics of runs against a reference motion (a model or a run);
- :func:`sweep`: many runs over parameter values, on all local cores or a Dask cluster;
- the errors, one type per failure family (:class:`GpmegenError` and its subclasses).
"""

from __future__ import annotations

import numbers
import warnings
from collections.abc import Callable, Iterable, Mapping
from pathlib import Path
from typing import TYPE_CHECKING, Any

from . import limits  # gpmegen.limits.lifted() lifts the bounds on resources
from .analysis.export import fmu as fmu_export
from .analysis.post import results as results_io
from .analysis.run import cases, inversions, linear, loading, opening, runs, tracking
from .analysis.run.loading import checked_backend, keyword_options
from .analysis.run.loading import gravity_function as gravity_function
from .analysis.run.model_files import load_model_file, read_model_file
from .analysis.run.runs import Results
from .analysis.run.runspec import NAMES as RUN_OPTIONS
from .analysis.run.runspec import RunSpec, split_options
from .analysis.sweep import sweep
from .codegen.backends import casadi as casadi_export
from .errors import (
    BuildError,
    DerivationError,
    GpmegenError,
    ModelError,
    SimulationError,
    StaleModelError,
    StaticsError,
)
from .model import (
    Body,
    Constraint,
    Controller,
    Drive,
    FlexibleLink,
    Joint,
    Model,
    Offset,
    Parameter,
    Point,
    Signal,
    reference_model,
)
from .model.urdf import import_urdf
from .model.urdf_export import urdf_text
from .version import __version__

if TYPE_CHECKING:  # for the annotations only: nothing more is imported at run time
    from .analysis.run.cases import Case
    from .analysis.run.linear import LinearModel
    from .analysis.run.tracking import Metrics
    from .runtime.consistent import Start
    from .runtime.model import LoadedModel

#: Where a model is: None or ``"manipulator"`` (the reference manipulator), a model file or a folder
#: made by ``gpmegen build --out`` (a path), or a :class:`Model`.
ModelSource = str | Path | Model | None
#: What takes one-line messages.
Progress = Callable[[str], object]

#: Where a model is found, beside the model itself: the reference arm's rfes, the folder of builds.
_FOUND: dict[str, Any] = {"nrfe": None, "directory": None}


def load(model: ModelSource | int = None, backend: str | None = None, params: Mapping[str, float] | None = None,
         *, nrfe: int | None = None, **options: Any) -> LoadedModel:
    """The generated model ready to evaluate.

    ``model``: a :class:`gpmegen.model.Model`, a model file's path (``nrfe`` rfes in each of its
    flexible links, as ``gpmegen build FILE --nrfe N``; None: the file's own), a folder made by
    ``gpmegen build --out``, or a name of a built-in case: ``"manipulator"``, the paper's arm
    (``nrfe`` rfes, default 5; :data:`gpmegen.analysis.run.opening.NAMED`). ``backend``: "c" or
    "numpy"; None (the default) is "c" where a C compiler is found, else "numpy", said in one
    line (:func:`gpmegen.analysis.run.loading.checked_backend`). ``params`` overrides parameter
    values. The model is built into ``directory`` (an option, as the others below; default
    :func:`gpmegen.runtime.loader.default_directory`) when missing or stale, or when a file it
    uses differs from the sha256 its manifest records, unless ``build=False``, which raises
    :class:`StaleModelError` with the command to rebuild (``command``, for a model of your own).

    A model whose start sets parameters (a model file's ``[initial] set``; the paper's arm:
    ``r_Ea`` and ``y_c`` that put E of the locked statics at its joint start on the constraints)
    binds them as its runs do, unless ``params`` gives them
    (:attr:`gpmegen.analysis.run.cases.Case.start_constants`); any other model is bound with its
    parameters' defaults.

    ``progress`` (a callable taking one line) is told each step of a build and of a C compile.
    ``transforms``: the body transforms to generate, of "T", "T_i", "T_ij"
    (:meth:`LoadedModel.transforms`); ``jacobians``: with the generated derivatives of the GPME
    (:meth:`LoadedModel.acceleration_jacobians`). Both are what the model must have at least: a
    folder built with more serves as it is, and one built with less is built again with both what
    it had and what is asked (so that asking in turn never rebuilds back and forth). An option
    not among these is refused in one line.

    Deprecated: ``load()``, ``load(nrfe=N)`` and ``load(N)`` without a model load the paper's arm
    as before, with a :class:`DeprecationWarning` naming ``load("manipulator", nrfe=N)``.
    """
    if model is None or isinstance(model, int):
        nrfe = model if model is not None else (nrfe if nrfe is not None else 5)
        warnings.warn(f"gpmegen.load() without a model is deprecated; use gpmegen.load({opening.REFERENCE!r}, "
                      f"nrfe={nrfe})", DeprecationWarning, stacklevel=2)
        model = opening.REFERENCE
    chosen = keyword_options(options, loading.LOAD_OPTIONS, "load")
    if isinstance(model, Model) and nrfe is not None:
        raise TypeError(f"load(): nrfe={nrfe} applies to a model file or a built-in case's name; a gpmegen.Model "
                        f"has its rfes already (gpmegen.load_model_file(path, nrfe={nrfe}))")
    case = _case(model, nrfe)
    if isinstance(case, cases.FolderCase):
        opened = case.open(checked_backend(backend, chosen["progress"]), params, chosen["progress"] or _silent)
        return case.bound(opened, params or {})
    backend = checked_backend(backend, chosen["progress"])
    free = {k: v for k, v in (params or {}).items() if k not in case.start_constants}
    loaded = case.located(lambda: loading.load(case.model, backend, free,
                                               **{"command": case.command, **_given(chosen)}))
    return case.bound(loaded, params or {})


def _given(chosen: dict[str, Any]) -> dict[str, Any]:
    """The load options ``chosen``, without ``command`` where the caller left it None (the case's
    own build command then stands)."""
    return {k: v for k, v in chosen.items() if not (k == "command" and v is None)}


def _silent(message: str) -> None:
    """A progress sink that says nothing."""


def _case(model: ModelSource, nrfe: int | None) -> Case:
    """The case of ``model``: None (the reference manipulator with ``nrfe`` rfes, default 5), a
    built-in case's name (:data:`gpmegen.analysis.run.opening.NAMED`), a model file's path, a
    folder made by ``gpmegen build --out``, or a :class:`Model`."""
    if model is None:
        model = opening.REFERENCE
    if isinstance(model, Model):
        return cases.ModelCase(model)
    if isinstance(model, (str, Path)):
        return opening.case_of_name(model, nrfe)
    raise TypeError(f"model must be None, a path or a gpmegen.Model, got {type(model).__name__}")


def _messages(progress: Progress | None) -> Progress:
    """``progress``, or when None a sink that passes only warnings on, as Python warnings."""
    if progress is not None:
        return progress

    def warn(message: str) -> None:
        if message.startswith("warning: "):
            import warnings

            warnings.warn(message[len("warning: "):], RuntimeWarning, stacklevel=4)

    return warn


def _started(model: ModelSource, nrfe: int | None, start: str | None,
             directory: str | Path | None) -> tuple[Case, str]:
    case = _case(model, nrfe)
    if directory is not None:
        case.directory = directory
    start = start or case.starts[0]
    if start not in case.starts:
        raise ModelError(f"start {start!r}: {case.start_refusal or 'use one of ' + ', '.join(case.starts)}")
    return case, start


def statics(model: ModelSource = None, *, params: Mapping[str, float] | None = None, backend: str | None = None,
            **options: Any) -> Start:
    """The consistent start of a run, as ``gpmegen statics`` finds it: a
    :class:`gpmegen.runtime.consistent.Start` with ``model`` (loaded, its constants bound), ``q`` and
    ``qd`` (n,) on the programmed constraints at t = 0, and ``moved`` (how far they were moved
    onto them).

    ``model``: None (the reference manipulator, ``nrfe`` rfes, default 5), a model file's path, a
    folder made by ``gpmegen build --out``, or a :class:`Model`. ``start``: "locked" or
    "constrained" statics, or "none" (the default of models other than the reference case: the
    configuration as given, undeformed). ``params`` overrides parameter values. ``backend`` as
    :func:`load` (default: C where a compiler is found). ``progress`` takes one-line messages
    (default: only warnings, as Python warnings). The options ``nrfe``, ``start``, ``directory``
    and ``progress`` are keywords; another is refused in one line."""
    chosen = keyword_options(options, {**_FOUND, "start": None, "progress": None}, "statics")
    progress = chosen["progress"]
    backend = checked_backend(backend, progress)
    case, start = _started(model, chosen["nrfe"], chosen["start"], chosen["directory"])
    return case.started(backend, start, dict(params or {}), _messages(progress))


#: :func:`simulate`'s options beyond its run's (:class:`RunSpec`'s fields), with their defaults.
_SIMULATE: dict[str, Any] = {**_FOUND, "progress": None, "feedforward": None}


def simulate(model: ModelSource = None, spec: RunSpec | None = None, *, params: Mapping[str, float] | None = None,
             backend: str | None = None, **options: Any) -> Results:
    """The constrained motion from :func:`statics`'s start, as ``gpmegen simulate`` runs it, as
    :class:`Results` (nothing is written: :meth:`Results.save`). ``model``, ``params``,
    ``backend`` and the options ``nrfe``, ``directory``, ``progress`` as :func:`statics`. The run
    is ``spec`` (a :class:`RunSpec`; default all its defaults) with the fields given as keyword
    options changed: ``start``, ``t_end``, ``dt`` (s), ``save_every`` (steps; default: those in
    1 ms, whatever the method, :func:`gpmegen.runtime.integrators.loop.default_save_every`), ``method``
    ("rk4"; on the C backend "genalpha", implicit with step ``dt`` and damping ``rho_inf``,
    "dop853", adaptive, or "radau", implicit and adaptive; "scipy-radau"), ``save_dt`` (s, the
    save interval, default ``dt·save_every``), ``rtol``, ``atol`` (adaptive methods),
    ``repartition``, ``actuated``, ``internal_dynamics``, ``max_violation``, checked by
    :class:`RunSpec` in one line each. ``feedforward``: a results file of an actuated
    realization (or a stable inversion) whose inputs ``u`` are added to the drives of the model's
    coordinates of the same names, read as table signals (:mod:`gpmegen.analysis.post.feedforward`;
    ``model`` a model file or a :class:`Model`). An option that is neither is refused in one line
    with the valid ones. A run that stops early (diverges) is returned with its ``status``
    saying why."""
    spec, chosen = split_options(spec, options, _SIMULATE, lambda names: (
        f"simulate() got an unknown option {names}; its options are {', '.join((*RUN_OPTIONS, *_SIMULATE))}"))
    progress = chosen["progress"]
    backend = checked_backend(backend, progress)
    case, start = _started(model, chosen["nrfe"], spec.start, chosen["directory"])
    if chosen["feedforward"] is not None:
        case = case.feed_forward(chosen["feedforward"])
    done = runs.run(case, spec.with_start(start), backend, dict(params or {}), None, _messages(progress))
    return runs.Results(done.results)


def export_casadi(folder: str | Path, model: ModelSource = None, *, nrfe: int | None = None,
                  inputs: Iterable[str] = (), overwrite: bool = False) -> dict[str, Any]:
    """The model's functions as CasADi functions, as ``gpmegen export --format casadi`` writes them
    into ``folder`` (:mod:`gpmegen.codegen.backends.casadi`): ``qdd(t, q, qd, u, p)``, ``M(q, p)``,
    ``f(t, q, qd, u, p)``, ``Phi``, ``Phi_rate``, ``D``, ``gamma`` ``(t, q, qd, p)``, ``points(q, p)``,
    ``energies(q, qd, p)``, by name; ``u`` holds a generalized force on each coordinate of
    ``inputs``. ``model``, ``nrfe`` as :func:`statics`; ``overwrite`` replaces an earlier export.
    Needs the casadi package (``pip install 'gpmegen[casadi]'``)."""
    casadi_export.require_casadi()
    case = _case(model, nrfe)
    return case.located(lambda: casadi_export.export(case.model, folder, tuple(inputs), overwrite=overwrite))


def export_fmu(out: str | Path, model: ModelSource = None, *, inputs: Iterable[str] = (), overwrite: bool = False,
               **options: Any) -> Path:
    """The model as an FMU (FMI 2.0, Model Exchange and Co-Simulation in one archive), as
    ``gpmegen export --format fmu`` writes it into the file ``out`` (``NAME.fmu``;
    :mod:`gpmegen.analysis.export.fmu`): its states q and q̇, the GPME's q̈, the points, the
    multipliers λ and the constraints' values as outputs, the parameters (tunable) and an input
    ``u_<coordinate>`` (a generalized force) on each coordinate of ``inputs``; its start values are
    :func:`statics`'s start (``start`` as there) and the run's parameter values. ``model``, and
    the keyword options ``start``, ``nrfe``, ``directory``, ``progress``, as :func:`statics`;
    ``overwrite`` replaces an earlier FMU. Needs a C compiler. Returns the FMU's path."""
    chosen = keyword_options(options, {**_FOUND, "start": None, "progress": None}, "export_fmu")
    case, start = _started(model, chosen["nrfe"], chosen["start"], chosen["directory"])
    return case.located(lambda: fmu_export.export(case, out, tuple(inputs), overwrite, start,
                                                  _messages(chosen["progress"])))


def linearize(model: ModelSource = None, *, params: Mapping[str, float] | None = None, backend: str | None = None,
              at: str | Path | None = None, **options: Any) -> LinearModel | list[LinearModel]:
    """The linear model ``ẋ = A x + B u`` (:class:`gpmegen.analysis.run.linear.LinearModel`), as
    ``gpmegen linearize`` makes it: about :func:`statics`'s start (arguments as there), or with
    ``at`` (a results file of this model) and ``times`` (s), a list of them, one at the saved
    state nearest each time. The model is loaded with its Jacobians (built when missing).
    ``inputs``: the coordinates that take a generalized force (default: those the model drives,
    and a model file's actuators). ``nrfe``, ``start``, ``directory``, ``progress``, ``times``
    and ``inputs`` are keyword options; another is refused in one line."""
    chosen = keyword_options(options, {**_FOUND, "start": None, "progress": None, "times": None, "inputs": None},
                      "linearize")
    progress, times, inputs = chosen["progress"], chosen["times"], chosen["inputs"]
    backend = checked_backend(backend, progress)
    case, start = _started(model, chosen["nrfe"], chosen["start"], chosen["directory"])
    if not isinstance(case, cases.FolderCase):  # refused before a build (a folder's model is refused once open)
        constraints = case.model.constraints
        linear.refuse_velocity_constraints([c.name for c in constraints], [c.order for c in constraints])
    case.jacobians = True
    messages = _messages(progress)
    if inputs is None:
        inputs = linear.default_inputs(case)
    if at is None:
        begun = case.started(backend, start, dict(params or {}), messages)
        where = "start as given (no statics)" if start == "none" else f"{start} statics"
        return linear.linearize(begun.model, 0.0, begun.q, begun.qd, inputs, where=where)
    if params:
        raise ModelError("at a run the run's parameter values are used; leave params (--param) out")
    loaded = case.load(backend, {}, messages)
    return linear.along_run(loaded, at, times, inputs)


def invert(model: ModelSource = None, *, t1: float, t0: float = 0.0, pre: float = 0.1, post: float = 0.1,
           params: Mapping[str, float] | None = None, **options: Any) -> Results:
    """The bounded inputs ``u`` of the model's actuated realization that move it along its
    programmed motion, at rest before ``t0`` and after ``t1`` (s), found by stable inversion as
    ``gpmegen invert`` finds them (NumPy backend): :class:`Results` on ``[t0 - pre, t1 + post]``
    with ``u`` (k, a) on ``actuators`` (a,), ``q``, ``qd`` and the driving functions; nothing is
    written (:meth:`Results.save`). The inputs may start before ``t0`` (pre-actuation, within
    ``pre`` s) and end after ``t1`` (within ``post`` s): the internal dynamics of a non-minimum
    phase motion. ``model``, ``params`` and the options ``nrfe``, ``directory``, ``start`` and
    ``progress`` as :func:`statics`; ``actuated``: the inputs' coordinates, one per constraint
    (default: a model file's actuators); ``nodes``: the boundary-value problem's first mesh
    (default 200). An option that is none of these is refused in one line."""
    chosen = keyword_options(options, {**_FOUND, "start": None, "progress": None, "actuated": None, "nodes": 200},
                             "invert")
    window = inversions.Window(t1=t1, t0=t0, pre=pre, post=post)
    nodes = chosen["nodes"]
    if isinstance(nodes, bool) or not isinstance(nodes, numbers.Integral) or nodes < 2:
        raise ModelError(f"invert(): nodes = {nodes!r}; give a whole number of mesh nodes, 2 or more")
    case, start = _started(model, chosen["nrfe"], chosen["start"], chosen["directory"])
    actuated = chosen["actuated"]
    if actuated is not None:   # one coordinate's name, or several
        actuated = [actuated] if isinstance(actuated, str) else list(actuated)
    res, _ = inversions.invert(case, start, window, int(nodes), dict(params or {}), actuated,
                               _messages(chosen["progress"]))
    return runs.Results(res)


def metrics(runs: str | Path | Results | Iterable[str | Path | Results], reference: ModelSource = None, *,
            after: float | None = None, backend: str | None = None, nrfe: int | None = None,
            progress: Progress | None = None) -> list[Metrics]:
    """Tracking metrics of ``runs`` (results files or :class:`Results`) against ``reference``, as
    ``gpmegen metrics`` prints them: a list of :class:`gpmegen.analysis.run.tracking.Metrics`, one per
    run (constraint values, path error, residual vibration, effort; see
    :mod:`gpmegen.analysis.run.tracking`). ``reference``: a results file (.npz: its end-effector path),
    a :class:`Model`, a model file or a folder made by ``gpmegen build --out`` (its constraint
    functions and its ideal run; a file with ``nrfe`` rfes, default the first run's), or None (the
    reference manipulator).
    ``after`` (s): where the residual vibration starts (default: the end of the programmed
    motion, where it is known). ``backend`` and ``progress`` as :func:`statics`."""
    runs = [runs] if isinstance(runs, (str, Path, Results)) else list(runs)
    if not runs:
        raise ModelError("metrics of no runs: give one results file or more")
    names = [str(r) if isinstance(r, (str, Path)) else f"run {k + 1}" for k, r in enumerate(runs)]
    data = [r.arrays if isinstance(r, Results) else results_io.load(r) for r in runs]
    progress = _messages(progress)
    ref = tracking.reference_of(reference, data, checked_backend(backend, progress), progress, nrfe)
    return [tracking.measure(run, ref, name, after) for run, name in zip(data, names)]


__all__ = [
    "load", "statics", "simulate", "Results", "load_model_file", "read_model_file", "reference_model",
    "Model", "Parameter", "Joint", "Offset", "Body", "Point", "FlexibleLink", "Drive", "Signal",
    "Controller", "Constraint",
    "GpmegenError", "ModelError", "DerivationError", "BuildError", "StaleModelError", "StaticsError",
    "SimulationError", "limits", "__version__", "sweep",
    "import_urdf", "urdf_text", "linearize", "invert", "metrics", "export_casadi", "export_fmu", "RunSpec",
]
