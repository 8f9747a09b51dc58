"""``asvs`` and ``vss``: the variable-structure law (4)-(5) (docs/drive-equations.md §5).

Law (4): ``U_k = (k_e·|e| + k_s·|m_f| + k_g·|q̈* + a·q̇*|)·sgn(S)·sgn(i_r)`` with
the sliding surface ``S = ė + c·e``, designed on the 2nd-order drive
``q̈ = β·U − a·q̇ − γ·m_f``. On S = 0 the error decays as e^(−c·t): monotone,
no overshoot, and the larger c the faster. The sliding regime exists while the
e-term of Ṡ pushes back, ``|c·(c − a)| <= |β|·k_e``, so the fastest slope is

    c_max = (a + √(a² + 4·|β|·k_e))/2          (the stationary root of (5))

and (5) asks ``k_s >= R/(k_m·k_u)``, ``k_g >= R·|i_r|·(J+H*)/(k_m·k_u)``.

- ``asvs``: a, β, c = κ·c_max and k_g from the CURRENT load H_ii each period
  (the quasi-stationary solution of (5): ċ is left out), m_f from the measured
  dry friction, velocity torque and gravity. Gear losses: the load the motor feels
  through a gear of efficiency η is f·H*, and f times the load torque in m_f, with
  f = 1/η while the motor drives or holds the load and η while the load drives it back
  (:func:`manipcad.dynamics.gear.gear_factor`, the plant's formula), the power flow judged
  from the law's load model along the reference, P = H_ii·q̈* (+ c_i + Q_i), against the
  measured q̇ (the law reads no current to know q̈).
- ``vss``: the same law with a, c, k_g fixed for the WORST-CASE (largest) load,
  where c_max is smallest, so the sliding regime exists for every load; it
  measures no load signal (m_f = dry friction only).
"""

from __future__ import annotations

import math

import numba as nb

from manipcad.control.design import (
    DEFAULT_PERIOD,
    check_period,
    inertia_range,
    joint_drive,
    law_efficiency,
    packed,
)
from manipcad.control.kernels import ST_C, ST_S
from manipcad.control.method import GEAR_EFFICIENCY_OPTIONAL, Method
from manipcad.control.regulator import Regulator, u_limit
from manipcad.control.signals import S_CI, S_HII, S_Q, S_QD, S_QDDREF, S_QDREF, S_QI, S_QREF
from manipcad.drives.dc import clip, dry_friction
from manipcad.drives.laws import asvs_a, asvs_beta, asvs_c_stationary, asvs_gains, asvs_voltage
from manipcad.drives.params import P_RATIO, pack_drive
from manipcad.dynamics.gear import gear_factor
from manipcad.errors import ManipcadError
from manipcad.model.robot import Robot

# k_e (V/rad), k_s and k_g as multiples of their minima from (5), adapt (1: c, a, k_g from the
# current H_ii; 0: fixed), H* used when fixed (kg·m², motor side), margin on c (fraction of
# the largest sliding slope), output limit (V), use the measured load torque in m_f (1/0)
# the measured load torque in m_f (1/0), the gear efficiency of the asvs's load model (-; 0
# or 1: none; vss has no load model)
AS_KE, AS_KSM, AS_KGM, AS_ADAPT, AS_HFIX, AS_CM, AS_ULIM, AS_TORQUE, AS_ETA = range(16, 25)
FIELDS = {"k_e_V_per_rad": AS_KE, "k_s_margin": AS_KSM, "k_g_margin": AS_KGM,
          "adapt": AS_ADAPT, "H_star_fixed_kgm2": AS_HFIX, "c_margin": AS_CM,
          "u_limit_V": AS_ULIM, "load_torque_compensation": AS_TORQUE}
#: asvs also stores the gear efficiency of its load model
FIELDS_ASVS = {**FIELDS, "gear_efficiency": AS_ETA}


@nb.njit(cache=True)
def sliding_slope(Hs, k_e, p):
    """(a 1/s, β rad/(s²·V), c_max 1/s) of the 2nd-order drive at motor-side load H* (h* = 0).

    c_max is the stationary root of (5) with sgn(S·e) = −1
    (:func:`manipcad.drives.laws.asvs_c_stationary`): on S = 0 the e-term of Ṡ pushes
    back while |c·(c − a)| <= |β|·k_e.
    """
    a = asvs_a(Hs, 0.0, p)
    beta = asvs_beta(Hs, p)
    return a, beta, asvs_c_stationary(a, beta, k_e, -1.0)


