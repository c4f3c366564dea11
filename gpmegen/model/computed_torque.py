"""Computed torque with a model that is not the plant: the law and its checks (plain data).

The plant's inputs on the coordinates ``c`` the law names are
``u = M_c(q_c) v - f_c(q_c, q̇_c)``, with ``v = q̈_r + K_d (q̇_r - q̇) + K_p (q_r - q)`` per
coordinate and ``M_c``, ``f_c`` (without drives: ``h - g - C q - damping`` and the force
elements) the *controller model*'s mass matrix and forces, derived with the plant
(:mod:`gpmegen.symbolic.computed_torque`). The controller reads its joint coordinates from the
plant's coordinates of the same names; its elastic coordinates (a coarse flexible controller's
sde freedoms, which the plant may lack or discretize otherwise) are held at rest, ``q = q̇ = 0``
with no commanded acceleration. With ``M_c = M`` and ``f_c = f`` the closed loop is
``ë + K_d ė + K_p e = 0`` for ``e = q_r - q``.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..errors import ModelError
from .chain import TIME, Joint, Model, symbol, velocity_symbol


@dataclass(frozen=True)
class ComputedTorque:
    """A computed-torque law: ``controller`` the controller's :class:`Model`, per actuated
    coordinate (``coordinates``, names of the plant's and the controller's joints) its reference
    ``references`` (expressions of ``t`` and the plant's parameters, rad or m), and its gains
    ``kp`` (1/s²) and ``kd`` (1/s), expressions of the plant's parameters. The controller's
    parameters enter at their default values but those ``params`` sets: ``(name, expression)``
    pairs, a controller parameter's name and an expression of the plant's parameters.
    ``source``: where the controller came from, ``signals``: the references' signal names, for
    messages."""

    controller: Model
    coordinates: tuple
    references: tuple
    kp: tuple
    kd: tuple
    source: str = ""
    signals: tuple = ()
    params: tuple = ()

    def commanded(self, rates=None) -> list:
        """``v = q̈_r + kd (q̇_r - q̇) + kp (q_r - q)`` per coordinate, an expression of ``t``, the
        parameters and the plant's state (``<coordinate>``, ``<coordinate>_dot``, as a feedback
        law names them). ``rates``: ``(q_r, q̇_r, q̈_r)`` per coordinate (the joint law's, from
        :func:`gpmegen.symbolic.computed_torque.reference_rates`, which differentiates switches
        branch by branch); by default the references' derivatives as SymPy takes them."""
        if rates is None:
            rates = [(r, sp.diff(r, TIME), sp.diff(r, TIME, 2)) for r in map(sp.sympify, self.references)]
        out = []
        for name, (r, rd, rdd), kp, kd in zip(self.coordinates, rates, self.kp, self.kd):
            out.append(rdd + kd * (rd - velocity_symbol(name)) + kp * (r - symbol(name)))
        return out


def joint_coordinates(model: Model) -> list[str]:
    """The coordinates of ``model``'s joints (not its flexible links' sdes), in chain order."""
    return [e.name for e in model.chain if isinstance(e, Joint)]


def check_joints_in_plant(law, plant_coordinates) -> None:
    """Refuse, in one line, a joint of ``law.controller`` that is no coordinate of the plant (the
    law, joint or task-space, reads the controller's joints from the plant's)."""
    plant = list(plant_coordinates)
    for name in joint_coordinates(law.controller):
        if name not in plant:
            raise ModelError(f"controller {law.source or law.controller.name}: its coordinate {name} is no coordinate "
                             f"of the plant (the plant's: {', '.join(plant)}); give the controller model the plant's "
                             f"joint names", ("controller", "model"))


def check(law: ComputedTorque, plant_coordinates, constant: set) -> None:
    """Refuse, in one line, a law whose coordinates the plant or the controller lacks, a
    controller joint the law does not actuate, a gain not of parameters or a reference not of
    ``t`` and parameters, a controller parameter set that the controller model lacks or set to
    more than the plant's parameters. ``constant``: the plant's parameter symbols."""
    where = f"controller {law.source or law.controller.name}"
    own = [p.name for p in law.controller.parameters]
    for name, value in law.params:
        if name not in own:
            raise ModelError(f"{where}: {name} is no parameter of the controller model (its parameters: "
                             f"{', '.join(own) or 'none'}); name one of them", ("controller", "params", name))
        extra = sorted(str(s) for s in sp.sympify(value).free_symbols - constant)
        if extra:
            raise ModelError(f"{where}: its parameter {name} reads {', '.join(extra)}; give it an expression of the "
                             f"plant's parameters", ("controller", "params", name))
    controller = joint_coordinates(law.controller)
    check_joints_in_plant(law, plant_coordinates)
    for k, name in enumerate(law.coordinates):
        if name not in controller:
            raise ModelError(f"{where}: the law acts on {name}, which is no joint of the controller model "
                             f"(its joints: {', '.join(controller)}); name one of them",
                             ("controller", "computed_torque", k, "coordinate"))
    if len(set(law.coordinates)) != len(law.coordinates):
        raise ModelError(f"{where}: a coordinate is named twice in the law; name each once",
                         ("controller", "computed_torque"))
    missing = [name for name in controller if name not in law.coordinates]
    if missing:
        raise ModelError(f"{where}: computed torque needs every joint of the controller model actuated, "
                         f"and the law leaves out {', '.join(missing)}; add it to the law",
                         ("controller", "computed_torque"))
    for k, (ref, kp, kd) in enumerate(zip(law.references, law.kp, law.kd)):
        for field, value, allowed in (("reference", ref, constant | {TIME}), ("kp", kp, constant),
                                      ("kd", kd, constant)):
            extra = sorted(str(s) for s in sp.sympify(value).free_symbols - allowed)
            if extra:
                raise ModelError(f"{where}: {field} of {law.coordinates[k]} reads {', '.join(extra)}; a reference "
                                 f"is a law of t and parameters, a gain of parameters",
                                 ("controller", "computed_torque", k, field))
