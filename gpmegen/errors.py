"""Exception types, one per failure family.

Every message names the file, field or quantity at fault and what would fix it, so that the
command line can print it as one line without a traceback.
"""


class GpmegenError(Exception):
    """Base of all errors the package raises on purpose."""


class _AboutAField:
    """An error about one field of a model: ``subject`` is its path as a model file writes it
    (``("constraints", 0, "expression")``, ``("chain", 3, "point")``, ``("parameters", "g")``;
    array entries count from 0), or empty when no field is at fault; ``other`` the path of a
    second field the message is about (the first of two names that clash). A model file maps
    both to lines (:meth:`gpmegen.model.toml_file.ModelFile.locate`)."""

    def __init__(self, message, subject=(), other=()):
        super().__init__(message)
        self.subject = tuple(subject)
        self.other = tuple(other)


class ModelError(_AboutAField, GpmegenError):
    """The model description is invalid (a field, name, value or expression)."""


class DerivationError(_AboutAField, GpmegenError):
    """The symbolic derivation cannot proceed (e.g. a constraint independent of every coordinate)."""


class BuildError(GpmegenError):
    """Generated code cannot be written, compiled or loaded."""


class StaleModelError(BuildError):
    """A generated module does not match the current model or package version."""


class StateError(GpmegenError, ValueError):
    """A state given to a model's function (t, q or q̇) holds a NaN or an infinity
    (:mod:`gpmegen.runtime.finite`)."""


class RunSpecError(GpmegenError, ValueError):
    """A run's specification (:class:`gpmegen.analysis.run.runspec.RunSpec`) holds a value that no run
    takes (a negative step, an unknown method, a save interval that is no whole number of steps)."""


class MissingExtraError(GpmegenError):
    """An optional package that a feature needs is not installed; the message names the extra of
    gpmegen that installs it (:func:`gpmegen.extras.require`)."""


class StaticsError(GpmegenError):
    """Newton–Raphson statics did not converge."""


class SimulationError(GpmegenError):
    """The integration diverged or the constraints could not be held.

    ``partial`` holds what was computed up to the failure (a dict of arrays) when available.
    """

    def __init__(self, message, partial=None):
        super().__init__(message)
        self.partial = partial


class EvaluationError(SimulationError):
    """A generated function failed arithmetically (division by zero, overflow, a root or log of
    a negative number) at the parameter values and state it was given."""


class ExtrapolationError(GpmegenError):
    """Runs that cannot be extrapolated across discretizations: outputs not comparable between
    them, different models, fewer than two levels, a level that did not finish."""


class ModelWarning(UserWarning):
    """A model was read, but not as its file says (e.g. a URDF name renamed); the command line
    prints it as one line."""


class OutputError(GpmegenError):
    """An output cannot be written where it was asked: over one of the command's own inputs,
    over an earlier output without leave, over a folder gpmegen did not make, or into a folder
    that cannot be written."""


class UnwritableFolderError(OutputError, OSError):
    """A folder an output goes into cannot be written (an OSError too, for callers that treat
    any failed write alike); its text is the whole message."""

    def __str__(self):
        return self.strerror or super().__str__()
