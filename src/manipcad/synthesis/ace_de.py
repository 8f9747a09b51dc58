"""``ace_de``: control law (3) after a stationary corrective element (paper 3.2).

The law (docs/drive-equations.md §3, :func:`manipcad.drives.laws.law3_voltage`)
makes the drive's third-order equation with a time-varying load equal the
constant-coefficient nominal model

    L·J_n·i_r·q⃛ + R·J_n·i_r·q̈ + k_m·k_w·i_r·q̇ = k_m·k_u·U

at any rate of change of H*, h*. The stationary corrective element (SCE) is a
PD (plus optional feed-forward) designed with python-control on that nominal
model to meet a bandwidth/damping spec; since the law keeps the drive nominal,
the SCE's design holds for every load.

Run time (compiled, :func:`manipcad.synthesis.kernels.ace_de_update`): the
simulator supplies H_ii, the velocity torque c_i and gravity Q_i; the law takes
h_i = Ḣ_ii (the momentum split), Ḣ_ii, Ḧ_ii and ṁ_f by backward differences,
m_f = M_f·sgn ω_m + (c_i − Ḣ_ii·q̇ + Q_i)/i_r, and q̈ from the measured armature
current through the shaft equation (no accelerometer).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import control as ct
import numpy as np

from manipcad.drives.laws import nominal_tf
from manipcad.errors import ManipcadError
from manipcad.model.robot import Drive, Robot
from manipcad.synthesis._common import (
    DEFAULT_PERIOD,
    SynthesizedRegulator,
    check_period,
    design_for_accuracy,
    design_pd,
    joint_drive,
    load_range,
    max_error_of,
    packed,
    parse_spec,
)
from manipcad.synthesis.kernels import (
    AD_FRIC,
    AD_JN,
    AD_TORQUE,
    KIND_ACE_DE,
    R_KD,
    R_KFA,
    R_KFV,
    R_KP,
    R_ULIM,
)

#: default closed-loop spec of the SCE: ω_n (rad/s), ζ
DEFAULT_BANDWIDTH = 30.0
DEFAULT_DAMPING = 1.0


def sce_feedforward(drive, J_n: float, order: int) -> tuple[float, float]:
    """Velocity and acceleration feed-forward that invert the nominal model (L·q⃛ term left out).

    k_fv = k_w·i_r/k_u (V·s/rad), k_fa = R·J_n·i_r/(k_m·k_u) (V·s²/rad).
    """
    kfv = drive.k_w * drive.ratio / drive.k_u
    return kfv, drive.R * J_n * drive.ratio / (drive.k_m * drive.k_u)


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
        return (f"U = {self.kp:.6g}·e + {self.kd:.6g}·ė + {self.kfv:.6g}·q̇* + "
                f"{self.kfa:.6g}·q̈*")

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

    The PD of :func:`~manipcad.synthesis._common.design_pd` at (ω_n, ζ), or with
    ``e_max`` the smallest ω_n that meets it on ``ref``
    (:func:`~manipcad.synthesis._common.design_for_accuracy`); the nominal
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
    ulim = d.u_max / d.k_u if math.isfinite(d.u_max) else math.inf
    p[R_KP], p[R_KD], p[R_KFV], p[R_KFA], p[R_ULIM] = kp, kd, kfv, kfa, ulim
    return SCEDesign(params=p, kp=kp, kd=kd, kfv=kfv, kfa=kfa, ulim=ulim, bandwidth=wn,
                     damping=zeta, max_error=e_max, nominal_max_error=e_reached, closed_loop=cl)


def synthesize_ace_de(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                      J_n: float | None = None, load_range_=None, order: int = 3,
                      feedforward: bool = True, friction: bool = True,
                      load_torque: bool = True, reference=None) -> SynthesizedRegulator:
    """Law (3) + SCE for one joint.

    Args:
        robot: the robot (the joint needs a drive with R, L, k_m, k_w, k_u).
        joint: joint index or name.
        spec: ``{"bandwidth": ω_n rad/s, "damping": ζ}`` of the nominal closed
            loop (default 30 rad/s, 1.0); with ``"max_error"`` (rad) the smallest
            ω_n >= the bandwidth whose nominal loop keeps |q* − q| below it on
            ``reference`` is taken ("unreachable accuracy" if none is).
        period: control period, s.
        J_n: nominal inertia, kg·m² motor side (default J + H*_max, the largest
            load, which keeps the gain ρ = (J+H*)/J_n <= 1 and the amplifier linear).
        load_range_: (H_min, H_max) joint side, kg·m² (default: over the joint limits).
        order: 3 (the law's inductance terms) or 2 (L neglected); match ``simulate(order=)``.
        feedforward: add the nominal model's velocity/acceleration feed-forward to the SCE.
        friction: compensate the dry friction M_f·sgn ω_m.
        load_torque: compensate the measured load torque (velocity torque less
            Ḣ_ii·q̇, and gravity).
        reference: for ``max_error``: the robot's trajectory or (t, q_ref) of the joint.

    Returns:
        A :class:`SynthesizedRegulator` of kind ``KIND_ACE_DE``.
    """
    period = check_period(period)
    j, d = joint_drive(robot, joint)
    if order not in (2, 3):
        raise ManipcadError(f"order must be 2 or 3, got {order}")
    if order == 3 and not (math.isfinite(d.L) and d.L > 0):
        raise ManipcadError(f"joint {robot.joint_names[j]!r}: law (3) of order 3 needs the "
                            f"armature inductance L > 0 (got {d.L}); use order=2")
    Hmin, Hmax = load_range(robot, j, load_range_)
    r2 = d.ratio ** 2
    Jn = d.J + Hmax / r2 if J_n is None else float(J_n)
    if not (math.isfinite(Jn) and Jn > 0):
        raise ManipcadError(f"nominal inertia J_n must be > 0 kg·m², got {Jn}")
    wn, zeta = parse_spec(spec, bandwidth=DEFAULT_BANDWIDTH, damping=DEFAULT_DAMPING,
                          accuracy=True)
    e_max, ref = max_error_of(spec, reference, j)
    plant = nominal_tf(d, Jn, order=order)
    T = d.R * Jn / (d.k_m * d.k_w)
    sce = design_sce(d, plant, T, Jn, order, wn, zeta, period, e_max, ref,
                     feedforward=feedforward, what=f"ace_de on {robot.joint_names[j]!r}")
    p = sce.params
    p[AD_JN], p[AD_FRIC], p[AD_TORQUE] = Jn, float(friction), float(load_torque)
    rho = ((d.J + Hmin / r2) / Jn, (d.J + Hmax / r2) / Jn)
    name = robot.joint_names[j]
    law = (f"ace_de ({name}): {sce.law()} (SCE, "
           f"ω_n = {sce.bandwidth:g} rad/s, ζ = {zeta:g} on the nominal model); law (3): "
           f"U_k = L(Ḣ*+h*+k_v)/(k_m k_u)·i_r·q̈ "
           f"+ [k_w/k_u·(1−ρ) + (R(h*+k_v)+L·ḣ*)/(k_m k_u)]·i_r·q̇ "
           f"+ R/(k_m k_u)·m_f + L/(k_m k_u)·ṁ_f + ρ·U with ρ = (J+H*)/J_n, J_n = {Jn:.6g} kg·m², "
           f"R = {d.R:g} Ω, L = {d.L if order == 3 else 0.0:g} H, k_m = {d.k_m:g} N·m/A, "
           f"k_w = {d.k_w:g} V·s/rad, k_u = {d.k_u:g}, k_v = {d.k_v:g} N·m·s/rad, "
           f"i_r = {d.ratio:g}; h_i = Ḣ_ii; H_ii in [{Hmin:.4g}, {Hmax:.4g}] kg·m² "
           f"(ρ in [{rho[0]:.3g}, {rho[1]:.3g}]); "
           f"|U_k| <= {sce.ulim:g} V, T = {period:g} s")
    signals = ["q", "q_dot", "i", "q_ref", "q_dot_ref", "H_ii", "h_i", "Q_i"]
    if feedforward:
        signals.append("q_ddot_ref")
    complexity = {
        # drive constants J, i_r, k_v, M_f±, R, L, k_m, k_w, k_u, J_n + SCE gains
        "gains_stored": 11 + (4 if feedforward else 2),
        # SCE 5-7, Ḣ/Ḧ differences 9, load torque 4, m_f and ṁ_f 6, q̈ from i 7,
        # law (3) coefficients 20, output 9, clip 2
        "ops_per_period": 62 + (4 if feedforward else 0),
        "signals": signals,
        "period": period,
    }
    design = {"J_n": Jn, "load_range": (Hmin, Hmax), "rho_range": rho, **sce.design(),
              "closed_loop_poles": sce.poles(), "order": order}
    return SynthesizedRegulator(
        joint=j, period=period, kind=KIND_ACE_DE, params=p, name="ace_de",
        needs=tuple(signals), method="ace_de", law=law, complexity=complexity,
        design=design, linear=sce.linear(plant))


def nominal_prediction(reg: SynthesizedRegulator, t, q_ref, qd_ref, qdd_ref=None):
    """The joint trajectory the nominal model predicts under the regulator's SCE.

    Integrates the constant-coefficient nominal model with the same sampled SCE
    (zero-order hold at the regulator's period) by RK4 at the step of ``t``.

    Args:
        reg: an ``ace_de`` (or ``ace_tf``) regulator.
        t: (K,) uniform times, s (a multiple of the period).
        q_ref, qd_ref, qdd_ref: (K,) reference of the joint, rad, rad/s, rad/s².

    Returns:
        (K,) joint positions, rad.
    """
    import numpy as np

    from manipcad.drives.params import P_KM, P_KU, P_KW, P_L, P_R, P_RATIO

    p = reg.params
    t = np.asarray(t, dtype=float)
    dt = float(t[1] - t[0])
    steps = max(1, int(round(reg.period / dt)))
    Jn = reg.design["J_n"]
    r, R, L, km, kw, ku = p[P_RATIO], p[P_R], p[P_L], p[P_KM], p[P_KW], p[P_KU]
    qdd_ref = np.zeros_like(t) if qdd_ref is None else qdd_ref

    def f(x, U):
        q, qd, i = x
        if L > 0:
            di = (ku * U - R * i - kw * r * qd) / L
        else:
            i = (ku * U - kw * r * qd) / R
            di = 0.0
        return np.array([qd, km * i / (Jn * r), di]), i

    x = np.array([q_ref[0], 0.0, 0.0])
    out = np.empty_like(t)
    U = 0.0
    for k in range(len(t)):
        out[k] = x[0]
        if k % steps == 0:
            U = (p[R_KP] * (q_ref[k] - x[0]) + p[R_KD] * (qd_ref[k] - x[1])
                 + p[R_KFV] * qd_ref[k] + p[R_KFA] * qdd_ref[k])
        k1, _ = f(x, U)
        k2, _ = f(x + 0.5 * dt * k1, U)
        k3, _ = f(x + 0.5 * dt * k2, U)
        k4, _ = f(x + dt * k3, U)
        x = x + dt / 6 * (k1 + 2 * k2 + 2 * k3 + k4)
        if L == 0:
            x[2] = 0.0
    return out
