"""Numerical inverse kinematics: damped least squares (Levenberg-Marquardt).

The task error of a point c on link k (default the tool) is

    e = [x* - x(q)]                          (position only, m), or
    e = [x* - x(q); log(R* · R(q)^T)]        (pose: m and rad, base frame),

and each iteration takes the damped least-squares step

    dq = J^T (J J^T + mu I)^-1 e                 (m <= n), or
    dq = (J^T J + mu I)^-1 J^T e                 (m > n),

with J the rows of the geometric Jacobian that match e. The damping mu is
raised when a step fails to reduce |e| and lowered when it succeeds, so far
from the target the method is a cautious gradient descent and near it a
Gauss-Newton (pseudo-inverse) iteration with quadratic convergence; positions
are reached to ``tol`` (1e-12 m by default). With ``respect_limits`` every
iterate is clipped into the joint limits.

When the error cannot be reduced further (the target is out of reach, outside
the joint limits, or the start is stuck at a singularity) or ``max_iter`` is
used up, :class:`KinematicsError` says how far the closest configuration found
is from the target.
"""

from __future__ import annotations

import numpy as np

from manipcad.errors import InputError, ManipcadError
from manipcad.kinematics.forward import frames, resolve_point
from manipcad.kinematics.jacobian import _jacobian_from_frames
from manipcad.kinematics.rotations import rotation_vector
from manipcad.model.robot import Robot


class KinematicsError(ManipcadError):
    """Inverse kinematics failed: the target is out of reach or the iteration did not converge.

    Attributes:
        q: (n,) the closest configuration found, rad or m.
        position_error: its distance from the target position, m.
        orientation_error: its orientation error, rad (0 for position-only).
    """

    def __init__(self, message: str, q: np.ndarray | None = None,
                 position_error: float = float("nan"),
                 orientation_error: float = 0.0) -> None:
        super().__init__(message)
        self.q = q
        self.position_error = position_error
        self.orientation_error = orientation_error


STALL_STEPS = 20  # accepted steps in a row that cut the squared error by < 1e-6


def _task_error(robot: Robot, q: np.ndarray, k: int, c: np.ndarray, x_goal: np.ndarray,
                R_goal: np.ndarray | None) -> tuple[np.ndarray, np.ndarray]:
    """Task error e (m, rad) and matching Jacobian rows at one configuration."""
    R, p = frames(robot, q[None, :])
    x = p[0, k] + R[0, k] @ c
    J = _jacobian_from_frames(robot, R, p, k, c)[0]
    if R_goal is None:
        return x_goal - x, J[:3]
    Rk = R[0, k] @ _tool_rotation(robot, k)
    e_w = rotation_vector(R_goal @ Rk.T)
    return np.concatenate([x_goal - x, e_w]), J


def _tool_rotation(robot: Robot, k: int) -> np.ndarray:
    return robot.tool_R if k == robot.n - 1 else np.eye(3)


def _damped_step(J: np.ndarray, e: np.ndarray, mu: float) -> np.ndarray:
    m, n = J.shape
    if m <= n:
        return J.T @ np.linalg.solve(J @ J.T + mu * np.eye(m), e)
    return np.linalg.solve(J.T @ J + mu * np.eye(n), J.T @ e)


