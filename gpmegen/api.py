"""gpmegen's public face in Python: what a user imports from ``gpmegen``.

- :func:`load`: a model (the reference manipulator, or any :class:`~gpmegen.model.Model`), built
  into generated code when missing or stale, opened on the NumPy or the C backend;
- :func:`load_model_file`, :func:`read_model_file`: models from TOML files;
- the model's elements (:class:`Model`, :class:`Joint`, :class:`FlexibleLink`, ...) and the
  reference case (:func:`reference_model`);
- the errors, one type per failure family (:class:`GpmegenError` and its subclasses).
"""

from __future__ import annotations

from pathlib import Path

from . import limits  # gpmegen.limits.lifted() lifts the bounds on resources
from .codegen.render import build as build_model
from .codegen.render import input_hash
from .errors import (
    BuildError,
    DerivationError,
    GpmegenError,
    ModelError,
    SimulationError,
    StaleModelError,
    StaticsError,
)
from .folder import BACKEND_FILES, read_manifest, recover_folder, stale_reason
from .model import (
    Body,
    Constraint,
    Drive,
    FlexibleLink,
    Joint,
    Model,
    Offset,
    Parameter,
    Point,
    reference_model,
)
from .model.requirements import requirements
from .model.rfem import check_nrfe
from .model.toml_file import load_model_file, read_model_file
from .runtime.loader import BACKENDS, check_backend, default_directory, open_folder
from .version import __version__


def load(nrfe: int = 5, backend: str = "numpy", params: dict | None = None, *, model=None,
         directory=None, build: bool = True, progress=None, command=None):
    """The generated model ready to evaluate.

    ``model``: a :class:`gpmegen.model.Model` (default: the reference manipulator with ``nrfe``
    rfes). ``params`` overrides parameter values. The model is built into ``directory`` (default
    :func:`gpmegen.runtime.loader.default_directory`) when missing or stale, or when a file it
    uses differs from the sha256 its manifest records, unless ``build=False``, which raises
    :class:`StaleModelError` with the command to rebuild (``command``, for a model of your own).
    ``progress`` (a callable taking one line) is told each step of a build and of a C compile.
    """
    check_backend(backend)
    if model is None:
        model = reference_model(check_nrfe(nrfe, "the reference arm"))
        command = f"gpmegen build --nrfe {nrfe}"
    directory = Path(directory) if directory is not None else default_directory()
    folder = directory / model.name
    recover_folder(folder)
    rebuild = command or "gpmegen build"
    digest = input_hash(model, BACKENDS)
    used = BACKEND_FILES["numpy"] + (BACKEND_FILES["c"] if backend == "c" else ())
    reason = stale_reason(folder, read_manifest(folder), digest, used)
    if reason is not None:
        if not build:
            raise StaleModelError(f"{reason}; rebuild it with '{rebuild} --force'")
        build_model(model, directory, BACKENDS, progress=progress, command=command, digest=digest)
    return open_folder(folder, backend, params, digest=digest, rebuild=rebuild, requirements=requirements(model),
                       progress=progress)


__all__ = [
    "load", "load_model_file", "read_model_file", "reference_model",
    "Model", "Parameter", "Joint", "Offset", "Body", "Point", "FlexibleLink", "Drive", "Constraint",
    "GpmegenError", "ModelError", "DerivationError", "BuildError", "StaleModelError", "StaticsError",
    "SimulationError", "limits", "__version__",
]
