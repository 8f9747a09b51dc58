"""``computed_torque``: decentralized computed torque through the drive model (a baseline).

``v = q̈* + k_d·ė + k_p·e``; the load the gear passes ``P = H_ii·v + c_i + Q_i``; joint
torque at the gear's input ``τ = f·P + J·i_r²·v + k_v·i_r²·q̇`` (+ ``|i_r|·M_f·sgn q̇``);
current ``i* = τ/(k_m·i_r)``; ``U = (R·i* + k_w·i_r·q̇)/k_u``
(:func:`manipcad.drives.dc.static_input`). The coupling Σ H_ik·q̈_k of the other joints
is not measured (decentralized) and the current's lag T_e = L/R is not compensated.

Gear losses: f = 1/η while the motor drives or holds the load (P·q̇ >= 0), η while the
load drives it back (:func:`manipcad.dynamics.gear.gear_factor`, the plant's and the
sizing's formula, with the measured q̇); η is the gear efficiency the design assumed
(``gains.gear_efficiency``; 1: no losses, the law as without them).
"""

from __future__ import annotations

import numba as nb

from manipcad._lazy import ct
from manipcad.control.design import (
    DEFAULT_PERIOD,
    check_period,
    inertia_range,
    joint_drive,
    law_efficiency,
    packed,
    parse_spec,
)
from manipcad.control.method import GEAR_EFFICIENCY_OPTIONAL, Method
from manipcad.control.regulator import Regulator, u_limit
from manipcad.control.signals import S_CI, S_HII, S_Q, S_QD, S_QDDREF, S_QDREF, S_QI, S_QREF
from manipcad.drives.dc import clip, required_joint_torque, rigid_current_for, static_input
from manipcad.drives.params import P_RATIO
from manipcad.dynamics.gear import gear_factor
from manipcad.errors import ManipcadError
from manipcad.model.robot import Robot

# outer-loop gains k_p (1/s²), k_d (1/s), output limit (V), compensate dry friction (1/0),
# the gear efficiency the law models η (-)
CT_KP, CT_KD, CT_ULIM, CT_FRIC, CT_ETA = 16, 17, 18, 19, 20
FIELDS = {"kp_per_s2": CT_KP, "kd_per_s": CT_KD, "u_limit_V": CT_ULIM,
          "friction_compensation": CT_FRIC, "gear_efficiency": CT_ETA}


@nb.njit(cache=True)
def joint_torque_to_input(tau, qd, p):
    """Amplifier input that makes a rigid drive give the joint torque τ at speed q̇, V.

    i* = τ/(k_m·i_r) (:func:`manipcad.drives.dc.rigid_current_for`), L neglected.
    """
    return static_input(rigid_current_for(tau, p), p[P_RATIO] * qd, p)


@nb.njit(cache=True)
def drive_torque(load, v, qd, eta, friction, p):
    """The joint-referred torque the motor must give, N·m (N): the load the gear passes
    (``load``, N·m or N) times the gear factor f (1/η motoring or holding, η braking;
    :func:`manipcad.dynamics.gear.gear_factor` at the speed q̇), plus the rotor's inertia
    J·i_r²·v, its viscous friction k_v·i_r²·q̇ and (``friction`` != 0) the dry friction
    |i_r|·M_f·sgn q̇ (:func:`manipcad.drives.dc.required_joint_torque`).

    Args:
        load: P, N·m (N); v: the commanded acceleration, rad/s² (m/s²); qd: q̇, rad/s
        (m/s); eta: gear efficiency η in (0, 1], -; friction: 1/0; p: the packed drive.
    """
    f = gear_factor(eta, load, qd) if eta != 1.0 else 1.0
    return required_joint_torque(f, load, v, qd, friction, p)


