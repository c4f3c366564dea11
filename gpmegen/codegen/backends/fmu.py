"""The model as an FMU (FMI 2.0, Model Exchange and Co-Simulation in one archive:
``gpmegen export --format fmu``).

This module renders what the archive holds but the binary (its files and the zip are made by
:mod:`gpmegen.analysis.export.fmu`, which compiles them and starts the case):

- ``modelDescription.xml``: the variables (below), each with a value reference assigned in a
  fixed order, the model's parameters with their units and descriptions, and the ModelStructure;
- ``fmu_model.h``, the header the FMI wrapper (``gpmegen/fmi``) takes of the model: the value
  references, the sizes and the start values, with the FMU's GUID made from the sources.

Variables (real unless said; value references in this order, from 0):

- the continuous states ``<coordinate>`` and ``<coordinate>_dot`` (rad or m, rad/s or m/s), then
  their derivatives ``der(<coordinate>)`` and ``der(<coordinate>_dot)``: q̇ and the GPME's q̈ with
  its Baumgarte terms, by the solver library's dense GPME solve;
- the parameters under their own names (tunable), then the inputs ``u_<coordinate>``: a
  generalized force (N·m or N) added to ``f`` on that coordinate, as the CasADi export's ``u``;
- the outputs: the named points' positions ``<point>.x``, ``.y``, ``.z`` (m) in {0}, the
  multipliers ``lambda_<constraint>`` of the ideal realization ``M q̈ - f - S u = Dᵀλ`` (least
  squares, as :func:`gpmegen.runtime.gpme.multipliers`) and the constraints' values
  ``phi_<constraint>``;
- the Co-Simulation's integrator: ``integrator_step`` (RK4's step, s), ``integrator_rtol`` and
  ``integrator_atol`` (DOP853's tolerances), and the integer ``integrator_method`` (0 RK4, 1 DOP853).

The start values are those :func:`layout` and :func:`config_header` are given: the exporter's,
those of the run ``gpmegen simulate`` would make.
"""

from __future__ import annotations

import hashlib
import math
import uuid
from dataclasses import dataclass
from importlib import resources

from ...errors import ModelError
from ...version import __version__
from .base import Backend

#: The FMI wrapper's files (package data ``gpmegen.fmi``) and the header this module writes for it.
WRAPPER = ("gpmegen_fmi2.c", "gpmegen_fmi2.h")
CONFIG = "fmu_model.h"
#: The model's generated files the FMU is compiled from.
MODEL_FILES = ("model.c", "model.h")
#: The Co-Simulation integrator's defaults: RK4 with steps of 0.1 ms; DOP853's tolerances.
METHODS = ("rk4", "dop853")
STEP, RTOL, ATOL = 1e-4, 1e-8, 1e-10
COORDINATE_UNITS = {"revolute": "rad", "prismatic": "m"}
FORCE_UNITS = {"revolute": "N.m", "prismatic": "N"}
#: Characters XML 1.0 allows (its Char production); any other is written as U+XXXX.
_XML_RANGES = ((0x9, 0x9), (0xA, 0xA), (0xD, 0xD), (0x20, 0xD7FF), (0xE000, 0xFFFD), (0x10000, 0x10FFFF))


class FmuBackend(Backend):
    """The FMU export: one archive ``<model>.fmu`` compiled from the C backend's files
    (:data:`MODEL_FILES`), gpmegen's solver library and the FMI wrapper; made by
    :func:`gpmegen.analysis.export.fmu.export`."""

    name = "fmu"
    files = ("NAME.fmu",)   # the one archive, at the path its caller names
    refuses = ("signals", "controllers")
    made = "an FMU"

    def templates(self) -> tuple[str, ...]:
        return ()   # it compiles the C backend's files, which it renders none of its own


@dataclass(frozen=True)
class Variable:
    """A ScalarVariable of modelDescription.xml."""

    name: str
    reference: int
    causality: str
    variability: str = "continuous"
    initial: str | None = None
    start: float | int | None = None
    unit: str = ""
    description: str = ""
    derivative: int | None = None   # index (from 1) of the state this is the derivative of
    kind: str = "Real"


