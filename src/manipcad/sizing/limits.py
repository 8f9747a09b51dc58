"""Checks of what a motion needs against a motor's ratings.

Four limits, each compared on the motor side of the gear:

- continuous: RMS motor torque over the run vs ``Drive.rated_torque``, N·m;
- peak: peak motor torque vs ``Drive.peak_torque``, N·m;
- speed: peak motor speed vs ``Drive.max_speed``, rad/s;
- voltage: peak armature voltage |u_a| vs ``Drive.u_max`` (the amplifier's
  output limit) when finite, else ``Drive.rated_voltage``, V.

The continuous check treats the run as the repeated duty cycle: the winding
heats with i², so the RMS torque (= k_m·RMS current) over one cycle is what
the continuous (thermal) rating bounds.

The margin is ``1 - required / limit``: the fraction of the limit left unused,
negative when the limit is exceeded (-0.25: 25 % over). Status is "pass"
(margin >= 0), "fail" (margin < 0) or "unknown" (no drive, or the rating or
the required value is not known, e.g. a motor without electrical data).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from manipcad.model.robot import Drive

#: the limits, in report order: name -> (what is compared, unit)
LIMITS: dict[str, tuple[str, str]] = {
    "continuous": ("RMS motor torque vs rated (continuous) torque", "N·m"),
    "peak": ("peak motor torque vs peak torque", "N·m"),
    "speed": ("peak motor speed vs max speed", "rad/s"),
    "voltage": ("peak armature voltage vs amplifier limit (else rated voltage)", "V"),
}

PASS, FAIL, UNKNOWN = "pass", "fail", "unknown"


@dataclass(frozen=True)
class LimitCheck:
    """One limit checked on every joint (arrays of shape (n,)).

    Attributes:
        name: "continuous", "peak", "speed" or "voltage".
        description: what is compared with what.
        unit: unit of ``required`` and ``limit`` (N·m, rad/s or V).
        required: what the motion needs, nan if unknown.
        limit: the motor's rating, nan if unknown.
        margin: 1 - required/limit (fraction; negative when violated), nan if unknown.
        status: "pass", "fail" or "unknown" per joint.
    """

    name: str
    description: str
    unit: str
    required: np.ndarray
    limit: np.ndarray
    margin: np.ndarray
    status: tuple[str, ...]

    @property
    def passed(self) -> np.ndarray:
        """(n,) bool: True where the status is "pass"."""
        return np.array([s == PASS for s in self.status], dtype=bool)


def voltage_limit(drive: Drive | None) -> float:
    """Largest armature voltage the drive can apply, V.

    The amplifier's output limit ``u_max`` when finite, else the motor's
    ``rated_voltage``, else nan.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> voltage_limit(Drive(u_max=40.0, rated_voltage=48.0))
        40.0
    """
    if drive is None:
        return math.nan
    if math.isfinite(drive.u_max) and drive.u_max > 0:
        return float(drive.u_max)
    return float(drive.rated_voltage)


def motor_limits(drive: Drive | None) -> dict[str, float]:
    """The four ratings of a drive's motor (N·m, N·m, rad/s, V); nan when unknown.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> motor_limits(Drive(rated_torque=0.187))["continuous"]
        0.187
    """
    if drive is None:
        return dict.fromkeys(LIMITS, math.nan)
    return {"continuous": float(drive.rated_torque), "peak": float(drive.peak_torque),
            "speed": float(drive.max_speed), "voltage": voltage_limit(drive)}


def margin(required, limit) -> np.ndarray:
    """1 - required/limit where both are known and the limit is > 0, else nan.

    Example:
        >>> import numpy as np
        >>> margin(np.array([1.0, 3.0, np.nan]), np.array([2.0, 2.0, 2.0])).tolist()
        [0.5, -0.5, nan]
    """
    req = np.asarray(required, dtype=float)
    lim = np.asarray(limit, dtype=float)
    ok = np.isfinite(req) & np.isfinite(lim) & (lim > 0)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.where(ok, 1.0 - req / np.where(ok, lim, 1.0), np.nan)


def status_of(m: float) -> str:
    """"pass", "fail" or "unknown" for one margin."""
    if not math.isfinite(m):
        return UNKNOWN
    return PASS if m >= 0 else FAIL


def check_limits(required: dict[str, np.ndarray],
                 drives: tuple[Drive | None, ...]) -> dict[str, LimitCheck]:
    """Check each joint's requirement against its motor, limit by limit.

    Args:
        required: for each name in :data:`LIMITS`, the (n,) required value
            (RMS motor torque N·m, peak motor torque N·m, peak motor speed
            rad/s, peak armature voltage V).
        drives: the robot's drives (None for a joint without one).

    Returns:
        name -> :class:`LimitCheck`, in the order of :data:`LIMITS`.
    """
    ratings = [motor_limits(d) for d in drives]
    out = {}
    for name, (desc, unit) in LIMITS.items():
        lim = np.array([r[name] for r in ratings], dtype=float)
        req = np.asarray(required[name], dtype=float)
        m = margin(req, lim)
        out[name] = LimitCheck(name=name, description=desc, unit=unit, required=req, limit=lim,
                               margin=m, status=tuple(status_of(float(v)) for v in m))
    return out


def overall_status(checks: dict[str, LimitCheck]) -> tuple[str, ...]:
    """Per joint: "fail" if any limit fails, else "unknown" if any is unknown, else "pass"."""
    n = len(next(iter(checks.values())).status)
    out = []
    for j in range(n):
        states = {c.status[j] for c in checks.values()}
        out.append(FAIL if FAIL in states else UNKNOWN if UNKNOWN in states else PASS)
    return tuple(out)
