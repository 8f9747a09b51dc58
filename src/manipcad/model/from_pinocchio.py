"""Robots from a Pinocchio ``Model`` (``pip install pin``).

Revolute and prismatic joints about any axis (RX, RY, RZ, RevoluteUnaligned,
the continuous RUBX/RUBY/RUBZ, PX, PY, PZ, PrismaticUnaligned) map onto
manipcad's joints; other joint types (free flyer, spherical, planar,
composite, mimic) are refused with the joint's name. A continuous joint's
angle is manipcad's q (Pinocchio stores cos q, sin q). ``model.armature``
(kg·m², kg) becomes a drive with J = armature and ratio 1. The inverse
dynamics and mass matrix equal Pinocchio's ``rnea`` and ``crba``
(tests/test_model_import.py).
"""

from __future__ import annotations

import numpy as np

from manipcad.errors import InputError
from manipcad.model.convert import SourceJoint, robot_from_joints
from manipcad.model.robot import PRISMATIC, REVOLUTE, Drive, Robot


def _joint_kind(jm, name: str, S: np.ndarray):
    """(kind, unit axis in the joint frame) from the joint type and its motion
    subspace S = [linear; angular] (6,) in the joint's local frame."""
    short = jm.shortname()
    revolute = short.startswith(("JointModelR", "JointModelRevolute"))
    prismatic = short.startswith(("JointModelP", "JointModelPrismatic")) and \
        not short.startswith("JointModelPlanar")
    if not (revolute or prismatic) or short.startswith("JointModelRevoluteHelical"):
        raise InputError(f"pinocchio model joint {name!r}", "", f"joint type {short} is not a "
                         "revolute or prismatic joint; manipcad models those only")
    axis = S[3:] if revolute else S[:3]
    other = S[:3] if revolute else S[3:]
    if np.linalg.norm(other) > 1e-12 or abs(np.linalg.norm(axis) - 1.0) > 1e-9:
        raise InputError(f"pinocchio model joint {name!r}", "", f"{short}: motion subspace "
                         f"{S.tolist()} is not a pure rotation or translation about a unit axis")
    return (REVOLUTE if revolute else PRISMATIC), axis / np.linalg.norm(axis)


def robot_from_pinocchio(model, name: str | None = None) -> Robot:
    """A :class:`~manipcad.model.Robot` from a ``pinocchio.Model``.

    Args:
        model: the Pinocchio model (joint placements m, link inertias kg and
            kg·m² in the joint frames, gravity m/s², armature kg·m²).
        name: the robot's name (default ``model.name``).

    Returns:
        The robot; joint k is Pinocchio's joint k + 1 (the universe is not a joint).

    Raises:
        InputError: a joint type other than revolute or prismatic (named).

    Example:
        >>> import pinocchio as pin
        >>> robot_from_pinocchio(pin.buildSampleModelManipulator()).n
        6
    """
    import pinocchio as pin  # deferred: optional dependency

    data = model.createData()
    pin.computeJointJacobians(model, data, pin.neutral(model))
    joints = []
    for i in range(1, model.njoints):
        jname = model.names[i]
        jm = model.joints[i]
        if jm.nv != 1:
            raise InputError(f"pinocchio model joint {jname!r}", "", f"{jm.nv} degrees of "
                             "freedom; manipcad models one per joint")
        J = pin.getJointJacobian(model, data, i, pin.ReferenceFrame.LOCAL)
        kind, axis = _joint_kind(jm, jname, np.asarray(J[:, jm.idx_v], dtype=float))
        inertia = model.inertias[i]
        arm = float(np.asarray(model.armature).reshape(-1)[jm.idx_v]) \
            if len(np.asarray(model.armature).reshape(-1)) else 0.0
        lower = upper = None
        if jm.nq == 1:
            lower = float(model.lowerPositionLimit[jm.idx_q])
            upper = float(model.upperPositionLimit[jm.idx_q])
        limits = (lower if lower is not None and np.isfinite(lower) and lower > -1e300
                  else -np.inf,
                  upper if upper is not None and np.isfinite(upper) and upper < 1e300
                  else np.inf)
        if limits[0] > limits[1]:
            limits = (-np.inf, np.inf)
        joints.append(SourceJoint(
            name=jname, kind=kind, parent=int(model.parents[i]) - 1,
            A=np.asarray(model.jointPlacements[i].homogeneous, dtype=float), axis=axis,
            mass=float(inertia.mass), com=np.asarray(inertia.lever, dtype=float).copy(),
            inertia=np.asarray(inertia.inertia, dtype=float).copy(), limits=limits,
            link=jname, drive=Drive(J=arm, ratio=1.0) if arm > 0 else None))
    gravity = np.asarray(model.gravity.linear, dtype=float).copy()
    return robot_from_joints(name or model.name or "pinocchio robot", joints, gravity=gravity,
                             source="pinocchio.Model")


__all__ = ["robot_from_pinocchio"]
