"""Reading one value of a model file: a table with its keys, a list, a string, a name, a number or
expression of the parameters, each refused at its file, line and field when it is not what the
schema asks for. A mixin of :class:`~gpmegen.model.file.reader.Reader`, whose state it reads."""

from __future__ import annotations

import difflib
import keyword
import math
import sys

import sympy as sp

from ...errors import ModelError
from ..chain import (
    check_name,
    symbol,
)
from ..requirements import requirements, violation
from ..rfem import check_nrfe
from .expressions import CONSTANTS, FUNCTIONS, TAKEN_NAMES, parse
from .locator import file_path, located
from .schema import (
    POINT_NAME,
    RATES,
    TEXT_FORBIDDEN,
    kind_of,
)


class ValueReading:
    """The typed reads of single values (a mixin of the Reader)."""

    # ---- structure ---------------------------------------------------------------------------
    def table(self, value, path, allowed=None, required=(), what="table"):
        """``value`` when it is a table of keys among ``allowed`` (any key when None) holding
        the ``required`` ones."""
        if not isinstance(value, dict):
            self.fail(path, f"expected a {what} (key = value lines or {{ ... }}), got {kind_of(value)}; "
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
            self.fail(path, f"expected a {what}, got {kind_of(value)}; write it as [ ... ]")
        if length is not None and len(value) != length:
            self.fail(path, f"expected {length} entries, got {len(value)}; write [{', '.join(['...'] * length)}]")
        return value

    def string(self, value, path, what="a string"):
        if not isinstance(value, str):
            self.fail(path, f"expected {what}, got {kind_of(value)}; write it in quotes")
        return value

    def text(self, value, path, multiline=False):
        """Free text that reaches comments and docstrings of the generated code."""
        self.string(value, path)
        if multiline:
            value = value.replace("\r\n", "\n")
        bad = TEXT_FORBIDDEN.search(value.replace("\n", "") if multiline else value)
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
            self.fail(path, f"expected a number or an expression string, got {kind_of(value)}; "
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
        for suffix, (quantity, orders) in (("_ddot", RATES["a"]), ("_dot", RATES["v"])):
            if name.endswith(suffix):
                base = name[:-len(suffix)]
                if base in self.coordinates and self.reading_drive:
                    return (f"{self.reading_drive} law may use positions and velocities, not the {quantity} {name} "
                            f"({self.reading_why}); remove it")
                if base in self.coordinates:
                    return f"the {quantity} {name} may appear only in {orders} or remove it"
                return f"{name!r}: {base!r} is not a coordinate; the coordinates are {coordinate_list}"
        point = POINT_NAME.match(name)
        if point:
            if point.group(2) in self.points:
                kind = point.group(1)[0]
                if kind in RATES and symbol(f"x_{point.group(2)}") in scope.values():
                    quantity, orders = RATES[kind]
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
