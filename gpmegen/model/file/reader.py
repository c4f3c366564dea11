"""Model files to Models: the schema of a model file read table by table into a
:class:`~gpmegen.model.Model`, every failure at the file, line and field it is about.

The user's guide is ``docs/model-file.md``; :mod:`gpmegen.model.toml_file` is the public face."""

from __future__ import annotations

import difflib
import functools
import keyword
import math
import re
import sys
from pathlib import Path

import sympy as sp

from ... import limits
from ...errors import ModelError, ModelWarning
from .. import shapes
from ..chain import (
    AXES,
    CLOSURE_TYPES,
    FORCE_TYPES,
    GROUND_NAME,
    JOINT_KINDS,
    MAX_SIGNALS,
    MOTOR_SUFFIX,
    PAPER_FREEDOMS,
    TIME,
    Body,
    Branch,
    CircularSection,
    Closure,
    Constraint,
    Controller,
    Drive,
    FlexibleLink,
    ForceElement,
    ISection,
    Joint,
    Model,
    Motor,
    Offset,
    Parameter,
    Point,
    RectangularSection,
    SeriesElastic,
    Signal,
    StiffnessSection,
    TubeSection,
    acceleration_symbol,
    check_name,
    closure_rows,
    point_acceleration_symbols,
    point_symbols,
    point_velocity_symbols,
    symbol,
    velocity_symbol,
)
from ..expand import FORCE_KEYS, FORCE_OF_ACCELERATIONS, RATE_OF_ACCELERATIONS, expand
from ..requirements import evaluate, requirements, violation
from ..rfem import check_freedoms, check_link, check_nrfe, discretize, link_coordinates
from .expressions import CONSTANTS, FUNCTIONS, TAKEN_NAMES, parse
from .locator import Locator, field_text, file_path, located
from .model_file import ModelFile
from .urdf_section import chain_error, read_urdf_chain

SCHEMA = 1

_LABEL = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_]{0,31}$")
_POINT_NAME = re.compile(r"^(vx|vy|vz|ax|ay|az|x|y|z)_(.+)$")
# Velocities ("v") and accelerations ("a") in constraint expressions: what they are, where they may appear.
_RATES = {"v": ("velocity", "first- and second-order constraints; set order = 1 or 2"),
          "a": ("acceleration", "second-order constraints; set order = 2")}
_TEXT_FORBIDDEN = re.compile(r'["\\]|\*/|[\x00-\x08\x0b-\x1f\x7f]')

TOP_KEYS = ("schema", "name", "description", "nrfe", "gravity", "dependent", "parameters",
            "chain", "drives", "constraints", "closures", "forces", "initial", "actuators", "urdf", "signals",
            "controllers", "controller")
SIGNAL_KEYS = ("name", "expression", "table", "column")
CLOSURE_KEYS = ("name", "points", "type", "axis", "alpha", "beta")
ELEMENT_KINDS = ("joint", "body", "flexible", "point")
SHAPE_KEYS = {
    "cylinder": ("type", "mass", "radius", "length", "axis"),
    "bar": ("type", "mass", "length", "width", "thickness"),
    "rod": ("type", "mass", "length", "radius"),
    "point_mass": ("type", "mass", "position"),
}
SHAPE_OPTIONAL = {"point_mass": ("position",)}
SECTION_KEYS = {
    "rectangular": ("type", "width", "thickness"),
    "circular": ("type", "radius"),
    "tube": ("type", "outer_diameter", "inner_diameter"),
    "I": ("type", "height", "width", "flange_thickness", "web_thickness"),
    "stiffness": ("type", "EIz", "EIy", "GJ", "rhoA", "rhoIz", "rhoIy", "EA"),
}
SECTION_OPTIONAL = {"stiffness": ("rhoIz", "rhoIy", "EA")}
SECTION_TYPES = {"rectangular": RectangularSection, "circular": CircularSection, "tube": TubeSection,
                 "I": ISection, "stiffness": StiffnessSection}


def _kind_of(value) -> str:
    if isinstance(value, bool):
        return "a boolean"
    if isinstance(value, dict):
        return "a table"
    if isinstance(value, list):
        return "a list"
    if isinstance(value, str):
        return "a string"
    if isinstance(value, (int, float)):
        return "a number"
    return type(value).__name__


def _number_text(value) -> str:
    value = float(value)
    return f"{value:g}"


