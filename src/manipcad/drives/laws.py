"""The paper's drive-level control laws, derived in docs/drive-equations.md.

Compiled scalar kernels (``numba.njit``) read the packed drive vector ``p``
(:mod:`manipcad.drives.params`); the python-control helpers take a
:class:`~manipcad.model.robot.Drive`. Motor-side load: ``H* = H_ii/i_r²``
(kg·m²), ``h* = h_i/i_r²`` (N·m·s/rad), their time derivatives ``Ḣ*``
(kg·m²/s), ``ḣ*`` (N·m·s/rad/s); ``m_f`` is the motor-side disturbance torque
of the shaft equation (dry friction ``M_f·sign(ω_m)`` plus the joint-side load
torque over ``i_r``), N·m.

- Law (3) (:func:`law3_voltage`): makes the varying-coefficient 3rd-order drive

      L(J+H*)·i_r·q⃛ + [R(J+H*) + L(Ḣ*+h*+k_v)]·i_r·q̈
          + [k_m·k_w + R(h*+k_v) + L·ḣ*]·i_r·q̇ + R·m_f + L·ṁ_f = k_m·k_u·U_k

  equal EXACTLY the nominal model ``L·J_n·i_r·q⃛ + R·J_n·i_r·q̈ + k_m·k_w·i_r·q̇ =
  k_m·k_u·U`` (the paper's, multiplied by k_m, with J_n = J by default).
- ACE (1) (:func:`ace1_tf`, :func:`ace1_output`): the moving zero
  ``W_k = (T_m·s+1)/(k_p·k_w·(T_1·s+1))`` under the quasi-stationary hypothesis.
- ASVS (4)-(5) (:func:`asvs_a`, :func:`asvs_voltage`, :func:`asvs_c_rate`,
  :func:`asvs_sdot`): sliding surface ``S = ė + c·e`` on the 2nd-order drive.
"""

from __future__ import annotations

import math

import numba
import numpy as np

from manipcad._lazy import ct
from manipcad.drives import params as P
from manipcad.drives.linear import drive_gain, mechanical_time_constant
from manipcad.errors import ModelError
from manipcad.model.robot import Drive

# ---------------------------------------------------------------- law (3)


@numba.njit(cache=True)
def law3_coefficients(H_star: float, h_star: float, H_star_dot: float, h_star_dot: float,
                      J_n: float, p: np.ndarray) -> tuple[float, float, float, float, float]:
    """Coefficients of the control law (3), derived (docs/drive-equations.md, §3).

    ``U_k = c_qdd·q̈ + c_qd·q̇ + c_m·m_f + c_mdot·ṁ_f + c_u·U`` with ρ = (J+H*)/J_n::

        c_qdd  = L·(Ḣ* + h* + k_v)·i_r / (k_m·k_u)
        c_qd   = [k_w·(1 - ρ)/k_u + (R·(h* + k_v) + L·ḣ*)/(k_m·k_u)]·i_r
        c_m    = R / (k_m·k_u)
        c_mdot = L / (k_m·k_u)
        c_u    = ρ

    Args:
        H_star: motor-side load inertia H*, kg·m².
        h_star: motor-side velocity coefficient h*, N·m·s/rad.
        H_star_dot: dH*/dt, kg·m²/s.
        h_star_dot: dh*/dt, N·m·s/rad/s.
        J_n: inertia of the nominal model, kg·m² (the paper's J_n; J for the
            printed nominal model).
        p: packed drive parameters (J, i_r, k_v, R, L, k_m, k_w, k_u).

    Returns:
        (c_qdd V·s²/rad, c_qd V·s/rad, c_m V/(N·m), c_mdot V·s/(N·m), c_u V/V).

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.drives.laws import law3_coefficients
        >>> p = pack_drive(Drive(J=1e-4, ratio=10, R=1, L=1e-3, k_m=.1, k_w=.1, k_u=1))
        >>> law3_coefficients(0.0, 0.0, 0.0, 0.0, 1e-4, p)  # unloaded, frictionless: U_k = U
        (0.0, 0.0, 10.0, 0.01, 1.0)
    """
    J = p[P.P_J]
    r = p[P.P_RATIO]
    kv = p[P.P_KV]
    R = p[P.P_R]
    L = p[P.P_L]
    kmku = p[P.P_KM] * p[P.P_KU]
    rho = (J + H_star) / J_n
    c_qdd = L * (H_star_dot + h_star + kv) * r / kmku
    c_qd = (p[P.P_KW] * (1.0 - rho) / p[P.P_KU] + (R * (h_star + kv) + L * h_star_dot) / kmku) * r
    return c_qdd, c_qd, R / kmku, L / kmku, rho


