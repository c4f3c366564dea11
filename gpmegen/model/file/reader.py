"""Model files to Models: the schema of a model file read table by table into a
:class:`~gpmegen.model.Model`, every failure at the file, line and field it is about.

The user's guide is ``docs/model-file.md``; :mod:`gpmegen.model.toml_file` is the public face."""

from __future__ import annotations

import functools

import sympy as sp

from ...errors import ModelError
from ..chain import (
    Model,
    Parameter,
    Signal,
    check_name,
    symbol,
)
from ..elements import kinds as element_kinds
from ..expand import expand
from ..law_checks import FORCE_OF_ACCELERATIONS
from ..requirements import evaluate
from .chain_reading import ChainReading
from .constraint_reading import ConstraintReading
from .element_reading import ElementReading
from .locator import Locator, field_text, located
from .model_file import ModelFile
from .presentation_section import read_presentation
from .schema import (
    SCHEMA,
    top_keys,
)
from .urdf_section import chain_error, read_urdf_chain
from .values import ValueReading


class Reader(ValueReading, ChainReading, ElementReading, ConstraintReading):
    """Reads one parsed file into a Model; every failure names the file, line and field."""

    def __init__(self, path, text: str, nrfe, row_kinds):
        self.file = str(path)
        self.row_kinds = row_kinds   # a model's closure rows judged (ConstraintReading.drop_vanishing)
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
        self.chain: tuple = ()
        self.constraints: tuple = ()   # the file's programmed constraints, then the element kinds' rows
        self.mimic: tuple = ()   # the constraints of a URDF's mimic joints
        self.entries: dict[str, tuple] = {}   # a Model field -> the entries of the element kinds read so far
        self.start_text: dict | None = None   # [initial] q and set as the file gives them (read_initial)

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

    # ---- sections ----------------------------------------------------------------------------
    def read(self, data, laws=None) -> ModelFile:
        """The model file of the parsed ``data``; ``laws(model)``: the model with what is read
        apart added (the ``[controller]`` table's law), before the one expansion that checks it."""
        self.table(data, (), top_keys(), what="model file")
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
        self.chain, self.mimic = chain, robot.constraints if robot is not None else ()
        self.constraints = self.read_constraints(data.get("constraints", []))
        fields, rows = self.read_kinds(data)   # the element kinds' entries; their rows join the constraints
        drives = self.read_drives(data.get("drives", []))   # after the controllers, whose states they read
        dependent = self.read_dependent(data.get("dependent", "auto"))
        constraints, dependent = self.prescribe(self.constraints, dependent, rows)
        if self.mimic:   # the URDF's mimic joints follow their leaders
            constraints += self.mimic
            dependent = None if dependent is None else tuple(dependent) + robot.dependent
        initial, initial_qd, start = self.read_initial(data.get("initial", {}))
        actuators = self.read_actuators(data.get("actuators", []), len(constraints))
        presentation = read_presentation(self, data["presentation"], constraints) if "presentation" in data else None
        model = Model(
            name=name, parameters=parameters, chain=chain, gravity=gravity, drives=drives,
            constraints=constraints, dependent=dependent, description=description, signals=signals,
            start_constants=start, presentation=presentation, **fields,
        )
        for kind in element_kinds():
            model = kind.finish(self, model)
        if laws is not None:
            model = laws(model)
        self.check_requirements(model)   # the controller's believed bounds too (requirements._believed)
        try:
            expand(model)
        except ModelError as exc:
            if "urdf" in data and exc.subject[:1] == ("chain",):
                raise chain_error(self, exc) from None
            raise located(exc, self.file, self.locator, chain) from None
        laws = {name: law for name, (law, _) in self.prescribed.items()}
        return ModelFile(self.file, model, initial, self.source, initial_qd, prescribed=laws, actuators=actuators,
                         limits=robot.limits if robot is not None else {}, start_text=self.start_text)

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
































