"""A computed-torque law's references along a run and the error against them.

The joint law (:class:`gpmegen.model.computed_torque.ComputedTorque`) holds each coordinate's
reference ``q_r(t)``, the task-space law (:class:`gpmegen.model.task_torque.TaskTorque`) each
component's ``x_r(t)`` of its point: expressions of ``t`` and the plant's parameters that the
generated drive forces were derived from, evaluated here at the saved times with the run's
parameter values. The task law's point is the controller model's, at the plant's joint
coordinates (what the law acts on), not the plant's own point of that name: so the saved error is
the one the law acted on. Other expressions of time and the parameters (a presentation's
prescribed coordinate) are evaluated along a run the same way (:func:`along`).
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ...model.chain import TIME
from ...model.names import point_symbols
from ...symbolic import names
from ...symbolic.computed_torque import controller_outputs
from ...symbolic.program import Program


def along(expressions, model, loaded, t) -> np.ndarray:
    """``expressions`` of time and the parameters of the symbolic ``model`` (a law's references,
    a presentation's prescribed coordinate) at the saved times ``t`` (k,) s, at the parameter
    values of ``loaded`` (the run's): (k, r), r expressions."""
    params = [p.symbol for p in model.parameters]
    values = [loaded.params[p.name] for p in model.parameters]
    evaluate = sp.lambdify([TIME, params], list(expressions), modules="numpy")
    t = np.asarray(t, dtype=float)
    # a constant expression evaluates to a number: broadcast it over the samples
    return np.stack([np.broadcast_to(np.asarray(r, dtype=float), t.shape) for r in evaluate(t, values)], axis=-1)


def _controller_point(law, loaded, q) -> np.ndarray:
    """The task law's point on its components, from the controller model's kinematics at the
    plant's joint coordinates ``q`` (k, n) (its elastic coordinates at rest): (k, c) m."""
    program = Program()
    (position,), coordinates = controller_outputs(law.controller, program,
                                                  lambda kin, dyn: [kin.points[law.point].position], dynamics=False)
    exprs = [position[r] for r in law.rows()]
    for symbol, expr in reversed(program.closure(exprs)):   # each definition reads earlier ones only
        exprs = [e.xreplace({symbol: expr}) for e in exprs]
    joints = [c for c in coordinates if any(e.has(names.coordinate(c)) for e in exprs)]
    evaluate = sp.lambdify([[names.coordinate(c) for c in joints]], exprs, modules="numpy")
    q = np.asarray(q, dtype=float)
    columns = [q[:, loaded.index(c)] for c in joints]
    return np.stack([np.broadcast_to(np.asarray(x, dtype=float), q.shape[:1]) for x in evaluate(columns)], axis=-1)


def reference_arrays(model, loaded, t, q) -> dict:
    """The results arrays of the computed-torque law of the symbolic ``model`` (loaded as
    ``loaded``) at the saved times ``t`` (k,) s and coordinates ``q`` (k, n):
    ``reference_coordinates`` (r,) the law's coordinates (the task law's: its point's coordinate
    names, ``x_E``, ...), ``q_reference`` (k, r) their references and ``tracking_error`` (k, r)
    the reference less the coordinate (rad or m); the task law adds ``reference_units`` (r,).
    Empty without a law."""
    t = np.asarray(t, dtype=float)
    joint, task = getattr(model, "computed_torque", None), getattr(model, "task_torque", None)
    if joint is not None:
        reference = along(joint.references, model, loaded, t)
        columns = [loaded.index(name) for name in joint.coordinates]
        return {"reference_coordinates": np.array(joint.coordinates), "q_reference": reference,
                "tracking_error": reference - np.asarray(q)[:, columns]}
    if task is not None:
        reference = along(task.references, model, loaded, t)
        components = [point_symbols(task.point)[r].name for r in task.rows()]
        return {"reference_coordinates": np.array(components), "q_reference": reference,
                "tracking_error": reference - _controller_point(task, loaded, q),
                "reference_units": np.array(["m"] * len(components))}
    return {}
