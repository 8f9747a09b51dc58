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
  dry friction, velocity torque and gravity.
- ``vss``: the same law with a, c, k_g fixed for the WORST-CASE (largest) load,
  where c_max is smallest, so the sliding regime exists for every load; it
  measures no load signal (m_f = dry friction only).
"""

from __future__ import annotations

import math

from manipcad.errors import ManipcadError
from manipcad.model.robot import Robot
from manipcad.synthesis._common import (
    DEFAULT_PERIOD,
    SynthesizedRegulator,
    check_period,
    joint_drive,
    load_range,
    packed,
)
from manipcad.synthesis.kernels import (
    AS_ADAPT,
    AS_CM,
    AS_HFIX,
    AS_KE,
    AS_KGM,
    AS_KSM,
    AS_TORQUE,
    AS_ULIM,
    KIND_ASVS,
)


def slope(drive, H_ii: float, k_e: float) -> tuple[float, float, float]:
    """(a 1/s, β rad/(s²·V), c_max 1/s) of the drive at joint-side load H_ii (h* = 0)."""
    Hs = H_ii / drive.ratio ** 2
    Jh = drive.J + Hs
    a = (drive.k_m * drive.k_w + drive.R * drive.k_v) / (drive.R * Jh)
    beta = drive.k_m * drive.k_u / (drive.R * drive.ratio * Jh)
    c = 0.5 * (a + math.sqrt(a * a + 4.0 * abs(beta) * k_e))
    return a, beta, c


_SPEC = {"k_e", "c_margin", "k_s_margin", "k_g_margin"}


def _synth(robot: Robot, joint, adapt: bool, spec, period, load_range_, order,
           load_torque: bool) -> SynthesizedRegulator:
    period = check_period(period)
    j, d = joint_drive(robot, joint)
    spec = dict(spec or {})
    unknown = set(spec) - _SPEC
    if unknown:
        raise ManipcadError(f"unknown spec keys {sorted(unknown)}; known: {sorted(_SPEC)}")
    ulim = d.u_max / d.k_u if math.isfinite(d.u_max) else math.inf
    Hmin, Hmax = load_range(robot, j, load_range_)
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
    a_lo, b_lo, c_lo = slope(d, Hmax, k_e)
    a_hi, b_hi, c_hi = slope(d, Hmin, k_e)
    kmku = d.k_m * d.k_u
    ks = ksm * d.R / kmku
    kg_min = kgm * d.R * abs(d.ratio) * (d.J + Hmin / d.ratio ** 2) / kmku
    kg_max = kgm * d.R * abs(d.ratio) * (d.J + Hmax / d.ratio ** 2) / kmku
    name = robot.joint_names[j]
    method = "asvs" if adapt else "vss"
    if adapt:
        law = (f"asvs ({name}): U_k = ({k_e:.6g}·|e| + {ks:.6g}·|m_f| + k_g·|q̈* + a·q̇*|)"
               f"·sgn(S)·sgn(i_r), S = ė + c·e, with the current load: a = (k_m k_w + R k_v)/"
               f"(R(J+H*)) in [{a_lo:.4g}, {a_hi:.4g}] 1/s, "
               f"c = {cm:g}·(a + √(a² + 4|β|·{k_e:.4g}))/2 in [{cm * c_lo:.4g}, {cm * c_hi:.4g}] "
               f"1/s, k_g = {kgm:g}·R|i_r|(J+H*)/(k_m k_u) in "
               f"[{kg_min:.4g}, {kg_max:.4g}] V·s²/rad; H_ii in [{Hmin:.4g}, {Hmax:.4g}] kg·m²; "
               f"|U_k| <= {ulim:g} V, T = {period:g} s")
        signals = ["q", "q_dot", "q_ref", "q_dot_ref", "q_ddot_ref", "H_ii"]
        if load_torque:
            signals += ["h_i", "Q_i"]
        gains = 11  # J, i_r, R, k_m, k_w, k_u, k_v, M_f±, k_e, margins folded: k_s
        ops = 45 + (4 if load_torque else 0)
    else:
        law = (f"vss ({name}): U_k = ({k_e:.6g}·|e| + {ks:.6g}·|m_f| + {kg_max:.6g}·|q̈* + "
               f"{a_lo:.6g}·q̇*|)·sgn(S)·sgn(i_r), S = ė + {cm * c_lo:.6g}·e (fixed for the largest "
               f"load H_ii = {Hmax:.4g} kg·m²; m_f = dry friction); |U_k| <= {ulim:g} V, "
               f"T = {period:g} s")
        signals = ["q", "q_dot", "q_ref", "q_dot_ref", "q_ddot_ref"]
        gains = 7  # k_e, k_s, k_g, a, c, M_f±
        ops = 18
    return SynthesizedRegulator(
        joint=j, period=period, kind=KIND_ASVS, params=p, name=method, needs=tuple(signals),
        method=method, law=law,
        complexity={"gains_stored": gains, "ops_per_period": ops, "signals": signals,
                    "period": period},
        design={"k_e": k_e, "k_s": ks, "k_g_range": (kg_min, kg_max),
                "c_range": (cm * c_lo, cm * c_hi) if adapt else (cm * c_lo, cm * c_lo),
                "a_range": (a_lo, a_hi), "load_range": (Hmin, Hmax), "c_margin": cm},
        linear={})


def synthesize_asvs(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                    load_range_=None, order: int = 3,
                    load_torque: bool = True) -> SynthesizedRegulator:
    """The adaptive VSS: law (4) with c, a, k_g from the current load.

    Args:
        robot, joint: the joint.
        spec: ``{"k_e": V/rad (default a²/|β| at the lightest load: the reaching
            loop q̈ + a·q̇ + |β|·k_e·q = 0 has damping 0.5 there and less at heavier
            loads; an overdamped reaching loop never meets the surface), "c_margin": κ in (0, 1]
            (c = κ·c_max, default 0.9), "k_s_margin", "k_g_margin": >= 1 (multiples
            of the minima of (5), default 1.5)}``.
        period: control period, s.
        load_range_: (H_min, H_max), kg·m².
        order: the drive model order of the packed parameters (the law is
            designed on the 2nd-order drive either way).
        load_torque: add the measured velocity torque and gravity to m_f.
    """
    return _synth(robot, joint, True, spec, period, load_range_, order, load_torque)


def synthesize_vss(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                   load_range_=None, order: int = 3) -> SynthesizedRegulator:
    """The fixed VSS baseline: law (4) with c, a, k_g for the worst-case (largest) load.

    Args: as :func:`synthesize_asvs` (no load signal is measured).
    """
    return _synth(robot, joint, False, spec, period, load_range_, order, False)
