"""Map another library's kinematic tree onto manipcad's (joint motion along local z).

Every importer (Robotics Toolbox, Pinocchio, MuJoCo) describes a joint ``i`` as
a fixed transform ``A`` from its parent's link frame, a motion about (or along)
a unit ``axis`` given in the frame after ``A``, then a fixed transform ``B``
to the source library's link frame, where the link's mass, centre of mass and
inertia are given::

    L_i = L_parent · A · Motion(axis, q + offset) · B

With ``R_a`` a rotation taking z onto ``axis`` (``Motion(axis, x) = R_a ·
Motion(z, x) · R_aᵀ``), manipcad's joint frame is ``F_i = L_parent · A · R_a ·
Motion(z, q + offset)`` and ``L_i = F_i · X_i`` with ``X_i = [R_aᵀ, 0] · B``.
So the placement of joint i in its parent's manipcad frame is ``X_parent · A ·
R_a``, the centre of mass is ``X_i`` applied to the source's, and the inertia
is rotated by ``X_i``'s rotation. Lengths m, masses kg, inertias kg·m².
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field

import numpy as np

from manipcad.model.robot import Drive, Robot, combine_bodies
from manipcad.model.urdf import align_z


@dataclass
class SourceJoint:
    """One joint of a source model (see the module docstring; 4×4 homogeneous transforms).

    Attributes:
        name: joint name.
        kind: "revolute" or "prismatic".
        parent: index of the parent joint in the list, -1 for the base.
        A: (4, 4) parent link frame -> frame before the motion.
        axis: (3,) unit motion axis in the frame after ``A``.
        B: (4, 4) frame after the motion -> the source's link frame.
        mass: link mass, kg.
        com: (3,) centre of mass in the source link frame, m.
        inertia: (3, 3) inertia about the centre of mass, source link axes, kg·m².
        offset: added to q before the motion, rad or m.
        limits: (lower, upper), rad or m.
        link: link name.
        drive: the joint's drive or None.
    """

    name: str
    kind: str
    parent: int
    A: np.ndarray
    axis: np.ndarray
    B: np.ndarray = field(default_factory=lambda: np.eye(4))
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))
    offset: float = 0.0
    limits: tuple[float, float] = (-np.inf, np.inf)
    link: str = ""
    drive: Drive | None = None


def homogeneous(R: np.ndarray | None = None, p: Sequence[float] | None = None) -> np.ndarray:
    """A 4×4 transform from a rotation (default identity) and a translation (m).

    Example:
        >>> homogeneous(p=[1, 2, 3])[:3, 3].tolist()
        [1.0, 2.0, 3.0]
    """
    T = np.eye(4)
    if R is not None:
        T[:3, :3] = R
    if p is not None:
        T[:3, 3] = p
    return T


def robot_from_joints(name: str, joints: Sequence[SourceJoint], *, base: np.ndarray | None = None,
                      gravity: Sequence[float] = (0.0, 0.0, -9.81),
                      tool: np.ndarray | None = None, source: str = "") -> Robot:
    """Build a validated :class:`Robot` from source joints (parents before children).

    Args:
        name: the robot's name.
        joints: the joints (see :class:`SourceJoint`).
        base: (4, 4) world -> the base's link frame (default identity).
        gravity: (3,) in the world (base) frame, m/s².
        tool: (4, 4) tool frame in the last joint's source link frame, or None.
        source: where the model came from (``Robot.source``).

    Returns:
        The robot; its dynamics equal the source's.
    """

    base = np.eye(4) if base is None else np.asarray(base, dtype=float)
    n = len(joints)
    X = []  # source link frame in manipcad's joint frame
    R_pl, p_pl, com, inertia = (np.zeros((n, 3, 3)), np.zeros((n, 3)), np.zeros((n, 3)),
                                np.zeros((n, 3, 3)))
    for i, j in enumerate(joints):
        Ra = align_z(np.asarray(j.axis, dtype=float))
        parent_X = base if j.parent < 0 else X[j.parent]
        P = parent_X @ np.asarray(j.A, dtype=float) @ homogeneous(Ra)
        R_pl[i], p_pl[i] = P[:3, :3], P[:3, 3]
        Xi = homogeneous(Ra.T) @ np.asarray(j.B, dtype=float)
        X.append(Xi)
        com[i] = Xi[:3, :3] @ np.asarray(j.com, dtype=float) + Xi[:3, 3]
        inertia[i] = Xi[:3, :3] @ np.asarray(j.inertia, dtype=float) @ Xi[:3, :3].T
    tool_R = tool_p = None
    if tool is not None and n:
        T = X[-1] @ np.asarray(tool, dtype=float)
        tool_R, tool_p = T[:3, :3], T[:3, 3]
    return Robot.from_arrays(
        name, [j.kind for j in joints], [j.parent for j in joints], R_pl, p_pl,
        [float(j.mass) for j in joints], com, 0.5 * (inertia + inertia.transpose(0, 2, 1)),
        offset=[float(j.offset) for j in joints], joint_names=[j.name for j in joints],
        drives=[j.drive for j in joints], gravity=gravity,
        limits=np.array([j.limits for j in joints], dtype=float).reshape(n, 2),
        link_names=[j.link or f"link{i + 1}" for i, j in enumerate(joints)],
        tool_R=tool_R, tool_p=tool_p, source=source)


@dataclass
class SourceBody:
    """A body of a source tree that may be welded to its parent (no joint).

    Attributes:
        name: body (link) name.
        parent: index of the parent body in the list, -1 for the base.
        T: (4, 4) parent body frame -> this body's frame before its joint.
        joint: the joint's (name, kind, axis, B, offset, limits, drive), or None
            for a body welded to its parent.
        mass, com, inertia: in this body's frame (kg, m, kg·m² about the com).
    """

    name: str
    parent: int
    T: np.ndarray
    joint: tuple | None
    mass: float = 0.0
    com: np.ndarray = field(default_factory=lambda: np.zeros(3))
    inertia: np.ndarray = field(default_factory=lambda: np.zeros((3, 3)))


def joints_from_bodies(bodies: Sequence[SourceBody]) -> list[SourceJoint]:
    """Collapse welded bodies into their nearest moving ancestor (parents first).

    A welded body's mass joins the moving link it is fixed to (combined about
    the common centre of mass, :func:`manipcad.model.robot.combine_bodies`);
    bodies welded to the base do not move and are dropped. The joints of
    bodies below a welded one get the welded transforms in their ``A``.
    """

    joints: list[SourceJoint] = []
    anchor: list[tuple[int, np.ndarray]] = []  # per body: (joint index or -1, anchor <- body)
    for b in bodies:
        if b.parent < 0:
            up, T_up = -1, np.eye(4)
        else:
            up, T_up = anchor[b.parent]
        T = T_up @ np.asarray(b.T, dtype=float)
        if b.joint is None:
            anchor.append((up, T))
            if up >= 0 and b.mass > 0:
                j = joints[up]
                R = T[:3, :3]
                m, c, I = combine_bodies(j.mass, j.com, j.inertia, float(b.mass),
                                         R @ np.asarray(b.com, float) + T[:3, 3],
                                         R @ np.asarray(b.inertia, float) @ R.T)
                j.mass, j.com, j.inertia = m, c, I
            continue
        name, kind, axis, B, offset, limits, drive = b.joint
        B = np.asarray(B, dtype=float)
        # the body's own inertia is given in its frame L = ... · Motion · B
        joints.append(SourceJoint(name=name, kind=kind, parent=up, A=T, axis=axis, B=B,
                                  mass=float(b.mass), com=np.asarray(b.com, float),
                                  inertia=np.asarray(b.inertia, float), offset=offset,
                                  limits=limits, link=b.name, drive=drive))
        anchor.append((len(joints) - 1, np.eye(4)))
    return joints
