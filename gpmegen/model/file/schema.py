"""The model file's schema: the keys each table takes, the sections and shapes, the names a
label or a point's coordinate may have, and how a value's kind is said in a message."""

from __future__ import annotations

import re

from .. import elements
from ..chain import CircularSection, ISection, RectangularSection, StiffnessSection, TubeSection

SCHEMA = 1

LABEL = re.compile(r"^[A-Za-z0-9][A-Za-z0-9_]{0,31}$")
POINT_NAME = re.compile(r"^(vx|vy|vz|ax|ay|az|x|y|z)_(.+)$")
# Velocities ("v") and accelerations ("a") in constraint expressions: what they are, where they may appear.
RATES = {"v": ("velocity", "first- and second-order constraints; set order = 1 or 2"),
          "a": ("acceleration", "second-order constraints; set order = 2")}
TEXT_FORBIDDEN = re.compile(r'["\\]|\*/|[\x00-\x08\x0b-\x1f\x7f]')

# the tables of the element kinds beside the chain ([[forces]], [[closures]], [[controllers]], ...)
# are the registry's (gpmegen.model.elements), read with the keys each kind names
TOP_KEYS = elements.registry.FILE_KEYS
SIGNAL_KEYS = ("name", "expression", "table", "column")
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


def top_keys() -> tuple:
    """The keys a model file may hold at its top: its own and the element kinds' tables."""
    return TOP_KEYS + elements.tables()


def kind_of(value) -> str:
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


def number_text(value) -> str:
    value = float(value)
    return f"{value:g}"
