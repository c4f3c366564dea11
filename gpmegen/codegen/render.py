"""Rendering of the Jinja templates into a generated model folder (:mod:`gpmegen.folder`), and
the input hash that says whether a folder is up to date."""

from __future__ import annotations

import functools
import hashlib
import json
import shutil
import time
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import jinja2

from .. import limits
from ..errors import ModelError
from ..folder import BACKEND_FILES, MANIFEST, FolderLock, read_manifest, recover_folder, stale_reason, write_folder
from ..model.chain import Model
from ..status import SolveStatus
from ..symbolic import derive
from ..symbolic.names import SIGNAL_FUNCTION
from ..symbolic.transforms import DEFAULT as DEFAULT_TRANSFORMS
from ..version import __version__
from .comments import comment_text
from .functions import arguments, lower, model_functions, prepare_all
from .printers import CPrinter, PythonPrinter


def template_environment() -> jinja2.Environment:
    """The Jinja environment over the installed ``templates/``."""
    root = resources.files("gpmegen.templates")
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(root)),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        autoescape=False,
    )
    env.filters["repr"] = repr
    env.filters["comment"] = comment_text
    env.filters["wrap"] = _wrap
    return env


def _wrap(values, per_line=6, indent=8):
    """Join code values with commas, ``per_line`` to a line."""
    values = list(values)
    lines = [", ".join(values[k:k + per_line]) for k in range(0, len(values), per_line)]
    return (",\n" + " " * indent).join(lines)


GENERATOR_PACKAGES = ("model", "symbolic", "codegen")
# Readers of model descriptions produce the Model, which is hashed itself.
NOT_GENERATOR = frozenset({"model/toml_file.py"})


@functools.cache
def generator_digest() -> bytes:
    """sha256 of the generator itself: the package version, the source of the generator's
    modules, the templates and the solver library's header (the descriptor model.c fills). Read
    once per process (they do not change while it runs)."""
    h = hashlib.sha256()
    h.update(__version__.encode())
    package = resources.files("gpmegen")
    for sub in GENERATOR_PACKAGES:
        for name in sorted(p.name for p in package.joinpath(sub).iterdir() if p.name.endswith(".py")):
            if f"{sub}/{name}" in NOT_GENERATOR:
                continue
            h.update(f"{sub}/{name}".encode())
            h.update(package.joinpath(sub, name).read_bytes())
    root = resources.files("gpmegen.templates")
    for name in sorted(p.name for p in root.iterdir() if p.name.endswith(".j2")):
        h.update(name.encode())
        h.update(root.joinpath(name).read_bytes())
    h.update(b"csrc/gpmegen_solver.h")
    h.update(package.joinpath("csrc", "gpmegen_solver.h").read_bytes())
    return h.digest()


def input_hash(model: Model, backends, transforms=DEFAULT_TRANSFORMS, jacobians: bool = False) -> str:
    """Hash of everything the generated code depends on: the model, the generator
    (:func:`generator_digest`), the backends, the body transforms and the Jacobians asked for."""
    h = hashlib.sha256()
    h.update(repr(model).encode())
    h.update(generator_digest())
    h.update(",".join(sorted(backends)).encode())
    h.update(("transforms:" + ",".join(transforms)).encode())
    if jacobians:
        h.update(b"jacobians")
    return h.hexdigest()[:16]


def check_no_signals(model, export: str) -> None:
    """Refuse, in one line, the export (``export``: what it makes) of a model whose drives read
    table signals: the tables are read at run time by gpmegen's runtime, which an export leaves
    behind."""
    if model is not None and model.signals:
        names = ", ".join(s.name for s in model.signals)
        raise ModelError(f"model {model.name}: its drives read the table signals {names}, which gpmegen's runtime "
                         f"supplies and {export} cannot carry; drive the model through its inputs instead (--inputs)")


