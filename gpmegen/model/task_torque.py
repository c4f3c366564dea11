"""Computed torque in task space with a controller model: the law and its checks (plain data).

The law moves a point ``P`` of the controller model along references ``x_r(t)``: with ``x``,
``ẋ`` the point's position and velocity in {0} (m, m/s) on the task components named,

    a_r = ẍ_r + K_d (ẋ_r - ẋ) + K_p (x_r - x),
    v   = J_c⁻¹ (a_r - J̇_c q̇),        J_c = ∂x/∂q_c over the controller's joint coordinates,
    u   = M_c(q_c) v - f_c(q_c, q̇_c),

``x``, ``ẋ``, ``J_c`` and ``J̇_c q̇`` computed from the controller model's kinematics at the
plant's joint coordinates of the same names (collocated: the plant's own point, on a flexible
plant, moves with the elastic coordinates the controller does not know; a law on it would be
non-collocated). ``J_c`` is square: as many components as the controller has joints, so at most
three. With ``M_c = M``, ``f_c = f`` and ``J_c`` regular the task error ``e = x_r - x`` obeys
``ë + K_d ė + K_p e = 0``; where ``J_c`` is singular the law is undefined.
"""

from __future__ import annotations

from dataclasses import dataclass

import sympy as sp

from ..errors import ModelError
from .chain import AXES, TIME, Model, Point, symbol, velocity_symbol
from .computed_torque import ComputedTorque, check_joints_in_plant, joint_coordinates


@dataclass(frozen=True)
class TaskTorque:
    """A task-space computed-torque law: ``controller`` the controller's :class:`Model` (its
    parameters at their default values), ``point`` the name of its point ``P``, ``components``
    the axes of {0} the law tracks (letters among ``x``, ``y``, ``z``), ``references`` one
    expression of ``t`` and the plant's parameters per component (m), the gains ``kp`` (1/s²)
    and ``kd`` (1/s), expressions of the plant's parameters. ``source``: where the controller
    came from, for messages."""

    controller: Model
    point: str
    components: tuple
    references: tuple
    kp: object
    kd: object
    source: str = ""

    def joint_law(self) -> ComputedTorque:
        """The joint law of the same references and gains on stand-ins for the point's
        components (an underscore first: no name of a model), so that both laws differentiate
        references alike (:func:`gpmegen.symbolic.computed_torque.reference_rates`)."""
        stand_ins = tuple(f"_{self.point}_{axis}" for axis in self.components)
        n = len(stand_ins)
        return ComputedTorque(self.controller, stand_ins, self.references, (self.kp,) * n, (self.kd,) * n)

    def commanded(self, position, velocity, rates=None) -> list:
        """``a_r`` per component, an expression of ``t``, the parameters and the given
        ``position`` and ``velocity`` of the point on the components (expressions); ``rates``:
        the references' ``(x_r, ẋ_r, ẍ_r)`` as :meth:`ComputedTorque.commanded` takes them."""
        law = self.joint_law()
        swap = {}
        for name, x, xd in zip(law.coordinates, position, velocity):
            swap[symbol(name)], swap[velocity_symbol(name)] = x, xd
        return [sp.sympify(a).xreplace(swap) for a in law.commanded(rates)]

    def rows(self) -> list[int]:
        """The rows of the components in a vector of {0}."""
        return [AXES.index(axis) for axis in self.components]


def check(law: TaskTorque, plant_coordinates, constant: set, joint_law=None) -> None:
    """Refuse, in one line, a task law beside a joint law (both would act on every controller
    joint), a point the controller lacks, components not distinct axes or not as many as the
    controller's joints (``J_c`` square), a reference per component missing, a controller joint
    the plant lacks, a gain not of parameters or a reference not of ``t`` and parameters.
    ``constant``: the plant's parameter symbols."""
    where = f"controller {law.source or law.controller.name}"
    here = ("controller", "task_space", 0)
    controller = joint_coordinates(law.controller)
    if joint_law is not None:
        raise ModelError(f"{where}: the joint law ([[controller.computed_torque]]) and the task-space law on "
                         f"{law.point} both act on {', '.join(controller)}; give one of the two",
                         ("controller", "task_space"))
    points = [e.name for e in law.controller.chain if isinstance(e, Point)]
    if law.point not in points:
        raise ModelError(f"{where}: no point {law.point!r} in the controller model (its points: "
                         f"{', '.join(points) or 'none'}); name one of them", here + ("point",))
    components = list(law.components)
    if not components or any(a not in AXES for a in components) or len(set(components)) != len(components):
        raise ModelError(f"{where}: components {components} are not distinct axes; name some of "
                         f"\"x\", \"y\", \"z\" once each", here + ("components",))
    if len(components) != len(controller):
        raise ModelError(f"{where}: the task-space law tracks {len(components)} components of {law.point} "
                         f"({', '.join(components)}) with the controller's {len(controller)} joints "
                         f"({', '.join(controller)}), and J_c must be square; name {len(controller)} components "
                         f"in components = [...]" if len(controller) <= 3 else
                         f"{where}: the controller model has {len(controller)} joints ({', '.join(controller)}), "
                         f"more than the 3 components of a point, so J_c cannot be square; use a joint law",
                         here + ("components",))
    if len(law.references) != len(components):
        raise ModelError(f"{where}: {len(law.references)} reference{'' if len(law.references) == 1 else 's'} for the "
                         f"{len(components)} components "
                         f"({', '.join(components)}); give one signal per component", here + ("reference",))
    check_joints_in_plant(law, plant_coordinates)
    for field, values, allowed in (("reference", law.references, constant | {TIME}), ("kp", (law.kp,), constant),
                                   ("kd", (law.kd,), constant)):
        for value in values:
            extra = sorted(str(s) for s in sp.sympify(value).free_symbols - allowed)
            if extra:
                raise ModelError(f"{where}: {field} of the task-space law reads {', '.join(extra)}; a reference "
                                 f"is a law of t and parameters, a gain of parameters", here + (field,))
