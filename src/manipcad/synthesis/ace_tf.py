"""``ace_tf``: the adaptive corrective element (1) after a stationary corrective element.

``W_k(s) = (T_m·s + 1)/(k_p·k_w·(T_1·s + 1))`` with T_m, k_p of the drive at the
current load (H_ii, h_i): the load-dependent pole of the drive is cancelled by
a moving zero, so that under the quasi-stationary hypothesis
``W_k·W_p = (k_u/k_w)/((T_1·s + 1)(T_e·s + 1))`` (docs/drive-equations.md §4).
The SCE is the PD of :mod:`manipcad.synthesis.ace_de` designed on that target.

Realizations (a time-varying transfer function depends on its realization):
``"observable"`` (default; the load enters the state equation: the
quasi-stationary ACE of the paper, exact only while the load is frozen) and
``"controllable"`` (filter first, load only in the output gains: exact for the
L = 0 drive at any rate of load change). Where the frozen-load drive has no
stable pole ((h*+k_v)·R + k_m·k_w <= 0, possible with h_i = Ḣ_ii < 0 when the
load changes fast) T_m is undefined; the denominator is floored at
``den_floor``·k_m·k_w.
"""

from __future__ import annotations

import math

from manipcad.drives.laws import ace1_target_tf
from manipcad.errors import ManipcadError
from manipcad.model.robot import Robot
from manipcad.synthesis._common import (
    DEFAULT_PERIOD,
    SynthesizedRegulator,
    check_period,
    joint_drive,
    load_range,
    max_error_of,
    parse_spec,
)
from manipcad.synthesis.ace_de import DEFAULT_BANDWIDTH, DEFAULT_DAMPING, design_sce
from manipcad.synthesis.kernels import (
    AT_DENMIN,
    AT_FORM,
    AT_HDOT,
    AT_T1,
    KIND_ACE_TF,
)

REALIZATIONS = ("observable", "controllable")


def synthesize_ace_tf(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                      T_1: float | None = None, load_range_=None, order: int = 3,
                      realization: str = "observable", h_dot: bool = True,
                      den_floor: float = 0.1, feedforward: bool = True,
                      reference=None) -> SynthesizedRegulator:
    """ACE (1) + SCE for one joint.

    Args:
        robot: the robot; joint: index or name.
        spec: ``{"bandwidth": ω_n rad/s, "damping": ζ, "max_error": rad}`` of the
            loop on the target (``max_error`` as in ``ace_de``, needs ``reference``).
        period: control period, s.
        T_1: the ACE's time constant, s (default R·J_n/(k_m·k_w) with
            J_n = J + H*_max: the same nominal drive as ``ace_de``).
        load_range_: (H_min, H_max) joint side, kg·m².
        order: 3 or 2: the target includes the T_e = L/R factor (3) or not.
        realization: "observable" (quasi-stationary) or "controllable".
        h_dot: use h_i = Ḣ_ii (True) or h_i = 0 (False) in T_m and k_p.
        den_floor: floor of (h*+k_v)·R + k_m·k_w as a fraction of k_m·k_w (0, 1].
        feedforward: nominal velocity/acceleration feed-forward in the SCE.
        reference: for ``max_error``: the robot's trajectory or (t, q_ref) of the joint.

    Returns:
        A :class:`SynthesizedRegulator` of kind ``KIND_ACE_TF``.
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
    Hmin, Hmax = load_range(robot, j, load_range_)
    Jn = d.J + Hmax / d.ratio ** 2
    T1 = d.R * Jn / (d.k_m * d.k_w) if T_1 is None else float(T_1)
    if not (math.isfinite(T1) and T1 > 0):
        raise ManipcadError(f"ACE time constant T_1 must be > 0 s, got {T1}")
    Jn = T1 * d.k_m * d.k_w / d.R
    wn, zeta = parse_spec(spec, bandwidth=DEFAULT_BANDWIDTH, damping=DEFAULT_DAMPING,
                          accuracy=True)
    e_max, ref = max_error_of(spec, reference, j)
    if order == 3 and not (math.isfinite(d.L) and d.L > 0):
        raise ManipcadError(f"joint {robot.joint_names[j]!r}: order 3 needs L > 0 (got {d.L})")
    plant = ace1_target_tf(d, T_1=T1, order=order)
    sce = design_sce(d, plant, T1, Jn, order, wn, zeta, period, e_max, ref,
                     feedforward=feedforward, what=f"ace_tf on {robot.joint_names[j]!r}")
    p = sce.params
    p[AT_T1], p[AT_FORM] = T1, float(realization == "controllable")
    p[AT_HDOT], p[AT_DENMIN] = float(h_dot), den_floor
    name = robot.joint_names[j]
    law = (f"ace_tf ({name}, {realization}): {sce.law()} "
           f"(SCE, ω_n = {sce.bandwidth:g} rad/s, ζ = {zeta:g}); ACE (1): "
           f"W_k = (T_m·s + 1)/(k_p·k_w·(T_1·s + 1)), T_1 = {T1:.6g} s, "
           f"T_m = (J+H*)·R/((h*+k_v)·R + k_m·k_w), k_p = k_m/((h*+k_v)·R + k_m·k_w), "
           f"J = {d.J:.4g} kg·m², R = {d.R:g} Ω, k_m = {d.k_m:g} N·m/A, k_w = {d.k_w:g} V·s/rad, "
           f"k_v = {d.k_v:g} N·m·s/rad, i_r = {d.ratio:g}; H* = H_ii/i_r², "
           f"h* = {'Ḣ_ii' if h_dot else '0'}/i_r²; H_ii in [{Hmin:.4g}, {Hmax:.4g}] kg·m²; "
           f"|U_k| <= {sce.ulim:g} V, T = {period:g} s")
    signals = ["q", "q_dot", "q_ref", "q_dot_ref", "H_ii"]
    if feedforward:
        signals.append("q_ddot_ref")
    complexity = {
        "gains_stored": 8 + (4 if feedforward else 2),  # J, i_r, k_v, R, k_m, k_w, T_1, e^(-T/T_1)
        # SCE 5-7, Ḣ difference 5, T_m/k_p terms 8, filter output and update 10, clip 2
        "ops_per_period": 30 + (4 if feedforward else 0),
        "signals": signals,
        "period": period,
    }
    design = {"T_1": T1, "J_n": Jn, "load_range": (Hmin, Hmax), **sce.design(),
              "realization": realization, "order": order, "closed_loop_poles": sce.poles()}
    from manipcad.drives.laws import ace1_tf

    linear = {**sce.linear(plant),
              "ace_at_min_load": ace1_tf(d, Hmin, 0.0, T_1=T1),
              "ace_at_max_load": ace1_tf(d, Hmax, 0.0, T_1=T1)}
    return SynthesizedRegulator(
        joint=j, period=period, kind=KIND_ACE_TF, params=p, name="ace_tf",
        needs=tuple(signals), method="ace_tf", law=law, complexity=complexity,
        design=design, linear=linear)
