"""The model file's ``[controller]`` table: a computed-torque law with a controller model of its
own (:class:`gpmegen.model.computed_torque.ComputedTorque`), read after the rest of the file.

The controller model is another model file, read by the ``load`` the caller passes (the file
reader itself, :func:`gpmegen.model.toml_file.read_model_file`), so that this module does not
import it back.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from ...errors import ModelError
from ..computed_torque import ComputedTorque
from ..expand import expand
from .locator import located
from .model_file import ModelFile

CONTROLLER_KEYS = ("model", "nrfe", "params", "computed_torque")
LAW_KEYS = ("coordinate", "reference", "kp", "kd")


def controller_path(plant_file: str, model: str) -> str:
    """The controller model's path: ``model`` as given when absolute, else relative to the
    plant's file."""
    return model if Path(model).is_absolute() else str(Path(plant_file).resolve().parent / model)


def read_controller(reader, data: dict, model_file: ModelFile, load, override: str | None = None) -> ModelFile:
    """``model_file`` with the computed-torque law of ``data["controller"]`` (the parsed file's
    table; ``reader`` the :class:`~gpmegen.model.file.reader.Reader` that read the rest);
    ``load(path, nrfe)`` reads a model file; ``override``: a controller model file read in
    place of the table's ``model`` (``--controller-model``, relative to the working directory)."""
    if "controller" not in data:
        if override is not None:
            raise ModelError(f"{reader.file}: --controller-model {override}: the file has no [controller] table to "
                             f"name the law's coordinates, references and gains; add one (docs/model-file.md)")
        return model_file
    path = ("controller",)
    table = reader.table(data["controller"], path, CONTROLLER_KEYS, ("model", "computed_torque"), "controller")
    nrfe = reader.nrfe(table["nrfe"], path + ("nrfe",)) if "nrfe" in table else None
    source = controller_path(reader.file, reader.string(table["model"], path + ("model",),
                                                        "a model file's path in quotes"))
    source = str(override) if override is not None else source
    controller = load(source, nrfe).model
    items = reader.array(table["computed_torque"], path + ("computed_torque",),
                         what="list of [[controller.computed_torque]] tables")
    coordinates, references, kp, kd, signals = [], [], [], [], []
    for k, item in enumerate(items):
        here = path + ("computed_torque", k)
        reader.table(item, here, LAW_KEYS, LAW_KEYS, "computed-torque law")
        coordinates.append(reader.string(item["coordinate"], here + ("coordinate",), "a coordinate name in quotes"))
        signals.append(reader.string(item["reference"], here + ("reference",), "a signal's name in quotes"))
        references.append(_reference(reader, signals[-1], here + ("reference",)))
        kp.append(reader.quantity(item["kp"], here + ("kp",), reader.params))
        kd.append(reader.quantity(item["kd"], here + ("kd",), reader.params))
    params = reader.table(table.get("params", {}), path + ("params",), what="table of the controller model's "
                          "parameters (name = expression of the plant's parameters)")
    values = tuple((str(name), reader.quantity(value, path + ("params", name), reader.params))
                   for name, value in params.items())
    law = ComputedTorque(controller, tuple(coordinates), tuple(references), tuple(kp), tuple(kd),
                         source=Path(source).name, signals=tuple(signals), params=values)
    model = dataclasses.replace(model_file.model, computed_torque=law)
    try:
        expand(model)
    except ModelError as exc:
        raise located(exc, reader.file, reader.locator) from None
    return dataclasses.replace(model_file, model=model)


def _reference(reader, name, path):
    """The law of t of the signal named ``name``: an expression signal (its derivatives are
    exact); a table signal is refused (its derivatives would be differences of samples)."""
    if name in reader.signal_expressions:
        return reader.signal_expressions[name]
    if name in reader.table_signals:
        reader.fail(path, f"signal {name!r} is a table, whose velocity and acceleration a computed-torque "
                          f"reference needs but a table does not give; give the reference as an expression of t")
    known = ", ".join(reader.signal_expressions) or "none"
    reader.fail(path, f"no signal {name!r} (the expression signals: {known}); declare it under [[signals]] "
                      f"with an expression of t")
