"""``ace_de``: control law (3) after a stationary corrective element (paper 3.2).

The law (docs/drive-equations.md §3, :func:`manipcad.drives.laws.law3_voltage`)
makes the drive's third-order equation with a time-varying load equal the
constant-coefficient nominal model

    L·J_n·i_r·q⃛ + R·J_n·i_r·q̈ + k_m·k_w·i_r·q̇ = k_m·k_u·U

at any rate of change of H*, h*. The stationary corrective element (SCE) is a
PD (plus optional feed-forward) designed with python-control on that nominal
model to meet a bandwidth/damping spec; since the law keeps the drive nominal,
the SCE's design holds for every load.

Run time (compiled, :func:`ace_de_update`): the
simulator supplies H_ii, the velocity torque c_i and gravity Q_i; the law takes
h_i = Ḣ_ii (the momentum split), Ḣ_ii, Ḧ_ii and ṁ_f by backward differences,
m_f = M_f·sgn ω_m + (c_i − Ḣ_ii·q̇ + Q_i)/i_r, and q̈ from the measured armature
current through the shaft equation (no accelerometer).

Gear losses: the gear of efficiency η passes the load P = H_ii·q̈ + h_i·q̇ + c_i − Ḣ_ii·q̇
+ Q_i to the motor as f·P/i_r, f = 1/η while the motor drives or holds the load and η
while the load drives it back (:func:`manipcad.dynamics.gear.gear_factor`, the plant's and
the sizing's formula). The law's load terms H*, h*, their rates and the load torque in
m_f are multiplied by the same f, so the drive is made nominal in either power flow;
f is chosen from the sign of P·q̇ with q̈ from the current (tried with 1/η, taken again
with η if the power flows back). The paper's drive model has no gear losses (η = 1).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np

from manipcad._lazy import ct
from manipcad.control.design import (
    DEFAULT_PERIOD,
    back_emf_feedforward,
    check_period,
    design_for_accuracy,
    design_pd,
    inertia_range,
    joint_drive,
    law_efficiency,
    max_error_of,
    packed,
    parse_spec,
    pd_bandwidth,
)
from manipcad.control.kernels import (
    R_KD,
    R_KFA,
    R_KFV,
    R_KP,
    R_ULIM,
    load_rates,
    sce_output,
    torque_rate,
)
from manipcad.control.method import GEAR_EFFICIENCY_OPTIONAL, Method
from manipcad.control.regulator import Regulator, u_limit
from manipcad.control.signals import S_CI, S_HII, S_I, S_QD, S_QI
from manipcad.drives.dc import clip, dry_friction
from manipcad.drives.laws import default_T1, law3_voltage, nominal_tf
from manipcad.drives.params import P_J, P_KM, P_KV, P_RATIO, P_WEPS
from manipcad.dynamics.gear import gear_factor
from manipcad.errors import ManipcadError
from manipcad.model.robot import Drive, Robot

# nominal inertia J_n (kg·m², motor side), compensate dry friction (1/0), compensate the
# measured load torque (1/0), the gear efficiency the law assumes η (-)
AD_JN, AD_FRIC, AD_TORQUE, AD_ETA = 21, 22, 23, 24
FIELDS = {"kp_V_per_rad": R_KP, "kd_V_s_per_rad": R_KD, "kfv_V_s_per_rad": R_KFV,
          "kfa_V_s2_per_rad": R_KFA, "u_limit_V": R_ULIM, "J_n_kgm2": AD_JN,
          "friction_compensation": AD_FRIC, "load_torque_compensation": AD_TORQUE,
          "gear_efficiency": AD_ETA}


@nb.njit(cache=True)
def _shaft_qdd(p, i, w, Hs, hs, m_load, fric, r):
    """q̈ from the measured current by the shaft equation, rad/s² (m/s²):
    i_r·q̈ = (k_m·i − (h*+k_v)·ω_m − m_load − M_f(ω_m))/(J+H*), the load terms as given
    (already multiplied by the gear factor)."""
    return (p[P_KM] * i - (hs + p[P_KV]) * w - m_load - fric) / ((p[P_J] + Hs) * r)


@nb.njit(cache=True)
def ace_de_update(p, s, sig, j, Ts):
    """Law (3) after the SCE: the drive made the constant-coefficient nominal model, V.

    H* = H_ii/i_r², h* = Ḣ*/… (the momentum split h_i = Ḣ_ii), m_f = M_f·sgn ω_m +
    (c_i − Ḣ_ii·q̇_i + Q_i)/i_r; q̈ from the measured current by the shaft equation
    i_r·q̈ = (k_m·i − (f·h*+k_v)·ω_m − m_f)/(J+f·H*), the load terms multiplied by the gear
    factor f (1/η or η with the power flow, module docstring). Returns U_k, V.
    """
    r = p[P_RATIO]
    r2 = r * r
    qd = sig[j, S_QD]
    H = sig[j, S_HII]
    Hd, Hdd = load_rates(H, s, Ts)
    tau = 0.0
    if p[AD_TORQUE] != 0.0:
        # the velocity torque less the part written as h_i·q̇, plus gravity
        tau = sig[j, S_CI] - Hd * qd + sig[j, S_QI]
    w = r * qd
    fric = dry_friction(w, p) if p[AD_FRIC] != 0.0 else 0.0
    eta = p[AD_ETA]
    f = 1.0 / eta
    qdd = _shaft_qdd(p, sig[j, S_I], w, f * H / r2, f * Hd / r2, f * tau / r, fric, r)
    if gear_factor(eta, H * qdd + Hd * qd + tau, qd) != f:
        f = eta
        qdd = _shaft_qdd(p, sig[j, S_I], w, f * H / r2, f * Hd / r2, f * tau / r, fric, r)
    md = torque_rate(f * tau / r, s, Ts)
    U = sce_output(p, sig, j)
    Uk = law3_voltage(U, qd, qdd, f * H / r2, f * Hd / r2, f * Hd / r2, f * Hdd / r2,
                      f * tau / r + fric, md, p[AD_JN], p)
    return clip(Uk, p[R_ULIM])


#: default closed-loop spec of the SCE: ω_n (rad/s), ζ
DEFAULT_BANDWIDTH = 30.0
DEFAULT_DAMPING = 1.0


def sce_feedforward(drive, J_n: float, order: int) -> tuple[float, float]:
    """Velocity and acceleration feed-forward that invert the nominal model (L·q⃛ term left out).

    k_fv = k_w·i_r/k_u (V·s/rad), k_fa = R·J_n·i_r/(k_m·k_u) (V·s²/rad).
    """
    return back_emf_feedforward(drive), drive.R * J_n * drive.ratio / (drive.k_m * drive.k_u)


@dataclass(frozen=True)
class SCEDesign:
    """A stationary corrective element designed by :func:`design_sce`.

    Attributes:
        params: the regulator's parameter vector: the packed drive, then the
            SCE gains and the output limit at ``R_KP .. R_ULIM``.
        kp, kd, kfv, kfa: the SCE gains, V/rad, V·s/rad, V·s/rad, V·s²/rad.
        ulim: output limit u_max/k_u, V (inf: none).
        bandwidth, damping: ω_n (rad/s, the one reached for a ``max_error``) and ζ.
        max_error: the accuracy asked, rad (None: none).
        nominal_max_error: the nominal loop's max error on the reference, rad (None: not asked).
        closed_loop: the nominal closed loop q/q*.
    """

    params: np.ndarray
    kp: float
    kd: float
    kfv: float
    kfa: float
    ulim: float
    bandwidth: float
    damping: float
    max_error: float | None
    nominal_max_error: float | None
    closed_loop: ct.TransferFunction

    def design(self) -> dict:
        """The SCE's entries of a regulator's ``design``."""
        return {"bandwidth": self.bandwidth, "damping": self.damping,
                "max_error": self.max_error, "nominal_max_error": self.nominal_max_error,
                "kp": self.kp, "kd": self.kd, "kfv": self.kfv, "kfa": self.kfa}

    def law(self) -> str:
        """The SCE's law with its numbers: ``U = k_p·e + k_d·ė + k_fv·q̇* + k_fa·q̈*``."""
        law = (f"U = {self.kp:.6g}·e + {self.kd:.6g}·ė + {self.kfv:.6g}·q̇* + "
               f"{self.kfa:.6g}·q̈*")
        if self.nominal_max_error is not None:
            law += (f" [promise: max |e| <= {self.nominal_max_error:.3g} rad on the reference "
                    f"(asked {self.max_error:.3g}), the nominal loop; check it with verify]")
        return law

    def poles(self) -> list[complex]:
        """Poles of the nominal closed loop."""
        return [complex(z) for z in self.closed_loop.poles()]

    def linear(self, plant: ct.TransferFunction) -> dict:
        """A regulator's ``linear``: the nominal plant, the SCE's PD and the closed loop."""
        return {"plant": plant, "sce": ct.tf([self.kd, self.kp], [1.0], inputs="e", outputs="U"),
                "closed_loop": self.closed_loop}


