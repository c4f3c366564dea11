"""Table signals at run time: the tables a model's signals name (:class:`gpmegen.model.Signal`),
read from results files and checked, and the function of t the generated code calls for each.

A signal is the linear interpolation of its samples ``(t_k, y_k)``, held at the ends: between
two samples ``y_k + (y_{k+1} - y_k)/(t_{k+1} - t_k)·(t - t_k)``, the samples' own values at
them. Its error against a function ``y`` of two continuous derivatives that the samples are
taken from is at most ``h²/8·max|ÿ|`` on each interval of length ``h`` (:func:`error_bound`).
The NumPy backend evaluates it with ``numpy.interp`` and the C backend with the solver
library's ``gpmegen_signal`` (``gpmegen/csrc/signals.c``), the same arithmetic.

The tables are the loaded model's module and library's, one set per process (the generated
functions call one function of t, which cannot take them as an argument): binding a model's
tables (:meth:`gpmegen.runtime.model.LoadedModel.with_signals`) sets them for every model loaded
from the same folder in the process.
"""

from __future__ import annotations

import zipfile
import zlib
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from .. import npz
from ..errors import ModelError, SimulationError

#: The arrays of a results file a column may come from: its name's prefix, the array, and the
#: array of its names (a coordinate's ``q`` and ``qd`` go by the coordinate alone).
COLUMN_ARRAYS = (("u_", "u", "actuators"), ("lambda_", "lambda", "constraint_names"),
                 ("drive_", "drive_forces", "coordinates"))
READ = frozenset({"t", "q", "qd", "coordinates", "u", "actuators", "lambda", "constraint_names", "drive_forces"})


@dataclass(frozen=True)
class Table:
    """A signal's samples: ``t`` (k,) s strictly increasing and ``y`` (k,), finite, k ≥ 2;
    ``source``: where they were read (for messages)."""

    name: str
    t: np.ndarray
    y: np.ndarray
    source: str = ""

    @property
    def span(self) -> tuple[float, float]:
        return float(self.t[0]), float(self.t[-1])

    def __call__(self, t):
        """The signal at ``t`` (s): the linear interpolation of the samples, held at the ends."""
        return np.interp(t, self.t, self.y)


def table(name: str, t, y, source: str = "") -> Table:
    """The samples ``t``, ``y`` of signal ``name`` as a :class:`Table`, checked: one-dimensional,
    as many of each and at least two, finite, ``t`` strictly increasing; ModelError naming the
    fault in one line otherwise."""
    where = f"{source}: " if source else ""
    what = f"{where}signal {name!r}"
    try:
        t = np.array(t, dtype=float)
        y = np.array(y, dtype=float)
    except (TypeError, ValueError):
        raise ModelError(f"{what}: its samples are not numbers; give t and values as arrays of numbers") from None
    if t.ndim != 1 or y.ndim != 1 or len(t) != len(y):
        raise ModelError(f"{what}: t {t.shape} and the values {y.shape} must be two arrays of one length; give one "
                         f"value per time")
    if len(t) < 2:
        raise ModelError(f"{what}: {len(t)} sample(s), an interpolation needs two at least; give a longer table")
    for array, label in ((t, "t"), (y, "the values")):
        bad = np.flatnonzero(~np.isfinite(array))
        if bad.size:
            raise ModelError(f"{what}: {label} at sample {bad[0]} is {array[bad[0]]}, not a finite number "
                             f"({bad.size} such); give finite samples")
    steps = np.diff(t)
    if np.any(steps <= 0):
        k = int(np.flatnonzero(steps <= 0)[0])
        raise ModelError(f"{what}: t is not strictly increasing (t[{k}] = {float(t[k])!r}, "
                         f"t[{k + 1}] = {float(t[k + 1])!r}); give samples at increasing times")
    t.flags.writeable = False
    y.flags.writeable = False
    return Table(name, t, y, source)


def columns(data: dict) -> list[str]:
    """The columns a results file's arrays ``data`` offer a signal."""
    names = [name for name in data if name not in READ]
    for prefix, array, labels in COLUMN_ARRAYS:
        if array in data and labels in data:
            names += [prefix + str(label) for label in data[labels]]
    for label in data.get("coordinates", ()):
        names += [str(label), f"{label}_dot"]
    return names


