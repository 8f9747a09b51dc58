"""Run checks: a simulated run judged against every rating, per joint.

:func:`run_checks` takes a :class:`~manipcad.sim.simulate.SimulationResult` and the
robot it ran (payload included) and returns :class:`RunChecks`: per joint, per check,
a :class:`Check` ``{value, limit, unit, verdict}``. The verdicts are "pass", "fail",
"unknown" (a rating or a value that is not known: the check could fail) and "n/a" (the
joint has no such limit: no gear, no velocity limit given, no amplifier limit). A joint
passes when no check fails or is unknown; the run passes when every joint does.

The checks (docs/checks.md gives each formula, limit and the source of the rating):

- ``tracking``: max |q* - q| against the accuracy asked (rad or m); only when one is
  given (``accuracy=``).
- ``saturation``: the fraction of the run the amplifier spends at its output limit,
  |k_u·U| >= u_max, against ``max_saturation`` (default 2 % of the run). With no
  amplifier limit (u_max = inf), ``voltage``: peak |k_u·U| against the motor's rated
  voltage (:func:`manipcad.sizing.limits.voltage_limit`).
- ``chattering``: reversals of the amplifier input per second. A reversal is a change
  of sign of U across a band of ±1 % of the amplifier's input range (u_max/k_u; the
  run's peak |U| without a limit), so rounding near zero does not count. A smooth law's
  input reverses with the motion, a few times per move (0 on the UR5 pick cycle with
  LQR); a switching one (ASVS, VSS in its boundary layer) every one to a few samples,
  hundreds to thousands of times per second — up to 1/T_s, the ceiling the regulator's
  period T_s sets (U is held between samples). The limit is ``max_chatter`` reversals
  per second (default 50: a full-amplitude input oscillation of 25 Hz).
- ``current_rms``, ``current_peak``: RMS and peak armature current against the motor's
  continuous current (``Drive.continuous_current``: rated_torque/k_m, else
  rated_current) and peak current (``Drive.peak_current``: peak_torque/k_m), A: the
  sizing's "continuous" and "peak" ratings in amperes.
- ``speed``, ``gear_continuous``, ``gear_peak``, ``gear_speed``, ``gear_average``,
  ``gear_average_speed``: the same checks ``size`` makes on a trajectory
  (:func:`manipcad.sizing.limits.check_rated`), on the simulated motion: motor speed
  i_r·q̇, and the gear's output torque P_rigid — the rigid-body inverse dynamics of the
  simulated q, q̇, q̈ (q̈ from the recorded q̇ by central differences), what the gear
  passes to the link.
- ``position``, ``velocity``, ``effort``: the joint's own limits (Robot.limits,
  velocity_limits, effort_limits; a URDF's ``<limit>``) against the simulated q, q̇ and
  P_rigid (:func:`manipcad.sizing.limits.check_joint_limits`).

Example:
    >>> import manipcad
    >>> from manipcad.sim.checks import run_checks
    >>> from manipcad.control import load_regulators
    >>> arm = manipcad.load_robot("cylindrical")
    >>> laws = manipcad.load_trajectory("examples/fig3_laws.yaml")
    >>> regs = load_regulators("examples/pid_cylindrical.yaml", arm)
    >>> res = manipcad.simulate(arm, t_end=0.1, dt=1e-4, trajectory=laws, regulators=regs)
    >>> checks = run_checks(res, arm, accuracy=1.0)
    >>> checks["turn"]["tracking"].verdict, checks.verdict in ("pass", "fail", "unknown")
    ('pass', True)
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from manipcad.dynamics import inverse_dynamics
from manipcad.errors import ManipcadError
from manipcad.model.payload import apply_payload
from manipcad.model.robot import PRISMATIC, Robot
from manipcad.sizing.limits import (
    FAIL,
    JOINT_LIMITS,
    NA,
    PASS,
    UNKNOWN,
    check_joint_limits,
    check_rated,
    judge,
    rating_table,
    voltage_limit,
)
from manipcad.sizing.stats import peak, time_mean, time_rms, weighted_cubic_mean

#: the verdicts, worst first
VERDICTS = (FAIL, UNKNOWN, PASS, NA)
#: default largest fraction of the run at the amplifier limit (-)
MAX_SATURATION = 0.02
#: default largest amplifier-input reversals per second (1/s)
MAX_CHATTER = 50.0
#: the reversal band, a fraction of the amplifier's input range (-)
CHATTER_BAND = 0.01

#: every run check, in report order: name -> (what is compared, unit of a revolute
#: joint, unit of a prismatic one)
CHECKS: dict[str, tuple[str, str, str]] = {
    "tracking": ("max |q* - q| vs the accuracy asked", "rad", "m"),
    "saturation": ("fraction of the run at the amplifier limit |k_u·U| >= u_max", "-", "-"),
    "voltage": ("peak |k_u·U| vs the motor's rated voltage (no amplifier limit)", "V", "V"),
    "chattering": ("amplifier-input reversals per second vs max_chatter", "1/s", "1/s"),
    "current_rms": ("RMS armature current vs continuous current (rated torque / k_m)",
                    "A", "A"),
    "current_peak": ("peak armature current vs peak torque / k_m", "A", "A"),
    "speed": ("peak motor speed |i_r·q̇| vs max speed", "rad/s", "rad/s"),
    "gear_continuous": ("RMS gear output torque vs gear rated torque", "N·m", "N"),
    "gear_peak": ("peak gear output torque vs gear repeated-peak torque", "N·m", "N"),
    "gear_speed": ("peak gear input speed vs gear max input speed", "rad/s", "rad/s"),
    "gear_average": ("average load torque (speed-weighted cubic mean) vs gear "
                     "average-torque limit", "N·m", "N"),
    "gear_average_speed": ("mean gear input speed vs gear average-input-speed limit",
                           "rad/s", "rad/s"),
    **{k: v for k, v in JOINT_LIMITS.items()},
}


@dataclass(frozen=True)
class Check:
    """One check of one joint.

    Attributes:
        value: what the run shows (unit ``unit``), nan when unknown.
        limit: what it is compared with (same unit), nan when unknown, inf for none.
        unit: SI unit of both ("-" for a fraction).
        verdict: "pass", "fail", "unknown" or "n/a".
    """

    value: float
    limit: float
    unit: str
    verdict: str

    def to_dict(self) -> dict[str, Any]:
        """``{"value", "limit", "unit", "verdict"}``, nan and inf as None (JSON)."""
        def num(x):
            return float(x) if math.isfinite(x) else None
        return {"value": num(self.value), "limit": num(self.limit), "unit": self.unit,
                "verdict": self.verdict}

    @classmethod
    def from_dict(cls, d: Mapping) -> Check:
        """The inverse of :meth:`to_dict` (None read as nan)."""
        def num(x):
            return math.nan if x is None else float(x)
        return cls(num(d.get("value")), num(d.get("limit")), str(d.get("unit", "")),
                   str(d.get("verdict", UNKNOWN)))


def worst(verdicts) -> str:
    """The overall verdict of several: "fail" if any fails, else "unknown" if any is
    unknown, else "pass" ("n/a" counts as passed).

    Example:
        >>> worst(["pass", "n/a"]), worst(["pass", "unknown"]), worst(["unknown", "fail"])
        ('pass', 'unknown', 'fail')
    """
    v = set(verdicts)
    return FAIL if FAIL in v else UNKNOWN if UNKNOWN in v else PASS


@dataclass(frozen=True)
class RunChecks:
    """Every check of a run, per joint (``checks[joint][name]`` -> :class:`Check`).

    Attributes:
        checks: joint name -> check name -> :class:`Check`, joints in the robot's order,
            checks in the order of :data:`CHECKS`.
        settings: the thresholds used: ``accuracy`` (per joint, rad or m, or None),
            ``max_saturation`` (-), ``max_chatter`` (reversals per second, 1/s).
    """

    checks: dict[str, dict[str, Check]]
    settings: dict = field(default_factory=dict)

    def __getitem__(self, joint: str) -> dict[str, Check]:
        return self.checks[joint]

    def __iter__(self):
        return iter(self.checks)

    @property
    def joints(self) -> tuple[str, ...]:
        """The joint names."""
        return tuple(self.checks)

    def joint_verdict(self, joint: str) -> str:
        """One joint's verdict over its checks (:func:`worst`)."""
        return worst(c.verdict for c in self.checks[joint].values())

    @property
    def verdict(self) -> str:
        """The run's verdict: "fail" if any check fails, else "unknown" if any is unknown,
        else "pass"."""
        return worst(self.joint_verdict(j) for j in self.checks)

    @property
    def ok(self) -> bool:
        """True when every check passes (or is n/a)."""
        return self.verdict == PASS

    def failures(self, verdict: str = FAIL) -> list[tuple[str, str, Check]]:
        """(joint, check name, :class:`Check`) of every check with this verdict."""
        return [(j, k, c) for j, cs in self.checks.items() for k, c in cs.items()
                if c.verdict == verdict]

    def summary(self) -> str:
        """The one-line verdict, e.g. ``"FAIL: 3 checks fail (elbow: saturation 1 of 0.02
        -, current_rms 5.9 of 1.2 A, tracking 3.16 of 0.001 rad)"``."""
        fails, unknown = self.failures(FAIL), self.failures(UNKNOWN)

        def items(rows):
            return ", ".join(f"{j}: {k} {_fmt(c.value)} of {_fmt(c.limit)} {c.unit}"
                             for j, k, c in rows)
        if fails:
            s = "" if len(fails) == 1 else "s"
            return (f"FAIL: {len(fails)} check{s} fail ({items(fails)})"
                    + (f"; {len(unknown)} unknown" if unknown else ""))
        if unknown:
            s = "" if len(unknown) == 1 else "s"
            return (f"UNKNOWN: no check fails; {len(unknown)} cannot be made "
                    f"({_grouped(unknown, list(self.checks))})")
        return f"PASS: every check of {len(self.checks)} joints passes"

    def to_dict(self) -> dict[str, dict[str, dict]]:
        """``{joint: {check: {value, limit, unit, verdict}}}`` (JSON-ready; metrics.json)."""
        return {j: {k: c.to_dict() for k, c in cs.items()} for j, cs in self.checks.items()}

    @classmethod
    def from_dict(cls, d: Mapping, settings: dict | None = None) -> RunChecks:
        """The inverse of :meth:`to_dict`."""
        return cls({str(j): {str(k): Check.from_dict(c) for k, c in cs.items()}
                    for j, cs in d.items()}, dict(settings or {}))

    def rows(self) -> list[dict[str, Any]]:
        """One row per check, for tables: joint, check, value, limit, unit, verdict."""
        return [{"joint": j, "check": k, **c.to_dict()} for j, cs in self.checks.items()
                for k, c in cs.items()]