def design_sce(d: Drive, plant: ct.TransferFunction, T: float, J_n: float, order: int, wn: float,
               zeta: float, period: float, e_max: float | None, ref, *, feedforward: bool,
               what: str) -> SCEDesign:
    """The SCE of ``ace_de`` and ``ace_tf`` on the nominal ``plant`` (time constant T), packed.

    The PD of :func:`~manipcad.control.design.design_pd` at (ω_n, ζ), or with
    ``e_max`` the smallest ω_n that meets it on ``ref``
    (:func:`~manipcad.control.design.design_for_accuracy`); the nominal
    feed-forward of :func:`sce_feedforward` (J_n) when ``feedforward``.
    """
    K = d.k_u / (d.k_w * d.ratio)
    kfv, kfa = sce_feedforward(d, J_n, order) if feedforward else (0.0, 0.0)
    e_reached = None
    if e_max is None:
        kp, kd, cl = design_pd(plant, K, T, wn, zeta, period, what=what)
    else:
        kp, kd, cl, wn, e_reached = design_for_accuracy(plant, K, T, wn, zeta, period,
                                                        (kfv, kfa), e_max, ref, what=what)
    p = packed(d, order)
    ulim = u_limit(d)
    p[R_KP], p[R_KD], p[R_KFV], p[R_KFA], p[R_ULIM] = kp, kd, kfv, kfa, ulim
    return SCEDesign(params=p, kp=kp, kd=kd, kfv=kfv, kfa=kfa, ulim=ulim, bandwidth=wn,
                     damping=zeta, max_error=e_max, nominal_max_error=e_reached, closed_loop=cl)


