"""The model file's ``[[controller.task_space]]`` table: a task-space computed-torque law
(:class:`gpmegen.model.task_torque.TaskTorque`) on a point of the controller model, read by
:func:`gpmegen.model.file.controller_section.read_controller` once the controller is loaded."""

from __future__ import annotations

from ..chain import AXES
from ..task_torque import TaskTorque

TASK_KEYS = ("point", "components", "reference", "kp", "kd")


def read_task_space(reader, value, controller, source: str, reference) -> TaskTorque:
    """The law of the ``[[controller.task_space]]`` tables ``value`` (one: two would both act on
    every joint of ``controller``); ``reference(reader, value, path)`` reads a reference signal
    as the joint law does; ``source``: the controller's file name, for messages."""
    path = ("controller", "task_space")
    items = reader.array(value, path, what="list of [[controller.task_space]] tables")
    if len(items) != 1:
        reader.fail(path, f"{len(items)} task-space laws, each acting on every joint of the controller model; "
                          f"give one [[controller.task_space]]")
    here = path + (0,)
    item = reader.table(items[0], here, TASK_KEYS, ("point", "reference", "kp", "kd"), "task-space law")
    point = reader.string(item["point"], here + ("point",), "a point's name in quotes")
    components = AXES
    if "components" in item:
        listed = reader.array(item["components"], here + ("components",), what="list of axes")
        components = tuple(reader.string(a, here + ("components", k), 'an axis, "x", "y" or "z"')
                           for k, a in enumerate(listed))
    signals = reader.array(item["reference"], here + ("reference",), what="list of signal names, one per component")
    references = tuple(reference(reader, name, here + ("reference", k)) for k, name in enumerate(signals))
    kp = reader.quantity(item["kp"], here + ("kp",), reader.params)
    kd = reader.quantity(item["kd"], here + ("kd",), reader.params)
    return TaskTorque(controller, point, tuple(components), references, kp, kd, source=source)
