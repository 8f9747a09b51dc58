"""Counterweights that take the gravity load off a joint (paper section 2: decoupling devices).

The paper asks for kinematic schemes or mechanical devices that decouple the drives
"where it is possible". Gravity is the constituent Q_i a device can take off without
any control: a counterweight fixed to link i, on the far side of joint i's axis.

The device is modelled as what it is, a rigid body on the link (a steel sphere,
folded into the link's mass, centre of mass and inertia with
:meth:`~manipcad.model.robot.Robot.with_payload`), so every command (sizing,
simulation, synthesis, code generation) sees it, it saves with the robot file
(:meth:`Robot.save`) and it loads back to the identical model. It takes gravity
torque off joint i, adds its weight to the joints before i whose axes are not
vertical, and adds inertia (m·r² and the sphere's own) to joint i and the joints
before it: :func:`fit_counterweight` fits it, and the caller weighs what it changes.

The fit, in closed form. A mass m at c (m, link i's body frame) adds to the
holding torque of a revolute joint i

    Q_i,cw(q) = -m·g·(z_i × R_i c) = -s·((R_iᵀ g) × e_z),    s = m·c (kg·m),

linear in the first moment s, where R_i(q) is link i's orientation in the base
frame, g the gravity vector and e_z the joint axis in the body frame. Only s_x,
s_y act (the component along the axis gives no torque about it). Over the
configurations q_k of the trajectories, s minimizes Σ_k (Q_i(q_k) + a_k·s)²
with a_k = -(R_iᵀ(q_k) g) × e_z: the normal equations give s = -(AᵀA)⁻¹AᵀQ.
The counterweight's arm r (distance from the axis, m) is free: m = |s|/r, the
inertia it adds about the axis ≈ |s|·r; :func:`fit_counterweight` takes r.

Prismatic joints are not given a counterweight on the link (it would add to the
weight the joint lifts); a vertical lift is balanced by a counterweight on a pulley
or a constant-force spring, which this model does not carry.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass

import numpy as np

from manipcad.dynamics import inverse_dynamics
from manipcad.errors import InputError
from manipcad.fileio import json_safe
from manipcad.kinematics.forward import forward_kinematics
from manipcad.model.robot import REVOLUTE, Robot

SOURCE = "counterbalance"
#: density of the counterweight's material (steel), kg/m³
STEEL = 7850.0


@dataclass(frozen=True)
class Counterweight:
    """A counterweight on the link of one revolute joint.

    Attributes:
        joint: the joint's name; index: its 0-based index.
        mass: the counterweight's mass, kg.
        com: its centre, m, in the body frame of the joint's link (the frame after the
            joint's motion, z along the axis).
        arm: its distance from the joint axis, m.
        radius: the radius of a steel sphere of that mass, m.
        inertia: its own inertia about its centre (a solid sphere, 2/5·m·ρ²), kg·m².
        first_moment: (s_x, s_y) = m·(c_x, c_y), kg·m: what the fit determines.
        gravity_peak_before, gravity_peak_after: peak |Q_i| over the configurations
            fitted, without and with it, N·m.
        gravity_rms_before, gravity_rms_after: RMS of Q_i over them, N·m.
    """

    joint: str
    index: int
    mass: float
    com: tuple[float, float, float]
    arm: float
    radius: float
    inertia: float
    first_moment: tuple[float, float]
    gravity_peak_before: float
    gravity_peak_after: float
    gravity_rms_before: float
    gravity_rms_after: float

    def apply(self, robot: Robot) -> Robot:
        """The robot with this counterweight folded into the link's body.

        Example:
            >>> import numpy as np
            >>> cw = Counterweight("q1", 0, 2.0, (-0.1, 0.0, 0.0), 0.1, 0.04, 1e-3,
            ...                    (-0.2, 0.0), 1.0, 0.0, 1.0, 0.0)
            >>> arm = pendulum(mass=1.0, length=0.2)
            >>> float(cw.apply(arm).mass[0])
            3.0
        """
        return robot.with_payload(self.mass, self.com, np.eye(3) * self.inertia,
                                  link=self.index)

    def to_dict(self) -> dict:
        """A JSON-ready mapping (SI units: kg, m, kg·m², kg·m, N·m)."""
        return json_safe(asdict(self))


def pendulum(mass: float = 1.0, length: float = 0.5) -> Robot:
    """One revolute joint with a horizontal axis carrying a point mass: the test case.

    The joint axis is the base y axis turned onto z; at q = 0 the mass hangs out
    horizontally along the body x axis, so its holding torque is
    Q = m·g·l·cos q (N·m).

    Args:
        mass: the point mass, kg.
        length: its distance from the axis, m.

    Example:
        >>> from manipcad.dynamics import inverse_dynamics
        >>> arm = pendulum(2.0, 0.5)
        >>> round(float(inverse_dynamics(arm, np.zeros(1), np.zeros(1), np.zeros(1))[0]), 4)
        9.81
    """
    R = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])  # axis: base -y
    return Robot.from_arrays("pendulum", ["revolute"], [-1], R[None], np.zeros((1, 3)),
                             [mass], [[length, 0.0, 0.0]], np.zeros((1, 3, 3)),
                             joint_names=["q1"])


def _body_rotations(robot: Robot, q: np.ndarray) -> np.ndarray:

    return forward_kinematics(robot, q)[:, :, :3, :3]


def gravity_regressor(robot: Robot, q: np.ndarray, joint: int) -> np.ndarray:
    """a_k with Q_i,cw(q_k) = a_k·s for a first moment s on link ``joint`` (see the module).

    Args:
        robot: the robot.
        q: (N, n) configurations, rad or m.
        joint: the revolute joint's index.

    Returns:
        (N, 3) rows a_k, N·m per kg·m (their third entry is 0).

    Example:
        >>> arm = pendulum(1.0, 0.5)
        >>> a = gravity_regressor(arm, np.array([[0.0], [np.pi / 2]]), 0)
        >>> (np.round(a, 4) + 0.0).tolist()   # s along +x adds m·g·l·cos q, like the mass
        [[9.81, 0.0, 0.0], [0.0, -9.81, 0.0]]
    """
    R = _body_rotations(robot, np.atleast_2d(q))[:, joint]
    g_body = np.einsum("kji,j->ki", R, np.asarray(robot.gravity, dtype=float))
    return -np.cross(g_body, np.array([0.0, 0.0, 1.0]))


def _check_q(robot: Robot, q) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if q.ndim != 2 or q.shape[1] != robot.n or len(q) < 1 or not np.isfinite(q).all():
        raise InputError(SOURCE, "q", f"must be finite configurations of shape (N, {robot.n}), "
                         f"got shape {q.shape}")
    return q


def holding_torque(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Q(q), the gravity constituent of every joint at each configuration, N·m (N): (N, n)."""

    z = np.zeros_like(q)
    return inverse_dynamics(robot, q, z, z, drives=False)


