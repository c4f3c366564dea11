"""How a model's runs are shown: the axis labels of its coordinates (with units), the units of its
constraints, the figures of a source its own figures correspond to, its legend label, the tag,
colour and tag offset of its start point, and a prescribed coordinate of the end-effector drawn
beside its motion (a model file's ``[presentation]`` table, :mod:`gpmegen.model.file.presentation_section`).

Text for figures only: a :class:`~gpmegen.model.Model` keeps its presentation out of its
``repr`` and so out of its input hash, and no generated file reads it."""

from __future__ import annotations

from dataclasses import dataclass


@dataclass(frozen=True)
class Prescribed:
    """A coordinate of the end-effector that the model prescribes, drawn dotted in its figure:
    ``axis`` 0, 1 or 2 (x, y, z in {0}), its legend ``label``, and its ``value`` (m), a SymPy
    expression of the parameters and time ``t``."""

    axis: int
    label: str
    value: object


@dataclass(frozen=True)
class Presentation:
    """``label``: the runs' legend label ("": the model's name). ``coordinates``: (coordinate,
    axis label with its unit) pairs, the coordinates the joint-coordinates figure draws, in
    order. ``constraint_units``: (constraint, unit of its expression) pairs. ``figures``:
    (figure, the source's figure it corresponds to) pairs, the figures those whose caption may
    name one (:data:`gpmegen.model.file.presentation_section.FIGURES`). ``start_tag``,
    ``colour`` (one of the plot cycle's C0 ... C9), ``tag_offset`` ((dx, dy) in points, None:
    placed by the figure): the start point in the path figure. ``prescribed``: a
    :class:`Prescribed`, or None."""

    label: str = ""
    coordinates: tuple = ()
    constraint_units: tuple = ()
    figures: tuple = ()
    start_tag: str = ""
    colour: str = ""
    tag_offset: tuple | None = None
    prescribed: Prescribed | None = None

    def metadata(self) -> dict:
        """What a run's results metadata holds of it, under the names the figures read (see
        :func:`gpmegen.analysis.post.results.metadata`); what is not given is left out."""
        given = {
            "label": self.label,
            "joints": [name for name, _ in self.coordinates],
            "joint_labels": dict(self.coordinates),
            "constraint_units": dict(self.constraint_units),
            "figures": dict(self.figures),
            "start_tag": self.start_tag,
            "colour": self.colour,
            "tag_offset": self.tag_offset,
            "prescribed": ({"axis": self.prescribed.axis, "label": self.prescribed.label}
                           if self.prescribed is not None else None),
        }
        return {key: value for key, value in given.items() if value}
