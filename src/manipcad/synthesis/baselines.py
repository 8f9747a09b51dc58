"""Baselines: ``none`` (a plain proportional position loop), ``pid``, ``computed_torque``.

Both are designed on the drive's linear model at one nominal load (default:
the largest H_ii of the range, the slowest drive) and keep their gains for
every load: no adaptation. Second-order model (L neglected):
``q/U = K/(s·(T_m·s + 1))``, ``K = k_u·k_p/i_r`` (rad/(V·s)).
"""

from __future__ import annotations

import math

import control as ct

from manipcad.drives.linear import drive_gain, linearize, mechanical_time_constant
from manipcad.errors import ManipcadError
from manipcad.model.robot import Robot
from manipcad.sim.regulators import pid
from manipcad.synthesis._common import (
    DEFAULT_PERIOD,
    SynthesizedRegulator,
    check_period,
    design_pd,
    joint_drive,
    load_range,
    packed,
    parse_spec,
)
from manipcad.synthesis.kernels import (
    CT_FRIC,
    CT_KD,
    CT_KP,
    CT_ULIM,
    KIND_CT,
    KIND_SCE,
    R_KD,
    R_KFA,
    R_KFV,
    R_KP,
    R_ULIM,
)


def _nominal(robot, joint, load_range_, H_nominal):
    j, d = joint_drive(robot, joint)
    Hmin, Hmax = load_range(robot, j, load_range_)
    H = Hmax if H_nominal is None else float(H_nominal)
    if not (math.isfinite(H) and H >= 0):
        raise ManipcadError(f"H_nominal must be >= 0 kg·m², got {H}")
    K = d.k_u * drive_gain(d, H, 0.0) / d.ratio
    T = mechanical_time_constant(d, H, 0.0)
    return j, d, (Hmin, Hmax), H, K, T


