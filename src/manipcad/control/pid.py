"""``pid``: PID on the position error, designed on the drive at a nominal load (a baseline).

``U = k_p·e + k_i·∫e dt + k_d·ė (+ k_ff·q̇*)``, clipped to ±u_lim with anti-windup.
Designed on the drive's linear model at one nominal load (default the largest H_ii,
the slowest drive) and kept for every load: no adaptation. Second-order model (L
neglected) ``q/U = K/(s·(T_m·s + 1))``, ``K = k_u·k_p/i_r`` (rad/(V·s)); the loop
is checked with the inductance (:func:`~manipcad.control.design.design_pd`).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from manipcad._lazy import ct
from manipcad.control.design import (
    DEFAULT_PERIOD,
    check_finite,
    check_period,
    design_pd,
    nominal_drive,
    parse_spec,
    pd_bandwidth,
)
from manipcad.control.method import Method
from manipcad.control.regulator import Regulator, u_limit
from manipcad.control.signals import NPARAM, S_Q, S_QD, S_QDREF, S_QREF
from manipcad.drives.linear import linearize
from manipcad.errors import ManipcadError
from manipcad.model.robot import Robot

# parameters (no drive block: the law does not read the drive)
PID_KP, PID_KI, PID_KD, PID_ULIM, PID_FF = 0, 1, 2, 3, 4
# state
PID_INT = 0

FIELDS = {"kp_V_per_rad": PID_KP, "ki_V_per_rad_s": PID_KI, "kd_V_s_per_rad": PID_KD,
          "u_limit_V": PID_ULIM, "kff_V_s_per_rad": PID_FF}


@nb.njit(cache=True)
def pid_update(p, s, sig, j, Ts):
    """PID on the error e = q* − q with velocity error ė = q̇* − q̇, V.

    u = k_p·e + k_i·∫e dt + k_d·ė (+ k_ff·q̇*), clipped to ±u_lim; the
    integral stops growing while the output is clipped (anti-windup).
    """
    e = sig[j, S_QREF] - sig[j, S_Q]
    ed = sig[j, S_QDREF] - sig[j, S_QD]
    integ = s[PID_INT] + e * Ts
    u = p[PID_KP] * e + p[PID_KI] * integ + p[PID_KD] * ed + p[PID_FF] * sig[j, S_QDREF]
    lim = p[PID_ULIM]
    if u > lim:
        u = lim
    elif u < -lim:
        u = -lim
    else:
        s[PID_INT] = integ
    return u


def pid(joint: int | str, *, kp: float, ki: float = 0.0, kd: float = 0.0,
        period: float = 1e-3, u_limit: float = math.inf, kff: float = 0.0,
        method: str = "pid") -> Regulator:
    """A PID regulator of one joint with the gains given, on the position error.

    Args:
        joint: joint index or name.
        kp: proportional gain, V/rad (V/m), or N·m/rad without a drive.
        ki: integral gain, V/(rad·s).
        kd: derivative gain on the velocity error, V·s/rad.
        period: sampling period, s.
        u_limit: output clip, V (N·m without a drive).
        kff: velocity feed-forward gain on q̇_ref, V·s/rad (e.g. k_w·i_r/k_u
            cancels the back-EMF at the reference speed).

    Returns:
        A :class:`~manipcad.control.regulator.Regulator` of method ``pid``.

    Example:
        >>> from manipcad.control import pid
        >>> reg = pid("q1", kp=200.0, kd=5.0, period=1e-3)
        >>> reg.describe()
        'pid: U = 200·e + 0·∫e + 5·ė + 0·q̇_ref (|U| ≤ inf), T = 0.001 s'
    """
    for name, v in (("kp", kp), ("ki", ki), ("kd", kd), ("kff", kff)):
        check_finite(name, v, "pid")
    period = check_period(period)
    if not u_limit > 0:

        raise ManipcadError(f"pid u_limit must be > 0, got {u_limit}")
    p = np.zeros(NPARAM)
    p[PID_KP], p[PID_KI], p[PID_KD], p[PID_ULIM], p[PID_FF] = kp, ki, kd, u_limit, kff
    needs = ("q", "q_dot", "q_ref", "q_dot_ref") if (kd or kff or method == "pid") else (
        "q", "q_ref")
    law = (f"{method}: U = {kp:g}·e + {ki:g}·∫e + {kd:g}·ė + {kff:g}·q̇_ref "
           f"(|U| ≤ {u_limit:g}), T = {period:g} s")
    return Regulator(method=method, joints=(joint,), period=float(period), params=p,
                     needs=needs, law=law)


def synthesize_pid(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                   load_range=None, H_nominal: float | None = None, kp: float | None = None,
                   ki: float | None = None, kd: float | None = None,
                   order: int = 3) -> Regulator:
    """PID designed on the drive at a nominal load.

    Default gains: the PD of ``spec`` (ω_n, ζ; default 30 rad/s, 1.0) on
    K/(s·(T_m·s + 1)) at H_nominal, checked with the inductance, and
    k_i = k_p·ω_n/10 (the integral a decade below the bandwidth). Any gain can be given.

    Args:
        robot, joint: the joint (with a drive).
        spec: ``{"bandwidth": rad/s, "damping": ζ}``.
        period: control period, s.
        load_range: (H_min, H_max), kg·m² (default: over the joint limits).
        H_nominal: the design load, kg·m² (default H_max).
        kp, ki, kd: gains given directly, V/rad, V/(rad·s), V·s/rad.
        order: 3 (with the inductance) or 2, for the check of the loop.

    Returns:
        A :class:`~manipcad.control.regulator.Regulator` of method ``pid``.

    Example:
        >>> import manipcad
        >>> reg = manipcad.synthesize(manipcad.load_robot("cylindrical"), "lift", "pid")
        >>> reg.method, reg.joint_names
        ('pid', ('lift',))
    """
    period = check_period(period)
    j, d, rng, H, K, T = nominal_drive(robot, joint, load_range, H_nominal)
    wn, zeta = parse_spec(spec, bandwidth=30.0, damping=1.0)
    wn, raised = pd_bandwidth(spec, wn, T, zeta)
    plant = linearize(d, H, 0.0, order=order).tf
    kp0, kd0, _ = design_pd(plant, K, T, wn, zeta, period,
                            what=f"pid on {robot.joint_names[j]!r}")
    kp = kp0 if kp is None else float(kp)
    kd = kd0 if kd is None else float(kd)
    ki = kp * wn / 10.0 if ki is None else float(ki)
    ulim = u_limit(d)
    reg = pid(j, kp=kp, ki=ki, kd=kd, period=period, u_limit=ulim)
    C = ct.tf([kd, kp, ki], [1.0, 0.0], inputs="e", outputs="U")
    cl = ct.feedback(C * plant, 1)
    name = robot.joint_names[j]
    reg.law = (f"pid ({name}): U = {kp:.6g}·e + {ki:.6g}·∫e + {kd:.6g}·ė (|U| <= {ulim:g} V, "
               f"anti-windup), designed at H_ii = {H:.4g} kg·m² (T_m = {T:.4g} s, "
               f"ω_n = {wn:g} rad/s, ζ = {zeta:g}); T = {period:g} s"
               + (f"; {raised}" if raised else ""))
    reg.design = {"kp": kp, "ki": ki, "kd": kd, "H_nominal": H, "load_range": rng,
                  "bandwidth": wn, "damping": zeta,
                  "closed_loop_poles": [complex(z) for z in cl.poles()]}
    if raised:
        reg.design["note"] = raised
    reg.linear = {"plant": plant, "controller": C, "closed_loop": cl}
    return reg


def export_pid(reg: Regulator):
    """The PID as a discrete-time python-control system: inputs (e, ė, q̇*), output U, V.

    The integral is the forward-Euler sum the compiled update keeps (∫e += e·T before the
    output); the clip and the anti-windup are not part of the linear export.
    """
    p = reg.params
    T = reg.period
    # x[k+1] = x[k] + T·e[k];  U[k] = kp·e + ki·(x[k] + T·e[k]) + kd·ė + kff·q̇*
    A = [[1.0]]
    B = [[T, 0.0, 0.0]]
    C = [[p[PID_KI]]]
    D = [[p[PID_KP] + p[PID_KI] * T, p[PID_KD], p[PID_FF]]]
    return ct.ss(A, B, C, D, T, inputs=["e", "e_dot", "q_dot_ref"], outputs=["U"],
                 name=f"pid_{'_'.join(reg.joint_names) or reg.joints[0]}")


METHOD = Method(
    name="pid", synthesize=synthesize_pid, update=pid_update, section="baseline",
    summary="PID designed at the nominal (largest) load, fixed gains",
    fields=FIELDS, export=export_pid, drive_blocks=0, linear=True,
    dynamic_states=(PID_INT,))
