"""The size of a model before it is expanded: what the resource limits (:mod:`gpmegen.limits`)
are given to judge a build or a run before any of it starts."""

from __future__ import annotations

from .chain import FlexibleLink, Joint, Model
from .rfem import link_coordinates


def coordinate_count(model: Model) -> int:
    """n_dof of ``model`` counted without expanding it: one per joint and one more for a
    series-elastic joint's motor, one per free freedom of each sde of each flexible link."""
    count = 0
    for element in model.chain:
        if isinstance(element, Joint):
            count += 2 if element.series_elastic is not None else 1
        elif isinstance(element, FlexibleLink):
            count += link_coordinates(element.n_rfe, element.freedoms)
    return count