def synthesize_none(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                    load_range_=None, H_nominal: float | None = None,
                    kp: float | None = None, sce: bool = False,
                    J_n: float | None = None, feedforward: bool = True) -> SynthesizedRegulator:
    """U = k_p·e: the drive with a plain position loop, no adaptation.

    The default gain gives the nominal-load loop T_m·s² + s + K·k_p the
    damping ζ of ``spec`` (default 1.0, critical): K·k_p = 1/(4ζ²·T_m). The
    bandwidth is then set by the drive (ω_n = 1/(2ζ·T_m)), so ``spec`` may
    hold only ``damping``.

    Args:
        robot, joint: the joint.
        spec: ``{"damping": ζ}``.
        period: control period, s.
        load_range_: (H_min, H_max), kg·m².
        H_nominal: the load the gain is designed at, kg·m² (default H_max).
        kp: give the gain directly, V/rad.
        sce: instead, the PD stationary corrective element of ``ace_de`` (same
            ``spec``: bandwidth and damping on the nominal model) applied to the
            drive directly: the paper's "no adaptation" curve, the same SCE
            without the corrector.
        J_n: with ``sce``, the nominal inertia the SCE is designed for, kg·m² motor side.
        feedforward: with ``sce``, include the SCE's nominal feed-forward (as ``ace_de``).
    """
    period = check_period(period)
    j, d, rng, H, K, T = _nominal(robot, joint, load_range_, H_nominal)
    if sce:
        from manipcad.synthesis.ace_de import synthesize_ace_de

        ref = synthesize_ace_de(robot, joint, spec=spec, period=period, load_range_=load_range_,
                                J_n=J_n, feedforward=feedforward)
        dz = ref.design
        p = packed(d, ref.design["order"])
        p[R_KP], p[R_KD], p[R_KFV], p[R_KFA] = dz["kp"], dz["kd"], dz["kfv"], dz["kfa"]
        ulim = d.u_max / d.k_u if math.isfinite(d.u_max) else math.inf
        p[R_ULIM] = ulim
        C = ct.tf([dz["kd"], dz["kp"]], [1.0], inputs="e", outputs="U")
        plant = linearize(d, H, 0.0, order=dz["order"]).tf
        name = robot.joint_names[j]
        law = (f"none ({name}, SCE only): U = {dz['kp']:.6g}·e + {dz['kd']:.6g}·ė + "
               f"{dz['kfv']:.6g}·q̇* + {dz['kfa']:.6g}·q̈* (|U| <= {ulim:g} V), the SCE of "
               f"ace_de (ω_n = {dz['bandwidth']:g} rad/s, ζ = {dz['damping']:g} on the nominal "
               f"model, J_n = {dz['J_n']:.4g} kg·m²) without the corrector; T = {period:g} s")
        needs = ("q", "q_dot", "q_ref", "q_dot_ref") + (("q_ddot_ref",) if feedforward else ())
        return SynthesizedRegulator(
            joint=j, period=period, kind=KIND_SCE, params=p, name="none",
            needs=needs, method="none", law=law,
            complexity={"gains_stored": 4 if feedforward else 2,
                        "ops_per_period": 9 if feedforward else 5,
                        "signals": list(needs), "period": period},
            design={"kp": dz["kp"], "kd": dz["kd"], "kfv": dz["kfv"], "kfa": dz["kfa"],
                    "load_range": rng, "sce": True},
            linear={"plant": plant, "controller": C, "closed_loop": ct.feedback(C * plant, 1)})
    if spec and "bandwidth" in spec:
        raise ManipcadError("none: a plain P loop cannot be given a bandwidth; "
                            "its bandwidth is 1/(2ζ·T_m)")
    _, zeta = parse_spec(spec, bandwidth=1.0, damping=1.0)
    if kp is None:
        kp = 1.0 / (4.0 * zeta * zeta * T * K)
    if not math.isfinite(kp) or kp == 0:
        raise ManipcadError(f"none: k_p must be finite and nonzero, got {kp}")
    ulim = d.u_max / d.k_u if math.isfinite(d.u_max) else math.inf
    base = pid(j, kp=kp, period=period, u_limit=ulim)
    name = robot.joint_names[j]
    law = (f"none ({name}): U = {kp:.6g}·e (|U| <= {ulim:g} V), designed at H_ii = {H:.4g} kg·m² "
           f"(T_m = {T:.4g} s, K = {K:.4g} rad/(V·s), ζ = {zeta:g}); T = {period:g} s")
    plant = linearize(d, H, 0.0, order=2).tf
    return SynthesizedRegulator(
        joint=j, period=period, kind=base.kind, params=base.params, name="none",
        needs=("q", "q_ref"), method="none", law=law,
        complexity={"gains_stored": 1, "ops_per_period": 2, "signals": ["q", "q_ref"],
                    "period": period},
        design={"kp": kp, "H_nominal": H, "load_range": rng, "T_m": T, "K": K, "damping": zeta},
        linear={"plant": plant, "controller": ct.tf([kp], [1.0], inputs="e", outputs="U"),
                "closed_loop": ct.feedback(kp * plant, 1)})


def synthesize_pid(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                   load_range_=None, H_nominal: float | None = None, kp: float | None = None,
                   ki: float | None = None, kd: float | None = None,
                   order: int = 3) -> SynthesizedRegulator:
    """PID (:func:`manipcad.sim.pid`) designed on the drive at a nominal load.

    Default gains: the PD of ``spec`` (ω_n, ζ; default 30 rad/s, 1.0) on
    K/(s·(T_m·s + 1)) at H_nominal, checked with the inductance
    (:func:`~manipcad.synthesis._common.design_pd`), and k_i = k_p·ω_n/10
    (the integral a decade below the bandwidth). Any gain can be given.
    """
    period = check_period(period)
    j, d, rng, H, K, T = _nominal(robot, joint, load_range_, H_nominal)
    wn, zeta = parse_spec(spec, bandwidth=30.0, damping=1.0)
    plant = linearize(d, H, 0.0, order=order).tf
    kp0, kd0, _ = design_pd(plant, K, T, wn, zeta, period, what=f"pid on {robot.joint_names[j]!r}")
    kp = kp0 if kp is None else float(kp)
    kd = kd0 if kd is None else float(kd)
    ki = kp * wn / 10.0 if ki is None else float(ki)
    ulim = d.u_max / d.k_u if math.isfinite(d.u_max) else math.inf
    base = pid(j, kp=kp, ki=ki, kd=kd, period=period, u_limit=ulim)
    C = ct.tf([kd, kp, ki], [1.0, 0.0], inputs="e", outputs="U")
    cl = ct.feedback(C * plant, 1)
    name = robot.joint_names[j]
    law = (f"pid ({name}): U = {kp:.6g}·e + {ki:.6g}·∫e + {kd:.6g}·ė (|U| <= {ulim:g} V, "
           f"anti-windup), designed at H_ii = {H:.4g} kg·m² (T_m = {T:.4g} s, "
           f"ω_n = {wn:g} rad/s, ζ = {zeta:g}); T = {period:g} s")
    return SynthesizedRegulator(
        joint=j, period=period, kind=base.kind, params=base.params, name="pid",
        needs=base.needs, method="pid", law=law,
        complexity={"gains_stored": 4, "ops_per_period": 10, "signals": list(base.needs),
                    "period": period},
        design={"kp": kp, "ki": ki, "kd": kd, "H_nominal": H, "load_range": rng,
                "bandwidth": wn, "damping": zeta,
                "closed_loop_poles": [complex(z) for z in cl.poles()]},
        linear={"plant": plant, "controller": C, "closed_loop": cl})


