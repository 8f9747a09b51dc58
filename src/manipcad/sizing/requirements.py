"""What a trajectory asks of each drive: torques, speeds, currents, voltages, powers.

:func:`required_drive` samples the trajectory, runs the inverse dynamics with
the drive terms (paper 4.1; the joint torque P_i of the paper's section 2
plus J·i_r²·q̈ + k_v·i_r²·q̇ + |i_r|·M_f·sign(q̇), exactly what the Robotics
Toolbox's ``rne`` returns) and refers the result to each motor
(:mod:`manipcad.sizing.motor`):

    motor torque  T_m = k_m·i = P / i_r          N·m   (η = 1; see below)
    motor speed   ω_m = i_r·q̇                    rad/s
    current       i = T_m / k_m                  A
    voltage       u_a = R·i + L·di/dt + k_w·ω_m  V   (amplifier input U = u_a / k_u)
    mechanical    p_m = P·q̇                      W   (power into the joint, drive terms included)
    electrical    p_e = u_a·i                    W   (power the amplifier delivers)

With a gear efficiency η < 1 the load torque P_rigid is scaled by 1/η while
the motor drives it and by η while it brakes (:mod:`manipcad.sizing.motor`),
so the motor torque, the current, the voltage and the electrical power carry
the gear loss: p_e - p_m = R·i² + L·i·di/dt + (k_w - k_m)·ω_m·i + gear
loss: the copper loss, the change of magnetic energy, the rounding between
catalog k_w and k_m, and the gear's friction. Both powers are negative while
the motor brakes.

Then it checks every motor and every gear against its ratings
(:mod:`manipcad.sizing.limits`): the gear's output torque is P_rigid (RMS and
peak) and its input speed the motor speed.
"""

from __future__ import annotations

import dataclasses
import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from manipcad.fileio import json_safe
from manipcad.model.robot import PRISMATIC, Drive, Robot
from manipcad.sizing.limits import (
    ALL_LIMITS,
    FAIL,
    JOINT_LIMITS,
    UNKNOWN,
    LimitCheck,
    check_joint_limits,
    check_limits,
    margin,
    overall_status,
)
from manipcad.sizing.motion import SampledMotion, sample_motion
from manipcad.sizing.motor import least_over_efficiency, motor_series
from manipcad.sizing.stats import peak, time_mean, time_rms, weighted_cubic_mean
from manipcad.trajectories.base import Trajectory

#: per-joint summary fields: name -> (unit for a revolute joint, unit for a prismatic one,
#: label in tables; the meaning of each is in :class:`DriveRequirements`)
FIELDS: dict[str, tuple[str, str, str]] = {
    "peak_torque": ("N·m", "N", "peak joint torque |P|"),
    "rms_torque": ("N·m", "N", "RMS joint torque"),
    "peak_speed": ("rad/s", "m/s", "peak joint speed |q̇|"),
    "peak_gear_torque": ("N·m", "N", "peak gear output |P_rigid|"),
    "rms_gear_torque": ("N·m", "N", "RMS gear output torque"),
    "average_gear_torque": ("N·m", "N", "average gear load torque"),
    "peak_motor_torque": ("N·m", "N·m", "peak motor torque |T_m|"),
    "rms_motor_torque": ("N·m", "N·m", "RMS motor torque"),
    "peak_motor_speed": ("rad/s", "rad/s", "peak motor speed |ω_m|"),
    "rms_motor_speed": ("rad/s", "rad/s", "RMS motor speed"),
    "mean_motor_speed": ("rad/s", "rad/s", "mean motor speed |ω_m|"),
    "peak_current": ("A", "A", "peak current |i|"),
    "rms_current": ("A", "A", "RMS current"),
    "peak_voltage": ("V", "V", "peak voltage |u_a|"),
    "peak_input_voltage": ("V", "V", "peak amp. input |U|"),
    "peak_mech_power": ("W", "W", "peak |P·q̇|"),
    "mean_mech_power": ("W", "W", "mean P·q̇"),
    "peak_elec_power": ("W", "W", "peak |u_a·i|"),
    "mean_elec_power": ("W", "W", "mean u_a·i"),
}


