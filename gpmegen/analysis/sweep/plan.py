"""What a sweep runs: the values of its parameters (every combination of given values, or random
or Latin-hypercube samples within ranges), one :class:`Task` per run, identified by a hash of
everything that decides its results, and the manifest that ties an output folder to one sweep."""

from __future__ import annotations

import collections
import hashlib
import itertools
import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import NamedTuple

from ...errors import GpmegenError
from ...fileio import atomic_write_bytes
from ..post.results import targets
from ..run.runspec import RunSpec

MANIFEST = "sweep.json"
FORMAT = "gpmegen-sweep-1"
RUNS = "runs"
SAMPLINGS = ("lhs", "random")
#: Column names of the summary that a parameter may not take.
RESERVED = ("run", "nrfe")
#: The most values one parameter takes (3 MB of them as Python floats); far more runs than a
#: sweep can make within the limits (gpmegen.limits.check_sweep), which refuse it with its estimate.
MAX_VALUES = 10**5


class SweepError(GpmegenError):
    """A sweep cannot be set up as asked: its arguments, or its output folder."""


class Range(NamedTuple):
    """The interval ``[low, high]`` that ``--samples`` draws a parameter's values from."""

    low: float
    high: float


def _number(name: str, text) -> float:
    try:
        value = float(text)
    except (TypeError, ValueError):
        raise SweepError(f"--param {name}: {text!r} is not a number") from None
    if not math.isfinite(value):
        raise SweepError(f"--param {name}: {text!r} is not a finite number")
    return value


def parse_param(text: str):
    """``NAME=v1,v2,…`` (those values), ``NAME=start:stop:count`` (``count`` evenly spaced values
    from start to stop) or ``NAME=low:high`` (a :class:`Range` for ``--samples``) as ``(name,
    values)``; SweepError saying the syntax when it is none of these."""
    name, sep, spec = text.partition("=")
    name = name.strip()
    if not sep or not name or not spec.strip():
        raise SweepError(f"--param {text!r}: write NAME=v1,v2,… or NAME=start:stop:count (or NAME=low:high "
                         f"with --samples)")
    parts = spec.split(":")
    if len(parts) == 1:
        return name, [_number(name, v) for v in spec.split(",")]
    if len(parts) == 2:
        return name, Range(_number(name, parts[0]), _number(name, parts[1]))
    if len(parts) == 3:
        start, stop, count = _number(name, parts[0]), _number(name, parts[1]), _count(text, parts[2])
        return name, [start + (stop - start) * k / (count - 1) if count > 1 else start for k in range(count)]
    raise SweepError(f"--param {text!r}: write NAME=start:stop:count or NAME=low:high, with at most two ':'")


def _count(text: str, given: str) -> int:
    """The count of ``NAME=start:stop:count`` (digits, or a whole number such as 1e4), at most
    :data:`MAX_VALUES`."""
    given = given.strip()
    try:
        count = float(given)
    except ValueError:
        count = math.nan
    if not (count >= 1 and count == math.floor(count)):
        raise SweepError(f"--param {text!r}: the count {given!r} after the second ':' must be a whole number >= 1")
    if count > MAX_VALUES:
        raise SweepError(f"--param {text!r}: {count:.3g} values of one parameter are more than a sweep takes "
                         f"({MAX_VALUES:.0e}); give a smaller count")
    return int(count)


def normalize(params: dict, samples: int | None) -> dict:
    """``params`` (name → a number, a list of numbers or, with ``samples``, a :class:`Range` or a
    ``(low, high)`` pair) as name → list of floats (values) or :class:`Range`, checked."""
    out = {}
    for name, value in params.items():
        if name in RESERVED:
            raise SweepError(f"--param {name}: '{name}' names a column of the summary, not a parameter; "
                             f"use --nrfe for the number of rfes")
        if isinstance(value, Range) or (samples is not None and isinstance(value, (list, tuple)) and len(value) == 2):
            low, high = (_number(name, v) for v in value)
            if samples is None:
                raise SweepError(f"--param {name}={low:g}:{high:g} is a range: give --samples K to draw from it, or "
                                 f"{name}={low:g}:{high:g}:COUNT for COUNT evenly spaced values")
            if not low <= high:
                raise SweepError(f"--param {name}: the range {low:g}:{high:g} must go from low to high")
            out[name] = Range(low, high)
            continue
        values = [_number(name, v) for v in (value if isinstance(value, (list, tuple)) else [value])]
        if not values:
            raise SweepError(f"--param {name}: give at least one value")
        if samples is not None and len(values) > 1:
            raise SweepError(f"--param {name}: with --samples give a range {name}=low:high (or one fixed value), "
                             f"not a list of values")
        if len(values) > MAX_VALUES:
            raise SweepError(f"--param {name}: {len(values)} values of one parameter are more than a sweep takes "
                             f"({MAX_VALUES:.0e}); give fewer")
        twice = sorted(v for v, n in collections.Counter(values).items() if n > 1)
        if twice:
            raise SweepError(f"--param {name}: {', '.join(f'{v:g}' for v in twice)} given twice; give each value once")
        out[name] = values
    if samples is not None and not any(isinstance(v, Range) for v in out.values()):
        raise SweepError("--samples draws within ranges: give at least one --param NAME=low:high")
    return out


