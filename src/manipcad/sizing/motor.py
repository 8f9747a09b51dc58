"""Motor-side quantities of one rigid-gear DC drive along a sampled motion (paper 3.1).

With the gear ratio i_r (motor angle / joint coordinate) and the joint torque
P (N·m, or N for a prismatic joint) that includes the drive terms,

    ω_m = i_r·q̇                                   motor speed, rad/s
    T_m = k_m·i = P / i_r                         motor (electromagnetic) torque, N·m
        = P_rigid / i_r + J·ω̇_m + k_v·ω_m + M_f(ω_m)
    i   = T_m / k_m                               armature current, A
    u_a = R·i + L·di/dt + k_w·ω_m                 armature voltage, V
    U   = u_a / k_u                               amplifier input, V

The motor torque is the torque the air gap must produce: it covers the load
referred to the shaft, the acceleration of the rotor and gear inertia J and
the motor's own friction, so it is what a data sheet's torque limits and the
current (through k_m) are compared with. di/dt is taken from the smooth part
of T_m (everything but the dry-friction step, see
:mod:`manipcad.sizing.motion`):

    dT_m/dt = (dP_rigid/dt) / i_r + J·i_r·q⃛ + k_v·i_r·q̈

Gear efficiency η (``Drive.efficiency``; 1 without a gear, nan when the
gear's source gives none, computed here as 1 and bounded by
:func:`manipcad.sizing.requirements.required_drive`) acts on the load
torque the gear passes, P_rigid: while the motor drives the load
(P_rigid·q̇ >= 0, holding at rest included) it must supply P_rigid/(i_r·η);
while the load drives the motor back (braking) only P_rigid·η/i_r:

    T_m = P_rigid·f / i_r + J·ω̇_m + k_v·ω_m + M_f(ω_m),   f = 1/η or η

(the rotor inertia and the motor's friction sit before the gear and are not
scaled). With η = 1 this is P / i_r.

The functions broadcast: ``ratio`` may be an array of shape (R, 1) against
samples of shape (N,), giving (R, N) — this is how the ratio sweep evaluates
every ratio in one pass. The drive's numbers (J, k_v, M_f, R, L, k_m, k_w,
efficiency) may be arrays of shape (C, 1) too, one row per candidate drive:
this is how drive selection (:mod:`manipcad.sizing.select`) evaluates a
catalogue's (motor, gear) pairs in one pass.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from manipcad.dynamics.gear import gear_factor_array
from manipcad.model.robot import Drive


@dataclass(frozen=True)
class MotorSeries:
    """Motor-side time series of one drive (shape (N,) or (R, N) for R ratios).

    Attributes:
        torque: motor torque T_m = k_m·i, N·m.
        speed: motor speed ω_m, rad/s.
        current: armature current i, A (nan if k_m is unknown).
        current_rate: di/dt of the smooth part, A/s.
        voltage: armature voltage u_a = R·i + L·di/dt + k_w·ω_m, V (nan if
            R, L, k_m or k_w is unknown).
    """

    torque: np.ndarray
    speed: np.ndarray
    current: np.ndarray
    current_rate: np.ndarray
    voltage: np.ndarray


def coulomb_direction(drive: Drive, qd: np.ndarray) -> np.ndarray:
    """Motor-side dry friction M_f signed by the JOINT direction, N·m.

    M_f+ where q̇ > 0, -M_f- where q̇ < 0, 0 at rest; the joint-side term is
    |i_r| times this, the motor-side term sign(i_r) times this.

    Example:
        >>> import numpy as np
        >>> from manipcad.model.robot import Drive
        >>> coulomb_direction(Drive(M_f=(0.1, 0.3)), np.array([1.0, -1.0, 0.0])).tolist()
        [0.1, -0.3, 0.0]
    """
    return np.where(qd > 0, drive.M_f[0], np.where(qd < 0, -drive.M_f[1], 0.0))


def joint_torque(drive: Drive, ratio, tau_rigid: np.ndarray, qd: np.ndarray,
                 qdd: np.ndarray) -> np.ndarray:
    """Joint torque with this drive's terms at gear ratio ``ratio``, N·m (N).

    P = P_rigid + J·i_r²·q̈ + k_v·i_r²·q̇ + |i_r|·M_f(q̇), the same sum as
    ``inverse_dynamics(..., drives=True)`` for this joint.

    Args:
        drive: the drive (J, k_v, M_f are used; its own ratio is not).
        ratio: i_r, rad/rad (rad/m); scalar or (R, 1).
        tau_rigid, qd, qdd: (N,) rigid-body torque (N·m or N), q̇, q̈ of the joint.
    """
    r = np.asarray(ratio, dtype=float)
    return (tau_rigid + (drive.J * qdd + drive.k_v * qd) * r * r
            + np.abs(r) * coulomb_direction(drive, qd))


def efficiency_factor(drive: Drive, tau_rigid: np.ndarray, qd: np.ndarray) -> np.ndarray:
    """The factor f on the load torque (module docstring): 1/η while the motor
    drives the load or holds it (P_rigid·q̇ >= 0), η while the load drives it back;
    :func:`manipcad.dynamics.gear.gear_factor`, the simulated plant's formula, of each
    sample (``tau_rigid`` and ``qd`` broadcast against each other).

    Example:
        >>> import numpy as np
        >>> from manipcad.model.robot import Drive
        >>> efficiency_factor(Drive(efficiency=0.8), np.array([10.0, 10.0]),
        ...                   np.array([1.0, -1.0])).tolist()
        [1.25, 0.8]
    """
    eta = np.asarray(drive.efficiency, dtype=float)
    eta = np.where(np.isnan(eta), 1.0, eta)  # unknown: η = 1 here; the sizing bounds the rest
    # the simulated plant's own formula (manipcad.dynamics.gear), element by element
    return gear_factor_array(eta, tau_rigid, qd)


def least_over_efficiency(at_one: np.ndarray, at_half: np.ndarray,
                          motoring: np.ndarray) -> np.ndarray:
    """Per sample, the least |x| of a motor-side quantity over every gear efficiency η in (0, 1].

    Every motor-side quantity of :func:`motor_series` (torque, current, voltage) is, per
    sample, affine in the efficiency factor f of :func:`efficiency_factor`:
    x = A + B·f, with f = 1/η in [1, ∞) while the motor drives the load and f = η in
    (0, 1] while the load drives it back. From its values at η = 1 (f = 1) and
    η = 1/2 (f = 2 motoring, 1/2 braking), A and B follow, and the least |A + B·f| over
    the sample's range of f is:

    - motoring, f >= 1: |A + B| when A + B and B have the same sign (|x| grows with f),
      else 0 (x crosses zero at some f > 1);
    - braking, f in (0, 1]: min(|A|, |A + B|) when A and A + B have the same sign, else 0.

    So a peak or an RMS of this bound is a lower bound of the quantity's peak or RMS at
    any efficiency: a check it fails fails whatever the gear's efficiency
    (:func:`manipcad.sizing.requirements.efficiency_unknown`).

    Args:
        at_one: (..., N) the quantity at η = 1 (N·m, A or V).
        at_half: (..., N) the same at η = 1/2.
        motoring: (N,) bool, P_rigid·q̇ >= 0 (the motor drives or holds the load).

    Returns:
        (..., N) the least |x| over η in (0, 1], same unit.

    Example:
        >>> import numpy as np
        >>> # motoring: x = 1 + 2·f (η=1: 3, η=1/2: 5) -> 3; braking: x = 1 + 2·f
        >>> # (η=1: 3, η=1/2: 2) -> 1 (f -> 0); braking x = 1 - 2·f -> 0 (crosses zero)
        >>> least_over_efficiency(np.array([3.0, 3.0, -1.0]), np.array([5.0, 2.0, 0.0]),
        ...                       np.array([True, False, False])).tolist()
        [3.0, 1.0, 0.0]
    """
    at_one, at_half = np.asarray(at_one, dtype=float), np.asarray(at_half, dtype=float)
    b = np.where(motoring, at_half - at_one, (at_half - at_one) / -0.5)  # f(1/2) - f(1)
    a = at_one - b
    up = np.where((at_one * b) >= 0, np.abs(at_one), 0.0)
    down = np.where(a * at_one >= 0, np.minimum(np.abs(a), np.abs(at_one)), 0.0)
    return np.where(motoring, up, down)


def motor_series(drive: Drive, ratio, tau: np.ndarray, qd: np.ndarray, qdd: np.ndarray,
                 dtau_rigid: np.ndarray, jerk: np.ndarray,
                 tau_rigid: np.ndarray | None = None) -> MotorSeries:
    """Motor torque, speed, current and voltage of one drive (module docstring).

    Args:
        drive: the drive (R, L, k_m, k_w, J, k_v, efficiency are used).
        ratio: i_r, rad/rad (rad/m); scalar or (R, 1).
        tau: joint torque with the drive terms at this ratio, N·m (N); (N,) or (R, N).
        qd, qdd: (N,) joint velocity and acceleration (rad/s, rad/s² or m/s, m/s²).
        dtau_rigid: (N,) d/dt of the rigid-body joint torque, N·m/s (N/s).
        jerk: (N,) d(q̈)/dt, rad/s³ (m/s³).
        tau_rigid: (N,) rigid-body joint torque P_rigid, N·m (N): the load the
            gear passes, scaled by the efficiency factor; None ignores the
            efficiency (η = 1).

    Returns:
        :class:`MotorSeries` with the broadcast shape.
    """
    r = np.asarray(ratio, dtype=float)
    f = 1.0 if tau_rigid is None else efficiency_factor(drive, tau_rigid, qd)
    if tau_rigid is not None:
        tau = tau + tau_rigid * (f - 1.0)
    torque = tau / r
    speed = r * qd
    torque_rate = dtau_rigid * f / r + drive.J * r * jerk + drive.k_v * r * qdd
    current = torque / drive.k_m
    current_rate = torque_rate / drive.k_m
    voltage = drive.R * current + drive.L * current_rate + drive.k_w * speed
    return MotorSeries(torque=torque, speed=speed, current=current,
                       current_rate=current_rate, voltage=voltage)
