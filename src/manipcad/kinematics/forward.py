"""Forward kinematics: the pose of every body frame and of the tool in the base frame.

The robot is the kinematic tree of :mod:`manipcad.model.robot`: joint ``i`` is a
fixed placement ``(R_i, p_i)`` in its parent's body frame followed by a motion
about the local z axis by ``q_i + offset_i`` (a rotation in rad for a revolute
joint, a translation in m for a prismatic one). Walking the tree from the base
(parents precede children) gives, for body frame ``i`` in the base frame,

    R_0i = R_0,parent · R_i · Rot_z(q_i + offset_i)                    (revolute)
    R_0i = R_0,parent · R_i,     p_0i = p_0,parent + R_0,parent · p_i
                                        + R_0i · e_z · (q_i + offset_i)  (prismatic)

Every function takes one configuration ``q`` of shape (n,) or a batch of shape
(N, n) and returns the matching shape.
"""

from __future__ import annotations

import numpy as np

from manipcad.errors import InputError
from manipcad.kinematics.rotations import rot_z_batch
from manipcad.model.robot import PRISMATIC, Robot


def as_batch(robot: Robot, q: np.ndarray, name: str = "q") -> tuple[np.ndarray, bool]:
    """Check a joint vector (n,) or batch (N, n) and return it as (N, n) floats.

    Returns:
        ``(Q, batched)``: Q of shape (N, n) (N = 1 for a single vector) and
        whether the input was a batch.

    Raises:
        InputError: wrong shape or non-finite values, naming ``name``.

    Example:
        >>> import numpy as np
        >>> import manipcad
        >>> robot = manipcad.load_robot("puma560")
        >>> Q, batched = as_batch(robot, np.zeros(6))
        >>> Q.shape, batched
        ((1, 6), False)
    """
    a = np.asarray(q, dtype=float)
    if a.ndim == 1 and a.shape[0] == robot.n:
        batched = False
        a = a[None, :]
    elif a.ndim == 2 and a.shape[1] == robot.n:
        batched = True
    else:
        raise InputError(name, "", f"expected shape ({robot.n},) or (N, {robot.n}) for "
                         f"{robot.name!r}, got {a.shape}")
    if not np.all(np.isfinite(a)):
        raise InputError(name, "", "values must be finite")
    return a, batched