def count(params: dict, samples: int | None) -> int:
    """Runs per model: the number of combinations of the values, or ``samples``."""
    if samples is not None:
        return samples
    return math.prod(len(values) for values in params.values())


def points(params: dict, samples: int | None, seed: int, sampling: str = "lhs") -> list[dict]:
    """The parameter values of each run (name → value), in a fixed order: every combination of
    the values (the last parameter varying fastest), or ``samples`` draws of the ranges (Latin
    hypercube or independent uniform, from ``seed``) with the fixed values beside them."""
    names = list(params)
    if samples is None:
        return [dict(zip(names, combination)) for combination in itertools.product(*params.values())]
    ranges = [name for name in names if isinstance(params[name], Range)]
    if sampling == "lhs":
        from scipy.stats import qmc

        unit = qmc.LatinHypercube(d=max(1, len(ranges)), seed=seed).random(samples)
    elif sampling == "random":
        import numpy as np

        unit = np.random.default_rng(seed).random((samples, max(1, len(ranges))))
    else:
        raise SweepError(f"unknown sampling {sampling!r}: use {' or '.join(SAMPLINGS)}")
    rows = []
    for u in unit:
        drawn = {name: params[name].low + float(x) * (params[name].high - params[name].low)
                 for name, x in zip(ranges, u)}
        rows.append({name: drawn[name] if name in drawn else params[name][0] for name in names})
    return rows


@dataclass(frozen=True)
class Task:
    """One run of a sweep: what decides its results (``inputs``), the results file ``out``
    (.npz, under ``folder``/runs), the coordinates its drives act on (``driven``, for the
    summary), the model's input hash ``digest`` (the key of a worker's loaded models) and
    whether the limits are lifted for it (``no_limits``: the sweep ran within
    :func:`gpmegen.limits.lifted`, which another process does not see)."""

    run_id: str
    model_file: str | None
    nrfe: int | None
    params: tuple  # ((name, value), ...)
    start: str
    t_end: float
    dt: float
    save_every: int
    method: str
    backend: str
    repartition: bool
    folder: str
    digest: str
    driven: tuple
    no_limits: bool = False

    @property
    def out(self) -> Path:
        return Path(self.folder) / RUNS / f"{self.run_id}.npz"

    @property
    def row_file(self) -> Path:
        """The summary row of the run, written once it is complete."""
        return Path(self.folder) / RUNS / f"{self.run_id}.json"

    def leftovers(self) -> list[Path]:
        """What a run stopped midway may have left: its partial results (a run stopped by a
        signal writes them) and the temporary files of a write that was cut short."""
        partial = [path for path in targets(self.out, complete=False) if path.exists()]
        return partial + sorted(self.out.parent.glob(f".{self.run_id}.*.tmp"))

    @property
    def spec(self):
        """The run's :class:`~gpmegen.analysis.run.runspec.RunSpec`."""
        return RunSpec(t_end=self.t_end, dt=self.dt, save_every=self.save_every, method=self.method, start=self.start,
                       repartition=self.repartition)

    def inputs(self) -> dict:
        """The run's columns of the summary: its id, nrfe and parameter values."""
        return {"run": self.run_id, "nrfe": self.nrfe, **dict(self.params)}


def run_id(identity: dict) -> str:
    """A run's id: a hash of everything that decides its results (``identity``, JSON-able)."""
    text = json.dumps(identity, sort_keys=True, separators=(",", ":"))
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def claim(folder: Path, arguments: dict) -> None:
    """Make ``folder`` the folder of the sweep of ``arguments`` (its manifest), or check that it
    is: SweepError when it holds another sweep, or files not made by a sweep."""
    arguments = json.loads(json.dumps(arguments))  # as the manifest holds them (tuples become lists)
    manifest = folder / MANIFEST
    if manifest.is_file():
        try:
            found = json.loads(manifest.read_text(encoding="utf-8"))
        except (OSError, ValueError) as exc:
            raise SweepError(f"{manifest}: unreadable sweep manifest ({exc}); choose another --out") from None
        if found.get("format") != FORMAT:
            raise SweepError(f"{manifest}: not a manifest of this gpmegen's sweeps (format {found.get('format')!r}); "
                             f"choose another --out")
        before = found.get("arguments", {})
        differ = [f"{key} {before.get(key)!r} there, {arguments.get(key)!r} here"
                  for key in sorted(set(before) | set(arguments)) if before.get(key) != arguments.get(key)]
        if differ:
            raise SweepError(f"--out {folder} holds a different sweep ({'; '.join(differ)}); rerun with its "
                             f"arguments to finish it, or choose another --out")
        return
    if folder.exists() and not folder.is_dir():
        raise SweepError(f"--out {folder} is a file; give a folder for the sweep")
    if folder.exists() and any(folder.iterdir()):
        raise SweepError(f"--out {folder} is not empty and holds no sweep ({MANIFEST} is missing); choose a new or "
                         f"empty folder")
    text = json.dumps({"format": FORMAT, "arguments": arguments}, indent=2, sort_keys=True) + "\n"
    atomic_write_bytes(manifest, text.encode())
    (folder / RUNS).mkdir(exist_ok=True)
