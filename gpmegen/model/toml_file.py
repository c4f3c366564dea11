"""Model description files: a chain, its parameters, drives and programmed constraints in TOML.

:func:`read_file` reads a file of schema version 1 with the standard library's ``tomllib``
and returns its :class:`~gpmegen.model.Model` with the file's ``[initial]`` configuration, the
rows of its closures judged by a function its caller passes (they are judged from the derived
kinematics, a layer above this one): :mod:`gpmegen.analysis.run.model_files` is the public face
(``gpmegen.read_model_file``, ``gpmegen.load_model_file``). Nothing here writes files.
``docs/model-file.md`` is the user's guide; in short::

    schema = 1                            # required: the schema version
    name = "arm_nrfe{nrfe}"               # required: "{nrfe}" becomes the n_rfe in use
    description = "..."                  # optional
    nrfe = 3                              # default n_rfe of the flexible links (optional)
    gravity = [0, "-g", 0]                # m/s² in {0}, default [0, 0, 0]
    dependent = ["psi2", "x3"]            # one coordinate per constraint, or "auto" (default)

    [parameters]                          # in file order; the only names chain quantities use
    g = { value = 9.81, unit = "m/s^2", doc = "gravitational acceleration" }
    L3 = 0.5                              # bare number: unit "" and doc ""

    [[chain]]                             # chain elements from the base outwards, one kind each:
    joint = "theta1"                      #   joint: name, type, axis (+ stiffness, damping,
                                          #     prescribed = "law(t)": a constraint, joint dependent)
    type = "revolute"                     #     "revolute" (rad) | "prismatic" (m)
    axis = "y"                            #     "x" | "y" | "z" of the current frame
    [[chain]]
    translation = [0, "h1", 0]            #   offset: translation (m), then
    rotations = [["z", "pi/2"]]           #     rotations [[axis, angle (rad)], ...]
    [[chain]]
    body = "column"                       #   body: a shape, or mass/center/inertia
    shape = { type = "cylinder", mass = "m1", radius = "R1", length = "h1", axis = "y" }
    [[chain]]
    flexible = "2"                        #   flexible link: label (coordinates psi2_1, ...)
    length = "L2"
    section = { type = "rectangular", width = "b2", thickness = "t2" }
    density = "rho2"
    young_modulus = "E2"
    shear_modulus = "G2"                  #   + torsion_constant, nrfe, damping = [dψ, dθ, dφ],
                                          #     freedoms = ["psi", "theta", "phi"] (default; "u": stretch)
    [[chain]]
    point = "E"                           #   point: name, position (m) in the current frame
    position = ["L3", 0, 0]

    [[drives]]                            # generalized force on a coordinate: t, parameters, the state
    coordinate = "theta1"
    expression = "tdr0*Min(t/t0, 1)^3*(10 - 15*Min(t/t0, 1) + 6*Min(t/t0, 1)^2)"

    [[constraints]]                       # order 0: Φ(points, q, t) = 0; order 1: linear in
    name = "circle"                       # velocities; order 2: linear in accelerations, no gains;
                                          # Baumgarte gains alpha, beta
    expression = "x_E^2 + z_E^2 - r_Ea^2"
    order = 0
    alpha = "alpha_circle"
    beta = "beta_circle"

    [[forces]]                            # along the line of two points; F > 0 pushes them apart
    name = "cylinder"                     # spring-damper: F = k (L0 - L) - c dL/dt
    points = ["A", "E"]                   # (stiffness with rest_length, damping); actuator:
    type = "spring-damper"                # force = a law of t, parameters and the state
    stiffness = "k_c"
    rest_length = "L0"
    damping = "c_c"

    [initial]                             # start configuration; unnamed coordinates are 0
    q = { theta1 = 0, psi2 = "pi/4" }
    qd = { theta1 = 0.1 }                 # start velocities (rad/s, m/s); dependent ones are solved
    set = { r_Ea = "sqrt(x_E^2 + z_E^2)" } # parameters from the points at the locked statics of q

Body shapes: ``cylinder`` (mass, radius, length, axis: along ``axis`` from 0 to ``length``),
``bar`` (mass, length, width, thickness: along x, thickness along y, width along z), ``rod``
(mass, length, radius: along x), ``point_mass`` (mass, position); or ``mass``, ``center`` and
``inertia`` (3x3 about the centre of mass, kg·m²) in the body table itself. Sections:
``rectangular`` (width along the link's z, thickness along its y), ``circular`` (radius),
``tube`` (outer_diameter, inner_diameter), ``I`` (height, width, flange_thickness,
web_thickness), or ``stiffness`` (EIz, EIy, GJ, rhoA, optional rhoIz, rhoIy, EA; the link then
gives no density, moduli nor torsion_constant).

Quantities are numbers or expression strings. Chain quantities, gravity, Baumgarte gains and
initial values may use parameters; drives and constraints also ``t``, coordinates and points
``x_P, y_P, z_P``; drives (feedback laws) and constraints of ``order = 1`` also velocities
``<coordinate>_dot`` and ``vx_P, vy_P, vz_P``. Functions: sin cos tan exp log sqrt Abs Min Max atan2 Heaviside
Piecewise; constant pi; operators ``+ - * / ** ^ ( ) ,``; comparisons ``< <= > >=`` and ``True``
only as the conditions of ``Piecewise((value, t < T), ..., (value, True))`` pairs. Expressions
are checked lexically, by name and for where comparisons stand before SymPy's parser sees them,
with a namespace holding only those names: user text is never ``eval``-ed or ``sympify``-ed as
such.

Errors raise :class:`~gpmegen.errors.ModelError` as ``"<file>:<line>: <field>: <problem>;
<fix>"``; field paths count array entries from 0 (``chain[3].shape.mass`` is the fourth
``[[chain]]``). The model layer's errors say which field is at fault by its path
(``error.subject``, see :mod:`gpmegen.errors`); :meth:`ModelFile.locate` puts the same context
on an error raised later from a model read here (e.g. the derivation's ``DerivationError``)
from the text read once, :func:`gpmegen.analysis.run.model_files.locate` reads the file again to
do so.

Here: the readers of a file, reading the file's bytes as TOML. The reader lives in
:mod:`gpmegen.model.file` by concern: ``locator`` (lines by field path), ``expressions`` (the
safe parse and its checks), ``reader`` (schema -> Model), ``model_file`` (the result).
"""

