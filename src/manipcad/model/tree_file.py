"""Robot files in the internal tree form: what :func:`save_robot` writes.

Any robot (from a DH file, a URDF + drives file, a catalog name, built in
Python) is written as its kinematic tree with every joint placement, link
inertia and drive field spelled out, so the file needs nothing else (no URDF,
no catalog) and loads back to an identical model: the numbers are written
with Python's shortest round-trip repr. SI units throughout:

.. code-block:: yaml

    name: ur5-drives
    convention: tree
    gravity: [0.0, 0.0, -9.81]            # m/s², base frame
    tool: {R: [[1, 0, 0], [0, 1, 0], [0, 0, 1]], p: [0, 0, 0.1]}   # last link frame; m
    joints:
      - name: shoulder_pan_joint
        type: revolute
        parent: base                      # a joint name or base
        placement: {R: [[...], [...], [...]], p: [0, 0, 0.089159]}  # in the parent body frame; m
        offset: 0.0                       # rad (m)
        limits: [-6.28, 6.28]             # rad (m); -.inf / .inf for none
        velocity_limit: 3.2               # rad/s (m/s), optional; effort_limit N·m (N)
        link: {name: shoulder_link, mass: 3.7, com: [0, 0, 0], inertia: {ixx: ...}}
        drive: {J: ..., ratio: ..., R: ..., ...}   # the fields of docs/robot-files.md
    frames:                               # named frames (URDF links) in their body
      - {name: tool0, body: wrist_3_joint, R: [[...]], p: [...]}

The joint moves about (along) the local z axis of its placement frame, as in
:mod:`manipcad.model.robot`. ``save_robot`` writes this; ``load_robot`` reads
it (``convention: tree``).
"""

from __future__ import annotations

import math
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BeforeValidator, Field

from manipcad.errors import InputError, ModelError
from manipcad.fileio import atomic_write_text, dump_yaml
from manipcad.model.robot import Drive, Robot
from manipcad.model.yaml_robot import (
    DriveSpec,
    LinkSpec,
    Num,
    OptNum,
    OptPair,
    Vec3,
    _check_link,
    _Spec,
    _vector,
    build_drive,
    read_yaml,
    validate,
)


def _matrix(v: Any) -> tuple[tuple[float, float, float], ...]:
    if not isinstance(v, list | tuple) or len(v) != 3:
        raise ValueError(f"expected a 3x3 rotation as three rows of three numbers, got {v!r}")
    return tuple(_vector(3, "(a row)")(row) for row in v)  # type: ignore[misc]


Mat3 = Annotated[tuple[tuple[float, float, float], ...], BeforeValidator(_matrix)]


class PoseSpec(_Spec):
    """A fixed frame: rotation R (3x3, rows) and origin p (m)."""

    R: Mat3 = ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
    p: Vec3 = (0.0, 0.0, 0.0)


class TreeLinkSpec(LinkSpec):
    """A link: its name, mass kg, centre of mass m and inertia kg·m² in the body frame."""

    name: str | None = None


class TreeJointSpec(_Spec):
    """One joint of the tree form."""

    name: str = Field(min_length=1)
    type: Literal["revolute", "prismatic"]
    parent: str = "base"
    placement: PoseSpec = PoseSpec()
    offset: Num = 0.0
    limits: OptPair = None
    velocity_limit: OptNum = None
    effort_limit: OptNum = None
    link: TreeLinkSpec
    drive: DriveSpec | None = None


class FrameSpec(PoseSpec):
    """A named frame in the body of a joint (or the base)."""

    name: str = Field(min_length=1)
    body: str = "base"


class TreeRobotSpec(_Spec):
    """A robot file in tree form (module docstring)."""

    name: str = Field(min_length=1)
    convention: Literal["tree"]
    gravity: Vec3 = (0.0, 0.0, -9.81)
    source: str = ""
    description: str = ""
    tool: PoseSpec | None = None
    joints: list[TreeJointSpec] = Field(min_length=1)
    frames: list[FrameSpec] = []
    drive_mounts: dict[str, Literal["before", "base"]] = {}