@nb.njit(cache=True)
def asvs_update(p, s, sig, j, Ts):
    """Law (4) with the slope c and the gains of (5) at the current load (or fixed), V.

    U_k = (k_e·|e| + k_s·|m_f| + k_g·|q̈* + a·q̇*|)·sgn(S)·sgn(i_r), S = ė + c·e.
    """
    r = p[P_RATIO]
    f = 1.0
    if p[AS_ADAPT] != 0.0:
        H = sig[j, S_HII]
        eta = p[AS_ETA]
        if eta > 0.0 and eta != 1.0:
            load = H * sig[j, S_QDDREF]
            if p[AS_TORQUE] != 0.0:
                load += sig[j, S_CI] + sig[j, S_QI]
            f = gear_factor(eta, load, sig[j, S_QD])
        Hs = f * H / (r * r)
    else:
        Hs = p[AS_HFIX]
    k_e = p[AS_KE]
    a, beta, cmax = sliding_slope(Hs, k_e, p)
    c = p[AS_CM] * cmax
    ks_min, kg_min = asvs_gains(Hs, p)
    k_s = p[AS_KSM] * ks_min
    k_g = p[AS_KGM] * kg_min
    e = sig[j, S_QREF] - sig[j, S_Q]
    S = sig[j, S_QDREF] - sig[j, S_QD] + c * e
    d = sig[j, S_QDDREF] + a * sig[j, S_QDREF]
    mf = dry_friction(r * sig[j, S_QD], p)
    if p[AS_TORQUE] != 0.0:
        mf += f * (sig[j, S_CI] + sig[j, S_QI]) / r
    s[ST_C] = c
    s[ST_S] = S
    return clip(asvs_voltage(e, S, mf, d, k_e, k_s, k_g, p), p[AS_ULIM])


def slope(drive, H_ii: float, k_e: float) -> tuple[float, float, float]:
    """(a 1/s, β rad/(s²·V), c_max 1/s) of a drive at joint-side load H_ii (h* = 0)."""

    return tuple(float(v) for v in sliding_slope(H_ii / drive.ratio ** 2, k_e,
                                                 pack_drive(drive, order=2)))


_SPEC = {"k_e", "c_margin", "k_s_margin", "k_g_margin"}