import functools
import re
import tomllib
from pathlib import Path

from ..errors import ModelError
from ..user_files import read_user_file
from .expand import expand
from .file.controller_section import read_controller
from .file.model_file import ModelFile
from .file.reader import SCHEMA, Reader
from .rfem import check_nrfe
from .urdf import import_urdf

__all__ = ["ModelFile", "SCHEMA", "read_file", "read_urdf_file"]


def _parse(path, nrfe, row_kinds):
    """A reader for the file at ``path`` (closure rows judged by ``row_kinds``: :func:`read_file`)
    and the file's TOML data; a ModelError at the line of a file that cannot be read, decoded or
    parsed."""
    if nrfe is not None:
        check_nrfe(nrfe, f"{path}")
    file = str(path)
    raw = read_user_file(path, "the model file", ModelError)
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as exc:
        line = raw[:exc.start].count(b"\n") + 1
        raise ModelError(f"{file}:{line}: the file is not UTF-8 text; save it as UTF-8") from None
    try:
        data = tomllib.loads(text)
    except tomllib.TOMLDecodeError as exc:
        message = str(exc)
        m = re.search(r"\(at line (\d+), column (\d+)\)", message)
        line = int(m.group(1)) if m else max(1, text.count("\n") + 1)
        detail = re.sub(r"\s*\(at (?:line \d+, column \d+|end of document)\)", "", message)
        where = f"column {m.group(2)}" if m else "end of file"
        raise ModelError(f"{file}:{line}: TOML syntax error ({where}): {detail}; fix the syntax "
                         f"(see docs/model-file.md)") from None
    return Reader(path, text, nrfe, row_kinds), data


def read_file(path, row_kinds, nrfe: int | None = None, controller_model: str | None = None) -> ModelFile:
    """The model of a schema-1 TOML file with its ``[initial]`` configuration (a file whose
    name ends in ``.urdf``: :func:`read_urdf_file`).

    ``row_kinds(model)``: each closure row's name -> "zero" (it vanishes identically: dropped,
    with a warning), "constant" (a constant other than zero: refused at the closure's line) or ""
    (kept), judged from the chain's kinematics, which this layer does not derive: the caller
    above passes it (:func:`gpmegen.analysis.run.model_files.read_model_file`, the public face).
    ``nrfe`` replaces the file's default ``nrfe`` (flexible links that give their own keep it)
    and fills ``{nrfe}`` in the name. Raises ModelError ``"<file>:<line>: <field>: <problem>;
    <fix>"``. Validates with :func:`gpmegen.model.expand.expand`; writes nothing.
    ``controller_model``: a model file read in place of the ``[controller]`` table's ``model``."""
    if Path(path).suffix.lower() == ".urdf":
        return read_urdf_file(path)
    reader, data = _parse(path, nrfe, row_kinds)
    plain = functools.partial(_read_plain, row_kinds=row_kinds)
    return reader.read(data, lambda model: read_controller(reader, data, model, plain, controller_model))


def _read_plain(path, nrfe: int | None = None, *, row_kinds) -> ModelFile:
    """A controller model: the file read as :func:`read_file` does, but for its own
    ``[controller]`` table, which a controller model leaves out (as it does its drives), so a
    plant may name its own file as its controller."""
    if Path(path).suffix.lower() == ".urdf":
        return read_urdf_file(path)
    reader, data = _parse(path, nrfe, row_kinds)
    return reader.read(data)


def read_urdf_file(path) -> ModelFile:
    """The rigid model of the URDF file at ``path`` (:func:`gpmegen.model.urdf.import_urdf`:
    its whole tree of moving joints, gravity ``-g`` along z, its mimic joints following their
    leaders), starting at ``q = 0``, with its joints' limits."""
    robot = import_urdf(path)
    try:
        expand(robot.model)
    except ModelError as exc:
        raise ModelError(f"{path}: {exc}") from None
    return ModelFile(str(path), robot.model, initial=robot.start, limits=robot.limits)
