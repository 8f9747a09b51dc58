"""``ace_tf``: the adaptive corrective element (1) after a stationary corrective element.

``W_k(s) = (T_m·s + 1)/(k_p·k_w·(T_1·s + 1))`` with T_m, k_p of the drive at the
current load (H_ii, h_i): the load-dependent pole of the drive is cancelled by
a moving zero, so that under the quasi-stationary hypothesis
``W_k·W_p = (k_u/k_w)/((T_1·s + 1)(T_e·s + 1))`` (docs/drive-equations.md §4).
The SCE is the PD of :mod:`manipcad.control.ace_de` designed on that target.

Realizations (a time-varying transfer function depends on its realization):
``"observable"`` (default; the load enters the state equation: the
quasi-stationary ACE of the paper, exact only while the load is frozen) and
``"controllable"`` (filter first, load only in the output gains: exact for the
L = 0 drive at any rate of load change). Where the frozen-load drive has no
stable pole ((h*+k_v)·R + k_m·k_w <= 0, possible with h_i = Ḣ_ii < 0 when the
load changes fast) T_m is undefined; the denominator is floored at
``den_floor``·k_m·k_w.

Gear losses: through a gear of efficiency η the motor feels the load f·H*, f·h*, with
f = 1/η while the motor drives or holds the load and η while the load drives it back
(:func:`manipcad.dynamics.gear.gear_factor`, the plant's formula). The controllable
realization takes T_m and k_p at f·H*, f·h*, the power flow judged from the ACE's load
model along the reference, P = H_ii·q̈* + h_i·q̇, against the measured q̇ (the ACE reads
no current to know q̈, and models no load torque). The observable realization does not
(its stored η is 1): f steps at every reversal of the power flow, a step of T_m that its
state equation, exact only for a frozen T_m, turns into a transient (docs/synthesis.md:
on the Fig. 3 case it raised the error from 4.8e-3 to 6.4e-3 rad). Both take the nominal
drive J_n = J + H*_max/η (the largest load through the gear motoring) for T_1.
"""

from __future__ import annotations

import math

import numba as nb

from manipcad.control.ace_de import DEFAULT_BANDWIDTH, DEFAULT_DAMPING, design_sce
from manipcad.control.design import (
    DEFAULT_PERIOD,
    check_period,
    inertia_range,
    joint_drive,
    law_efficiency,
    max_error_of,
    parse_spec,
    pd_bandwidth,
)
from manipcad.control.kernels import (
    R_KD,
    R_KFA,
    R_KFV,
    R_KP,
    R_ULIM,
    ST_X,
    load_rates,
    sce_output,
)
from manipcad.control.method import GEAR_EFFICIENCY_OPTIONAL, Method
from manipcad.control.regulator import Regulator
from manipcad.control.signals import S_HII, S_QD, S_QDDREF
from manipcad.drives.dc import clip
from manipcad.drives.laws import (
    ace1_filter_step,
    ace1_obs_output,
    ace1_obs_step,
    ace1_output,
    ace1_parameters,
    ace1_target_tf,
    ace1_tf,
    default_T1,
)
from manipcad.drives.params import P_KM, P_KV, P_KW, P_R, P_RATIO
from manipcad.dynamics.gear import gear_factor
from manipcad.errors import ManipcadError
from manipcad.model.robot import Robot

# T_1 (s), realization (0 observable = quasi-stationary, 1 controllable), use h* = Ḣ* (1)
# or h* = 0 (0), floor of (h*+k_v)·R + k_m·k_w as a fraction of k_m·k_w, the gear
# efficiency η the ACE models (-)
AT_T1, AT_FORM, AT_HDOT, AT_DENMIN, AT_ETA = 21, 22, 23, 24, 25
FIELDS = {"kp_V_per_rad": R_KP, "kd_V_s_per_rad": R_KD, "kfv_V_s_per_rad": R_KFV,
          "kfa_V_s2_per_rad": R_KFA, "u_limit_V": R_ULIM, "T_1_s": AT_T1,
          "controllable_realization": AT_FORM, "h_from_H_dot": AT_HDOT, "den_floor": AT_DENMIN,
          "gear_efficiency": AT_ETA}


