"""A trajectory sampled on a time grid with the joint torques it needs.

:func:`sample_motion` is the common first step of :func:`~manipcad.sizing.required_drive`
and :func:`~manipcad.sizing.ratio_sweep`: it checks the arguments, puts the
payload on the robot, samples the trajectory on a uniform grid and runs the
inverse dynamics (paper 4.1) on the whole batch:

- ``tau``: joint torques WITH the drive terms J·i_r²·q̈ + k_v·i_r²·q̇ +
  |i_r|·M_f·sign(q̇) (``inverse_dynamics(..., drives=True)``, the Robotics
  Toolbox's ``rne``);
- ``tau_rigid``: the rigid-body torques without them (``drives=False``);
- ``dtau_rigid`` and ``jerk``: time derivatives of ``tau_rigid`` and of q̈,
  which the armature's L·di/dt needs (the trajectories give q, q̇, q̈ only).

The derivatives are taken from extra samples at t ± h (h = 1e-3·Δt) with
the minmod limiter: the smaller of the forward and backward differences when
they have the same sign, 0 when they do not. Where the signal is smooth this
is the derivative to O(h); where the trajectory has a step in q̈ (a cosine law
cut mid-period, the corners of a trapezoidal profile, the hold after
``duration``) it takes the one-sided derivative of the smooth side instead of
a spike of size jump/h. A step of torque is a step of current, which no
finite voltage makes in zero time; the sizing reports the voltage of the
smooth motion on either side of it (docs/sizing.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from manipcad.dynamics.api import inverse_dynamics
from manipcad.errors import InputError, ManipcadError
from manipcad.model.payload import apply_payload
from manipcad.model.robot import Robot
from manipcad.trajectories.base import Trajectory

#: refuse grids longer than this (memory: about 20 arrays of N × n floats)
MAX_SAMPLES = 2_000_000
#: derivative step as a fraction of the grid step
H_FRACTION = 1e-3


@dataclass(frozen=True)
class SampledMotion:
    """A trajectory on a time grid with its joint torques (SI units).

    Attributes:
        robot: the robot, payload included.
        t: (N,) sample times, s, from 0 to t_end.
        q, qd, qdd: (N, n) joint positions, velocities, accelerations
            (rad, rad/s, rad/s² or m, m/s, m/s²).
        tau: (N, n) joint torques with the drive terms, N·m (N for prismatic).
        tau_rigid: (N, n) rigid-body joint torques without the drive terms, N·m (N).
        dtau_rigid: (N, n) d(tau_rigid)/dt, N·m/s (N/s).
        jerk: (N, n) d(q̈)/dt, rad/s³ (m/s³).
        payload_mass: the payload mass added, kg (0 if none).
    """

    robot: Robot
    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    qdd: np.ndarray
    tau: np.ndarray
    tau_rigid: np.ndarray
    dtau_rigid: np.ndarray
    jerk: np.ndarray
    payload_mass: float

    @property
    def t_end(self) -> float:
        """End of the grid, s."""
        return float(self.t[-1])

    @property
    def dt(self) -> float:
        """Grid step, s (<= the requested dt so that t_end is on the grid)."""
        return float(self.t[1] - self.t[0])


def time_grid(t_end: float, dt: float) -> np.ndarray:
    """Uniform grid 0, Δt, ..., t_end (s) with Δt = t_end/ceil(t_end/dt) <= dt.

    Example:
        >>> time_grid(1.0, 0.3).tolist()
        [0.0, 0.25, 0.5, 0.75, 1.0]
    """
    steps = max(1, math.ceil(t_end / dt - 1e-9))
    return np.linspace(0.0, t_end, steps + 1)


def _check_args(robot: Robot, trajectory: Trajectory, t_end: float | None,
                dt: float) -> tuple[float, float]:
    if not isinstance(robot, Robot):
        raise InputError("robot", "", f"expected a Robot, got {type(robot).__name__}")
    if not isinstance(trajectory, Trajectory):
        raise InputError("trajectory", "", f"expected a Trajectory, got "
                         f"{type(trajectory).__name__}")
    if trajectory.n != robot.n:
        raise InputError("trajectory", "", f"has {trajectory.n} joints but robot "
                         f"{robot.name!r} has {robot.n}")
    try:
        dt = float(dt)
        t_end = float(trajectory.duration if t_end is None else t_end)
    except (TypeError, ValueError):
        raise InputError("dt", "", "dt and t_end must be numbers (s)") from None
    if not math.isfinite(dt) or dt <= 0:
        raise InputError("dt", "", f"must be a finite number > 0 s, got {dt}")
    if not math.isfinite(t_end) or t_end <= 0:
        raise InputError("t_end", "", f"must be a finite number > 0 s, got {t_end} "
                         "(a trajectory of zero duration needs an explicit t_end)")
    if t_end / dt > MAX_SAMPLES:
        raise InputError("dt", "", f"t_end/dt = {t_end / dt:.3g} samples is more than "
                         f"{MAX_SAMPLES}; use a larger dt")
    return t_end, dt


def limited_derivative(f_minus: np.ndarray, f0: np.ndarray, f_plus: np.ndarray, h: float,
                       no_backward: np.ndarray) -> np.ndarray:
    """Minmod derivative from samples at t - h, t, t + h (unit of f per s).

    Args:
        f_minus, f0, f_plus: samples, shape (N, ...).
        h: the offset, s.
        no_backward: (N,) bool, True where t - h < 0 (forward difference only).

    Example:
        >>> import numpy as np
        >>> d = limited_derivative(np.array([0.0, 1.0]), np.array([1.0, 1.0]),
        ...                        np.array([2.0, 1.0]), 1.0, np.array([False, False]))
        >>> d.tolist()    # smooth slope 1; a step on the left of the second point -> 0
        [1.0, 0.0]
    """
    fwd = (f_plus - f0) / h
    bwd = (f0 - f_minus) / h
    same = np.sign(fwd) == np.sign(bwd)
    d = np.where(same, np.where(np.abs(fwd) < np.abs(bwd), fwd, bwd), 0.0)
    d[no_backward] = fwd[no_backward]
    return d


def sample_motion(robot: Robot, trajectory: Trajectory, *, t_end: float | None = None,
                  dt: float = 1e-3, payload: Any = None) -> SampledMotion:
    """Sample a trajectory and its joint torques (see the module docstring).

    Args:
        robot: the robot.
        trajectory: a trajectory of ``robot.n`` joints.
        t_end: end of the grid, s (default the trajectory's duration; beyond it
            the trajectory holds at rest).
        dt: largest grid step, s.
        payload: see :func:`manipcad.model.payload.apply_payload` (a mass alone sits
            at the tool point).

    Returns:
        :class:`SampledMotion`.

    Raises:
        InputError: wrong joint count, dt or t_end not > 0, a bad payload.
    """
    t_end, dt = _check_args(robot, trajectory, t_end, dt)
    robot, m_p = apply_payload(robot, payload)
    t = time_grid(t_end, dt)
    h = H_FRACTION * float(t[1] - t[0])
    no_back = t < h
    t_minus = np.where(no_back, t, t - h)
    q, qd, qdd = trajectory.sample(t)
    qp, qdp, qddp = trajectory.sample(t + h)
    qm, qdm, qddm = trajectory.sample(t_minus)
    for name, a in (("q", q), ("qd", qd), ("qdd", qdd)):
        if not np.all(np.isfinite(a)):
            k = int(np.argwhere(~np.isfinite(a))[0, 0])
            raise ManipcadError(f"the trajectory gives a non-finite {name} at t = {t[k]:.6g} s")
    tau = inverse_dynamics(robot, q, qd, qdd, drives=True)
    rig = inverse_dynamics(robot, np.concatenate([q, qp, qm]), np.concatenate([qd, qdp, qdm]),
                           np.concatenate([qdd, qddp, qddm]), drives=False)
    N = t.shape[0]
    tau_rigid, rig_p, rig_m = rig[:N], rig[N:2 * N], rig[2 * N:]
    return SampledMotion(
        robot=robot, t=t, q=q, qd=qd, qdd=qdd, tau=tau, tau_rigid=tau_rigid,
        dtau_rigid=limited_derivative(rig_m, tau_rigid, rig_p, h, no_back),
        jerk=limited_derivative(qddm, qdd, qddp, h, no_back),
        payload_mass=m_p,
    )
