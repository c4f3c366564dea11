"""What a command runs: a *case*, a model with its scenario (how it is loaded and started, how its
runs are labelled and shown). The paper's manipulator is one case
(:class:`gpmegen.analysis.reference_case.ReferenceCase`), a model file another (:class:`FileCase`);
generic code asks the case instead of testing model or coordinate names.
"""

from __future__ import annotations

from functools import cached_property
from pathlib import Path

from ..errors import BuildError, DerivationError


class Case:
    """A model and its scenario. Subclasses give ``model`` (the symbolic Model), ``command`` (the
    build command that makes it), ``label`` (for progress and summaries), ``results_stem`` (the
    default results name), ``starts`` (the starts it accepts, the default first) and
    :meth:`start`."""

    starts: tuple = ()
    start_refusal = ""  # why a start not in ``starts`` is refused, and what to use instead

    def located(self, action):
        """Run ``action()``; subclasses add where in their source a derivation error comes from."""
        return action()

    def load(self, backend, params, progress):
        """The generated model on ``backend`` ("c" falls back to "numpy" when it cannot be built)."""
        import gpmegen

        def load(name):
            return self.located(lambda: gpmegen.load(backend=name, params=params, progress=progress,
                                                     model=self.model, command=self.command))

        if backend == "c":
            try:
                return load("c")
            except BuildError as exc:
                progress(f"C backend unavailable ({exc}); using the NumPy backend")
        return load("numpy")

    def shown(self, model) -> list[str]:
        """The coordinates a run's start and end lines show: the first three."""
        return list(model.coordinates[:3])

    def start_note(self, model) -> str:
        """What the start line adds after the shown coordinates (e.g. constants set at the start)."""
        return ""

    def constants(self, model) -> str:
        """The constants the scenario sets at the start, as ``gpmegen statics`` prints them."""
        return ""

    def metadata(self, model) -> dict:
        """What plots need beyond the results' generic metadata (see :func:`results.metadata`):
        ``label`` and those listed in :func:`gpmegen.analysis.results.metadata`. By default the
        model's name, and its first four joints (not the sde rotations of its flexible links)."""
        from ..model.chain import Joint

        joints = [element.name for element in self.model.chain if isinstance(element, Joint)]
        return {"label": model.module.MODEL, "joints": joints[:4]}

    def extras(self, model, results) -> dict:
        """Arrays added to a run's results (none by default)."""
        return {}


class FileCase(Case):
    """A model file (``path``) with ``nrfe`` rfes (None: the file's own); the file is read once,
    when first needed."""

    starts = ("initial", "locked", "constrained")

    def __init__(self, path, nrfe=None):
        self.path, self.nrfe = path, nrfe

    @cached_property
    def file(self):
        from ..model.toml_file import read_model_file

        return read_model_file(self.path, nrfe=self.nrfe)

    @property
    def model(self):
        return self.file.model

    @property
    def command(self) -> str:
        return f"gpmegen build {self.path}" + (f" --nrfe {self.nrfe}" if self.nrfe is not None else "")

    @property
    def label(self) -> str:
        return Path(self.path).stem

    results_stem = label

    def located(self, action):
        """Run ``action()``; a derivation error gets the file and line it comes from (from the
        text read once, never a second read of the file)."""
        try:
            return action()
        except DerivationError as exc:
            raise self.file.locate(exc) from None

    def start(self, backend, start, overrides, progress):
        """The loaded model and q0: the file's ``[initial]`` configuration (see
        :func:`gpmegen.analysis.study.file_start`)."""
        from . import study

        model = self.load(backend, overrides, progress)
        initial = self.file.initial_values(model.params)
        progress(f"start of {self.path} ({start})")
        return study.file_start(model, initial, start)


def case_for(model_file, nrfe) -> Case:
    """The case a command runs: a model file with ``nrfe`` rfes (None: its own), or the
    reference manipulator (default 5 rfes)."""
    if model_file:
        return FileCase(model_file, nrfe)
    from .reference_case import ReferenceCase

    return ReferenceCase(nrfe or 5)
