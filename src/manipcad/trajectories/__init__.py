"""Motion laws (trajectories) and the trajectory files.

Every trajectory has ``.n`` joints, a ``.duration`` (s) and
``.sample(t) -> (q, qd, qdd)`` of shape (len(t), n) in SI units (rad, rad/s,
rad/s² or m, m/s, m/s²); after ``duration`` it holds its final position with
zero velocity and acceleration. Laws:

- :func:`cosine`: q = q0 + A(1 - cos ωt), the paper's laws (2);
- :func:`quintic`: point to point with zero end velocities and accelerations;
- :func:`trapezoidal`: point to point, trapezoidal velocity, joints synchronised;
- :func:`spline`: C2 cubic spline through via points, zero end velocities;
- :func:`waypoints`: point-to-point moves through poses with a dwell at each;
- :func:`line`, :func:`circle`: gripper paths through inverse kinematics.

:func:`gripper_speed` gives the tool speed (m/s) along any of them;
:func:`load_trajectory` and :func:`save_trajectory` read and write YAML files.

Example:
    >>> import numpy as np
    >>> from manipcad.trajectories import cosine
    >>> traj = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], duration=1.6)
    >>> q, qd, qdd = traj.sample(np.linspace(0.0, 1.6, 161))
    >>> q.shape
    (161, 3)
"""

from manipcad.trajectories.base import Trajectory
from manipcad.trajectories.cartesian import (
    CartesianTrajectory,
    CircleTrajectory,
    LineTrajectory,
    circle,
    line,
)
from manipcad.trajectories.cosine import CosineTrajectory, cosine
from manipcad.trajectories.io import load_trajectory, save_trajectory, trajectory_from_dict
from manipcad.trajectories.quintic import QuinticTrajectory, quintic
from manipcad.trajectories.speed import gripper_speed
from manipcad.trajectories.spline import SplineTrajectory, spline
from manipcad.trajectories.trapezoidal import TrapezoidalTrajectory, trapezoidal
from manipcad.trajectories.waypoints import WaypointsTrajectory, waypoints

__all__ = [
    "Trajectory", "cosine", "quintic", "trapezoidal", "spline", "line", "circle", "waypoints",
    "CosineTrajectory", "QuinticTrajectory", "TrapezoidalTrajectory", "SplineTrajectory",
    "WaypointsTrajectory",
    "CartesianTrajectory", "LineTrajectory", "CircleTrajectory",
    "gripper_speed", "load_trajectory", "save_trajectory", "trajectory_from_dict",
]
