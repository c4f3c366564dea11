"""Rendering of the Jinja templates and atomic writing of a generated model folder.

A model is generated into ``<out>/<model name>/`` holding ``model_numpy.py``, ``model.c`` (C
backend) and ``manifest.json``. The folder is written beside the target under a temporary name
and swapped in by renames, so an interrupted build leaves the previous folder intact.
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
import time
from dataclasses import dataclass
from importlib import resources
from pathlib import Path

import jinja2

from .. import __version__, limits
from ..errors import BuildError
from ..model.chain import Model
from ..symbolic import derive
from .functions import lower, model_functions, prepare
from .printers import CPrinter, PythonPrinter

BACKEND_FILES = {"numpy": "model_numpy.py", "c": "model.c"}
MANIFEST = "manifest.json"


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
    env.filters["docstring"] = _docstring_text
    env.filters["wrap"] = _wrap
    return env


def _docstring_text(text) -> str:
    """Free text made safe inside a triple-quoted Python docstring."""
    return str(text).replace("\\", "\\\\").replace('"""', '\\"\\"\\"')


def _wrap(values, per_line=6, indent=8):
    """Join code values with commas, ``per_line`` to a line."""
    values = list(values)
    lines = [", ".join(values[k:k + per_line]) for k in range(0, len(values), per_line)]
    return (",\n" + " " * indent).join(lines)


GENERATOR_PACKAGES = ("model", "symbolic", "codegen")
# Readers of model descriptions produce the Model, which is hashed itself.
NOT_GENERATOR = frozenset({"model/toml_file.py"})


def input_hash(model: Model, backends) -> str:
    """Hash of everything the generated code depends on: the model, the package version, the
    source of the generator itself, the templates and the backends asked for."""
    h = hashlib.sha256()
    h.update(repr(model).encode())
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
    h.update(",".join(sorted(backends)).encode())
    return h.hexdigest()[:16]


@dataclass
class BuildResult:
    model: str
    folder: Path
    n_dof: int
    skipped: bool
    seconds: float
    files: dict  # file name -> size in bytes


def render(model: Model, backends=("numpy",), progress=None, command=None) -> dict[str, str]:
    """Derive ``model`` and render the requested backends; returns file name -> text."""
    say = progress or (lambda msg: None)
    digest = input_hash(model, backends)
    t0 = time.perf_counter()
    say("deriving the equations of motion")
    d = derive(model)
    say(f"derived {len(d.program.definitions)} intermediate quantities for {d.chain.n_dof} coordinates "
        f"in {time.perf_counter() - t0:.1f} s")
    fns = model_functions(d)
    names = d.chain.model.parameter_names
    context = dict(
        model=model,
        version=__version__,
        input_hash=digest,
        command=command or f"gpmegen build ({model.name})",
        n_dof=d.chain.n_dof,
        coordinates=d.chain.coordinates,
        parameters=model.parameters,
        parameter_names=names,
        defaults=tuple(float(p.default) for p in model.parameters),
        points=d.chain.points,
        constraints=d.constraints.names,
        constraint_orders=d.constraints.orders,
        dependent=tuple(model.dependent) if model.dependent is not None else None,
    )
    env = template_environment()
    files = {}
    printers = {"numpy": PythonPrinter(names), "c": CPrinter(names)}
    say(f"common subexpressions of {len(fns)} functions")
    prepared = [prepare(fn, d) for fn in fns]
    for backend in backends:
        say(f"printing the {backend} backend")
        lowered = [lower(fn, d, printers[backend], p) for fn, p in zip(fns, prepared)]
        template = env.get_template(BACKEND_FILES[backend] + ".j2")
        files[BACKEND_FILES[backend]] = template.render(functions=lowered, **context)
    manifest = {
        "model": model.name,
        "gpmegen_version": __version__,
        "input_hash": digest,
        "n_dof": d.chain.n_dof,
        "coordinates": list(d.chain.coordinates),
        "parameters": {p.name: float(p.default) for p in model.parameters},
        "points": list(d.chain.points),
        "constraints": list(d.constraints.names),
        "dependent": list(model.dependent) if model.dependent is not None else None,
        "files": {name: hashlib.sha256(text.encode()).hexdigest() for name, text in sorted(files.items())},
    }
    files[MANIFEST] = json.dumps(manifest, indent=2, sort_keys=True) + "\n"
    return files


