"""Baselines without adaptation: ``none`` (a plain position loop) and ``none_sce`` (the SCE of
``ace_de`` alone, the paper's "without adaptation" curve 1 of Fig. 3).

Both are designed on the drive's linear model at one nominal load (default the largest
H_ii of the range, the slowest drive) and keep their gains for every load. "No
adaptation" is a method; a joint with *no regulator* gets U = 0 and is not a method.
"""

from __future__ import annotations

import math

import numba as nb

from manipcad._lazy import ct
from manipcad.control.ace_de import synthesize_ace_de
from manipcad.control.design import (
    DEFAULT_PERIOD,
    check_period,
    nominal_drive,
    packed,
    parse_spec,
)
from manipcad.control.kernels import R_KD, R_KFA, R_KFV, R_KP, R_ULIM, sce_output
from manipcad.control.method import Method
from manipcad.control.pid import PID_KP, PID_ULIM, pid
from manipcad.control.regulator import Regulator, u_limit
from manipcad.control.signals import S_Q, S_QREF
from manipcad.drives.dc import clip
from manipcad.drives.linear import linearize
from manipcad.errors import ManipcadError
from manipcad.model.robot import Robot

P_FIELDS = {"kp_V_per_rad": PID_KP, "u_limit_V": PID_ULIM}
SCE_FIELDS = {"kp_V_per_rad": R_KP, "kd_V_s_per_rad": R_KD, "kfv_V_s_per_rad": R_KFV,
              "kfa_V_s2_per_rad": R_KFA, "u_limit_V": R_ULIM}


@nb.njit(cache=True)
def p_update(p, s, sig, j, Ts):
    """The plain position loop U = k_p·e, clipped, V."""
    return clip(p[PID_KP] * (sig[j, S_QREF] - sig[j, S_Q]), p[PID_ULIM])


@nb.njit(cache=True)
def sce_update(p, s, sig, j, Ts):
    """The SCE alone on the drive (no corrector), clipped: U, V."""
    return clip(sce_output(p, sig, j), p[R_ULIM])


def synthesize_none(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                    load_range=None, H_nominal: float | None = None,
                    kp: float | None = None) -> Regulator:
    """U = k_p·e: the drive with a plain position loop, no adaptation.

    The default gain gives the nominal-load loop T_m·s² + s + K·k_p the damping ζ of
    ``spec`` (default 1.0, critical): K·k_p = 1/(4ζ²·T_m). The bandwidth is then set by
    the drive (ω_n = 1/(2ζ·T_m)), so ``spec`` may hold only ``damping``.

    Args:
        robot, joint: the joint (with a drive).
        spec: ``{"damping": ζ}``.
        period: control period, s.
        load_range: (H_min, H_max), kg·m².
        H_nominal: the load the gain is designed at, kg·m² (default H_max).
        kp: the gain given directly, V/rad.

    Returns:
        A :class:`~manipcad.control.regulator.Regulator` of method ``none``.

    Example:
        >>> import manipcad
        >>> reg = manipcad.synthesize(manipcad.load_robot("cylindrical"), "turn", "none")
        >>> reg.needs
        ('q', 'q_ref')
    """
    period = check_period(period)
    j, d, rng, H, K, T = nominal_drive(robot, joint, load_range, H_nominal)
    if spec and "bandwidth" in spec:
        raise ManipcadError("none: a plain P loop cannot be given a bandwidth; "
                            "its bandwidth is 1/(2ζ·T_m)")
    _, zeta = parse_spec(spec, bandwidth=1.0, damping=1.0)
    if kp is None:
        kp = 1.0 / (4.0 * zeta * zeta * T * K)
    if not math.isfinite(kp) or kp == 0:
        raise ManipcadError(f"none: k_p must be finite and nonzero, got {kp}")
    ulim = u_limit(d)
    reg = pid(j, kp=kp, period=period, u_limit=ulim, method="none")
    name = robot.joint_names[j]
    reg.law = (f"none ({name}): U = {kp:.6g}·e (|U| <= {ulim:g} V), designed at H_ii = "
               f"{H:.4g} kg·m² (T_m = {T:.4g} s, K = {K:.4g} rad/(V·s), ζ = {zeta:g}); "
               f"T = {period:g} s")
    plant = linearize(d, H, 0.0, order=2).tf
    reg.design = {"kp": kp, "H_nominal": H, "load_range": rng, "T_m": T, "K": K,
                  "damping": zeta}
    reg.linear = {"plant": plant, "controller": ct.tf([kp], [1.0], inputs="e", outputs="U"),
                  "closed_loop": ct.feedback(kp * plant, 1)}
    return reg


