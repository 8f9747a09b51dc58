"""Checks of what a motion needs against a motor's and a gear's ratings.

Four motor limits, each compared on the motor side of the gear:

- continuous: RMS motor torque over the run vs ``Drive.rated_torque``, N·m;
- peak: peak motor torque vs ``Drive.peak_torque``, N·m;
- speed: peak motor speed vs ``Drive.max_speed``, rad/s;
- voltage: peak armature voltage |u_a| vs ``Drive.u_max`` (the amplifier's
  output limit) when finite, else ``Drive.rated_voltage``, V.

Five gear limits:

- gear_continuous: RMS gear output torque (the rigid-body joint torque, what
  the gear passes to the link) vs ``Drive.gear_rated_torque``, N·m (N);
- gear_peak: peak gear output torque vs ``Drive.gear_peak_torque`` (the
  repeated-peak rating), N·m (N);
- gear_speed: peak gear input speed (= motor speed) vs
  ``Drive.gear_max_input_speed``, rad/s;
- gear_average: the average load torque of Harmonic Drive's selection
  procedure, (∫|ω|·|T|³ dt / ∫|ω| dt)^(1/3) with T the gear output torque and ω
  the joint speed (:func:`~manipcad.sizing.stats.weighted_cubic_mean`), vs
  ``Drive.gear_average_torque`` (the "limit for average torque"), N·m (N);
- gear_average_speed: the mean gear input speed (1/T)∫|ω_m| dt vs
  ``Drive.gear_average_input_speed`` (the "limit for average input speed"), rad/s.

The two average ratings are optional: strain-wave (harmonic) catalogues give
them, planetary, screw and belt data sheets do not. Where a drive lacks one,
the bounds that still decide are used (:func:`average_bounds`): the average
torque limit is never below the rated (continuous) torque (the catalogues'
order, which the gear loader enforces where both are given), so an average
load torque at or under ``gear_rated_torque`` passes, checked against that
rated torque; the average input speed limit is never above the max input
speed, so a mean input speed over ``gear_max_input_speed`` fails. Otherwise an
absent average-torque limit is "unknown" (the load exceeds the continuous
rating and only the missing rating could say whether the gear survives it), an
absent average-speed limit "n/a": nothing below the max speed bounds it, and a
mean speed under the max input speed is what every gear without this rating is
sold for (its peak speed is checked by gear_speed).

The continuous checks treat the run as the repeated duty cycle: the winding
heats with i², so the RMS torque (= k_m·RMS current) over one cycle is what
the continuous (thermal) rating bounds; for the gear the RMS output torque
against the rated torque is the plain, conservative reading of a rating
given at the rated input speed (a harmonic drive's life calculation with the
cubic mean torque is left to the maker's method).

Three limits of the joint itself (the robot's, e.g. a URDF's ``<limit>``),
checked by :func:`check_joint_limits`:

- position: the joint position's extremes vs ``Robot.limits``, rad (m): the
  required value is the extreme nearer its limit (or beyond it), the limit
  that side's; the margin is the room left over the joint's range;
- velocity: peak |q̇| vs ``Robot.velocity_limits``, rad/s (m/s);
- effort: peak gear output torque |P_rigid| (what the actuator passes to the
  link; the joint torque without a drive) vs ``Robot.effort_limits``, N·m (N).

A joint without such a limit (±inf, the default) gets "n/a".

The functions are vectorized: :func:`judge` and :func:`check_rated` take
arrays of any length (the joints of one robot, or thousands of catalogue
candidates for one joint) and :func:`check_limits` is
``check_rated(required, *rating_table(drives))``.

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
    "gear_average": ("average load torque (speed-weighted cubic mean) vs gear average-torque "
                     "limit (else its rated torque as a lower bound)", "N·m"),
    "gear_average_speed": ("mean gear input speed vs gear average-input-speed limit", "rad/s"),
}
#: every check of a sizing, motor first
ALL_LIMITS: dict[str, tuple[str, str]] = {**LIMITS, **GEAR_LIMITS}
#: the joint's own limits (see the module docstring): name -> (what, unit of a revolute
#: joint, unit of a prismatic one)
JOINT_LIMITS: dict[str, tuple[str, str, str]] = {
    "position": ("joint position extremes vs the joint's limits", "rad", "m"),
    "velocity": ("peak joint speed |q̇| vs the joint's velocity limit", "rad/s", "m/s"),
    "effort": ("peak gear output torque |P_rigid| vs the joint's effort limit", "N·m", "N"),
}

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
                 "gear_speed": "gear_max_input_speed", "gear_average": "gear_average_torque",
                 "gear_average_speed": "gear_average_input_speed"}


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
    ratings = (drive.gear_rated_torque, drive.gear_peak_torque, drive.gear_max_input_speed,
               drive.gear_average_torque, drive.gear_average_input_speed)
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


def verdicts(m) -> np.ndarray:
    """"pass" (margin >= 0), "fail" (< 0) or "unknown" (nan) for an array of margins.

    Example:
        >>> verdicts(np.array([0.5, -0.1, np.nan])).tolist()
        ['pass', 'fail', 'unknown']
    """
    m = np.asarray(m, dtype=float)
    return np.where(np.isnan(m), UNKNOWN, np.where(m >= 0, PASS, FAIL)).astype(object)


def judge(required, limit) -> tuple[np.ndarray, np.ndarray]:
    """The margin ``1 - required/limit`` and the verdict of each (required, limit) pair.

    The one comparison of a value against a rating that every check makes (the sizing,
    the selection over a catalogue, the run checks). Any shapes that broadcast.

    Args:
        required: what the motion needs (nan: unknown), in the rating's unit.
        limit: the rating (nan, or <= 0: unknown).

    Returns:
        (margin, verdict): float and object arrays; margin nan and verdict "unknown"
        where either is unknown.

    Example:
        >>> m, v = judge(np.array([1.0, 3.0]), 2.0)
        >>> m.tolist(), v.tolist()
        ([0.5, -0.5], ['pass', 'fail'])
    """
    m = margin(required, limit)
    return m, verdicts(m)


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
        name -> :class:`LimitCheck`, in the order of :data:`ALL_LIMITS`
        (:func:`check_rated` on the drives' :func:`rating_table`).

    Example:
        >>> import numpy as np
        >>> from manipcad.model.robot import Drive
        >>> d = Drive(ratio=100.0, gear="harmonic_csf20_100", gear_rated_torque=40.0)
        >>> req = dict.fromkeys(ALL_LIMITS, np.array([1.0]))
        >>> req["gear_continuous"] = np.array([77.6])
        >>> check_limits(req, (d,))["gear_continuous"].status
        ('fail',)
    """
    rated, geared = rating_table(drives)
    return check_rated(required, rated, geared)