@numba.njit(cache=True)
def law3_voltage(U: float, qd: float, qdd: float, H_star: float, h_star: float,
                 H_star_dot: float, h_star_dot: float, m_f: float, m_f_dot: float,
                 J_n: float, p: np.ndarray) -> float:
    """Control law (3): the amplifier input U_k that makes the drive nominal.

    With this U_k the drive (any H*(t), h*(t), m_f(t)) obeys exactly
    ``L·J_n·i_r·q⃛ + R·J_n·i_r·q̈ + k_m·k_w·i_r·q̇ = k_m·k_u·U``.

    Args:
        U: input of the corrector (the nominal drive's input), V.
        qd: joint velocity q̇, rad/s.
        qdd: joint acceleration q̈, rad/s².
        H_star: H*, kg·m².
        h_star: h*, N·m·s/rad.
        H_star_dot: dH*/dt, kg·m²/s.
        h_star_dot: dh*/dt, N·m·s/rad/s.
        m_f: motor-side disturbance torque (dry friction + load/i_r), N·m.
        m_f_dot: its time derivative, N·m/s.
        J_n: nominal inertia, kg·m².
        p: packed drive parameters.

    Returns:
        U_k, V (amplifier input; keep |k_u·U_k| within u_max for exactness).

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.drives.laws import law3_voltage
        >>> p = pack_drive(Drive(J=1e-4, ratio=10, R=1, L=1e-3, k_m=.1, k_w=.1, k_u=1))
        >>> round(law3_voltage(2.0, 0, 0, 1e-4, 0, 0, 0, 0, 0, 1e-4, p), 12)   # ρ = 2
        4.0
    """
    c_qdd, c_qd, c_m, c_mdot, c_u = law3_coefficients(H_star, h_star, H_star_dot,
                                                      h_star_dot, J_n, p)
    return c_qdd * qdd + c_qd * qd + c_m * m_f + c_mdot * m_f_dot + c_u * U


@numba.njit(cache=True)
def law3_voltage_paper(U: float, qd: float, qdd: float, H_star: float, h_star: float,
                       h_star_dot: float, m_f: float, J_n: float, p: np.ndarray) -> float:
    """Law (3) as printed in the paper (dots restored), for comparison only.

    ``U_k = L(2h*+k_v)/(k_m k_u)·i_r·q̈ + [k_w/k_u·(1-ρ) + (R(h*+k_v)+L·ḣ*)/(k_m k_u)]·i_r·q̇
    + R/(k_m k_u)·M_f + ρ·U``, i.e. :func:`law3_voltage` with ``Ḣ*`` taken as
    ``h*`` and ``ṁ_f = 0``, which is how it is computed: the derived law when
    ``h* = Ḣ*`` (true for the paper's Fig. 2 turning joint, whose velocity
    term is the rate of change of its inertia) and ``ṁ_f = 0``.

    Args: as :func:`law3_voltage` (no Ḣ*, no ṁ_f).

    Returns:
        U_k, V.
    """
    return law3_voltage(U, qd, qdd, H_star, h_star, h_star, h_star_dot, m_f, 0.0, J_n, p)


def nominal_tf(drive: Drive, J_n: float | None = None, *, order: int = 3) -> ct.TransferFunction:
    """The nominal constant-coefficient drive law (3) produces, from U to q.

    ``(L·J_n/k_m)·i_r·q⃛ + (R·J_n/k_m)·i_r·q̈ + k_w·i_r·q̇ = k_u·U``, i.e.
    ``q/U = k_u·k_m / (i_r·s·(L·J_n·s² + R·J_n·s + k_m·k_w))`` (order 3) or
    ``k_u·k_m / (i_r·s·(R·J_n·s + k_m·k_w))`` (order 2, L neglected).

    Args:
        drive: the drive.
        J_n: nominal inertia, kg·m² (default: the rotor inertia J).
        order: 3 or 2.

    Returns:
        TransferFunction, rad/V.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.laws import nominal_tf
        >>> d = Drive(J=1e-4, ratio=10, R=1, L=1e-3, k_m=.1, k_w=.1, k_u=1)
        >>> nominal_tf(d, order=2).poles().size
        2
    """
    P.check_electrics(drive, need_L=order == 3)
    Jn = _nominal_inertia(drive, J_n)
    r, R, km, kw, ku = drive.ratio, drive.R, drive.k_m, drive.k_w, drive.k_u
    if order == 3:
        den = [drive.L * Jn * r, R * Jn * r, km * kw * r, 0.0]
    elif order == 2:
        den = [R * Jn * r, km * kw * r, 0.0]
    else:
        raise ModelError(f"order must be 2 or 3, got {order}")
    return ct.tf([ku * km], den, inputs="U", outputs="q")


