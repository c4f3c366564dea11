"""What a command runs: a *case*, a model with its scenario (how it is loaded and started, how its
runs are labelled and shown). The paper's manipulator is one case
(:class:`gpmegen.analysis.run.reference_case.ReferenceCase`), a model file another (:class:`FileCase`);
generic code asks the case instead of testing model or coordinate names.
"""

from __future__ import annotations

from functools import cached_property
from pathlib import Path
from typing import TYPE_CHECKING

from ...errors import BuildError, DerivationError, ModelError
from ...folder import read_start, write_start
from ...model.chain import Joint
from ...model.size import coordinate_count
from ...runtime.loader import open_folder
from ...symbolic.forces import check_apart
from ..post import feedforward, law_references
from . import loading, recorded_start, set_at_start, study
from .model_files import read_model_file

if TYPE_CHECKING:
    from ...model import Model


class Case:
    """A model and its scenario. Subclasses give ``model`` (the symbolic Model), ``command`` (the
    build command that makes it), ``label`` (for progress and summaries), ``name`` (in file
    names), ``results_stem`` (the
    default results name), ``starts`` (the starts it accepts, the default first) and
    :meth:`start` (returning a :class:`gpmegen.runtime.consistent.Start`)."""

    starts: tuple = ()
    actuators: tuple = ()  # coordinates whose inputs realize the constraints by default (none: ideally)
    start_refusal = ""  # why a start not in ``starts`` is refused, and what to use instead
    model: Model  # each subclass gives it (a property)
    label: str
    command: str | None  # the build command that makes the model (None: made in Python)

    def located(self, action):
        """Run ``action()``; subclasses add where in their source a derivation error comes from."""
        return action()

    def controlled_by(self, path):
        """This case with another controller model: a model file's only (:class:`FileCase`)."""
        raise ModelError(f"{self.label}: --controller-model replaces the controller model of a model file's "
                         f"[controller] table; give the plant's model file")

    def feed_forward(self, run):
        """This case driven by the inputs of the run at ``run``: a model of the user's only
        (:class:`ModelCase`), whose drives can be rewritten."""
        raise ModelError(f"{self.label}: feedforward drives a model file or a gpmegen.Model (its drives are "
                         f"rewritten); give the plant's model file")

    @property
    def source(self):
        """The symbolic model where the case has it (None: a built folder's code alone)."""
        return self.model

    @property
    def declared(self):
        """The parameters the start sets (:class:`gpmegen.model.start_constants.StartConstants`,
        a model file's ``[initial] set``), or None."""
        return getattr(self.source, "start_constants", None)

    @property
    def start_constants(self) -> tuple[str, ...]:
        """The names of the parameters the start sets from the model itself (so per n_rfe)."""
        return self.declared.names if self.declared is not None else ()

    directory: str | Path | None = None  # where generated models live (None: gpmegen.runtime.loader.default_directory)
    jacobians = False  # load the model with the generated derivatives of the GPME (gpmegen build --jacobians)

    def load(self, backend, params, progress):
        """The generated model on ``backend`` ("c" falls back to "numpy" when it cannot be built);
        ``progress`` is told the model's folder."""
        model = None
        if backend == "c":
            try:
                model = self.open("c", params, progress)
            except BuildError as exc:
                progress(f"C backend unavailable ({exc}); using the NumPy backend")
        if model is None:
            model = self.open("numpy", params, progress)
        progress(f"model folder: {model.folder}")
        return model

    def open(self, backend, params, progress):
        """The generated model on ``backend``, built first where missing or stale."""
        return self.located(lambda: loading.load(self.model, backend, params, progress=progress,
                                                 command=self.command, directory=self.directory,
                                                 jacobians=self.jacobians))

    def started(self, backend, start, overrides, progress):
        """:meth:`start`, with its report and, when the start was off the constraints, its
        warning told to ``progress``."""
        begun = self.start(backend, start, overrides, progress)
        progress(begun.report())
        if begun.warning():
            progress(begun.warning())
        return begun

    def shown(self, model) -> list[str]:
        """The coordinates a run's start and end lines show: the first three."""
        return list(model.coordinates[:3])

    def start_note(self, model) -> str:
        """What the start line adds after the shown coordinates: the parameters set at the start."""
        return "; " + self._described(model, ".6g") if self.declared is not None else ""

    def constants(self, model) -> str:
        """The parameters the start sets, as ``gpmegen statics`` prints them."""
        return self._described(model, ".9f") if self.declared is not None else ""

    def _described(self, model, form) -> str:
        units = {p.name: p.unit for p in self.source.parameters} if self.source is not None else {}
        return set_at_start.described(self.declared, model, units, form)

    def metadata(self, model) -> dict:
        """What plots need beyond the results' generic metadata (see :func:`results.metadata`):
        ``label`` and those listed in :func:`gpmegen.analysis.post.results.metadata`. By default the
        model's name, and its first four joints (not the sde rotations of its flexible links);
        what the model's presentation gives (:class:`gpmegen.model.presentation.Presentation`, a
        model file's ``[presentation]``) in their place and beside them."""
        joints = [element.name for element in self.model.chain if isinstance(element, Joint)]
        shown = self.presentation.metadata() if self.presentation is not None else {}
        return {"label": model.module.MODEL, "joints": joints[:4], **shown}

    @property
    def presentation(self):
        """How the model's runs are shown (:class:`gpmegen.model.presentation.Presentation`), or None."""
        return getattr(self.source, "presentation", None)

    def bound(self, loaded, params, locked=True):
        """The ``loaded`` model with the parameters the start sets (:attr:`declared`) bound as its
        runs bind them, those of ``params`` (the user's values) kept: what :func:`gpmegen.load`
        returns. ``locked`` False: taken at the start configuration itself (a run without
        statics). As loaded where the start sets none."""
        return set_at_start.bind(self.declared, loaded, params, locked)[0] if self.declared is not None else loaded

    def extras(self, model, results) -> dict:
        """Arrays added to a run's results: the prescribed coordinate of the presentation, if
        any (``prescribed``, m, one per saved time), at the parameter values of the run."""
        prescribed = self.presentation.prescribed if self.presentation is not None else None
        if prescribed is None:
            return {}
        return {"prescribed": law_references.along([prescribed.value], self.source, model, results["t"])[:, 0]}

    def joint_limits(self) -> dict:
        """Coordinate -> (lower, upper, velocity, unit) limits a run is checked against after
        it ends (:mod:`gpmegen.analysis.post.joint_limits`); none by default."""
        return {}

    def locator(self) -> dict | None:
        """Where a results file finds this case again (its ``model_source`` metadata, read by
        :func:`case_of_source`); None: a model made in Python, which no file holds."""
        return None

    def record_start(self, folder) -> None:
        """Keep in the built ``folder`` what a run from the folder alone needs to start as this
        case does (nothing by default)."""

    def size(self) -> tuple[int, int]:
        """(coordinates, constraints) of the model, known before it is derived or loaded."""
        return coordinate_count(self.model), len(self.model.constraints)


