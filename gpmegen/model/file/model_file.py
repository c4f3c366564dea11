"""A model read from a file: the Model, the file's start configuration, and what locates a
later error about it in the file."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

import sympy as sp

from ...errors import GpmegenError, ModelError
from ..chain import TIME, Model, symbol
from ..requirements import evaluate
from .locator import Locator, located


@dataclass(frozen=True)
class ModelFile:
    """A model read from a file, with the file's start configuration.

    ``initial``, ``initial_qd``: coordinate name -> value (SymPy expression of parameters) from
    ``[initial] q`` and ``[initial] qd``; coordinates not named start at 0. ``prescribed``:
    coordinate name -> its law (SymPy expression of ``t`` and parameters) for the joints given
    ``prescribed = "law(t)"``, whose constraints the model holds. ``actuators``: the coordinates
    whose inputs realize the constraints (empty: ideally). ``limits``: coordinate -> (lower,
    upper, velocity, unit) of the URDF's joints (:attr:`gpmegen.model.urdf.ImportedRobot.limits`),
    which runs are checked against afterwards. ``start_text``: the ``[initial] q`` and ``set`` of
    a file that sets parameters at its start, as the file gives them (``at``, ``values``: [name,
    number or expression string] pairs; None without ``set``), which a built folder records
    (:mod:`gpmegen.analysis.run.recorded_start`)."""

    path: str
    model: Model
    initial: dict = field(default_factory=dict)
    source: str = field(default="", repr=False, compare=False)   # the file's text, for locate()
    initial_qd: dict = field(default_factory=dict)
    prescribed: dict = field(default_factory=dict)
    actuators: tuple = ()
    limits: dict = field(default_factory=dict, compare=False)
    start_text: dict | None = field(default=None, compare=False)

    @functools.cached_property
    def _locator(self) -> Locator:
        return Locator(self.source)

    def locate(self, error: GpmegenError) -> GpmegenError:
        """``error`` about this model (a ModelError or DerivationError whose ``subject`` is a
        field) as an error of the same type whose message starts with ``"<file>:<line>:
        <field>: "``, from the text read once."""
        return located(error, self.path, self._locator, self.model.chain)

    def initial_values(self, params: dict | None = None) -> dict[str, float]:
        """The start configuration as numbers (rad, m), with the parameter defaults overridden
        by ``params``."""
        return self._numbers(self.initial, "q", params)

    def initial_velocities(self, params: dict | None = None) -> dict[str, float]:
        """The start velocities ``[initial] qd`` as numbers (rad/s, m/s), as :meth:`initial_values`."""
        return self._numbers(self.initial_qd, "qd", params)

    def _numbers(self, table, key, params):
        values = {p.symbol: p.default for p in self.model.parameters}
        values.update({symbol(name): float(value) for name, value in (params or {}).items()})
        numbers = {}
        for name, expr in table.items():
            numbers[name] = evaluate(expr, values)
            if numbers[name] is None:
                raise ModelError(f"{self.path}: initial.{key}.{name} = {expr} is not a finite real number with the "
                                 f"parameter values in use; change those parameters or the expression")
        return numbers

    def prescribed_motion(self, t: float = 0.0, params: dict | None = None) -> dict[str, tuple[float, float]]:
        """Each prescribed joint's position and velocity (rad or m, per s) at the time ``t`` (s):
        its law and the law's time derivative, with the parameter defaults overridden by
        ``params``; what a consistent start of the joint needs."""
        values = {p.symbol: p.default for p in self.model.parameters}
        values.update({symbol(name): float(value) for name, value in (params or {}).items()})
        values[TIME] = float(t)
        motion = {}
        for name, law in self.prescribed.items():
            pair = evaluate(law, values), evaluate(sp.diff(law, TIME), values)
            if None in pair:
                raise ModelError(f"{self.path}: the prescribed law of {name}, {law}, or its rate is not a finite "
                                 f"real number at t = {t:g} s with the parameter values in use; change the law or "
                                 f"those parameters")
            motion[name] = pair
        return motion
