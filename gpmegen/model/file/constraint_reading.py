"""Reading a model file's programmed constraints, the dependent (prescribed) coordinates, the
actuators and the initial values; dropping the closures' rows that vanish identically. A mixin of
:class:`~gpmegen.model.file.reader.Reader`."""

from __future__ import annotations

import difflib

from ...errors import ModelError, ModelWarning
from ..chain import (
    TIME,
    Body,
    Constraint,
    FlexibleLink,
    acceleration_symbol,
    check_name,
    point_acceleration_symbols,
    point_symbols,
    point_velocity_symbols,
    symbol,
    velocity_symbol,
)
from ..rfem import discretize
from ..start_constants import StartConstants
from .schema import kind_of


def prescribed_name(coordinate: str) -> str:
    """The name of the constraint that prescribes the joint of ``coordinate``."""
    return f"prescribed_{coordinate}"


class ConstraintReading:
    """Constraints, dependent coordinates, actuators and initial values; the closures' rows that
    vanish identically (a mixin of the Reader)."""

    def constraint_scope(self, order):
        """The names a constraint of ``order`` may use: parameters, t, coordinates and point
        coordinates; velocities from order 1 on, accelerations at order 2."""
        scope = {**self.params, "t": TIME}
        highest = order if order in (1, 2) and not isinstance(order, bool) else 0   # other orders: expand()
        made = ((symbol, point_symbols), (velocity_symbol, point_velocity_symbols),
                (acceleration_symbol, point_acceleration_symbols))
        for of_coordinate, of_point in made[:highest + 1]:
            scope.update({of_coordinate(c).name: of_coordinate(c) for c in self.coordinates})
            scope.update({s.name: s for point in self.points for s in of_point(point)})
        return scope

    def read_constraints(self, items):
        self.array(items, ("constraints",), what="list of [[constraints]] tables")
        moving = {f(c) for c in self.coordinates for f in (symbol, velocity_symbol, acceleration_symbol)}
        for point in self.moving_points:
            moving |= {s for f in (point_symbols, point_velocity_symbols, point_acceleration_symbols) for s in f(point)}
        constraints = []
        for k, item in enumerate(items):
            path = ("constraints", k)
            self.table(item, path, ("name", "expression", "order", "alpha", "beta"), ("name", "expression"),
                       "constraint")
            name = self.name(item["name"], path + ("name",), "constraint")
            order = item.get("order", 0)   # its values: expand()
            expr = self.quantity(item["expression"], path + ("expression",),
                                 {**self.constraint_scope(order), **self.signal_expressions})
            if not (expr.free_symbols & moving):
                self.fail(path + ("expression",), f"the constraint {expr} = 0 does not depend on any coordinate "
                                                  f"(it names no coordinate and no point that a joint moves), so "
                                                  f"no motion can hold it; name a moving point or a coordinate")
            extra = {}
            for key in ("alpha", "beta"):
                if key in item:
                    if key == "beta" and order == 1:
                        self.fail(path + ("beta",), "beta applies to position constraints only (a first-order "
                                                    "constraint is stabilized by alpha); remove it")
                    if order == 2:
                        self.fail(path + (key,), f"{key} applies to position and first-order constraints only "
                                                 f"(a second-order constraint is held as it stands); remove it")
                    extra[key] = self.quantity(item[key], path + (key,), self.params)
            constraints.append(Constraint(name, expr, order, **extra))
        return tuple(constraints)

    def taken_names(self, constraints=(), closures=()) -> dict:
        """The file's names so far (parameters, coordinates, points, bodies, the names
        ``constraints``, ``closures`` and their rows), each with what it names."""
        bodies = [part.name for element in self.chain
                  for part in (discretize(element) if isinstance(element, FlexibleLink) else (element,))
                  if isinstance(part, Body)]
        return {**{name: "parameter" for name in self.params}, **{name: "coordinate" for name in self.coordinates},
                **{name: "point" for name in self.points}, **{name: "body" for name in bodies},
                **{name: "constraint" for name in constraints},
                **{name: "closure" for closure in closures for name in (closure.name,)}}

    def constraint_names(self) -> tuple:
        """The names of the model's constraints known so far: the file's, the rows of the
        element kinds read, and those the reader writes after them (each prescribed joint's,
        :meth:`prescribe`; a URDF's mimic joints')."""
        return (tuple(c.name for c in self.constraints) + tuple(prescribed_name(q) for q in self.prescribed)
                + tuple(c.name for c in self.mimic))

    def drop_vanishing(self, model):
        """``model`` without the rows of its closures that vanish identically (one warning line
        each, naming the closure and the row); a row whose value is a constant other than zero
        (the points can never meet along it) is refused. The rows are judged by the reader's
        ``row_kinds`` (each closure row's name -> "zero", "constant" or ""), which the caller
        derives from the chain's kinematics in the layer above this one
        (:func:`gpmegen.analysis.run.model_files.closure_row_kinds`)."""
        import dataclasses
        import warnings

        try:
            kinds = self.row_kinds(dataclasses.replace(model, dependent=None))
        except ModelError:
            return model   # the full check reports it
        closures, dropped = [], set()
        for k, closure in enumerate(model.closures):
            kept = []
            for label, row in zip(closure.rows, closure.constraints()):
                if kinds[row.name] == "constant":
                    self.fail(("closures", k, "points"), f"closure {closure.name!r}: its row {label!r} "
                                                         f"({closure.describe(label)} = 0) is a constant other than "
                                                         f"zero, so the points can never meet; place them where the "
                                                         f"loop can close")
                if kinds[row.name] == "zero":
                    dropped.add(row.name)
                    warnings.warn(f"closure {closure.name!r}: row {label!r} ({closure.describe(label)}) vanishes "
                                  f"identically on this chain and is dropped", ModelWarning, stacklevel=2)
                else:
                    kept.append(label)
            if not kept:
                self.fail(("closures", k), f"closure {closure.name!r}: every row vanishes identically, so it holds "
                                           f"nothing; remove it")
            closures.append(dataclasses.replace(closure, rows=tuple(kept)))
        return dataclasses.replace(model, closures=tuple(closures),
                                   constraints=tuple(c for c in model.constraints if c.name not in dropped))

    def prescribe(self, constraints, dependent, rows=()):
        """``constraints`` and ``dependent`` with each prescribed joint's law written as the
        position constraint ``prescribed_<q>: q - law(t) = 0``, after the file's own, and ``q``
        dependent: the GPME prescribes a joint's motion by a programmed constraint with that
        joint's coordinate dependent. The one place this is written. ``rows``: the tables of the
        element kinds whose rows are among ``constraints`` (``closures``), for the message."""
        if not self.prescribed:
            return constraints, dependent
        taken = {c.name for c in constraints} | set(self.params) | set(self.coordinates) | set(self.points)
        written = []
        for name, (law, here) in self.prescribed.items():
            cname = prescribed_name(name)
            try:
                check_name(cname, "the name of the constraint that prescribed writes")
            except ModelError as exc:
                raise self.error(here, f"{exc}: shorten the joint's name") from None
            if cname in taken:
                self.fail(here, f"prescribed writes the constraint {cname!r}, and that name is already taken in "
                                f"the file; rename the other one")
            if dependent is not None and name in dependent:
                self.fail(("dependent", dependent.index(name)), f"{name!r} is prescribed, which makes it dependent "
                                                                f"already; remove it from dependent")
            written.append(Constraint(cname, symbol(name) - law))
        if dependent is None and constraints:
            listed = "[[constraints]]" + "".join(f" and the rows of the [[{table}]] kept" for table in rows)
            self.fail(("dependent",), f"with prescribed joints, list the dependent coordinates of the {listed} "
                                      "(one per constraint; the prescribed joints are added after them): write "
                                      "dependent = [\"...\"]")
        return constraints + tuple(written), tuple(dependent or ()) + tuple(self.prescribed)

    def read_dependent(self, value):
        """None for "auto", else the list as a tuple (its entries: expand())."""
        if value == "auto":
            return None
        if not isinstance(value, list):
            self.fail(("dependent",), f"expected a list of coordinate names or \"auto\", got {kind_of(value)} "
                                      f"{value!r}; write dependent = [\"psi2\"] or dependent = \"auto\"")
        return tuple(value)

    def check_coordinate(self, name, path):
        """Refuse ``name`` (at ``path``) unless it is a coordinate of the chain read."""
        if name not in self.coordinates:
            close = difflib.get_close_matches(name, self.coordinates, 1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            self.fail(path, f"{name!r} is not a coordinate; {hint}the coordinates are {', '.join(self.coordinates)}")

    def read_actuators(self, value, constraints: int) -> tuple:
        """The coordinates whose inputs realize the constraints (none: ideally), one per
        constraint."""
        path = ("actuators",)
        if not isinstance(value, list) or not all(isinstance(name, str) for name in value):
            self.fail(path, f"expected a list of coordinate names, got {kind_of(value)} {value!r}; write "
                            f"actuators = [\"psi2\", \"x3\"]")
        for name in value:
            self.check_coordinate(name, path)
        if value and (len(value) != constraints or len(set(value)) != len(value)):
            self.fail(path, f"name {constraints} distinct coordinate(s), one input per constraint, got {len(value)}")
        return tuple(value)

    def read_initial(self, table):
        """``[initial] q`` and ``qd``: coordinate name -> quantity, for positions and velocities;
        and ``set``: the :class:`StartConstants` taken at the locked statics of ``q`` (None
        without ``set``), kept too as the file gives them in ``self.start_text`` (``at`` and
        ``values``: [name, number or expression string] pairs), which a built folder records."""
        path = ("initial",)
        self.table(table, path, ("q", "qd", "set"), what="initial table")
        q, qd = (self.read_coordinate_values(table.get(key, {}), path + (key,)) for key in ("q", "qd"))
        if "set" not in table:
            return q, qd, None
        values = self.table(table["set"], path + ("set",), what="table of parameters")
        scope = {**self.params, **{s.name: s for point in self.points for s in point_symbols(point)}}
        for name in values:
            if name not in self.params:
                close = difflib.get_close_matches(name, list(self.params), 1)
                hint = f"did you mean {close[0]!r}? " if close else ""
                self.fail(path + ("set", name), f"{name!r} is not a parameter; {hint}the start sets parameters "
                                                f"declared under [parameters]")
        self.start_text = {"at": [[name, value] for name, value in table.get("q", {}).items()],
                           "values": [[name, value] for name, value in values.items()]}
        return q, qd, StartConstants(
            at=tuple(q.items()),
            values=tuple((name, self.quantity(value, path + ("set", name), scope)) for name, value in values.items()))

    def read_coordinate_values(self, table, path):
        """A table of coordinate name -> quantity (at ``path``)."""
        q = self.table(table, path, what="table of coordinates")
        values = {}
        for name, value in q.items():
            self.check_coordinate(name, path + (name,))
            values[name] = self.quantity(value, path + (name,), self.params)
        return values
