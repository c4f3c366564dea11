"""The input hash a generated file records: the model, the generator's own source and templates,
and the build's options; a folder whose hash differs is stale."""

from __future__ import annotations

import functools
import hashlib
from importlib import resources

from ..model.chain import Model
from ..symbolic.transforms import DEFAULT as DEFAULT_TRANSFORMS
from ..version import __version__

#: The folders whose modules are the generator (a subpackage is named on its own; the readers
#: of model files under model/ are not: they produce the Model, which is hashed itself).
GENERATOR_PACKAGES = ("model", "symbolic", "codegen", "codegen/backends")
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
        for name in sorted(p.name for p in package.joinpath(*sub.split("/")).iterdir() if p.name.endswith(".py")):
            if f"{sub}/{name}" in NOT_GENERATOR:
                continue
            h.update(f"{sub}/{name}".encode())
            h.update(package.joinpath(*sub.split("/"), name).read_bytes())
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