def xml_text(text: str) -> str:
    """``text`` for an XML attribute in double quotes: markup characters escaped, line breaks and
    tabs as character references (kept through attribute normalization), characters XML 1.0
    cannot hold (controls, lone surrogates) as ``U+XXXX``."""
    out = []
    for char in str(text):
        code = ord(char)
        if not any(lo <= code <= hi for lo, hi in _XML_RANGES):
            out.append(f"U+{code:04X}")
        elif char in "&<>\"'\n\r\t":
            out.append({"&": "&amp;", "<": "&lt;", ">": "&gt;", '"': "&quot;", "'": "&apos;",
                        "\n": "&#10;", "\r": "&#13;", "\t": "&#9;"}[char])
        else:
            out.append(char)
    return "".join(out)


def _number(value) -> str:
    """A start value as XML writes it: the shortest text that reads back as the same double."""
    if isinstance(value, int):
        return str(value)
    if not math.isfinite(value):
        raise ModelError(f"a start value {value} is not finite; an FMU's start values are finite numbers")
    return repr(float(value))


def coordinate_kinds(model) -> dict:
    """Joint kind ("revolute", "prismatic") of each coordinate of the symbolic ``model``."""
    from ...model.chain import Joint
    from ...model.expand import expand

    return {e.name: e.kind for e in expand(model).elements if isinstance(e, Joint)}


@dataclass
class Layout:
    """The FMU's variables and where each kind starts among the value references."""

    variables: list
    references: dict   # first value reference of each kind (VR_Q, VR_QD, ...), and N_REALS, VR_METHOD
    states: list       # indices (from 1) of the states
    derivatives: list  # indices (from 1) of their derivatives
    outputs: list      # indices (from 1) of the outputs
    dependencies: dict  # index of an output or derivative -> the indices of the states and inputs it depends on


def layout(model, loaded, q0, qd0, inputs, lambda_units: dict) -> Layout:
    """The variables of ``model`` (symbolic), ``loaded`` (its generated model, bound to the run's
    parameter values) started at ``q0``, ``qd0``, with inputs on the coordinates ``inputs``."""
    kinds = coordinate_kinds(model)
    coordinates = loaded.coordinates
    docs = {p.name: p for p in model.parameters}
    unit = {name: COORDINATE_UNITS.get(kinds.get(name), "") for name in coordinates}
    variables, refs = [], {}

    def add(kind, items):
        refs[kind] = len(variables)
        variables.extend(items)

    add("VR_Q", [Variable(name, 0, "local", initial="exact", start=float(q0[i]), unit=unit[name],
                          description=f"coordinate {name}") for i, name in enumerate(coordinates)])
    add("VR_QD", [Variable(f"{name}_dot", 0, "local", initial="exact", start=float(qd0[i]),
                           unit=unit[name] and unit[name] + "/s", description=f"velocity of {name}")
                  for i, name in enumerate(coordinates)])
    n = len(coordinates)
    add("VR_DQ", [Variable(f"der({name})", 0, "local", unit=unit[name] and unit[name] + "/s", derivative=1 + i)
                  for i, name in enumerate(coordinates)])
    add("VR_DQD", [Variable(f"der({name}_dot)", 0, "local", unit=unit[name] and unit[name] + "/s2",
                            derivative=1 + n + i, description=f"acceleration of {name} (the GPME)")
                   for i, name in enumerate(coordinates)])
    add("VR_P", [Variable(name, 0, "parameter", "tunable", "exact", float(loaded.p[k]),
                          docs[name].unit if name in docs else "", docs[name].doc if name in docs else "")
                 for k, name in enumerate(loaded.parameter_names)])
    add("VR_U", [Variable(f"u_{name}", 0, "input", start=0.0, unit=FORCE_UNITS.get(kinds.get(name), ""),
                          description=f"generalized force on {name}, added to the model's") for name in inputs])
    add("VR_POINTS", [Variable(f"{point}.{axis}", 0, "output", unit="m",
                               description=f"{axis} of point {point} in {{0}}")
                      for point in loaded.points for axis in "xyz"])
    add("VR_LAMBDA", [Variable(f"lambda_{name}", 0, "output", unit=_unit(lambda_units.get(name, "")),
                               description=f"multiplier of constraint {name}") for name in loaded.constraint_names])
    add("VR_PHI", [Variable(f"phi_{name}", 0, "output", description=f"value of constraint {name}")
                   for name in loaded.constraint_names])
    add("VR_STEP", [Variable("integrator_step", 0, "parameter", "fixed", "exact", STEP, "s",
                             "Co-Simulation: RK4's step (the last one of a communication step shorter)"),
                    Variable("integrator_rtol", 0, "parameter", "fixed", "exact", RTOL, "",
                             "Co-Simulation: DOP853's relative tolerance"),
                    Variable("integrator_atol", 0, "parameter", "fixed", "exact", ATOL, "",
                             "Co-Simulation: DOP853's absolute tolerance")])
    refs["VR_RTOL"], refs["VR_ATOL"] = refs["VR_STEP"] + 1, refs["VR_STEP"] + 2
    refs["N_REALS"] = len(variables)
    variables = [Variable(**{**v.__dict__, "reference": k}) for k, v in enumerate(variables)]
    refs["VR_METHOD"] = 0   # the one Integer: its own value references
    variables.append(Variable("integrator_method", 0, "parameter", "fixed", "exact", 0, "",
                              "Co-Simulation: the integrator, 0 RK4 (integrator_step), 1 DOP853 (adaptive, "
                              "integrator_rtol and integrator_atol)", kind="Integer"))
    names = [v.name for v in variables]
    repeated = sorted({name for name in names if names.count(name) > 1})
    if repeated:
        raise ModelError(f"the FMU would have two variables named {repeated[0]!r}; rename the model's parameter, "
                         f"coordinate or point of that name")
    index = {v.name: k + 1 for k, v in enumerate(variables)}
    states = [index[v.name] for v in variables[refs["VR_Q"]:refs["VR_DQ"]]]
    derivatives = [index[v.name] for v in variables[refs["VR_DQ"]:refs["VR_P"]]]
    outputs = [index[v.name] for v in variables if v.causality == "output"]
    inputs_at = [index[v.name] for v in variables if v.causality == "input"]
    # q̇ is the velocity state alone; q̈ and λ take everything (the inputs enter f); a point's position
    # is a function of q, a constraint's value of q and q̇ (and t): neither is fed through from an input,
    # so that a tool closes a loop from them to the inputs without an algebraic loop
    dependencies = {derivatives[i]: [states[n + i]] for i in range(n)}
    dependencies.update({k: states + inputs_at for k in derivatives[n:]})
    dependencies.update({index[v.name]: states[:n] for v in variables[refs["VR_POINTS"]:refs["VR_LAMBDA"]]})
    dependencies.update({index[v.name]: states + inputs_at for v in variables[refs["VR_LAMBDA"]:refs["VR_PHI"]]})
    dependencies.update({index[v.name]: list(states) for v in variables[refs["VR_PHI"]:refs["VR_STEP"]]})
    return Layout(variables, refs, states, derivatives, outputs, dependencies)


