"""A content hash of a robot model: what a regulator file records about the robot it was made for.

The hash covers everything that changes the dynamics or the drives: joint names and types,
the tree, placements, offsets, link inertial parameters, drives (every field), gravity,
limits and the tool frame; not the robot's name or its source path. Floats are hashed by
their exact bytes (a change in the last bit counts).
"""

from __future__ import annotations

import dataclasses
import hashlib
import math

import numpy as np


def robot_hash(robot) -> str:
    """SHA-256 (hex, first 16 characters) of a robot's model content.

    Args:
        robot: a :class:`~manipcad.model.robot.Robot`.

    Returns:
        16 hexadecimal characters.

    Example:
        >>> import manipcad
        >>> from manipcad.model.hashing import robot_hash
        >>> arm = manipcad.load_robot("cylindrical")
        >>> robot_hash(arm) == robot_hash(manipcad.load_robot("cylindrical"))
        True
        >>> robot_hash(arm) == robot_hash(arm.with_payload(1.0))
        False
    """
    h = hashlib.sha256()

    def put(x) -> None:
        if isinstance(x, str):
            h.update(b"s" + x.encode() + b"\0")
        elif x is None:
            h.update(b"n")
        elif isinstance(x, bool | int | float):
            h.update(b"f" + np.float64(x).tobytes())
        else:
            a = np.ascontiguousarray(np.asarray(x, dtype=float))
            h.update(b"a" + str(a.shape).encode() + a.tobytes())

    for s in robot.joint_names + robot.joint_types:
        put(s)
    for a in (robot.parent, robot.placement_R, robot.placement_p, robot.offset, robot.mass,
              robot.com, robot.inertia, robot.gravity, robot.tool_R, robot.tool_p):
        put(a)
    put(robot.limits)
    for d in robot.drives or ():
        if d is None:
            put(None)
            continue
        for f in dataclasses.fields(d):
            v = getattr(d, f.name)
            if f.name == "assumed":
                if v:  # (a drive without assumptions hashes as before they existed)
                    put(repr(v))
                continue
            if f.name == "M_s":
                if v is not None:  # (static = kinetic friction hashes as before M_s existed)
                    put(np.asarray(v, dtype=float))
                continue
            if isinstance(v, tuple):
                put(np.asarray(v, dtype=float))
            elif isinstance(v, float) and math.isnan(v):
                put("nan")
            else:
                put(v)
    return h.hexdigest()[:16]
