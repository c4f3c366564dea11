"""Where generated models live, and how a generated folder is opened: its NumPy module
imported from the text its manifest records, bound to parameter values, on the NumPy or the C
backend. Building a folder that is missing or stale is :func:`gpmegen.api.load`'s part."""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path

from ..errors import BuildError, ModelError, StaleModelError
from ..folder import read_manifest
from ..model.chain import Signal
from . import signals
from .ccompile import find_compiler
from .model import LoadedModel
from .numpy_module import import_numpy_module

#: The source checkout this package runs from, or None when it is installed (no pyproject.toml
#: beside the package).
CHECKOUT = Path(__file__).resolve().parents[2]
CHECKOUT = CHECKOUT if (CHECKOUT / "pyproject.toml").is_file() and (CHECKOUT / "generated").is_dir() else None


def default_directory() -> Path:
    """The one folder where models are built and looked for, by ``gpmegen build`` (its default
    ``--out``), every other command and :func:`gpmegen.load` alike: ``$GPMEGEN_GENERATED``, else
    the checkout's ``generated/`` when the current folder is inside the source checkout gpmegen
    runs from, else ``generated/`` of the current folder. Never the installed package, nor a
    checkout the user is not in. Relative to the current folder where it lies under it."""
    env = os.environ.get("GPMEGEN_GENERATED")
    if env:
        return Path(env)
    here = Path.cwd().resolve()
    if CHECKOUT is not None and (here == CHECKOUT or CHECKOUT in here.parents):
        return Path(os.path.relpath(CHECKOUT / "generated", here))
    return Path("generated")


def _open_numpy(module, params, folder, rebuild, requirements, progress) -> LoadedModel:
    return LoadedModel(module, params, "numpy", folder, requirements)


def _open_c(module, params, folder, rebuild, requirements, progress) -> LoadedModel:
    from .cmodel import CModel  # cffi and the C compiler, needed on the C backend only

    return CModel(module, params, folder=folder, rebuild=rebuild, requirements=requirements, progress=progress)


#: How the runtime opens each backend a folder holds, keyed by the names of
#: :mod:`gpmegen.codegen.backends` (which codegen renders; the runtime does not import codegen):
#: each takes the folder's verified NumPy module (the model's constants), the parameter
#: values, the folder, the rebuild command, the requirements and ``progress``.
OPENERS = {"numpy": _open_numpy, "c": _open_c}
#: The backends a model is opened on (and so built for).
BACKENDS = tuple(OPENERS)


def check_backend(backend: str) -> str:
    """``backend`` when it is one the runtime opens, else ModelError."""
    if backend not in OPENERS:
        raise ModelError(f"unknown backend {backend!r}; use {' or '.join(map(repr, OPENERS))}")
    return backend


def default_backend(say) -> str:
    """The backend used when none is named: "c" where a C compiler is found, else "numpy", after
    telling ``say`` (a callable taking one line) why."""
    try:
        find_compiler()
        return "c"
    except BuildError as exc:
        say(f"{exc}; using the NumPy backend")
        return "numpy"


def chosen_backend(backend: str | None, say) -> str:
    """``backend`` checked (:func:`check_backend`); None: :func:`default_backend`."""
    return default_backend(say) if backend is None else check_backend(backend)


def open_folder(folder: Path, backend: str = "numpy", params: Mapping[str, float] | None = None, *,
                digest: str | None = None, rebuild: str = "gpmegen build", requirements=(), progress=None):
    """The generated model of ``folder`` ready to evaluate on ``backend``, its parameters
    overridden by ``params`` and checked against ``requirements`` (the model's physical bounds,
    :func:`gpmegen.model.requirements.requirements`). ``digest``: the input hash the folder must
    have been generated from (StaleModelError naming ``<rebuild> --force`` otherwise).
    ``progress`` (a callable taking one line) hears about a C compile as it runs."""
    check_backend(backend)
    module = import_numpy_module(folder, rebuild)
    if digest is not None and getattr(module, "INPUT_HASH", None) != digest:
        raise StaleModelError(f"{folder}/model_numpy.py does not match its model; rebuild it with "
                              f"'{rebuild} --force'")
    loaded = OPENERS[backend](module, params, folder, rebuild, requirements, progress)
    return with_tables(loaded, folder) if loaded.signal_names else loaded


def with_tables(loaded, folder):
    """``loaded`` with the tables of its signals read from the files its folder's manifest
    names (:mod:`gpmegen.runtime.signals`)."""
    entries = (read_manifest(Path(folder)) or {}).get("signals", [])
    if [e.get("name") for e in entries] != list(loaded.signal_names):
        raise StaleModelError(f"{folder}: its manifest does not name the tables of the signals "
                              f"{', '.join(loaded.signal_names)}; build it again with 'gpmegen build --force'")
    return loaded.with_signals(signals.read_all(Signal(e["name"], e["table"], e["column"]) for e in entries))