def _unit(text: str) -> str:
    """A unit as the FMU names it: "generalized" (no unit known) is none; the middle dot a period."""
    return "" if text in ("", "generalized") else text.replace("·", ".").replace("²", "2").replace("³", "3")


def guid(texts: dict) -> str:
    """The FMU's GUID: made from the sha256 of what it is built from (the model's C, the wrapper's
    header with the variables' layout), so the same model gives the same GUID."""
    h = hashlib.sha256()
    for name in sorted(texts):
        h.update(name.encode() + b"\0" + texts[name].encode() + b"\0")
    return "{" + str(uuid.UUID(bytes=h.digest()[:16], version=4)) + "}"


def config_header(model_name, loaded, inputs, refs, q0, qd0, redundant_rows=False) -> str:
    """fmu_model.h: what the wrapper takes of the model (its names are identifiers; no free text);
    ``redundant_rows``: the model closes loops, whose rows may be more than its motion needs."""
    n_constraints = len(loaded.constraint_names)
    index = {name: k for k, name in enumerate(loaded.coordinates)}

    def array(kind, name, values):
        body = ", ".join(values) if values else "0"
        return f"static const {kind} {name}[] = {{{body}}};\n"

    lines = [
        f"/* The model {model_name} for the FMI wrapper gpmegen_fmi2.c; written by gpmegen {__version__}. */\n\n",
        "#ifndef GPMEGEN_FMU_CONFIG\n#define GPMEGEN_FMU_CONFIG\n\n#include \"model.h\"\n\n",
        "#define FMU_GUID \"@GUID@\"\n",
        f"#define N_DOF {len(loaded.coordinates)}\n#define N_CONSTRAINTS {n_constraints}\n",
        f"#define N_PARAMETERS {len(loaded.parameter_names)}\n#define N_POINTS {len(loaded.points)}\n",
        f"#define N_INPUTS {len(inputs)}\n#define REDUNDANT_ROWS {int(bool(redundant_rows))}\n",
        *(f"#define {name} {value}\n" for name, value in refs.items()),
        *(f"#define MODEL_{part.upper()} {model_name}_{part}\n"
          for part in ("gpme_terms", "constraint_terms", "baumgarte_gains", "drive_forces", "points")),
        f"#define FMU_CONSTRAINT_ORDERS {'CONSTRAINT_ORDERS_' if n_constraints else 'NULL'}\n",
        f"#define STEP_START {STEP!r}\n#define RTOL_START {RTOL!r}\n#define ATOL_START {ATOL!r}\n"
        f"#define METHOD_START 0\n\n",
        array("int", "CONSTRAINT_ORDERS_", [str(int(k)) for k in loaded.constraint_orders]),
        array("int", "INPUT_COORDINATES", [str(index[name]) for name in inputs]),
        array("double", "Q_START", [_number(float(x)) for x in q0]),
        array("double", "QD_START", [_number(float(x)) for x in qd0]),
        array("double", "P_START", [_number(float(x)) for x in loaded.p]),
        "\n#endif\n",
    ]
    return "".join(lines)