def synthesize_none_sce(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                        load_range=None, J_n: float | None = None, feedforward: bool = True,
                        order: int = 3, reference=None) -> Regulator:
    """The stationary corrective element of ``ace_de`` applied to the drive directly.

    The same SCE (same ``spec``: bandwidth and damping on the nominal model, the same
    nominal feed-forward) without the corrector: the like-for-like "no adaptation"
    baseline of ``ace_de`` and ``ace_tf``.

    Args:
        robot, joint: the joint.
        spec, period, load_range, J_n, feedforward, order, reference: as ``ace_de``.

    Returns:
        A :class:`~manipcad.control.regulator.Regulator` of method ``none_sce``.
    """

    period = check_period(period)
    ref = synthesize_ace_de(robot, joint, spec=spec, period=period, load_range=load_range,
                            J_n=J_n, feedforward=feedforward, order=order, reference=reference)
    j = ref.joints[0]
    d = robot.drives[j]
    dz = ref.design
    p = packed(d, order)
    p[R_KP], p[R_KD], p[R_KFV], p[R_KFA] = dz["kp"], dz["kd"], dz["kfv"], dz["kfa"]
    ulim = u_limit(d)
    p[R_ULIM] = ulim
    C = ct.tf([dz["kd"], dz["kp"]], [1.0], inputs="e", outputs="U")
    H = dz["load_range"][1]
    plant = linearize(d, H, 0.0, order=order).tf
    name = robot.joint_names[j]
    law = (f"none_sce ({name}): U = {dz['kp']:.6g}·e + {dz['kd']:.6g}·ė + "
           f"{dz['kfv']:.6g}·q̇* + {dz['kfa']:.6g}·q̈* (|U| <= {ulim:g} V), the SCE of "
           f"ace_de (ω_n = {dz['bandwidth']:g} rad/s, ζ = {dz['damping']:g} on the nominal "
           f"model, J_n = {dz['J_n']:.4g} kg·m²) without the corrector; T = {period:g} s")
    needs = ("q", "q_dot", "q_ref", "q_dot_ref") + (("q_ddot_ref",) if feedforward else ())
    return Regulator(
        method="none_sce", joints=(j,), period=period, params=p, needs=needs, law=law,
        design={k: dz[k] for k in ("kp", "kd", "kfv", "kfa", "load_range", "J_n",
                                   "bandwidth", "damping")},
        linear={"plant": plant, "controller": C, "closed_loop": ct.feedback(C * plant, 1)})


def export_sce(reg: Regulator):
    """The SCE as a static gain: inputs (e, ė, q̇*, q̈*), output U, V (the clip left out)."""
    p = reg.params
    return ct.ss([], [], [], [[p[R_KP], p[R_KD], p[R_KFV], p[R_KFA]]], reg.period,
                 inputs=["e", "e_dot", "q_dot_ref", "q_ddot_ref"], outputs=["U"],
                 name=f"{reg.method}_{'_'.join(reg.joint_names) or reg.joints[0]}")


def export_p(reg: Regulator):
    """The P loop as a static gain: input e (rad), output U (V); the clip left out."""
    return ct.ss([], [], [], [[reg.params[PID_KP]]], reg.period, inputs=["e"], outputs=["U"],
                 name=f"none_{'_'.join(reg.joint_names) or reg.joints[0]}")


NONE = Method(
    name="none", synthesize=synthesize_none, update=p_update, section="3.1 (Fig. 3 curve 1)",
    summary="plain P position loop at the nominal load, no adaptation",
    fields=P_FIELDS, export=export_p, drive_blocks=0, linear=True)

NONE_SCE = Method(
    name="none_sce", synthesize=synthesize_none_sce, update=sce_update, section="3.1",
    summary="the SCE of ace_de without the corrector (Fig. 3 curve 1)",
    fields=SCE_FIELDS, export=export_sce, linear=True)
