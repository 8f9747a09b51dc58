"""The drives of the design: the robot file's, else selected from the catalogue.

:func:`resolve_drives` keeps the drives the robot file gives. A joint without one is
given one by the catalogue selection (:func:`select_drives`, one call) when the
selection is available in this installation; otherwise the design stops with one
clear error naming the joints. :func:`next_drive_up` is the design loop's remedy for a
joint that no method can control within its drive's ratings: the next feasible
catalogue pair with a larger objective, or None when the selection cannot give one.
"""

from __future__ import annotations

import importlib.util
from typing import Any

from manipcad.errors import InputError
from manipcad.model.robot import Robot


def selection_available() -> bool:
    """Whether the catalogue selection (``manipcad.sizing.select``) is installed."""
    return importlib.util.find_spec("manipcad.sizing.select") is not None


def parts(robot: Robot) -> dict[str, dict[str, Any]]:
    """Per joint the motor, gear and ratio of its drive (None without one).

    Example:
        >>> import manipcad
        >>> parts(manipcad.load_robot("cylindrical"))["turn"]["motor"] != ""
        True
    """
    out: dict[str, Any] = {}
    for name, d in zip(robot.joint_names, robot.drives, strict=True):
        out[name] = None if d is None else {"motor": d.name, "gear": d.gear,
                                            "ratio": float(d.ratio),
                                            "efficiency": float(d.efficiency)}
    return out


def select_drives(robot: Robot, trajectories, payloads, *, joints=None, makers=None):
    """Drives for ``joints`` from the catalogue (``manipcad select``'s API).

    Returns:
        (the robot with the selected drives, the selection's report as a mapping).

    Raises:
        InputError: the selection is not available, or no catalogue pair is feasible.
    """
    if not selection_available():
        names = ", ".join(joints or robot.joint_names)
        raise InputError("--robot", "drives", f"no drive on {names}, and the catalogue "
                         "selection is not available: give the drives in the robot file")
    from manipcad.sizing import select as sel  # the catalogue selection

    result = sel.select(robot, list(trajectories), payload_range=(min(payloads), max(payloads)),
                        makers=makers, joints=joints)
    return result.robot, result.to_dict()


def resolve_drives(robot: Robot, trajectories, payloads, *, makers=None
                   ) -> tuple[Robot, dict[str, Any]]:
    """The robot with a drive on every joint, and where each came from.

    Returns:
        (robot, {"source": {joint: "robot file" | "selected"}, "selection": report or None}).
    """
    missing = [robot.joint_names[j] for j, d in enumerate(robot.drives) if d is None]
    source = {n: "robot file" for n in robot.joint_names if n not in missing}
    if not missing:
        return robot, {"source": source, "selection": None}
    robot, report = select_drives(robot, trajectories, payloads, joints=missing, makers=makers)
    source.update({n: "selected" for n in missing})
    return robot, {"source": source, "selection": report}


def next_drive_up(robot: Robot, joint: int, trajectories, payloads, *, makers=None):
    """The next larger catalogue drive for ``joint``, or None (with the reason).

    Returns:
        (robot with it, None) or (None, why not).
    """
    if not selection_available():
        return None, "the catalogue selection is not available in this installation"
    from manipcad.sizing import select as sel

    try:
        new = sel.next_up(robot, joint, list(trajectories),
                          payload_range=(min(payloads), max(payloads)), makers=makers)
    except (AttributeError, InputError) as exc:
        return None, str(exc)
    if new is None:
        return None, "no larger feasible catalogue pair"
    return new, None


__all__ = ["resolve_drives", "select_drives", "next_drive_up", "parts", "selection_available"]
