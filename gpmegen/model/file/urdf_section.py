"""The ``urdf`` key of a model file: the chain read from a URDF, with the file's ``[[chain]]``
tables attached to its links (points, and links made flexible)."""

from __future__ import annotations

from importlib import metadata
from pathlib import Path

from ...errors import ModelError
from ..chain import FlexibleLink, Joint, Point
from ..rfem import discretize
from ..urdf import GRAVITY, FlexibleUrdfLink, import_urdf, unit_direction
from ..urdf_tree import read_tree

URDF_KEYS = ("file", "package", "tip")
ATTACHED_KINDS = ("point", "flexible")


def urdf_path(reader, value) -> Path:
    """The URDF file a model file names: ``urdf = "robot.urdf"`` (relative to the model file),
    ``{ file = ... }``, or ``{ package = "dist", file = "path/in/it.urdf" }`` for a URDF shipped
    by an installed Python distribution (found in its list of installed files)."""
    here = ("urdf",)
    if isinstance(value, str):
        value = {"file": value}
    reader.table(value, here, URDF_KEYS, ("file",), "urdf table")
    file = reader.string(value["file"], here + ("file",), "a file name in quotes")
    if "package" not in value:
        return Path(reader.file).parent / file
    package = reader.string(value["package"], here + ("package",), "a distribution name in quotes")
    try:
        files = metadata.files(package) or []
    except metadata.PackageNotFoundError:
        reader.fail(here + ("package",), f"the URDF comes from the Python distribution {package!r}, which is not "
                                         f"installed; install it (pip install {package})")
    found = [f for f in files if str(f).replace("\\", "/").endswith("/" + file.lstrip("/"))]
    if not found:
        reader.fail(here + ("file",), f"the distribution {package!r} holds no file ending in {file!r}; check the path")
    return Path(found[0].locate())


def read_urdf_chain(reader, data, parameters: tuple, name: str) -> tuple:
    """The chain of the model file's model ``name`` with a ``urdf`` key, its parameters (``g``
    added, 9.81 m/s², when the file gives no gravity and declares no ``g``) and the
    :class:`~gpmegen.model.urdf.ImportedRobot` (its mimic constraints and limits); the reader's
    coordinates and points recorded as :meth:`Reader.read_chain` records them."""
    path = urdf_path(reader, data["urdf"])
    tree = read_tree(path)
    tip = data["urdf"].get("tip") if isinstance(data["urdf"], dict) else None
    if tip is not None:
        reader.string(tip, ("urdf", "tip"), "a link name in quotes")
        if tip not in tree.links:
            reader.fail(("urdf", "tip"), f"the URDF {path.name} has no link {tip!r}; name one of "
                                         f"{', '.join(tree.links)}")
    flexible, extra = [], []
    items = reader.array(data.get("chain", []), ("chain",), what="list of [[chain]] tables")
    for k, item in enumerate(items):
        where = ("chain", k)
        reader.table(item, where, None, ("link",), "[[chain]] table of a URDF model")
        link = reader.string(item["link"], where + ("link",), "a link name in quotes")
        if link not in tree.links:
            reader.fail(where + ("link",), f"the URDF {path.name} has no link {link!r}; name one of "
                                           f"{', '.join(tree.links)}")
        kinds = [key for key in ATTACHED_KINDS if key in item]
        if len(kinds) != 1:
            reader.fail(where, "a [[chain]] table of a URDF model attaches one point or makes its link flexible; "
                               "give point = \"...\" or flexible = \"...\"")
        rest = {key: value for key, value in item.items() if key not in ("link", "along")}
        if kinds == ["point"]:
            extra.append((link, reader.read_point(rest, where)))
            continue
        if "along" not in item:
            reader.fail(where, "a flexible URDF link needs the direction it extends along in the link's frame; "
                               "add along = [1, 0, 0] (a unit vector)")
        along = tuple(float(v) for v in reader.read_vector(item["along"], where + ("along",), {}))
        try:
            unit_direction(along, f"flexible link on {link!r}")
        except ModelError as exc:
            reader.fail(where + ("along",), str(exc))
        if link in [f.link for f in flexible]:
            reader.fail(where + ("link",), f"link {link!r} is made flexible twice; keep one of the two tables")
        flexible.append(FlexibleUrdfLink(link, along, reader.read_flexible(rest, where)))
    if "gravity" not in data and "g" not in reader.params:
        parameters += (GRAVITY,)
        reader.params["g"] = GRAVITY.symbol
    robot = import_urdf(tree, tip=tip, flexible=tuple(flexible), extra=tuple(extra), parameters=parameters,
                        name=name)
    _record(reader, robot.model.chain)
    return robot.model.chain, parameters, robot


def _record(reader, chain):
    """The coordinates and points of ``chain`` in chain order, points after a joint as moving."""
    moving = False
    for element in chain:
        if isinstance(element, Joint):
            reader.coordinates.append(element.name)
            moving = True
        elif isinstance(element, FlexibleLink):
            reader.coordinates += [part.name for part in discretize(element) if isinstance(part, Joint)]
            moving = True
        elif isinstance(element, Point):
            if element.name not in reader.points:
                reader.points.append(element.name)
            if moving:
                reader.moving_points.add(element.name)


def chain_error(reader, error: ModelError) -> ModelError:
    """An error of the expanded model about its chain: the chain came from the URDF, whose lines
    the model file does not hold, so the message names the file only."""
    return ModelError(f"{reader.file}: {error}")
