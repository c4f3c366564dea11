"""Where generated models live, and how a generated folder is opened: its NumPy module
imported from the text its manifest records, bound to parameter values, on the NumPy or the C
backend. Building a folder that is missing or stale is :func:`gpmegen.api.load`'s part."""

from __future__ import annotations

import hashlib
import importlib.util
import os
import sys
from collections import OrderedDict
from pathlib import Path

from ..errors import BuildError, ModelError, StaleModelError
from ..folder import read_verified

#: The source checkout this package runs from, or None when it is installed (no pyproject.toml
#: beside the package).
CHECKOUT = Path(__file__).resolve().parents[2]
CHECKOUT = CHECKOUT if (CHECKOUT / "pyproject.toml").is_file() and (CHECKOUT / "generated").is_dir() else None
BACKENDS = ("numpy", "c")


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


def check_backend(backend: str) -> str:
    """``backend`` when it is one gpmegen has, else ModelError."""
    if backend not in BACKENDS:
        raise ModelError(f"unknown backend {backend!r}; use 'numpy' or 'c'")
    return backend


def default_backend(say) -> str:
    """The backend used when none is named: "c" where a C compiler is found, else "numpy", after
    telling ``say`` (a callable taking one line) why."""
    from .ccompile import find_compiler

    try:
        find_compiler()
        return "c"
    except BuildError as exc:
        say(f"{exc}; using the NumPy backend")
        return "numpy"


def chosen_backend(backend: str | None, say) -> str:
    """``backend`` checked (:func:`check_backend`); None: :func:`default_backend`."""
    return default_backend(say) if backend is None else check_backend(backend)


#: The compiled code of the generated NumPy modules this process imported, by path and sha256 of
#: their text (the most recent :data:`COMPILED_KEPT`): compiling a large generated module costs
#: more than running it, and a process that loads one model again (levels, sweeps, repeated
#: calls) runs the code compiled from the same text.
_compiled: OrderedDict = OrderedDict()
COMPILED_KEPT = 32


def _code(source: str, path: Path):
    """``source`` compiled as the file ``path``, or the code compiled from the same text before."""
    key = (str(path), hashlib.sha256(source.encode()).hexdigest())
    code = _compiled.get(key)
    if code is None:
        code = compile(source, str(path), "exec")
        _compiled[key] = code
        while len(_compiled) > COMPILED_KEPT:
            _compiled.popitem(last=False)
    return code


def import_numpy_module(folder: Path, rebuild: str = "gpmegen build"):
    """Import ``folder/model_numpy.py`` under a name unique to its folder, running exactly the
    text checked against the folder's manifest (no bytecode cache, which nothing checks; the
    code compiled from the same text earlier in this process, :func:`_code`).
    ``rebuild``: the command the error messages give as the fix."""
    path = Path(folder) / "model_numpy.py"
    source = read_verified(folder, path.name, rebuild)
    name = f"gpmegen_generated_{Path(folder).name}_{abs(hash(str(path.resolve())))}"
    module = importlib.util.module_from_spec(importlib.util.spec_from_loader(name, loader=None, origin=str(path)))
    module.__file__ = str(path)
    try:
        exec(_code(source, path), module.__dict__)
    except Exception as exc:  # a damaged or hand-edited module: whatever it raises, rebuilding is the fix
        raise BuildError(f"{path} cannot be imported ({type(exc).__name__}: {exc}); rebuild it with "
                         f"'{rebuild} --force'") from None
    sys.modules.setdefault(name, module)
    return module


def open_folder(folder: Path, backend: str = "numpy", params: dict | None = None, *, digest: str | None = None,
                rebuild: str = "gpmegen build", requirements=(), progress=None):
    """The generated model of ``folder`` ready to evaluate on ``backend``, its parameters
    overridden by ``params`` and checked against ``requirements`` (the model's physical bounds,
    :func:`gpmegen.model.requirements.requirements`). ``digest``: the input hash the folder must
    have been generated from (StaleModelError naming ``<rebuild> --force`` otherwise).
    ``progress`` (a callable taking one line) hears about a C compile as it runs."""
    from .model import LoadedModel

    check_backend(backend)
    module = import_numpy_module(folder, rebuild)
    if digest is not None and getattr(module, "INPUT_HASH", None) != digest:
        raise StaleModelError(f"{folder}/model_numpy.py does not match its model; rebuild it with "
                              f"'{rebuild} --force'")
    if backend == "c":
        from .cmodel import CModel
        loaded = CModel(module, params, folder=folder, rebuild=rebuild, requirements=requirements, progress=progress)
    else:
        loaded = LoadedModel(module, params, "numpy", folder, requirements)
    return with_tables(loaded, folder) if loaded.signal_names else loaded


def with_tables(loaded, folder):
    """``loaded`` with the tables of its signals read from the files its folder's manifest
    names (:mod:`gpmegen.runtime.signals`)."""
    from ..folder import read_manifest
    from ..model.chain import Signal
    from . import signals

    entries = (read_manifest(Path(folder)) or {}).get("signals", [])
    if [e.get("name") for e in entries] != list(loaded.signal_names):
        raise StaleModelError(f"{folder}: its manifest does not name the tables of the signals "
                              f"{', '.join(loaded.signal_names)}; build it again with 'gpmegen build --force'")
    return loaded.with_signals(signals.read_all(Signal(e["name"], e["table"], e["column"]) for e in entries))