def nominal_params(p: np.ndarray, J_n: float) -> np.ndarray:
    """Packed parameters of the nominal drive: inertia J_n, no friction, no load.

    The nominal model of law (3) is the same DC drive with J → J_n,
    k_v = M_f = 0 and H* = h* = 0; feed these parameters with ``H_ii = h_i =
    τ_l = 0`` to :func:`manipcad.drives.dc.rigid_rhs` to integrate it with the
    drive's own states ``(q, q̇, i)``.

    Args:
        p: packed drive parameters.
        J_n: nominal inertia, kg·m².

    Returns:
        A new packed vector.
    """
    pn = np.array(p, dtype=float, copy=True)
    pn[P.P_J] = J_n
    pn[P.P_KV] = 0.0
    pn[P.P_MFP] = 0.0
    pn[P.P_MFN] = 0.0
    return pn


def _nominal_inertia(drive: Drive, J_n: float | None) -> float:
    Jn = drive.J if J_n is None else float(J_n)
    if not (math.isfinite(Jn) and Jn > 0):
        raise ModelError(f"nominal inertia J_n must be > 0 kg·m², got {Jn} "
                         "(a drive with J = 0 needs an explicit J_n)")
    return Jn


# ---------------------------------------------------------------- ACE (1)


@numba.njit(cache=True)
def ace1_parameters(H_star: float, h_star: float, p: np.ndarray) -> tuple[float, float]:
    """The load-dependent pole of the drive the ACE (1) cancels: (T_m, k_p).

    ``T_m = (H*+J)·R / [(h*+k_v)·R + k_m·k_w]``, ``k_p = k_m / [(h*+k_v)·R + k_m·k_w]``.

    Args:
        H_star: H*, kg·m².
        h_star: h*, N·m·s/rad.
        p: packed drive parameters.

    Returns:
        (T_m s, k_p rad/(V·s)).
    """
    den = (h_star + p[P.P_KV]) * p[P.P_R] + p[P.P_KM] * p[P.P_KW]
    return (H_star + p[P.P_J]) * p[P.P_R] / den, p[P.P_KM] / den


@numba.njit(cache=True)
def ace1_filter_rate(x: float, U: float, T_1: float) -> float:
    """State rate of the ACE (1) realization: T_1·ẋ = U - x.

    The filter state x (V) does not depend on the load; only the output
    gains of :func:`ace1_output` do (moving zero).

    Args:
        x: filter state, V.
        U: ACE input, V.
        T_1: the ACE's (nominal) time constant, s.

    Returns:
        dx/dt, V/s.
    """
    return (U - x) / T_1


@numba.njit(cache=True)
def ace1_filter_step(x: float, U: float, T_1: float, Ts: float) -> float:
    """The filter state of :func:`ace1_filter_rate` one period Ts later, U held (exact), V.

    x(t+Ts) = U + (x − U)·exp(−Ts/T_1).
    """
    return U + (x - U) * math.exp(-Ts / T_1)


@numba.njit(cache=True)
def ace1_output(U: float, x: float, T_m: float, k_p: float, T_1: float,
                p: np.ndarray) -> float:
    """Output of the ACE (1): U_k = (T_m·ẋ + x) / (k_p·k_w), ẋ = (U - x)/T_1.

    Realizes ``W_k(s) = (T_m·s + 1) / (k_p·k_w·(T_1·s + 1))`` at the current
    (T_m, k_p). In this filter-first form the drive with L neglected follows
    ``(k_u/k_w)/(T_1·s + 1)`` exactly even when T_m, k_p vary (see
    docs/drive-equations.md, §4); the observable form
    (:func:`ace1_obs_rate`), which puts T_m inside the state equation, does not.

    Args:
        U: ACE input, V.
        x: filter state, V.
        T_m: current mechanical time constant, s.
        k_p: current speed gain, rad/(V·s).
        T_1: the ACE's time constant, s.
        p: packed drive parameters (k_w).

    Returns:
        U_k, V (amplifier input).

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.drives.laws import ace1_output
        >>> p = pack_drive(Drive(J=1e-4, R=1, L=1e-3, k_m=.1, k_w=.1))
        >>> round(ace1_output(1.0, 1.0, 0.02, 10.0, 0.01, p), 12)   # steady: 1/(k_p k_w)
        1.0
    """
    return (T_m * (U - x) / T_1 + x) / (k_p * p[P.P_KW])


