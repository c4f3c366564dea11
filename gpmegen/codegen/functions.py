"""The functions every generated module holds, and their lowering to printable code.

Each function takes some of ``t`` (s), ``q``, ``qd`` (coordinates and velocities in the model's
order), ``a`` (given accelerations), ``lam`` (given constraint multipliers) and ``p`` (parameter
values in the model's order) and returns arrays. The same list feeds
the NumPy and the C templates, so both backends expose the same functions with the same shapes.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..model.chain import TIME
from ..symbolic import Derivation, names
from ..symbolic import transforms as _transforms
from ..symbolic.derivatives import gpme_jacobians
from ..symbolic.program import Program
from . import blocks as blocking
from .cse import eliminate


@dataclass(frozen=True)
class Output:
    name: str
    shape: tuple
    values: tuple  # flattened row-major expressions
    doc: str = ""  # what it holds, in which order and unit


@dataclass(frozen=True)
class Function:
    name: str
    doc: str
    inputs: tuple  # subset of ("t", "q", "qd", "a", "lam", "p"), in that order
    outputs: tuple
    batched: bool = False  # the C library also exports <name>_batch over many states
    hot: bool = False  # called by every GPME solve: compiled with the solve and RK4 (model.c.j2)


#: What each input is; ``{n}`` is the number of its entries.
INPUT_DOCS = {
    "t": "time (s)",
    "q": "({n},) coordinates in COORDINATES order",
    "qd": "({n},) velocities in COORDINATES order",
    "a": "({n},) accelerations in COORDINATES order",
    "lam": "({n},) constraint multipliers in CONSTRAINTS order, M qdd - f = D^T lam",
    "p": "({n},) parameter values in PARAMETERS order",
}


def arguments(fn: Function, n_dof: int, n_parameters: int, n_constraints: int = 0) -> tuple:
    """``(name, description)`` of each input and then each output of ``fn``, the one text both
    backends print: the NumPy docstring and the C comment."""
    sizes = {"t": 0, "q": n_dof, "qd": n_dof, "a": n_dof, "lam": n_constraints, "p": n_parameters}
    inputs = tuple((name, INPUT_DOCS[name].format(n=sizes[name])) for name in fn.inputs)
    outputs = tuple((out.name, f"{out.shape} {out.doc}" + (", row-major" if len(out.shape) >= 2 else ""))
                    for out in fn.outputs)
    return inputs + outputs


@dataclass(frozen=True)
class Lowered:
    """A function ready for a template: used inputs, straight-line body, output code."""

    function: Function
    time_used: bool
    q_used: tuple   # (index, local name)
    qd_used: tuple
    p_used: tuple
    body: tuple     # (local name, code)
    outputs: tuple  # (Output, tuple of code strings)
    blocks: tuple = ()  # the C backend's blocks (codegen/blocks.py); () when the function is one block
    workspace: int = 0  # values passed between its blocks
    a_used: tuple = ()    # (index, local name), as q_used
    lam_used: tuple = ()


def _out(name, matrix, doc, vector=False):
    """An output; ``vector``: a column (n,) rather than a matrix (r, c), even when 1 x 1."""
    m = sp.Matrix(matrix)
    return Output(name, (m.shape[0],) if vector else tuple(m.shape), tuple(m), doc)


def _nested(name, blocks, shape, doc):
    """An output of nested lists of 4x4 matrices (``shape`` ends in 4, 4), flattened row-major."""
    def flat(x):
        return tuple(x) if isinstance(x, sp.MatrixBase) else tuple(v for part in x for v in flat(part))
    return Output(name, shape, flat(blocks), doc)


def transform_functions(d: Derivation, kinds) -> list[Function]:
    """The functions of the body transforms ``kinds`` (of :data:`gpmegen.symbolic.transforms.KINDS`)."""
    kin = d.kinematics
    n_bodies, n = len(kin.bodies), len(kin.q)
    fns = []
    if "T" in kinds:
        fns.append(Function("transforms", "Body transforms T = [R p; 0 1] from each body's frame to {0}.", ("q", "p"),
                            (_nested("T", [_transforms.transform(b) for b in kin.bodies], (n_bodies, 4, 4),
                                     "T of each body in BODIES order (p in m)"),)))
    if "T_i" in kinds or "T_ij" in kinds:
        first = _transforms.first_derivatives(kin)
    if "T_i" in kinds:
        fns.append(Function("transform_derivatives", "First derivatives T_i = dT/dq_i = Delta_i T of the body "
                            "transforms.", ("q", "p"),
                            (_nested("T_i", first, (n_bodies, n, 4, 4),
                                     "T_i[b, i] = dT_b/dq_i, bodies in BODIES order, i in COORDINATES order"),)))
    if "T_ij" in kinds:
        fns.append(Function("transform_second_derivatives", "Second derivatives T_ij = d2T/dq_i dq_j = "
                            "Delta_i Delta_j T (i <= j) of the body transforms.", ("q", "p"),
                            (_nested("T_ij", _transforms.second_derivatives(kin, first), (n_bodies, n, n, 4, 4),
                                     "T_ij[b, i, j] = d2T_b/dq_i dq_j, symmetric in i, j"),)))
    return fns


def given_accelerations(d: Derivation) -> tuple:
    """The symbols of input ``a`` (n,), in COORDINATES order."""
    return tuple(names.acceleration(name) for name in d.chain.coordinates)


def given_multipliers(d: Derivation) -> tuple:
    """The symbols of input ``lam`` (m,), in CONSTRAINTS order."""
    return tuple(names.multiplier(name) for name in d.constraints.names)


def model_functions(d: Derivation, transforms=_transforms.DEFAULT, jacobians: bool = False) -> list[Function]:
    """The generated functions of a derivation, in a fixed order; ``transforms``: the body
    transforms to generate (see :mod:`gpmegen.symbolic.transforms`); ``jacobians``: with the
    derivatives of the GPME residuals (:func:`_jacobian_function`), built on request."""
    dyn, con, kin = d.dynamics, d.constraints, d.kinematics
    points = sp.Matrix([[*kin.points[name].position] for name in kin.points]) if kin.points else sp.zeros(0, 3)
    qd = sp.Matrix(kin.qd)
    kinetic = (qd.T * dyn.mass_matrix * qd)[0, 0] / 2
    mass = _out("M", dyn.mass_matrix, "mass matrix M(q), symmetric")
    forces = _out("f", dyn.forces, "generalized forces f = Q(t, q, qd) + h(q, qd) - g(q) - C q - damping", vector=True)
    constraint_outputs = (
        _out("phi", con.value, "constraint values phi in CONSTRAINTS order", vector=True),
        _out("phi_rate", con.rate, "their rates d(phi)/dt", vector=True),
        _out("jacobian", con.jacobian, "constraint matrix D, one row per constraint, one column per coordinate"),
        _out("gamma", con.gamma, "the rows' terms free of qdd: D qdd + gamma = 0 on the constraints",
             vector=True),
    )
    fns = [
        Function("mass_matrix", "Mass matrix M(q).", ("q", "p"), (mass,), batched=True),
        Function("forces", "Generalized forces: drive, velocity, gravity, spring and damping terms.",
                 ("t", "q", "qd", "p"), (forces,), batched=True),
        Function("static_residual", "Gravity and spring terms g(q) + C q.", ("q", "p"),
                 (_out("r", dyn.gravity_terms + dyn.spring_forces, "g(q) + C q", vector=True),)),
        Function("stiffness_jacobian", "Tangent stiffness K = d(g + C q)/dq, from T_ij.", ("q", "p"),
                 (_out("K", dyn.stiffness_jacobian, "K[i, j] = d(g + C q)_i / dq_j"),)),
        Function("drive_forces", "Drive forces Q(t, q, qd): the drives' laws, feedback included.",
                 ("t", "q", "qd", "p"),
                 (_out("Q", dyn.drive_forces, "drive forces Q(t, q, qd)", vector=True),), hot=True),
        Function("points", "Positions of the named points in {0}.", ("q", "p"),
                 (Output("P", (points.shape[0], 3), tuple(points),
                         "positions (m), one row per point in POINTS order: x, y, z in {0}"),)),
        Function("constraint_terms", "phi, phi_rate, D, gamma of the programmed constraints.",
                 ("t", "q", "qd", "p"), constraint_outputs, batched=True),
        Function("baumgarte_gains", "Baumgarte gains alpha, beta of each constraint.", ("p",),
                 (_out("alpha", con.alpha, "alpha per constraint, in CONSTRAINTS order", vector=True),
                  _out("beta", con.beta, "beta per constraint, in CONSTRAINTS order", vector=True)), hot=True),
        Function("energies", "Kinetic, gravity potential and spring energy.", ("q", "qd", "p"),
                 (Output("e", (3,), (kinetic, dyn.potential_energy, dyn.spring_energy),
                         "kinetic, gravity potential and spring energy (J)"),)),
        # the dense solve's terms: gpme_motion and the analytic Jacobians, no longer the hot path
        Function("gpme_terms", "M, f and the constraint terms in one pass (shared kinematics).",
                 ("t", "q", "qd", "p"), (mass, forces) + constraint_outputs),
        _recursive_function(d, constraint_outputs),
    ]
    return (fns + _force_functions(d) + _limit_functions(d) + _controller_functions(d)
            + ([_jacobian_function(d)] if jacobians else [])
            + transform_functions(d, transforms))


def _force_functions(d: Derivation) -> list[Function]:
    """The readings of the force elements between points (:mod:`gpmegen.symbolic.forces`), for
    a model that has them (a model without keeps the functions it always had)."""
    terms = d.dynamics.elements
    if terms is None:
        return []
    values = [v for row in zip(terms.length, terms.rate, terms.force) for v in row]
    return [Function("force_elements", "Length, rate and force of each force element between points.",
                     ("t", "q", "qd", "p"),
                     (Output("F", (len(terms.length), 3), tuple(values),
                             "one row per element in FORCES order: length L (m), its rate (m/s) and the force "
                             "(N, positive pushing the two points apart)"),))]


def _controller_functions(d: Derivation) -> list[Function]:
    """The rates of the controller states, for a model that has them; their current values are
    the last entries of ``p`` (:attr:`gpmegen.model.chain.Model.p_names`)."""
    rates = d.controller_rates
    if not rates.shape[0]:
        return []
    initial = sp.Matrix([sp.sympify(c.initial) for c in d.chain.model.controllers])
    return [Function("controller_rates", "Time derivatives of the controller states.", ("t", "q", "qd", "p"),
                     (_out("z_rate", rates, "dz/dt, one per controller state in CONTROLLERS order", vector=True),),
                     hot=True),
            Function("controller_initial", "The controller states at the start.", ("p",),
                     (_out("z0", initial, "z at the start, in CONTROLLERS order", vector=True),))]


def _limit_functions(d: Derivation) -> list[Function]:
    """The laws of the drives with a limit before their clip, beside the limit, for a model that
    has such drives (what tells when a drive sits at its limit)."""
    limited = d.dynamics.limited
    if not limited:
        return []
    values = [v for _, law, limit in limited for v in (law, limit)]
    return [Function("drive_limits", "Each limited drive's law before its clip, and its limit.", ("t", "q", "qd", "p"),
                     (Output("L", (len(limited), 2), tuple(values),
                             "one row per limited drive in LIMITED_DRIVES order: the law (N m or N) and the limit"),))]


def _recursive_function(d: Derivation, constraint_outputs) -> Function:
    """What the articulated-body solve of the C backend reads (:mod:`gpmegen.symbolic.recursive`):
    O(n) numbers in place of gpme_terms' M."""
    rec = d.recursive
    return Function(
        "recursive_terms", "Joint axes, link inertias, bias and joint forces in {0} for the articulated-body "
        "solve, and the constraint terms.", ("t", "q", "qd", "p"),
        (_out("S", rec.axes, "world twist (omega, v at the origin) of each joint's axis, in COORDINATES order"),
         _out("I", rec.links, "spatial inertia of each link (the bodies joint j moves directly: none "
              "of its children's) about the origin: m (kg), c = m r_C (kg m), I_O xx, xy, xz, yy, yz, zz (kg m^2)"),
         _out("b", rec.bias, "bias force of each link (torque about the origin, N m; force, N): its rate of "
              "momentum at qdd = 0 plus its weight"),
         _out("tau", rec.joint_forces, "joint forces Q(t, q, qd) - C q - damping", vector=True))
        + constraint_outputs
        + (() if rec.armature is None else
           (_out("armature", rec.armature, "each joint's geared motor inertia n^2 J_m (kg m^2 or kg), added to "
                 "its pivot", vector=True),)), hot=True)


