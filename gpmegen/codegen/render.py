"""Rendering of a model's folder (:mod:`gpmegen.folder`): the model derived once, then each
backend asked for (:mod:`gpmegen.codegen.backends`) printed and written, and the manifest."""

from __future__ import annotations

import hashlib
import json
import shutil
import time
from dataclasses import dataclass
from pathlib import Path

from .. import limits
from ..errors import ModelError
from ..folder import MANIFEST, FolderLock, read_manifest, recover_folder, stale_reason, write_folder
from ..model.chain import Model
from ..model.size import coordinate_count
from ..status import SolveStatus
from ..symbolic import derive
from ..symbolic.names import SIGNAL_FUNCTION
from ..symbolic.transforms import DEFAULT as DEFAULT_TRANSFORMS
from ..version import __version__
from . import backends as registry
from .digest import input_hash
from .functions import lower, model_functions, prepare_all
from .templating import model_context, template_environment


@dataclass
class BuildResult:
    model: str
    folder: Path
    n_dof: int
    skipped: bool
    seconds: float
    files: dict  # file name -> size in bytes


def render(model: Model, backends=("numpy",), progress=None, command=None, digest=None,
           transforms=DEFAULT_TRANSFORMS, jacobians: bool = False) -> dict[str, str]:
    """Derive ``model`` and render the requested backends; returns file name -> text.
    ``digest``: its :func:`input_hash`, when the caller has it already; ``transforms``: the body
    transforms to generate (:data:`gpmegen.symbolic.transforms.KINDS`); ``jacobians``: with the
    generated derivatives of the GPME residuals (else the C Jacobian is by differences)."""
    say = progress or (lambda msg: None)
    chosen = [registry.get(name) for name in backends]
    export = next((b.name for b in chosen if not b.folder), None)
    if export is not None:
        raise ModelError(f"the {export} backend is an export, not a part of a model's folder; write it with "
                         f"'gpmegen export --format {export}'")
    digest = digest or input_hash(model, backends, transforms, jacobians)
    t0 = time.perf_counter()
    n_dof = coordinate_count(model)
    say(f"deriving the equations of motion of {n_dof} coordinates (deriving and printing estimated at "
        f"{limits.duration(limits.build_seconds(n_dof, jacobians))} of CPU time"
        + (", with the acceleration Jacobians)" if jacobians else ")"))
    d = derive(model)
    say(f"derived {len(d.program.definitions)} intermediate quantities for {d.chain.n_dof} coordinates "
        f"in {time.perf_counter() - t0:.1f} s")
    for warning in d.warnings:
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
    say(f"common subexpressions of {len(fns)} functions")
    prepared = prepare_all(fns, d)
    for backend in chosen:
        say(f"printing the {backend.name} backend")
        printer, cache = backend.printer(names, signals), {}
        lowered = [lower(fn, d, printer, p, split=backend.split, cache=cache) for fn, p in zip(fns, prepared)]
        files.update(backend.write(env, lowered, context))
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
        limits.check_build(coordinate_count(model), model.name, jacobians=jacobians)
    with FolderLock(folder):
        return _build_locked(model, folder, backends, force, progress, command, digest, transforms, jacobians)


def _stale(folder, manifest, digest, backends, transforms, jacobians) -> str | None:
    """Why the build in ``folder`` (its ``manifest``) is not the one asked for; None: it is."""
    return stale_reason(folder, manifest, digest, [name for b in backends for name in registry.get(b).files],
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
    limits.check_build(coordinate_count(model), model.name, jacobians=jacobians)
    texts = render(model, backends, progress, command, digest, transforms, jacobians)
    write_folder(folder, texts, registry.folder_files())
    return BuildResult(
        model.name, folder, json.loads(texts[MANIFEST])["n_dof"], False, time.perf_counter() - t0,
        {name: len(text.encode()) for name, text in sorted(texts.items())},
    )
