"""The task-space computed-torque law's generalized forces, derived with the plant
(:class:`gpmegen.model.task_torque.TaskTorque`).

The controller model's mass matrix, forces and its point's kinematics (position, velocity, the
velocity-product part ``J̇_c q̇`` of its acceleration, the Jacobian columns of the controller's
joints) are derived in a program of their own and copied into the plant's, as the joint law's
are (:func:`gpmegen.symbolic.computed_torque.controller_outputs`). ``J_c`` is at most 3 × 3 (a
point has three components), so ``J_c⁻¹`` is written out as ``adj(J_c) / det(J_c)``: a few
products, no pivoting, emitted like any other expression into every backend; ``det(J_c) = 0``
(a singular pose) divides by zero, where the law is undefined.
"""

from __future__ import annotations

import sympy as sp

from ..errors import DerivationError
from ..model.computed_torque import joint_coordinates
from ..model.task_torque import TaskTorque
from .computed_torque import controller_outputs, on_plant, reference_rates
from .computed_torque import warnings as joint_warnings
from .kinematics import Kinematics


def derive(kin: Kinematics, law: TaskTorque) -> sp.Matrix:
    """The law's generalized force on the plant whose kinematics is ``kin`` (n,): on each joint
    coordinate of the controller ``(M_c v - f_c)`` of the controller's same coordinate, with
    ``v = J_c⁻¹ (a_r - J̇_c q̇)`` on its joints and 0 on its elastic coordinates; elsewhere 0."""
    joints = joint_coordinates(law.controller)
    rows = law.rows()

    def outputs(own, dyn):
        point = own.points[law.point]
        columns = [own.chain.coordinates.index(name) for name in joints]
        jacobian = sp.Matrix([[point.jacobian[j][r] for j in columns] for r in rows])
        return [dyn.mass_matrix, dyn.forces, point.position, point.velocity, point.acceleration, jacobian]

    (mass, forces, position, velocity, bias, jacobian), coordinates = controller_outputs(
        law.controller, kin.program, outputs)
    define = kin.program.define
    wanted = sp.Matrix(law.commanded([position[r] for r in rows], [velocity[r] for r in rows],
                                     reference_rates(law.joint_law())))
    rhs = (wanted - sp.Matrix([bias[r] for r in rows])).applyfunc(define)
    det = define(jacobian.det(method="berkowitz"))
    if det == 0:   # the point cannot move along the components by these joints, at any pose
        raise DerivationError(f"controller.task_space: J_c of point {law.point} on {', '.join(law.components)} by "
                              f"{', '.join(joints)} is singular at every pose (its determinant is 0), so no joint "
                              f"motion moves it along every component; track a point the controller's joints move, "
                              f"on components they reach", ("controller", "task_space", 0, "point"))
    inverse_det = define(1 / det)
    solved = dict(zip(joints, (jacobian.adjugate(method="berkowitz") * rhs * inverse_det).applyfunc(define)))
    return on_plant(kin, mass, forces, coordinates, solved)


def warnings(law: TaskTorque, defaults) -> list[str]:
    """One line per switch where a component's reference (``x_r``, ``y_r`` or ``z_r``) or its
    velocity jumps, naming the field, as the joint law's (``defaults``: the plant's parameter
    symbols -> numbers)."""
    fields = [f"controller.task_space.reference[{k}] ({axis})" for k, axis in enumerate(law.components)]
    return joint_warnings(law.joint_law(), defaults, fields, symbols=law.components)
