"""gpmegen: reference dynamics models (Generalized Programmed Motion Equations) of open chains
with flexible links, as generated NumPy and C code."""

__version__ = "0.1.0"

__all__ = ["load", "__version__"]


def __getattr__(name):
    # gpmegen.load is imported when first used, so that importing the package (as the console
    # command does before it can catch Ctrl-C) costs nothing.
    if name == "load":
        from .runtime.loader import load

        globals()["load"] = load
        return load
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
