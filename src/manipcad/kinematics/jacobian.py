"""Geometric Jacobian of a point on a link and its time derivative.

For a point c fixed on link k, with base-frame position x(q), the geometric
Jacobian J (6, n) maps joint rates to the point's linear velocity and the
link's angular velocity, both in the base frame:

    [v; w] = J(q) · qd,   v in m/s, w in rad/s.

Only joints on the path from the base to link k contribute (a tree). With z_j
the base-frame axis of joint j and o_j the origin of its body frame,

    revolute j:   J_v[:, j] = z_j × (x - o_j),   J_w[:, j] = z_j
    prismatic j:  J_v[:, j] = z_j,               J_w[:, j] = 0.

The derivative along a motion (q, qd) uses z_j' = w_j × z_j and
(x - o_j)' = v_x - v_oj, where w_j and v_oj are the angular velocity of body j
and the velocity of its origin:

    revolute j:   J_v'[:, j] = (w_j × z_j) × (x - o_j) + z_j × (v_x - v_oj),
                  J_w'[:, j] = w_j × z_j
    prismatic j:  J_v'[:, j] = w_j × z_j,   J_w'[:, j] = 0,

so that the point's classical acceleration is a = J_v·qdd + J_v'·qd.
"""

from __future__ import annotations

import numpy as np

from manipcad.errors import InputError
from manipcad.kinematics.forward import ancestors, as_batch, frames, resolve_point
from manipcad.kinematics.rotations import cross
from manipcad.model.robot import PRISMATIC, Robot

FRAMES = ("world", "local")


def jacobian(robot: Robot, q: np.ndarray, link: int | str = -1,
             point: np.ndarray | None = None, frame: str = "world") -> np.ndarray:
    """Geometric Jacobian [linear; angular] of a point fixed on a link.

    Args:
        robot: the robot.
        q: joint coordinates (rad or m), shape (n,) or a batch (N, n).
        link: joint index or name of the link carrying the point; -1 is the last.
        point: (3,) point in the link's body frame, m; default the tool frame
            origin for the last link, the body frame origin for other links.
        frame: "world" expresses both blocks in the base frame; "local" in the
            axes of the link's body frame, or of the tool frame when the point
            is the default tool point (as the Toolbox's ``jacobe``); either way
            it is the velocity of the same point.

    Returns:
        (6, n), or (N, 6, n) for a batch. Rows 0-2 give the point velocity
        (m/s per rad/s or per m/s), rows 3-5 the link angular velocity (rad/s
        per joint rate). Columns of joints that are not ancestors of the link
        are zero.

    Raises:
        InputError: q of the wrong shape, a bad point or frame.

    Example:
        >>> import numpy as np
        >>> import manipcad
        >>> robot = manipcad.load_robot("puma560")
        >>> jacobian(robot, np.zeros(robot.n)).shape
        (6, 6)
    """
    if frame not in FRAMES:
        raise InputError("frame", "", f"unknown frame {frame!r}; expected one of {FRAMES}")
    Q, batched = as_batch(robot, q)
    k, c = resolve_point(robot, link, point)
    R, p = frames(robot, Q)
    J = _jacobian_from_frames(robot, R, p, k, c)
    if frame == "local":
        Rl = R[:, k] @ robot.tool_R if (point is None and k == robot.n - 1) else R[:, k]
        Rt = np.swapaxes(Rl, 1, 2)
        J = np.concatenate([Rt @ J[:, :3], Rt @ J[:, 3:]], axis=1)
    return J if batched else J[0]


def _jacobian_from_frames(robot: Robot, R: np.ndarray, p: np.ndarray, k: int,
                          c: np.ndarray) -> np.ndarray:
    N = R.shape[0]
    J = np.zeros((N, 6, robot.n))
    x = p[:, k] + R[:, k] @ c
    for j in ancestors(robot, k):
        z = R[:, j, :, 2]
        if robot.joint_types[j] == PRISMATIC:
            J[:, :3, j] = z
        else:
            J[:, :3, j] = cross(z, x - p[:, j])
            J[:, 3:, j] = z
    return J


def jacobian_dot(robot: Robot, q: np.ndarray, qd: np.ndarray, link: int | str = -1,
                 point: np.ndarray | None = None) -> np.ndarray:
    """Time derivative of the base-frame geometric Jacobian along a motion.

    ``J'(q, qd) = sum_k dJ/dq_k · qd_k``, so the point's classical acceleration
    and the link's angular acceleration are ``[a; w'] = J·qdd + J'·qd``.

    Args:
        robot: the robot.
        q: joint coordinates (rad or m), (n,) or (N, n).
        qd: joint rates (rad/s or m/s), same shape as q.
        link: joint index or name of the link carrying the point; -1 is the last.
        point: (3,) point in the link's body frame, m (defaults as :func:`jacobian`).

    Returns:
        (6, n) or (N, 6, n), in 1/s times the units of :func:`jacobian`.

    Example:
        >>> import numpy as np
        >>> import manipcad
        >>> robot = manipcad.load_robot("puma560")
        >>> jacobian_dot(robot, np.zeros(6), np.ones(6)).shape
        (6, 6)
    """
    Q, batched = as_batch(robot, q)
    Qd, _ = as_batch(robot, qd, "qd")
    if Qd.shape != Q.shape:
        raise InputError("qd", "", f"shape {Qd.shape} does not match q {Q.shape}")
    k, c = resolve_point(robot, link, point)
    R, p = frames(robot, Q)
    w, v = body_velocities(robot, R, p, Qd)
    N = Q.shape[0]
    x = p[:, k] + R[:, k] @ c
    vx = v[:, k] + cross(w[:, k], x - p[:, k])
    Jd = np.zeros((N, 6, robot.n))
    for j in ancestors(robot, k):
        z = R[:, j, :, 2]
        wz = cross(w[:, j], z)
        if robot.joint_types[j] == PRISMATIC:
            Jd[:, :3, j] = wz
        else:
            Jd[:, :3, j] = cross(wz, x - p[:, j]) + cross(z, vx - v[:, j])
            Jd[:, 3:, j] = wz
    return Jd if batched else Jd[0]


def body_velocities(robot: Robot, R: np.ndarray, p: np.ndarray,
                    Qd: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Angular velocity of every body and velocity of its frame origin, base frame.

    Args:
        robot: the robot.
        R, p: the frames of :func:`manipcad.kinematics.forward.frames`, (N, n, 3, 3), (N, n, 3) m.
        Qd: (N, n) joint rates, rad/s or m/s.

    Returns:
        ``(w, v)`` of shape (N, n, 3) each: rad/s and m/s.

    Example:
        >>> import numpy as np
        >>> import manipcad
        >>> robot = manipcad.load_robot("puma560")
        >>> w, v = body_velocities(robot, *frames(robot, np.zeros((1, 6))), np.ones((1, 6)))
        >>> w.shape
        (1, 6, 3)
    """
    N, n = Qd.shape
    w = np.zeros((N, n, 3))
    v = np.zeros((N, n, 3))
    for i in range(n):
        par = int(robot.parent[i])
        z = R[:, i, :, 2]
        if par >= 0:
            w_par, v_par = w[:, par], v[:, par]
            v_i = v_par + cross(w_par, p[:, i] - p[:, par])
        else:
            w_par = np.zeros((N, 3))
            v_i = np.zeros((N, 3))
        if robot.joint_types[i] == PRISMATIC:
            w[:, i] = w_par
            v[:, i] = v_i + z * Qd[:, i, None]
        else:
            w[:, i] = w_par + z * Qd[:, i, None]
            v[:, i] = v_i
    return w, v
