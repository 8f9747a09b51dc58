"""A payload as the commands take it: a mass, or a mapping; one reading for every caller.

``simulate(payload=)``, ``size``/``select`` (:func:`manipcad.sizing.sample_motion`), the
run checks and the automated design put a payload on the robot through
:func:`apply_payload`, so ``--payload 2`` means the same body everywhere:

- a mass alone (kg) is a point mass at the robot's **tool point** (``tool:`` of the robot
  file, :attr:`~manipcad.model.robot.Robot.tool_p`: what the gripper holds; the last
  link's origin when the robot file gives no tool);
- a mapping ``{mass, com, inertia, link}``: ``com`` (m) in the carrying link's frame
  (default: the tool point when the payload is on the last link given by index or joint
  name, the frame's origin otherwise),
  ``inertia`` ((3, 3) about the payload's centre of mass, kg·m²; default a point mass),
  ``link`` (a joint index or name, or a link name; default the last link).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np

from manipcad.errors import InputError, ManipcadError
from manipcad.model.robot import Robot

#: the keys a payload mapping may have
KEYS = ("mass", "com", "inertia", "link")


def apply_payload(robot: Robot, payload: Any, *, source: str = "payload") -> tuple[Robot, float]:
    """The robot carrying ``payload``, and the payload's mass (kg).

    Args:
        robot: the robot.
        payload: None; a mass in kg (a point mass at the tool point); or a mapping with
            ``mass`` (kg) and optionally ``com`` (m), ``inertia`` (kg·m²) and ``link``
            (module docstring).
        source: the argument or file named in errors.

    Returns:
        (the loaded robot, the mass in kg); ``(robot, 0.0)`` for None.

    Raises:
        InputError: not a number or such a mapping, an unknown key, a mass that is not a
            finite number >= 0, a com that is not 3 finite numbers, a bad link or inertia.

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> loaded, m = apply_payload(arm, 2.0)
        >>> m, round(float(loaded.mass[-1] - arm.mass[-1]), 9)
        (2.0, 2.0)
        >>> apply_payload(arm, (2.0, 0.1))  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        manipcad.errors.InputError: payload: expected a mass in kg or a mapping ... got tuple
    """
    if payload is None:
        return robot, 0.0
    if isinstance(payload, int | float | np.integer | np.floating) and \
            not isinstance(payload, bool):
        fields: dict[str, Any] = {"mass": payload}
    elif isinstance(payload, Mapping):
        fields = dict(payload)
        unknown = sorted(set(map(str, fields)) - set(KEYS))
        if unknown:
            raise InputError(source, unknown[0], f"unknown key (expected {', '.join(KEYS)})")
        if "mass" not in fields:
            raise InputError(source, "mass", "missing (kg)")
    else:
        raise InputError(source, "", f"expected a mass in kg or a mapping with "
                         f"{', '.join(KEYS)}; got {type(payload).__name__}")
    link = fields.get("link", -1)
    # the tool point is in the last joint's body frame: the default com when the payload
    # sits on that body named by index or joint name (a URDF link name has its own frame)
    last = (not isinstance(link, bool) and link in (-1, robot.n - 1)) or \
        link == robot.joint_names[-1]
    default_com = np.asarray(robot.tool_p, dtype=float) if last else np.zeros(3)
    try:
        mass = float(fields["mass"])
    except (TypeError, ValueError):
        raise InputError(source, "mass", f"expected a number (kg), got "
                         f"{fields['mass']!r}") from None
    if not (math.isfinite(mass) and mass >= 0):
        raise InputError(source, "mass", f"must be a finite number >= 0 kg, got {mass}")
    try:
        com = np.asarray(fields.get("com", default_com), dtype=float)
    except (TypeError, ValueError):
        com = np.full(1, np.nan)
    if com.shape != (3,) or not np.all(np.isfinite(com)):
        raise InputError(source, "com", f"expected 3 finite numbers (m), got "
                         f"{fields.get('com')!r}")
    try:
        loaded = robot.with_payload(mass, com, fields.get("inertia"), link=link)
    except ManipcadError as exc:
        raise InputError(source, getattr(exc, "field", None) or "", str(exc)) from None
    except (TypeError, ValueError) as exc:
        raise InputError(source, "", f"{exc}") from None
    return loaded, mass


__all__ = ["apply_payload", "KEYS"]