def _synth(robot: Robot, joint, adapt: bool, spec, period, load_range, order,
           load_torque: bool) -> Regulator:
    period = check_period(period)
    j, d = joint_drive(robot, joint)
    spec = dict(spec or {})
    unknown = set(spec) - _SPEC
    if unknown:
        raise ManipcadError(f"unknown spec keys {sorted(unknown)}; known: {sorted(_SPEC)}")
    ulim = u_limit(d)
    Hmin, Hmax = inertia_range(robot, j, load_range)
    if "k_e" in spec:
        k_e = float(spec["k_e"])
    else:
        # the reaching phase is the loop q̈ + a·q̇ + |β|·k_e·q = 0; the surface is reached
        # (S changes sign before e does) only if that loop is underdamped: default
        # damping 0.5 at the lightest load, k_e = a²/|β| there (smaller at heavier loads)
        a0, b0, _ = slope(d, Hmin, 0.0)
        k_e = a0 * a0 / abs(b0)
    cm = float(spec.get("c_margin", 0.9))
    ksm = float(spec.get("k_s_margin", 1.5))
    kgm = float(spec.get("k_g_margin", 1.5))
    if not (math.isfinite(k_e) and k_e > 0):
        raise ManipcadError(f"k_e must be > 0 V/rad, got {k_e}")
    if not (0 < cm <= 1):
        raise ManipcadError(f"c_margin must be in (0, 1] (c > c_max loses the sliding regime), "
                            f"got {cm}")
    if not (ksm >= 1 and kgm >= 1) or not (math.isfinite(ksm) and math.isfinite(kgm)):
        raise ManipcadError(f"k_s_margin and k_g_margin must be >= 1 (condition (5)), "
                            f"got {ksm}, {kgm}")
    p = packed(d, order)
    p[AS_KE], p[AS_KSM], p[AS_KGM], p[AS_ADAPT] = k_e, ksm, kgm, float(adapt)
    p[AS_HFIX] = Hmax / d.ratio ** 2
    p[AS_CM], p[AS_ULIM], p[AS_TORQUE] = cm, ulim, float(adapt and load_torque)
    eta = law_efficiency(d) if adapt else 1.0
    if adapt:
        p[AS_ETA] = eta   # vss has no load model: its entry stays 0 (none), not in its file
    a_lo, b_lo, c_lo = slope(d, Hmax, k_e)
    a_hi, b_hi, c_hi = slope(d, Hmin, k_e)
    ks_min, kg_lo = asvs_gains(Hmin / d.ratio ** 2, p)
    _, kg_hi = asvs_gains(Hmax / d.ratio ** 2, p)
    ks, kg_min, kg_max = ksm * ks_min, kgm * kg_lo, kgm * kg_hi
    name = robot.joint_names[j]
    method = "asvs" if adapt else "vss"
    if adapt:
        law = (f"asvs ({name}): U_k = ({k_e:.6g}·|e| + {ks:.6g}·|m_f| + k_g·|q̈* + a·q̇*|)"
               f"·sgn(S)·sgn(i_r), S = ė + c·e, with the current load: a = (k_m k_w + R k_v)/"
               f"(R(J+H*)) in [{a_lo:.4g}, {a_hi:.4g}] 1/s, "
               f"c = {cm:g}·(a + √(a² + 4|β|·{k_e:.4g}))/2 in [{cm * c_lo:.4g}, {cm * c_hi:.4g}] "
               f"1/s, k_g = {kgm:g}·R|i_r|(J+H*)/(k_m k_u) in "
               f"[{kg_min:.4g}, {kg_max:.4g}] V·s²/rad; H_ii in [{Hmin:.4g}, {Hmax:.4g}] kg·m²; "
               f"H* and the load torque in m_f times f = 1/η motoring or holding, η braking "
               f"(power flow of H_ii·q̈*{' + c_i + Q_i' if load_torque else ''} against q̇), "
               f"η = {eta:g} (a, c, k_g ranges above at f = 1); "
               f"|U_k| <= {ulim:g} V, T = {period:g} s")
        needs = ["q", "q_dot", "q_ref", "q_dot_ref", "q_ddot_ref", "H_ii"]
        if load_torque:
            needs += ["c_i", "Q_i"]
    else:
        law = (f"vss ({name}): U_k = ({k_e:.6g}·|e| + {ks:.6g}·|m_f| + {kg_max:.6g}·|q̈* + "
               f"{a_lo:.6g}·q̇*|)·sgn(S)·sgn(i_r), S = ė + {cm * c_lo:.6g}·e (fixed for the largest "
               f"load H_ii = {Hmax:.4g} kg·m²; m_f = dry friction); |U_k| <= {ulim:g} V, "
               f"T = {period:g} s")
        needs = ["q", "q_dot", "q_ref", "q_dot_ref", "q_ddot_ref"]
    return Regulator(
        method=method, joints=(j,), period=period, params=p, needs=tuple(needs), law=law,
        design={"k_e": k_e, "k_s": ks, "k_g_range": (kg_min, kg_max),
                "c_range": (cm * c_lo, cm * c_hi) if adapt else (cm * c_lo, cm * c_lo),
                "a_range": (a_lo, a_hi), "load_range": (Hmin, Hmax), "c_margin": cm,
                "gear_efficiency": eta})


def synthesize_asvs(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                    load_range=None, order: int = 3,
                    load_torque: bool = True) -> Regulator:
    """The adaptive VSS: law (4) with c, a, k_g from the current load.

    Args:
        robot, joint: the joint.
        spec: ``{"k_e": V/rad (default a²/|β| at the lightest load: the reaching
            loop q̈ + a·q̇ + |β|·k_e·q = 0 has damping 0.5 there and less at heavier
            loads; an overdamped reaching loop never meets the surface), "c_margin": κ in (0, 1]
            (c = κ·c_max, default 0.9), "k_s_margin", "k_g_margin": >= 1 (multiples
            of the minima of (5), default 1.5)}``.
        period: control period, s.
        load_range: (H_min, H_max), kg·m².
        order: the drive model order of the packed parameters (the law is
            designed on the 2nd-order drive either way).
        load_torque: add the measured velocity torque and gravity to m_f.
    """
    return _synth(robot, joint, True, spec, period, load_range, order, load_torque)


def synthesize_vss(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                   load_range=None, order: int = 3) -> Regulator:
    """The fixed VSS baseline: law (4) with c, a, k_g for the worst-case (largest) load.

    Args: as :func:`synthesize_asvs` (no load signal is measured).
    """
    return _synth(robot, joint, False, spec, period, load_range, order, False)


ASVS = Method(
    name="asvs", synthesize=synthesize_asvs, update=asvs_update, section="3.2 (4)-(5)",
    summary="adaptive variable structure: sliding slope and gains of (5) at the current load",
    fields=FIELDS_ASVS, optional_fields=GEAR_EFFICIENCY_OPTIONAL)

VSS = Method(
    name="vss", synthesize=synthesize_vss, update=asvs_update, section="3.2 (baseline)",
    summary="law (4) with slope and gains fixed for the heaviest load (no adaptation)",
    fields=FIELDS)