def column(data: dict, name: str):
    """The samples (k,) of column ``name`` of a results file's arrays, or None when it has none:
    an array of its own of that name (a table written with ``numpy.savez(path, t=..., name=...)``)
    or a column of the results' arrays (:data:`COLUMN_ARRAYS`, ``q``, ``qd``)."""
    if name in data and name not in READ:
        return np.asarray(data[name])
    for prefix, array, labels in COLUMN_ARRAYS:
        if name.startswith(prefix) and array in data and labels in data:
            found = [k for k, label in enumerate(data[labels]) if prefix + str(label) == name]
            if found:
                return np.asarray(data[array]).reshape(len(data["t"]), -1)[:, found[0]]
    for array, suffix in (("q", ""), ("qd", "_dot")):
        found = [k for k, label in enumerate(data.get("coordinates", ())) if f"{label}{suffix}" == name]
        if found and array in data:
            return np.asarray(data[array]).reshape(len(data["t"]), -1)[:, found[0]]
    return None


def read_results(path, wanted=()) -> dict:
    """The arrays of a results file a signal may read (:data:`READ`, and those named ``wanted``),
    bounded as :func:`gpmegen.npz.read_checked` reads them; ModelError in one line when it
    cannot be read."""
    remake = "make it again with 'gpmegen simulate'"
    keep = READ | set(wanted)
    try:
        return npz.read_checked(Path(path), keep.__contains__, ModelError, remake)
    except FileNotFoundError:
        raise ModelError(f"{path}: no such results file; run 'gpmegen simulate' to make it, or fix the table's "
                         f"path") from None
    except (OSError, ValueError, EOFError, zipfile.BadZipFile, zlib.error) as exc:
        raise ModelError(f"{path}: not a results file (.npz) that can be read ({exc or type(exc).__name__}); "
                         f"{remake}") from None


def entries(path) -> list[str]:
    """The names of the arrays of the NPZ at ``path`` other than :data:`READ` (none read)."""
    try:
        with zipfile.ZipFile(path) as zf:
            names = [info.filename.removesuffix(".npy") for info in zf.infolist()]
    except (OSError, zipfile.BadZipFile):
        return []
    return [name for name in names if name not in READ]


def read(signal, data: dict | None = None) -> Table:
    """The table of ``signal`` (:class:`gpmegen.model.Signal`): its column of its results file
    (``data``: that file's arrays, when read already), checked (:func:`table`)."""
    data = read_results(signal.table, (signal.column,)) if data is None else data
    if "t" not in data:
        raise ModelError(f"{signal.table}: holds no times t, so it is not a results file; make it with "
                         f"'gpmegen simulate'")
    values = column(data, signal.column)
    if values is None:
        offered = ", ".join(dict.fromkeys(columns(data) + entries(signal.table))) or "none"
        raise ModelError(f"{signal.table}: no column {signal.column!r} for signal {signal.name!r}; its columns are "
                         f"{offered}")
    return table(signal.name, np.ravel(data["t"]), values, signal.table)


def read_all(signals) -> tuple:
    """The tables of ``signals``, each file read once."""
    signals = tuple(signals)
    files: dict = {}
    for signal in signals:
        files.setdefault(signal.table, set()).add(signal.column)
    data = {path: read_results(path, wanted) for path, wanted in files.items()}
    out = [read(signal, data[signal.table]) for signal in signals]
    return tuple(out)


def span(tables) -> tuple[float, float]:
    """The times every table of ``tables`` covers: (latest start, earliest end)."""
    return max(t.span[0] for t in tables), min(t.span[1] for t in tables)


def check_span(tables, t0: float, t_end: float) -> None:
    """Refuse a run over ``[t0, t_end]`` that leaves the time range of a table (SimulationError,
    one line naming the table and the range)."""
    for tab in tables:
        lo, hi = tab.span
        if t0 < lo or t_end > hi:
            raise SimulationError(f"the run's times {t0:g} to {t_end:g} s leave those of signal {tab.name!r}, "
                                  f"{lo:g} to {hi:g} s ({tab.source or 'its table'}); end the run by t = {hi:g} s "
                                  f"or give a table that covers it")


def error_bound(h: float, second_derivative_max: float) -> float:
    """The bound ``h²/8·max|ÿ|`` of the linear interpolation's error on an interval of length
    ``h`` for a function whose second derivative is at most ``second_derivative_max`` in size."""
    return h * h / 8.0 * abs(second_derivative_max)


def numpy_function(tables):
    """The function ``(k, t) -> float`` a generated NumPy module calls for its signals."""
    ts = [tab.t for tab in tables]
    ys = [tab.y for tab in tables]

    def signal(k, t):
        return float(np.interp(t, ts[k], ys[k]))

    return signal
