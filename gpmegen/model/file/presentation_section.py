"""The model file's ``[presentation]`` table: how its runs are shown in figures
(:class:`gpmegen.model.presentation.Presentation`), each entry refused in one line when it is not
what the table takes. Its text reaches figures only, never generated code."""

from __future__ import annotations

import math
import re

from ..chain import AXES, TIME
from ..presentation import Prescribed, Presentation

PRESENTATION_KEYS = ("label", "coordinates", "constraint_units", "figures", "start_tag", "colour", "tag_offset",
                     "prescribed", "rigid")
#: What a ``[presentation.rigid]`` table may change for the file read with nrfe = 1.
RIGID_KEYS = ("label", "start_tag", "colour", "tag_offset")
PRESCRIBED_KEYS = ("axis", "label", "value")
#: The figures whose caption may name the figure of a source they correspond to
#: (:mod:`gpmegen.analysis.figures.plots`).
FIGURES = ("joint_coordinates", "end_effector", "path")
COLOUR = re.compile(r"C[0-9]")
LONGEST = 80   # characters of one text: a label, a unit, a caption
FARTHEST = 200  # points a start tag may sit from its point


def read_presentation(reader, value, constraints: tuple) -> Presentation:
    """The ``[presentation]`` table ``value`` of the file ``reader`` reads, whose coordinates
    the reader has recorded and whose ``constraints`` are read; with its ``rigid`` table's
    entries where the file is read with nrfe = 1."""
    path = ("presentation",)
    table = reader.table(value, path, PRESENTATION_KEYS, what="[presentation] table")
    entries = dict(table)
    rigid = entries.pop("rigid", None)
    if rigid is not None:
        reader.table(rigid, path + ("rigid",), RIGID_KEYS, what="[presentation.rigid] table")
    rigid = rigid if reader.default_nrfe == 1 else None
    entries.update(rigid or {})

    def at(key):   # where an entry was read: the rigid table's replaces the table's own
        return path + ("rigid", key) if rigid and key in rigid else path + (key,)

    names = [c.name for c in constraints]
    return Presentation(
        label=_label(reader, entries.get("label", ""), at("label")),
        coordinates=_pairs(reader, entries.get("coordinates", {}), path + ("coordinates",), reader.coordinates,
                           "coordinate"),
        constraint_units=_pairs(reader, entries.get("constraint_units", {}), path + ("constraint_units",), names,
                                "constraint"),
        figures=_pairs(reader, entries.get("figures", {}), path + ("figures",), FIGURES, "figure"),
        start_tag=_text(reader, entries.get("start_tag", ""), at("start_tag")),
        colour=_colour(reader, entries["colour"], at("colour")) if "colour" in entries else "",
        tag_offset=_offset(reader, entries["tag_offset"], at("tag_offset")) if "tag_offset" in entries else None,
        prescribed=_prescribed(reader, entries["prescribed"], path + ("prescribed",))
        if "prescribed" in entries else None,
    )


def _text(reader, value, path) -> str:
    """One line of text for a figure (mathtext allowed: figures draw what they cannot parse as
    it is)."""
    reader.string(value, path)
    if any(ord(c) < 32 or ord(c) == 127 for c in value):
        reader.fail(path, "the text holds a line break or control character; write one line for the figure")
    if len(value) > LONGEST:
        reader.fail(path, f"the text has {len(value)} characters, more than a figure's {LONGEST}; shorten it")
    return value


def _label(reader, value, path) -> str:
    """The legend label; ``{nrfe}`` in it becomes the n_rfe in use, as in the model's name."""
    text = _text(reader, value, path)
    if "{nrfe}" in text and reader.default_nrfe is None:
        reader.fail(path, "the label uses {nrfe} but no nrfe is set; add nrfe = 3 or pass nrfe")
    return text.replace("{nrfe}", str(reader.default_nrfe))


def _pairs(reader, value, path, known, what) -> tuple:
    """The table ``value`` of names among ``known`` (each a ``what``) to one line of text, as
    (name, text) pairs in the file's order."""
    reader.table(value, path, what=f"table of {what} = text")
    for name in value:
        if name not in known:
            listed = ", ".join(list(known)[:12]) + (", ..." if len(known) > 12 else "")
            reader.fail(path + (name,), f"{name!r} is not a {what} of the model; name one of {listed or 'none'}")
    return tuple((name, _text(reader, text, path + (name,))) for name, text in value.items())


def _colour(reader, value, path) -> str:
    reader.string(value, path, 'a colour in quotes, "C0" to "C9"')
    if not COLOUR.fullmatch(value):
        reader.fail(path, f"unknown colour {value!r}; use one of the plot cycle's colours \"C0\" to \"C9\"")
    return value


def _offset(reader, value, path) -> tuple:
    """(dx, dy) in points from the start point to its tag."""
    reader.array(value, path, 2, "list of two numbers [dx, dy] in points")
    for k, v in enumerate(value):
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not math.isfinite(v) or abs(v) > FARTHEST:
            reader.fail(path + (k,), f"expected a number of points from -{FARTHEST} to {FARTHEST}, got {v!r}; "
                                     f"write e.g. tag_offset = [8, -14]")
    return tuple(value)


def _prescribed(reader, value, path) -> Prescribed:
    """``{ axis = "y", label = "...", value = "expression of parameters and t" }``."""
    reader.table(value, path, PRESCRIBED_KEYS, PRESCRIBED_KEYS, "prescribed table")
    axis = reader.choice(value["axis"], path + ("axis",), AXES, "axis")
    label = _text(reader, value["label"], path + ("label",))
    return Prescribed(AXES.index(axis), label, reader.quantity(value["value"], path + ("value",),
                                                                {**reader.params, "t": TIME}))
