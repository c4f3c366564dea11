"""Where commands write, and the one rule for it: an output never replaces one of the command's
own inputs (the same path once symlinks are resolved, the same file by another name, or a folder
holding it); it replaces an earlier output only when asked (``--overwrite``,
``overwrite=True``); an output folder that cannot be written is named with the cause. A model's
folder has a rule of its own (:func:`gpmegen.folder.foreign_files`)."""

from __future__ import annotations

import os
from pathlib import Path

from .errors import OutputError, UnwritableFolderError

OVERWRITE = "pass --overwrite to replace it, or choose another --out"


def replaced(target, source) -> str | None:
    """How writing ``target`` (a file, or a folder replaced whole) would replace ``source``: the
    same path once symlinks are resolved, a folder holding it, or the same file (inode) by
    another name; None when it would not."""
    target, source = Path(target), Path(source)
    resolved, inside = target.resolve(), source.resolve()
    if resolved == inside:
        return "is" if target == source else f"is {source},"
    if resolved in inside.parents:
        return f"holds {source},"
    try:
        return f"is the same file as {source}," if os.path.samefile(target, source) else None
    except OSError:  # either is missing: no file is both
        return None


def check(targets, inputs=(), overwrite: bool = False, *, what: str = "an earlier output", fix: str = OVERWRITE,
          error=OutputError) -> None:
    """Refuse, before any work, to write ``targets`` (paths) when one of them would replace one of
    ``inputs`` (paths, None skipped; never allowed), or, unless ``overwrite``, when one is there
    already (it holds ``what``; ``fix`` says what to do). Raises ``error`` in one line."""
    targets = [Path(t) for t in targets]
    for target in targets:
        for source in inputs:
            how = replaced(target, source) if source is not None else None
            if how is not None:
                raise error(f"{target} {how} an input of this command; write to another path (an input is never "
                            f"replaced)")
    if not overwrite:
        taken = next((t for t in targets if t.exists() or t.is_symlink()), None)
        if taken is not None:
            raise error(f"{taken} holds {what}; {fix}")


def unwritable(folder, exc: OSError, fix: str = "choose another --out, or make it writable") -> OutputError:
    """The error for an output ``folder`` that ``exc`` (raised creating a file in it) says cannot
    be written: the folder and the cause, never the temporary file's name."""
    return UnwritableFolderError(exc.errno, f"output folder {folder} is not writable ({exc.strerror}); {fix}")


def writable_folder(path) -> None:
    """Refuse early an output folder that cannot be written, so nothing is half-written; it is
    created when missing."""
    import tempfile

    path = Path(path)
    probe = path
    while not probe.exists() and probe != probe.parent:
        probe = probe.parent
    if not probe.is_dir():
        raise OutputError(f"output folder {path}: {probe} is a file, not a folder; choose another --out")
    try:
        path.mkdir(parents=True, exist_ok=True)
        with tempfile.TemporaryFile(dir=path):
            pass
    except OSError as exc:
        raise unwritable(path, exc) from None