class ModelCase(Case):
    """A :class:`~gpmegen.model.Model` of the user's own, started at rest and undeformed at
    q = 0 (a model file adds its ``[initial]``: :class:`FileCase`)."""

    starts = ("none", "locked", "constrained")
    start_refusal = "a model of your own starts with --statics none, locked or constrained"
    feedforward = None  # a results file whose inputs u drive the model (feed_forward)

    def __init__(self, model=None):
        self._model = model

    @property
    def model(self):
        return self.fed(self._model)

    def feed_forward(self, run) -> ModelCase:
        """This case with the inputs ``u`` of the run at ``run`` (a results file) added to its
        drives (:mod:`gpmegen.analysis.post.feedforward`), checked now."""
        self.feedforward = run
        self.__dict__.pop("_fed", None)
        _ = self.model  # the run read and matched to the coordinates now, not at the start
        return self

    def fed(self, model):
        """``model`` with the feedforward's inputs, made once."""
        if self.feedforward is None:
            return model
        if "_fed" not in self.__dict__:
            self.__dict__["_fed"] = feedforward.model(model, self.feedforward)
        return self.__dict__["_fed"]

    @property
    def command(self) -> str | None:
        return None  # built from Python: gpmegen.load names "gpmegen build" as the fix

    @property
    def label(self) -> str:
        return self.model.name

    @property
    def name(self) -> str:
        """The case in file names (e.g. ``modes_<name>_joints.csv``)."""
        return self.label

    @property
    def results_stem(self) -> str:
        return self.name

    def initial(self, params) -> tuple[dict, dict]:
        """The start configuration and velocities before they are made consistent: coordinate
        name -> value (rad, m; rad/s, m/s) at the parameter values ``params``: at rest, at the
        configuration the start's parameters are set at (:attr:`declared`), else at q = 0."""
        if self.declared is None:
            return {}, {}
        return self.declared.configuration({p.symbol: params.get(p.name, p.default) for p in self.model.parameters}), {}

    def metadata(self, model) -> dict:
        """As :meth:`Case.metadata`, and the results file fed forward (``feedforward``), if any."""
        meta = super().metadata(model)
        if self.feedforward is not None:
            meta["feedforward"] = str(Path(self.feedforward).resolve())
        return meta

    def start(self, backend, start, overrides, progress):
        """The loaded model's consistent start (:class:`gpmegen.runtime.consistent.Start`) from
        :meth:`initial` (see :func:`gpmegen.analysis.run.study.file_start`)."""
        model = self.load(backend, overrides, progress)
        progress(f"start of {self.label} ({'no statics' if start == 'none' else start + ' statics'})")
        if self.declared is not None:   # its [initial] set, at [initial] q (its locked statics unless none)
            model = self.bound(model, overrides, locked=start != "none")
        q, qd = self.initial(model.params)
        return study.file_start(model, q, start, qd, closures=self.closure_rows())

    def closure_rows(self) -> dict:
        """Each closure's name -> the names of its constraint rows, for the start's messages."""
        return {c.name: [c.row_name(label) for label in c.rows] for c in self.model.closures}


