"""Reading a model file's `[[chain]]`: joints (with their motors and series-elastic drive trains),
offsets, bodies and their shapes, flexible links and their sections (cut into rfes), points and
branches. A mixin of :class:`~gpmegen.model.file.reader.Reader`."""

from __future__ import annotations

import difflib
import math

import sympy as sp

from ... import limits
from ...errors import ModelError
from .. import shapes
from ..chain import (
    AXES,
    GROUND_NAME,
    JOINT_KINDS,
    MOTOR_SUFFIX,
    PAPER_FREEDOMS,
    TIME,
    Body,
    Branch,
    FlexibleLink,
    Joint,
    Motor,
    Offset,
    Point,
    SeriesElastic,
)
from ..requirements import evaluate
from ..rfem import check_freedoms, check_link, discretize, link_coordinates
from .locator import located
from .schema import (
    ELEMENT_KINDS,
    LABEL,
    SECTION_KEYS,
    SECTION_OPTIONAL,
    SECTION_TYPES,
    SHAPE_KEYS,
    SHAPE_OPTIONAL,
    kind_of,
    number_text,
)


class ChainReading:
    """The chain's elements read into Joints, Offsets, Bodies, FlexibleLinks, Points and Branches
    (a mixin of the Reader)."""

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
                self.fail(path, f"expected a table, got {kind_of(item)}; write each element as a [[chain]] table")
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
                                                   f"({number_text(second)} kg·m² about the centre); no "
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
        if not LABEL.match(label):
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
