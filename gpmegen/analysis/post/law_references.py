"""A computed-torque law's references along a run and the error against them.

The law (:class:`gpmegen.model.computed_torque.ComputedTorque`) holds each coordinate's
reference ``q_r(t)`` as the expression of ``t`` and the plant's parameters that the generated
drive forces were derived from; it is evaluated here at the saved times with the run's parameter
values, so the saved error is the one the law acted on. Other expressions of time and the
parameters (a presentation's prescribed coordinate) are evaluated along a run the same way
(:func:`along`).
"""

from __future__ import annotations

import numpy as np
import sympy as sp

from ...model.chain import TIME


def reference_arrays(model, loaded, t, q) -> dict:
    """The results arrays of the computed-torque law of the symbolic ``model`` (loaded as
    ``loaded``) at the saved times ``t`` (k,) s and coordinates ``q`` (k, n):
    ``reference_coordinates`` (r,) the law's coordinates, ``q_reference`` (k, r) their references
    ``q_r`` and ``tracking_error`` (k, r) ``q_r - q`` (rad or m). Empty without a law."""
    law = getattr(model, "computed_torque", None)
    if law is None:
        return {}
    reference = along(law.references, model, loaded, t)
    columns = [loaded.index(name) for name in law.coordinates]
    return {"reference_coordinates": np.array(law.coordinates), "q_reference": reference,
            "tracking_error": reference - np.asarray(q)[:, columns]}


def along(expressions, model, loaded, t) -> np.ndarray:
    """``expressions`` of time and the parameters of the symbolic ``model`` at the saved times
    ``t`` (k,) s, at the parameter values of ``loaded`` (the run's): (k, r), r expressions."""
    params = [p.symbol for p in model.parameters]
    values = [loaded.params[p.name] for p in model.parameters]
    evaluate = sp.lambdify([TIME, params], list(expressions), modules="numpy")
    t = np.asarray(t, dtype=float)
    # a constant expression evaluates to a number: broadcast it over the samples
    return np.stack([np.broadcast_to(np.asarray(r, dtype=float), t.shape) for r in evaluate(t, values)], axis=-1)
