"""The parameters a model sets at its start (:class:`gpmegen.model.start_constants.StartConstants`,
a model file's ``[initial] set``) bound to a loaded model: the locked statics of its start
configuration are solved, the declared expressions evaluated there, and the values the user
gave kept."""

from __future__ import annotations

import numpy as np

from ...model.names import symbol
from ...runtime import statics


def configuration(declared, loaded) -> np.ndarray:
    """q (n,) with the coordinates ``declared.at`` names at their values (at ``loaded``'s
    parameter values) and the others 0."""
    q = np.zeros(loaded.n_dof)
    for name, value in declared.configuration(_symbols(loaded.params)).items():
        q[loaded.index(name)] = value
    return q


def values_at(declared, loaded, q) -> dict[str, float]:
    """The parameters ``declared`` sets, at the configuration ``q`` (n,) of ``loaded``."""
    points = dict(zip(loaded.points, loaded.point_positions(q)))
    return declared.evaluated(points, _symbols(loaded.params))


def bind(declared, loaded, given=None):
    """``loaded`` with the parameters ``declared`` sets taken at the locked statics of its start
    configuration (those the user ``given``, name -> value, kept), and that configuration q (n,)."""
    q = statics.locked(loaded, configuration(declared, loaded))
    values = values_at(declared, loaded, q)
    values.update({k: v for k, v in (given or {}).items() if k in values})
    return loaded.with_params(**values), q


def reach_hint(declared) -> str:
    """What a start that cannot reach the constraints asks of the values set, e.g. given ones."""
    return f"are the values of {', '.join(declared.names)} within the model's reach?"


def described(declared, model, units: dict, form: str) -> str:
    """The values ``model`` (loaded) holds for the parameters ``declared`` sets, each with its
    unit (``units``: name -> unit) and in ``form`` (a format spec, e.g. ".6g")."""
    return ", ".join(f"{name} = {model.params[name]:{form}}" + (f" {units[name]}" if units.get(name) else "")
                     for name in declared.names)


def _symbols(params: dict) -> dict:
    """Parameter name -> value as symbol -> value."""
    return {symbol(name): value for name, value in params.items()}
