"""The parameters a model sets at its start (:class:`gpmegen.model.start_constants.StartConstants`,
a model file's ``[initial] set``) bound to a loaded model: the locked statics of its start
configuration are solved, the declared expressions evaluated there, and the values the user
gave kept."""

from __future__ import annotations

import numpy as np

from ...errors import ModelError
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


def bind(declared, loaded, given=None, locked=True):
    """``loaded`` with the parameters ``declared`` sets taken at the locked statics of its start
    configuration (``locked`` False: at that configuration itself, as a start without statics
    begins there), those the user ``given`` (name -> value) kept, and that configuration q (n,).
    ModelError when a value set moves what it was taken from (:func:`check_unmoved`)."""
    q = configuration(declared, loaded)
    if locked:
        q = statics.locked(loaded, q)
    values = values_at(declared, loaded, q)
    values.update({k: v for k, v in (given or {}).items() if k in values})
    was = measured(loaded, q)
    for name, value in values.items():
        check_unmoved(was, loaded.with_params(**{name: value}), q, name)
    return loaded.with_params(**values), q


# The relative change of the points or of the springs' statics that a value set may cause: none
# but rounding (the values feed the constraints, not the chain, its forces or gravity).
UNMOVED = 1e-9


def measured(model, q) -> tuple:
    """What the values set are taken from at ``q`` (n,): ``(what, values)`` of the points'
    positions and of the static balance ``g + C q``."""
    return (("the points' positions", np.ravel(model.point_positions(q))),
            ("the static balance", model.static_residual(q)))


def check_unmoved(was, after, q, name) -> None:
    """Refuse in one line a parameter ``name`` set at the start whose value (``after``, the model
    with it) moves what ``was`` (:func:`measured` of the model without it at ``q``) holds: the
    values were taken there, so the start would no longer be where they hold."""
    for (what, before), (_, now) in zip(was, measured(after, q)):
        if not np.allclose(now, before, rtol=UNMOVED, atol=UNMOVED * max(1.0, np.abs(before).max(initial=0.0))):
            raise ModelError(f"[initial] set: the value set for {name} changes {what} at the start the values are "
                             f"taken at; set only parameters the chain, its forces and gravity do not read (such as "
                             f"the constants of programmed constraints)", ("initial", "set", name))


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
