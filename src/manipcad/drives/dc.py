"""DC servo drive: amplifier, armature circuit, motor torque, rigid gear (paper 3.1).

Compiled scalar kernels (``numba.njit``), safe to call from the simulator's
compiled RK4. They read the packed parameter vector ``p`` of
:mod:`manipcad.drives.params`.

Equations (motor side, ω_m = i_r·q̇ for a rigid gear)::

    u_a = clip(k_u·U, -u_max, u_max)                  amplifier output, V
    L·di/dt + R·i + k_w·ω_m = u_a                     armature
    (J + H*)·ω̇_m + (h* + k_v)·ω_m + M_f(ω_m) = k_m·i - τ_l / i_r     shaft

with H* = H_ii / i_r², h* = h_i / i_r² and τ_l the joint-side load torque
not carried by H_ii·q̈ + h_i·q̇ (gravity, coupling, external), N·m.

How the closed-loop simulator combines a RIGID drive with the multibody model
(kinds ``KIND_RIGID``, ``KIND_RIGID_STATIC``):

1. drive state: the armature current ``i`` (A) only (none if L is neglected);
2. at every RK4 stage, with the joint velocity q̇ of that stage:
   ``di/dt = armature_current_rate(i, U, i_r·q̇, p)``
   (or ``i = static_current(U, i_r·q̇, p)`` for the 2nd-order kind);
3. the joint torque from the drive is ``τ = rigid_joint_torque(i, p) = i_r·k_m·i``;
4. the multibody forward dynamics WITH the drive terms (``drives=True``:
   ``J·i_r²`` on the diagonal of H, ``k_v·i_r²·q̇`` and ``|i_r|·M_f·sign(q̇)``)
   takes that τ and returns q̈. The shaft equation above is exactly that
   joint equation divided by i_r, so nothing else is added.

Elastic and backlash gears are in :mod:`manipcad.drives.transmission`.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from manipcad.drives.params import (
    KIND_RIGID,
    KIND_RIGID_STATIC,
    P_J,
    P_KIND,
    P_KM,
    P_KU,
    P_KV,
    P_KW,
    P_L,
    P_MFN,
    P_MFP,
    P_R,
    P_RATIO,
    P_UMAX,
    P_WEPS,
)


@numba.njit(cache=True)
def amplifier_voltage(U: float, k_u: float, u_max: float) -> float:
    """Amplifier output (armature) voltage with its output limit.

    Args:
        U: amplifier input (control signal), V.
        k_u: amplifier gain, V/V.
        u_max: limit of the OUTPUT voltage k_u·U, V (inf: none).

    Returns:
        u_a = clip(k_u·U, -u_max, u_max), V.

    Example:
        >>> from manipcad.drives.dc import amplifier_voltage
        >>> amplifier_voltage(5.0, 10.0, 24.0)
        24.0
    """
    return clip(k_u * U, u_max)


@numba.njit(cache=True)
def clip(u: float, lim: float) -> float:
    """u limited to [-lim, lim] (lim = inf: no limit); the one saturation of the package.

    Example:
        >>> from manipcad.drives.dc import clip
        >>> clip(-7.0, 5.0)
        -5.0
    """
    if u > lim:
        return lim
    if u < -lim:
        return -lim
    return u


@numba.njit(cache=True)
def dry_friction(omega_m: float, p: np.ndarray) -> float:
    """Dry (Coulomb) friction torque on the motor shaft, opposing the motion.

    Uses M_f+ when the motion moves the joint positively
    (``sign(ω_m·i_r) > 0``), M_f- otherwise; inside the linear zone
    ``|ω_m| < p[P_WEPS]`` (if > 0) the torque is ``M_f·ω_m/ω_eps``.

    Args:
        omega_m: motor speed, rad/s.
        p: packed drive parameters.

    Returns:
        Friction torque with the sign of ω_m (enters the shaft equation with a
        plus sign on the left), N·m; 0 at ω_m = 0.

    Example:
        >>> from manipcad.drives.dc import dry_friction
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(ratio=-5, M_f=(0.1, 0.3), R=1, L=1e-3, k_m=.1, k_w=.1))
        >>> dry_friction(-2.0, p)   # motor turns back -> joint moves forward -> M_f+
        -0.1
    """
    if omega_m == 0.0:
        return 0.0
    weps = p[P_WEPS]
    if weps > 0.0 and abs(omega_m) < weps:
        return abs(kinetic_friction(omega_m, p)) * omega_m / weps
    return kinetic_friction(omega_m, p)


@numba.njit(cache=True)
def kinetic_friction(s: float, p: np.ndarray) -> float:
    """The dry friction torque on the motor shaft for motion of sign s, opposing it.

    M_f+ when the motion moves the joint positively (``sign(s·i_r) > 0``), M_f- otherwise
    (no linear zone: the friction of a shaft sliding that way).

    Args:
        s: the direction of the motor's motion (its sign counts), rad/s or -.
        p: packed drive parameters.

    Returns:
        +M_f for s > 0, -M_f for s < 0, 0 for s = 0, N·m.

    Example:
        >>> from manipcad.drives.dc import kinetic_friction
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(ratio=-5, M_f=(0.1, 0.3), R=1, L=1e-3, k_m=.1, k_w=.1))
        >>> kinetic_friction(-1.0, p), kinetic_friction(1.0, p)
        (-0.1, 0.3)
    """
    if s == 0.0:
        return 0.0
    mf = p[P_MFP] if (s > 0.0) == (p[P_RATIO] > 0.0) else p[P_MFN]
    return mf if s > 0.0 else -mf


@numba.njit(cache=True)
def armature_current_rate(i: float, U: float, omega_m: float, p: np.ndarray) -> float:
    """di/dt of the armature: (u_a - R·i - k_w·ω_m) / L.

    Args:
        i: armature current, A.
        U: amplifier input, V.
        omega_m: motor speed, rad/s (i_r·q̇ for a rigid gear).
        p: packed drive parameters (needs L > 0).

    Returns:
        di/dt, A/s.

    Example:
        >>> from manipcad.drives.dc import armature_current_rate
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(R=2.0, L=1e-3, k_m=.1, k_w=.1, k_u=1.0))
        >>> armature_current_rate(0.0, 1.0, 0.0, p)
        1000.0
    """
    u_a = amplifier_voltage(U, p[P_KU], p[P_UMAX])
    return (u_a - p[P_R] * i - p[P_KW] * omega_m) / p[P_L]


@numba.njit(cache=True)
def static_current(U: float, omega_m: float, p: np.ndarray) -> float:
    """Armature current with the inductance neglected: (u_a - k_w·ω_m) / R.

    Args:
        U: amplifier input, V.
        omega_m: motor speed, rad/s.
        p: packed drive parameters.

    Returns:
        i, A.

    Example:
        >>> from manipcad.drives.dc import static_current
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(R=2.0, L=0.0, k_m=.1, k_w=.1, k_u=1.0))
        >>> static_current(1.0, 0.0, p)
        0.5
    """
    u_a = amplifier_voltage(U, p[P_KU], p[P_UMAX])
    return (u_a - p[P_KW] * omega_m) / p[P_R]


@numba.njit(cache=True)
def phis(z: float) -> tuple[float, float, float, float, float]:
    """The exponential integrators' φ_0..φ_4 at z, with one exponential.

    φ_k(z) = (e^z - Σ_{j<k} z^j/j!) / z^k: φ_0 = e^z, φ_k(0) = 1/k!, and
    t^(k+1)·k!·φ_(k+1)(λt) = ∫_0^t e^(λ(t-τ))·τ^k dτ. For |z| < 1 φ_4 by its Taylor
    series and φ_k = z·φ_(k+1) + 1/k! downwards (no cancellation); beyond, the
    recurrence φ_(k+1) = (φ_k - 1/k!)/z upwards from e^z.

    Args:
        z: argument (λ·t, -).

    Returns:
        (φ_0, φ_1, φ_2, φ_3, φ_4), -.

    Example:
        >>> import math
        >>> from manipcad.drives.dc import phis
        >>> abs(phis(-2.0)[1] - (1 - math.exp(-2.0)) / 2) < 1e-15
        True
        >>> phis(0.0) == (1.0, 1.0, 0.5, 1 / 6, 1 / 24)
        True
    """
    if abs(z) < 1.0:
        term = 1.0 / 24.0
        p4 = term
        for m in range(1, 30):
            term *= z / (m + 4)
            p4 += term
            if abs(term) < 1e-17 * abs(p4):
                break
        p3 = z * p4 + 1.0 / 6.0
        p2 = z * p3 + 0.5
        p1 = z * p2 + 1.0
        return z * p1 + 1.0, p1, p2, p3, p4
    p0 = math.exp(z)
    p1 = (p0 - 1.0) / z
    p2 = (p1 - 1.0) / z
    p3 = (p2 - 0.5) / z
    return p0, p1, p2, p3, (p3 - 1.0 / 6.0) / z


@numba.njit(cache=True)
def armature_current_poly(i0: float, U: float, omega0: float, w1: float, w2: float,
                          w3: float, t: float, p: np.ndarray) -> float:
    """Armature current t s later, U held and the motor speed a cubic in time.

    The exact solution of the armature equation L·di/dt + R·i + k_w·ω_m(τ) = u_a(U)
    with ω_m(τ) = ω0 + w1·τ + w2·τ² + w3·τ³ over [0, t]: with λ = -R/L, z = λ·t and
    the functions :func:`phis`,

        i(t) = e^z·i0 + t·φ_1(z)·(u_a - k_w·ω0)/L
               - (k_w/L)·(w1·t²·φ_2(z) + 2·w2·t³·φ_3(z) + 6·w3·t⁴·φ_4(z)),

    which holds the lag of the current behind a changing back-EMF and is exact for
    any L/R, however short. The adaptive integrator (:mod:`manipcad.sim.adaptive`)
    advances the stiff current this way, the speed's polynomial taken from its own
    stages.

    Args:
        i0: current at the start, A.
        U: amplifier input held over the step, V.
        omega0: motor speed at the start, rad/s.
        w1, w2, w3: the speed's polynomial coefficients, rad/s², rad/s³, rad/s⁴.
        t: step length, s (>= 0; 0 returns i0).
        p: packed drive parameters (L > 0).

    Returns:
        i(t), A.

    Example:
        >>> import math
        >>> from manipcad.drives.dc import armature_current_poly
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(R=2.0, L=1e-3, k_m=.1, k_w=.1, k_u=1.0))
        >>> i = armature_current_poly(0.0, 1.0, 0.0, 0.0, 0.0, 0.0, 5e-4, p)  # one L/R
        >>> abs(i - 0.5 * (1 - math.exp(-1.0))) < 1e-15
        True
    """
    if t <= 0.0:
        return i0
    p0, p1, p2, p3, p4 = phis(-t * p[P_R] / p[P_L])
    return armature_current_phis(i0, U, omega0, w1, w2, w3, t, p, p0, p1, p2, p3, p4)


@numba.njit(cache=True)
def armature_current_phis(i0: float, U: float, omega0: float, w1: float, w2: float,
                          w3: float, t: float, p: np.ndarray, p0: float, p1: float,
                          p2: float, p3: float, p4: float) -> float:
    """:func:`armature_current_poly` with φ_0..φ_4 (-R·t/L) given (:func:`phis`).

    For a caller that advances many currents over the same t (the adaptive
    integrator's stages) and computes the φ once. Arguments and result as
    :func:`armature_current_poly`; p0..p4: φ_0..φ_4 at z = -R·t/L, -.

    Example:
        >>> from manipcad.drives.dc import armature_current_phis, armature_current_poly, phis
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(R=2.0, L=1e-3, k_m=.1, k_w=.1, k_u=1.0))
        >>> i = armature_current_phis(0.3, 1.0, 5.0, 2e2, 0.0, 0.0, 1e-3, p, *phis(-2.0))
        >>> i == armature_current_poly(0.3, 1.0, 5.0, 2e2, 0.0, 0.0, 1e-3, p)
        True
    """
    L = p[P_L]
    u_a = amplifier_voltage(U, p[P_KU], p[P_UMAX])
    return (p0 * i0 + t * p1 * (u_a - p[P_KW] * omega0) / L
            - p[P_KW] / L * t * t * (w1 * p2 + t * (2.0 * w2 * p3 + 6.0 * w3 * t * p4)))


@numba.njit(cache=True)
def static_input(i: float, omega_m: float, p: np.ndarray) -> float:
    """Amplifier input that drives the current i at motor speed ω_m, L neglected, V.

    The inverse of :func:`static_current` inside the amplifier's linear zone:
    ``U = (R·i + k_w·ω_m)/k_u`` (V) for the armature current i wanted (A);
    ``omega_m`` and ``p`` as there.

    Example (there and back at 10 rad/s):
        >>> from manipcad.drives import dc, params
        >>> from manipcad.model.robot import Drive
        >>> p = params.pack_drive(Drive(R=2.0, L=0.0, k_m=.1, k_w=.1, k_u=1.0))
        >>> U = dc.static_input(0.5, 10.0, p); U, dc.static_current(U, 10.0, p)
        (2.0, 0.5)
    """
    return (p[P_R] * i + p[P_KW] * omega_m) / p[P_KU]


@numba.njit(cache=True)
def rigid_joint_torque(i: float, p: np.ndarray) -> float:
    """Joint-side torque delivered by a rigid-gear drive: i_r·k_m·i.

    Rotor inertia and motor friction are NOT subtracted here: the multibody
    model with ``drives=True`` carries them (J·i_r², k_v·i_r², |i_r|·M_f).

    Args:
        i: armature current, A.
        p: packed drive parameters.

    Returns:
        Joint torque, N·m (N for a prismatic joint).

    Example:
        >>> from manipcad.drives.dc import rigid_joint_torque
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.model.robot import Drive
        >>> rigid_joint_torque(2.0, pack_drive(Drive(ratio=50, R=1, L=1e-3, k_m=.1, k_w=.1)))
        10.0
    """
    return p[P_RATIO] * p[P_KM] * i


@numba.njit(cache=True)
def rigid_current_for(tau: float, p: np.ndarray) -> float:
    """The armature current at which a rigid-gear drive gives the joint torque ``tau``
    (N·m, N for a prismatic joint; ``p`` the packed drive): τ/(k_m·i_r), A, the inverse
    of :func:`rigid_joint_torque`.

    Example (there and back):
        >>> from manipcad.drives import dc, params
        >>> from manipcad.model.robot import Drive
        >>> p = params.pack_drive(Drive(ratio=50, R=1, L=1e-3, k_m=.1, k_w=.1))
        >>> dc.rigid_current_for(10.0, p), dc.rigid_joint_torque(2.0, p)
        (2.0, 10.0)
    """
    return tau / (p[P_KM] * p[P_RATIO])


@numba.njit(cache=True)
def required_joint_torque(f: float, load: float, qdd: float, qd: float, friction: float,
                          p: np.ndarray) -> float:
    """The joint torque a rigid-gear drive must give (:func:`rigid_joint_torque`, i_r·k_m·i)
    to move its joint at q̈, q̇ against the load its gear passes, N·m (N).

    ``τ = f·P + J·i_r²·q̈ + k_v·i_r²·q̇`` (+ ``|i_r|·M_f·sgn q̇``, as
    :func:`dry_friction` of ω_m = i_r·q̇, when ``friction`` != 0): the joint equation
    of the module docstring solved for the drive's torque, the load P times the gear
    factor f (:func:`manipcad.dynamics.gear.gear_factor`; 1 without losses).

    Args:
        f: gear factor on the load, -.
        load: the load torque P the gear passes to the joint, N·m (N).
        qdd: joint acceleration, rad/s² (m/s²).
        qd: joint velocity, rad/s (m/s).
        friction: 1 to include the motor's dry friction, 0 to leave it out.
        p: packed drive parameters.

    Returns:
        τ, N·m (N).

    Example:
        >>> from manipcad.drives.dc import required_joint_torque
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(J=1e-4, k_v=1e-3, ratio=10, R=1, L=1e-3, k_m=.1, k_w=.1))
        >>> round(required_joint_torque(1.25, 2.0, 3.0, 0.5, 0.0, p), 12)  # 2.5 + 0.03 + 0.05
        2.58
    """
    r = p[P_RATIO]
    tau = f * load + p[P_J] * r * r * qdd + p[P_KV] * r * r * qd
    if friction != 0.0:
        tau += r * dry_friction(r * qd, p)
    return tau


@numba.njit(cache=True)
def rigid_drive_rate(i: float, U: float, qd: float, p: np.ndarray) -> tuple[float, float]:
    """One rigid drive inside the coupled simulator: (di/dt, joint torque).

    Args:
        i: armature current, A (ignored for the 2nd-order kind).
        U: amplifier input, V.
        qd: joint velocity, rad/s (m/s).
        p: packed drive parameters of kind KIND_RIGID or KIND_RIGID_STATIC.

    Returns:
        (di/dt A/s, 0 for the 2nd-order kind; joint torque i_r·k_m·i N·m).

    Example:
        >>> from manipcad.drives.dc import rigid_drive_rate
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(ratio=10, R=1.0, L=1e-2, k_m=.1, k_w=.1))
        >>> rigid_drive_rate(1.0, 2.0, 0.0, p)
        (100.0, 1.0)
    """
    omega = p[P_RATIO] * qd
    if int(p[P_KIND]) == KIND_RIGID_STATIC:
        return 0.0, rigid_joint_torque(static_current(U, omega, p), p)
    return armature_current_rate(i, U, omega, p), rigid_joint_torque(i, p)


@numba.njit(cache=True)
def rigid_rhs(x: np.ndarray, U: float, H_ii: float, h_i: float, tau_load: float,
              p: np.ndarray, dx: np.ndarray) -> None:
    """Right-hand side of ONE rigid drive with its load frozen (or given per call).

    Joint-side form of the paper's shaft equation (divide by i_r to get it)::

        (H_ii + J·i_r²)·q̈ + (h_i + k_v·i_r²)·q̇ + i_r·M_f(i_r·q̇) + τ_l = i_r·k_m·i

    States ``x = (q, q̇, i)`` (kind KIND_RIGID) or ``(q, q̇)`` (KIND_RIGID_STATIC).
    H_ii, h_i and τ_l may change from call to call (time-varying load).

    Args:
        x: state, rad, rad/s, A.
        U: amplifier input, V.
        H_ii: joint-side load inertia, kg·m² (kg).
        h_i: joint-side velocity coefficient, N·m·s/rad.
        tau_load: joint-side load torque, N·m (gravity, coupling, external).
        p: packed drive parameters.
        dx: output, same shape as x: (q̇, q̈, di/dt).

    Example:
        >>> import numpy as np
        >>> from manipcad.drives.dc import rigid_rhs
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.model.robot import Drive
        >>> p = pack_drive(Drive(J=1e-4, ratio=10, R=1, L=1e-3, k_m=.1, k_w=.1))
        >>> dx = np.zeros(3); rigid_rhs(np.array([0., 0., 1.]), 0., 0.01, 0., 0., p, dx)
        >>> float(dx[1])    # 10·0.1·1 / (0.01 + 1e-4·100)
        50.0
    """
    r = p[P_RATIO]
    qd = x[1]
    omega = r * qd
    if int(p[P_KIND]) == KIND_RIGID:
        i = x[2]
        dx[2] = armature_current_rate(i, U, omega, p)
    else:
        i = static_current(U, omega, p)
    inertia = H_ii + p[P_J] * r * r
    torque = (r * p[P_KM] * i - (h_i + p[P_KV] * r * r) * qd
              - r * dry_friction(omega, p) - tau_load)
    dx[0] = qd
    dx[1] = torque / inertia


@numba.njit(cache=True)
def rigid_current(x: np.ndarray, U: float, p: np.ndarray) -> float:
    """Armature current of a standalone rigid drive state (either kind), A.

    Args:
        x: (q, q̇, i) or (q, q̇).
        U: amplifier input, V.
        p: packed drive parameters.

    Returns:
        i, A.
    """
    if int(p[P_KIND]) == KIND_RIGID:
        return x[2]
    return static_current(U, p[P_RATIO] * x[1], p)


@numba.njit(cache=True)
def rigid_powers(x: np.ndarray, U: float, H_ii: float, h_i: float, tau_load: float,
                 p: np.ndarray, out: np.ndarray) -> None:
    """Power flows of a standalone rigid drive, for the energy balance.

    With ω = i_r·q̇, H* = H_ii/i_r², h* = h_i/i_r²::

        u_a·i = R·i² + d/dt(½·L·i²) + k_w·ω·i                 (electrical)
        k_m·i·ω = d/dt(½·(J+H*)·ω²) + (h*+k_v)·ω² + M_f(ω)·ω + (τ_l/i_r)·ω   (mechanical)

    (for constant H*; k_w·ω·i = k_m·i·ω when k_m = k_w in SI units).

    Args:
        x: state (q, q̇, i) or (q, q̇).
        U: amplifier input, V.
        H_ii, h_i, tau_load: joint-side load (kg·m², N·m·s/rad, N·m).
        p: packed drive parameters.
        out: output (7,), W: [u_a·i, R·i², k_w·ω·i, k_m·i·ω,
            (h*+k_v)·ω², M_f(ω)·ω, (τ_l/i_r)·ω].
    """
    r = p[P_RATIO]
    omega = r * x[1]
    i = rigid_current(x, U, p)
    out[0] = amplifier_voltage(U, p[P_KU], p[P_UMAX]) * i
    out[1] = p[P_R] * i * i
    out[2] = p[P_KW] * omega * i
    out[3] = p[P_KM] * i * omega
    out[4] = (h_i / (r * r) + p[P_KV]) * omega * omega
    out[5] = dry_friction(omega, p) * omega
    out[6] = tau_load / r * omega
