"""The parameters a built folder's start sets (a model file's ``[initial] set``, recorded by
``gpmegen build --out`` in the folder's ``start.json``: :func:`gpmegen.folder.write_start`) as
the :class:`~gpmegen.model.start_constants.StartConstants` the file itself gives, so that a run
from the folder binds them as a run from the file does. The record is the file's own text, read
back through the model file's safe expression reader with the names the folder's manifest holds
(the folder may come from someone else: its text is never ``eval``-ed)."""

from __future__ import annotations

import math
import sys
from pathlib import Path
from typing import NoReturn

import sympy as sp

from ...errors import ModelError
from ...folder import START, read_start_set
from ...model.file.expressions import parse
from ...model.names import point_symbols, symbol
from ...model.start_constants import StartConstants


def declared(folder, manifest: dict) -> StartConstants | None:
    """The parameters the start of the built ``folder`` sets (None: it sets none), its text read
    with the parameters and points of its ``manifest``: the configuration from the parameters, each
    value from the parameters the start does not set and the points' ``x_P, y_P, z_P``. A name
    or text the reader refuses raises ModelError in one line naming the record and the fix."""
    pairs = read_start_set(folder)
    if pairs is None:
        return None
    params = {name: symbol(name) for name in manifest.get("parameters", {})}
    set_names = {name for name, _ in pairs["values"]}
    points = {s.name: s for point in manifest.get("points", ()) for s in point_symbols(point)}
    values = {name: value for name, value in params.items() if name not in set_names} | points
    where = Path(folder) / START
    # the names it is taken at and sets must be the model's: the record may have been edited
    for key, names, known in (("q", [n for n, _ in pairs["at"]], manifest.get("coordinates", ())),
                              ("set", sorted(set_names), params)):
        for name in names:
            if name not in known:
                what = "coordinate" if key == "q" else "parameter"
                _refuse(where, (key, name), f"{name!r} is no {what} of the model")
    return StartConstants(at=tuple((name, _quantity(value, params, where, ("q", name))) for name, value in pairs["at"]),
                          values=tuple((name, _quantity(value, values, where, ("set", name)))
                                       for name, value in pairs["values"]))


def _quantity(value, scope: dict, where: Path, field: tuple) -> sp.Expr:
    """A recorded number as the reader makes it (an integer exact, a float as it is), a string
    parsed by the safe reader with the names ``scope`` holds."""
    try:
        if isinstance(value, str):
            return parse(value, scope, lambda name, _: f"{name!r} is not a name this value may read here")
        if abs(value) > sys.float_info.max or not math.isfinite(value):   # in this order: a long int
            text = str(value) if len(str(value)) <= 24 else f"{str(value)[:12]}... ({len(str(value))} characters)"
            raise ModelError(f"{text} is not a finite number within a double's range")
        return sp.Integer(value) if isinstance(value, int) else sp.Float(value)
    except ModelError as exc:
        _refuse(where, field, str(exc))


def _refuse(where: Path, field: tuple, problem: str) -> NoReturn:
    """ModelError: the record at ``where`` has ``problem`` in its ``field``; rebuild the folder."""
    raise ModelError(f"{where}: initial.{'.'.join(field)}: {problem}; build the model into this folder again "
                     f"with 'gpmegen build <its model file> --out {Path(where).parent.parent}'") from None
