"""The C backend: ``model.h`` and ``model.c``, the model's functions and the exported wrappers of
the solver library's loops, compiled and loaded by the runtime (its NumPy module supplies the
model's constants there)."""

from __future__ import annotations

from ..printers import CPrinter
from .base import Backend


class CBackend(Backend):
    name = "c"
    files = ("model.h", "model.c")
    folder = True
    opened = True
    split = True   # a long function is cut into blocks, which a compiler handles in bounded time

    def printer(self, parameters, signals=()):
        return CPrinter(parameters, signals)
