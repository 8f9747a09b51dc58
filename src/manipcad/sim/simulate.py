"""``simulate``: the full coupled closed loop along a trajectory (paper section 5, feature 4)."""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field

import numpy as np

from manipcad.drives.params import (
    KIND_NONE,
    P_KIND,
    joint_referred_terms,
    pack_drives,
    state_offsets,
)
from manipcad.errors import ManipcadError
from manipcad.model.robot import COL_BV, COL_FCN, COL_FCP, COL_JR, Robot
from manipcad.sim.loop import run
from manipcad.sim.metrics import joint_metrics
from manipcad.sim.regulators import NPARAM, NSTATE, Regulator


class SimulationDiverged(ManipcadError):
    """The simulation blew up; ``.result`` holds what was computed up to then."""

    def __init__(self, message: str, result: SimulationResult) -> None:
        super().__init__(message)
        self.result = result


@dataclass
class SimulationResult:
    """Time series and metrics of a closed-loop run (SI units).

    Attributes:
        t: (K,) times, s.
        q, qd: (K, n) joint positions (rad or m) and velocities (rad/s or m/s).
        q_ref, qd_ref: (K, n) reference positions and velocities.
        u: (K, n) regulator outputs: amplifier inputs U, V (joint torque for
            joints without a drive model).
        current: (K, n) armature currents, A (nan without a drive model).
        tau: (K, n) joint torques from the drives (plus disturbance), N·m or N.
        metrics: per joint name: max and RMS error, overshoot, rise and
            settling time (of a step), control effort, energy.
        robot: the robot's name; joint_names: its joints.
        settings: dt, t_end and the regulators' descriptions.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    q_ref: np.ndarray
    qd_ref: np.ndarray
    u: np.ndarray
    current: np.ndarray
    tau: np.ndarray
    joint_names: tuple[str, ...]
    robot: str = ""
    settings: dict = field(default_factory=dict)
    metrics: dict = field(default_factory=dict)

    @property
    def error(self) -> np.ndarray:
        """Tracking error q_ref - q, rad or m, shape (K, n)."""
        return self.q_ref - self.q


def simulate(
    robot: Robot,
    *,
    t_end: float,
    dt: float = 1e-4,
    trajectory=None,
    regulators: Sequence[Regulator] | None = None,
    q0=None,
    qd0=None,
    payload=None,
    drives: bool = True,
    disturbance: Callable[[np.ndarray], np.ndarray] | np.ndarray | None = None,
    transmissions=None,
    order: int = 3,
    record_every: int = 1,
) -> SimulationResult:
    """Simulate the closed loop: coupled multibody dynamics, DC drives, sampled regulators.

    Fixed-step RK4 (compiled), so switching (sliding-mode) regulators are
    integrated exactly as a digital controller runs them: each regulator is
    sampled at its own period (a multiple of ``dt``) and held between samples.

    Args:
        robot: the manipulator (a drive per joint for ``drives=True``; joints
            without one take the regulator output as torque).
        t_end: duration, s (> 0).
        dt: integration step, s.
        trajectory: reference; anything with ``.sample(t) -> (q, qd, qdd)`` of
            shape (len(t), n). None: hold q0.
        regulators: one :class:`Regulator` per controlled joint (others get 0).
        q0, qd0: initial state (default: the reference at t = 0, zero speed).
        payload: None, a mass in kg (at the last link's origin), or a dict
            ``{"mass": kg, "com": [x, y, z] m}`` on the last link.
        drives: True: the DC drives' electrical and mechanical dynamics;
            False: the passive rigid body driven by regulator torques only.
        disturbance: extra joint torques, N·m or N: an (n,) constant or a
            function of the time array returning (len(t), n).
        transmissions: per-joint :class:`manipcad.drives.params.Transmission`
            (elasticity, backlash) or None.
        order: 3 keeps the armature inductance, 2 neglects it.
        record_every: keep every k-th step in the result.

    Returns:
        :class:`SimulationResult`.

    Raises:
        SimulationDiverged: NaN or runaway speed, with the time and joint and
            the partial result.

    Example:
        >>> import manipcad
        >>> from manipcad.sim import simulate
        >>> arm = manipcad.load_robot("cylindrical")
        >>> res = simulate(arm, t_end=0.1, dt=1e-3, drives=False)
        >>> res.q.shape
        (101, 3)
    """
    n = robot.n
    if not (t_end > 0 and math.isfinite(t_end)):
        raise ManipcadError(f"t_end must be > 0 s, got {t_end}")
    if not (dt > 0 and dt <= t_end):
        raise ManipcadError(f"dt must be in (0, t_end], got {dt}")
    if int(record_every) < 1:
        raise ManipcadError(f"record_every must be >= 1, got {record_every}")
    robot = _with_payload(robot, payload)
    K = int(round(t_end / dt))
    t = np.arange(K + 1) * dt
    QR, QDR, QDDR = _reference(trajectory, t, n, q0)
    x_q = QR[0].copy() if q0 is None else _vec(q0, n, "q0")
    x_qd = np.zeros(n) if qd0 is None else _vec(qd0, n, "qd0")
    if trajectory is None:
        QR[:] = x_q
    DIST = _disturbance(disturbance, t, n)

    if drives:
        if not robot.has_drives:
            raise ManipcadError(f"robot {robot.name!r} has no drives; use drives=False")
        dtable = pack_drives(robot.drives, transmissions, order=order)
    else:
        dtable = pack_drives([None] * n)
    off = state_offsets(dtable)
    rtable = np.array(robot.table)
    rtable[:, [COL_JR, COL_BV, COL_FCP, COL_FCN]] = joint_referred_terms(dtable)
    x0 = np.concatenate([x_q, x_qd, _drive_initial_state(dtable, off, x_q, x_qd)])

    rkind, rparam, rstate, rsteps, need_comp, described = _pack_regulators(
        robot, regulators, dt)
    every = int(record_every)
    m = K // every + 1
    # the loop fills every row it keeps (a diverged run is cut after its last recorded row)
    Q, QD, U, I, TAU = (np.empty((m, n)) for _ in range(5))
    T = np.empty(m)
    status, step, joint = run(rtable, robot.table, robot.gravity, dtable, off, bool(drives),
                              rkind, rparam, rstate, rsteps, need_comp, QR, QDR, QDDR, DIST,
                              x0, float(dt), K, every, T, Q, QD, U, I, TAU)
    keep = slice(0, (step // every) + 1) if status else slice(None)
    res = SimulationResult(
        t=T[keep], q=Q[keep], qd=QD[keep], q_ref=QR[::every][keep], qd_ref=QDR[::every][keep],
        u=U[keep], current=I[keep], tau=TAU[keep], joint_names=robot.joint_names,
        robot=robot.name,
        settings={"dt": dt, "t_end": t_end, "drives": bool(drives), "order": order,
                  "regulators": described},
    )
    if status:
        what = "NaN in the state" if status == 1 else "speed above 1e4 rad/s (m/s)"
        where = f"joint {robot.joint_names[joint]!r}" if joint >= 0 else "a drive state"
        raise SimulationDiverged(f"simulation diverged at t = {step * dt:.6g} s: {what} "
                                 f"at {where}", res)
    res.metrics = joint_metrics(res, drives=bool(drives) and robot.has_drives, dtable=dtable)
    return res




def _vec(x, n: int, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.shape != (n,) or not np.isfinite(a).all():
        raise ManipcadError(f"{name} must be a finite vector of shape ({n},), got {a.shape}")
    return a.copy()


def _with_payload(robot: Robot, payload) -> Robot:
    if payload is None:
        return robot
    if isinstance(payload, dict):
        unknown = set(payload) - {"mass", "com", "inertia", "link"}
        if unknown or "mass" not in payload:
            raise ManipcadError("payload must be a mass or a dict with 'mass' and optional "
                                f"'com', 'inertia', 'link'; got keys {sorted(payload)}")
        return robot.with_payload(payload["mass"], payload.get("com", (0, 0, 0)),
                                  payload.get("inertia"), link=payload.get("link", -1))
    return robot.with_payload(float(payload))


def _reference(trajectory, t: np.ndarray, n: int, q0):
    if trajectory is None:
        zero = np.zeros((len(t), n))
        return zero.copy(), zero.copy(), zero
    q, qd, qdd = trajectory.sample(t)
    arrays = [np.ascontiguousarray(a, dtype=float) for a in (q, qd, qdd)]
    for a in arrays:
        if a.shape != (len(t), n):
            raise ManipcadError(f"trajectory has {a.shape[-1]} joints, the robot {n}")
        if not np.isfinite(a).all():
            raise ManipcadError("trajectory samples hold NaN or infinite values")
    return arrays


def _disturbance(disturbance, t: np.ndarray, n: int) -> np.ndarray:
    if disturbance is None:
        return np.zeros((len(t), n))
    d = disturbance(t) if callable(disturbance) else disturbance
    d = np.asarray(d, dtype=float)
    if d.shape == (n,):
        d = np.broadcast_to(d, (len(t), n))
    if d.shape != (len(t), n) or not np.isfinite(d).all():
        raise ManipcadError(f"disturbance must be finite with shape ({n},) or "
                            f"({len(t)}, {n}), got {d.shape}")
    return np.ascontiguousarray(d)


def _drive_initial_state(dtable, off, q, qd) -> np.ndarray:
    """Drive states at rest with the joint: zero current, motor at i_r·q (elastic kinds)."""
    from manipcad.drives.params import KIND_ELASTIC, KIND_ELASTIC_STATIC, P_RATIO

    xd = np.zeros(off[-1])
    for j in range(len(q)):
        if int(dtable[j, P_KIND]) in (KIND_ELASTIC, KIND_ELASTIC_STATIC):
            xd[off[j]] = dtable[j, P_RATIO] * q[j]
            xd[off[j] + 1] = dtable[j, P_RATIO] * qd[j]
    return xd


def _pack_regulators(robot: Robot, regulators, dt: float):
    n = robot.n
    rkind = np.zeros(n, dtype=np.int64)
    rparam = np.zeros((n, NPARAM))
    rstate = np.zeros((n, NSTATE))
    rsteps = np.ones(n, dtype=np.int64)
    described = {}
    need_comp = False
    for reg in regulators or ():
        j = robot.joint_index(reg.joint)
        if rkind[j] != 0:
            raise ManipcadError(f"two regulators for joint {robot.joint_names[j]!r}")
        steps = reg.period / dt
        if abs(steps - round(steps)) > 1e-6 * steps or round(steps) < 1:
            raise ManipcadError(f"regulator period {reg.period:g} s of joint "
                                f"{robot.joint_names[j]!r} is not a multiple of dt = {dt:g} s")
        rkind[j] = reg.kind
        rparam[j] = reg.params
        rstate[j] = reg.initial_state()
        rsteps[j] = int(round(steps))
        need_comp = need_comp or any(s in reg.needs for s in ("H_ii", "h_i", "Q_i"))
        described[robot.joint_names[j]] = reg.describe()
    return rkind, rparam, rstate, rsteps, need_comp, described


__all__ = ["simulate", "SimulationResult", "SimulationDiverged", "KIND_NONE"]
