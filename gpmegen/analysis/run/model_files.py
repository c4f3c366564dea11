"""Model files read into Models (``gpmegen.read_model_file``, ``gpmegen.load_model_file``): the
model layer's reader (:func:`gpmegen.model.toml_file.read_file`) given the judge of the closures'
rows, :func:`closure_row_kinds`, which needs the chain's derived kinematics. Here, above both the
reader and the derivation, so that the model layer does not import the derivation: a file's
model holds the closure rows kept, a row that vanishes identically dropped with one warning line
and one that is a constant other than zero refused at the file's line."""

from __future__ import annotations

from ...errors import GpmegenError
from ...model.chain import Model
from ...model.expand import expand
from ...model.toml_file import ModelFile, read_file
from ...symbolic.constraints import constant_rows
from ...symbolic.kinematics import forward
from ...symbolic.program import Program


def closure_row_kinds(model: Model) -> dict[str, str]:
    """Each closure row of ``model`` (a Model whose ``dependent`` may be None), by its name:
    "zero" where it vanishes identically on the chain, "constant" where it is a constant other
    than zero, else "" (:func:`gpmegen.symbolic.constraints.constant_rows` on the kinematics
    derived for this alone). A ModelError when the model does not expand."""
    rows = [row for closure in model.closures for row in closure.constraints()]
    return dict(zip((row.name for row in rows), constant_rows(forward(expand(model), Program()), rows)))


def read_model_file(path, nrfe: int | None = None, controller_model: str | None = None) -> ModelFile:
    """The model of a schema-1 TOML file with its ``[initial]`` configuration (a file whose
    name ends in ``.urdf``: its rigid model, :func:`gpmegen.model.toml_file.read_urdf_file`).

    ``nrfe`` replaces the file's default ``nrfe`` (flexible links that give their own keep it)
    and fills ``{nrfe}`` in the name. Raises ModelError ``"<file>:<line>: <field>: <problem>;
    <fix>"``. Validates with :func:`gpmegen.model.expand.expand`; writes nothing.
    ``controller_model``: a model file read in place of the ``[controller]`` table's ``model``."""
    return read_file(path, closure_row_kinds, nrfe, controller_model)


def load_model_file(path, nrfe: int | None = None) -> Model:
    """The :class:`~gpmegen.model.Model` described by the TOML file at ``path`` (see
    :func:`read_model_file`), or by the URDF file at ``path`` when its name ends in ``.urdf``."""
    return read_model_file(path, nrfe).model


def read_initial(path, nrfe: int | None = None, params: dict | None = None) -> dict[str, float]:
    """The file's start configuration ``[initial] q`` as numbers (rad, m), coordinate name ->
    value, evaluated with the parameter defaults overridden by ``params``; coordinates not named
    start at 0."""
    return read_model_file(path, nrfe).initial_values(params)


def locate(path, error: GpmegenError, nrfe: int | None = None) -> GpmegenError:
    """``error`` (e.g. a DerivationError from deriving a model read from ``path``) as an error of
    the same type whose message starts with the file, line and field it is about. Reads the
    file again: :meth:`ModelFile.locate` on the file already read does not."""
    return read_model_file(path, nrfe).locate(error)