def rating_table(drives) -> tuple[dict[str, np.ndarray], np.ndarray]:
    """The drives' ratings as arrays: check name -> (n,) rating (units of
    :data:`ALL_LIMITS`, nan unknown), and (n,) bool: the drive has a gear
    (:func:`has_gear`).

    Example:
        >>> from manipcad.model.robot import Drive
        >>> rated, geared = rating_table((Drive(rated_torque=0.2), None))
        >>> rated["continuous"].tolist()[0], geared.tolist()
        (0.2, [False, False])
    """
    rows = [ratings(d) for d in drives]
    rated = {k: np.array([r[k] for r in rows], dtype=float) for k in ALL_LIMITS}
    return rated, np.array([has_gear(d) for d in drives], dtype=bool)


def check_rated(required: dict[str, np.ndarray], rated: dict[str, np.ndarray],
                geared: np.ndarray) -> dict[str, LimitCheck]:
    """The checks of :func:`check_limits` on ratings given as arrays, vectorized.

    One element per drive: a robot's joints (``size``) or a catalogue's
    candidate drives for one joint (``select``). The statuses follow the module
    docstring; the average checks without their own rating are decided by
    :func:`average_bounds`' rules.

    Args:
        required: check name -> (n,) required value (units of :data:`ALL_LIMITS`);
            names left out are not checked.
        rated: check name -> (n,) rating, nan unknown (:func:`rating_table`).
        geared: (n,) bool, the drive has a gear (else its gear checks are "n/a").

    Returns:
        name -> :class:`LimitCheck`, in the order of :data:`ALL_LIMITS`.

    Example:
        >>> import numpy as np
        >>> rated = {"peak": np.array([1.0, 1.0, np.nan])}
        >>> c = check_rated({"peak": np.array([0.5, 2.0, 1.0])}, rated, np.zeros(3, bool))
        >>> c["peak"].status, c["peak"].margin.tolist()[:2]
        (('pass', 'fail', 'unknown'), [0.5, -1.0])
    """
    out = {}
    for name, (desc, unit) in ALL_LIMITS.items():
        if name not in required:
            continue
        lim = np.asarray(rated[name], dtype=float)
        req = np.asarray(required[name], dtype=float)
        m = margin(req, lim)
        status = verdicts(m)
        if name == "gear_average":
            lim, m, status = _average_bounds(name, req, lim, m, status, rated["gear_continuous"])
        elif name == "gear_average_speed":
            lim, m, status = _average_bounds(name, req, lim, m, status, rated["gear_speed"])
        if name in GEAR_LIMITS:
            status = np.where(np.asarray(geared, dtype=bool), status, NA)
        out[name] = LimitCheck(name=name, description=desc, unit=unit, required=req, limit=lim,
                               margin=m, status=tuple(status.tolist()))
    return out