@numba.njit(cache=True)
def ace1_obs_rate(v: float, U: float, T_m: float, T_1: float) -> float:
    """State rate of the ACE (1) in observable form: T_1·v̇ = -v + (1 - T_m/T_1)·U.

    The frozen-parameter (quasi-stationary) realization of the same W_k(s):
    the load enters the state equation, so it is exact only while T_m is
    constant and errs in proportion to the rate of change of the load (see
    docs/drive-equations.md, §4). Kept to reproduce the paper's ACE (1).

    Args:
        v: filter state, V.
        U: ACE input, V.
        T_m: current mechanical time constant, s.
        T_1: the ACE's time constant, s.

    Returns:
        dv/dt, V/s.
    """
    return (-v + (1.0 - T_m / T_1) * U) / T_1


@numba.njit(cache=True)
def ace1_obs_step(v: float, U: float, T_m: float, T_1: float, Ts: float) -> float:
    """The state of :func:`ace1_obs_rate` one period Ts later, U and T_m held (exact), V.

    v(t+Ts) = v·a + (1 − a)·(1 − T_m/T_1)·U with a = exp(−Ts/T_1).
    """
    a = math.exp(-Ts / T_1)
    return v * a + (1.0 - a) * (1.0 - T_m / T_1) * U


@numba.njit(cache=True)
def ace1_obs_output(U: float, v: float, T_m: float, k_p: float, T_1: float,
                    p: np.ndarray) -> float:
    """Output of the observable-form ACE (1): U_k = (T_m/T_1·U + v)/(k_p·k_w), V.

    Args:
        U: ACE input, V.
        v: filter state of :func:`ace1_obs_rate`, V.
        T_m: current mechanical time constant, s.
        k_p: current speed gain, rad/(V·s).
        T_1: the ACE's time constant, s.
        p: packed drive parameters (k_w).

    Returns:
        U_k, V.
    """
    return (T_m / T_1 * U + v) / (k_p * p[P.P_KW])


def default_T1(drive: Drive, J_n: float | None = None) -> float:
    """The ACE's nominal time constant: T_1 = R·J_n/(k_m·k_w), s.

    The no-load, frictionless mechanical time constant (with J_n = J), which
    makes ACE (1) and law (3) target the same nominal drive when L → 0.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.laws import default_T1
        >>> round(default_T1(Drive(J=1e-4, R=1, L=1e-3, k_m=.1, k_w=.1)), 12)
        0.01
    """
    P.check_electrics(drive, need_L=False)
    return drive.R * _nominal_inertia(drive, J_n) / (drive.k_m * drive.k_w)


def ace1_tf(drive: Drive, H_ii: float = 0.0, h_i: float = 0.0, *, T_1: float | None = None,
            J_n: float | None = None) -> ct.TransferFunction:
    """Transfer function of the adaptive corrective element (1) at a load.

    ``W_k(s) = (T_m·s + 1) / (k_p·k_w·(T_1·s + 1))`` so that, with the drive's
    speed response ``k_u·k_p/((T_m·s+1)(T_e·s+1))``,
    ``W_k·W_p = (k_u/k_w) / ((T_1·s + 1)(T_e·s + 1))``: k = k_u/k_w,
    T_1 and T_2 = T_e = L/R do not depend on the load.

    Args:
        drive: the drive.
        H_ii: joint-side load inertia, kg·m².
        h_i: joint-side velocity coefficient, N·m·s/rad.
        T_1: the ACE's time constant, s (default :func:`default_T1`).
        J_n: nominal inertia for the default T_1, kg·m².

    Returns:
        TransferFunction W_k(s), V/V.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.laws import ace1_tf
        >>> d = Drive(J=1e-4, ratio=10, R=1, L=1e-3, k_m=.1, k_w=.1)
        >>> round(float(ace1_tf(d, H_ii=0.01).dcgain()), 12)   # 1/(k_p k_w) = 1 without friction
        1.0
    """

    T_m = mechanical_time_constant(drive, H_ii, h_i)
    k_p = drive_gain(drive, H_ii, h_i)
    T1 = default_T1(drive, J_n) if T_1 is None else float(T_1)
    if not (math.isfinite(T1) and T1 > 0):
        raise ModelError(f"ACE time constant T_1 must be > 0 s, got {T1}")
    g = 1.0 / (k_p * drive.k_w)
    return ct.tf([g * T_m, g], [T1, 1.0], inputs="U", outputs="U_k")


