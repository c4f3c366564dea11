"""The force elements between two points of the chain, ``[[forces]]``
(:class:`~gpmegen.model.chain.ForceElement`, ``Model.forces``): read here (after the closures,
whose names they may not take), checked by :func:`gpmegen.model.law_checks.check_forces`, derived
by :mod:`gpmegen.symbolic.forces`."""

from __future__ import annotations

from ..chain import FORCE_TYPES, ForceElement
from ..law_checks import FORCE_KEYS
from .registry import ElementKind, register


@register
class Forces(ElementKind):
    table = "forces"
    keys = ("name", "points", "type", "stiffness", "rest_length", "damping", "force")
    required = ("name", "points", "type")
    what = "force"
    field = "forces"

    def read_all(self, reader, items) -> tuple:
        """Each name free among the file's names (the constraints with the closures' rows and
        those the reader writes, the closures), its type with the keys it needs, two points of
        the chain."""
        reader.array(items, ("forces",), what="list of [[forces]] tables")
        taken = reader.taken_names(reader.constraint_names(), reader.entries.get("closures", ()))
        forces = []
        for k, item in enumerate(items):
            path = ("forces", k)
            reader.entry(item, path, self)
            name = reader.name(item["name"], path + ("name",), "force")
            if name in taken:
                reader.fail(path + ("name",), f"force {name!r}: the name is already taken by a {taken[name]}; "
                                              f"rename the force")
            taken[name] = "force"
            forces.append(_force(reader, item, path, name))
        return tuple(forces)


def _force(reader, item, path, name) -> ForceElement:
    """The force element ``name`` of the entry ``item`` at ``path``: the keys of its type, its
    two points, its quantities of parameters (an actuator's force a law of the state)."""
    kind = reader.choice(item["type"], path + ("type",), FORCE_TYPES, "force type")
    needed, allowed = FORCE_KEYS[kind]
    for key in ("stiffness", "rest_length", "damping", "force"):
        if key in item and key not in allowed:
            reader.fail(path + (key,), f"force {name!r}: a {kind} takes no {key}; remove it, or use the type "
                                       f"that has it")
    if not any(key in item for key in needed):
        article = "an" if kind[0] in "aeiou" else "a"
        reader.fail(path, f"force {name!r}: {article} {kind} needs " + " or ".join(needed) + "; add "
                          + " = ... or ".join(needed) + " = ...")
    if kind == "spring-damper" and "stiffness" in item and "rest_length" not in item:
        reader.fail(path, f"force {name!r}: a spring needs its rest_length (m) with its stiffness; add "
                          f"rest_length = ...")
    points = reader.point_pair(item["points"], path + ("points",), f"force {name!r}")
    if points[0] == points[1]:
        reader.fail(path + ("points", 1), f"force {name!r}: the point {points[0]!r} is named twice, so the "
                                          f"force has no line; name two different points")
    values = {key: reader.quantity(item[key], path + (key,), reader.params)
              for key in ("stiffness", "rest_length", "damping") if key in item}
    if kind == "actuator":
        values["force"] = reader.law(item["force"], path + ("force",), "an actuator's")
    return ForceElement(name, points, kind, **values)
