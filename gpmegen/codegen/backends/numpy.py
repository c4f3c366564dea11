"""The NumPy backend: ``model_numpy.py``, the readable reference of every generated model and the
oracle of the others' tests; the runtime imports it from the verified text."""

from __future__ import annotations

from ..printers import PythonPrinter
from .base import Backend


class NumpyBackend(Backend):
    name = "numpy"
    files = ("model_numpy.py",)
    folder = True
    opened = True

    def printer(self, parameters, signals=()):
        return PythonPrinter(parameters, signals)