@dataclass(frozen=True)
class DriveRequirements:
    """The drive torques, speeds, currents, voltages and powers a trajectory needs.

    Per-joint summaries are arrays of shape (n,); joint-side values are in N·m,
    rad/s (N, m/s for prismatic joints), motor-side ones in N·m, rad/s, A, V, W.
    Motor-side values are nan for a joint without a drive; currents, voltages
    and electrical powers are nan when the motor's R, L, k_m or k_w is unknown.
    Peaks are magnitudes (max |x|), RMS and means are time averages over
    [0, t_end] (trapezoidal rule).

    Attributes:
        robot: the robot as used (payload included).
        drives: the drives, one or None per joint.
        t_end: end of the run, s.
        dt: grid step, s.
        payload_mass: payload added, kg.
        t: (N,) sample times, s.
        q, qd, qdd: (N, n) joint positions, velocities, accelerations (SI).
        tau: (N, n) joint torques P with the drive terms, N·m (N).
        motor_torque: (N, n) motor torque k_m·i = P/i_r, N·m.
        motor_speed: (N, n) motor speed i_r·q̇, rad/s.
        current: (N, n) armature current, A.
        voltage: (N, n) armature voltage u_a, V.
        mech_power: (N, n) P·q̇, W.
        elec_power: (N, n) u_a·i, W.
        peak_torque: (n,) peak joint torque |P|, N·m (N).
        rms_torque: (n,) RMS joint torque, N·m (N).
        peak_speed: (n,) peak joint speed, rad/s (m/s).
        peak_gear_torque: (n,) peak gear output torque |P_rigid| (the
            rigid-body joint torque the gear passes), N·m (N).
        rms_gear_torque: (n,) RMS gear output torque, N·m (N).
        average_gear_torque: (n,) average load torque of the gear, the cubic
            mean of |P_rigid| weighted by |q̇| (Harmonic Drive's selection
            procedure), N·m (N).
        peak_motor_torque: (n,) peak motor torque, N·m.
        rms_motor_torque: (n,) RMS motor torque, N·m.
        peak_motor_speed: (n,) peak motor speed, rad/s.
        rms_motor_speed: (n,) RMS motor speed, rad/s.
        mean_motor_speed: (n,) mean |ω_m| (the gear's average input speed), rad/s.
        peak_current: (n,) peak armature current, A.
        rms_current: (n,) RMS armature current, A.
        peak_voltage: (n,) peak armature voltage |u_a|, V.
        peak_input_voltage: (n,) peak amplifier input |U| = |u_a|/k_u, V.
        peak_mech_power: (n,) peak |P·q̇|, W.
        mean_mech_power: (n,) mean P·q̇, W.
        peak_elec_power: (n,) peak |u_a·i|, W.
        mean_elec_power: (n,) mean u_a·i, W.
        checks: limit name -> :class:`~manipcad.sizing.limits.LimitCheck`
            ("continuous", "peak", "speed", "voltage" for the motor;
            "gear_continuous", "gear_peak", "gear_speed", "gear_average",
            "gear_average_speed" for the gear).
        status: per joint "pass", "fail" or "unknown" over all the limits.
    """

    robot: Robot
    drives: tuple[Drive | None, ...]
    t_end: float
    dt: float
    payload_mass: float
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    motor_torque: np.ndarray
    motor_speed: np.ndarray
    current: np.ndarray
    voltage: np.ndarray
    mech_power: np.ndarray
    elec_power: np.ndarray
    peak_torque: np.ndarray
    rms_torque: np.ndarray
    peak_speed: np.ndarray
    peak_gear_torque: np.ndarray
    rms_gear_torque: np.ndarray
    average_gear_torque: np.ndarray
    peak_motor_torque: np.ndarray
    rms_motor_torque: np.ndarray
    peak_motor_speed: np.ndarray
    rms_motor_speed: np.ndarray
    mean_motor_speed: np.ndarray
    peak_current: np.ndarray
    rms_current: np.ndarray
    peak_voltage: np.ndarray
    peak_input_voltage: np.ndarray
    peak_mech_power: np.ndarray
    mean_mech_power: np.ndarray
    peak_elec_power: np.ndarray
    mean_elec_power: np.ndarray
    checks: dict[str, LimitCheck] = field(default_factory=dict)
    status: tuple[str, ...] = ()

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.robot.n

    @property
    def joint_names(self) -> tuple[str, ...]:
        """Joint names."""
        return self.robot.joint_names

    @property
    def ok(self) -> bool:
        """True when every joint passes every limit (unknown counts as not passing)."""
        return all(s == "pass" for s in self.status)

    def units(self, joint: int) -> dict[str, str]:
        """Unit of each summary field for one joint (joint-side units depend on its type)."""
        prismatic = self.robot.joint_types[joint] == PRISMATIC
        return {k: (v[1] if prismatic else v[0]) for k, v in FIELDS.items()}

    def to_dict(self, *, series: bool = False) -> dict[str, Any]:
        """A JSON-ready summary: plain floats, nan as None.

        Args:
            series: also include the time series (t, tau, motor_torque,
                motor_speed, current, voltage), one list per quantity.

        Returns:
            ``{"robot", "t_end" (s), "dt" (s), "payload_mass" (kg), "ok",
            "limits": {name: description}, "joints": [{"name", "type", "motor",
            "gear", "ratio", "units", <each summary field>, "checks": {name:
            {"required", "limit", "margin", "status", "unit"}}, "status"}]}``.
        """
        joints = []
        for j in range(self.n):
            d = self.drives[j]
            entry: dict[str, Any] = {
                "name": self.joint_names[j], "type": self.robot.joint_types[j],
                "motor": d.name if d is not None else None,
                "gear": d.gear if d is not None else None,
                "ratio": json_safe(float(d.ratio)) if d is not None else None,
                "units": self.units(j),
            }
            for key in FIELDS:
                entry[key] = json_safe(getattr(self, key)[j])
            entry["checks"] = {
                name: {"required": json_safe(c.required[j]), "limit": json_safe(c.limit[j]),
                       "margin": json_safe(c.margin[j]), "status": c.status[j],
                       "unit": check_unit(name, c.unit, self.robot.joint_types[j])}
                for name, c in self.checks.items()
            }
            entry["status"] = self.status[j]
            joints.append(entry)
        out: dict[str, Any] = {
            "robot": self.robot.name, "t_end": self.t_end, "dt": self.dt,
            "payload_mass": self.payload_mass, "ok": self.ok,
            "limits": {k: v[0] for k, v in {**ALL_LIMITS, **JOINT_LIMITS}.items()},
            "joints": joints,
        }
        if series:
            out["series"] = {key: json_safe(getattr(self, key)) for key in (
                "t", "tau", "motor_torque", "motor_speed", "current", "voltage")}
        return out

    def __repr__(self) -> str:
        return (f"DriveRequirements({self.robot.name!r}, n={self.n}, t_end={self.t_end:g} s, "
                f"status={list(self.status)})")


