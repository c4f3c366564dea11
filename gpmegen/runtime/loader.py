"""Finding, building when needed, and importing generated models."""

from __future__ import annotations

import importlib.util
import os
import sys
from pathlib import Path

from ..errors import BuildError, ModelError, StaleModelError

REPO_GENERATED = Path(__file__).resolve().parents[2] / "generated"


def default_directory() -> Path:
    """Where generated models live: ``$GPMEGEN_GENERATED``, else the repository's
    ``generated/`` (a source checkout), else ``~/.cache/gpmegen/generated``."""
    env = os.environ.get("GPMEGEN_GENERATED")
    if env:
        return Path(env)
    if REPO_GENERATED.is_dir():
        return REPO_GENERATED
    cache = Path(os.environ.get("XDG_CACHE_HOME", Path.home() / ".cache"))
    return cache / "gpmegen" / "generated"


def import_numpy_module(folder: Path):
    """Import ``folder/model_numpy.py`` under a name unique to its folder."""
    path = Path(folder) / "model_numpy.py"
    name = f"gpmegen_generated_{Path(folder).name}_{abs(hash(str(path.resolve())))}"
    spec = importlib.util.spec_from_file_location(name, path)
    if spec is None or spec.loader is None:
        raise BuildError(f"cannot import {path}")
    module = importlib.util.module_from_spec(spec)
    try:
        spec.loader.exec_module(module)
    except Exception as exc:  # a damaged or hand-edited module: whatever it raises, rebuilding is the fix
        raise BuildError(f"{path} cannot be imported ({type(exc).__name__}: {exc}); rebuild it with "
                         f"'gpmegen build --force'") from None
    sys.modules.setdefault(name, module)
    return module


def _check_nrfe(nrfe):
    if isinstance(nrfe, bool) or not isinstance(nrfe, int) or nrfe < 1:
        raise ModelError(f"nrfe must be a whole number ≥ 1 (1 is the rigid arm), got {nrfe!r}")


def load(nrfe: int = 5, backend: str = "numpy", params: dict | None = None, *, model=None,
         directory=None, build: bool = True, progress=None, command=None):
    """The generated model ready to evaluate.

    ``model``: a :class:`gpmegen.model.Model` (default: the reference manipulator with ``nrfe``
    rfes). ``params`` overrides parameter values. The model is built into ``directory`` (default
    :func:`default_directory`) when missing or stale, unless ``build=False``, which raises
    :class:`StaleModelError` with the command to rebuild (``command``, for a model of your own).
    """
    from ..codegen.render import build as build_model
    from ..codegen.render import input_hash, read_manifest, recover_folder
    from ..model import reference_model
    from ..model.requirements import requirements
    from .model import LoadedModel

    if backend not in ("numpy", "c"):
        raise ModelError(f"unknown backend {backend!r}; use 'numpy' or 'c'")
    if model is None:
        _check_nrfe(nrfe)
        model = reference_model(nrfe)
        command = f"gpmegen build --nrfe {nrfe}"
    directory = Path(directory) if directory is not None else default_directory()
    folder = directory / model.name
    recover_folder(folder)
    backends = ("numpy", "c")
    manifest = read_manifest(folder)
    digest = input_hash(model, backends)
    if manifest is None or manifest.get("input_hash") != digest or not (folder / "model_numpy.py").exists():
        if not build:
            why = "is missing" if manifest is None else "was generated from other inputs or another gpmegen version"
            raise StaleModelError(f"{folder} {why}; rebuild it with '{command or 'gpmegen build'} --force'")
        build_model(model, directory, backends, progress=progress, command=command)
    module = import_numpy_module(folder)
    if getattr(module, "INPUT_HASH", None) != digest:
        raise StaleModelError(f"{folder}/model_numpy.py does not match its model; rebuild it with "
                              f"'{command or 'gpmegen build'} --force'")
    needs = requirements(model)
    if backend == "c":
        from .cmodel import CModel
        return CModel(module, params, folder=folder, requirements=needs)
    return LoadedModel(module, params, "numpy", folder, needs)
