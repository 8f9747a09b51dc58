"""Checks made on assumed data: say which, and take them as unknown on request (``--strict``).

A drive's ``assumed`` (:attr:`manipcad.model.robot.Drive.assumed`) names the values
that are not printed on a data sheet but stated by the library (docs/catalog.md):
a strain-wave gear's efficiency (Harmonic Drive AG's model at its one published
point), a friction the sheet does not give taken as 0. The motor-side checks
(continuous, peak, voltage) depend on them; speed and gear checks do not.

- :func:`assumed_passes`: the passed checks that rest on an assumed value, with why
  (``size`` prints them as "pass with an assumed efficiency");
- :func:`strict_robot` and :func:`strict_requirements`: the same sizing with the
  assumed values taken as unknown: an assumed efficiency becomes nan (the sizing's
  unknown-efficiency rule then applies: a check that fails even through a lossless
  gear fails, else it is unknown), and a motor-side pass on any other assumed value
  becomes unknown.

Example:
    >>> from manipcad.model.robot import Drive
    >>> d = Drive(J=1e-4, ratio=100.0, efficiency=0.7, assumed=(("efficiency", "why"),))
    >>> strict_drive(d).efficiency, strict_drive(d).assumed
    (nan, ())
"""

from __future__ import annotations

import dataclasses
import math
from typing import Any

import numpy as np

from manipcad.model.robot import Drive, Robot
from manipcad.sizing.limits import PASS, UNKNOWN, overall_status
from manipcad.sizing.requirements import DriveRequirements

#: the checks that depend on the drive's efficiency and friction (the motor torque)
MOTOR_SIDE = ("continuous", "peak", "voltage")


def strict_drive(d: Drive) -> Drive:
    """The drive with an assumed efficiency taken as unknown (nan)."""
    assumed = dict(d.assumed)
    if "efficiency" not in assumed:
        return d
    assumed.pop("efficiency")
    return d.replace(efficiency=math.nan, assumed=tuple(sorted(assumed.items())))


def strict_robot(robot: Robot) -> Robot:
    """The robot with every drive's assumed efficiency taken as unknown."""
    if not any(d is not None and d.assumed for d in robot.drives):
        return robot
    return robot.replace(drives=tuple(None if d is None else strict_drive(d)
                                      for d in robot.drives))


def strict_requirements(req: DriveRequirements) -> DriveRequirements:
    """The sizing with the motor-side passes that rest on assumed values (other than an
    efficiency, which :func:`strict_robot` makes unknown first) taken as unknown."""
    changed = False
    checks = dict(req.checks)
    for name in MOTOR_SIDE:
        c = checks.get(name)
        if c is None:
            continue
        status = list(c.status)
        for j, d in enumerate(req.drives):
            if d is not None and d.assumed and status[j] == PASS:
                status[j], changed = UNKNOWN, True
        if tuple(status) != c.status:
            m = np.array(c.margin, dtype=float)
            m[[k for k, st in enumerate(status) if st == UNKNOWN]] = np.nan
            checks[name] = dataclasses.replace(c, status=tuple(status), margin=m)
    if not changed:
        return req
    return dataclasses.replace(req, checks=checks, status=overall_status(checks))


def assumed_passes(req: DriveRequirements) -> list[dict[str, Any]]:
    """The passed motor-side checks that rest on assumed values.

    Returns:
        One dict per (joint, check): ``joint`` (name), ``check``, ``fields`` (the
        assumed drive fields) and ``why`` (field -> the stated reason).
    """
    out = []
    for j, d in enumerate(req.drives):
        if d is None or not d.assumed:
            continue
        for name in MOTOR_SIDE:
            c = req.checks.get(name)
            if c is not None and c.status[j] == PASS:
                out.append({"joint": req.joint_names[j], "check": name,
                            "fields": [k for k, _ in d.assumed], "why": dict(d.assumed)})
    return out


__all__ = ["MOTOR_SIDE", "strict_drive", "strict_robot", "strict_requirements",
           "assumed_passes"]