def check_unit(name: str, unit: str, joint_type: str) -> str:
    """The unit of check ``name`` on a joint of this type: a joint limit's is the
    prismatic one of :data:`~manipcad.sizing.limits.JOINT_LIMITS` on a prismatic joint.

    Example:
        >>> check_unit("velocity", "rad/s", "prismatic"), check_unit("peak", "N·m", "prismatic")
        ('m/s', 'N·m')
    """
    if name in JOINT_LIMITS and joint_type == PRISMATIC:
        return JOINT_LIMITS[name][2]
    return unit


def motor_side(motion: SampledMotion) -> dict[str, np.ndarray]:
    """Motor torque, speed, current and voltage time series, (N, n) each, nan without a drive.

    Args:
        motion: the sampled motion (:func:`~manipcad.sizing.motion.sample_motion`).

    Returns:
        {"motor_torque" N·m, "motor_speed" rad/s, "current" A, "voltage" V,
        "input_voltage" V}.
    """
    N, n = motion.tau.shape
    out = {k: np.full((N, n), np.nan)
           for k in ("motor_torque", "motor_speed", "current", "voltage", "input_voltage")}
    for j, d in enumerate(motion.robot.drives):
        if d is None:
            continue
        s = motor_series(d, d.ratio, motion.tau[:, j], motion.qd[:, j], motion.qdd[:, j],
                         motion.dtau_rigid[:, j], motion.jerk[:, j], motion.tau_rigid[:, j])
        out["motor_torque"][:, j] = s.torque
        out["motor_speed"][:, j] = s.speed
        out["current"][:, j] = s.current
        out["voltage"][:, j] = s.voltage
        out["input_voltage"][:, j] = s.voltage / d.k_u if d.k_u != 0 else np.nan
    return out


