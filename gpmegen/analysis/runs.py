"""One run of a case (:mod:`gpmegen.analysis.cases`): refused before any work when it cannot
finish, started, integrated, its results annotated with the case's metadata and written."""

from __future__ import annotations

import sys
import time
from dataclasses import dataclass

from .. import limits
from . import driving, study
from . import results as results_io


@dataclass
class Run:
    """A finished (or stopped) run: the loaded ``model``, its ``results``, the files ``written``
    and the ``wall`` time of the integration in s."""

    model: object
    results: dict
    written: list
    wall: float


def check(case, t_end, dt, save_every, method, backend) -> None:
    """Refuse, before anything is loaded or solved, a run that cannot finish (gpmegen.limits)."""
    model = case.model
    limits.check_run(limits.model_coordinates(model), len(model.constraints), t_end, dt, save_every, method, backend)


def run(case, start, t_end, dt, save_every, method, backend, overrides, out, progress, repartition=False,
        actuated=None, internal_dynamics=False) -> Run:
    """Start ``case`` (``start``: one of ``case.starts``), integrate its constrained motion (held
    by inputs on the coordinates ``actuated``, one per constraint; None: the case's own, e.g. a
    model file's ``actuators``; ``()``: ideally; with ``internal_dynamics``, their eigenvalues saved
    along the run) and
    write ``out`` (.npz and .csv), or beside it a partial run (see
    :func:`gpmegen.analysis.results.save`). ``progress`` takes one-line messages."""
    check(case, t_end, dt, save_every, method, backend)
    model, q0 = case.start(backend, start, overrides, progress)
    model = model.with_actuators(case.actuators if actuated is None else actuated)
    shown = case.shown(model)
    progress("start: " + ", ".join(f"{name} = {q0[model.index(name)]:.6g}" for name in shown)
             + case.start_note(model))
    t0 = time.perf_counter()
    bar = None
    if method == "rk4":
        from ..runtime.integrate import Progress

        bar = Progress(t_end, case.label, enabled=sys.stderr.isatty())
    res = study.simulate(model, q0, t_end, dt, save_every, method, progress=bar, start=start,
                         repartition=repartition, notify=progress, internal_dynamics=internal_dynamics)
    wall = time.perf_counter() - t0
    res = results_io.annotate(res, case.metadata(model), case.extras(model, res))
    res = driving.annotate(res, case.model, model)
    return Run(model, res, results_io.save(res, out), wall)
