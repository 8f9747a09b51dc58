"""The regulator interface of the closed-loop simulator, and the PID regulator.

A regulator controls one joint (decentralized control, as in the paper). It is
sampled every ``period`` seconds (digital control, zero-order hold between
samples). At a sample the simulator fills a signal vector ``sig`` (indices
``S_*`` below: time, reference, measured state, armature current and the
current moment constituents H_ii, h_i, Q_i of the joint, the motor angle
and speed) and calls the
compiled :func:`regulator_update` with the regulator's kind, its parameter
vector and its own state vector; the returned value is held until the next
sample. With a drive it is the amplifier input U (V); on a joint without a
drive (or with ``drives=False``) it is the joint torque (N·m or N).

To add a method (the synthesis issue does): give it a new ``KIND_*`` code,
write its compiled update below and dispatch to it in :func:`regulator_update`,
and a :class:`Regulator` subclass that packs its parameters. The synthesis
methods' updates live in :mod:`manipcad.synthesis.kernels` and are imported at
the end of this module (they read the signal indices defined here).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numba as nb
import numpy as np

from manipcad.errors import ManipcadError

# signal vector filled by the simulator at every sample of a joint's regulator
# (S_THM, S_WM: motor angle θ_m rad and speed ω_m rad/s; i_r·q and i_r·q̇ on a rigid gear)
S_T, S_QREF, S_QDREF, S_QDDREF, S_Q, S_QD, S_I, S_HII, S_HI, S_QI, S_THM, S_WM = range(12)
NSIG = 12
#: parameter and state vector lengths every regulator is packed to (the
#: synthesis methods need room for the packed drive and a gain table)
NPARAM = 256
NSTATE = 16

KIND_NONE = 0
KIND_PID = 1

# PID parameters
PID_KP, PID_KI, PID_KD, PID_ULIM, PID_FF = 0, 1, 2, 3, 4
# PID state
PID_INT = 0


@nb.njit(cache=True)
def pid_update(p, s, sig, Ts):
    """PID on the error e = q_ref - q with velocity error ė = q̇_ref - q̇.

    u = k_p·e + k_i·∫e dt + k_d·ė (+ k_ff·q̇_ref), clipped to ±u_lim; the
    integral stops growing while the output is clipped (anti-windup).
    """
    e = sig[S_QREF] - sig[S_Q]
    ed = sig[S_QDREF] - sig[S_QD]
    integ = s[PID_INT] + e * Ts
    u = p[PID_KP] * e + p[PID_KI] * integ + p[PID_KD] * ed + p[PID_FF] * sig[S_QDREF]
    lim = p[PID_ULIM]
    if u > lim:
        u = lim
    elif u < -lim:
        u = -lim
    else:
        s[PID_INT] = integ
    return u


@nb.njit(cache=True)
def regulator_update(kind, p, s, sig, Ts):
    """One control period of a regulator of the given kind; returns its output."""
    if kind == KIND_PID:
        return pid_update(p, s, sig, Ts)
    if kind == KIND_ACE_DE:
        return ace_de_update(p, s, sig, Ts)
    if kind == KIND_ACE_TF:
        return ace_tf_update(p, s, sig, Ts)
    if kind == KIND_ASVS:
        return asvs_update(p, s, sig, Ts)
    if kind == KIND_LQR:
        return lqr_update(p, s, sig, Ts)
    if kind == KIND_CT:
        return computed_torque_update(p, s, sig, Ts)
    if kind == KIND_SCE:
        return sce_update(p, s, sig, Ts)
    return 0.0


@dataclass
class Regulator:
    """A sampled regulator of one joint.

    Attributes:
        joint: the joint index it drives (set by the simulator from ``joint_name`` if given).
        period: sampling period, s.
        kind: the compiled law's code (``KIND_*``).
        params: parameter vector (length ``NPARAM``), meaning set by the kind.
        name: method name, e.g. "pid".
        needs: signals the law reads, in words (for the realization complexity).
    """

    joint: int | str
    period: float = 1e-3
    kind: int = KIND_NONE
    params: np.ndarray = field(default_factory=lambda: np.zeros(NPARAM))
    name: str = "none"
    needs: tuple[str, ...] = ()

    def describe(self) -> str:
        """The law with its numbers filled in."""
        return f"{self.name}: no control (U = 0)"

    def initial_state(self) -> np.ndarray:
        """The regulator's state at t = 0 (length ``NSTATE``)."""
        return np.zeros(NSTATE)


def pid(joint: int | str, *, kp: float, ki: float = 0.0, kd: float = 0.0,
        period: float = 1e-3, u_limit: float = math.inf, kff: float = 0.0) -> Regulator:
    """A PID regulator of one joint, on the position error.

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
        A :class:`Regulator` of kind ``KIND_PID``.

    Example:
        >>> from manipcad.sim import pid
        >>> reg = pid("q1", kp=200.0, kd=5.0, period=1e-3)
        >>> reg.describe()
        'pid: U = 200·e + 0·∫e + 5·ė + 0·q̇_ref (|U| ≤ inf), T = 0.001 s'
    """
    for name, v in (("kp", kp), ("ki", ki), ("kd", kd), ("kff", kff)):
        if not math.isfinite(v):
            raise ManipcadError(f"pid {name} must be finite, got {v}")
    if not (period > 0 and math.isfinite(period)):
        raise ManipcadError(f"pid period must be > 0 s, got {period}")
    if not u_limit > 0:
        raise ManipcadError(f"pid u_limit must be > 0, got {u_limit}")
    p = np.zeros(NPARAM)
    p[PID_KP], p[PID_KI], p[PID_KD], p[PID_ULIM], p[PID_FF] = kp, ki, kd, u_limit, kff
    return _PID(joint=joint, period=float(period), kind=KIND_PID, params=p, name="pid",
                needs=("q", "q_dot", "q_ref", "q_dot_ref"))


class _PID(Regulator):
    def describe(self) -> str:
        p = self.params
        return (f"pid: U = {p[PID_KP]:g}·e + {p[PID_KI]:g}·∫e + {p[PID_KD]:g}·ė + "
                f"{p[PID_FF]:g}·q̇_ref (|U| ≤ {p[PID_ULIM]:g}), T = {self.period:g} s")


# the synthesis methods' compiled updates (imported last: they read the S_* above)
from manipcad.synthesis.kernels import (  # noqa: E402
    KIND_ACE_DE,
    KIND_ACE_TF,
    KIND_ASVS,
    KIND_CT,
    KIND_LQR,
    KIND_SCE,
    ace_de_update,
    ace_tf_update,
    asvs_update,
    computed_torque_update,
    lqr_update,
    sce_update,
)
