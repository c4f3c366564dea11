"""gpmegen: reference dynamics models (Generalized Programmed Motion Equations) of open chains
with flexible links, as generated NumPy and C code.

What a user needs is importable from here (see :mod:`gpmegen.api`): ``gpmegen.load``,
``gpmegen.load_model_file``, ``gpmegen.statics``, ``gpmegen.simulate``, ``gpmegen.linearize``,
``gpmegen.metrics``,
``gpmegen.export_casadi``, ``gpmegen.export_fmu``, a run's specification ``gpmegen.RunSpec``,
the model's elements and the errors.
"""

# Nothing is imported here: the console command imports this package before it can catch Ctrl-C
# (gpmegen/entry.py), so every name, __version__ included, is looked up when first used. A type
# checker reads the names from where they are defined: it takes TYPE_CHECKING as true.
TYPE_CHECKING = False
if TYPE_CHECKING:
    from typing import Any

    from . import limits
    from .api import (
        Body,
        BuildError,
        Constraint,
        DerivationError,
        Drive,
        FlexibleLink,
        GpmegenError,
        Joint,
        Model,
        ModelError,
        Offset,
        Parameter,
        Point,
        Results,
        RunSpec,
        Signal,
        SimulationError,
        StaleModelError,
        StaticsError,
        export_casadi,
        export_fmu,
        import_urdf,
        invert,
        linearize,
        load,
        load_model_file,
        metrics,
        read_model_file,
        reference_model,
        simulate,
        statics,
        sweep,
        urdf_text,
    )
    from .version import __version__

__all__ = [
    "load", "statics", "simulate", "Results", "load_model_file", "read_model_file", "reference_model",
    "Model", "Parameter", "Joint", "Offset", "Body", "Point", "FlexibleLink", "Drive", "Signal",
    "Controller", "Constraint",
    "GpmegenError", "ModelError", "DerivationError", "BuildError", "StaleModelError", "StaticsError",
    "SimulationError", "limits", "__version__", "sweep",
    "import_urdf", "urdf_text", "linearize", "invert", "metrics", "export_casadi",
    "export_fmu", "RunSpec",
]


def __getattr__(name: str) -> "Any":
    if name == "__version__":
        from .version import __version__

        return __version__
    if name == "limits":  # a submodule: imported as one, never through gpmegen.api
        import importlib

        return importlib.import_module(f"{__name__}.limits")
    if name in __all__:
        from . import api

        value = getattr(api, name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