def efficiency_unknown(checks: dict[str, LimitCheck], motion: SampledMotion,
                       t: np.ndarray) -> dict[str, LimitCheck]:
    """The motor checks of the drives whose gear efficiency is unknown (nan), made honest.

    The motor torque and the armature voltage are computed with η = 1, which is not a
    bound: a lower η raises them while the motor drives the load and lowers them while
    the load drives it back. What can be known is the least value over every η in
    (0, 1], sample by sample (:func:`~manipcad.sizing.motor.least_over_efficiency`):
    its RMS and peak bound the RMS and peak at any efficiency from below. So the
    continuous (RMS torque), peak (torque) and voltage (peak voltage) checks fail when
    that bound already exceeds the rating — a check that fails at every efficiency
    fails, whatever the gear's data leave out (``required`` is then the bound) — and
    are "unknown" otherwise (``required`` stays the value at η = 1, margin nan). Speed
    and gear checks do not depend on η and are kept.

    Args:
        checks: the checks of :func:`check_limits` (computed with η = 1 for these drives).
        motion: the sampled motion.
        t: its time grid, s.

    Returns:
        The checks, with those of the unknown-η drives replaced.
    """
    drives = motion.robot.drives
    unknown = [j for j, d in enumerate(drives) if d is not None and math.isnan(d.efficiency)]
    if not unknown:
        return checks
    least: dict[int, dict[str, float]] = {}
    for j in unknown:
        d = drives[j]
        cols = (motion.tau[:, j], motion.qd[:, j], motion.qdd[:, j], motion.dtau_rigid[:, j],
                motion.jerk[:, j], motion.tau_rigid[:, j])
        one = motor_series(d.replace(efficiency=1.0), d.ratio, *cols)
        half = motor_series(d.replace(efficiency=0.5), d.ratio, *cols)
        motoring = motion.tau_rigid[:, j] * motion.qd[:, j] >= 0
        torque = least_over_efficiency(one.torque, half.torque, motoring)
        volts = least_over_efficiency(one.voltage, half.voltage, motoring)
        least[j] = {"continuous": float(time_rms(torque[:, None], t)[0]),
                    "peak": float(peak(torque[:, None])[0]),
                    "voltage": float(peak(volts[:, None])[0])}
    out = dict(checks)
    for name in ("continuous", "peak", "voltage"):
        c = checks[name]
        status = list(c.status)
        req = np.array(c.required, dtype=float)
        for j in unknown:
            bound = least[j][name]
            if bound > c.limit[j]:
                status[j], req[j] = FAIL, bound
            else:
                status[j] = UNKNOWN
        m = margin(req, c.limit)
        m[[k for k, st in enumerate(status) if st == UNKNOWN]] = np.nan
        out[name] = dataclasses.replace(c, required=req, margin=m, status=tuple(status))
    return out


