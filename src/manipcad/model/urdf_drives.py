"""Robot files that take a URDF as their body and add the drives (docs/robot-files.md).

A URDF describes links, joints and inertias but not the motors and gears that
move them. This file names a URDF and adds, per joint, a drive (the same
fields as a drive in a DH robot file: catalog ``motor:``/``gear:`` names and/or
explicit fields), joint locks, a payload on a named link and a tool frame.
SI units throughout:

.. code-block:: yaml

    name: ur5-drives
    urdf: ur5_robot.urdf            # the body; a path relative to this file
    lock: {}                        # joint name -> fixed value, rad or m
    drives:                         # per joint; the fields of DH robot files
      shoulder_pan_joint: {motor: maxon_ec90_flat_607941, gear: harmonic_csf25_100}
      shoulder_lift_joint: {motor: ..., gear: ..., backlash: 0.0002}
    payload: {link: wrist_3_link, mass: 2.0, com: [0, 0, 0.05]}   # kg; m, in that link's URDF frame
    tool: {link: tool0, xyz: [0, 0, 0.1], rpy: [0, 0, 0]}         # m, rad, in tool0's frame

- ``urdf``: a path relative to the robot file (or absolute).
- ``lock``: movable joints held at a value become fixed joints (the Panda's
  fingers: ``lock: {panda_finger_joint1: 0.0, panda_finger_joint2: 0.0}``).
- ``drives``: keyed by joint name; joints without an entry have no drive.
- ``payload``: ``link`` (a URDF link name), ``mass`` kg, ``com`` m in that
  link's own URDF frame, optional ``inertia`` about the centre of mass
  (``{ixx, iyy, izz, ixy, ixz, iyz}`` kg·m², the link's axes).
- ``tool``: the tool frame at ``xyz`` (m) and ``rpy`` (rad, fixed axes x, y, z)
  in the frame of ``link`` (a URDF link carried by the last joint; default the
  last joint's child link).
- ``drive_mounts``: joint name -> ``before`` (the convention: a drive's own
  mass on the link before its joint) or ``base`` (off the arm); read by
  ``manipcad select`` (docs/select.md).
- ``gravity``: m/s², base frame (default [0, 0, -9.81]); ``name``,
  ``source``, ``description``: text.

Every problem raises :class:`~manipcad.errors.InputError` naming the file,
the field (``drives.elbow_joint.motor``) and the reason.
"""

from __future__ import annotations

from pathlib import Path
from typing import Literal

import numpy as np
from pydantic import Field

from manipcad.errors import InputError, ModelError
from manipcad.fileio import check_readable
from manipcad.model.robot import Robot, mounts_tuple
from manipcad.model.urdf import load_urdf
from manipcad.model.yaml_robot import (
    DriveSpec,
    InertiaSpec,
    Num,
    Vec3,
    _check_link,
    _Spec,
    build_drive,
    read_yaml,
    rpy_to_matrix,
    validate,
)


class PayloadSpec(_Spec):
    """A payload on a named link: mass kg, centre of mass m and inertia kg·m²
    (about the centre of mass) in that link's own URDF frame."""

    link: str = Field(min_length=1)
    mass: Num
    com: Vec3 = (0.0, 0.0, 0.0)
    inertia: InertiaSpec = InertiaSpec()


class LinkToolSpec(_Spec):
    """The tool frame: xyz (m) and rpy (rad) in the frame of a named link."""

    link: str | None = None
    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)


class UrdfRobotSpec(_Spec):
    """A robot file whose body is a URDF (module docstring)."""

    urdf: str = Field(min_length=1)
    name: str | None = None
    source: str = ""
    description: str = ""
    gravity: Vec3 = (0.0, 0.0, -9.81)
    lock: dict[str, Num] = {}
    drives: dict[str, DriveSpec] = {}
    payload: PayloadSpec | None = None
    tool: LinkToolSpec | None = None
    drive_mounts: dict[str, Literal["before", "base"]] = {}


def is_urdf_robot_file(data: object) -> bool:
    """True when parsed YAML is a URDF-based robot file (it has a ``urdf`` key)."""
    return isinstance(data, dict) and "urdf" in data


