"""One run of a case (:mod:`gpmegen.analysis.run.cases`): refused before any work when it cannot
finish, started, integrated, its results annotated with the case's metadata and written."""

from __future__ import annotations

import sys
import time
from collections.abc import Callable, KeysView, Mapping
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import NDArray

from ... import limits, outputs
from ...runtime import integrators
from ...runtime.integrators.loop import PROGRESS_LINES, Progress
from ..post import drive_limits, driving, joint_limits, law_references
from ..post import results as results_io
from . import study
from .runspec import RunSpec

if TYPE_CHECKING:
    from ...runtime.model import LoadedModel
    from .cases import Case


@dataclass
class Run:
    """A finished (or stopped) run: the loaded ``model``, its ``results``, the files ``written``,
    the ``wall`` time of the integration in s and the loaded model as the start left it
    (``started``: before the actuators of the run were set on it)."""

    model: LoadedModel
    results: dict[str, Any]
    written: list[Path]
    wall: float
    started: LoadedModel | None = None


def check(case: Case, spec: RunSpec, backend: str) -> None:
    """Refuse, before anything is loaded or solved, the run ``spec`` of ``case`` on ``backend``
    that cannot finish (gpmegen.limits)."""
    limits.check_run(*case.size(), spec, backend)


def run(case: Case, spec: RunSpec, backend: str, overrides: Mapping[str, float], out: str | Path | None,
        progress: Callable[[str], object]) -> Run:
    """Start ``case`` from ``spec.start`` (one of ``case.starts``; None: its first), integrate its
    constrained motion as ``spec`` says (a :class:`gpmegen.analysis.run.runspec.RunSpec`: held by
    inputs on the coordinates ``actuated``, one per constraint; None: the case's own, e.g. a model
    file's ``actuators``; ``()``: ideally; see :func:`gpmegen.analysis.run.study.simulate`) on
    ``backend`` with the parameter values ``overrides`` (name -> value) and write ``out`` (.npz
    and .csv), or beside it a partial run (see :func:`gpmegen.analysis.post.results.save`); nothing
    when ``out`` is None. ``progress`` takes one-line messages."""
    spec = spec if spec.start is not None else spec.with_start(case.starts[0])
    check(case, spec, backend)
    begun = case.started(backend, spec.start, overrides, progress)
    model = begun.model.with_actuators(case.actuators if spec.actuated is None else spec.actuated)
    q0 = begun.q
    shown = case.shown(model)
    progress("start: " + ", ".join(f"{name} = {q0[model.index(name)]:.6g}" for name in shown)
             + case.start_note(model))
    t0 = time.perf_counter()
    bar = None
    if integrators.get(spec.method).chunked:
        bar = Progress(spec.t_end, f"{case.label}, t (s)", enabled=sys.stderr.isatty(), lines_every=PROGRESS_LINES)
    res = study.simulate(model, q0, spec, qd0=begun.qd, progress=bar, notify=progress)
    wall = time.perf_counter() - t0
    res = results_io.annotate(res, {**case.metadata(model), "start_moved": begun.meta(),
                                    "model_source": case.locator()}, case.extras(model, res))
    res = driving.annotate(res, case.source, model)
    if case.source is not None:   # a computed-torque law's references are the symbolic model's
        res = results_io.annotate(res, {}, law_references.reference_arrays(case.source, model, res["t"], res["q"]))
    for line in joint_limits.exceeded(case.joint_limits(), model.coordinates, res["t"], res["q"], res["qd"]):
        progress(line)
    if "time_at_limit" in res and len(res["t"]):
        for line in drive_limits.summary(res["limited_drives"], res["time_at_limit"], res["t"][-1] - res["t"][0]):
            progress(line)
    if case.source is not None:  # the sdes are known from the symbolic model
        warning = driving.large_rotation(case.source, model, res["t"], res["q"])
        if warning:
            progress(warning)
    return Run(model, res, results_io.save(res, out) if out is not None else [], wall, begun.model)


class Results:
    """A run's results (what :func:`gpmegen.simulate` returns, and what a results file holds):
    ``t`` (k,) s; ``q``, ``qd`` (k, n) in rad, m, rad/s, m/s; ``coordinates``; ``meta`` (model,
    start, settings, parameters, how far the start moved; see
    :func:`gpmegen.analysis.post.results.metadata`); ``status`` ("complete" or why the run stopped);
    every array of the file by name (``results["phi"]``, ``results["end_effector"]``, ...)."""

    def __init__(self, arrays: Mapping[str, Any]) -> None:
        self.arrays = dict(arrays)

    @classmethod
    def load(cls, path: str | Path) -> Results:
        """The results written to ``path`` (.npz) by ``gpmegen simulate`` or :meth:`save`."""
        return cls(results_io.load(path))

    @property
    def t(self) -> NDArray[np.float64]:
        """sample times (k,) s"""
        return self.arrays["t"]

    @property
    def q(self) -> NDArray[np.float64]:
        """coordinates (k, n)"""
        return self.arrays["q"]

    @property
    def qd(self) -> NDArray[np.float64]:
        """velocities (k, n)"""
        return self.arrays["qd"]

    @property
    def coordinates(self) -> tuple[str, ...]:
        """names of the columns of q and qd"""
        return tuple(str(c) for c in self.arrays["coordinates"])

    @property
    def meta(self) -> dict[str, Any]:
        """the run's metadata (dict)"""
        return results_io.metadata(self.arrays)

    @property
    def status(self) -> str:
        """"complete", or why the run stopped"""
        return str(self.arrays["status"])

    def __getitem__(self, name: str) -> Any:
        return self.arrays[name]

    def keys(self) -> KeysView[str]:
        return self.arrays.keys()

    def _column(self, name: str) -> int:
        if name not in self.coordinates:
            raise KeyError(f"{name!r} is not a coordinate of this run; its coordinates are "
                           f"{', '.join(self.coordinates)}")
        return self.coordinates.index(name)

    def coordinate(self, name: str) -> NDArray[np.float64]:
        """The coordinate ``name`` over time, (k,) rad or m."""
        return self.q[:, self._column(name)]

    def velocity(self, name: str) -> NDArray[np.float64]:
        """The velocity of coordinate ``name`` over time, (k,) rad/s or m/s."""
        return self.qd[:, self._column(name)]

    def force(self, name: str) -> NDArray[np.float64]:
        """The force element ``name`` over time, (k, 3): its length L (m), rate dL/dt (m/s) and
        force (N, positive pushing its two points apart)."""
        names = tuple(str(f) for f in self.arrays.get("force_names", ()))
        if name not in names:
            raise KeyError(f"{name!r} is not a force element of this run; its force elements are "
                           f"{', '.join(names) or 'none'}")
        return self.arrays["force_elements"][:, names.index(name)]

    def save(self, path: str | Path, overwrite: bool = False) -> list[Path]:
        """Write the results to ``path`` (.npz, a CSV beside it; a partial run beside ``path``,
        see :func:`gpmegen.analysis.post.results.save`); an earlier run's results there are replaced
        only with ``overwrite``. Returns the paths written."""
        outputs.check(results_io.targets(path), (), overwrite, what="an earlier run's results",
                      fix="save with overwrite=True to replace them, or choose another path",
                      error=results_io.ResultsError)
        return results_io.save(self.arrays, path)

    def __repr__(self) -> str:
        return (f"<gpmegen results {self.meta['model']} ({self.meta['start']} start, {self.status}): "
                f"{len(self.t)} samples to t = {self.t[-1]:.6g} s>")

