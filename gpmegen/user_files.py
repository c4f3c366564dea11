"""Reading the files a user names (model files, URDFs): regular files of bounded size only.

A device (``/dev/zero``), a FIFO or a file beyond the cap would be read until the memory runs
out, or block for ever: they are refused in one line before anything is read.
"""

from __future__ import annotations

import os
import stat

#: The largest model file or URDF read (bytes). The longest chain a build could finish in an hour
#: is a model file of well under 1 MB; parsing 8 MB of TOML or XML takes about 100 MB.
MAX_USER_FILE_BYTES = 8 * 2**20

_KINDS = ((stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"), (stat.S_ISFIFO, "a FIFO"),
          (stat.S_ISSOCK, "a socket"), (stat.S_ISDIR, "a folder"))


def _size(n_bytes: int) -> str:
    return f"{n_bytes} bytes ({n_bytes / 2**20:.3g} MiB)"


def _open(path, what: str, error, limit: int):
    """``path`` opened for reading as a binary file, once known to be a regular file of at most
    ``limit`` bytes."""
    file = str(path)
    try:
        # O_NONBLOCK: opening a FIFO must not wait for a writer before it can be refused
        fd = os.open(file, os.O_RDONLY | os.O_NONBLOCK | getattr(os, "O_CLOEXEC", 0))
    except OSError as exc:
        raise error(f"{file}: cannot read {what} ({exc.strerror or exc}); check the path") from None
    fh = os.fdopen(fd, "rb")
    try:
        info = os.fstat(fd)
        for test, kind in _KINDS:
            if test(info.st_mode):
                raise error(f"{file}: {what} is {kind}, not a regular file; give a file")
        if info.st_size > limit:
            raise error(f"{file}: {what} holds {info.st_size} bytes, beyond the {_size(limit)} read; give a "
                        f"smaller file")
        os.set_blocking(fd, True)
    except BaseException:
        fh.close()
        raise
    return fh


def check_user_file(path, what: str, error, limit: int = MAX_USER_FILE_BYTES) -> None:
    """Refuse ``path`` as :func:`read_user_file` does, without reading it (for readers that take
    a path)."""
    _open(path, what, error, limit).close()


def read_user_file(path, what: str, error, limit: int = MAX_USER_FILE_BYTES) -> bytes:
    """The bytes of the regular file at ``path``; ``error`` (an exception class) with one line
    naming ``what`` the file should be ("the model file") when it cannot be read, is no regular
    file, or holds more than ``limit`` bytes."""
    with _open(path, what, error, limit) as fh:
        try:
            data = fh.read(limit + 1)  # one byte more tells a file that grew since
        except OSError as exc:
            raise error(f"{path}: cannot read {what} ({exc.strerror or exc}); check the path") from None
    if len(data) > limit:
        raise error(f"{path}: {what} holds more than the {_size(limit)} read; give a smaller file")
    return data
