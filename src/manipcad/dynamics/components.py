"""The split of each drive's torque into the paper's constituents (section 2, Fig. 1).

    P_i = H_ii q̈_i + Σ_{j≠i} H_ij q̈_j + h_i + Q_i + M_i + (drive terms)

H_ii q̈_i is the joint's own inertial constituent, the sum over j ≠ i the
inertial coupling from the other joints' accelerations, h_i the velocity
(Coriolis and centrifugal) constituent, Q_i gravity, M_i the external action
and the drive terms the rotor inertia J·i_r²·q̈_i and friction. The adaptive
regulators read H_ii, h_i and Q_i from here.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manipcad.dynamics.api import inverse_dynamics, mass_matrix
from manipcad.model.robot import COL_JR, Robot


@dataclass(frozen=True)
class TorqueComponents:
    """Constituents of the joint torques, each shaped like q ((n,) or (N, n)).

    Attributes:
        H_ii: diagonal of the rigid-body inertia matrix, kg·m² (kg for prismatic).
        inertial: own inertial constituent H_ii·q̈_i, N·m (N).
        coupling: Σ_{j≠i} H_ij·q̈_j, inertial coupling from the other joints, N·m (N).
        velocity: h_i, Coriolis and centrifugal constituent, N·m (N).
        gravity: Q_i, gravity constituent, N·m (N).
        external: M_i, from the external wrenches on the links, N·m (N).
        rotor: J·i_r²·q̈_i, rotor and gearbox inertia, N·m (N).
        friction: k_v·i_r²·q̇_i + |i_r|·M_f·sign(q̇_i), N·m (N).
    """

    H_ii: np.ndarray
    inertial: np.ndarray
    coupling: np.ndarray
    velocity: np.ndarray
    gravity: np.ndarray
    external: np.ndarray
    rotor: np.ndarray
    friction: np.ndarray

    @property
    def total(self) -> np.ndarray:
        """The whole drive torque P_i, N·m (N): equals :func:`inverse_dynamics` with drives."""
        return (self.inertial + self.coupling + self.velocity + self.gravity + self.external
                + self.rotor + self.friction)


def torque_components(robot: Robot, q, qd, qdd, *, gravity=None, f_ext=None) -> TorqueComponents:
    """Split the drive torques along a motion into the paper's constituents.

    Args:
        robot: the manipulator.
        q, qd, qdd: joint positions, velocities, accelerations (SI), (n,) or (N, n).
        gravity: gravity in the base frame, m/s² (default the robot's).
        f_ext: external wrenches on the links as in :func:`inverse_dynamics`.

    Returns:
        :class:`TorqueComponents`; ``.total`` equals ``inverse_dynamics(robot, q, qd, qdd)``.

    Example:
        >>> import numpy as np, manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> parts = manipcad.torque_components(arm, np.zeros(3), np.ones(3), np.ones(3))
        >>> parts.coupling.shape
        (3,)
    """
    qdd = np.asarray(qdd, dtype=float)
    zero = np.zeros_like(qdd)
    H = mass_matrix(robot, q, drives=False)
    H_ii = np.diagonal(H, axis1=-2, axis2=-1).copy()
    inertial = H_ii * qdd
    coupling = np.einsum("...ij,...j->...i", H, qdd) - inertial
    no_g = np.zeros(3)
    velocity = inverse_dynamics(robot, q, qd, zero, gravity=no_g, drives=False)
    grav = inverse_dynamics(robot, q, zero, zero, gravity=gravity, drives=False)
    if f_ext is None:
        external = np.zeros_like(inertial)
    else:
        external = inverse_dynamics(robot, q, zero, zero, gravity=no_g, f_ext=f_ext,
                                    drives=False)
    with_drives = inverse_dynamics(robot, q, qd, zero, gravity=no_g, drives=True)
    friction = with_drives - velocity
    rotor = robot.table[:, COL_JR] * qdd
    return TorqueComponents(H_ii, inertial, coupling, velocity, grav, external, rotor, friction)