def read_manifest(folder: Path) -> dict | None:
    """The manifest of a generated folder, or None when missing or unreadable."""
    try:
        return json.loads((Path(folder) / MANIFEST).read_text())
    except (OSError, ValueError):
        return None


def write_folder(folder: Path, files: dict[str, str]) -> None:
    """Write ``files`` as the whole content of ``folder``, atomically: written under a
    temporary name beside it, then swapped in by renames."""
    folder = Path(folder)
    parent = folder.parent
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{folder.name}.tmp-", dir=parent))
    except OSError as exc:
        raise BuildError(f"cannot write into {parent}: {exc.strerror}; choose a writable --out folder") from None
    try:
        for name, text in files.items():
            with open(tmp / name, "w", encoding="utf-8", newline="\n") as fh:
                fh.write(text)
                fh.flush()
                os.fsync(fh.fileno())
        os.chmod(tmp, 0o755)
        old = None
        if folder.exists():
            old = parent / f".{folder.name}.old-{os.getpid()}"
            os.replace(folder, old)
        os.replace(tmp, folder)
        if old is not None:
            shutil.rmtree(old, ignore_errors=True)
    except OSError as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        raise BuildError(f"cannot write {folder}: {exc.strerror}") from None


def recover_folder(folder: Path) -> None:
    """If a build was killed between its two renames, put the previous folder back."""
    folder = Path(folder)
    if folder.exists():
        return
    olds = sorted(folder.parent.glob(f".{folder.name}.old-*"))
    if olds:
        os.replace(olds[-1], folder)


class _FolderLock:
    """An exclusive lock on ``<out>/.<name>.lock`` so that concurrent builds of one model into
    one folder take turns (the second then finds the first's result up to date)."""

    def __init__(self, folder: Path):
        self.path = folder.parent / f".{folder.name}.lock"

    def __enter__(self):
        import fcntl

        try:
            self.path.parent.mkdir(parents=True, exist_ok=True)
            self.handle = open(self.path, "a")
        except OSError as exc:
            raise BuildError(f"cannot write into {self.path.parent}: {exc.strerror}; choose a writable --out folder") from None
        fcntl.flock(self.handle, fcntl.LOCK_EX)
        return self

    def __exit__(self, *exc):
        import fcntl

        fcntl.flock(self.handle, fcntl.LOCK_UN)
        self.handle.close()
        return False


def build(model: Model, out: Path, backends=("numpy",), force=False, progress=None, command=None) -> BuildResult:
    """Generate ``model`` into ``out/<model name>/`` unless an up-to-date build is there."""
    folder = Path(out) / model.name
    with _FolderLock(folder):
        return _build_locked(model, folder, backends, force, progress, command)


def _build_locked(model, folder, backends, force, progress, command) -> BuildResult:
    recover_folder(folder)
    # Holding the lock, no other build writes here: temporary folders left by a killed build go.
    for stale in folder.parent.glob(f".{folder.name}.tmp-*"):
        shutil.rmtree(stale, ignore_errors=True)
    digest = input_hash(model, backends)
    manifest = read_manifest(folder)
    t0 = time.perf_counter()
    if not force and manifest and manifest.get("input_hash") == digest and all(
        (folder / BACKEND_FILES[b]).exists() for b in backends
    ):
        files = {p.name: p.stat().st_size for p in sorted(folder.iterdir())}
        return BuildResult(model.name, folder, manifest["n_dof"], True, 0.0, files)
    limits.check_build(limits.model_coordinates(model), model.name)
    texts = render(model, backends, progress, command)
    write_folder(folder, texts)
    return BuildResult(
        model.name, folder, json.loads(texts[MANIFEST])["n_dof"], False, time.perf_counter() - t0,
        {name: len(text.encode()) for name, text in sorted(texts.items())},
    )
