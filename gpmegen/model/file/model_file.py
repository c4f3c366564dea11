"""A model read from a file: the Model, the file's start configuration, and what locates a
later error about it in the file."""

from __future__ import annotations

import functools
from dataclasses import dataclass, field

from ...errors import GpmegenError, ModelError
from ..chain import Model, symbol
from ..requirements import evaluate
from .locator import Locator, located


@dataclass(frozen=True)
class ModelFile:
    """A model read from a file, with the file's start configuration.

    ``initial``: coordinate name -> value (SymPy expression of parameters) from ``[initial] q``;
    coordinates not named start at 0. ``actuators``: the coordinates whose inputs realize the
    constraints (empty: ideally)."""

    path: str
    model: Model
    initial: dict = field(default_factory=dict)
    source: str = field(default="", repr=False, compare=False)   # the file's text, for locate()
    actuators: tuple = ()

    @functools.cached_property
    def _locator(self) -> Locator:
        return Locator(self.source)

    def locate(self, error: GpmegenError) -> GpmegenError:
        """``error`` about this model (a ModelError or DerivationError whose ``subject`` is a
        field) as an error of the same type whose message starts with ``"<file>:<line>:
        <field>: "``, from the text read once."""
        return located(error, self.path, self._locator)

    def initial_values(self, params: dict | None = None) -> dict[str, float]:
        """The start configuration as numbers (rad, m), with the parameter defaults overridden
        by ``params``."""
        values = {p.symbol: p.default for p in self.model.parameters}
        values.update({symbol(name): float(value) for name, value in (params or {}).items()})
        numbers = {}
        for name, expr in self.initial.items():
            numbers[name] = evaluate(expr, values)
            if numbers[name] is None:
                raise ModelError(f"{self.path}: initial.q.{name} = {expr} is not a finite real number with the "
                                 f"parameter values in use; change those parameters or the expression")
        return numbers