@nb.njit(cache=True)
def ace_tf_update(p, s, sig, j, Ts):
    """ACE (1) after the SCE: W_k = (T_m·s + 1)/(k_p·k_w·(T_1·s + 1)) at the current load, V.

    T_m, k_p from :func:`manipcad.drives.laws.ace1_parameters` at H* = f·H_ii/i_r² and
    h* = f·Ḣ_ii/i_r² (or 0), f the gear factor (module docstring; 1 without losses), with
    (h*+k_v)·R + k_m·k_w floored at ``den_floor``·k_m·k_w; output
    and state of the observable or controllable realization from :mod:`manipcad.drives.laws`,
    the filter advanced exactly over the period with its input held.
    """
    r = p[P_RATIO]
    r2 = r * r
    H = sig[j, S_HII]
    Hd, _ = load_rates(H, s, Ts)
    if p[AT_HDOT] == 0.0:
        Hd = 0.0
    f = 1.0
    eta = p[AT_ETA]
    if eta != 1.0:
        f = gear_factor(eta, H * sig[j, S_QDDREF] + Hd * sig[j, S_QD], sig[j, S_QD])
    Hs = f * H / r2
    hs = f * Hd / r2
    kmkw = p[P_KM] * p[P_KW]
    h_floor = (p[AT_DENMIN] * kmkw - kmkw) / p[P_R] - p[P_KV]
    if hs < h_floor:
        hs = h_floor
    Tm, kp = ace1_parameters(Hs, hs, p)
    T1 = p[AT_T1]
    U = sce_output(p, sig, j)
    x = s[ST_X]
    if p[AT_FORM] != 0.0:
        Uk = ace1_output(U, x, Tm, kp, T1, p)
        s[ST_X] = ace1_filter_step(x, U, T1, Ts)
    else:
        Uk = ace1_obs_output(U, x, Tm, kp, T1, p)
        s[ST_X] = ace1_obs_step(x, U, Tm, T1, Ts)
    return clip(Uk, p[R_ULIM])


REALIZATIONS = ("observable", "controllable")


