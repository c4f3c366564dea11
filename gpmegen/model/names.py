"""The names of a model: the pattern every user name matches (it reaches generated Python and C),
the words it may not be, and the SymPy symbols named after coordinates and points; nothing here
does algebra beyond naming symbols."""

from __future__ import annotations

import keyword
import re

import sympy as sp

from ..errors import ModelError

AXES = ("x", "y", "z")

# Names reach generated Python and C: a strict pattern, matched in full, keeps them safe there.
# A letter first also keeps them out of the generator's own names (gpmegen.symbolic.names),
# which all begin with an underscore.
NAME_PATTERN = re.compile(r"[A-Za-z][A-Za-z0-9_]{0,47}")
RESERVED_NAMES = frozenset(
    {"t", "q", "qd", "p", "pi", "out", "math", "np", "numpy",
     "sin", "cos", "tan", "exp", "sqrt", "log", "abs", "min", "max", "fmin", "fmax", "double",
     "int", "void", "return", "if", "else", "for", "while", "const", "def", "lambda", "None",
     "Abs", "Min", "Max", "atan2", "Integer", "Float", "Symbol", "Rational"}
    | set(keyword.kwlist)
    | {"auto", "break", "case", "char", "continue", "default", "do", "enum", "extern", "float", "goto",
       "inline", "long", "register", "restrict", "short", "signed", "sizeof", "static", "struct",
       "switch", "typedef", "union", "unsigned", "volatile", "isfinite", "fabs", "pow"}
)


# Names that stand bare in expressions (parameters, coordinates) must not shadow SymPy's own.
SYMPY_NAMES = frozenset({"E", "I", "N", "S", "O", "Q", "oo", "zoo", "nan", "beta", "gamma", "zeta"})


TIME = sp.Symbol("t", real=True)
GROUND_NAME = "ground"


def check_name(name: str, what: str, bare: bool = False, subject: tuple = ()) -> str:
    """Return ``name`` if it is a safe identifier, else raise ModelError naming ``what`` (about
    the field ``subject``). ``bare``: the name stands alone in expressions, so it must not
    shadow a SymPy name."""
    if not isinstance(name, str) or not NAME_PATTERN.fullmatch(name):
        raise ModelError(
            f"{what} {name!r} is not a valid name: use a letter followed by letters, digits or "
            f"underscores (at most 48 characters)", subject
        )
    if name in RESERVED_NAMES or name.startswith("_") or (bare and name in SYMPY_NAMES):
        raise ModelError(f"{what} {name!r} is reserved in generated code: choose another name", subject)
    return name


#: The solver library's C namespace (functions ``gpmegen_*``, macros ``GPMEGEN_*``). A model's
#: name is the prefix of its exported C names (``<name>_rk4``), so a name that is this word or
#: begins with it and ``_`` would declare the library's own names again.
SOLVER_NAMESPACE = "gpmegen"


def check_model_name(name: str, subject: tuple = ()) -> str:
    """Return ``name`` if it can name a model: a safe identifier (:func:`check_name`) outside the
    solver library's C namespace; else raise ModelError naming the fix."""
    check_name(name, "model name", subject=subject)
    if name.lower() == SOLVER_NAMESPACE or name.lower().startswith(SOLVER_NAMESPACE + "_"):
        raise ModelError(f"model name {name!r} would prefix its C names with '{name}_', the solver library's own "
                         f"(gpmegen_rk4, GPMEGEN_OK, ...): choose another name, e.g. 'my_{name}'", subject)
    return name


def symbol(name: str) -> sp.Symbol:
    """The real SymPy symbol of a parameter or coordinate name."""
    return sp.Symbol(name, real=True)


def velocity_symbol(coordinate: str) -> sp.Symbol:
    """Symbol of a coordinate's velocity in constraint expressions: ``<name>_dot``."""
    return sp.Symbol(f"{coordinate}_dot", real=True)


def acceleration_symbol(coordinate: str) -> sp.Symbol:
    """Symbol of a coordinate's acceleration in second-order constraints: ``<name>_ddot``."""
    return sp.Symbol(f"{coordinate}_ddot", real=True)


def point_symbols(point: str) -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """Symbols of a point's coordinates in {0}: ``x_P, y_P, z_P`` (m)."""
    return tuple(sp.Symbol(f"{a}_{point}", real=True) for a in AXES)


def point_velocity_symbols(point: str) -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """Symbols of a point's velocity in {0}: ``vx_P, vy_P, vz_P`` (m/s)."""
    return tuple(sp.Symbol(f"v{a}_{point}", real=True) for a in AXES)


def point_acceleration_symbols(point: str) -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """Symbols of a point's acceleration in {0} in second-order constraints: ``ax_P, ay_P, az_P``
    (m/s²)."""
    return tuple(sp.Symbol(f"a{a}_{point}", real=True) for a in AXES)


def axis_symbols(point: str, axis: str) -> tuple[sp.Symbol, sp.Symbol, sp.Symbol]:
    """Symbols of the unit vector along the ``axis`` ("x", "y" or "z") of the frame a point is
    attached to, in {0}: what a closure's orientation rows are written in. Their names hold a
    double underscore, which no expression of a model file may, so that they are a closure's
    alone."""
    return tuple(sp.Symbol(f"e{axis}__{point}__{a}", real=True) for a in AXES)


def as_expr(value) -> sp.Expr:
    """A number or SymPy expression as a SymPy expression."""
    return sp.sympify(value)


def free_symbols(expr) -> set:
    """The free symbols of ``expr``, none when it is not an expression (:func:`check_expression`
    says so)."""
    try:
        return sp.sympify(expr).free_symbols
    except (sp.SympifyError, TypeError):
        return set()


def check_expression(expr, allowed: set, where: str, subject: tuple):
    try:
        expr = sp.sympify(expr)
    except (sp.SympifyError, TypeError) as exc:
        raise ModelError(f"{where}: not a valid expression ({exc})", subject) from None
    if expr.has(sp.DiracDelta):
        raise ModelError(f"{where}: DiracDelta is an impulse, which generated code cannot evaluate; prescribe the "
                         f"motion it causes instead (a jump with Heaviside or Piecewise)", subject)
    if any(pw.args[-1].cond != sp.true for pw in expr.atoms(sp.Piecewise)):
        raise ModelError(f"{where}: a Piecewise has no last pair (value, True), so its value is undefined where "
                         f"no condition holds; end it with (value, True)", subject)
    unknown = sorted(str(s) for s in expr.free_symbols if s not in allowed)
    unreal = [name for name in unknown if name in {str(s) for s in allowed}]
    if unreal:   # SymPy holds Symbol('x') and Symbol('x', real=True) as two symbols
        raise ModelError(f"{where}: the symbol {unreal[0]} is not declared real; make it "
                         f"sympy.Symbol({unreal[0]!r}, real=True), as gpmegen's own names are", subject)
    if unknown:
        raise ModelError(f"{where}: unknown name(s) {', '.join(unknown)}; declare them as parameters or use "
                         f"names defined in the model", subject)
    return expr


class Names:
    """The one namespace of parameters, coordinates, bodies, points and constraints, with the
    path of each name's field (see :class:`gpmegen.errors.ModelError`)."""

    def __init__(self):
        self.seen: dict[str, tuple[str, tuple]] = {}

    def claim(self, name, what, path):
        check_name(name, what, bare=what in ("parameter", "coordinate", "signal", "controller state"), subject=path)
        if name in self.seen:
            other, other_path = self.seen[name]
            raise ModelError(f"{what} {name!r} duplicates the {other} of the same name; rename one", path,
                             other_path)
        self.seen[name] = (what, path)