def inverse_kinematics(
    robot: Robot,
    target: np.ndarray,
    q0: np.ndarray,
    *,
    position_only: bool | None = None,
    link: int | str = -1,
    point: np.ndarray | None = None,
    tol: float = 1e-12,
    max_iter: int = 500,
    respect_limits: bool = True,
) -> np.ndarray:
    """Joint coordinates that put a point (default the tool) at a target.

    Args:
        robot: the robot.
        target: a (3,) position in the base frame (m), or a (4, 4) homogeneous
            pose of the tool frame (translation m) when ``link`` is the last link
            (of the link's body frame otherwise).
        q0: (n,) start of the iteration, rad or m; the solution found is the
            one the iteration reaches from here.
        position_only: match only the position; default True for a (3,) target
            and False for a (4, 4) one.
        link: joint index or name of the link carrying the point; -1 is the last.
        point: (3,) point in the link's body frame, m; default the tool frame
            origin for the last link.
        tol: convergence threshold on the position error (m) and on the
            orientation error (rad).
        max_iter: the most iterations (Jacobian evaluations) allowed.
        respect_limits: keep every iterate inside ``robot.limits``.

    Returns:
        (n,) joint coordinates, rad or m.

    Raises:
        InputError: bad shapes or values of target, q0, tol.
        KinematicsError: no convergence (target out of reach, outside the joint
            limits, or a singular start); carries the closest q found.

    Example:
        >>> import numpy as np
        >>> import manipcad
        >>> from manipcad.kinematics import inverse_kinematics, tool_pose
        >>> robot = manipcad.load_robot("puma560")
        >>> q = inverse_kinematics(robot, [0.5, 0.0, 1.2], np.array([0, 0.8, -1.2, 0, 0.5, 0]))
        >>> bool(np.linalg.norm(tool_pose(robot, q)[:3, 3] - [0.5, 0.0, 1.2]) < 1e-12)
        True
    """
    n = robot.n
    goal = np.asarray(target, dtype=float)
    if goal.shape == (4, 4):
        x_goal, R_goal = goal[:3, 3].copy(), goal[:3, :3].copy()
        if position_only:
            R_goal = None
        elif not np.allclose(R_goal @ R_goal.T, np.eye(3), atol=1e-9):
            raise InputError("target", "", "the rotation part of the pose is not a rotation")
    elif goal.shape == (3,):
        if position_only is False:
            raise InputError("target", "", "an orientation needs a (4, 4) pose target")
        x_goal, R_goal = goal.copy(), None
    else:
        raise InputError("target", "", f"expected a (3,) position or a (4, 4) pose, "
                         f"got shape {goal.shape}")
    if not np.all(np.isfinite(goal)):
        raise InputError("target", "", "values must be finite")
    q = np.asarray(q0, dtype=float).copy()
    if q.shape != (n,) or not np.all(np.isfinite(q)):
        raise InputError("q0", "", f"expected {n} finite joint values, got {np.shape(q0)}")
    if not (tol > 0 and np.isfinite(tol)):
        raise InputError("tol", "", f"must be > 0, got {tol}")
    k, c = resolve_point(robot, link, point)
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    if respect_limits:
        q = np.clip(q, lo, hi)

    def cost(err: np.ndarray) -> float:
        return float(err @ err)

    e, J = _task_error(robot, q, k, c, x_goal, R_goal)
    mu = 1e-3 * max(1e-6, float(np.max(np.sum(J * J, axis=1))))
    it = slow = 0
    while not _converged(e, tol):
        if it >= max_iter:
            _fail(robot, q, e, f"did not converge in {max_iter} iterations", respect_limits)
        it += 1
        while True:
            dq = _damped_step(J, e, mu)
            q_new = q + dq
            if respect_limits:
                q_new = np.clip(q_new, lo, hi)
            e_new, J_new = _task_error(robot, q_new, k, c, x_goal, R_goal)
            if cost(e_new) < cost(e):
                # a run of accepted steps that hardly help: a (constrained) local minimum
                slow = slow + 1 if cost(e_new) > (1.0 - 1e-6) * cost(e) else 0
                q, e, J = q_new, e_new, J_new
                mu = max(mu * 0.1, 1e-30)
                break
            mu *= 10.0
            if mu > 1e12 or float(np.max(np.abs(q_new - q))) < 1e-15:
                slow = STALL_STEPS
                break
        if slow >= STALL_STEPS and not _converged(e, tol):
            _fail(robot, q, e, "the error cannot be reduced further; the target is out of "
                  "reach or q0 is at a singularity", respect_limits)
    return q


def _converged(e: np.ndarray, tol: float) -> bool:
    if np.linalg.norm(e[:3]) > tol:
        return False
    return e.shape[0] == 3 or np.linalg.norm(e[3:]) <= tol


def _fail(robot: Robot, q: np.ndarray, e: np.ndarray, reason: str,
          respect_limits: bool) -> None:
    lo, hi = robot.limits[:, 0], robot.limits[:, 1]
    at_limit = [robot.joint_names[i] for i in range(robot.n) if q[i] <= lo[i] or q[i] >= hi[i]]
    if respect_limits and at_limit:
        reason += f" (joints at their limits: {', '.join(at_limit)})"
    ep = float(np.linalg.norm(e[:3]))
    ew = float(np.linalg.norm(e[3:])) if e.shape[0] > 3 else 0.0
    what = f"{ep:.3g} m" + (f" and {ew:.3g} rad" if e.shape[0] > 3 else "")
    raise KinematicsError(
        f"inverse kinematics of {robot.name!r} failed: {reason}; the closest configuration "
        f"found is {what} from the target (q = {np.array2string(q, precision=4)})",
        q=q.copy(), position_error=ep, orientation_error=ew)
