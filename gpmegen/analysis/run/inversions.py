"""A stable inversion of a case (:mod:`gpmegen.runtime.inversion`) as a results file: the bounded
inputs of its actuated realization over a rest-to-rest programmed motion."""

from __future__ import annotations

import math
import numbers
from dataclasses import dataclass, fields

import numpy as np
from scipy.integrate import cumulative_trapezoid

from ... import limits
from ...errors import ModelError
from ...model.size import coordinate_count
from ...runtime import inversion
from ..post import driving
from ..post import results as results_io
from . import study


def work(t, qd, forces) -> np.ndarray:
    """∫ q̇·Q dt (k,) J along the samples, by the trapezoid rule (``forces`` (k, n))."""
    return cumulative_trapezoid(np.einsum("ij,ij->i", qd, forces), t, initial=0.0)


@dataclass(frozen=True)
class Window:
    """Where an inversion's programmed motion moves: at rest before ``t0`` and after ``t1`` (s),
    the inputs free to act ``pre`` s before and ``post`` s after. Checked when made: finite
    numbers, ``t1`` after ``t0``, positive ``pre`` and ``post`` (one line each)."""

    t1: float
    t0: float = 0.0
    pre: float = 0.1
    post: float = 0.1

    def __post_init__(self):
        for f in fields(self):
            value = getattr(self, f.name)
            if isinstance(value, bool) or not isinstance(value, numbers.Real) or not math.isfinite(value):
                raise ModelError(f"{f.name} = {value!r} is not a finite number of seconds; give one")
            object.__setattr__(self, f.name, float(value))
        if not self.t1 > self.t0:
            raise ModelError(f"t1 ({self.t1:g} s) must come after t0 ({self.t0:g} s)")
        if not (self.pre > 0 and self.post > 0):
            raise ModelError(f"pre ({self.pre:g} s) and post ({self.post:g} s) must be positive windows")


def invert(case, start, window: Window, nodes, overrides, actuated, progress):
    """Stable inversion of ``case`` (from its ``start``, the guess of the first rest state) for
    its programmed motion in ``window``, on ``nodes`` first mesh nodes, with the inputs on
    ``actuated`` (None: the case's own): ``(results, inversion)``, nothing written."""
    t0, t1, pre, post = window.t0, window.t1, window.pre, window.post
    limits.check_inversion(coordinate_count(case.model), nodes)
    begun = case.started("numpy", start, overrides, progress)
    model, q0 = begun.model, begun.q
    model = model.with_actuators(case.actuators if actuated is None else actuated)
    if not len(model.actuators):
        raise ModelError("a stable inversion needs actuated coordinates, one per constraint: give --actuated "
                         "(actuated= from Python) or a model file's actuators")
    progress(f"stable inversion on [{t0 - pre:g}, {t1 + post:g}] s from {nodes} mesh nodes")
    inv = inversion.stable_inversion(model, q0, t0, t1, pre, post, nodes=nodes, progress=progress)
    n = model.n_dof
    drive = np.array([model.drive_forces(t, q, qd) for t, q, qd in zip(inv.t, inv.q, inv.qd)])
    inputs = np.zeros((len(inv.t), n))
    inputs[:, model.actuators] = inv.u
    y = np.column_stack([inv.q, inv.qd, work(inv.t, inv.qd, drive), work(inv.t, inv.qd, inputs)])
    settings = dict(method="stable inversion (solve_bvp)", t0=t0, t1=t1, pre=pre, post=post, nodes=len(inv.t),
                    lead=inv.lead, lag=inv.lag, residual=inv.residual, start=start, backend="numpy",
                    actuators=[model.coordinates[k] for k in model.actuators])
    res = study.collect(model, inv.t, y, "complete", settings)
    res = results_io.annotate(res, {**case.metadata(model), "model_source": case.locator()}, case.extras(model, res))
    res = driving.annotate(res, case.source, model)
    return res, inv
