"""The optional packages a feature of gpmegen needs, each installed with an extra of the package
(``[project.optional-dependencies]`` in pyproject.toml), and :func:`require`, which imports one
where the feature starts or says in one line which extra installs it."""

import importlib
from types import ModuleType

from .errors import MissingExtraError

#: Each optional package, by the name it is imported as: what a message calls it, and the extra
#: of gpmegen that installs it.
EXTRAS = {
    "casadi": ("the casadi package", "casadi"),
    "control": ("python-control", "control"),
    "distributed": ("Dask", "cluster"),
}


def install_command(extra: str) -> str:
    """The command that installs gpmegen with ``extra``."""
    return f"pip install 'gpmegen[{extra}]'"


def require(package: str, feature: str) -> ModuleType:
    """The optional ``package`` (one of :data:`EXTRAS`) imported for ``feature`` (what needs it,
    as a message names it); :class:`MissingExtraError` in one line naming the extra to install
    when it is not installed."""
    what, extra = EXTRAS[package]
    try:
        return importlib.import_module(package)
    except ImportError:
        raise MissingExtraError(f"{feature} needs {what}, which is not installed: {install_command(extra)}") \
            from None
