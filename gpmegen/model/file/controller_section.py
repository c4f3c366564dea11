"""The model file's ``[controller]`` table: a computed-torque law with a controller model of its
own (:class:`gpmegen.model.computed_torque.ComputedTorque`), read after the rest of the file and expanded with it.

The controller model is another model file, read by the ``load`` the caller passes (the file
reader itself, :func:`gpmegen.model.toml_file.read_file`), so that this module does not import it
back.
"""

from __future__ import annotations

import dataclasses
from pathlib import Path

from ...errors import ModelError
from ..chain import Model
from ..computed_torque import ComputedTorque
from .task_space_section import read_task_space

CONTROLLER_KEYS = ("model", "nrfe", "params", "computed_torque", "task_space")
LAW_KEYS = ("coordinate", "reference", "kp", "kd")


def controller_path(plant_file: str, model: str) -> str:
    """The controller model's path: ``model`` as given when absolute, else relative to the
    plant's file."""
    return model if Path(model).is_absolute() else str(Path(plant_file).resolve().parent / model)


def read_controller(reader, data: dict, model: Model, load, override: str | None = None) -> Model:
    """``model`` with the computed-torque law of ``data["controller"]`` (the parsed file's table;
    ``reader`` the :class:`~gpmegen.model.file.reader.Reader` that reads the rest and then
    expands the model once, the law with it);
    ``load(path, nrfe)`` reads a model file; ``override``: a controller model file read in
    place of the table's ``model`` (``--controller-model``, relative to the working directory)."""
    if "controller" not in data:
        if override is not None:
            raise ModelError(f"{reader.file}: --controller-model {override}: the file has no [controller] table to "
                             f"name the law's coordinates, references and gains; add one (docs/model-file.md)")
        return model
    path = ("controller",)
    table = reader.table(data["controller"], path, CONTROLLER_KEYS, ("model",), "controller")
    if "computed_torque" not in table and "task_space" not in table:
        reader.fail(path, "no law: add [[controller.computed_torque]] per joint or one [[controller.task_space]]")
    nrfe = reader.nrfe(table["nrfe"], path + ("nrfe",)) if "nrfe" in table else None
    source = controller_path(reader.file, reader.string(table["model"], path + ("model",),
                                                        "a model file's path in quotes"))
    source = str(override) if override is not None else source
    controller = load(source, nrfe).model
    if "task_space" in table:
        model = dataclasses.replace(model, task_torque=read_task_space(reader, table["task_space"], controller,
                                                                       Path(source).name, _reference))
    if "computed_torque" in table:
        law = _joint_law(reader, table["computed_torque"], controller, Path(source).name)
        model = dataclasses.replace(model, computed_torque=dataclasses.replace(law, params=_params(reader, table)))
    elif "params" in table:
        reader.fail(path + ("params",), "sets the controller model's parameters of a [[controller.computed_torque]] "
                                        "law only, and this table has none; a task-space law reads them at the "
                                        "controller model's values")
    return model


def _joint_law(reader, value, controller, source: str) -> ComputedTorque:
    """The law of the ``[[controller.computed_torque]]`` tables ``value``."""
    path = ("controller",)
    items = reader.array(value, path + ("computed_torque",),
                         what="list of [[controller.computed_torque]] tables")
    coordinates, references, kp, kd, signals = [], [], [], [], []
    for k, item in enumerate(items):
        here = path + ("computed_torque", k)
        reader.table(item, here, LAW_KEYS, LAW_KEYS, "computed-torque law")
        coordinates.append(reader.string(item["coordinate"], here + ("coordinate",), "a coordinate name in quotes"))
        signals.append(reader.string(item["reference"], here + ("reference",), "a signal's name in quotes"))
        references.append(_reference(reader, item["reference"], here + ("reference",)))
        kp.append(reader.quantity(item["kp"], here + ("kp",), reader.params))
        kd.append(reader.quantity(item["kd"], here + ("kd",), reader.params))
    return ComputedTorque(controller, tuple(coordinates), tuple(references), tuple(kp), tuple(kd), source=source,
                          signals=tuple(signals))


def _params(reader, table) -> tuple:
    """``(name, expression)`` per entry of the table's ``params``: a controller model's parameter
    set to an expression of the plant's parameters (checked against the controller model by
    :func:`gpmegen.model.computed_torque.check`)."""
    path = ("controller", "params")
    params = reader.table(table.get("params", {}), path, what="table of the controller model's parameters "
                          "(name = expression of the plant's parameters)")
    return tuple((str(name), reader.quantity(value, path + (name,), reader.params)) for name, value in params.items())


def _reference(reader, value, path):
    """The law of t of the signal named ``value``: an expression signal (its derivatives are
    exact); a table signal is refused (its derivatives would be differences of samples)."""
    name = reader.string(value, path, "a signal's name in quotes")
    if name in reader.signal_expressions:
        return reader.signal_expressions[name]
    if name in reader.table_signals:
        reader.fail(path, f"signal {name!r} is a table, whose velocity and acceleration a computed-torque "
                          f"reference needs but a table does not give; give the reference as an expression of t")
    known = ", ".join(reader.signal_expressions) or "none"
    reader.fail(path, f"no signal {name!r} (the expression signals: {known}); declare it under [[signals]] "
                      f"with an expression of t")
