"""Reading what acts on a model file's chain: signals, controllers, drives and their laws, force
elements. A mixin of :class:`~gpmegen.model.file.reader.Reader`."""

from __future__ import annotations

import difflib
from pathlib import Path

from ..chain import (
    FORCE_TYPES,
    MAX_SIGNALS,
    TIME,
    Controller,
    Drive,
    ForceElement,
    Signal,
    point_acceleration_symbols,
    point_symbols,
    point_velocity_symbols,
    symbol,
)
from ..elements import get as element_kind
from ..elements import kinds as element_kinds
from ..law_checks import FORCE_KEYS, FORCE_OF_ACCELERATIONS, RATE_OF_ACCELERATIONS
from .schema import (
    SIGNAL_KEYS,
)


class ElementReading:
    """Signals, controllers, drives and force elements (a mixin of the Reader)."""

    def expression_names(self) -> dict:
        """What every name of an expression stands for beside parameters and t: coordinates,
        their velocities and accelerations, points' positions, velocities and accelerations (the
        names a signal may not take, each with what it is)."""
        names = {name: "parameter" for name in self.params}
        names["t"] = "time"
        for c in self.coordinates:
            names.update({c: "coordinate", f"{c}_dot": f"the velocity of coordinate {c!r}",
                          f"{c}_ddot": f"the acceleration of coordinate {c!r}"})
        for point in self.points:
            for f, kind in ((point_symbols, "position"), (point_velocity_symbols, "velocity"),
                            (point_acceleration_symbols, "acceleration")):
                names.update({s.name: f"a {kind} coordinate of point {point!r}" for s in f(point)})
        return names

    def fresh_name(self, name, path, what, taken: dict, seen: dict) -> None:
        """Refuse ``name`` (of a ``what`` at ``path``) when the file's expressions give it to
        something else (``taken``: name -> what it is) or an earlier one of its kind took it
        (``seen``: name -> its path, to which it is then added)."""
        if name in taken:
            other = taken[name] if " " in taken[name] else f"a {taken[name]}"
            self.fail(path, f"{what} {name!r} has the name of {other} in expressions; choose another name")
        if name in seen:
            self.fail(path, f"a second {what} {name!r} (the first at line {self.locator.line(seen[name])}); choose "
                            f"another name")
        seen[name] = path

    def read_signals(self, items) -> tuple:
        """The ``[[signals]]``: each a name for a law of t and parameters (``expression``, written
        where the name stands) or for a column of a results file (``table``, ``column``), read at
        run time (:class:`Signal`)."""
        self.array(items, ("signals",), what="list of [[signals]] tables")
        taken = self.expression_names()
        seen: dict[str, tuple] = {}
        for k, item in enumerate(items):
            path = ("signals", k)
            self.table(item, path, SIGNAL_KEYS, ("name",), "signal")
            name = self.name(item["name"], path + ("name",), "signal", bare=True)
            self.fresh_name(name, path + ("name",), "signal", taken, seen)
            if ("expression" in item) == ("table" in item):
                self.fail(path, "give a signal either expression = \"...\" (a law of t and parameters) or "
                                "table = \"run.npz\" with column = \"...\", not both nor neither")
            if "expression" in item:
                if "column" in item:
                    self.fail(path + ("column",), "column belongs with table; remove it")
                scope = {**self.params, "t": TIME, **self.signal_expressions}
                self.signal_expressions[name] = self.quantity(item["expression"], path + ("expression",), scope)
                continue
            if len(self.table_signals) == MAX_SIGNALS:
                self.fail(path, f"more than {MAX_SIGNALS} signals read from tables; join runs into fewer")
            if "column" not in item:
                self.fail(path, "missing required key 'column'; add column = \"u_<coordinate>\" (the column of "
                                "the table to read)")
            table = self.string(item["table"], path + ("table",), "a results file's path in quotes")
            column = self.string(item["column"], path + ("column",), "a column name in quotes")
            if not table:
                self.fail(path + ("table",), "the table's path is empty; give a results file (.npz)")
            where = Path(table) if Path(table).is_absolute() else Path(self.file).resolve().parent / table
            self.table_signals[name] = Signal(name, str(where), column)
        return tuple(self.table_signals.values())

    def signal_scope(self) -> dict:
        """The signals' names as expressions take them: an expression signal's law, a table
        signal's symbol."""
        return {**self.signal_expressions, **{name: s.symbol for name, s in self.table_signals.items()}}

    def point_pair(self, value, path, owner: str) -> tuple:
        """Two names of the chain's points (``value``, at ``path``) for ``owner`` (a closure, a
        force element: named in the messages)."""
        self.array(value, path, 2, "list of two point names")
        points = tuple(self.string(p, path + (j,), "a point name in quotes") for j, p in enumerate(value))
        for j, point in enumerate(points):
            if point not in self.points:
                close = difflib.get_close_matches(point, self.points, 1)
                hint = f"did you mean {close[0]!r}? or " if close else ""
                self.fail(path + (j,), f"{owner}: no point {point!r}; {hint}declare it with a [[chain]] point = "
                                       f"\"{point}\" element")
        return points

    def read_controllers(self, items, chain) -> tuple:
        """The ``[[controllers]]`` as :class:`Controller`: each state a name of its own among the
        file's names, its ``rate`` a law of t, parameters, positions and velocities, signals and
        the controller states (any of them, read before the rates), ``initial`` of parameters."""
        self.array(items, ("controllers",), what="list of [[controllers]] tables")
        taken = {**self.taken_names(chain, ()), **self.expression_names(),
                 **{name: "a signal" for name in self.signal_scope()}}
        states: dict[str, tuple] = {}
        for k, item in enumerate(items):
            path = ("controllers", k)
            self.entry(item, path, element_kind("controllers"))
            name = self.name(item["state"], path + ("state",), "controller state", bare=True)
            self.fresh_name(name, path + ("state",), "controller state", taken, states)
        self.controller_states = {name: symbol(name) for name in states}
        scope = {**self.constraint_scope(1), **self.signal_scope(), **self.controller_states}
        controllers = []
        for k, item in enumerate(items):
            path = ("controllers", k)
            rate = self.law(item["rate"], path + ("rate",), "a controller state's rate", scope, RATE_OF_ACCELERATIONS)
            initial = self.quantity(item.get("initial", 0), path + ("initial",), self.params)
            controllers.append(Controller(item["state"], rate, initial))
        return tuple(controllers)

    def read_drives(self, items):
        self.array(items, ("drives",), what="list of [[drives]] tables")
        # a feedback law: t, parameters, positions and velocities; the signals and controller states
        scope = {**self.constraint_scope(1), **self.signal_scope(), **self.controller_states}
        drives = []
        for k, item in enumerate(items):
            path = ("drives", k)
            self.table(item, path, ("coordinate", "expression", "limit"), ("coordinate", "expression"), "drive")
            coordinate = self.string(item["coordinate"], path + ("coordinate",), "a coordinate name in quotes")
            limit = self.quantity(item["limit"], path + ("limit",), self.params) if "limit" in item else None
            drives.append(Drive(coordinate, self.law(item["expression"], path + ("expression",), "a drive's", scope),
                                limit))
        return tuple(drives)

    def law(self, value, path, whose, scope=None, why=FORCE_OF_ACCELERATIONS):
        """A feedback law (``whose``: "a drive's", "an actuator's", "a controller state's rate"):
        of t, parameters, positions and velocities (``scope``, when given: those names and more, a
        drive's signals); ``why`` it may not read accelerations, as its refusal says."""
        self.reading_drive, self.reading_why = whose, why
        try:
            return self.quantity(value, path, scope if scope is not None else self.constraint_scope(1))
        finally:
            self.reading_drive, self.reading_why = "", FORCE_OF_ACCELERATIONS

    def read_forces(self, items, taken) -> tuple:
        """The ``[[forces]]`` as :class:`ForceElement`: each name free among the file's names
        (``taken``: name -> what it is), its type with the keys it needs, two points of the chain."""
        self.array(items, ("forces",), what="list of [[forces]] tables")
        forces = []
        for k, item in enumerate(items):
            path = ("forces", k)
            self.entry(item, path, element_kind("forces"))
            name = self.name(item["name"], path + ("name",), "force")
            if name in taken:
                self.fail(path + ("name",), f"force {name!r}: the name is already taken by a {taken[name]}; "
                                            f"rename the force")
            taken[name] = "force"
            kind = self.choice(item["type"], path + ("type",), FORCE_TYPES, "force type")
            needed, allowed = FORCE_KEYS[kind]
            for key in ("stiffness", "rest_length", "damping", "force"):
                if key in item and key not in allowed:
                    self.fail(path + (key,), f"force {name!r}: a {kind} takes no {key}; remove it, or use the type "
                                             f"that has it")
            if not any(key in item for key in needed):
                article = "an" if kind[0] in "aeiou" else "a"
                self.fail(path, f"force {name!r}: {article} {kind} needs " + " or ".join(needed) + "; add "
                                + " = ... or ".join(needed) + " = ...")
            if kind == "spring-damper" and "stiffness" in item and "rest_length" not in item:
                self.fail(path, f"force {name!r}: a spring needs its rest_length (m) with its stiffness; add "
                                f"rest_length = ...")
            points = self.point_pair(item["points"], path + ("points",), f"force {name!r}")
            if points[0] == points[1]:
                self.fail(path + ("points", 1), f"force {name!r}: the point {points[0]!r} is named twice, so the "
                                                f"force has no line; name two different points")
            values = {key: self.quantity(item[key], path + (key,), self.params)
                      for key in ("stiffness", "rest_length", "damping") if key in item}
            if kind == "actuator":
                values["force"] = self.law(item["force"], path + ("force",), "an actuator's")
            forces.append(ForceElement(name, points, kind, **values))
        return tuple(forces)

    def entry(self, item, path, kind) -> None:
        """Refuse the entry ``item`` (at ``path``) of the element kind ``kind`` unless it is a
        table of that kind's keys holding its required ones."""
        self.table(item, path, kind.keys, kind.required, kind.what)

    def read_elements(self, data) -> tuple:
        """The entries of the registered element kinds held in ``Model.elements`` (those that
        are no field of their own), kind by kind in the registry's order, each read by its kind."""
        elements = []
        for kind in element_kinds():
            if kind.field is not None:
                continue
            items = data.get(kind.table, [])
            self.array(items, (kind.table,), what=f"list of [[{kind.table}]] tables")
            for k, item in enumerate(items):
                self.entry(item, (kind.table, k), kind)
                elements.append(kind.read(self, item, (kind.table, k)))
        return tuple(elements)