def synthesize_computed_torque(robot: Robot, joint, *, spec=None,
                               period: float = DEFAULT_PERIOD, load_range_=None,
                               friction: bool = True, order: int = 3) -> SynthesizedRegulator:
    """Decentralized computed torque through the drive model (L neglected).

    v = q̈* + k_d·ė + k_p·e with k_p = ω_n², k_d = 2ζω_n (``spec``, default
    30 rad/s, 1.0); the joint torque (H_ii + J·i_r²)·v + k_v·i_r²·q̇ + c_i + Q_i
    (+ dry friction) is turned into the amplifier input through the motor's
    static equations, U = (R·i* + k_w·i_r·q̇)/k_u with i* = τ/(k_m·i_r). The
    coupling Σ H_ik·q̈_k of the other joints is not measured (decentralized) and
    the current's lag T_e = L/R is not compensated.

    Args:
        robot, joint: the joint; spec: ``{"bandwidth", "damping"}`` of the error dynamics.
        period: control period, s; load_range_: (H_min, H_max) kg·m² (for the description).
        friction: compensate the dry friction.
        order: packed drive order (the law itself neglects L).
    """
    period = check_period(period)
    j, d = joint_drive(robot, joint)
    wn, zeta = parse_spec(spec, bandwidth=30.0, damping=1.0)
    if wn * period > 0.5:
        raise ManipcadError(f"computed_torque: bandwidth {wn:g} rad/s is unreachable with the "
                            f"control period {period:g} s (need ω_n·T_s <= 0.5)")
    Hmin, Hmax = load_range(robot, j, load_range_)
    kp, kd = wn * wn, 2.0 * zeta * wn
    p = packed(d, order)
    ulim = d.u_max / d.k_u if math.isfinite(d.u_max) else math.inf
    p[CT_KP], p[CT_KD], p[CT_ULIM], p[CT_FRIC] = kp, kd, ulim, float(friction)
    name = robot.joint_names[j]
    law = (f"computed_torque ({name}): v = q̈* + {kd:.6g}·ė + {kp:.6g}·e; τ = (H_ii + "
           f"{d.J * d.ratio ** 2:.6g})·v + {d.k_v * d.ratio ** 2:.6g}·q̇ + c_i + Q_i"
           f"{' + |i_r|·M_f·sgn q̇' if friction else ''}; U = ({d.R:g}·τ/({d.k_m:g}·{d.ratio:g}) "
           f"+ {d.k_w * d.ratio:.6g}·q̇)/{d.k_u:g} (|U| <= {ulim:g} V); H_ii in "
           f"[{Hmin:.4g}, {Hmax:.4g}] kg·m²; T = {period:g} s")
    signals = ["q", "q_dot", "q_ref", "q_dot_ref", "q_ddot_ref", "H_ii", "h_i", "Q_i"]
    err = ct.tf([1.0, 0.0, 0.0], [1.0, kd, kp])  # e/q* of the loop without the q̈* term
    return SynthesizedRegulator(
        joint=j, period=period, kind=KIND_CT, params=p, name="computed_torque",
        needs=tuple(signals), method="computed_torque", law=law,
        complexity={"gains_stored": 9 if friction else 7, "ops_per_period": 24,
                    "signals": signals, "period": period},
        design={"kp": kp, "kd": kd, "bandwidth": wn, "damping": zeta,
                "load_range": (Hmin, Hmax)},
        linear={"closed_loop": ct.tf([kd, kp], [1.0, kd, kp]), "error": err})
