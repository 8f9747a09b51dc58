"""Kinematics of the manipulator tree: forward kinematics, Jacobians, inverse kinematics.

Every function takes one configuration q of shape (n,) (rad for revolute, m for
prismatic joints) or a batch (N, n) and returns the matching shape. Poses are
4x4 homogeneous transforms in the base frame with translations in m.

Example:
    >>> import numpy as np
    >>> import manipcad
    >>> from manipcad.kinematics import jacobian, tool_pose
    >>> robot = manipcad.load_robot("puma560")
    >>> tool_pose(robot, np.zeros(6)).shape, jacobian(robot, np.zeros(6)).shape
    ((4, 4), (6, 6))
"""

from manipcad.kinematics.forward import forward_kinematics, point_position, tool_pose
from manipcad.kinematics.inverse import KinematicsError, inverse_kinematics
from manipcad.kinematics.jacobian import jacobian, jacobian_dot

__all__ = [
    "forward_kinematics", "tool_pose", "point_position",
    "jacobian", "jacobian_dot",
    "inverse_kinematics", "KinematicsError",
]
