"""The reactions of closed loops: each closure's force and moment in {0} from its multipliers.

A closure between the points C1 and C2 (:class:`gpmegen.model.chain.Closure`) holds its rows as
position constraints, so that ``M q̈ - f = Dᵀλ`` gives each row's ``λ``. Its reaction on the
body of C2, from the body of C1 (the body of C1 takes the opposite), follows from the virtual
work of the rows ``δΦ·λ``:

- a coincidence row ``x_C2 - x_C1`` (``y``, ``z``): the force ``λ`` along {0}'s axis, at C2;
- a slide row ``(r_C2 - r_C1)·b₁``: the force ``λ b₁`` at C2 (``b₁`` an axis of C1's frame);
- an orientation row ``a₁·b₂``: the moment ``λ b₂ × a₁`` (``a₁`` an axis of C1's frame, ``b₂``
  one of C2's).

A dropped row (:meth:`gpmegen.model.file.reader.Reader.drop_vanishing`) contributes nothing. The
axes of the points' frames at the saved states come from the model's kinematics, printed once
as a straight-line Python function (:func:`frame_rotations`).
"""

from __future__ import annotations

import math

import numpy as np
from sympy.printing.pycode import PythonCodePrinter

from ...model.chain import AXES
from ...model.expand import expand
from ...symbolic.kinematics import forward
from ...symbolic.program import Program


def frame_rotations(model, points):
    """``R(q, p)``: the rotations (len(points), 3, 3) to {0} of the frames ``points`` are
    attached to, at the coordinates ``q`` (n,) and the parameter values ``p`` (in the model's
    order): the kinematics' program of intermediates for those entries alone, printed as Python."""
    program = Program()
    kin = forward(expand(model), program)
    entries = [e for point in points for e in kin.points[point].R]
    printer = PythonCodePrinter({"fully_qualified_modules": True, "standard": "python3"})
    lines = ["def rotations(q, p):"]
    lines += [f"    {s} = q[{j}]" for j, s in enumerate(kin.q)]
    lines += [f"    {param.symbol} = p[{k}]" for k, param in enumerate(model.parameters)]
    lines += [f"    {s} = {printer.doprint(e)}" for s, e in program.closure(entries)]
    lines.append(f"    return [{', '.join(printer.doprint(e) for e in entries) or ''}]")
    namespace = {"math": math}
    exec(compile("\n".join(lines), "<closure frames>", "exec"), namespace)   # names checked by expand()
    rotations = namespace["rotations"]
    return lambda q, p: np.asarray(rotations(list(map(float, q)), list(map(float, p))), float).reshape(-1, 3, 3)


def row_indices(model, closure) -> list[int]:
    """The indices of ``closure``'s rows among the model's constraints, in its order."""
    names = [c.name for c in model.constraints]
    return [names.index(closure.row_name(label)) for label in closure.rows]


def has_moment(closure) -> bool:
    """Whether the closure's type holds orientation (revolute, prismatic): a moment is reported."""
    return closure.kind != "point"


def reactions(model, q, lam, p) -> dict:
    """Closure name -> ``{"force": (k, 3), "moment": (k, 3)}`` (N, N·m in {0}; "moment" only
    where the type holds orientation): the reaction on the body of its second point from the body
    of its first, at the saved coordinates ``q`` (k, n) with the multipliers ``lam`` (k, m) and
    parameter values ``p``."""
    q, lam = np.atleast_2d(q), np.atleast_2d(lam)
    out = {}
    framed = [c for c in model.closures if any(label not in AXES for label in c.rows)]
    framed_names = {c.name for c in framed}
    points = list(dict.fromkeys(point for c in framed for point in c.points))
    rotate = frame_rotations(model, points) if points else None
    for closure in model.closures:
        rows = row_indices(model, closure)
        force, moment = np.zeros((len(q), 3)), np.zeros((len(q), 3))
        for k in range(len(q)):
            if not (np.all(np.isfinite(lam[k, rows])) and np.all(np.isfinite(q[k]))):
                force[k] = moment[k] = np.nan
                continue
            R = dict(zip(points, rotate(q[k], p))) if closure.name in framed_names else {}
            for label, value in zip(closure.rows, lam[k, rows]):
                if label in AXES:
                    force[k, AXES.index(label)] += value
                elif label.endswith("1"):
                    force[k] += value * R[closure.points[0]][:, AXES.index(label[0])]
                else:
                    a1 = R[closure.points[0]][:, AXES.index(label[0])]
                    b2 = R[closure.points[1]][:, AXES.index(label[1])]
                    moment[k] += value * np.cross(b2, a1)
        out[closure.name] = {"force": force, **({"moment": moment} if has_moment(closure) else {})}
    return out


def result_arrays(model, q, lam, p) -> dict:
    """The results' arrays of :func:`reactions`: ``closure_<name>_force`` and, where it has one,
    ``closure_<name>_moment`` (k, 3)."""
    return {f"closure_{name}_{kind}": values for name, wrench in reactions(model, q, lam, p).items()
            for kind, values in wrench.items()}


def acting(closure) -> dict:
    """The components of {0} ("x", "y", "z") along which the closure's kept rows can act, for
    "force" and "moment": a dropped row's component is zero throughout."""
    slides = any(label.endswith("1") for label in closure.rows)
    turns = any(len(label) == 2 and not label.endswith("1") for label in closure.rows)
    return {"force": list(AXES) if slides else [a for a in AXES if a in closure.rows],
            "moment": list(AXES) if turns else []}


def describe(model) -> list[dict]:
    """The closures as results metadata: name, points, type, axis, the rows kept (constraint
    names), whether a moment is reported and the components its rows act along (:func:`acting`)."""
    return [{"name": c.name, "points": list(c.points), "type": c.kind, "axis": c.axis,
             "rows": [c.row_name(label) for label in c.rows], "moment": has_moment(c), "acting": acting(c)}
            for c in model.closures]