def _jacobian_function(d: Derivation) -> Function:
    """The derivatives of the GPME residuals F = f - M a + D^T lam and C = c - D a
    (:func:`gpmegen.symbolic.derivatives.gpme_residuals`) that the acceleration Jacobians solve
    for. In the cold part although implicit integrators call it: it is one straight-line block of
    O(n²) values (12 400 lines at n_rfe = 5) that GCC at -O3 took over 5 min and 1 GB to compile,
    at -O0 3 s; a Jacobian is evaluated far less often than the accelerations."""
    F_q, F_qd, C_q, C_qd = gpme_jacobians(d, given_accelerations(d), given_multipliers(d))
    return Function(
        "gpme_residual_jacobians",
        "Jacobians of F = f - M a + D^T lam and C = c - D a (c the constraint rows' right sides).",
        ("t", "q", "qd", "a", "lam", "p"),
        (_out("F_q", F_q, "dF/dq"), _out("F_qd", F_qd, "dF/dqd"),
         Output("C_q", tuple(C_q.shape), tuple(C_q), "dC/dq, one row per constraint"),
         Output("C_qd", tuple(C_qd.shape), tuple(C_qd), "dC/dqd, one row per constraint")))


def prepare(fn: Function, d: Derivation):
    """The needed definitions of ``fn`` with common subexpressions hoisted, and its outputs;
    computed once and printed for every backend."""
    return prepare_all([fn], d)[0]


