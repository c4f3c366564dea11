"""What every backend's templates share: the Jinja environment over ``templates/`` and what a
template says of a model (:func:`model_context`)."""

from __future__ import annotations

import functools
from importlib import resources

import jinja2

from ..model.chain import Model
from ..version import __version__
from .comments import comment_text
from .functions import arguments


def template_environment() -> jinja2.Environment:
    """The Jinja environment over the installed ``templates/``."""
    root = resources.files("gpmegen.templates")
    env = jinja2.Environment(
        loader=jinja2.FileSystemLoader(str(root)),
        undefined=jinja2.StrictUndefined,
        keep_trailing_newline=True,
        autoescape=False,
    )
    env.filters["repr"] = repr
    env.filters["comment"] = comment_text
    env.filters["wrap"] = _wrap
    return env


def _wrap(values, per_line=6, indent=8):
    """Join code values with commas, ``per_line`` to a line."""
    values = list(values)
    lines = [", ".join(values[k:k + per_line]) for k in range(0, len(values), per_line)]
    return (",\n" + " " * indent).join(lines)


def model_context(model: Model, d, digest: str, command: str) -> dict:
    """What every backend's template says of ``model`` (derived as ``d``): its name and text,
    sizes, coordinates, parameters and defaults, points, constraints, the generator's version,
    the input hash and the command that regenerates it, and the arguments' docs."""
    names = d.chain.model.parameter_names
    return dict(
        model=model,
        version=__version__,
        input_hash=digest,
        command=command,
        n_dof=d.chain.n_dof,
        coordinates=d.chain.coordinates,
        parameters=model.parameters,
        parameter_names=names,
        controllers=tuple(c.state for c in model.controllers),
        defaults=tuple(float(p.default) for p in model.parameters),
        points=d.chain.points,
        constraints=d.constraints.names,
        constraint_orders=d.constraints.orders,
        forces=tuple(f.name for f in model.forces),
        limited=tuple(coordinate for coordinate, _, _ in d.dynamics.limited),
        force_points=tuple(tuple(f.points) for f in model.forces),
        arguments=functools.partial(arguments, n_dof=d.chain.n_dof, n_parameters=len(d.chain.model.p_names),
                                    n_constraints=len(d.constraints.names)),
    )