def synthesize_ace_de(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                      J_n: float | None = None, load_range=None, order: int = 3,
                      feedforward: bool = True, friction: bool = True,
                      load_torque: bool = True, reference=None,
                      friction_zone: float | None = None) -> Regulator:
    """Law (3) + SCE for one joint.

    Args:
        robot: the robot (the joint needs a drive with R, L, k_m, k_w, k_u).
        joint: joint index or name.
        spec: ``{"bandwidth": ω_n rad/s, "damping": ζ}`` of the nominal closed
            loop (default 30 rad/s, 1.0); with ``"max_error"`` (rad) the smallest
            ω_n >= the bandwidth whose nominal loop keeps |q* − q| below it on
            ``reference`` is taken ("unreachable accuracy" if none is).
        period: control period, s.
        J_n: nominal inertia, kg·m² motor side (default J + H*_max/η, the largest
            load through the gear motoring, which keeps the gain ρ = (J+f·H*)/J_n <= 1
            and the amplifier linear).
        load_range: (H_min, H_max) joint side, kg·m² (default: over the joint limits).
        order: 3 (the law's inductance terms) or 2 (L neglected); match ``simulate(order=)``.
        feedforward: add the nominal model's velocity/acceleration feed-forward to the SCE.
        friction: compensate the dry friction M_f·sgn ω_m.
        load_torque: compensate the measured load torque (velocity torque less
            Ḣ_ii·q̇, and gravity).
        reference: for ``max_error``: the robot's trajectory or (t, q_ref) of the joint.
        friction_zone: the motor speed below which the law's dry-friction term
            M_f·sgn(ω_m) is made linear, M_f·ω_m/ω_ε, rad/s (default
            2·M_f·T/(J + H*_min): twice the speed one period of friction changes, below
            which the sampled sign of ω_m says nothing; 0: the pure sign). With the pure
            sign the law pushes with ±M_f on the sign of a speed chattering about zero after
            the motion stops and the joint creeps (a standing error of 1e-4..5e-4 rad on a
            UR5 or Panda wrist); the linear zone removes it (docs/synthesis.md).

    Returns:
        A :class:`~manipcad.control.regulator.Regulator` of method ``ace_de``.
    """
    period = check_period(period)
    j, d = joint_drive(robot, joint)
    if order not in (2, 3):
        raise ManipcadError(f"order must be 2 or 3, got {order}")
    if order == 3 and not (math.isfinite(d.L) and d.L > 0):
        raise ManipcadError(f"joint {robot.joint_names[j]!r}: law (3) of order 3 needs the "
                            f"armature inductance L > 0 (got {d.L}); use order=2")
    Hmin, Hmax = inertia_range(robot, j, load_range)
    r2 = d.ratio ** 2
    # the gear's efficiency the law models (an unknown one: none, η = 1)
    eta = law_efficiency(d)
    Jn = d.J + Hmax / (eta * r2) if J_n is None else float(J_n)
    if not (math.isfinite(Jn) and Jn > 0):
        raise ManipcadError(f"nominal inertia J_n must be > 0 kg·m², got {Jn}")
    wn, zeta = parse_spec(spec, bandwidth=DEFAULT_BANDWIDTH, damping=DEFAULT_DAMPING,
                          accuracy=True)
    e_max, ref = max_error_of(spec, reference, j)
    plant = nominal_tf(d, Jn, order=order)
    T = default_T1(d, Jn)
    wn, raised = pd_bandwidth(spec, wn, T, zeta)
    sce = design_sce(d, plant, T, Jn, order, wn, zeta, period, e_max, ref,
                     feedforward=feedforward, what=f"ace_de on {robot.joint_names[j]!r}")
    p = sce.params
    p[AD_JN], p[AD_FRIC], p[AD_TORQUE], p[AD_ETA] = Jn, float(friction), float(load_torque), eta
    if friction_zone is None:
        friction_zone = 2.0 * max(d.M_f) * period / (d.J + Hmin / r2)
    if not (math.isfinite(friction_zone) and friction_zone >= 0):
        raise ManipcadError(f"friction_zone must be >= 0 rad/s, got {friction_zone}")
    # the law's own friction model (the simulated drive keeps its own)
    p[P_WEPS] = max(p[P_WEPS], friction_zone)
    rho = ((d.J + eta * Hmin / r2) / Jn, (d.J + Hmax / (eta * r2)) / Jn)
    name = robot.joint_names[j]
    law = (f"ace_de ({name}): {sce.law()} (SCE, "
           f"ω_n = {sce.bandwidth:g} rad/s, ζ = {zeta:g} on the nominal model); law (3): "
           f"U_k = L(Ḣ*+h*+k_v)/(k_m k_u)·i_r·q̈ "
           f"+ [k_w/k_u·(1−ρ) + (R(h*+k_v)+L·ḣ*)/(k_m k_u)]·i_r·q̇ "
           f"+ R/(k_m k_u)·m_f + L/(k_m k_u)·ṁ_f + ρ·U with ρ = (J+H*)/J_n, J_n = {Jn:.6g} kg·m², "
           f"H*, h* and the load torque in m_f times f = 1/η or η with the power flow, "
           f"η = {eta:g}, "
           f"R = {d.R:g} Ω, L = {d.L if order == 3 else 0.0:g} H, k_m = {d.k_m:g} N·m/A, "
           f"k_w = {d.k_w:g} V·s/rad, k_u = {d.k_u:g}, k_v = {d.k_v:g} N·m·s/rad, "
           f"i_r = {d.ratio:g}; h_i = Ḣ_ii; H_ii in [{Hmin:.4g}, {Hmax:.4g}] kg·m² "
           f"(ρ in [{rho[0]:.3g}, {rho[1]:.3g}]); "
           f"|U_k| <= {sce.ulim:g} V, T = {period:g} s")
    needs = ["q", "q_dot", "i", "q_ref", "q_dot_ref", "H_ii"]
    if load_torque:
        needs += ["c_i", "Q_i"]
    if feedforward:
        needs.append("q_ddot_ref")
    design = {"J_n": Jn, "load_range": (Hmin, Hmax), "rho_range": rho, **sce.design(),
              "closed_loop_poles": sce.poles(), "order": order}
    if raised:
        design["note"] = raised
        law += f"; {raised}"
    return Regulator(
        method="ace_de", joints=(j,), period=period, params=p, needs=tuple(needs), law=law,
        design=design, linear=sce.linear(plant))


METHOD = Method(
    name="ace_de", synthesize=synthesize_ace_de, update=ace_de_update, section="3.1 (3)",
    summary="law (3): the drive's differential equation stabilized at the nominal, + SCE",
    fields=FIELDS, linear=True, optional_fields=GEAR_EFFICIENCY_OPTIONAL)
