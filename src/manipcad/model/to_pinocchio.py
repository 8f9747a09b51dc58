"""Export a :class:`~manipcad.model.Robot` to a Pinocchio model (``pip install pin``).

Joint offsets have no Pinocchio counterpart: pass ``q + robot.offset`` to
Pinocchio. Drives are not exported (Pinocchio's ``rotorInertia`` and
``rotorGearRatio`` are set so that ``armature`` holds J·i_r², for users who want it).
"""

from __future__ import annotations

import numpy as np

from manipcad.model.robot import REVOLUTE, Robot


def depth_first_order(robot: Robot) -> np.ndarray:
    """Joint indices in depth-first order, children in index order.

    Pinocchio's CRBA assumes every subtree holds consecutive joint indices; our
    trees only ask that parents precede children.
    """
    children: list[list[int]] = [[] for _ in range(robot.n + 1)]
    for i, p in enumerate(robot.parent):
        children[p].append(i)  # the base (-1) lands in the last slot
    order: list[int] = []
    stack = children[-1][::-1]
    while stack:
        i = stack.pop()
        order.append(i)
        stack.extend(children[i][::-1])
    return np.array(order, dtype=np.int64)


def to_pinocchio(robot: Robot, *, armature: bool = False):
    """Build the equivalent ``pinocchio.Model`` (revolute → RZ, prismatic → PZ joints).

    Args:
        robot: the manipulator.
        armature: set ``model.armature`` to the drives' J·i_r² (kg·m²).

    Returns:
        (model, order): the ``pinocchio.Model`` with our gravity and link
        inertias, its joints in depth-first order, and ``order`` such that
        Pinocchio's joint k is our joint ``order[k]`` (pass ``q[order]``).
    """
    import pinocchio as pin  # deferred: optional dependency

    model = pin.Model()
    model.name = robot.name
    model.gravity = pin.Motion(np.asarray(robot.gravity, dtype=float), np.zeros(3))
    order = depth_first_order(robot)
    ids = {}
    for i in order:
        parent = 0 if robot.parent[i] < 0 else ids[int(robot.parent[i])]
        joint = pin.JointModelRZ() if robot.joint_types[i] == REVOLUTE else pin.JointModelPZ()
        placement = pin.SE3(robot.placement_R[i].copy(), robot.placement_p[i].copy())
        jid = model.addJoint(parent, joint, placement, robot.joint_names[i])
        inertia = pin.Inertia(float(robot.mass[i]), robot.com[i].copy(), robot.inertia[i].copy())
        model.appendBodyToJoint(jid, inertia, pin.SE3.Identity())
        ids[int(i)] = jid
    if armature:
        model.armature = np.array([0.0 if d is None else d.reflected_inertia
                                   for d in (robot.drives[i] for i in order)])
    return model, order