def average_bounds(name: str, required: np.ndarray, limit: np.ndarray, m: np.ndarray,
                   status: list[str], drives: tuple[Drive | None, ...]
                   ) -> tuple[np.ndarray, np.ndarray, list[str]]:
    """Decide the average checks of drives without the average rating, where a bound can.

    For "gear_average" (N·m): an unknown limit is bounded below by the gear's
    rated torque, so a required value at or under it passes (``limit`` becomes
    that rated torque, the margin is taken against it); above it (or without a
    rated torque) the status stays "unknown". For "gear_average_speed"
    (rad/s): the unknown limit is bounded above by the max input speed, so a
    required value over it fails (``limit`` becomes the max input speed);
    otherwise the status is "n/a" (not rated). See the module docstring.

    Args:
        name: "gear_average" or "gear_average_speed".
        required: (n,) required values; limit: (n,) ratings, nan unknown;
        m: (n,) margins; status: per-joint statuses (all from :func:`check_limits`).
        drives: the drives.

    Returns:
        (limit, margin, status) with the bounded joints decided.

    Example:
        >>> import numpy as np
        >>> from manipcad.model.robot import Drive
        >>> d = Drive(ratio=100.0, gear="g", gear_rated_torque=40.0)
        >>> req, lim = np.array([30.0, 50.0]), np.array([np.nan, np.nan])
        >>> lim, m, st = average_bounds("gear_average", req, lim, margin(req, lim),
        ...                             [UNKNOWN, UNKNOWN], (d, d))
        >>> st, lim.tolist(), m.round(3).tolist()
        (['pass', 'unknown'], [40.0, nan], [0.25, nan])
    """
    field = "gear_continuous" if name == "gear_average" else "gear_speed"
    bound = rating_table(drives)[0][field]
    limit, m, st = _average_bounds(name, np.asarray(required, dtype=float), limit, m,
                                   np.array(status, dtype=object), bound)
    return limit, m, st.tolist()


