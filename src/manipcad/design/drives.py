"""The drives of the design: the robot file's, else selected from the catalogue.

:func:`resolve_drives` keeps the drives the robot file gives; the joints without one get
theirs from the catalogue selection (:func:`manipcad.sizing.select.select_drives`, the
API of ``manipcad select``, one call: every compatible motor and gear checked with
``size``'s checks on every trajectory at both ends of the payload range, the least
objective that passes with the margin, the drives' masses on the links).

:func:`next_drive_up` is the design loop's remedy for a joint that no method controls
within its drive's ratings: the joint's feasible catalogue candidates in the order of
the objective (the selection's choice and its alternatives), the first whose
joint-side peak torque is larger than the present drive's.

The selection and the verification sweep both put a payload at the tool point
(:func:`manipcad.model.payload.apply_payload`, as ``size --payload``).
"""

from __future__ import annotations

import math
from typing import Any

from manipcad.errors import InputError, ManipcadError
from manipcad.model.robot import Drive, Robot
from manipcad.sizing import select as sel

#: where a robot made by the selection says so (select writes it into ``Robot.source``)
SELECTED = "selected by manipcad select"


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


def peak_joint_torque(d: Drive) -> float:
    """What a drive can apply at the joint, N·m (N): the smaller of the motor's peak
    torque·|i_r| and the gear's repeated peak (nan if neither is known).

    Example:
        >>> import manipcad
        >>> peak_joint_torque(manipcad.load_robot("cylindrical").drives[0]) > 0
        True
    """
    vals = [float(d.peak_torque) * abs(float(d.ratio)), float(d.gear_peak_torque)]
    vals = [v for v in vals if math.isfinite(v)]
    return min(vals) if vals else math.nan


def select_drives(robot: Robot, trajectories, payloads, *, joints=None, makers=None,
                  objective: str = "mass", margin: float | None = None):
    """Drives for ``joints`` from the catalogue: (the robot with them, the report)."""

    kw: dict[str, Any] = {"payload_range": (min(payloads), max(payloads)), "makers": makers,
                          "joints": joints, "objective": objective}
    if margin is not None:
        kw["margin"] = margin
    result = sel.select_drives(robot, list(trajectories), **kw)
    return result.robot, result.to_dict()


def resolve_drives(robot: Robot, trajectories, payloads, *, makers=None,
                   objective: str = "mass", margin: float | None = None
                   ) -> tuple[Robot, dict[str, Any]]:
    """The robot with a drive on every joint, and where each came from.

    Returns:
        (robot, {"source": {joint: "robot file" | "catalogue selection"},
        "selection": the selection's report or None}).

    Raises:
        NoFeasibleDrive: no catalogue pair is feasible for a joint (naming it, the
            closest candidate and the check it fails).
    """
    missing = [robot.joint_names[j] for j, d in enumerate(robot.drives) if d is None]
    source = {n: "robot file" for n in robot.joint_names if n not in missing}
    if not missing:
        return robot, {"source": source, "selection": None}
    robot, report = select_drives(robot, trajectories, payloads, joints=missing,
                                  makers=makers, objective=objective, margin=margin)
    source.update({n: "catalogue selection" for n in missing})
    return robot, {"source": source, "selection": report}


def next_drive_up(robot: Robot, joint: int, trajectories, payloads, *, makers=None,
                  tried=()) -> tuple[Robot | None, str]:
    """The arm with the next larger catalogue drive on ``joint``, or (None, why not).

    Args:
        robot: the arm (its drives from a robot file: a selected arm's links already
            hold the drives' masses and are not re-selected).
        joint: the joint's index.
        trajectories, payloads: what the candidates must pass (``size``'s checks).
        makers: the makers allowed.
        tried: labels of candidates already tried on this joint.

    Returns:
        (robot, label of the new drive) or (None, the reason).
    """

    if SELECTED in robot.source:
        return None, ("the arm's drives come from the catalogue selection (their masses are "
                      "on its links): select again with a larger margin")
    d0 = robot.drives[joint]
    have = peak_joint_torque(d0) if d0 is not None else 0.0
    try:
        res = sel.select_drives(robot, list(trajectories),
                                payload_range=(min(payloads), max(payloads)), makers=makers,
                                joints=[joint], verify=False)
    except (ManipcadError, InputError) as exc:
        return None, f"the catalogue has no feasible drive: {exc}"
    except ImportError as exc:            # the selection's catalogue could not be loaded
        return None, f"the catalogue selection could not run: {exc}"
    ch = res.joints[0]
    for cand in (ch.chosen, *ch.alternatives):
        cap = peak_joint_torque(cand.part.drive)
        if cand.label in tried or not (math.isfinite(cap) and cap > (have or 0.0)):
            continue
        drives = list(robot.drives)
        drives[joint] = cand.part.drive
        arm = robot.replace(drives=tuple(drives))
        masses = {joint: cand.part.mass} if math.isfinite(cand.part.mass) else {}
        arm = sel.with_drive_masses(arm, masses) if masses else arm
        return arm, cand.label
    return None, (f"no feasible catalogue drive for {robot.joint_names[joint]} can apply more "
                  f"than its present {have:.4g} N·m")


__all__ = ["resolve_drives", "select_drives", "next_drive_up", "parts", "peak_joint_torque"]
