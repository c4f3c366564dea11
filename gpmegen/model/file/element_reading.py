"""Reading what acts on a model file's chain: signals, drives and their laws, and the entries of
the element kinds (``[[forces]]``, ``[[closures]]``, ``[[controllers]]``, any kind registered),
each read by its kind (:mod:`gpmegen.model.elements`). A mixin of
:class:`~gpmegen.model.file.reader.Reader`."""

from __future__ import annotations

import difflib
from pathlib import Path

from ..chain import (
    MAX_SIGNALS,
    TIME,
    Drive,
    Signal,
    point_acceleration_symbols,
    point_symbols,
    point_velocity_symbols,
)
from ..elements import kinds as element_kinds
from ..law_checks import FORCE_OF_ACCELERATIONS
from .schema import (
    SIGNAL_KEYS,
)


class ElementReading:
    """Signals, drives and the element kinds' entries (a mixin of the Reader)."""

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

    def entry(self, item, path, kind) -> None:
        """Refuse the entry ``item`` (at ``path``) of the element kind ``kind`` unless it is a
        table of that kind's keys holding its required ones."""
        self.table(item, path, kind.keys, kind.required, kind.what)

    def read_kinds(self, data) -> tuple[dict, list]:
        """The entries of every element kind (:mod:`gpmegen.model.elements`), kind by kind in
        the registry's order, each read by its kind from its table's array: ``Model`` field ->
        the entries of the kinds that fill it, and the tables of the kinds that wrote constraint
        rows. As each kind is read, its entries join ``self.entries`` and its rows
        ``self.constraints``, for the kinds after it."""
        rows = []
        for kind in element_kinds():
            entries = tuple(kind.read_all(self, data.get(kind.table, [])))
            self.entries[kind.field] = self.entries.get(kind.field, ()) + entries
            written = tuple(kind.rows(entries))
            self.constraints += written
            rows += [kind.table] if written else []
        return dict(self.entries), rows