def is_tree_file(data: object) -> bool:
    """True when parsed YAML is a tree-form robot file (``convention: tree``)."""
    return isinstance(data, dict) and data.get("convention") == "tree"


def load_tree_robot(path: str | Path) -> Robot:
    """Load a tree-form robot file (the form :func:`save_robot` writes).

    Args:
        path: the .yaml file.

    Returns:
        The validated :class:`Robot`.

    Raises:
        InputError: naming the file, the field and the reason.
    """
    path = Path(path)
    label = str(path)
    spec = validate(TreeRobotSpec, read_yaml(path, label), label)
    index: dict[str, int] = {}
    parents = []
    for i, j in enumerate(spec.joints):
        if j.name in index or j.name == "base":
            raise InputError(label, f"joints[{i}].name", f"duplicate or reserved name {j.name!r}")
        if j.parent != "base" and j.parent not in index:
            raise InputError(label, f"joints[{i}].parent", f"unknown parent {j.parent!r}; "
                             "expected base or a joint listed before")
        parents.append(-1 if j.parent == "base" else index[j.parent])
        index[j.name] = i
    links = [_check_link(j.link, label, f"joints[{i}].link") for i, j in enumerate(spec.joints)]
    drives = [None if j.drive is None else build_drive(j.drive, label, f"joints[{i}].drive")
              for i, j in enumerate(spec.joints)]
    frames = []
    for k, f in enumerate(spec.frames):
        if f.body != "base" and f.body not in index:
            raise InputError(label, f"frames[{k}].body", f"unknown joint {f.body!r}")
        frames.append((f.name, -1 if f.body == "base" else index[f.body], f.R, f.p))
    tool = spec.tool or PoseSpec()
    try:
        return Robot.from_arrays(
            spec.name, [j.type for j in spec.joints], parents,
            np.array([j.placement.R for j in spec.joints]),
            np.array([j.placement.p for j in spec.joints]),
            [m for m, _, _ in links], np.array([c for _, c, _ in links]),
            np.array([inertia for _, _, inertia in links]),
            offset=[j.offset for j in spec.joints],
            joint_names=[j.name for j in spec.joints], drives=drives, gravity=spec.gravity,
            limits=np.array([j.limits if j.limits is not None else (-math.inf, math.inf)
                             for j in spec.joints]),
            link_names=[j.link.name or f"link{i + 1}" for i, j in enumerate(spec.joints)],
            tool_R=np.array(tool.R), tool_p=np.array(tool.p), source=spec.source,
            frames=frames, drive_mounts=spec.drive_mounts,
            velocity_limits=[math.inf if j.velocity_limit is None else j.velocity_limit
                             for j in spec.joints],
            effort_limits=[math.inf if j.effort_limit is None else j.effort_limit
                           for j in spec.joints],
        )
    except ModelError as exc:
        raise InputError(label, "", str(exc)) from None


# --------------------------------------------------------------------------- writing

#: Drive fields written (all but the labels and the transmission, handled apart)
_DRIVE_NUMBERS = ("J", "ratio", "k_v", "R", "L", "k_m", "k_w", "k_u", "u_max",
                  "rated_torque", "peak_torque", "max_speed", "rated_voltage", "rated_current",
                  "backlash", "efficiency", "gear_rated_torque", "gear_peak_torque",
                  "gear_max_input_speed", "gear_average_torque", "gear_average_input_speed")


