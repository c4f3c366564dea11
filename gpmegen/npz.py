"""Reading NPZ files a user names (results, extrapolations) without unbounded memory: every
array's declared size is checked before anything is inflated."""

from __future__ import annotations

import math
import zipfile
from pathlib import Path

import numpy as np

from . import limits


def read_checked(path: Path, keep, error, remake: str) -> dict:
    """The arrays of the NPZ at ``path`` whose names ``keep(name)`` accepts (the first of any
    duplicate), each read after its declared sizes are checked: the .npy header's shape must fit
    the size the zip declares for the entry (which bounds what is inflated), and all of them the
    memory available; ``error`` (an exception class) with one line otherwise, ending in ``remake``
    (how to make the file again) where the file is at fault. Zip and .npy faults
    propagate as OSError, ValueError, EOFError, zipfile.BadZipFile or zlib.error."""
    with zipfile.ZipFile(path) as zf:
        entries = {}
        for info in zf.infolist():
            key = info.filename.removesuffix(".npy")
            if not keep(key) or key in entries:
                continue
            with zf.open(info) as fh:
                version = np.lib.format.read_magic(fh)
                read_header = np.lib.format.read_array_header_1_0 if version == (1, 0) else \
                    np.lib.format.read_array_header_2_0
                shape, _, dtype = read_header(fh)
            declared = math.prod(shape) * dtype.itemsize
            if dtype.hasobject or declared > info.file_size:
                raise error(f"{path}: its array '{key}' declares {declared} bytes in {info.file_size}; {remake}")
            entries[key] = info
        total = sum(info.file_size for info in entries.values())
        available = limits.available_memory()
        if available is not None and total > available:
            raise error(f"{path}: its arrays hold {total / 1e9:.3g} GB, more than the {available / 1e9:.3g} "
                        f"GB of memory available; read it on a larger machine")
        data = {}
        for key, info in entries.items():
            with zf.open(info) as fh:
                data[key] = np.lib.format.read_array(fh, allow_pickle=False)
    return data