def prepare_all(fns, d: Derivation) -> list:
    """:func:`prepare` of each of ``fns`` from one elimination over all their needs: an
    intermediate several functions share is rewritten once and keeps one name, so it is printed
    once per backend (:func:`lower`'s ``cache``); each function takes the definitions its
    outputs need, in order."""
    values = [v for fn in fns for out in fn.outputs for v in out.values]
    definitions, outputs = eliminate(d.program.closure(values), values)
    shared = Program()
    shared.definitions = dict(definitions)
    result, k = [], 0
    for fn in fns:
        size = sum(len(out.values) for out in fn.outputs)
        result.append((shared.closure(outputs[k:k + size]), outputs[k:k + size]))
        k += size
    return result


def lower(fn: Function, d: Derivation, printer, prepared=None, split=False, cache=None) -> Lowered:
    """Straight-line code of ``fn`` printed by ``printer``; ``split``: also cut into blocks of
    bounded length (the C backend); ``cache``: a dict of code already printed by this printer
    for functions prepared together (:func:`prepare_all`)."""
    body, outputs = prepared if prepared is not None else prepare(fn, d)
    free = set()
    for _, e in body:
        free |= e.free_symbols
    for e in outputs:
        free |= sp.sympify(e).free_symbols
    kin = d.kinematics
    q_used = tuple((j, s.name) for j, s in enumerate(kin.q) if s in free)
    qd_used = tuple((j, s.name) for j, s in enumerate(kin.qd) if s in free)
    p_used = tuple((k, names.parameter_local(name)) for k, name in enumerate(d.chain.model.p_names)
                   if sp.Symbol(name, real=True) in free)
    cache = {} if cache is None else cache

    def doprint(expr):
        if expr not in cache:
            cache[expr] = printer.doprint(expr)
        return cache[expr]

    a_used = tuple((j, s.name) for j, s in enumerate(given_accelerations(d)) if s in free)
    lam_used = tuple((k, s.name) for k, s in enumerate(given_multipliers(d)) if s in free)
    lines = tuple((doprint(s), doprint(e)) for s, e in body)
    printed, k = [], 0
    for out in fn.outputs:
        size = len(out.values)
        printed.append((out, tuple(doprint(e) for e in outputs[k:k + size])))
        k += size
    blocks, workspace = _blocks(body, outputs, lines, printed, d) if split else ((), 0)
    return Lowered(fn, TIME in free, q_used, qd_used, p_used, lines, tuple(printed), blocks, workspace,
                   a_used, lam_used)


def _blocks(body, outputs, lines, printed, d):
    """The C backend's blocks of a lowered function (:func:`gpmegen.codegen.blocks.split`)."""
    kin = d.kinematics
    inputs = {
        "q": tuple((s, j, s.name) for j, s in enumerate(kin.q)),
        "qd": tuple((s, j, s.name) for j, s in enumerate(kin.qd)),
        "p": tuple((sp.Symbol(name, real=True), k, names.parameter_local(name))
                   for k, name in enumerate(d.chain.model.p_names)),
        "a": tuple((s, j, s.name) for j, s in enumerate(given_accelerations(d))),
        "lam": tuple((s, k, s.name) for k, s in enumerate(given_multipliers(d))),
    }
    definitions = tuple((s, name, code) for (s, _), (name, code) in zip(body, lines))
    stores = tuple((out.name, i, code) for out, codes in printed for i, code in enumerate(codes))
    uses = [e.free_symbols for _, e in body] + [sp.sympify(e).free_symbols for e in outputs]
    return blocking.split(definitions, stores, uses, TIME, inputs)
