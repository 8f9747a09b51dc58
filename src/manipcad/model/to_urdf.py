"""``robot_to_urdf(robot)``: the rigid-body model as URDF text.

Each joint becomes a URDF ``revolute`` (``continuous`` when it has no
limits) or ``prismatic`` joint with axis z, its origin the joint placement
with the joint offset folded in (URDF has no offset), so URDF q = manipcad q.
Each link carries its mass (kg), centre of mass (m) and inertia about it
(kg·m², link axes). A tool frame other than the identity is a fixed joint to
a massless link ``tool``. Not in URDF: gravity and the drives (motor,
gearbox, friction) — :func:`save_robot` writes everything. Reading the text
back with ``load_robot`` gives the same kinematics and rigid-body dynamics to
1e-12 (tests/test_model_import.py).
"""

from __future__ import annotations

import math
from pathlib import Path
from xml.sax.saxutils import quoteattr

import numpy as np

from manipcad.fileio import atomic_write_text
from manipcad.model.robot import REVOLUTE, Robot


def rpy_of(R: np.ndarray) -> tuple[float, float, float]:
    """URDF roll, pitch, yaw (rad) of a rotation: R = Rz(yaw)·Ry(pitch)·Rx(roll).

    Example:
        >>> from manipcad.model.urdf import rpy_matrix
        >>> R = rpy_matrix(np.array([0.1, -0.2, 0.3]))
        >>> [round(a, 12) for a in rpy_of(R)]
        [0.1, -0.2, 0.3]
    """
    R = np.asarray(R, dtype=float)
    pitch = math.atan2(-R[2, 0], math.hypot(R[0, 0], R[1, 0]))
    if math.hypot(R[0, 0], R[1, 0]) < 1e-12:  # pitch = ±90°: roll and yaw share one axis
        return math.atan2(-R[1, 2], R[1, 1]), pitch, 0.0
    return math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])


def _f(x: float) -> str:
    return repr(float(x))


def _origin(R: np.ndarray, p: np.ndarray) -> str:
    r = rpy_of(R)
    return (f'<origin xyz="{_f(p[0])} {_f(p[1])} {_f(p[2])}" '
            f'rpy="{_f(r[0])} {_f(r[1])} {_f(r[2])}"/>')


def robot_to_urdf(robot: Robot, path: str | Path | None = None) -> str:
    """The robot as URDF text (see the module docstring); written to ``path`` if given.

    Args:
        robot: the robot.
        path: a file to write (atomically), or None.

    Returns:
        The URDF text.

    Example:
        >>> import manipcad, warnings
        >>> with warnings.catch_warnings():
        ...     warnings.simplefilter("ignore")
        ...     puma = manipcad.load_robot("puma560")
        >>> text = robot_to_urdf(puma)
        >>> manipcad.load_robot(text).n
        6
    """
    # deferred: start-up cost: keeps manipcad.model.urdf out of import manipcad
    from manipcad.model.urdf import rpy_matrix

    used = set(robot.link_names)
    base = next(b for b in ("base_link", "base", "world_base", "base_0") if b not in used)
    lines = ['<?xml version="1.0"?>',
             f"<!-- written by manipcad from {robot.name!r}; gravity "
             f"{np.asarray(robot.gravity).tolist()} m/s² and the drives are not part of URDF "
             "(save_robot keeps them) -->",
             f"<robot name={quoteattr(robot.name)}>", f"  <link name={quoteattr(base)}/>"]
    for i in range(robot.n):
        R, p = robot.placement_R[i].copy(), robot.placement_p[i].copy()
        if robot.joint_types[i] == REVOLUTE:
            R = R @ rpy_matrix(np.array([0.0, 0.0, robot.offset[i]]))
        else:
            p = p + R[:, 2] * robot.offset[i]
        parent = base if robot.parent[i] < 0 else robot.link_names[robot.parent[i]]
        lo, hi = robot.limits[i]
        kind = robot.joint_types[i]
        # 0: no limit (the URDF attribute is required; the loader reads 0 as none)
        given = (("effort", robot.effort_limits[i]), ("velocity", robot.velocity_limits[i]))
        rates = "".join(f' {k}="{_f(v) if np.isfinite(v) else 0}"' for k, v in given)
        if kind == REVOLUTE and not (np.isfinite(lo) or np.isfinite(hi)):
            kind = "continuous"
            limit = (f'\n    <limit{rates}/>' if any(np.isfinite(v) for _, v in given)
                     else "")
        else:
            bounds = "".join(f' {k}="{_f(v)}"' for k, v in (("lower", lo), ("upper", hi))
                             if np.isfinite(v))
            limit = f'\n    <limit{bounds}{rates}/>'
        c, I = robot.com[i], robot.inertia[i]
        link = robot.link_names[i]
        lines += [
            f"  <link name={quoteattr(link)}>",
            "    <inertial>",
            f'      <origin xyz="{_f(c[0])} {_f(c[1])} {_f(c[2])}" rpy="0 0 0"/>',
            f'      <mass value="{_f(robot.mass[i])}"/>',
            f'      <inertia ixx="{_f(I[0, 0])}" ixy="{_f(I[0, 1])}" ixz="{_f(I[0, 2])}" '
            f'iyy="{_f(I[1, 1])}" iyz="{_f(I[1, 2])}" izz="{_f(I[2, 2])}"/>',
            "    </inertial>",
            "  </link>",
            f"  <joint name={quoteattr(robot.joint_names[i])} type=\"{kind}\">",
            f"    <parent link={quoteattr(parent)}/>",
            f"    <child link={quoteattr(link)}/>",
            f"    {_origin(R, p)}",
            f'    <axis xyz="0 0 1"/>{limit}',
            "  </joint>"]
    if not (np.allclose(robot.tool_R, np.eye(3)) and not np.any(robot.tool_p)) and robot.n:
        tool = next(t for t in ("tool", "tool0", "tool_frame") if t not in used)
        lines += [f"  <link name={quoteattr(tool)}/>",
                  f"  <joint name={quoteattr(tool + '_joint')} type=\"fixed\">",
                  f"    <parent link={quoteattr(robot.link_names[-1])}/>",
                  f"    <child link={quoteattr(tool)}/>",
                  f"    {_origin(robot.tool_R, robot.tool_p)}",
                  "  </joint>"]
    lines.append("</robot>")
    text = "\n".join(lines) + "\n"
    if path is not None:

        atomic_write_text(path, text)
    return text


__all__ = ["robot_to_urdf", "rpy_of"]
