"""gpmegen: reference dynamics models (Generalized Programmed Motion Equations) of open chains
with flexible links, as generated NumPy and C code."""

__version__ = "0.1.0"

from . import limits  # noqa: E402  (gpmegen.limits.lifted() lifts the bounds on resources)
from .runtime.loader import load  # noqa: E402

__all__ = ["limits", "load", "__version__"]
