"""The public dynamics functions: one state (n,) or a batch (N, n) in, matching shape out."""

from __future__ import annotations

import numpy as np

from manipcad.dynamics._inputs import as_fext, as_gravity, as_states
from manipcad.dynamics.aba import aba_batch
from manipcad.dynamics.crba import crba_batch
from manipcad.dynamics.forward_crba import crba_fd_batch
from manipcad.dynamics.rnea import rnea_batch
from manipcad.errors import ManipcadError
from manipcad.model.robot import Robot


def inverse_dynamics(robot: Robot, q, qd, qdd, *, gravity=None, f_ext=None,
                     drives: bool = True) -> np.ndarray:
    """Joint torques that produce a motion: the recursive algorithm of paper 4.1.

    Args:
        robot: the manipulator.
        q: joint positions, rad or m, shape (n,) or (N, n).
        qd: joint velocities, rad/s or m/s, same shape.
        qdd: joint accelerations, rad/s² or m/s², same shape.
        gravity: gravity vector in the base frame, m/s², shape (3,); default the robot's.
        f_ext: external wrenches on the links, [force (N), moment (N·m) about the
            body-frame origin] in each link's body axes, shape (n, 6) or (N, n, 6).
            They act on the robot, so they lower the torques needed.
        drives: add the drive terms J·i_r²·q̈ + k_v·i_r²·q̇ + |i_r|·M_f·sign(q̇)
            (False: the pure rigid body).

    Returns:
        Joint torques P (N·m, or N for prismatic joints), shape like q.

    Example:
        >>> import numpy as np, manipcad
        >>> puma = manipcad.load_robot("puma560")
        >>> tau = manipcad.inverse_dynamics(puma, np.zeros(6), np.zeros(6), np.zeros(6))
        >>> tau.shape
        (6,)
    """
    (Q, QD, QDD), single = as_states(robot.n, q=q, qd=qd, qdd=qdd)
    F, use_f = as_fext(robot.n, Q.shape[0], single, f_ext)
    tau = np.empty_like(Q)
    rnea_batch(robot.table, as_gravity(robot, gravity), Q, QD, QDD, F, use_f, drives, tau)
    return tau[0] if single else tau


def mass_matrix(robot: Robot, q, *, drives: bool = True) -> np.ndarray:
    """Joint-space inertia matrix H(q): the composite algorithm of paper 4.2 (method 1).

    Args:
        robot: the manipulator.
        q: joint positions, rad or m, shape (n,) or (N, n).
        drives: add the rotor inertias J·i_r² on the diagonal.

    Returns:
        H, shape (n, n) or (N, n, n); kg·m² between revolute joints, kg between
        prismatic ones, kg·m for mixed pairs.

    Example:
        >>> import numpy as np, manipcad
        >>> H = manipcad.mass_matrix(manipcad.load_robot("puma560"), np.zeros(6))
    """
    (Q,), single = as_states(robot.n, q=q)
    H = np.empty((Q.shape[0], robot.n, robot.n))
    crba_batch(robot.table, Q, drives, H)
    return H[0] if single else H


def forward_dynamics(robot: Robot, q, qd, tau, *, method: str = "aba", gravity=None,
                     f_ext=None, drives: bool = True) -> np.ndarray:
    """Joint accelerations under given joint torques (paper 4.2).

    Args:
        robot: the manipulator.
        q, qd: joint positions (rad or m) and velocities (rad/s or m/s), (n,) or (N, n).
        tau: joint torques, N·m or N, same shape.
        method: "aba", the O(n) articulated-body ("pursuit") method, or "crba",
            the mass matrix with Cholesky, O(n³).
        gravity, f_ext, drives: as in :func:`inverse_dynamics`.

    Returns:
        q̈, rad/s² or m/s², shape like q.

    Example:
        >>> import numpy as np, manipcad
        >>> puma = manipcad.load_robot("puma560")
        >>> qdd = manipcad.forward_dynamics(puma, np.zeros(6), np.zeros(6), np.zeros(6))
    """
    (Q, QD, T), single = as_states(robot.n, q=q, qd=qd, tau=tau)
    F, use_f = as_fext(robot.n, Q.shape[0], single, f_ext)
    g = as_gravity(robot, gravity)
    qdd = np.empty_like(Q)
    if method == "aba":
        aba_batch(robot.table, g, Q, QD, T, F, use_f, drives, qdd)
    elif method == "crba":
        bad = crba_fd_batch(robot.table, g, Q, QD, T, F, use_f, drives, qdd)
        if bad >= 0:
            raise ManipcadError(f"the mass matrix is not positive definite at state {bad}: "
                                "a joint moves no mass (add inertia or a drive)")
    else:
        raise ManipcadError(f"method must be 'aba' or 'crba', got {method!r}")
    return qdd[0] if single else qdd