def check_no_controllers(model, export: str) -> None:
    """Refuse, in one line, the export (``export``: what it makes) of a model with controller
    states: their rates are integrated by gpmegen's own integrators, which an export leaves
    behind."""
    if model is not None and model.controllers:
        names = ", ".join(c.state for c in model.controllers)
        raise ModelError(f"model {model.name}: {export} does not carry controller states ({names}) yet; "
                         f"simulate it with gpmegen simulate, or write the controller outside the export")


@dataclass
class BuildResult:
    model: str
    folder: Path
    n_dof: int
    skipped: bool
    seconds: float
    files: dict  # file name -> size in bytes


def model_context(model: Model, d, digest: str, command: str) -> dict:
    """What every backend's template says of ``model`` (derived as ``d``): its name and text,
    sizes, coordinates, parameters and defaults, points, constraints, the generator's version,
    the input hash and the command that regenerates it, and the arguments' docs."""
    names = d.chain.model.parameter_names
    return dict(
        model=model,
        version=__version__,
        input_hash=digest,
        command=command,
        n_dof=d.chain.n_dof,
        coordinates=d.chain.coordinates,
        parameters=model.parameters,
        parameter_names=names,
        controllers=tuple(c.state for c in model.controllers),
        defaults=tuple(float(p.default) for p in model.parameters),
        points=d.chain.points,
        constraints=d.constraints.names,
        constraint_orders=d.constraints.orders,
        forces=tuple(f.name for f in model.forces),
        limited=tuple(coordinate for coordinate, _, _ in d.dynamics.limited),
        force_points=tuple(tuple(f.points) for f in model.forces),
        arguments=functools.partial(arguments, n_dof=d.chain.n_dof, n_parameters=len(d.chain.model.p_names),
                                    n_constraints=len(d.constraints.names)),
    )


def render(model: Model, backends=("numpy",), progress=None, command=None, digest=None,
           transforms=DEFAULT_TRANSFORMS, jacobians: bool = False) -> dict[str, str]:
    """Derive ``model`` and render the requested backends; returns file name -> text.
    ``digest``: its :func:`input_hash`, when the caller has it already; ``transforms``: the body
    transforms to generate (:data:`gpmegen.symbolic.transforms.KINDS`); ``jacobians``: with the
    generated derivatives of the GPME residuals (else the C Jacobian is by differences)."""
    say = progress or (lambda msg: None)
    digest = digest or input_hash(model, backends, transforms, jacobians)
    t0 = time.perf_counter()
    n_dof = limits.model_coordinates(model)
    say(f"deriving the equations of motion of {n_dof} coordinates (deriving and printing estimated at "
        f"{limits.duration(limits.build_seconds(n_dof, jacobians))} of CPU time"
        + (", with the acceleration Jacobians)" if jacobians else ")"))
    d = derive(model)
    say(f"derived {len(d.program.definitions)} intermediate quantities for {d.chain.n_dof} coordinates "
        f"in {time.perf_counter() - t0:.1f} s")
    for warning in d.constraints.warnings:
        say(f"warning: {warning}")
    fns = model_functions(d, transforms, jacobians)
    names = d.chain.model.p_names   # the controller states read from p as the parameters are
    context = dict(
        model_context(model, d, digest, command or f"gpmegen build ({model.name})"),
        bodies=d.chain.bodies,
        transforms=tuple(transforms),
        jacobians=jacobians,
        massive_links=d.recursive.massive,
        armature=d.recursive.armature is not None,
        parent_links=d.recursive.parent,
        leaf_links=tuple(not children for children in d.chain.topology.children),
        first_child_links=tuple(p >= 0 and j == max(d.chain.topology.children[p])
                                for j, p in enumerate(d.chain.topology.parent)),
        dependent=tuple(model.dependent) if model.dependent is not None else None,
        statuses=tuple(SolveStatus),
        signals=tuple(s.name for s in model.signals),
        signal_function=SIGNAL_FUNCTION,
    )
    env = template_environment()
    files = {}
    signals = context["signals"]
    printers = {"numpy": PythonPrinter(names, signals), "c": CPrinter(names, signals)}
    say(f"common subexpressions of {len(fns)} functions")
    prepared = prepare_all(fns, d)
    for backend in backends:
        say(f"printing the {backend} backend")
        cache: dict = {}
        lowered = [lower(fn, d, printers[backend], p, split=backend == "c", cache=cache)
                   for fn, p in zip(fns, prepared)]
        for name in BACKEND_FILES[backend]:
            files[name] = env.get_template(name + ".j2").render(functions=lowered, **context)
    manifest = {
        "model": model.name,
        "gpmegen_version": __version__,
        "input_hash": digest,
        "n_dof": d.chain.n_dof,
        "coordinates": list(d.chain.coordinates),
        "parameters": {p.name: float(p.default) for p in model.parameters},
        "points": list(d.chain.points),
        "bodies": list(d.chain.bodies),
        "transforms": list(transforms),
        "jacobians": jacobians,
        "constraints": list(d.constraints.names),
        **({"forces": [f.name for f in model.forces]} if model.forces else {}),
        "dependent": list(model.dependent) if model.dependent is not None else None,
        "files": {name: hashlib.sha256(text.encode()).hexdigest() for name, text in sorted(files.items())},
    }
    if model.signals:   # where a run of the folder alone reads the tables
        manifest["signals"] = [{"name": s.name, "table": s.table, "column": s.column} for s in model.signals]
    files[MANIFEST] = json.dumps(manifest, indent=2, sort_keys=True) + "\n"
    return files


