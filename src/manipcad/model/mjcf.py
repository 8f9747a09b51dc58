"""Robots from MJCF (MuJoCo XML) through the ``mujoco`` package's own parser.

``load_mjcf(path)`` compiles the file with ``mujoco.MjModel.from_xml_path``
and maps the compiled model (bodies, hinge and slide joints, inertias, gravity)
onto a :class:`~manipcad.model.Robot`: a body welded to its parent (no joint)
joins its parent's link; free and ball joints and bodies with several joints
are refused. A joint's ``ref`` (qpos0) becomes the joint offset −ref, so q
is MuJoCo's qpos. ``armature`` (kg·m², kg), ``damping`` (N·m·s/rad) and
``frictionloss`` (N·m) become a drive with ratio 1 (J, k_v, M_f). The inverse
dynamics and mass matrix equal MuJoCo's ``mj_inverse`` and ``mj_fullM``
(tests/test_model_import.py).
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from manipcad.errors import InputError
from manipcad.model.convert import SourceBody, homogeneous, joints_from_bodies, robot_from_joints
from manipcad.model.robot import PRISMATIC, REVOLUTE, Drive, Robot


def _quat(q) -> np.ndarray:
    """Rotation matrix of a MuJoCo quaternion (w, x, y, z)."""
    w, x, y, z = np.asarray(q, dtype=float) / np.linalg.norm(q)
    return np.array([[1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
                     [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
                     [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)]])


def _mujoco():
    try:
        import mujoco  # deferred: optional dependency
    except ImportError:
        raise InputError("MJCF", "", "reading MJCF needs the mujoco package "
                         "(pip install mujoco)") from None
    return mujoco


def load_mjcf(path: str | Path) -> Robot:
    """Load a robot from an MJCF file (MuJoCo's parser and compiler).

    Args:
        path: the .xml file (SI units as MuJoCo's: m, kg, rad unless the file
            says ``angle="degree"``, which the compiler converts).

    Returns:
        The robot.

    Raises:
        InputError: MuJoCo cannot read the file (its message), or a joint
            manipcad does not model (named).

    Example:
        >>> from manipcad.model.mjcf import load_mjcf
        >>> arm = load_mjcf("arm.xml")  # doctest: +SKIP
    """
    mujoco = _mujoco()
    src = str(path)
    if not Path(path).is_file():
        raise InputError(src, "", "no such file")
    try:
        model = mujoco.MjModel.from_xml_path(src)
    except ValueError as exc:
        raise InputError(src, "", f"MuJoCo cannot read it: {exc}") from None
    return robot_from_mujoco(model, source=src, name=Path(src).stem)


def robot_from_mjcf_string(text: str, source: str = "<string>") -> Robot:
    """A robot from MJCF text (see :func:`load_mjcf`)."""
    mujoco = _mujoco()
    try:
        model = mujoco.MjModel.from_xml_string(text)
    except ValueError as exc:
        raise InputError(source, "", f"MuJoCo cannot read it: {exc}") from None
    return robot_from_mujoco(model, source=source)


def robot_from_mujoco(model, *, source: str = "mujoco.MjModel", name: str | None = None) -> Robot:
    """A :class:`~manipcad.model.Robot` from a compiled ``mujoco.MjModel``.

    Args:
        model: the compiled model.
        source: where it came from (for errors and ``Robot.source``).
        name: the robot's name (default the model's).

    Returns:
        The robot; its joints in MuJoCo's joint order.
    """
    mujoco = _mujoco()
    hinge, slide = int(mujoco.mjtJoint.mjJNT_HINGE), int(mujoco.mjtJoint.mjJNT_SLIDE)
    bodies: list[SourceBody] = []
    index = {0: -1}  # MuJoCo body id -> position in ``bodies``
    for b in range(1, model.nbody):
        parent = index[int(model.body_parentid[b])]
        T = homogeneous(_quat(model.body_quat[b]), model.body_pos[b])
        bname = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_BODY, b) or f"body{b}"
        nj = int(model.body_jntnum[b])
        spec = None
        if nj > 1:
            raise InputError(source, f"body {bname!r}", f"{nj} joints in one body; manipcad "
                             "models one joint per link")
        if nj == 1:
            j = int(model.body_jntadr[b])
            jname = mujoco.mj_id2name(model, mujoco.mjtObj.mjOBJ_JOINT, j) or f"joint{j}"
            jtype = int(model.jnt_type[j])
            if jtype not in (hinge, slide):
                raise InputError(source, f"joint {jname!r}", "free and ball joints are not "
                                 "modelled; manipcad takes hinge and slide joints")
            kind = REVOLUTE if jtype == hinge else PRISMATIC
            jpos = np.asarray(model.jnt_pos[j], dtype=float)
            axis = np.asarray(model.jnt_axis[j], dtype=float)
            axis = axis / np.linalg.norm(axis)
            T = T @ homogeneous(p=jpos)
            B = homogeneous(p=-jpos)
            dof = int(model.jnt_dofadr[j])
            arm, damp = float(model.dof_armature[dof]), float(model.dof_damping[dof])
            fric = float(model.dof_frictionloss[dof])
            drive = Drive(J=arm, ratio=1.0, k_v=damp, M_f=fric) \
                if arm or damp or fric else None
            limits = (-np.inf, np.inf)
            if model.jnt_limited[j]:
                limits = (float(model.jnt_range[j][0]), float(model.jnt_range[j][1]))
            offset = -float(model.qpos0[model.jnt_qposadr[j]])
            spec = (jname, kind, axis, B, offset, limits, drive)
        Ri = _quat(model.body_iquat[b])
        bodies.append(SourceBody(
            name=bname, parent=parent, T=T, joint=spec, mass=float(model.body_mass[b]),
            com=np.asarray(model.body_ipos[b], dtype=float),
            inertia=Ri @ np.diag(np.asarray(model.body_inertia[b], dtype=float)) @ Ri.T))
        index[b] = len(bodies) - 1
    joints = joints_from_bodies(bodies)
    if len(joints) != model.njnt:
        raise InputError(source, "", f"{model.njnt} joints in the model, {len(joints)} mapped")
    return robot_from_joints(name or "mjcf robot", joints,
                             gravity=np.asarray(model.opt.gravity, dtype=float).copy(),
                             source=source)


__all__ = ["load_mjcf", "robot_from_mjcf_string", "robot_from_mujoco"]