def fit_counterweight(robot: Robot, q, joint: int | str, *, arm: float,
                      density: float = STEEL) -> Counterweight | None:
    """The counterweight on ``joint``'s link that minimizes its gravity torque over ``q``.

    Args:
        robot: the robot (its own links, payload and any counterweights already fitted).
        q: (N, n) configurations the trajectories pass through, rad or m.
        joint: a revolute joint, index or name.
        arm: the counterweight's distance from the axis, m (> 0): the mass is |s|/arm.
        density: its material's density, kg/m³ (steel by default).

    Returns:
        The :class:`Counterweight` (least squares, closed form: see the module), or None
        when the joint's gravity torque does not depend on its link's orientation (a
        vertical axis: nothing to balance).

    Raises:
        InputError: a prismatic joint, a bad arm, density or configuration array.

    Example:
        >>> arm = pendulum(2.0, 0.5)
        >>> q = np.linspace(-1.5, 1.5, 31)[:, None]
        >>> cw = fit_counterweight(arm, q, 0, arm=0.25)
        >>> round(cw.mass, 6), [round(x, 6) for x in cw.com], round(cw.gravity_peak_after, 9)
        (4.0, [-0.25, 0.0, 0.0], 0.0)
    """
    j = robot.joint_index(joint)
    if robot.joint_types[j] != REVOLUTE:
        raise InputError(SOURCE, "joint", f"{robot.joint_names[j]!r} is prismatic: a "
                         "counterweight on its link would add to the weight it lifts")
    if not (isinstance(arm, int | float) and math.isfinite(arm) and arm > 0):
        raise InputError(SOURCE, "arm", f"must be a distance > 0 m, got {arm!r}")
    if not (isinstance(density, int | float) and math.isfinite(density) and density > 0):
        raise InputError(SOURCE, "density", f"must be > 0 kg/m³, got {density!r}")
    q = _check_q(robot, q)
    Q = holding_torque(robot, q)[:, j]
    A = gravity_regressor(robot, q, j)[:, :2]
    scale = float(np.abs(A).max()) if A.size else 0.0
    if scale <= 1e-9 * float(np.linalg.norm(robot.gravity)) or \
            np.linalg.matrix_rank(A, tol=1e-9 * max(scale, 1.0)) == 0:
        return None
    s, *_ = np.linalg.lstsq(A, -Q, rcond=None)
    norm = float(np.hypot(*s))
    if norm == 0.0:
        return None
    mass = norm / float(arm)
    z = float(robot.com[j][2])
    com = (float(s[0] / mass), float(s[1] / mass), z)
    radius = (3.0 * mass / (4.0 * math.pi * density)) ** (1.0 / 3.0)
    after = Q + A @ s
    return Counterweight(
        joint=robot.joint_names[j], index=j, mass=mass, com=com, arm=float(arm),
        radius=radius, inertia=0.4 * mass * radius ** 2,
        first_moment=(float(s[0]), float(s[1])),
        gravity_peak_before=float(np.abs(Q).max()), gravity_peak_after=float(np.abs(after).max()),
        gravity_rms_before=float(np.sqrt(np.mean(Q ** 2))),
        gravity_rms_after=float(np.sqrt(np.mean(after ** 2))))


def apply_counterweights(robot: Robot, weights) -> Robot:
    """The robot with every counterweight of ``weights`` folded into its link.

    Example:
        >>> apply_counterweights(pendulum(), []).mass.tolist()
        [1.0]
    """
    for cw in weights:
        robot = cw.apply(robot)
    return robot


__all__ = ["Counterweight", "fit_counterweight", "gravity_regressor", "holding_torque",
           "apply_counterweights", "pendulum", "STEEL"]