def build(model: Model, out: Path, backends=("numpy",), force=False, progress=None, command=None,
          digest=None, transforms=DEFAULT_TRANSFORMS, jacobians: bool = False) -> BuildResult:
    """Generate ``model`` into ``out/<model name>/`` unless an up-to-date build is there, its
    files as its manifest records them. ``digest``: the model's :func:`input_hash`, when the
    caller has it already; ``transforms``, ``jacobians``: as :func:`render`."""
    folder = Path(out) / model.name
    digest = digest or input_hash(model, backends, transforms, jacobians)
    # A build that would be refused is refused before the lock creates anything in ``out``
    # (looked at without the lock: the answer is checked again under it).
    if force or _stale(folder, read_manifest(folder), digest, backends, transforms, jacobians) is not None:
        limits.check_build(limits.model_coordinates(model), model.name, jacobians=jacobians)
    with FolderLock(folder):
        return _build_locked(model, folder, backends, force, progress, command, digest, transforms, jacobians)


def _stale(folder, manifest, digest, backends, transforms, jacobians) -> str | None:
    """Why the build in ``folder`` (its ``manifest``) is not the one asked for; None: it is."""
    return stale_reason(folder, manifest, digest, [name for b in backends for name in BACKEND_FILES[b]],
                        jacobians, transforms)


def _build_locked(model, folder, backends, force, progress, command, digest, transforms, jacobians) -> BuildResult:
    recover_folder(folder)
    # Holding the lock, no other build writes here: temporary folders left by a killed build go.
    for stale in folder.parent.glob(f".{folder.name}.tmp-*"):
        shutil.rmtree(stale, ignore_errors=True)
    manifest = read_manifest(folder)
    t0 = time.perf_counter()
    if not force:
        reason = _stale(folder, manifest, digest, backends, transforms, jacobians)
        if reason is None:
            files = {p.name: p.stat().st_size for p in sorted(folder.iterdir())}
            return BuildResult(model.name, folder, manifest["n_dof"], True, 0.0, files)
        if manifest is not None and progress is not None:
            progress(f"{reason}: building it again")
    limits.check_build(limits.model_coordinates(model), model.name, jacobians=jacobians)
    texts = render(model, backends, progress, command, digest, transforms, jacobians)
    write_folder(folder, texts)
    return BuildResult(
        model.name, folder, json.loads(texts[MANIFEST])["n_dof"], False, time.perf_counter() - t0,
        {name: len(text.encode()) for name, text in sorted(texts.items())},
    )
