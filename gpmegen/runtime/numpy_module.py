"""A generated folder's NumPy module imported from exactly the text its manifest records, the
code compiled once per text and process. Apart from :mod:`gpmegen.runtime.loader` because the
C backend's probe (:mod:`gpmegen.runtime.cprobe`), which the loader reaches through the C model,
imports it too."""

from __future__ import annotations

import hashlib
import importlib.util
import sys
from collections import OrderedDict
from pathlib import Path

from ..errors import BuildError
from ..folder import read_verified

#: The compiled code of the generated NumPy modules this process imported, by path and sha256 of
#: their text (the most recent :data:`COMPILED_KEPT`): compiling a large generated module costs
#: more than running it, and a process that loads one model again (levels, sweeps, repeated
#: calls) runs the code compiled from the same text.
_compiled: OrderedDict = OrderedDict()
COMPILED_KEPT = 32


def _code(source: str, path: Path):
    """``source`` compiled as the file ``path``, or the code compiled from the same text before."""
    key = (str(path), hashlib.sha256(source.encode()).hexdigest())
    code = _compiled.get(key)
    if code is None:
        code = compile(source, str(path), "exec")
        _compiled[key] = code
        while len(_compiled) > COMPILED_KEPT:
            _compiled.popitem(last=False)
    return code


def import_numpy_module(folder: Path, rebuild: str = "gpmegen build"):
    """Import ``folder/model_numpy.py`` under a name unique to its folder, running exactly the
    text checked against the folder's manifest (no bytecode cache, which nothing checks; the
    code compiled from the same text earlier in this process, :func:`_code`).
    ``rebuild``: the command the error messages give as the fix."""
    path = Path(folder) / "model_numpy.py"
    source = read_verified(folder, path.name, rebuild)
    name = f"gpmegen_generated_{Path(folder).name}_{abs(hash(str(path.resolve())))}"
    module = importlib.util.module_from_spec(importlib.util.spec_from_loader(name, loader=None, origin=str(path)))
    module.__file__ = str(path)
    try:
        exec(_code(source, path), module.__dict__)
    except Exception as exc:  # a damaged or hand-edited module: whatever it raises, rebuilding is the fix
        raise BuildError(f"{path} cannot be imported ({type(exc).__name__}: {exc}); rebuild it with "
                         f"'{rebuild} --force'") from None
    sys.modules.setdefault(name, module)
    return module
