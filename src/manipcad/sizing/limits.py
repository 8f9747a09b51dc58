"""Checks of what a motion needs against a motor's and a gear's ratings.

Four motor limits, each compared on the motor side of the gear:

- continuous: RMS motor torque over the run vs ``Drive.rated_torque``, N·m;
- peak: peak motor torque vs ``Drive.peak_torque``, N·m;
- speed: peak motor speed vs ``Drive.max_speed``, rad/s;
- voltage: peak armature voltage |u_a| vs ``Drive.u_max`` (the amplifier's
  output limit) when finite, else ``Drive.rated_voltage``, V.

Three gear limits:

- gear_continuous: RMS gear output torque (the rigid-body joint torque, what
  the gear passes to the link) vs ``Drive.gear_rated_torque``, N·m (N);
- gear_peak: peak gear output torque vs ``Drive.gear_peak_torque`` (the
  repeated-peak rating), N·m (N);
- gear_speed: peak gear input speed (= motor speed) vs
  ``Drive.gear_max_input_speed``, rad/s.

The continuous checks treat the run as the repeated duty cycle: the winding
heats with i², so the RMS torque (= k_m·RMS current) over one cycle is what
the continuous (thermal) rating bounds; for the gear the RMS output torque
against the rated torque is the plain, conservative reading of a rating
given at the rated input speed (a harmonic drive's life calculation with the
cubic mean torque is left to the maker's method).

The margin is ``1 - required / limit``: the fraction of the limit left unused,
negative when the limit is exceeded (-0.25: 25 % over). Status is "pass"
(margin >= 0), "fail" (margin < 0), "unknown" (no drive, or the rating or
the required value is not known, e.g. a motor without electrical data or a
gear without ratings) or "n/a" (a gear check on a drive without a gear:
no gear named, ratio ±1 and no gear rating).
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
#: the gear limits, in report order (see the module docstring)
GEAR_LIMITS: dict[str, tuple[str, str]] = {
    "gear_continuous": ("RMS gear output torque vs gear rated torque", "N·m"),
    "gear_peak": ("peak gear output torque vs gear repeated-peak torque", "N·m"),
    "gear_speed": ("peak gear input speed vs gear max input speed", "rad/s"),
}
#: every check of a sizing, motor first
ALL_LIMITS: dict[str, tuple[str, str]] = {**LIMITS, **GEAR_LIMITS}

PASS, FAIL, UNKNOWN, NA = "pass", "fail", "unknown", "n/a"


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


#: Drive attribute holding each rating ("voltage" is :func:`voltage_limit`)
_RATING_FIELD = {"continuous": "rated_torque", "peak": "peak_torque", "speed": "max_speed",
                 "gear_continuous": "gear_rated_torque", "gear_peak": "gear_peak_torque",
                 "gear_speed": "gear_max_input_speed"}


def ratings(drive: Drive | None, names=ALL_LIMITS) -> dict[str, float]:
    """A drive's rating for each check name (units of :data:`ALL_LIMITS`); nan when unknown.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> ratings(Drive(rated_torque=0.187, gear_rated_torque=40.0))["gear_continuous"]
        40.0
    """
    if drive is None:
        return dict.fromkeys(names, math.nan)
    return {k: voltage_limit(drive) if k == "voltage" else float(getattr(drive, _RATING_FIELD[k]))
            for k in names}


def motor_limits(drive: Drive | None) -> dict[str, float]:
    """The four ratings of a drive's motor (N·m, N·m, rad/s, V); nan when unknown.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> motor_limits(Drive(rated_torque=0.187))["continuous"]
        0.187
    """
    return ratings(drive, LIMITS)


def has_gear(drive: Drive | None) -> bool:
    """True when a drive has a gear to check: one is named, the ratio is not ±1,
    or a gear rating is given.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> has_gear(Drive(ratio=1.0)), has_gear(Drive(ratio=100.0))
        (False, True)
    """
    if drive is None:
        return False
    ratings = (drive.gear_rated_torque, drive.gear_peak_torque, drive.gear_max_input_speed)
    return bool(drive.gear) or abs(drive.ratio) != 1.0 or any(np.isfinite(ratings))


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
    """Check each joint's requirement against its motor and gear, limit by limit.

    Args:
        required: for each name in :data:`ALL_LIMITS`, the (n,) required value
            (RMS motor torque N·m, peak motor torque N·m, peak motor speed
            rad/s, peak armature voltage V, RMS and peak gear output torque
            N·m (N), peak gear input speed rad/s). Gear names may be left out
            (then only the motor is checked).
        drives: the robot's drives (None for a joint without one).

    Returns:
        name -> :class:`LimitCheck`, in the order of :data:`ALL_LIMITS`.

    Example:
        >>> import numpy as np
        >>> from manipcad.model.robot import Drive
        >>> d = Drive(ratio=100.0, gear="harmonic_csf20_100", gear_rated_torque=40.0)
        >>> req = dict.fromkeys(ALL_LIMITS, np.array([1.0]))
        >>> req["gear_continuous"] = np.array([77.6])
        >>> check_limits(req, (d,))["gear_continuous"].status
        ('fail',)
    """
    rated = [ratings(d) for d in drives]
    out = {}
    for name, (desc, unit) in ALL_LIMITS.items():
        if name not in required:
            continue
        lim = np.array([r[name] for r in rated], dtype=float)
        req = np.asarray(required[name], dtype=float)
        m = margin(req, lim)
        status = [status_of(float(v)) for v in m]
        if name in GEAR_LIMITS:
            status = [NA if not has_gear(d) else s for s, d in zip(status, drives, strict=True)]
        out[name] = LimitCheck(name=name, description=desc, unit=unit, required=req, limit=lim,
                               margin=m, status=tuple(status))
    return out


def overall_status(checks: dict[str, LimitCheck]) -> tuple[str, ...]:
    """Per joint: "fail" if any limit fails, else "unknown" if any is unknown, else
    "pass" ("n/a" checks count as passed)."""
    n = len(next(iter(checks.values())).status)
    out = []
    for j in range(n):
        states = {c.status[j] for c in checks.values()}
        out.append(FAIL if FAIL in states else UNKNOWN if UNKNOWN in states else PASS)
    return tuple(out)