def ace1_target_tf(drive: Drive, *, T_1: float | None = None, J_n: float | None = None,
                   order: int = 3) -> ct.TransferFunction:
    """The stabilized drive the ACE (1) aims at, from U to q.

    ``q/U = (k_u/k_w) / (i_r·s·(T_1·s + 1)(T_e·s + 1))`` (order 3) or without
    the T_e factor (order 2).

    Args:
        drive: the drive.
        T_1: the ACE's time constant, s (default :func:`default_T1`).
        J_n: nominal inertia for the default T_1, kg·m².
        order: 3 or 2.

    Returns:
        TransferFunction, rad/V.
    """
    T1 = default_T1(drive, J_n) if T_1 is None else float(T_1)
    k = drive.k_u / drive.k_w
    s = ct.tf("s")
    g = k / (drive.ratio * s * (T1 * s + 1))
    if order == 3:
        P.check_electrics(drive, need_L=True)
        g = g / (drive.L / drive.R * s + 1)
    elif order != 2:
        raise ModelError(f"order must be 2 or 3, got {order}")
    return ct.tf(g.num, g.den, inputs="U", outputs="q")


# ---------------------------------------------------------------- ASVS (4)-(5)


@numba.njit(cache=True)
def asvs_a(H_star: float, h_star: float, p: np.ndarray) -> float:
    """a = [k_m·k_w + R·(k_v + h*)] / [R·(J + H*)] = 1/T_m of the 2nd-order drive, 1/s.

    Args:
        H_star: H*, kg·m².
        h_star: h*, N·m·s/rad.
        p: packed drive parameters.

    Returns:
        a, 1/s.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.params import pack_drive
        >>> from manipcad.drives.laws import asvs_a
        >>> round(asvs_a(1e-4, 0.0, pack_drive(Drive(J=1e-4, R=1, L=0, k_m=.1, k_w=.1))), 9)
        50.0
    """
    return ((p[P.P_KM] * p[P.P_KW] + p[P.P_R] * (p[P.P_KV] + h_star))
            / (p[P.P_R] * (p[P.P_J] + H_star)))


@numba.njit(cache=True)
def asvs_beta(H_star: float, p: np.ndarray) -> float:
    """β = k_m·k_u / [R·i_r·(J + H*)]: joint acceleration per volt of U, rad/(s²·V).

    The 2nd-order drive is ``q̈ = β·U - a·q̇ - γ·m_f`` (see :func:`asvs_gamma`).
    """
    return p[P.P_KM] * p[P.P_KU] / (p[P.P_R] * p[P.P_RATIO] * (p[P.P_J] + H_star))


@numba.njit(cache=True)
def asvs_gamma(H_star: float, p: np.ndarray) -> float:
    """γ = 1 / [i_r·(J + H*)]: joint acceleration per motor-side N·m, rad/(s²·N·m)."""
    return 1.0 / (p[P.P_RATIO] * (p[P.P_J] + H_star))


@numba.njit(cache=True)
def asvs_gains(H_star: float, p: np.ndarray) -> tuple[float, float]:
    """Smallest gains of law (4) that keep the sliding regime, from (5).

    ``k_s >= R/(k_m·k_u)`` (the paper prints this bound as "k_g >=
    R(k_u k_m)^-1") and ``k_g >= 1/|β| = R·|i_r|·(J+H*)/(k_m·k_u)`` (the
    paper's "k_g = R i_r (J+H*)(k_m k_u)^-1").

    Args:
        H_star: H*, kg·m².
        p: packed drive parameters.

    Returns:
        (k_s_min V/(N·m), k_g_min V·s²/rad).
    """
    kmku = p[P.P_KM] * p[P.P_KU]
    return p[P.P_R] / kmku, p[P.P_R] * abs(p[P.P_RATIO]) * (p[P.P_J] + H_star) / kmku