def _grouped(rows: Sequence[tuple[str, str, Check]], joints: Sequence[str]) -> str:
    """Checks that cannot be made, grouped by the joints they concern, then why:
    ``"current_rms, speed on every joint; tracking on elbow: no rating / no value"`` (a
    check whose value is known lacks its limit, a rating; one whose value is unknown
    lacks the run's data)."""
    by_check: dict[str, list[str]] = {}
    for j, k, _ in rows:
        by_check.setdefault(k, []).append(j)
    groups: dict[tuple[str, ...], list[str]] = {}
    for k, js in by_check.items():
        groups.setdefault(tuple(js), []).append(k)
    why = {"no rating" if math.isfinite(c.value) else "no value" for _, _, c in rows}
    parts = [", ".join(ks) + " on " + ("every joint" if len(js) == len(joints) > 1
                                        else ", ".join(js))
             for js, ks in groups.items()]
    return "; ".join(parts) + f": {' / '.join(sorted(why))}"


def _fmt(x: float) -> str:
    return "-" if x is None or not math.isfinite(x) else f"{x:.3g}"


def _per_joint(value, names: Sequence[str], what: str) -> np.ndarray:
    """A scalar, a sequence of n, or a {joint: value} mapping -> (n,) floats (nan: none)."""
    n = len(names)
    if value is None:
        return np.full(n, np.nan)
    if isinstance(value, Mapping):
        unknown = set(value) - set(names)
        if unknown:
            raise ManipcadError(f"{what}: no joint named {sorted(unknown)[0]!r}; joints are "
                                f"{', '.join(names)}")
        out = np.array([np.nan if value.get(nm) is None else float(value[nm])
                        for nm in names])
    else:
        a = np.asarray(value, dtype=float).reshape(-1)
        if a.size == 1:
            out = np.full(n, float(a[0]))
        elif a.size == n:
            out = a.copy()
        else:
            raise ManipcadError(f"{what}: one value or {n} (one per joint), got {a.size}")
    bad = ~(np.isnan(out) | (out > 0))
    if bad.any():
        raise ManipcadError(f"{what} must be > 0, got {out[bad][0]} for joint "
                            f"{names[int(np.flatnonzero(bad)[0])]!r}")
    return out