def required_drive(robot: Robot, trajectory: Trajectory, *, t_end: float | None = None,
                   dt: float = 1e-3, payload: Any = None) -> DriveRequirements:
    """The drive torques, currents, voltages and powers a trajectory needs, and the motor checks.

    Args:
        robot: the manipulator with its drives.
        trajectory: a joint trajectory of ``robot.n`` joints (SI units).
        t_end: end of the run, s (default ``trajectory.duration``; after the
            duration the arm holds its last position, so the gravity load
            still counts in the RMS values).
        dt: largest sampling step, s; the grid is uniform, 0 to t_end, with
            step t_end/ceil(t_end/dt).
        payload: None; a payload mass, kg (point mass at the last link's
            origin); or a mapping {"mass": kg, "com": [x, y, z] m in the last
            link's body frame, optional "inertia" (3, 3) kg·m² and "link"}.
            Applied with :meth:`Robot.with_payload`.

    Returns:
        :class:`DriveRequirements`: per-joint peak and RMS torques (joint and
        motor side), speeds, currents, voltages, powers, the four limit checks
        with margins, and the time series.

    Raises:
        InputError: a trajectory with the wrong number of joints, dt or t_end
            not > 0, a bad payload.

    Example:
        >>> import manipcad
        >>> from manipcad.sizing import required_drive
        >>> from manipcad.trajectories import cosine
        >>> arm = manipcad.load_robot("cylindrical")
        >>> req = required_drive(arm, cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], 1.6))
        >>> req.peak_torque.shape, req.checks["continuous"].status[0] in ("pass", "fail")
        ((3,), True)
    """
    motion = sample_motion(robot, trajectory, t_end=t_end, dt=dt, payload=payload)
    t = motion.t
    ms = motor_side(motion)
    mech = motion.tau * motion.qd
    elec = ms["voltage"] * ms["current"]
    summary = {
        "peak_torque": peak(motion.tau), "rms_torque": time_rms(motion.tau, t),
        "peak_speed": peak(motion.qd),
        "peak_gear_torque": peak(motion.tau_rigid),
        "rms_gear_torque": time_rms(motion.tau_rigid, t),
        "average_gear_torque": weighted_cubic_mean(motion.tau_rigid, motion.qd, t),
        "peak_motor_torque": peak(ms["motor_torque"]),
        "rms_motor_torque": time_rms(ms["motor_torque"], t),
        "peak_motor_speed": peak(ms["motor_speed"]),
        "rms_motor_speed": time_rms(ms["motor_speed"], t),
        "mean_motor_speed": time_mean(np.abs(ms["motor_speed"]), t),
        "peak_current": peak(ms["current"]), "rms_current": time_rms(ms["current"], t),
        "peak_voltage": peak(ms["voltage"]), "peak_input_voltage": peak(ms["input_voltage"]),
        "peak_mech_power": peak(mech), "mean_mech_power": time_mean(mech, t),
        "peak_elec_power": peak(elec), "mean_elec_power": time_mean(elec, t),
    }
    drives = motion.robot.drives
    required = {
        "continuous": summary["rms_motor_torque"], "peak": summary["peak_motor_torque"],
        "speed": summary["peak_motor_speed"], "voltage": summary["peak_voltage"],
        "gear_continuous": summary["rms_gear_torque"], "gear_peak": summary["peak_gear_torque"],
        "gear_speed": summary["peak_motor_speed"],
        "gear_average": summary["average_gear_torque"],
        "gear_average_speed": summary["mean_motor_speed"],
    }
    checks = efficiency_unknown(check_limits(required, drives), motion, t)
    checks.update(check_joint_limits(motion.q.min(axis=0), motion.q.max(axis=0),
                                     summary["peak_speed"], summary["peak_gear_torque"],
                                     motion.robot))
    return DriveRequirements(
        robot=motion.robot, drives=drives, t_end=motion.t_end, dt=motion.dt,
        payload_mass=motion.payload_mass, t=t, q=motion.q, qd=motion.qd, qdd=motion.qdd,
        tau=motion.tau, motor_torque=ms["motor_torque"], motor_speed=ms["motor_speed"],
        current=ms["current"], voltage=ms["voltage"], mech_power=mech, elec_power=elec,
        checks=checks, status=overall_status(checks), **summary,
    )