def _average_bounds(name: str, required: np.ndarray, limit: np.ndarray, m: np.ndarray,
                    status: np.ndarray, bound: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`average_bounds` on arrays: ``bound`` (n,) is the gear's rated torque
    (N·m, for "gear_average") or its max input speed (rad/s, "gear_average_speed")."""
    limit, m, status = limit.copy(), m.copy(), status.copy()
    bound = np.asarray(bound, dtype=float)
    open_ = ~np.isfinite(limit) & np.isfinite(required)
    known = np.isfinite(bound) & (bound > 0)
    safe = np.where(known, bound, 1.0)
    if name == "gear_average":
        hit = open_ & known & (required <= safe)
        status[hit] = PASS
    else:
        hit = open_ & known & (required > safe)
        status[hit] = FAIL
        status[open_ & ~hit] = NA
    limit[hit] = bound[hit]
    m[hit] = 1.0 - required[hit] / bound[hit]
    return limit, m, status


def check_joint_limits(q_min, q_max, peak_speed, peak_effort, robot) -> dict[str, LimitCheck]:
    """The joints' own limits (:data:`JOINT_LIMITS`) against a motion's extremes, per joint.

    One function for a trajectory (``size``) and for a simulated run (the run checks).

    Args:
        q_min, q_max: (n,) smallest and largest joint position, rad (m).
        peak_speed: (n,) peak |q̇|, rad/s (m/s).
        peak_effort: (n,) peak gear output torque |P_rigid|, N·m (N).
        robot: the robot (its ``limits``, ``velocity_limits``, ``effort_limits``,
            ``joint_types``).

    Returns:
        {"position", "velocity", "effort"} -> :class:`LimitCheck` (unit: the revolute
        one; a prismatic joint's is in :data:`JOINT_LIMITS`). "n/a" where the joint has
        no such limit. Position: ``required`` is the extreme nearer its limit (or further
        beyond it), ``limit`` that side's limit, ``margin`` the room left as a fraction
        of the range (nan for a one-sided range); it passes within 1e-9 of the range
        (rounding).

    Example:
        >>> import numpy as np, manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> lo, hi = arm.limits[:, 0], arm.limits[:, 1]
        >>> c = check_joint_limits(lo, hi + 0.1, np.zeros(3), np.zeros(3), arm)
        >>> c["position"].status[2], c["velocity"].status[2]
        ('fail', 'n/a')
    """
    lo = np.asarray(robot.limits, dtype=float)[:, 0]
    hi = np.asarray(robot.limits, dtype=float)[:, 1]
    q_min, q_max = np.asarray(q_min, dtype=float), np.asarray(q_max, dtype=float)
    room_lo, room_hi = q_min - lo, hi - q_max
    upper = room_hi < room_lo
    req = np.where(upper, q_max, q_min)
    lim = np.where(upper, hi, lo)
    room = np.minimum(room_lo, room_hi)
    span = hi - lo
    with np.errstate(invalid="ignore", divide="ignore"):
        m = np.where(np.isfinite(span) & (span > 0), room / np.where(span > 0, span, 1.0),
                     np.nan)
    tol = 1e-9 * np.maximum(1.0, np.abs(np.where(np.isfinite(lim), lim, 0.0)))
    status = np.where(~np.isfinite(lim), NA,
                      np.where(~np.isfinite(room), UNKNOWN,
                               np.where(room >= -tol, PASS, FAIL))).astype(object)
    out = {"position": LimitCheck("position", JOINT_LIMITS["position"][0], "rad", req, lim, m,
                                  tuple(str(x) for x in status))}
    for name, value, limit in (("velocity", peak_speed, robot.velocity_limits),
                               ("effort", peak_effort, robot.effort_limits)):
        value = np.asarray(value, dtype=float)
        limit = np.asarray(limit, dtype=float)
        m, st = judge(value, np.where(np.isfinite(limit), limit, np.nan))
        st = np.where(np.isfinite(limit), st, NA)
        out[name] = LimitCheck(name, JOINT_LIMITS[name][0], JOINT_LIMITS[name][1], value,
                               limit, m, tuple(str(x) for x in st))
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