def drive_to_dict(d: Drive) -> dict[str, Any]:
    """A drive as the explicit fields of a robot file (unknown ratings left out).

    Example:
        >>> drive_to_dict(Drive(J=1e-5, ratio=50.0, M_f=(0.01, 0.02)))["M_f"]
        [0.01, 0.02]
    """
    out: dict[str, Any] = {}
    if d.name:
        out["motor_name"] = d.name
    if d.gear:
        out["gear_name"] = d.gear
    for key in _DRIVE_NUMBERS:
        v = float(getattr(d, key))
        if key == "efficiency" and math.isnan(v):
            out[key] = "unknown"          # not 1: the gear's source gives none
            continue
        if math.isnan(v) or (key == "u_max" and math.isinf(v)) or (key == "backlash" and v == 0):
            continue
        out[key] = v
    out["M_f"] = [float(d.M_f[0]), float(d.M_f[1])]
    if d.M_s is not None:
        out["M_s"] = [float(d.M_s[0]), float(d.M_s[1])]
    if d.elastic:
        out["elasticity"] = [float(d.stiffness), float(d.damping)]
    if d.assumed:
        out["assumed"] = dict(d.assumed)
    return out


def _rows(R: np.ndarray) -> list[list[float]]:
    return [[float(x) for x in row] for row in np.asarray(R)]


def _vec(v: np.ndarray) -> list[float]:
    return [float(x) for x in np.asarray(v).reshape(-1)]


def robot_to_dict(robot: Robot) -> dict[str, Any]:
    """The tree-form file content of a robot (module docstring)."""
    joints = []
    for i in range(robot.n):
        I = robot.inertia[i]
        entry: dict[str, Any] = {
            "name": robot.joint_names[i], "type": robot.joint_types[i],
            "parent": "base" if robot.parent[i] < 0 else robot.joint_names[robot.parent[i]],
            "placement": {"R": _rows(robot.placement_R[i]), "p": _vec(robot.placement_p[i])},
            "offset": float(robot.offset[i]),
            "limits": _vec(robot.limits[i]),
            **{key: float(v) for key, v in (("velocity_limit", robot.velocity_limits[i]),
                                            ("effort_limit", robot.effort_limits[i]))
               if math.isfinite(v)},
            "link": {"name": robot.link_names[i], "mass": float(robot.mass[i]),
                     "com": _vec(robot.com[i]),
                     "inertia": {"ixx": float(I[0, 0]), "iyy": float(I[1, 1]),
                                 "izz": float(I[2, 2]), "ixy": float(I[0, 1]),
                                 "ixz": float(I[0, 2]), "iyz": float(I[1, 2])}},
        }
        if robot.drives[i] is not None:
            entry["drive"] = drive_to_dict(robot.drives[i])
        joints.append(entry)
    out: dict[str, Any] = {
        "name": robot.name, "convention": "tree", "gravity": _vec(robot.gravity),
        "source": robot.source,
        "tool": {"R": _rows(robot.tool_R), "p": _vec(robot.tool_p)},
        "joints": joints,
    }
    if robot.drive_mounts:
        out["drive_mounts"] = dict(robot.drive_mounts)
    if robot.frames:
        out["frames"] = [{"name": nm, "body": "base" if b < 0 else robot.joint_names[b],
                          "R": _rows(R), "p": _vec(p)} for nm, b, R, p in robot.frames]
    return out


def save_robot(robot: Robot, path: str | Path) -> Path:
    """Write a robot with its drives as a tree-form robot file that loads back to an
    identical model.

    Args:
        robot: the robot.
        path: the .yaml file to write (its folder must exist), str or Path.

    Returns:
        The path written.

    Raises:
        InputError: the file cannot be written.

    Example:
        >>> import manipcad, tempfile, os
        >>> puma = manipcad.load_robot("puma560")
        >>> f = save_robot(puma, os.path.join(tempfile.mkdtemp(), "puma.yaml"))
        >>> bool((manipcad.load_robot(f).table == puma.table).all())
        True
    """
    path = Path(path)
    text = ("# manipcad robot, tree form (docs/robot-files.md); SI units: m, rad, kg, kg·m²,\n"
            "# drive fields as in robot files (motor side J kg·m², R Ω, L H, k_m N·m/A, ...)\n"
            + dump_yaml(robot_to_dict(robot), sort_keys=False, allow_unicode=True,
                             default_flow_style=None,
                             width=100))

    return atomic_write_text(path, text)


__all__ = ["save_robot", "load_tree_robot", "robot_to_dict", "drive_to_dict", "is_tree_file",
           "TreeRobotSpec"]
