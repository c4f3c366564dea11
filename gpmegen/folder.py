"""A generated model's folder: its files, its manifest, and how it is read and written.

``<out>/<model name>/`` holds ``model_numpy.py``, ``model.h``, ``model.c`` and ``manifest.json``;
the manifest records the model, the input hash and each file's sha256. Code generation writes the
folder (:func:`write_folder`: under a temporary name beside it, then swapped in by renames, so
an interrupted build leaves the previous folder intact); the runtime reads it
(:func:`read_verified`: a file is used only as its manifest records it).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import tempfile
from pathlib import Path

from .errors import BuildError, OutputError, StaleModelError
from .fileio import atomic_write_bytes

MANIFEST = "manifest.json"
#: A built model's start from its source (a model file's ``[initial]`` at the parameter
#: defaults), beside the generated files: what a run from the folder alone starts from.
START = "start.json"


def check_replaceable(folder: Path, generated=()) -> None:
    """Refuse (OutputError) to replace ``folder`` unless gpmegen made it: missing, empty, or a
    folder with a manifest that holds only files a build writes (its manifest, its start and
    the backends' files ``generated``: :func:`gpmegen.codegen.backends.folder_files`), so that
    nothing else is lost (a damaged manifest among them counts: the folder is rebuilt)."""
    folder = Path(folder)
    if not folder.exists() and not folder.is_symlink():
        return
    fix = f"build into another --out, or remove {folder} yourself"
    if folder.is_symlink() or not folder.is_dir():
        raise OutputError(f"{folder} is not a folder gpmegen made (a {'link' if folder.is_symlink() else 'file'}); "
                          f"{fix}")
    entries = sorted(folder.iterdir())
    own = {MANIFEST, START, *generated}
    others = [p.name for p in entries if p.name not in own or p.is_symlink() or not p.is_file()]
    if others or (entries and not (folder / MANIFEST).is_file()):
        held = ", ".join(others[:3]) + (f" and {len(others) - 3} more" if len(others) > 3 else "")
        raise OutputError(f"{folder} is not a folder gpmegen made (it holds {held or 'no ' + MANIFEST}); a build "
                          f"replaces its model's folder whole: {fix}")


def read_manifest(folder: Path) -> dict | None:
    """The manifest of a generated folder, or None when missing or unreadable."""
    try:
        manifest = json.loads((Path(folder) / MANIFEST).read_text())
    except (OSError, ValueError):
        return None
    return manifest if isinstance(manifest, dict) else None


def write_start(folder: Path, q: dict, qd: dict, declared: dict | None = None) -> None:
    """Record the start ``q``, ``qd`` (coordinate name -> number) in the built ``folder``, and the
    parameters the start sets, ``declared`` (a model file's ``[initial] q`` and ``set`` as the file
    gives them: ``at``, ``values``, lists of [name, number or expression string]), if any."""
    record = {"q": q, "qd": qd} if declared is None else {"q": q, "qd": qd, "set": declared}
    text = json.dumps(record, indent=2, sort_keys=True) + "\n"
    atomic_write_bytes(Path(folder) / START, text.encode())


def read_start(folder: Path) -> tuple[dict, dict]:
    """The start recorded in ``folder`` by :func:`write_start`, or ``({}, {})`` (rest at q = 0)
    when none is; a damaged record raises BuildError."""
    data = _start_record(folder)
    if data is None:
        return {}, {}
    try:
        return {str(k): float(v) for k, v in data["q"].items()}, {str(k): float(v) for k, v in data["qd"].items()}
    except (ValueError, KeyError, TypeError, AttributeError):
        raise _damaged(folder) from None


def read_start_set(folder: Path) -> dict | None:
    """The parameters the start sets as :func:`write_start` recorded them in ``folder`` (``at``
    and ``values``: lists of (name, number or expression string) pairs, the text not yet read),
    or None when it records none; a damaged record raises BuildError."""
    data = _start_record(folder)
    if data is None or "set" not in data:
        return None
    declared = data["set"]
    try:
        pairs = {key: [(name, value) for name, value in declared[key]] for key in ("at", "values")}
    except (ValueError, KeyError, TypeError):
        raise _damaged(folder) from None
    for name, value in pairs["at"] + pairs["values"]:
        if not isinstance(name, str) or isinstance(value, bool) or not isinstance(value, (int, float, str)):
            raise _damaged(folder)
    for key in ("at", "values"):   # a name given twice: write_start writes each once
        if len({name for name, _ in pairs[key]}) != len(pairs[key]):
            raise _damaged(folder)
    return pairs


def _start_record(folder: Path) -> dict | None:
    """The JSON object of ``folder``'s start record, None without one; BuildError when damaged."""
    try:
        data = json.loads((Path(folder) / START).read_text(encoding="utf-8"))
    except FileNotFoundError:
        return None
    except (OSError, ValueError):
        raise _damaged(folder) from None
    if not isinstance(data, dict):
        raise _damaged(folder)
    return data


def _damaged(folder: Path) -> BuildError:
    return BuildError(f"{Path(folder) / START} is damaged; build the model into this folder again with 'gpmegen build "
                      f"<its model file> --out {Path(folder).parent}'")


def _checked(folder: Path, name: str, manifest: dict | None) -> tuple[str | None, str | None]:
    """``(text, None)`` when the file ``folder/name``, read once, has the sha256 its manifest
    records, else ``(None, what is wrong)``."""
    path = Path(folder) / name
    files = manifest.get("files") if manifest else None
    recorded = files.get(name) if isinstance(files, dict) else None
    try:
        data = path.read_bytes()
    except FileNotFoundError:
        return None, f"{path} is missing"
    except OSError as exc:
        return None, f"{path} cannot be read ({exc.strerror})"
    if recorded is None:
        return None, f"{path} is not recorded in the folder's {MANIFEST}"
    if hashlib.sha256(data).hexdigest() != recorded:
        return None, f"{path} differs from the sha256 recorded in {MANIFEST} (edited or truncated)"
    return data.decode("utf-8"), None


def read_verified(folder: Path, name: str, rebuild: str = "gpmegen build") -> str:
    """The text of the generated file ``folder/name``, read once and checked against the sha256
    recorded in the folder's manifest, so that what is used is exactly what was generated.
    Raises StaleModelError naming the file and the fix (``<rebuild> --force``) when it differs,
    is missing or is not recorded."""
    text, problem = _checked(folder, name, read_manifest(folder))
    if problem is not None:
        raise StaleModelError(f"{problem}; rebuild it with '{rebuild} --force'")
    return text


def stale_reason(folder: Path, manifest: dict | None, digest: str, names, jacobians: bool = False,
                 transforms=()) -> str | None:
    """Why the generated ``folder`` (its manifest ``manifest``) cannot serve for the input hash
    ``digest`` and the files ``names``: missing, built without the ``jacobians`` or
    ``transforms`` asked for, generated from other inputs, or a file that differs from its
    recorded sha256; None when it can."""
    if manifest is None:
        return f"{folder}/{MANIFEST} is missing or unreadable" if Path(folder).exists() else f"{folder} is missing"
    if manifest.get("input_hash") != digest:
        lacking = (["the acceleration Jacobians"] if jacobians and not manifest.get("jacobians") else []) + [
            f"the transforms {kind}" for kind in transforms if kind not in manifest.get("transforms", ())]
        if lacking:
            return f"{folder} was built without {' and '.join(lacking)}, which are asked for now"
        return f"{folder} was generated from other inputs (the model or its build options) or another gpmegen version"
    return next((problem for name in names if (problem := _checked(folder, name, manifest)[1])), None)


def write_folder(folder: Path, files: dict[str, str], generated=()) -> None:
    """Write ``files`` as the whole content of ``folder``, atomically: written under a
    temporary name beside it, then swapped in by renames; a folder gpmegen did not make is
    refused (:func:`check_replaceable`, ``generated`` and ``files`` the names a build writes)."""
    folder = Path(folder)
    parent = folder.parent
    check_replaceable(folder, {*generated, *files})
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


class FolderLock:
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
            raise BuildError(f"cannot write into {self.path.parent}: {exc.strerror}; choose a writable --out "
                             f"folder") from None
        fcntl.flock(self.handle, fcntl.LOCK_EX)
        return self

    def __exit__(self, *exc):
        import fcntl

        fcntl.flock(self.handle, fcntl.LOCK_UN)
        self.handle.close()
        return False
