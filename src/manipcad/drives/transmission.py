"""Elastic transmission with backlash between the motor and the joint.

Compiled scalar kernels. The gear no longer ties the motor to the joint, so
the drive gets its own mechanical states: the motor angle θ_m (rad) and speed
ω_m (rad/s), plus the current i (A) when L is kept. Drive-state order:

- ``KIND_ELASTIC``: ``(θ_m, ω_m, i)``
- ``KIND_ELASTIC_STATIC`` (L neglected): ``(θ_m, ω_m)``

Equations (δ = θ_m/i_r - q is the joint-side deflection, rad)::

    τ_s = k_s·dz(δ, b) + d_s·δ̇        (in contact; 0 inside the gap |δ| <= b)
    J·ω̇_m + k_v·ω_m + M_f(ω_m) = k_m·i - τ_s / i_r          motor shaft
    L·di/dt + R·i + k_w·ω_m = u_a                              armature
    joint side: the multibody model receives τ_s as the joint torque

How the simulator combines an ELASTIC drive with the multibody model: at
every stage it calls :func:`elastic_motor_modal` with the joint's (q, q̇) and the
gear's modes (the hybrid plant of :mod:`manipcad.sim.events`: the contact c of
:func:`gear_torque`, switched where the gap closes or opens, and the motor shaft's
stick-slip mode, switched where it stops or breaks away, both located in time); it
writes the motor-state derivatives and returns τ_s, which is the joint torque handed
to the multibody forward dynamics. :func:`elastic_motor_rhs` is the same with the
modes read from the state (the dead zone's clamp, sign(ω_m) friction). For such a joint the
multibody model must NOT add the rotor inertia, viscous or dry friction
(they are on the motor states here): see
:func:`manipcad.drives.params.joint_referred_terms`.

Stiffness sets the step: RK4 needs ``dt`` well below ``2.8/ω_s``, with
``ω_s = sqrt(k_s·(1/(J·i_r²) + 1/H_ii))`` the transmission's natural frequency.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from manipcad.drives.dc import (
    armature_current_rate,
    dry_friction,
    kinetic_friction,
    static_current,
)
from manipcad.drives.params import (
    KIND_ELASTIC,
    P_DS,
    P_GAP,
    P_J,
    P_KIND,
    P_KM,
    P_KS,
    P_KV,
    P_RATIO,
)


@numba.njit(cache=True)
def dead_zone(x: float, b: float) -> float:
    """Dead zone of half-width b: 0 for |x| <= b, else x - b·sign(x).

    Args:
        x: input (deflection), rad or m.
        b: half-width of the zone, >= 0, same unit.

    Returns:
        dz(x, b), same unit.

    Example:
        >>> from manipcad.drives.transmission import dead_zone
        >>> dead_zone(0.003, 0.001), dead_zone(-0.0005, 0.001)
        (0.002, 0.0)
    """
    if x > b:
        return x - b
    if x < -b:
        return x + b
    return 0.0


@numba.njit(cache=True)
def transmission_torque(theta_m: float, omega_m: float, q: float, qd: float,
                        p: np.ndarray) -> float:
    """Torque the transmission passes to the joint, joint side.

    ``δ = θ_m/i_r - q``, ``δ̇ = ω_m/i_r - q̇``. Without backlash (``b = 0``)
    ``τ_s = k_s·δ + d_s·δ̇``. With backlash ``τ_s = 0`` inside the gap
    ``|δ| <= b``; in contact ``τ_s = k_s·dz(δ, b) + d_s·δ̇``, clipped so that it
    only pushes (``>= 0`` for ``δ > b``, ``<= 0`` for ``δ < -b``).

    Args:
        theta_m: motor angle, rad.
        omega_m: motor speed, rad/s.
        q: joint coordinate, rad (m).
        qd: joint velocity, rad/s (m/s).
        p: packed drive parameters (k_s, d_s, b).

    Returns:
        τ_s, N·m (N for a prismatic joint).

    Example:
        >>> import numpy as np
        >>> from manipcad.drives.transmission import transmission_torque
        >>> from manipcad.drives.params import pack_drive, Transmission
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(ratio=10, R=1, L=1e-3, k_m=.1, k_w=.1),
        ...                Transmission(1000.0, 0.0, 0.01))
        >>> transmission_torque(0.05, 0.0, 0.0, 0.0, p)     # δ = 0.005 inside the gap
        0.0
        >>> round(transmission_torque(0.3, 0.0, 0.0, 0.0, p), 9)   # δ = 0.03
        20.0
    """
    r = p[P_RATIO]
    d = theta_m / r - q
    dd = omega_m / r - qd
    return gear_torque(d, dd, p, contact_of(d, dd, p))


@numba.njit(cache=True)
def gear_torque(d: float, dd: float, p: np.ndarray, c: float) -> float:
    """Torque the gear passes to the joint in contact mode c, joint side.

    ``k_s·(δ - c·b) + d_s·δ̇`` with the teeth in contact on the flank c = +1
    (δ > b) or c = -1 (δ < -b), 0 in the gap (c = 0); without backlash
    (``b = 0``) ``k_s·δ + d_s·δ̇`` whatever c.

    Args:
        d: deflection δ = θ_m/i_r - q, rad (m).
        dd: its rate δ̇, rad/s (m/s).
        p: packed drive parameters (k_s, d_s, b).
        c: contact mode, +1, -1 or 0.

    Returns:
        τ_s, N·m (N).

    Example:
        >>> from manipcad.drives.transmission import gear_torque
        >>> from manipcad.drives.params import pack_drive, Transmission
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(ratio=10, R=1, L=1e-3, k_m=.1, k_w=.1),
        ...                Transmission(1000.0, 2.0, 0.01))
        >>> round(gear_torque(0.03, -1.0, p, 1.0), 9), gear_torque(0.03, -1.0, p, 0.0)
        (18.0, 0.0)
    """
    b = p[P_GAP]
    if b == 0.0:
        return p[P_KS] * d + p[P_DS] * dd
    if c == 0.0:
        return 0.0
    return p[P_KS] * (d - c * b) + p[P_DS] * dd


@numba.njit(cache=True)
def contact_of(d: float, dd: float, p: np.ndarray) -> float:
    """The contact mode of a backlash gear at δ, δ̇ (the dead zone's clamp): +1 when
    δ > b and the contact pushes (its torque > 0), -1 when δ < -b and it pushes the
    other way, else 0 (the gap, or teeth that separate faster than the spring
    closes them: a damper cannot glue them together).

    Args:
        d: deflection δ, rad (m); dd: δ̇, rad/s (m/s); p: packed drive parameters.

    Returns:
        +1, -1 or 0.

    Example:
        >>> from manipcad.drives.transmission import contact_of
        >>> from manipcad.drives.params import pack_drive, Transmission
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(ratio=10, R=1, L=1e-3, k_m=.1, k_w=.1),
        ...                Transmission(1000.0, 2.0, 0.01))
        >>> contact_of(0.03, 0.0, p), contact_of(0.03, -20.0, p), contact_of(-0.02, 0.0, p)
        (1.0, 0.0, -1.0)
    """
    b = p[P_GAP]
    if d > b and gear_torque(d, dd, p, 1.0) > 0.0:
        return 1.0
    if d < -b and gear_torque(d, dd, p, -1.0) < 0.0:
        return -1.0
    return 0.0


@numba.njit(cache=True)
def backlash_residual(delta: float, p: np.ndarray) -> float:
    """Spring torque of the gap minus the linear spring: k_s·(dz(δ, b) - δ).

    The linear models (:func:`manipcad.drives.linear.linearize`) keep the
    transmission in contact with the spring k_s·δ; this is the nonlinear
    remainder F(ε) of the paper's (6) for the stiffness part, joint side.

    Args:
        delta: deflection θ_m/i_r - q, rad.
        p: packed drive parameters.

    Returns:
        Torque correction, N·m: -k_s·δ inside the gap, ∓k_s·b in contact.

    Example:
        >>> from manipcad.drives.transmission import backlash_residual
        >>> from manipcad.drives.params import pack_drive, Transmission
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(ratio=1, R=1, L=1e-3, k_m=.1, k_w=.1),
        ...                Transmission(100.0, 0.0, 0.01))
        >>> round(backlash_residual(0.05, p), 12)
        -1.0
    """
    return p[P_KS] * (dead_zone(delta, p[P_GAP]) - delta)


@numba.njit(cache=True)
def elastic_motor_rhs(xm: np.ndarray, U: float, q: float, qd: float,
                      p: np.ndarray, dxm: np.ndarray) -> float:
    """Motor-side states of an elastic/backlash drive inside the coupled simulator.

    Args:
        xm: motor states (θ_m rad, ω_m rad/s, i A) or (θ_m, ω_m) for the
            2nd-order kind.
        U: amplifier input, V.
        q: joint coordinate, rad.
        qd: joint velocity, rad/s.
        p: packed drive parameters (KIND_ELASTIC or KIND_ELASTIC_STATIC).
        dxm: output, same shape as xm: (ω_m, ω̇_m, di/dt).

    Returns:
        τ_s, the joint-side torque the transmission passes to the joint, N·m.

    Example:
        >>> import numpy as np
        >>> from manipcad.drives.transmission import elastic_motor_rhs
        >>> from manipcad.drives.params import pack_drive, Transmission
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(J=1e-4, ratio=10, R=1, L=1e-3, k_m=.1, k_w=.1),
        ...                Transmission(1000.0))
        >>> d = np.zeros(3)
        >>> round(elastic_motor_rhs(np.array([0.1, 0., 0.]), 0., 0., 0., p, d), 9)
        10.0
    """
    return elastic_motor_modal(xm, U, q, qd, p, dxm, math.nan, math.nan)[0]


@numba.njit(cache=True)
def elastic_motor_modal(xm: np.ndarray, U: float, q: float, qd: float, p: np.ndarray,
                        dxm: np.ndarray, c: float, s: float) -> tuple[float, float]:
    """:func:`elastic_motor_rhs` in given modes (the hybrid plant, :mod:`manipcad.sim.events`).

    Args:
        xm, U, q, qd, p, dxm: as :func:`elastic_motor_rhs`.
        c: the gear's contact mode (:func:`gear_torque`: +1, -1 in contact on that
            flank, 0 in the gap); nan: taken from the state (:func:`contact_of`).
        s: the motor shaft's mode: +1 / -1 sliding that way (the kinetic friction
            :func:`manipcad.drives.dc.kinetic_friction` against it, whatever the sign
            ω_m takes), 0 stuck (ω̇_m = 0 and θ̇_m = ω_m, which is 0); nan: the friction
            law :func:`manipcad.drives.dc.dry_friction` of ω_m.

    Returns:
        (τ_s N·m joint side, T N·m): T the torque on a stuck shaft that its friction
        must hold, k_m·i - τ_s/i_r (0 unless s = 0).

    Example:
        >>> import numpy as np
        >>> from manipcad.drives.transmission import elastic_motor_modal
        >>> from manipcad.drives.params import pack_drive, Transmission
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(J=1e-4, ratio=10, R=1, L=1e-3, k_m=.1, k_w=.1),
        ...                Transmission(1000.0, 0.0, 0.001))
        >>> d = np.zeros(3)
        >>> t = elastic_motor_modal(np.array([0.1, 0., 2.]), 0., 0., 0., p, d, 1.0, 0.0)
        >>> [round(v, 9) for v in t], d[:2].tolist()     # τ_s = 1000·(0.01 - 0.001)
        ([9.0, -0.7], [0.0, 0.0])
    """
    r = p[P_RATIO]
    theta, omega = xm[0], xm[1]
    if int(p[P_KIND]) == KIND_ELASTIC:
        i = xm[2]
        dxm[2] = armature_current_rate(i, U, omega, p)
    else:
        i = static_current(U, omega, p)
    d = theta / r - q
    dd = omega / r - qd
    if c != c:
        c = contact_of(d, dd, p)
    tau_s = gear_torque(d, dd, p, c)
    dxm[0] = omega
    if s == 0.0:
        dxm[1] = 0.0
        return tau_s, p[P_KM] * i - tau_s / r
    f = dry_friction(omega, p) if s != s else kinetic_friction(s, p)
    dxm[1] = (p[P_KM] * i - p[P_KV] * omega - f - tau_s / r) / p[P_J]
    return tau_s, 0.0


@numba.njit(cache=True)
def elastic_rhs(x: np.ndarray, U: float, H_ii: float, h_i: float, tau_load: float,
                p: np.ndarray, dx: np.ndarray) -> None:
    """Right-hand side of ONE elastic/backlash drive with its load (standalone).

    States ``x = (q, q̇, θ_m, ω_m, i)`` (KIND_ELASTIC) or ``(q, q̇, θ_m, ω_m)``
    (KIND_ELASTIC_STATIC). Joint side: ``H_ii·q̈ + h_i·q̇ + τ_l = τ_s``.

    Args:
        x: state, rad, rad/s, rad, rad/s, A.
        U: amplifier input, V.
        H_ii: joint-side load inertia, kg·m² (> 0).
        h_i: joint-side velocity coefficient, N·m·s/rad.
        tau_load: joint-side load torque, N·m.
        p: packed drive parameters.
        dx: output, same shape as x.

    Example:
        >>> import numpy as np
        >>> from manipcad.drives.transmission import elastic_rhs
        >>> from manipcad.drives.params import pack_drive, Transmission
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(J=1e-4, ratio=10, R=1, L=1e-3, k_m=.1, k_w=.1),
        ...                Transmission(1000.0))
        >>> dx = np.zeros(5); elastic_rhs(np.array([0., 0., 0.1, 0., 0.]), 0., 2., 0., 0., p, dx)
        >>> round(float(dx[1]), 9)   # τ_s / H_ii = 10 / 2
        5.0
    """
    tau_s = elastic_motor_rhs(x[2:], U, x[0], x[1], p, dx[2:])
    dx[0] = x[1]
    dx[1] = (tau_s - h_i * x[1] - tau_load) / H_ii