def reversals(u: np.ndarray, band: np.ndarray) -> np.ndarray:
    """Sign reversals of each column of u across a band ±band (hysteresis): the count of
    changes between u > band and u < -band, values inside the band keeping the last side.

    Args:
        u: (K, n) signal, any unit.
        band: (n,) half-width of the band (same unit, >= 0).

    Returns:
        (n,) int counts.

    Example:
        >>> reversals(np.array([[1.0], [0.0], [-1.0], [0.05], [1.0], [-0.05]]),
        ...           np.array([0.1])).tolist()
        [2]
    """
    u = np.asarray(u, dtype=float)
    side = np.where(u > band, 1, np.where(u < -band, -1, 0))
    out = np.zeros(u.shape[1], dtype=np.int64)
    for j in range(u.shape[1]):
        s = side[:, j]
        s = s[s != 0]          # inside the band: the last side holds
        out[j] = int(np.count_nonzero(s[1:] != s[:-1]))
    return out


def _accelerations(t: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """q̈ from the recorded q̇ (central differences, one-sided at the ends)."""
    if len(t) < 2:
        return np.zeros_like(qd)
    return np.gradient(qd, t, axis=0, edge_order=1)


def gear_output_torque(result, robot: Robot) -> np.ndarray:
    """The gear output torque P_rigid (N·m or N) along a run, (K, n): the rigid-body
    inverse dynamics of the simulated q, q̇ and q̈ (q̈ by central differences of the
    recorded q̇); with a pickup in the run, the robot after it from the pickup's time."""

    qdd = _accelerations(result.t, result.qd)
    tau = inverse_dynamics(robot, result.q, result.qd, qdd, drives=False)
    pick = (result.settings or {}).get("pickup")
    if isinstance(pick, Mapping) and "t" in pick and "mass" in pick:
        after = robot.with_payload(float(pick["mass"]), pick.get("com", (0.0, 0.0, 0.0)),
                                   pick.get("inertia"), link=pick.get("link", -1))
        k = result.t >= float(pick["t"])
        if k.any():
            tau[k] = inverse_dynamics(after, result.q[k], result.qd[k], qdd[k], drives=False)
    return np.atleast_2d(tau)


def run_checks(result, robot: Robot, *, accuracy=None, payload=None,
               max_saturation: float = MAX_SATURATION,
               max_chatter: float = MAX_CHATTER) -> RunChecks:
    """Judge a simulated run against every rating (module docstring), per joint.

    Args:
        result: a :class:`~manipcad.sim.simulate.SimulationResult` (t, q, q̇, q*, U, i).
        robot: the robot that ran, with its drives (as passed to ``simulate``).
        accuracy: the tracking accuracy asked, rad or m: one value, one per joint, or
            {joint: value}; None (or a joint left out): no tracking check.
        payload: the payload the run carried (``simulate``'s ``payload=``: kg, or a dict),
            applied to ``robot`` for the gear torques; None when ``robot`` already
            carries it.
        max_saturation: the largest fraction of the run at the amplifier limit (0..1].
        max_chatter: the largest amplifier-input reversals per second, 1/s (> 0).

    Returns:
        :class:`RunChecks`.

    Raises:
        ManipcadError: a result and a robot with different joints, a bad accuracy or
            threshold.
    """
    names = tuple(result.joint_names)
    if tuple(robot.joint_names) != names:
        raise ManipcadError(f"the result's joints {list(names)} are not robot "
                            f"{robot.name!r}'s {list(robot.joint_names)}")
    if not (isinstance(max_saturation, int | float) and 0 < max_saturation <= 1):
        raise ManipcadError(f"max_saturation must be in (0, 1], got {max_saturation!r}")
    if not (isinstance(max_chatter, int | float) and 0 < max_chatter < math.inf):
        raise ManipcadError(f"max_chatter must be > 0 reversals/s, got {max_chatter!r}")
    acc = _per_joint(accuracy, names, "accuracy")
    if payload is not None:
        robot = apply_payload(robot, payload)[0]
    n, t = robot.n, np.asarray(result.t, dtype=float)
    drives = robot.drives
    use_drives = bool((result.settings or {}).get("drives", True)) and robot.has_drives
    if not use_drives:
        drives = (None,) * n
    prism = [jt == PRISMATIC for jt in robot.joint_types]
    unit = {k: [v[2] if p else v[1] for p in prism] for k, v in CHECKS.items()}
    out: dict[str, dict[str, Check]] = {nm: {} for nm in names}

    def put(name: str, value, limit, verdict) -> None:
        for j, nm in enumerate(names):
            out[nm][name] = Check(float(value[j]), float(limit[j]), unit[name][j],
                                  str(verdict[j]))

    # tracking
    if np.isfinite(acc).any():
        err = peak(np.asarray(result.q_ref) - np.asarray(result.q))
        m, v = judge(err, acc)
        put("tracking", err, acc, np.where(np.isnan(acc), NA, v))
        for nm, a in zip(names, acc, strict=True):
            if math.isnan(a):
                del out[nm]["tracking"]

    # the amplifier: saturation (or the voltage without a limit), chattering
    U = np.asarray(result.u, dtype=float)
    k_u = np.array([d.k_u if d is not None else np.nan for d in drives])
    u_max = np.array([d.u_max if d is not None else np.nan for d in drives])
    limited = np.isfinite(u_max) & (u_max > 0)
    ua = np.abs(U * np.where(np.isfinite(k_u), k_u, np.nan))
    at_limit = ua >= np.where(limited, u_max, np.inf) * (1.0 - 1e-9)
    frac = time_mean(at_limit.astype(float), t) if len(t) > 1 else at_limit[0].astype(float)
    frac = np.where(limited, frac, np.nan)
    m, v = judge(frac, np.full(n, max_saturation))
    has = np.array([d is not None for d in drives])
    put("saturation", frac, np.full(n, max_saturation),
        np.where(limited & has, v, NA))
    if (has & ~limited).any():
        vlim = np.array([voltage_limit(d) if d is not None else np.nan for d in drives])
        vpk = peak(ua)
        m, v = judge(vpk, vlim)
        put("voltage", vpk, vlim, np.where(has & ~limited, v, NA))
        for nm, lim_ok in zip(names, limited | ~has, strict=True):
            if lim_ok:
                del out[nm]["voltage"]
    T = float(t[-1] - t[0]) if len(t) > 1 else 0.0
    scale = np.where(limited, u_max / np.where(np.isfinite(k_u) & (k_u != 0), np.abs(k_u),
                                              np.nan), peak(U))
    rev = reversals(U, CHATTER_BAND * np.nan_to_num(scale, nan=0.0))
    rate = rev / T if T > 0 else np.zeros(n)
    m, v = judge(rate, np.full(n, float(max_chatter)))
    put("chattering", rate, np.full(n, float(max_chatter)), np.where(has & (T > 0), v, NA))

    # the motor: current (A), speed; the gear: the sizing's checks on the simulated motion
    rated, geared = rating_table(drives)
    i_cont = np.array([d.continuous_current if d is not None else np.nan for d in drives])
    i_peak = np.array([d.peak_current if d is not None else np.nan for d in drives])
    cur = np.asarray(result.current, dtype=float)
    i_rms, i_pk = time_rms(cur, t), peak(cur)
    for name, value, limit in (("current_rms", i_rms, i_cont), ("current_peak", i_pk, i_peak)):
        m, v = judge(value, limit)
        put(name, value, limit, np.where(has, v, NA))
    ratio = np.array([d.ratio if d is not None else np.nan for d in drives])
    qd = np.asarray(result.qd, dtype=float)
    wm = qd * ratio
    P = gear_output_torque(result, robot)
    required = {"speed": peak(wm), "gear_continuous": time_rms(P, t), "gear_peak": peak(P),
                "gear_speed": peak(wm), "gear_average": weighted_cubic_mean(P, qd, t),
                "gear_average_speed": time_mean(np.abs(wm), t)}
    for name, c in check_rated(required, rated, geared).items():
        put(name, c.required, c.limit, np.where(has, c.status, NA))
    q = np.asarray(result.q, dtype=float)
    for name, c in check_joint_limits(q.min(axis=0), q.max(axis=0), peak(qd), peak(P),
                                      robot).items():
        put(name, c.required, c.limit, c.status)
    order = {k: i for i, k in enumerate(CHECKS)}
    checks = {nm: dict(sorted(cs.items(), key=lambda kv: order[kv[0]]))
              for nm, cs in out.items()}
    return RunChecks(checks, {"accuracy": {nm: (None if math.isnan(a) else float(a))
                                           for nm, a in zip(names, acc, strict=True)},
                              "max_saturation": float(max_saturation),
                              "max_chatter": float(max_chatter)})


__all__ = ["run_checks", "RunChecks", "Check", "CHECKS", "worst", "reversals",
           "gear_output_torque", "MAX_SATURATION", "MAX_CHATTER"]
