"""Packed drive parameters: the one float array the compiled drive kernels read.

A :class:`~manipcad.model.robot.Drive` (motor, amplifier, gearbox) and an
optional :class:`Transmission` (elasticity, backlash) are packed into a
float64 vector ``p`` of length :data:`NPAR` by :func:`pack_drive`; a robot's
drives into an ``(n, NPAR)`` table by :func:`pack_drives`. Every kernel in
:mod:`manipcad.drives.dc`, :mod:`manipcad.drives.transmission` and
:mod:`manipcad.drives.laws` takes such a ``p``, so numba sees plain floats and
arrays, never Python objects.

Layout of ``p`` (index constant: meaning, unit)::

    P_KIND   drive kind, one of KIND_* below (stored as a float)
    P_J      rotor + gearbox inertia on the motor shaft J, kg·m²
    P_RATIO  gear ratio i_r = motor angle / joint coordinate, rad/rad (rad/m)
    P_KV     viscous friction on the motor shaft k_v, N·m·s/rad
    P_MFP    dry friction M_f for positive joint-direction motion, N·m (motor side)
    P_MFN    dry friction M_f for negative joint-direction motion, N·m (motor side)
    P_R      armature resistance R, Ω
    P_L      armature inductance L, H (0 for the 2nd-order kinds)
    P_KM     torque constant k_m, N·m/A
    P_KW     back-EMF constant k_w, V·s/rad
    P_KU     amplifier gain k_u, V/V
    P_UMAX   limit of the amplifier OUTPUT voltage k_u·U, V (inf: no limit)
    P_KS     transmission stiffness k_s, joint side, N·m/rad (N/m)
    P_DS     transmission damping d_s, joint side, N·m·s/rad (N·s/m)
    P_GAP    backlash half-width b, joint side, rad (m); the gap is 2·b wide
    P_WEPS   dry-friction linear zone on the motor speed, rad/s (0: pure sign)

Drive kinds and their drive states (see docs/drive-equations.md)::

    KIND_NONE            0  no drive                       states: none
    KIND_RIGID           1  rigid gear, L > 0              states: (i,)
    KIND_RIGID_STATIC    2  rigid gear, L neglected        states: none (i algebraic)
    KIND_ELASTIC         3  spring/backlash gear, L > 0    states: (θ_m, ω_m, i)
    KIND_ELASTIC_STATIC  4  spring/backlash gear, L = 0    states: (θ_m, ω_m)

Which quantity saturates: the amplifier takes the control signal U (V) and
puts out the armature voltage ``u_a = k_u·U``; its OUTPUT is limited,
``u_a = clip(k_u·U, -u_max, +u_max)`` (``Drive.u_max`` is the edge of the
linear zone in volts at the armature). The equivalent input limit is
``u_max / k_u``.

Which friction value applies: ``M_f`` is a pair (positive, negative motion)
named after the JOINT direction, as in the joint-referred model table
(``COL_FCP = |i_r|·M_f+`` for ``qd > 0``). On the motor shaft the positive
value is used when ``sign(ω_m·i_r) > 0``; for ``i_r > 0`` this is plain
positive motor motion.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np

from manipcad.errors import ModelError
from manipcad.model.robot import Drive

P_KIND = 0
P_J = 1
P_RATIO = 2
P_KV = 3
P_MFP = 4
P_MFN = 5
P_R = 6
P_L = 7
P_KM = 8
P_KW = 9
P_KU = 10
P_UMAX = 11
P_KS = 12
P_DS = 13
P_GAP = 14
P_WEPS = 15
NPAR = 16

KIND_NONE = 0
KIND_RIGID = 1
KIND_RIGID_STATIC = 2
KIND_ELASTIC = 3
KIND_ELASTIC_STATIC = 4

#: the layout of ``p`` by name, each key with its unit (as regulator files write a drive):
#: key -> index
PACKED_FIELDS = {
    "kind": P_KIND, "J_kgm2": P_J, "ratio": P_RATIO, "k_v_Nms_per_rad": P_KV,
    "M_f_pos_Nm": P_MFP, "M_f_neg_Nm": P_MFN, "R_ohm": P_R, "L_H": P_L,
    "k_m_Nm_per_A": P_KM, "k_w_Vs_per_rad": P_KW, "k_u": P_KU, "u_max_V": P_UMAX,
    "k_s_Nm_per_rad": P_KS, "d_s_Nms_per_rad": P_DS, "backlash_rad": P_GAP,
    "friction_zone_rad_per_s": P_WEPS,
}

#: number of drive states of each kind (index = kind)
KIND_STATES = (0, 1, 0, 3, 2)
#: names of the drive states of each kind, in state order
KIND_STATE_NAMES = ((), ("i",), (), ("theta_m", "omega_m", "i"), ("theta_m", "omega_m"))


@dataclass(frozen=True)
class Transmission:
    """An elastic transmission with optional backlash between motor and joint.

    The gear output angle is ``θ_m / i_r`` (joint side); the deflection is
    ``δ = θ_m / i_r - q`` and the torque passed to the joint is

    - no backlash (``backlash == 0``): ``τ_s = k_s·δ + d_s·δ̇``;
    - backlash ``b > 0`` (dead zone of width ``2·b``): ``τ_s = 0`` while
      ``|δ| <= b``; in contact ``τ_s = k_s·dz(δ, b) + d_s·δ̇``, limited so that
      the contact only pushes (``τ_s >= 0`` for ``δ > b``, ``<= 0`` for
      ``δ < -b``; a damper cannot glue the teeth together).

    Attributes:
        stiffness: k_s, joint-side torsional stiffness, N·m/rad (N/m for a
            prismatic joint); > 0 and finite.
        damping: d_s, joint-side damping, N·m·s/rad (N·s/m); >= 0.
        backlash: b, half of the gap, joint side, rad (m); >= 0.

    Example:
        >>> from manipcad.drives.params import Transmission
        >>> Transmission(stiffness=2.0e4, damping=5.0, backlash=1e-3).backlash
        0.001
    """

    stiffness: float
    damping: float = 0.0
    backlash: float = 0.0

    def __post_init__(self) -> None:
        for name in ("stiffness", "damping", "backlash"):
            object.__setattr__(self, name, float(getattr(self, name)))
        if not (math.isfinite(self.stiffness) and self.stiffness > 0):
            raise ModelError(f"transmission stiffness must be > 0 and finite, got {self.stiffness}")
        if not (math.isfinite(self.damping) and self.damping >= 0):
            raise ModelError(f"transmission damping must be >= 0 and finite, got {self.damping}")
        if not (math.isfinite(self.backlash) and self.backlash >= 0):
            raise ModelError(f"transmission backlash must be >= 0 and finite, got {self.backlash}")


def as_transmission(
    elasticity: Transmission | tuple[float, float] | float | None,
    backlash: float | None = None,
) -> Transmission | None:
    """Build a :class:`Transmission` from the loose forms the API accepts.

    Args:
        elasticity: None (rigid), a :class:`Transmission`, a stiffness k_s
            (N·m/rad) or a pair (k_s N·m/rad, d_s N·m·s/rad).
        backlash: half-width b of the gap, rad (joint side), or None. A gap
            needs a contact stiffness, so it needs ``elasticity``.

    Returns:
        The transmission, or None for a rigid gear.

    Raises:
        ModelError: backlash without elasticity, or non-physical values.

    Example:
        >>> from manipcad.drives.params import as_transmission
        >>> as_transmission((1e4, 2.0), backlash=0.002)
        Transmission(stiffness=10000.0, damping=2.0, backlash=0.002)
    """
    if elasticity is None:
        if backlash:
            raise ModelError("backlash needs a contact stiffness: give elasticity=(k_s, d_s) too")
        return None
    if isinstance(elasticity, Transmission):
        t = elasticity
        if backlash is not None:
            t = Transmission(t.stiffness, t.damping, backlash)
        return t
    if np.ndim(elasticity) == 0:
        k_s, d_s = float(elasticity), 0.0
    else:
        vals = tuple(float(v) for v in elasticity)  # type: ignore[union-attr]
        if len(vals) != 2:
            raise ModelError("elasticity must be k_s or a pair (k_s, d_s)")
        k_s, d_s = vals
    return Transmission(k_s, d_s, 0.0 if backlash is None else backlash)


def drive_transmission(drive: Drive | None) -> Transmission | None:
    """The transmission a drive describes itself (``Drive.stiffness``,
    ``damping``, ``backlash``, joint side), or None for a rigid gear.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> drive_transmission(Drive(stiffness=2e4, backlash=1e-4))
        Transmission(stiffness=20000.0, damping=0.0, backlash=0.0001)
        >>> drive_transmission(Drive()) is None
        True
    """
    if drive is None or not drive.elastic:
        return None
    return Transmission(drive.stiffness, drive.damping, drive.backlash)


def check_electrics(drive: Drive, *, need_L: bool) -> None:
    """Raise :class:`ModelError` unless the drive's electrical data are usable.

    Args:
        drive: the drive.
        need_L: True when the armature inductance enters the model (3rd order).
    """
    for name in ("R", "k_m", "k_w"):
        v = float(getattr(drive, name))
        if not (math.isfinite(v) and v > 0):
            raise ModelError(f"drive {drive.name or ''!r}: {name} must be > 0 and finite "
                             f"to model the motor, got {v}")
    if not (math.isfinite(drive.k_u) and drive.k_u > 0):
        raise ModelError(f"drive {drive.name or ''!r}: k_u must be > 0, got {drive.k_u}")
    if need_L and not (math.isfinite(drive.L) and drive.L > 0):
        raise ModelError(f"drive {drive.name or ''!r}: L must be > 0 for the 3rd-order model "
                         f"(got {drive.L}); use order=2 to neglect it")
    if not math.isfinite(drive.J) or drive.J < 0 or not math.isfinite(drive.k_v):
        raise ModelError(f"drive {drive.name or ''!r}: J and k_v must be finite and >= 0")


def pack_drive(
    drive: Drive | None,
    transmission: Transmission | None = None,
    *,
    order: int = 3,
    friction_eps: float = 0.0,
) -> np.ndarray:
    """Pack one drive into the parameter vector ``p`` the kernels read.

    Args:
        drive: the drive, or None (kind ``KIND_NONE``, all zeros).
        transmission: elasticity/backlash between motor and joint, or None for
            a rigid gear.
        order: 3 keeps the armature inductance (current is a state), 2
            neglects it (the current follows the voltage at once). A drive
            with ``L == 0`` is always order 2.
        friction_eps: linear zone of the dry friction on the motor speed,
            rad/s; 0 for the pure ``sign`` law (used only by the kernels that
            carry the motor's own speed: elastic kinds and the standalone model).

    Returns:
        float64 array of shape (NPAR,); see the module docstring for the layout.

    Raises:
        ModelError: missing or non-physical electrical data, bad order.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.params import pack_drive, P_KIND, KIND_RIGID
        >>> d = Drive(J=2e-4, ratio=60, R=2.1, L=1e-3, k_m=0.228, k_w=0.228, k_u=10)
        >>> int(pack_drive(d)[P_KIND]) == KIND_RIGID
        True
    """
    p = np.zeros(NPAR)
    if drive is None:
        return p
    if order not in (2, 3):
        raise ModelError(f"drive model order must be 2 or 3, got {order}")
    static = order == 2 or (math.isfinite(drive.L) and drive.L == 0.0)
    check_electrics(drive, need_L=not static)
    if not (math.isfinite(friction_eps) and friction_eps >= 0):
        raise ModelError(f"friction_eps must be >= 0 rad/s, got {friction_eps}")
    if transmission is None:
        kind = KIND_RIGID_STATIC if static else KIND_RIGID
    else:
        kind = KIND_ELASTIC_STATIC if static else KIND_ELASTIC
        p[P_KS] = transmission.stiffness
        p[P_DS] = transmission.damping
        p[P_GAP] = transmission.backlash
    p[P_KIND] = kind
    p[P_J] = drive.J
    p[P_RATIO] = drive.ratio
    p[P_KV] = drive.k_v
    p[P_MFP], p[P_MFN] = drive.M_f
    p[P_R] = drive.R
    p[P_L] = 0.0 if static else drive.L
    p[P_KM] = drive.k_m
    p[P_KW] = drive.k_w
    p[P_KU] = drive.k_u
    p[P_UMAX] = drive.u_max
    p[P_WEPS] = friction_eps
    return p


def pack_drives(
    drives: Sequence[Drive | None],
    transmissions: Sequence[Transmission | None] | None = None,
    *,
    order: int = 3,
    friction_eps: float = 0.0,
) -> np.ndarray:
    """Pack a robot's drives into an ``(n, NPAR)`` table (one row per joint).

    Args:
        drives: one drive or None per joint (``robot.drives``).
        transmissions: one transmission or None per joint; where None (or
            for all joints when ``transmissions`` is None) the drive's own
            (:func:`drive_transmission`: rigid unless the drive has a finite
            stiffness) is used.
        order: 3 or 2, as in :func:`pack_drive`.
        friction_eps: dry-friction linear zone, rad/s, as in :func:`pack_drive`.

    Returns:
        float64 array (n, NPAR).

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.params import pack_drives
        >>> d = Drive(J=2e-4, ratio=60, R=2.1, L=1e-3, k_m=0.228, k_w=0.228)
        >>> pack_drives([d, None]).shape
        (2, 16)
    """
    n = len(drives)
    trs = [None] * n if transmissions is None else list(transmissions)
    if len(trs) != n:
        raise ModelError(f"{len(trs)} transmissions for {n} drives")
    trs = [drive_transmission(d) if t is None else t for d, t in zip(drives, trs, strict=True)]
    table = np.zeros((n, NPAR))
    for j, (d, t) in enumerate(zip(drives, trs, strict=True)):
        table[j] = pack_drive(d, t, order=order, friction_eps=friction_eps)
    return table


def state_offsets(table: np.ndarray) -> np.ndarray:
    """Offsets of each joint's drive states in the stacked drive-state vector.

    Args:
        table: (n, NPAR) packed drives.

    Returns:
        int64 array of shape (n + 1,): joint j's states are
        ``xd[off[j]:off[j + 1]]``; ``off[n]`` is the total count.

    Example:
        >>> import numpy as np
        >>> from manipcad.drives.params import state_offsets, NPAR, P_KIND
        >>> t = np.zeros((3, NPAR)); t[:, P_KIND] = [1, 3, 0]
        >>> state_offsets(t).tolist()
        [0, 1, 4, 4]
    """
    kinds = np.asarray(table)[:, P_KIND].astype(np.int64)
    counts = np.array([KIND_STATES[k] for k in kinds], dtype=np.int64)
    return np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)


def joint_referred_terms(table: np.ndarray) -> np.ndarray:
    """The drive terms the rigid-body dynamics must add on the joint side.

    For a rigid gear (kinds 1, 2) the rotor inertia, viscous and dry friction
    move with the joint and are added to the multibody model as ``J·i_r²`` on
    the diagonal of H, ``k_v·i_r²·qd`` and ``|i_r|·M_f·sign(qd)`` (the
    ``drives=True`` columns of :attr:`Robot.table`). For an elastic gear
    (kinds 3, 4) those terms live on the motor states instead and the joint
    side must NOT add them; this function returns zeros for such joints.

    Args:
        table: (n, NPAR) packed drives.

    Returns:
        (n, 4) array: ``J·i_r²`` (kg·m²), ``k_v·i_r²`` (N·m·s/rad),
        ``|i_r|·M_f+`` and ``|i_r|·M_f-`` (N·m).

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.params import pack_drives, joint_referred_terms
        >>> d = Drive(J=1e-4, ratio=10, R=1, L=1e-3, k_m=.1, k_w=.1)
        >>> joint_referred_terms(pack_drives([d]))[0].tolist()
        [0.01, 0.0, 0.0, 0.0]
    """
    t = np.asarray(table, dtype=float)
    rigid = np.isin(t[:, P_KIND].astype(np.int64), (KIND_RIGID, KIND_RIGID_STATIC))
    r = t[:, P_RATIO]
    out = np.stack([t[:, P_J] * r**2, t[:, P_KV] * r**2,
                    np.abs(r) * t[:, P_MFP], np.abs(r) * t[:, P_MFN]], axis=1)
    out[~rigid] = 0.0
    return out
