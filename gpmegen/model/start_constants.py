"""Parameters a model sets at its start (a model file's ``[initial] set``): each an expression
of the other parameters and of the named points' positions ``x_P, y_P, z_P`` (m), evaluated at
the locked statics of the start configuration (the joints held at ``at``), so that programmed
constraints written with them hold there. The paper's arm sets its circle radius ``r_Ea`` and
the centre ``y_c`` of E's height this way."""

from __future__ import annotations

from dataclasses import dataclass

from ..errors import ModelError
from .names import point_symbols
from .requirements import evaluate


@dataclass(frozen=True)
class StartConstants:
    """``at``: (coordinate, expression of parameters) pairs, the configuration whose locked
    statics the values are taken at (coordinates not named: 0). ``values``: (parameter,
    expression of parameters and point coordinates) pairs, in the order they are set."""

    at: tuple = ()
    values: tuple = ()

    @property
    def names(self) -> tuple[str, ...]:
        """The parameters set at the start."""
        return tuple(name for name, _ in self.values)

    def check(self, model, coordinates, points) -> None:
        """Refuse, in one ModelError line, a value for a parameter ``model`` lacks, an expression
        reading a name that is neither a parameter nor a coordinate of the named ``points``, or a
        configuration of a name not among ``coordinates``."""
        params = {p.symbol for p in model.parameters}
        readable = params | {s for point in points for s in point_symbols(point)}
        for name, expression in self.at:
            if name not in coordinates:
                raise ModelError(f"the start holds {name!r}, which is not a coordinate of {model.name}; the "
                                 f"coordinates are {', '.join(coordinates)}", ("initial", "q", name))
            self._reads(name, expression, params, "is not a parameter; the start configuration reads parameters only",
                        ("initial", "q", name))
        for name, expression in self.values:
            if name not in model.parameter_names:
                raise ModelError(f"the start sets {name!r}, which is not a parameter of {model.name}; declare it "
                                 f"under [parameters] or remove it from [initial] set", ("initial", "set", name))
            self._reads(name, expression, readable, "is neither a parameter nor a named point's x_P, y_P, z_P; "
                        "fix the name or declare the point", ("initial", "set", name))
            self._reads(name, expression, readable - {p.symbol for p in model.parameters if p.name in self.names},
                        "the start also sets; write each value from the other parameters and the points",
                        ("initial", "set", name))

    @staticmethod
    def _reads(name, expression, readable, why, subject) -> None:
        unknown = sorted(str(s) for s in expression.free_symbols - readable)
        if unknown:
            raise ModelError(f"the start value of {name} reads {unknown[0]}, which {why}", subject)

    def configuration(self, params: dict) -> dict[str, float]:
        """``at`` as numbers (rad, m) at the parameter values ``params`` (symbol -> number)."""
        return {name: self._number(name, expression, params, "start configuration") for name, expression in self.at}

    def evaluated(self, points: dict, params: dict) -> dict[str, float]:
        """The values set: parameter name -> number, with the points' positions ``points``
        (name -> (x, y, z) in m) and the parameter values ``params`` (symbol -> number)."""
        given = dict(params)
        for name, position in points.items():
            given.update(zip(point_symbols(name), (float(v) for v in position)))
        return {name: self._number(name, expression, given, "value set at the start")
                for name, expression in self.values}

    @staticmethod
    def _number(name, expression, values, what) -> float:
        number = evaluate(expression, values)
        if number is None:
            raise ModelError(f"the {what} of {name}, {expression}, is not a finite real number at the start's locked "
                             f"statics; change the expression or the parameters it reads")
        return number
