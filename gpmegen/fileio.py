"""Atomic writing of files: written beside the target under a temporary name, flushed to disk,
then renamed over it, so readers see the old file or the new one, never half of one."""

from __future__ import annotations

import os
import signal
import tempfile
from contextlib import contextmanager
from pathlib import Path

from .outputs import unwritable


def atomic_write(path, write, mode=0o644) -> Path:
    """Write ``path`` by calling ``write(binary file)``; creates the parent folder."""
    return atomic_write_all({path: write}, mode)[0]


def atomic_write_bytes(path, data: bytes, mode=0o644) -> Path:
    """Write ``data`` to ``path`` atomically."""
    return atomic_write(path, lambda fh: fh.write(data), mode)


def atomic_write_all(writes: dict, mode=0o644) -> list[Path]:
    """Write several files as one: ``writes`` maps each path to ``write(binary file)``. All are
    written to temporary files first, then renamed into place with Ctrl-C and SIGTERM held back,
    so an interruption leaves either all the old files or all the new ones. (A crash of the
    machine between two renames can still mix them: give the files a shared id to tell.)"""
    staged = []
    try:
        for path, write in writes.items():
            path = Path(path)
            try:
                path.parent.mkdir(parents=True, exist_ok=True)
                fd, tmp = tempfile.mkstemp(prefix=f".{path.name}.", suffix=".tmp", dir=path.parent)
            except OSError as exc:  # named by the folder and the cause, not the temporary file's name
                raise unwritable(path.parent, exc) from None
            staged.append((tmp, path))
            os.fchmod(fd, mode)
            with os.fdopen(fd, "wb") as fh:
                write(fh)
                fh.flush()
                os.fsync(fh.fileno())
        with signals_held():
            for tmp, path in staged:
                os.replace(tmp, path)
    except BaseException:
        for tmp, _ in staged:
            Path(tmp).unlink(missing_ok=True)
        raise
    return [path for _, path in staged]


@contextmanager
def signals_held():
    """Hold Ctrl-C and SIGTERM back inside the block: the first that arrives is acted on (as its
    handler would have) when the block ends. Outside the main thread, where signals interrupt
    nothing, the block runs as it is."""
    received = []
    previous = {}
    try:
        for signum in (signal.SIGINT, signal.SIGTERM):
            previous[signum] = signal.signal(signum, lambda number, frame: received.append(number))
    except ValueError:  # not the main thread
        pass
    try:
        yield
    finally:
        for signum, handler in previous.items():
            signal.signal(signum, signal.SIG_DFL if handler is None else handler)
        if received:
            handler = previous[received[0]]
            if callable(handler):
                handler(received[0], None)  # Ctrl-C: raises KeyboardInterrupt
            elif handler != signal.SIG_IGN:  # the default action: SIGTERM ends the process
                os.kill(os.getpid(), received[0])