@nb.njit(cache=True)
def computed_torque_update(p, s, sig, j, Ts):
    """Decentralized computed torque through the drive model (L neglected), V."""
    qd = sig[j, S_QD]
    v = (sig[j, S_QDDREF] + p[CT_KD] * (sig[j, S_QDREF] - qd)
         + p[CT_KP] * (sig[j, S_QREF] - sig[j, S_Q]))
    load = sig[j, S_HII] * v + sig[j, S_CI] + sig[j, S_QI]
    tau = drive_torque(load, v, qd, p[CT_ETA], p[CT_FRIC], p)
    return clip(joint_torque_to_input(tau, qd, p), p[CT_ULIM])


def outer_gains(spec, period: float, what: str) -> tuple[float, float, float, float]:
    """(k_p 1/s², k_d 1/s, ω_n rad/s, ζ) of the error dynamics ë + k_d·ė + k_p·e = 0."""
    wn, zeta = parse_spec(spec, bandwidth=30.0, damping=1.0)
    if wn * period > 0.5:
        raise ManipcadError(f"{what}: bandwidth {wn:g} rad/s is unreachable with the "
                            f"control period {period:g} s (need ω_n·T_s <= 0.5)")
    return wn * wn, 2.0 * zeta * wn, wn, zeta


def synthesize_computed_torque(robot: Robot, joint, *, spec=None,
                               period: float = DEFAULT_PERIOD, load_range=None,
                               friction: bool = True, order: int = 3) -> Regulator:
    """Decentralized computed torque for one joint.

    Args:
        robot, joint: the joint (with a drive).
        spec: ``{"bandwidth": ω_n rad/s, "damping": ζ}`` of the error dynamics (default
            30 rad/s, 1.0): k_p = ω_n², k_d = 2ζω_n.
        period: control period, s.
        load_range: (H_min, H_max) kg·m² (for the description).
        friction: compensate the dry friction.
        order: packed drive order (the law itself neglects L).

    Returns:
        A :class:`~manipcad.control.regulator.Regulator` of method ``computed_torque``.
    """
    period = check_period(period)
    j, d = joint_drive(robot, joint)
    kp, kd, wn, zeta = outer_gains(spec, period, "computed_torque")
    Hmin, Hmax = inertia_range(robot, j, load_range)
    p = packed(d, order)
    ulim = u_limit(d)
    eta = law_efficiency(d)
    p[CT_KP], p[CT_KD], p[CT_ULIM], p[CT_FRIC] = kp, kd, ulim, float(friction)
    p[CT_ETA] = eta
    name = robot.joint_names[j]
    law = (f"computed_torque ({name}): v = q̈* + {kd:.6g}·ė + {kp:.6g}·e; τ = f·(H_ii·v + c_i "
           f"+ Q_i) + {d.reflected_inertia:.6g}·v + {d.k_v * d.ratio ** 2:.6g}·q̇"
           f"{' + |i_r|·M_f·sgn q̇' if friction else ''}, f = 1/η motoring or holding, η "
           f"braking, η = {eta:g}; U = ({d.R:g}·τ/({d.k_m:g}·{d.ratio:g}) "
           f"+ {d.k_w * d.ratio:.6g}·q̇)/{d.k_u:g} (|U| <= {ulim:g} V); H_ii in "
           f"[{Hmin:.4g}, {Hmax:.4g}] kg·m²; T = {period:g} s")
    needs = ("q", "q_dot", "q_ref", "q_dot_ref", "q_ddot_ref", "H_ii", "c_i", "Q_i")
    return Regulator(
        method="computed_torque", joints=(j,), period=period, params=p, needs=needs, law=law,
        design={"kp": kp, "kd": kd, "bandwidth": wn, "damping": zeta,
                "load_range": (Hmin, Hmax), "gear_efficiency": eta},
        linear={"closed_loop": ct.tf([kd, kp], [1.0, kd, kp]),
                "error": ct.tf([1.0, 0.0, 0.0], [1.0, kd, kp])})


METHOD = Method(
    name="computed_torque", synthesize=synthesize_computed_torque,
    update=computed_torque_update, section="baseline",
    summary="decentralized computed torque: H_ii, c_i, Q_i of the joint through the drive model",
    fields=FIELDS, linear=True, optional_fields=GEAR_EFFICIENCY_OPTIONAL)
