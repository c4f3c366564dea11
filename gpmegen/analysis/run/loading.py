"""A generated model ready to evaluate (:func:`load`, :func:`gpmegen.load` of a model passed in): built into its
folder by codegen when missing or stale, then opened by the runtime, which do not import each
other: here, above both, so that a case (:mod:`gpmegen.analysis.run.cases`) loads its model
without going up to :mod:`gpmegen.api`."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path

from ...codegen import backends as registry
from ...codegen.render import build as build_model
from ...codegen.render import input_hash
from ...errors import StaleModelError
from ...folder import check_replaceable, read_manifest, recover_folder, stale_reason
from ...model.requirements import requirements
from ...runtime.loader import BACKENDS, chosen_backend, default_directory, open_folder
from ...symbolic.transforms import DEFAULT as DEFAULT_TRANSFORMS
from ...symbolic.transforms import KINDS, check_kinds


def keyword_options(options: dict, defaults: dict, what: str) -> dict:
    """``defaults`` (name -> value) with the keyword ``options`` of the function ``what`` over
    them; a name that is none of them is refused in one line with the valid ones."""
    unknown = [name for name in options if name not in defaults]
    if unknown:
        raise TypeError(f"{what}() got an unknown option {', '.join(map(repr, unknown))}; its options are "
                        f"{', '.join(defaults)}")
    return {**defaults, **options}


#: :func:`gpmegen.load`'s keyword options and their defaults.
LOAD_OPTIONS = {"directory": None, "build": True, "progress": None, "command": None, "transforms": DEFAULT_TRANSFORMS,
         "jacobians": False}


def load(model, backend: str | None = None, params: Mapping[str, float] | None = None, **options):
    """``model`` (a :class:`gpmegen.model.Model`) generated and ready to evaluate, bound with its
    parameters' defaults and ``params``: :func:`gpmegen.load` of a model passed in, with its
    options (``LOAD_OPTIONS``)."""
    chosen = keyword_options(options, LOAD_OPTIONS, "load")
    directory, build, progress = chosen["directory"], chosen["build"], chosen["progress"]
    command, transforms, jacobians = chosen["command"], chosen["transforms"], chosen["jacobians"]
    backend = checked_backend(backend, progress)
    directory = Path(directory) if directory is not None else default_directory()
    folder = directory / model.name
    recover_folder(folder)
    rebuild = command or "gpmegen build"
    manifest = read_manifest(folder)
    transforms, jacobians = _at_least(manifest, check_kinds(transforms), jacobians)
    digest = input_hash(model, BACKENDS, transforms, jacobians)
    # the NumPy module supplies every backend's constants, so it is checked for each
    used = tuple(dict.fromkeys(registry.get("numpy").files + registry.get(backend).files))
    reason = stale_reason(folder, manifest, digest, used, jacobians, transforms)
    if reason is not None:
        if not build:
            raise StaleModelError(f"{reason}; rebuild it with '{rebuild} --force'")
        check_replaceable(folder, registry.folder_files())  # before the derivation, which the build would write there
        build_model(model, directory, BACKENDS, progress=progress, command=command, digest=digest,
                    transforms=transforms, jacobians=jacobians)
    loaded = open_folder(folder, backend, params, digest=digest, rebuild=rebuild, requirements=requirements(model),
                         progress=progress)
    loaded.gravity = gravity_function(model)
    return loaded


def gravity_function(model):
    """The model's gravity vector g⃗ in {0} (3,) m/s² as a function of the parameter values (name →
    number): what the generated code holds only inside its forces, kept for the analyses that need
    its direction (the kinds of modes)."""
    import sympy as sp

    symbols = [p.symbol for p in model.parameters]
    import numpy as np

    evaluate = sp.lambdify(symbols, [sp.sympify(v) for v in model.gravity], modules="numpy")
    return lambda params: np.array(evaluate(*(params[p.name] for p in model.parameters)), dtype=float)


def _at_least(manifest, transforms, jacobians):
    """The optional outputs a load builds or reuses: those asked and those the folder already
    holds (its ``manifest``, None when there is none)."""
    held = manifest or {}
    kinds = tuple(k for k in KINDS if k in transforms or k in held.get("transforms", ()))
    return kinds, bool(jacobians or held.get("jacobians", False))


def checked_backend(backend, progress):
    """``backend`` checked; None: "c" where a C compiler is found, else "numpy" (as the command
    line chooses), the reason told to ``progress`` or, without one, as a Python RuntimeWarning."""
    import warnings

    said = []
    chosen = chosen_backend(backend, said.append)
    for line in said:
        if progress is not None:
            progress(line)
        else:
            warnings.warn(line, RuntimeWarning, stacklevel=3)
    return chosen