class FileCase(ModelCase):
    """A model file (``path``) with ``nrfe`` rfes (None: the file's own); the file is read once,
    when first needed."""

    controller_model = None  # a model file in place of the file's [controller] model (controlled_by)

    def __init__(self, path, nrfe=None):
        self.path, self.nrfe = path, nrfe

    @cached_property
    def file(self):
        file = read_model_file(self.path, nrfe=self.nrfe, controller_model=self.controller_model)
        try:   # from the derived kinematics, which the model layer that reads the file cannot see
            check_apart(file.model)
        except DerivationError as exc:
            raise file.locate(exc) from None
        return file

    def controlled_by(self, path) -> FileCase:
        """This case with the model file at ``path`` as its computed-torque law's controller
        model, read now."""
        self.controller_model = path
        self.__dict__.pop("file", None)
        _ = self.file
        return self

    @property
    def model(self):
        return self.fed(self.file.model)

    @property
    def command(self) -> str:
        return f"gpmegen build {self.path}" + (f" --nrfe {self.nrfe}" if self.nrfe is not None else "")

    @property
    def label(self) -> str:
        return Path(self.path).stem + ("_ff" if self.feedforward is not None else "")

    @property
    def actuators(self) -> tuple:
        return self.file.actuators

    def located(self, action):
        """Run ``action()``; a derivation error gets the file and line it comes from (from the
        text read once, never a second read of the file)."""
        try:
            return action()
        except DerivationError as exc:
            raise self.file.locate(exc) from None

    def initial(self, params) -> tuple[dict, dict]:
        """The file's ``[initial] q`` and ``qd``."""
        return self.file.initial_values(params), self.file.initial_velocities(params)

    def joint_limits(self) -> dict:
        """The limits of the URDF the file names (none without one)."""
        return self.file.limits

    def locator(self) -> dict:
        return {"file": str(Path(self.path).resolve()), "nrfe": self.nrfe}

    def record_start(self, folder) -> None:
        """The file's ``[initial]`` at the parameter defaults, and the parameters its start sets as
        the file gives them, for :class:`FolderCase`."""
        write_start(folder, *self.initial(None), self.file.start_text)


class FolderCase(ModelCase):
    """A model built by ``gpmegen build --out`` and opened from its ``folder`` (the files its
    manifest records), without its source: it starts from the model file's ``[initial]`` at the
    parameter defaults that the build recorded (:func:`gpmegen.folder.read_start`; at rest at
    q = 0 without one), with the parameters the file's start sets bound as the file's runs bind
    them (:mod:`gpmegen.analysis.run.recorded_start`), and parameter values are not checked
    against the model's physical bounds (those live in the source)."""

    def __init__(self, folder, manifest):
        self.folder, self.manifest = Path(folder), manifest

    @cached_property
    def declared(self):
        """The parameters the start sets, as the build recorded them (None: none)."""
        return recorded_start.declared(self.folder, self.manifest)

    @property
    def model(self):
        raise ModelError(f"{self.folder} holds generated code, not its model; give the model file instead")

    source = None

    def closure_rows(self) -> dict:
        """None known: the closures live in the model file, which a folder does not hold (its rows
        are constraints like the others)."""
        return {}

    @property
    def command(self) -> str:
        return f"gpmegen build <its model file> --out {self.folder.parent}"

    @property
    def label(self) -> str:
        return self.manifest["model"]

    def open(self, backend, params, progress):
        """The folder's generated model on ``backend``, as its manifest records it (never rebuilt)."""
        return open_folder(self.folder, backend, params, rebuild=self.command, progress=progress)

    def size(self) -> tuple[int, int]:
        return int(self.manifest["n_dof"]), len(self.manifest["constraints"])

    def locator(self) -> dict:
        return {"folder": str(self.folder.resolve())}

    def initial(self, params) -> tuple[dict, dict]:
        return read_start(self.folder)

    def metadata(self, model) -> dict:
        """The model's name, and its first four coordinates as the joints of the figures (the
        folder does not say which coordinates are joints)."""
        return {"label": self.label, "joints": list(model.coordinates[:4])}
