"""The case a model file's or folder's path, a results file's ``model_source`` or a command's
arguments name: a :class:`~gpmegen.analysis.run.cases.FileCase`, a
:class:`~gpmegen.analysis.run.cases.FolderCase` or the
:class:`~gpmegen.analysis.run.reference_case.ReferenceCase`. Apart from :mod:`cases` because
the reference case is one of its kinds."""

from __future__ import annotations

from pathlib import Path

from ...errors import ModelError
from ...folder import MANIFEST, START, read_manifest
from ...model.rfem import check_nrfe
from .cases import Case, FileCase, FolderCase
from .reference_case import ReferenceCase


def case_of_path(path, nrfe=None) -> Case:
    """The case of ``path``: a model file, or a folder made by ``gpmegen build --out`` (a model's
    folder, or the output folder holding exactly one). A folder of the reference manipulator built
    as such (``gpmegen build --nrfe N``) runs as the reference case (its scenario), loaded from
    that folder; one built from a model file, the same model or not, as that file's start."""
    path = Path(path)
    if not path.is_dir():
        return FileCase(str(path), nrfe)
    folders = [path] if (path / MANIFEST).exists() else sorted(p.parent for p in path.glob(f"*/{MANIFEST}"))
    if len(folders) != 1:
        found = ", ".join(str(p) for p in folders)
        raise ModelError(f"{path}: " + (f"holds {len(folders)} built models ({found}); name one of them"
                                        if folders else "is a folder without a built model (no manifest.json); give "
                                                        "a model file or a folder made by 'gpmegen build --out'"))
    manifest = read_manifest(folders[0])
    if manifest is None or "model" not in manifest:
        raise ModelError(f"{folders[0]}/{MANIFEST} is unreadable; build the model again with 'gpmegen build --force'")
    if nrfe is not None:
        raise ModelError(f"--nrfe {nrfe} does not apply to {folders[0]}, built with its own; build the model with "
                         f"--nrfe {nrfe} into a folder and name that one")
    # a folder built from a model file records the file's start (start.json): it runs from that,
    # not from the paper's scenario, even where its model's hash is the reference arm's
    reference = None if (folders[0] / START).exists() else ReferenceCase.of_manifest(manifest)
    if reference is not None:
        reference.directory = folders[0].parent
        return reference
    return FolderCase(folders[0], manifest)


#: The name that reaches the paper's arm as a path reaches a model file (``gpmegen.load("manipulator")``,
#: ``gpmegen metrics --reference manipulator``); a file or folder of that name is taken first.
REFERENCE = "manipulator"


def case_of_name(model, nrfe=None) -> Case:
    """The case a name or path ``model`` names: :data:`REFERENCE` (the paper's arm with ``nrfe``
    rfes, default 5) where no file or folder has that name, else :func:`case_of_path`."""
    if str(model) == REFERENCE and not Path(model).exists():
        return ReferenceCase(check_nrfe(nrfe or 5, "the reference arm"))
    return case_of_path(model, nrfe)


def case_of_source(source, what) -> Case:
    """The case a results file's ``model_source`` metadata names (see :meth:`Case.locator`),
    ModelError naming ``what`` (the results file) when it names none or one that is gone."""
    if not source:
        raise ModelError(f"{what}: the results do not say which model made them (a model made in Python, or "
                         f"results of an older gpmegen); give its model file with --model")
    if not _is_locator(source):
        raise ModelError(f"{what}: its model_source {str(source)[:80]!r} is not one gpmegen writes "
                         f"({{\"reference\": N}}, {{\"file\": path, \"nrfe\": N}} or {{\"folder\": path}}); "
                         f"give its model file with --model")
    if "reference" in source:
        return ReferenceCase(source["reference"])
    path = Path(source.get("file") or source.get("folder"))
    if not path.exists():
        raise ModelError(f"{what}: the model the results name, {path}, is not there; give its model file with --model")
    return case_of_path(path, source.get("nrfe"))


def _is_locator(source) -> bool:
    """Whether ``source`` is a ``model_source`` as :meth:`Case.locator` writes it."""
    def count(value):
        return type(value) is int and value >= 1

    if not isinstance(source, dict):
        return False
    if set(source) == {"reference"}:
        return count(source["reference"])
    paths = [source[key] for key in ("file", "folder") if key in source]
    if len(paths) != 1 or not isinstance(paths[0], str) or not paths[0].strip():
        return False
    return set(source) <= {"file", "folder", "nrfe"} and (source.get("nrfe") is None or count(source["nrfe"]))


def case_for(model_file, nrfe) -> Case:
    """The case a command runs: a model file with ``nrfe`` rfes (None: its own), a folder made
    by ``gpmegen build --out`` (:func:`case_of_path`), or the reference manipulator (default 5
    rfes)."""
    if model_file:
        return case_of_path(model_file, nrfe)
    return ReferenceCase(nrfe or 5)
