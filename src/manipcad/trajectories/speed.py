"""Gripper (tool) speed along a trajectory, from the Jacobian."""

from __future__ import annotations

import numpy as np

from manipcad.errors import InputError
from manipcad.kinematics.jacobian import jacobian
from manipcad.model.robot import Robot
from manipcad.trajectories.base import Trajectory


def gripper_speed(robot: Robot, trajectory: Trajectory, t: float | np.ndarray,
                  ) -> np.ndarray | float:
    """Speed of the tool frame origin, |J_v(q)·qd|, along a trajectory.

    Args:
        robot: the robot the trajectory drives (its n must match).
        trajectory: any :class:`Trajectory`.
        t: a time or a 1-D array of times, s (>= 0).

    Returns:
        (len(t),) speeds in m/s (a float for a scalar t). Zero after the
        trajectory's duration, where it holds.

    Raises:
        InputError: the trajectory has a different number of joints, or bad times.

    Example:
        >>> import numpy as np
        >>> import manipcad
        >>> from manipcad.trajectories import cosine, gripper_speed
        >>> robot = manipcad.load_robot("puma560")
        >>> traj = cosine(np.full(6, 0.2), np.full(6, 2.0), duration=1.0)
        >>> gripper_speed(robot, traj, np.linspace(0, 1, 11)).shape
        (11,)
    """
    if trajectory.n != robot.n:
        raise InputError("trajectory", "", f"has {trajectory.n} joints; robot "
                         f"{robot.name!r} has {robot.n}")
    scalar = np.ndim(t) == 0
    q, qd, _ = trajectory.sample(np.atleast_1d(np.asarray(t, dtype=float)))
    Jv = jacobian(robot, q)[:, :3]
    v = np.linalg.norm(np.einsum("kij,kj->ki", Jv, qd), axis=1)
    return float(v[0]) if scalar else v