@numba.njit(cache=True)
def asvs_voltage(e: float, S: float, m_f: float, d: float, k_e: float, k_s: float,
                 k_g: float, p: np.ndarray) -> float:
    """Law (4): U_k = (k_e·|e| + k_s·|m_f| + k_g·|q̈* + a·q̇*|)·sign(S)·sign(i_r).

    Args:
        e: position error q* - q, rad.
        S: sliding variable ė + c·e, rad/s.
        m_f: motor-side disturbance torque (dry friction + load/i_r), N·m.
        d: q̈* + a·q̇* (desired acceleration and velocity), rad/s².
        k_e: gain on |e| (1 in the paper), V/rad.
        k_s: gain on |m_f|, V/(N·m).
        k_g: gain on |d|, V·s²/rad.
        p: packed drive parameters (sign of i_r).

    Returns:
        U_k, V.
    """
    g = k_e * abs(e) + k_s * abs(m_f) + k_g * abs(d)
    s = 1.0 if S > 0.0 else (-1.0 if S < 0.0 else 0.0)
    return g * s if p[P.P_RATIO] > 0.0 else -g * s


@numba.njit(cache=True)
def asvs_c_rate(c: float, a: float, beta: float, S: float, e: float, k_e: float) -> float:
    """The adapted slope c of (5): ċ = c² - a·c + |β|·k_e·sign(S·e), 1/s².

    This makes the e-term of Ṡ vanish (docs/drive-equations.md, §5).

    Args:
        c: current slope of S = ė + c·e, 1/s.
        a: :func:`asvs_a`, 1/s.
        beta: :func:`asvs_beta`, rad/(s²·V).
        S: sliding variable, rad/s.
        e: position error, rad.
        k_e: gain on |e| in law (4), V/rad.

    Returns:
        dc/dt, 1/s².
    """
    se = S * e
    sg = 1.0 if se > 0.0 else (-1.0 if se < 0.0 else 0.0)
    return c * c - a * c + abs(beta) * k_e * sg


@numba.njit(cache=True)
def asvs_c_stationary(a: float, beta: float, k_e: float, sigma: float) -> float:
    """Constant slope c solving c² - a·c + |β|·k_e·σ = 0 (ċ = 0 in (5)), 1/s.

    Args:
        a, beta, k_e: as in :func:`asvs_c_rate`.
        sigma: sign(S·e), +1 or -1.

    Returns:
        For σ = -1 the positive root (a + √(a² + 4|β|k_e))/2 (> a); for σ = +1
        the larger root (a + √(a² - 4|β|k_e))/2 (< a), nan when a² < 4|β|k_e.
    """
    if sigma < 0.0:
        return 0.5 * (a + math.sqrt(a * a + 4.0 * abs(beta) * k_e))
    disc = a * a - 4.0 * abs(beta) * k_e
    if disc < 0.0:
        return math.nan
    return 0.5 * (a + math.sqrt(disc))


@numba.njit(cache=True)
def asvs_sdot(S: float, e: float, c: float, c_dot: float, a: float, beta: float,
              gamma: float, U: float, d: float, m_f: float) -> float:
    """Ṡ of the 2nd-order drive for any input U (the sliding-condition identity).

    ``Ṡ = (c - a)·S + (ċ - c² + a·c)·e + d + γ·m_f - β·U`` with
    ``d = q̈* + a·q̇*``; sliding needs S·Ṡ < 0.

    Args:
        S: sliding variable, rad/s.
        e: position error, rad.
        c: slope, 1/s.
        c_dot: its rate, 1/s².
        a: 1/s.
        beta: rad/(s²·V).
        gamma: rad/(s²·N·m).
        U: amplifier input, V.
        d: q̈* + a·q̇*, rad/s².
        m_f: motor-side disturbance torque, N·m.

    Returns:
        dS/dt, rad/s².
    """
    return (c - a) * S + (c_dot - c * c + a * c) * e + d + gamma * m_f - beta * U


@numba.njit(cache=True)
def asvs_margin(d: float, m_f: float, k_s: float, k_g: float, beta: float,
                gamma: float) -> float:
    """Reaching margin η of law (4): S·Ṡ <= (c - a)·S² - η·|S| when (5) holds.

    ``η = (|β|·k_g - 1)·|d| + (|β|·k_s - |γ|)·|m_f|`` (>= 0 iff the gains meet
    (5)); with c > a the sliding regime is kept for |S| < η/(c - a).

    Returns:
        η, rad/s².
    """
    ab = abs(beta)
    return (ab * k_g - 1.0) * abs(d) + (ab * k_s - abs(gamma)) * abs(m_f)