def model_description(model, identifier, fmu_guid, lay: Layout, c_files) -> str:
    """modelDescription.xml: both interfaces, the units, the variables and the ModelStructure."""
    units = sorted({v.unit for v in lay.variables if v.unit})
    attributes = (f'fmiVersion="2.0" modelName="{xml_text(model.name)}" guid="{fmu_guid}" '
                  f'description="{xml_text(model.description)}" generationTool="gpmegen {__version__}" '
                  f'variableNamingConvention="flat" numberOfEventIndicators="0"')
    sources = "".join(f'      <File name="{name}"/>\n' for name in c_files)
    lines = ['<?xml version="1.0" encoding="UTF-8"?>\n', f"<fmiModelDescription {attributes}>\n",
             f'  <ModelExchange modelIdentifier="{identifier}" canNotUseMemoryManagementFunctions="true" '
             f'completedIntegratorStepNotNeeded="true">\n    <SourceFiles>\n{sources}    </SourceFiles>\n'
             f"  </ModelExchange>\n",
             f'  <CoSimulation modelIdentifier="{identifier}" canHandleVariableCommunicationStepSize="true" '
             f'canNotUseMemoryManagementFunctions="true">\n    <SourceFiles>\n{sources}    </SourceFiles>\n'
             f"  </CoSimulation>\n"]
    if units:
        lines += ["  <UnitDefinitions>\n", *(f'    <Unit name="{xml_text(u)}"/>\n' for u in units),
                  "  </UnitDefinitions>\n"]
    lines += ['  <DefaultExperiment startTime="0" stopTime="1" tolerance="1e-08"/>\n', "  <ModelVariables>\n"]
    for k, v in enumerate(lay.variables, start=1):
        attrs = [f'name="{xml_text(v.name)}"', f'valueReference="{v.reference}"']
        if v.description:
            attrs.append(f'description="{xml_text(v.description)}"')
        attrs += [f'causality="{v.causality}"', f'variability="{v.variability}"']
        if v.initial:
            attrs.append(f'initial="{v.initial}"')
        inner = []
        if v.unit:
            inner.append(f'unit="{xml_text(v.unit)}"')
        if v.start is not None:
            inner.append(f'start="{_number(v.start)}"')
        if v.derivative is not None:
            inner.append(f'derivative="{v.derivative}"')
        lines.append(f"    <!-- {k} -->\n    <ScalarVariable {' '.join(attrs)}>\n"
                     f"      <{v.kind}{''.join(' ' + a for a in inner)}/>\n    </ScalarVariable>\n")
    lines.append("  </ModelVariables>\n  <ModelStructure>\n")
    def unknown(k, known):
        listed = "" if known is None else f' dependencies="{" ".join(map(str, known))}"'
        return f'      <Unknown index="{k}"{listed}/>\n'

    for tag, indices, known in (("Outputs", lay.outputs, lay.dependencies),
                                ("Derivatives", lay.derivatives, lay.dependencies),
                                ("InitialUnknowns", sorted(lay.outputs + lay.derivatives), {})):
        if indices:   # the initial unknowns without dependencies: on everything (the parameters too)
            lines += [f"    <{tag}>\n", *(unknown(k, known.get(k)) for k in indices), f"    </{tag}>\n"]
    lines.append("  </ModelStructure>\n</fmiModelDescription>\n")
    return "".join(lines)


def wrapper_sources() -> dict[str, str]:
    """The FMI wrapper's files, by name."""
    root = resources.files("gpmegen.fmi")
    return {name: root.joinpath(name).read_text(encoding="utf-8") for name in WRAPPER}