def frames(robot: Robot, Q: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rotations and origins of every body frame in the base frame for a batch.

    Args:
        robot: the robot.
        Q: (N, n) joint coordinates, rad or m.

    Returns:
        ``(R, p)``: R of shape (N, n, 3, 3) and p of shape (N, n, 3) in m.

    Example:
        >>> import numpy as np
        >>> import manipcad
        >>> robot = manipcad.load_robot("puma560")
        >>> R, p = frames(robot, np.zeros((4, 6)))
        >>> R.shape, p.shape
        ((4, 6, 3, 3), (4, 6, 3))
    """
    N, n = Q.shape
    R = np.empty((N, n, 3, 3))
    p = np.empty((N, n, 3))
    motion = Q + robot.offset[None, :]
    for i in range(n):
        par = int(robot.parent[i])
        Rp, pp = robot.placement_R[i], robot.placement_p[i]
        if par < 0:
            Rj = np.broadcast_to(Rp, (N, 3, 3))
            oj = np.broadcast_to(pp, (N, 3))
        else:
            Rj = R[:, par] @ Rp
            oj = p[:, par] + R[:, par] @ pp
        if robot.joint_types[i] == PRISMATIC:
            R[:, i] = Rj
            p[:, i] = oj + Rj[:, :, 2] * motion[:, i, None]
        else:
            R[:, i] = Rj @ rot_z_batch(motion[:, i])
            p[:, i] = oj
    return R, p


def _homogeneous(R: np.ndarray, p: np.ndarray) -> np.ndarray:
    T = np.zeros(R.shape[:-2] + (4, 4))
    T[..., :3, :3] = R
    T[..., :3, 3] = p
    T[..., 3, 3] = 1.0
    return T


def forward_kinematics(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Homogeneous transforms of every body frame in the base frame.

    Args:
        robot: the robot.
        q: joint coordinates (rad for revolute, m for prismatic joints), shape
            (n,) or a batch (N, n).

    Returns:
        (n, 4, 4), or (N, n, 4, 4) for a batch: ``T[i]`` maps body-frame-i
        coordinates to base-frame coordinates (translations in m).

    Raises:
        InputError: q of the wrong shape or not finite.

    Example:
        >>> import numpy as np
        >>> import manipcad
        >>> robot = manipcad.load_robot("puma560")
        >>> forward_kinematics(robot, np.zeros(robot.n)).shape
        (6, 4, 4)
    """
    Q, batched = as_batch(robot, q)
    T = _homogeneous(*frames(robot, Q))
    return T if batched else T[0]


def tool_pose(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Homogeneous transform of the tool (gripper) frame in the base frame.

    The tool frame is ``(robot.tool_R, robot.tool_p)`` in the last link's body frame.

    Args:
        robot: the robot.
        q: joint coordinates (rad or m), shape (n,) or (N, n).

    Returns:
        (4, 4), or (N, 4, 4) for a batch; translation in m.

    Example:
        >>> import numpy as np
        >>> import manipcad
        >>> robot = manipcad.load_robot("puma560")
        >>> tool_pose(robot, np.zeros((10, 6))).shape
        (10, 4, 4)
    """
    Q, batched = as_batch(robot, q)
    R, p = frames(robot, Q)
    Rt = R[:, -1] @ robot.tool_R
    pt = p[:, -1] + R[:, -1] @ robot.tool_p
    T = _homogeneous(Rt, pt)
    return T if batched else T[0]


def stick_points(robot: Robot, q: np.ndarray) -> np.ndarray:
    """The arm as a stick figure at pose ``q``: line segments joint to joint, then the tool.

    Args:
        robot: the robot.
        q: (n,) joint coordinates, rad or m.

    Returns:
        (S, 2, 3) segment end points in the base frame, m: for each joint, from its
        parent's frame origin (the base origin for a root joint) to its own, and
        from the last body's origin to the tool point.

    Example:
        >>> import manipcad
        >>> stick_points(manipcad.load_robot("puma560"), [0.0] * 6).shape
        (7, 2, 3)
    """
    qa = np.asarray(q, dtype=float).reshape(1, -1)
    _, p = frames(robot, qa)
    p = p[0]
    segs = []
    for i in range(robot.n):
        par = int(robot.parent[i])
        segs.append((np.zeros(3) if par < 0 else p[par], p[i]))
    segs.append((p[-1], tool_pose(robot, qa)[0, :3, 3]))
    return np.asarray(segs)


def point_position(robot: Robot, q: np.ndarray, link: int | str = -1,
                   point: np.ndarray | None = None) -> np.ndarray:
    """Base-frame position of a point fixed on a link.

    Args:
        robot: the robot.
        q: joint coordinates (rad or m), (n,) or (N, n).
        link: joint index or name of the link (default the last one).
        point: (3,) coordinates in the link's body frame, m; default the tool
            frame origin for the last link and the body frame origin otherwise.

    Returns:
        (3,) or (N, 3), m.

    Example:
        >>> import numpy as np
        >>> import manipcad
        >>> robot = manipcad.load_robot("puma560")
        >>> point_position(robot, np.zeros(robot.n)).shape
        (3,)
    """
    Q, batched = as_batch(robot, q)
    k, c = resolve_point(robot, link, point)
    R, p = frames(robot, Q)
    x = p[:, k] + R[:, k] @ c
    return x if batched else x[0]


def resolve_point(robot: Robot, link: int | str,
                  point: np.ndarray | None) -> tuple[int, np.ndarray]:
    """Link index and body-frame point (m) with the defaults of :func:`point_position`.

    Example:
        >>> import manipcad
        >>> resolve_point(manipcad.load_robot("puma560"), -1, None)[0]
        5
    """
    k = robot.joint_index(link)
    if point is None:
        c = robot.tool_p.copy() if k == robot.n - 1 else np.zeros(3)
    else:
        c = np.asarray(point, dtype=float)
        if c.shape != (3,) or not np.all(np.isfinite(c)):
            raise InputError("point", "", f"expected 3 finite coordinates in m, got {c!r}")
    return k, c


def ancestors(robot: Robot, link: int) -> list[int]:
    """Joint indices on the path from the base to ``link`` (inclusive), base first.

    Example:
        >>> import manipcad
        >>> ancestors(manipcad.load_robot("puma560"), 2)
        [0, 1, 2]
    """
    chain = []
    j = int(link)
    while j >= 0:
        chain.append(j)
        j = int(robot.parent[j])
    return chain[::-1]