class Reader:
    """Reads one parsed file into a Model; every failure names the file, line and field."""

    def __init__(self, path, text: str, nrfe):
        self.file = str(path)
        self.source = text
        self.nrfe_argument = nrfe
        self.params: dict[str, sp.Symbol] = {}
        self.defaults: dict[sp.Symbol, sp.Float] = {}
        self.coordinates: list[str] = []
        self.points: list[str] = []
        self.moving_points: set[str] = set()
        self.labels: dict[str, tuple] = {}
        self.prescribed: dict[str, tuple] = {}   # coordinate -> (law of t, path of its field)
        self.reading_drive = ""   # names are read for a law ("a drive's", "an actuator's": positions and
        # velocities only)
        self.reading_why = FORCE_OF_ACCELERATIONS   # why that law may not read accelerations
        self.controller_states: dict[str, sp.Symbol] = {}   # a controller state's name -> its symbol
        self.signal_expressions: dict[str, sp.Expr] = {}   # a signal given by an expression: name -> it
        self.table_signals: dict[str, Signal] = {}   # a signal read from a table: name -> it

    @functools.cached_property
    def locator(self) -> Locator:
        """Line numbers, found when a message first needs one (a scan of the whole text)."""
        return Locator(self.source)

    # ---- errors ------------------------------------------------------------------------------
    def where(self, path) -> str:
        name = field_text(path)
        return f"{self.file}:{self.locator.line(path)}: " + (f"{name}: " if name else "")

    def error(self, path, message: str) -> ModelError:
        return ModelError(self.where(path) + message)

    def fail(self, path, message: str):
        raise self.error(path, message)

    # ---- structure ---------------------------------------------------------------------------
    def table(self, value, path, allowed=None, required=(), what="table"):
        """``value`` when it is a table of keys among ``allowed`` (any key when None) holding
        the ``required`` ones."""
        if not isinstance(value, dict):
            self.fail(path, f"expected a {what} (key = value lines or {{ ... }}), got {_kind_of(value)}; "
                            f"see docs/model-file.md")
        for key in value if allowed is not None else ():
            if key not in allowed:
                close = difflib.get_close_matches(key, allowed, 1)
                fix = f"did you mean {close[0]!r}?" if close else f"the keys of a {what} are {', '.join(allowed)}"
                self.fail(path + (key,), f"unknown key {key!r}; {fix}")
        for key in required:
            if key not in value:
                self.fail(path, f"missing required key {key!r}; add {key} = ... to this {what}")
        return value

    def array(self, value, path, length=None, what="list"):
        if not isinstance(value, list):
            self.fail(path, f"expected a {what}, got {_kind_of(value)}; write it as [ ... ]")
        if length is not None and len(value) != length:
            self.fail(path, f"expected {length} entries, got {len(value)}; write [{', '.join(['...'] * length)}]")
        return value

    def string(self, value, path, what="a string"):
        if not isinstance(value, str):
            self.fail(path, f"expected {what}, got {_kind_of(value)}; write it in quotes")
        return value

    def text(self, value, path, multiline=False):
        """Free text that reaches comments and docstrings of the generated code."""
        self.string(value, path)
        if multiline:
            value = value.replace("\r\n", "\n")
        bad = _TEXT_FORBIDDEN.search(value.replace("\n", "") if multiline else value)
        if bad or (not multiline and "\n" in value):
            what = repr(bad.group(0)) if bad else "a line break"
            self.fail(path, f"the text holds {what}, which generated "
                            f"code cannot carry in a comment; remove double quotes, backslashes, '*/', "
                            f"control characters" + ("" if multiline else " and line breaks"))
        return value

    def choice(self, value, path, options, what):
        if value not in options:
            close = difflib.get_close_matches(str(value), options, 1)
            hint = f"did you mean {close[0]!r}? " if close else ""
            self.fail(path, f"unknown {what} {value!r}; {hint}use one of {', '.join(options)}")
        return value

    def nrfe(self, value, path):
        """``value`` as a number of rfes (the rule: :func:`gpmegen.model.rfem.check_nrfe`)."""
        try:
            return check_nrfe(value, "", subject=path)
        except ModelError as exc:
            raise located(exc, self.file, self.locator) from None

    def name(self, value, path, what, bare=False):
        self.string(value, path, f"a {what} name in quotes")
        try:
            check_name(value, what, bare=bare)
        except ModelError as exc:
            raise self.error(path, str(exc).replace(": ", "; ", 1) if "; " not in str(exc) else str(exc)) from None
        if bare and keyword.iskeyword(value):
            self.fail(path, f"{what} {value!r} is a Python keyword; choose another name")
        if bare and value in TAKEN_NAMES:
            self.fail(path, f"{what} {value!r} is the name of a function or constant in expressions; "
                            f"choose another name")
        return value

    # ---- quantities and expressions ----------------------------------------------------------
    def quantity(self, value, path, scope):
        """A number or an expression string as a SymPy expression. Signs are checked on the
        whole model (:meth:`check_requirements`)."""
        if isinstance(value, bool) or not isinstance(value, (int, float, str)):
            self.fail(path, f"expected a number or an expression string, got {_kind_of(value)}; "
                            f"write e.g. 0.5 or \"L2/2\"")
        if isinstance(value, int):
            if abs(value) > sys.float_info.max:
                self.fail(path, f"integer of {len(str(abs(value)))} digits, beyond a double; give a value "
                                f"below 1e308 in size")
            expr = sp.Integer(value)
        elif isinstance(value, float):
            if not math.isfinite(value):
                self.fail(path, f"{value} is not a finite number; give a finite value")
            expr = sp.Float(value)
        else:
            expr = self.expression(value, path, scope)
        return expr

    def check_requirements(self, model):
        """The physical bounds of ``model`` (masses, sizes, moduli, gains, ...) with the parameter
        defaults, each reported at the line of its quantity."""
        values = {p.name: p.default for p in model.parameters}
        for need in requirements(model):
            problem = violation(need, values, "the parameter defaults")
            if problem:
                self.fail(file_path(need.subject, model.chain), problem)

    def expression(self, text, path, scope):
        """Parse ``text`` safely; ``scope`` maps the names it may use to their symbols."""
        try:
            return parse(text, scope, self.unknown)
        except ModelError as exc:
            raise self.error(path, str(exc)) from None

    def unknown(self, name, scope) -> str:
        """Why ``name`` is not in ``scope``, and what would fix it."""
        coordinate_list = ", ".join(self.coordinates[:12]) + (", ..." if len(self.coordinates) > 12 else "")
        if name in self.table_signals:
            return (f"signal {name!r} is read from a table, so it may appear only in drives (a constraint needs "
                    f"the time derivatives of its law, which a table does not give); write the signal as an "
                    f"expression of t, or use it in a drive")
        if name == "t":
            return "time t may appear only in drives and constraints; use parameters here"
        if name in self.params:
            return (f"parameter values are numbers and cannot refer to parameter {name!r}; write the "
                    f"number, or the expression where the value is used")
        if name in self.coordinates:
            return (f"coordinate {name!r} may appear only in drives and constraints; use parameters (and t in "
                    f"drives) here")
        for suffix, (quantity, orders) in (("_ddot", _RATES["a"]), ("_dot", _RATES["v"])):
            if name.endswith(suffix):
                base = name[:-len(suffix)]
                if base in self.coordinates and self.reading_drive:
                    return (f"{self.reading_drive} law may use positions and velocities, not the {quantity} {name} "
                            f"({self.reading_why}); remove it")
                if base in self.coordinates:
                    return f"the {quantity} {name} may appear only in {orders} or remove it"
                return f"{name!r}: {base!r} is not a coordinate; the coordinates are {coordinate_list}"
        point = _POINT_NAME.match(name)
        if point:
            if point.group(2) in self.points:
                kind = point.group(1)[0]
                if kind in _RATES and symbol(f"x_{point.group(2)}") in scope.values():
                    quantity, orders = _RATES[kind]
                    if self.reading_drive:
                        return (f"{self.reading_drive} law may use positions and velocities, not the point "
                                f"{quantity} {name} ({self.reading_why}); remove it")
                    return f"the point {quantity} {name} may appear only in {orders} or remove it"
                return f"point coordinate {name} may appear only in drives and constraints; remove it"
            known = ", ".join(self.points) or "none"
            return (f"{name!r} names no declared point {point.group(2)!r} (points: {known}); declare the "
                    f"point with a [[chain]] point = \"{point.group(2)}\" element or fix the name")
        close = difflib.get_close_matches(name, [*scope, *FUNCTIONS, *CONSTANTS], 1)
        hint = f"did you mean {close[0]!r}? or " if close else ""
        return f"unknown name {name!r}; {hint}declare it under [parameters]"

    # ---- sections ----------------------------------------------------------------------------
    def read(self, data) -> ModelFile:
        self.table(data, (), TOP_KEYS, what="model file")
        if "schema" not in data:
            self.fail(("schema",), "missing schema version; add schema = 1 at the top of the file")
        schema = data["schema"]
        if isinstance(schema, bool) or schema != SCHEMA:
            self.fail(("schema",), f"unsupported schema {schema!r}; this gpmegen reads schema = {SCHEMA}")
        if "name" not in data:
            self.fail(("name",), "missing model name; add name = \"my_model_nrfe{nrfe}\"")
        self.default_nrfe = None
        if "nrfe" in data:
            self.default_nrfe = self.nrfe(data["nrfe"], ("nrfe",))
        if self.nrfe_argument is not None:
            self.default_nrfe = self.nrfe_argument
        raw_name = self.string(data["name"], ("name",))
        if "{nrfe}" in raw_name and self.default_nrfe is None:
            self.fail(("name",), "the name uses {nrfe} but no nrfe is set; add nrfe = 3 or pass nrfe")
        name = raw_name.replace("{nrfe}", str(self.default_nrfe))
        try:
            check_name(name, "model name")
        except ModelError as exc:
            raise self.error(("name",), str(exc).replace(": ", "; ", 1)) from None
        description = self.text(data.get("description", ""), ("description",), multiline=True)

        parameters = self.read_parameters(data.get("parameters", {}))
        robot = None
        if "urdf" in data:
            chain, parameters, robot = read_urdf_chain(self, data, parameters, name)
        else:
            if "chain" not in data:
                self.fail(("chain",), "missing chain; add [[chain]] elements (joints, bodies, ...)")
            self.check_chain_size(data["chain"])
            chain = self.read_chain(data["chain"])
        up = [0, 0, "-g"] if "urdf" in data else [0, 0, 0]   # URDF robots are described z up
        gravity = self.read_vector(data.get("gravity", up), ("gravity",), self.params)
        signals = self.read_signals(data.get("signals", []))
        controllers = self.read_controllers(data.get("controllers", []), chain)
        drives = self.read_drives(data.get("drives", []))
        constraints = self.read_constraints(data.get("constraints", []))
        closures = self.read_closures(data.get("closures", []), constraints, chain)
        constraints += tuple(row for closure in closures for row in closure.constraints())
        dependent = self.read_dependent(data.get("dependent", "auto"))
        constraints, dependent = self.prescribe(constraints, dependent, bool(closures))
        if robot is not None and robot.constraints:   # the URDF's mimic joints follow their leaders
            constraints += robot.constraints
            dependent = None if dependent is None else tuple(dependent) + robot.dependent
        initial, initial_qd = self.read_initial(data.get("initial", {}))
        actuators = self.read_actuators(data.get("actuators", []), len(constraints))
        forces = self.read_forces(data.get("forces", []), self.taken_names(chain, constraints, closures))
        model = Model(
            name=name, parameters=parameters, chain=chain, gravity=gravity, drives=drives,
            constraints=constraints, dependent=dependent, description=description, closures=closures,
            signals=signals, forces=forces, controllers=controllers,
        )
        if closures:
            model = self.drop_vanishing(model, chain)
        self.check_requirements(model)
        try:
            expand(model)
        except ModelError as exc:
            if "urdf" in data and exc.subject[:1] == ("chain",):
                raise chain_error(self, exc) from None
            raise located(exc, self.file, self.locator, chain) from None
        if forces:
            self.check_forces(model)
        laws = {name: law for name, (law, _) in self.prescribed.items()}
        return ModelFile(self.file, model, initial, self.source, initial_qd, prescribed=laws, actuators=actuators,
                         limits=robot.limits if robot is not None else {})

    def check_chain_size(self, items):
        """Refuse, before reading it element by element, a chain whose build cannot finish
        (:func:`gpmegen.limits.check_build`): its coordinates are counted from the raw tables."""
        if not isinstance(items, list):
            return
        n_dof = 0
        for item in items:
            if isinstance(item, dict) and "joint" in item:
                n_dof += 2 if "series_elastic" in item else 1   # a series-elastic motor's coordinate
            elif isinstance(item, dict) and "flexible" in item:
                n_dof += link_coordinates(item.get("nrfe", self.default_nrfe), item.get("freedoms", PAPER_FREEDOMS))
        limits.check_build(n_dof, self.file, f"{len(items)} chain elements, ")

    def read_parameters(self, table):
        path = ("parameters",)
        self.table(table, path, what="parameters table")
        parameters = []
        for pname, entry in table.items():
            here = path + (pname,)
            self.name(pname, here, "parameter", bare=True)
            if isinstance(entry, dict):
                self.table(entry, here, ("value", "unit", "doc"), ("value",), "parameter")
                value, vpath = entry["value"], here + ("value",)
                unit = self.text(entry.get("unit", ""), here + ("unit",))
                doc = self.text(entry.get("doc", ""), here + ("doc",))
            else:
                value, vpath, unit, doc = entry, here, "", ""
            default = evaluate(self.quantity(value, vpath, {}), {})
            if default is None:
                self.fail(vpath, f"{value!r} is not a finite real number; give a value below 1e308 in size")
            parameters.append(Parameter(pname, default, unit, doc))
            self.params[pname] = symbol(pname)
            self.defaults[symbol(pname)] = sp.Float(default)
        return tuple(parameters)

    def read_vector(self, value, path, scope, length=3):
        self.array(value, path, length)
        return tuple(self.quantity(v, path + (k,), scope) for k, v in enumerate(value))

    def read_chain(self, items):
        self.array(items, ("chain",), what="list of [[chain]] tables")
        if not items:
            self.fail(("chain",), "the chain is empty; add [[chain]] elements")
        elements = []
        moving = False
        moving_of = {}   # point -> whether a joint moves it
        for k, item in enumerate(items):
            path = ("chain", k)
            if not isinstance(item, dict):
                self.fail(path, f"expected a table, got {_kind_of(item)}; write each element as a [[chain]] table")
            if "parent" in item:   # a branch from that point (checked when the model is expanded)
                parent = self.string(item["parent"], path + ("parent",))
                elements.append(Branch(parent))
                moving = parent != GROUND_NAME and moving_of.get(parent, True)
                item = {key: value for key, value in item.items() if key != "parent"}
            kinds = [key for key in ELEMENT_KINDS if key in item]
            if len(kinds) > 1:
                self.fail(path, f"one element cannot be both a {kinds[0]} and a {kinds[1]}; split it into "
                                f"two [[chain]] tables")
            if not kinds:
                if not ({"translation", "rotations"} & item.keys()):
                    close = [c for key in item for c in difflib.get_close_matches(key, ELEMENT_KINDS, 1)]
                    hint = f" (did you mean {close[0]!r}?)" if close else ""
                    self.fail(path, f"element of unknown kind{hint}; give joint, body, flexible or point, or "
                                    f"translation/rotations for a fixed offset")
                element = self.read_offset(item, path)
            else:
                element = getattr(self, f"read_{kinds[0]}")(item, path)
            if isinstance(element, FlexibleLink):
                for part in self.expand_link(element, path):
                    if isinstance(part, Joint):
                        moving = True
            elif isinstance(element, Joint):
                moving = True
            elif isinstance(element, Point):
                moving_of[element.name] = moving
                if moving:
                    self.moving_points.add(element.name)
            elements.append(element)
        return tuple(elements)

    def read_joint(self, item, path):
        keys = ("joint", "type", "axis", "stiffness", "rest", "damping", "prescribed", "motor", "series_elastic")
        self.table(item, path, keys, keys[:3], "joint")
        name = self.name(item["joint"], path + ("joint",), "coordinate", bare=True)
        kind = self.choice(item["type"], path + ("type",), JOINT_KINDS, "joint type")
        if isinstance(item["axis"], list):   # a unit vector of numbers, checked when the model is expanded
            axis = self.read_vector(item["axis"], path + ("axis",), {})
        else:
            axis = self.choice(item["axis"], path + ("axis",), AXES, "axis")
        extra = {}
        for key in ("stiffness", "rest", "damping"):
            if key in item:
                extra[key] = self.quantity(item[key], path + (key,), self.params)
        if "rest" in item and "stiffness" not in item:
            self.fail(path + ("rest",), f"joint {name!r} has a rest position but no spring; add stiffness = ... "
                                        f"or leave rest out")
        self.coordinates.append(name)
        extra.update(self.read_drive_train(item, path, name))
        if "prescribed" in item:
            here = path + ("prescribed",)
            self.prescribed[name] = (self.quantity(item["prescribed"], here, {**self.params, "t": TIME}), here)
        return Joint(name, kind, axis, **extra)

    def read_drive_train(self, item, path, name) -> dict:
        """A joint's ``motor = { inertia, gear }`` and ``series_elastic = { stiffness, damping }``
        as the Joint's fields; a series-elastic joint's motor coordinate ``<name>_motor`` joins
        the coordinates that drives and the initial state may name."""
        extra = {}
        if "motor" in item:
            here = path + ("motor",)
            table = self.table(item["motor"], here, ("inertia", "gear"), ("inertia",), "motor")
            extra["motor"] = Motor(*(self.quantity(table[key], here + (key,), self.params)
                                     for key in ("inertia", "gear") if key in table))
        if "series_elastic" in item:
            here = path + ("series_elastic",)
            if "motor" not in item:
                self.fail(here, f"joint {name!r} is series-elastic but has no motor; add motor = {{ inertia = ..., "
                                f"gear = ... }} to it")
            table = self.table(item["series_elastic"], here, ("stiffness", "damping"), ("stiffness",),
                               "series_elastic table")
            extra["series_elastic"] = SeriesElastic(*(self.quantity(table[key], here + (key,), self.params)
                                                      for key in ("stiffness", "damping") if key in table))
            self.coordinates.append(name + MOTOR_SUFFIX)
        return extra

    def read_offset(self, item, path):
        self.table(item, path, ("translation", "rotations"), what="offset")
        extra = {}
        if "translation" in item:
            extra["translation"] = self.read_vector(item["translation"], path + ("translation",), self.params)
        if "rotations" in item:
            rotations = []
            for k, rotation in enumerate(self.array(item["rotations"], path + ("rotations",))):
                here = path + ("rotations", k)
                self.array(rotation, here, 2, "[axis, angle] pair")
                axis = self.choice(rotation[0], here + (0,), AXES, "axis")
                rotations.append((axis, self.quantity(rotation[1], here + (1,), self.params)))
            extra["rotations"] = tuple(rotations)
        return Offset(**extra)

    def read_body(self, item, path):
        self.table(item, path, ("body", "shape", "mass", "center", "inertia"), ("body",), "body")
        name = self.name(item["body"], path + ("body",), "body")
        P = self.params
        if "shape" in item:
            if {"mass", "center", "inertia"} & item.keys():
                self.fail(path, "give either a shape or mass/center/inertia, not both; remove one")
            here = path + ("shape",)
            shape = self.table(item["shape"], here, ("type", "mass", "radius", "length", "axis", "width",
                                                     "thickness", "position"), ("type",), "shape")
            kind = self.choice(shape["type"], here + ("type",), tuple(SHAPE_KEYS), "shape type")
            optional = SHAPE_OPTIONAL.get(kind, ())
            self.table(shape, here, SHAPE_KEYS[kind],
                       tuple(k for k in SHAPE_KEYS[kind] if k not in optional), f"{kind} shape")

            size = {key: self.quantity(shape[key], here + (key,), P) for key in SHAPE_KEYS[kind]
                    if key not in ("type", "axis", "position")}
            quantities = shapes.shape_quantities(**size)
            if kind == "cylinder":
                axis = self.choice(shape["axis"], here + ("axis",), AXES, "axis")
                h = shapes.solid_cylinder(size["mass"], size["radius"], size["length"], axis)
            elif kind == "bar":
                h = shapes.bar(size["mass"], size["length"], size["width"], size["thickness"])
            elif kind == "rod":
                h = shapes.rod(size["mass"], size["length"], size["radius"])
            else:
                position = self.read_vector(shape.get("position", [0, 0, 0]), here + ("position",), P)
                h = shapes.point_mass(size["mass"], position)
        else:
            if "mass" not in item:
                self.fail(path, "a body needs a shape or a mass; add shape = { type = \"bar\", ... } or mass = ...")
            mass = self.quantity(item["mass"], path + ("mass",), P)
            center = self.read_vector(item.get("center", [0, 0, 0]), path + ("center",), P)
            rows = self.array(item.get("inertia", [[0, 0, 0]] * 3), path + ("inertia",), 3, "3x3 list")
            inertia = [self.read_vector(row, path + ("inertia", i), P) for i, row in enumerate(rows)]
            for i in range(3):
                for j in range(i):
                    if not self.same_quantity(inertia[i][j], inertia[j][i]):
                        self.fail(path + ("inertia", i, j), f"the inertia tensor is not symmetric "
                                                            f"({inertia[i][j]} ≠ {inertia[j][i]}); make [{i}][{j}] "
                                                            f"equal [{j}][{i}]")
            trace = sum(inertia[i][i] for i in range(3))
            scale = evaluate(abs(trace), self.defaults)
            for k, axis in enumerate(AXES):
                # ∫(axis)² dm about the centre: ½ tr I - I_kk
                second = evaluate(trace / 2 - inertia[k][k], self.defaults)
                if second is not None and scale is not None and second < -1e-12 * scale:
                    self.fail(path + ("inertia",), f"the inertia tensor gives a negative ∫{axis}² dm "
                                                   f"({_number_text(second)} kg·m² about the centre); no "
                                                   f"moment of inertia may exceed the sum of the other two")
            h = shapes.from_inertia_tensor(mass, center, inertia)
            quantities = ((("mass",), mass),) + tuple((("inertia", i, i), inertia[i][i]) for i in range(3))
        return Body(name, h, quantities)

    def same_quantity(self, a, b) -> bool:
        """Whether ``a`` and ``b`` are one quantity: equal as written, or equal in value at the
        parameter defaults and at a second, unrelated set of values. Bounded: user expressions
        are never simplified (``simplify((a+b+c+d)**100)`` does not end)."""
        if a == b:
            return True
        others = {s: v * (sp.Float("1.1") + sp.Float("0.013") * k) + sp.Float("0.01") * (k + 1)
                  for k, (s, v) in enumerate(self.defaults.items())}
        for values in (self.defaults, others):
            va, vb = evaluate(a, values), evaluate(b, values)
            if va is None or vb is None or not math.isclose(va, vb, rel_tol=1e-12):
                return False
        return True

    def read_flexible(self, item, path):
        keys = ("flexible", "length", "section", "density", "young_modulus", "shear_modulus",
                "torsion_constant", "nrfe", "damping", "freedoms")
        self.table(item, path, keys, keys[:3], "flexible link")
        label = self.string(item["flexible"], path + ("flexible",), "a label in quotes")
        if not _LABEL.match(label):
            self.fail(path + ("flexible",), f"label {label!r} is not valid: use letters, digits and underscores "
                                            f"(it names the coordinates psi{label}_1, ...)")
        if label in self.labels:
            first = self.locator.line(self.labels[label])
            self.fail(path + ("flexible",), f"label {label!r} is already used by the flexible link at line "
                                            f"{first}; give each flexible link its own label")
        self.labels[label] = path + ("flexible",)
        P = self.params
        extra = {key: self.quantity(item[key], path + (key,), P)
                 for key in ("density", "young_modulus", "shear_modulus", "torsion_constant") if key in item}
        if "damping" in item:
            extra["damping"] = self.read_vector(item["damping"], path + ("damping",), P, 3)
        if "freedoms" in item:
            freedoms = self.array(item["freedoms"], path + ("freedoms",), what="list of sde freedoms")
            try:
                extra["freedoms"] = check_freedoms(freedoms, f"flexible link {label!r}", path + ("freedoms",))
            except ModelError as exc:
                raise located(exc, self.file, self.locator) from None
        if "nrfe" in item:
            n_rfe = self.nrfe(item["nrfe"], path + ("nrfe",))
        elif self.default_nrfe is not None:
            n_rfe = self.default_nrfe
        else:
            self.fail(path, "no n_rfe for this flexible link; add nrfe = 3 here or at the top of the file")
        return FlexibleLink(label=label, length=self.quantity(item["length"], path + ("length",), P),
                            section=self.read_section(item["section"], path + ("section",)), n_rfe=n_rfe, **extra)

    def read_section(self, section, here):
        """A flexible link's ``section`` table as a section of :mod:`gpmegen.model.chain`."""
        self.table(section, here, tuple(dict.fromkeys(k for keys in SECTION_KEYS.values() for k in keys)), ("type",),
                   "section")
        kind = self.choice(section["type"], here + ("type",), tuple(SECTION_KEYS), "section type")
        optional = SECTION_OPTIONAL.get(kind, ())
        self.table(section, here, SECTION_KEYS[kind], tuple(k for k in SECTION_KEYS[kind] if k not in optional),
                   f"{kind} section")
        return SECTION_TYPES[kind](**{key: self.quantity(section[key], here + (key,), self.params)
                                      for key in SECTION_KEYS[kind][1:] if key in section})

    def expand_link(self, link, path):
        """The rfem elements of ``link`` (the flexible link at ``path``), their coordinates recorded."""
        try:
            check_link(link, path)
        except ModelError as exc:
            raise located(exc, self.file, self.locator) from None
        parts = discretize(link)
        self.coordinates += [part.name for part in parts if isinstance(part, Joint)]
        return parts

    def read_point(self, item, path):
        self.table(item, path, ("point", "position"), ("point",), "point")
        name = self.name(item["point"], path + ("point",), "point")
        position = self.read_vector(item.get("position", [0, 0, 0]), path + ("position",), self.params)
        self.points.append(name)
        return Point(name, position)

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
            self.table(item, path, ("state", "rate", "initial"), ("state", "rate"), "controller")
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
            self.table(item, path, ("name", "points", "type", "stiffness", "rest_length", "damping", "force"),
                       ("name", "points", "type"), "force")
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

    def check_forces(self, model):
        """Refuse a force element whose points coincide in every configuration (derived from
        the kinematics, as the build would)."""
        import dataclasses

        # The layer above the model's: the points are compared in the derived kinematics of the
        # model being read (an exception of the import contracts in pyproject.toml).
        from ...symbolic.forces import check_coincident
        from ...symbolic.kinematics import forward
        from ...symbolic.program import Program

        try:
            check_coincident(forward(expand(dataclasses.replace(model, dependent=None)), Program()), model.forces)
        except ModelError as exc:
            raise located(exc, self.file, self.locator) from None

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

    def taken_names(self, chain, constraints, closures=()) -> dict:
        """The file's names so far (parameters, coordinates, points, bodies, constraints, closures
        and their rows), each with what it names."""
        bodies = [part.name for element in chain
                  for part in (discretize(element) if isinstance(element, FlexibleLink) else (element,))
                  if isinstance(part, Body)]
        return {**{name: "parameter" for name in self.params}, **{name: "coordinate" for name in self.coordinates},
                **{name: "point" for name in self.points}, **{name: "body" for name in bodies},
                **{c.name: "constraint" for c in constraints},
                **{name: "closure" for closure in closures for name in (closure.name,)}}

    def read_closures(self, items, constraints, chain) -> tuple:
        """The ``[[closures]]`` as :class:`Closure` with all the rows of their type (the ones that
        vanish identically are dropped later: :meth:`drop_vanishing`); each name, and the names of
        the rows it writes, checked against every name of the file."""
        self.array(items, ("closures",), what="list of [[closures]] tables")
        taken = self.taken_names(chain, constraints)
        closures = []
        for k, item in enumerate(items):
            path = ("closures", k)
            self.table(item, path, CLOSURE_KEYS, ("name", "points"), "closure")
            name = self.name(item["name"], path + ("name",), "closure")
            kind = item.get("type", "point")
            if kind not in CLOSURE_TYPES:
                close = difflib.get_close_matches(str(kind), CLOSURE_TYPES, 1)
                hint = f"did you mean {close[0]!r}? " if close else ""
                self.fail(path + ("type",), f"closure {name!r}: unknown type {kind!r}; {hint}use "
                                            + ", ".join(f'"{t}"' for t in CLOSURE_TYPES))
            axis = item.get("axis")
            if kind == "point" and axis is not None:
                self.fail(path + ("axis",), f"closure {name!r}: a point closure takes no axis; remove it, or use "
                                            f"type = \"revolute\" or \"prismatic\"")
            if kind != "point" and axis is None:
                self.fail(path, f"closure {name!r}: a {kind} closure needs its axis; add axis = \"x\", \"y\" or "
                                f"\"z\" (of the frame of its first point)")
            if kind != "point":
                self.choice(axis, path + ("axis",), AXES, "closure axis")
            points = self.point_pair(item["points"], path + ("points",), f"closure {name!r}")
            gains = {}
            for key in ("alpha", "beta"):
                if key in item:
                    gains[key] = self.quantity(item[key], path + (key,), self.params)
                    value = evaluate(gains[key], self.defaults)
                    if value is not None and value < 0:
                        self.fail(path + (key,), f"closure {name!r}: negative {key} {value:g}; Baumgarte gains must "
                                                 f"be zero or positive")
            closure = Closure(name, points, kind, axis, closure_rows(kind, axis), **gains)
            named = [(f"closure {name!r}", name)] + [(f"the row {label!r} of closure {name!r}", closure.row_name(label))
                                                     for label in closure.rows]
            for what, text in named:
                if text in taken:
                    self.fail(path + ("name",), f"{what} is named {text!r}, and that name is already taken by a "
                                                f"{taken[text]}; rename the closure")
                try:
                    check_name(text, "closure row")
                except ModelError as exc:
                    raise self.error(path + ("name",), f"{exc}: shorten the closure's name") from None
                taken[text] = "closure" if text == name else "closure row"
            closures.append(closure)
        return tuple(closures)

    def drop_vanishing(self, model, chain):
        """``model`` without the rows of its closures that vanish identically (one warning line
        each, naming the closure and the row); a row whose value is a constant other than zero
        (the points can never meet along it) is refused."""
        import dataclasses
        import warnings

        # The layer above the model's: these rows are judged from the derived kinematics of the
        # model being read (an exception of the import contracts in pyproject.toml).
        from ...symbolic.constraints import constant_rows
        from ...symbolic.kinematics import forward
        from ...symbolic.program import Program

        try:
            flat = expand(dataclasses.replace(model, dependent=None))
        except ModelError:
            return model   # the full check reports it
        rows = [row for closure in model.closures for row in closure.constraints()]
        kinds = dict(zip((row.name for row in rows), constant_rows(forward(flat, Program()), rows)))
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

    def prescribe(self, constraints, dependent, closures=False):
        """``constraints`` and ``dependent`` with each prescribed joint's law written as the
        position constraint ``prescribed_<q>: q - law(t) = 0``, after the file's own, and ``q``
        dependent: the GPME prescribes a joint's motion by a programmed constraint with that
        joint's coordinate dependent. The one place this is written."""
        if not self.prescribed:
            return constraints, dependent
        taken = {c.name for c in constraints} | set(self.params) | set(self.coordinates) | set(self.points)
        written = []
        for name, (law, here) in self.prescribed.items():
            cname = f"prescribed_{name}"
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
            rows = "[[constraints]] and the rows of the [[closures]] kept" if closures else "[[constraints]]"
            self.fail(("dependent",), f"with prescribed joints, list the dependent coordinates of the {rows} "
                                      "(one per constraint; the prescribed joints are added after them): write "
                                      "dependent = [\"...\"]")
        return constraints + tuple(written), tuple(dependent or ()) + tuple(self.prescribed)

    def read_dependent(self, value):
        """None for "auto", else the list as a tuple (its entries: expand())."""
        if value == "auto":
            return None
        if not isinstance(value, list):
            self.fail(("dependent",), f"expected a list of coordinate names or \"auto\", got {_kind_of(value)} "
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
            self.fail(path, f"expected a list of coordinate names, got {_kind_of(value)} {value!r}; write "
                            f"actuators = [\"psi2\", \"x3\"]")
        for name in value:
            self.check_coordinate(name, path)
        if value and (len(value) != constraints or len(set(value)) != len(value)):
            self.fail(path, f"name {constraints} distinct coordinate(s), one input per constraint, got {len(value)}")
        return tuple(value)

    def read_initial(self, table):
        """``[initial] q`` and ``qd``: coordinate name -> quantity, for positions and velocities."""
        path = ("initial",)
        self.table(table, path, ("q", "qd"), what="initial table")
        return tuple(self.read_coordinate_values(table.get(key, {}), path + (key,)) for key in ("q", "qd"))

    def read_coordinate_values(self, table, path):
        """A table of coordinate name -> quantity (at ``path``)."""
        q = self.table(table, path, what="table of coordinates")
        values = {}
        for name, value in q.items():
            self.check_coordinate(name, path + (name,))
            values[name] = self.quantity(value, path + (name,), self.params)
        return values