def load_urdf_robot(path: str | Path) -> Robot:
    """Load a robot file that takes a URDF as its body and adds drives.

    Args:
        path: the .yaml file (schema in the module docstring and
            docs/robot-files.md).

    Returns:
        The validated :class:`Robot` with its drives, locks, payload and tool.

    Raises:
        InputError: naming the file, the field and the reason.

    Example:
        >>> from manipcad.model.load import load_robot
        >>> ur5 = load_robot("examples/ur5/ur5.yaml")   # doctest: +SKIP
        >>> ur5.has_drives                               # doctest: +SKIP
        True
    """
    path = Path(path)
    label = str(path)
    spec = validate(UrdfRobotSpec, read_yaml(path, label), label)
    return build_urdf_robot(spec, label, base_dir=path.parent)


def build_urdf_robot(spec: UrdfRobotSpec, label: str, base_dir: Path) -> Robot:
    """Map a validated :class:`UrdfRobotSpec` onto a :class:`Robot` (``label``
    names the file in errors; ``base_dir`` resolves the URDF, motor and gear paths)."""
    urdf = Path(spec.urdf)
    if not urdf.is_absolute():
        urdf = base_dir / urdf
    if not (urdf.exists() or urdf.is_symlink()):
        raise InputError(label, "urdf", f"no such file {str(urdf)!r} (a path relative to "
                         "this robot file)")

    try:  # a directory, a FIFO, a device: say what it is (a FIFO is never opened)
        check_readable(urdf)
    except InputError as exc:
        raise InputError(label, "urdf", f"{str(urdf)!r} {exc.reason}") from None
    try:
        body = load_urdf(urdf, lock=dict(spec.lock))
    except InputError as exc:
        if exc.field.startswith("lock."):
            raise InputError(label, exc.field, exc.reason) from None
        raise
    for name in spec.lock:
        if name in spec.drives:
            raise InputError(label, f"drives.{name}", "the joint is locked (lock:); a locked "
                             "joint has no drive")
    drives = list(body.drives)
    for name, dspec in spec.drives.items():
        if name not in body.joint_names:
            raise InputError(label, f"drives.{name}", "no movable joint of that name in "
                             f"{spec.urdf}; joints are {', '.join(body.joint_names)}")
        drives[body.joint_names.index(name)] = build_drive(dspec, label, f"drives.{name}",
                                                           base_dir)
    for name in spec.drive_mounts:
        if name not in body.joint_names:
            raise InputError(label, f"drive_mounts.{name}", "no movable joint of that name "
                             f"in {spec.urdf}; joints are {', '.join(body.joint_names)}")
    changes: dict = {"drives": tuple(drives), "gravity": np.array(spec.gravity),
                     "source": spec.source.strip() or body.source,
                     "drive_mounts": mounts_tuple(spec.drive_mounts)}
    if spec.name:
        changes["name"] = spec.name
    if spec.tool is not None:
        changes["tool_R"], changes["tool_p"] = _tool(body, spec.tool, label)
    try:
        robot = body.replace(**changes)
    except ModelError as exc:
        raise InputError(label, "", str(exc)) from None
    if spec.payload is not None:
        robot = _payload(robot, spec.payload, label)
    return robot


def _tool(robot: Robot, tool: LinkToolSpec, label: str) -> tuple[np.ndarray, np.ndarray]:
    """The tool frame in the last body's frame (rotation, origin m)."""
    link = tool.link if tool.link is not None else robot.link_names[-1]
    try:
        body, R_l, p_l = robot.link_frame(link)
    except ModelError as exc:
        raise InputError(label, "tool.link", str(exc)) from None
    if body != robot.n - 1:
        where = "the base" if body < 0 else f"joint {robot.joint_names[body]!r}"
        raise InputError(label, "tool.link", f"link {link!r} is moved by {where}; the tool "
                         f"must be on a link the last joint {robot.joint_names[-1]!r} moves")
    R_t = rpy_to_matrix(*tool.rpy)
    return R_l @ R_t, p_l + R_l @ np.array(tool.xyz)


def _payload(robot: Robot, payload: PayloadSpec, label: str) -> Robot:
    if payload.link not in robot.all_link_names:
        raise InputError(label, "payload.link", f"no link named {payload.link!r}; links are "
                         + ", ".join(robot.all_link_names))
    m, c, I = _check_link(payload, label, "payload")  # type: ignore[arg-type]
    try:
        return robot.with_payload(m, c, I, link=payload.link)
    except ModelError as exc:
        raise InputError(label, "payload", str(exc)) from None


__all__ = ["load_urdf_robot", "build_urdf_robot", "is_urdf_robot_file", "UrdfRobotSpec",
           "PayloadSpec", "LinkToolSpec"]