def synthesize_ace_tf(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                      T_1: float | None = None, load_range=None, order: int = 3,
                      realization: str = "observable", h_dot: bool = True,
                      den_floor: float = 0.1, feedforward: bool = True,
                      reference=None) -> Regulator:
    """ACE (1) + SCE for one joint.

    Args:
        robot: the robot; joint: index or name.
        spec: ``{"bandwidth": ω_n rad/s, "damping": ζ, "max_error": rad}`` of the
            loop on the target (``max_error`` as in ``ace_de``, needs ``reference``).
        period: control period, s.
        T_1: the ACE's time constant, s (default R·J_n/(k_m·k_w) with
            J_n = J + H*_max/η, the largest load through the gear motoring: the same
            nominal drive as ``ace_de``).
        load_range: (H_min, H_max) joint side, kg·m².
        order: 3 or 2: the target includes the T_e = L/R factor (3) or not.
        realization: "observable" (quasi-stationary) or "controllable".
        h_dot: use h_i = Ḣ_ii (True) or h_i = 0 (False) in T_m and k_p.
        den_floor: floor of (h*+k_v)·R + k_m·k_w as a fraction of k_m·k_w (0, 1].
        feedforward: nominal velocity/acceleration feed-forward in the SCE.
        reference: for ``max_error``: the robot's trajectory or (t, q_ref) of the joint.

    Returns:
        A :class:`~manipcad.control.regulator.Regulator` of method ``ace_tf``.
    """
    period = check_period(period)
    j, d = joint_drive(robot, joint)
    if realization not in REALIZATIONS:
        raise ManipcadError(f"ace_tf realization must be one of {REALIZATIONS}, "
                            f"got {realization!r}")
    if order not in (2, 3):
        raise ManipcadError(f"order must be 2 or 3, got {order}")
    if not (0 < den_floor <= 1):
        raise ManipcadError(f"den_floor must be in (0, 1], got {den_floor}")
    Hmin, Hmax = inertia_range(robot, j, load_range)
    eta = law_efficiency(d)
    Jn = d.J + Hmax / (eta * d.ratio ** 2)
    T1 = default_T1(d, Jn) if T_1 is None else float(T_1)
    if not (math.isfinite(T1) and T1 > 0):
        raise ManipcadError(f"ACE time constant T_1 must be > 0 s, got {T1}")
    Jn = T1 * d.k_m * d.k_w / d.R
    wn, zeta = parse_spec(spec, bandwidth=DEFAULT_BANDWIDTH, damping=DEFAULT_DAMPING,
                          accuracy=True)
    e_max, ref = max_error_of(spec, reference, j)
    if order == 3 and not (math.isfinite(d.L) and d.L > 0):
        raise ManipcadError(f"joint {robot.joint_names[j]!r}: order 3 needs L > 0 (got {d.L})")
    plant = ace1_target_tf(d, T_1=T1, order=order)
    wn, raised = pd_bandwidth(spec, wn, T1, zeta)
    sce = design_sce(d, plant, T1, Jn, order, wn, zeta, period, e_max, ref,
                     feedforward=feedforward, what=f"ace_tf on {robot.joint_names[j]!r}")
    p = sce.params
    p[AT_T1], p[AT_FORM] = T1, float(realization == "controllable")
    # the observable realization follows no step of T_m: it models no losses (module doc)
    eta_law = eta if realization == "controllable" else 1.0
    p[AT_HDOT], p[AT_DENMIN], p[AT_ETA] = float(h_dot), den_floor, eta_law
    name = robot.joint_names[j]
    obs_note = ("" if eta_law == eta else
                f" (the gear: {eta:g}; the observable realization follows no step of T_m)")
    law = (f"ace_tf ({name}, {realization}): {sce.law()} "
           f"(SCE, ω_n = {sce.bandwidth:g} rad/s, ζ = {zeta:g}); ACE (1): "
           f"W_k = (T_m·s + 1)/(k_p·k_w·(T_1·s + 1)), T_1 = {T1:.6g} s, "
           f"T_m = (J+H*)·R/((h*+k_v)·R + k_m·k_w), k_p = k_m/((h*+k_v)·R + k_m·k_w), "
           f"J = {d.J:.4g} kg·m², R = {d.R:g} Ω, k_m = {d.k_m:g} N·m/A, k_w = {d.k_w:g} V·s/rad, "
           f"k_v = {d.k_v:g} N·m·s/rad, i_r = {d.ratio:g}; H* = H_ii/i_r², "
           f"h* = {'Ḣ_ii' if h_dot else '0'}/i_r², both times f = 1/η motoring or holding, "
           f"η braking (power flow of H_ii·q̈*{' + Ḣ_ii·q̇' if h_dot else ''} against q̇), "
           f"η = {eta_law:g}{obs_note}"
           f", T_1 for J_n = J + H*_max/{eta:g}; H_ii in [{Hmin:.4g}, {Hmax:.4g}] kg·m²; "
           f"|U_k| <= {sce.ulim:g} V, T = {period:g} s")
    needs = ["q", "q_dot", "q_ref", "q_dot_ref", "H_ii"]
    if feedforward or eta_law != 1.0:
        needs.append("q_ddot_ref")
    design = {"T_1": T1, "J_n": Jn, "load_range": (Hmin, Hmax), "gear_efficiency": eta_law,
              **sce.design(),
              "realization": realization, "order": order, "closed_loop_poles": sce.poles()}
    if raised:
        design["note"] = raised
        law += f"; {raised}"
    linear = {**sce.linear(plant),
              "ace_at_min_load": ace1_tf(d, Hmin, 0.0, T_1=T1),
              "ace_at_max_load": ace1_tf(d, Hmax, 0.0, T_1=T1)}
    return Regulator(
        method="ace_tf", joints=(j,), period=period, params=p, needs=tuple(needs), law=law,
        design=design, linear=linear, options={"realization": realization})


METHOD = Method(
    name="ace_tf", synthesize=synthesize_ace_tf, update=ace_tf_update, section="3.1 (1)",
    summary="ACE (1): moving zero cancels the load pole (realization observable|controllable)"
            ", + SCE",
    fields=FIELDS, linear=True, dynamic_states=(ST_X,),
    optional_fields=GEAR_EFFICIENCY_OPTIONAL)
