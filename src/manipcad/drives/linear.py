"""Linear models of one drive at a frozen load, as python-control objects.

The load seen by joint i is frozen at ``H_ii`` (kg·m², joint side) and
``h_i`` (N·m·s/rad, joint side); referred to the motor it is
``H* = H_ii/i_r²`` and ``h* = h_i/i_r²`` (paper 3.1). Dry friction, the
amplifier limit and the backlash gap are left out of the linear model (they
are the F(ε) and W of the paper's (6)); a transmission with backlash is
linearized in contact.

Time constants and gains (paper, section 3.1)::

    T_m = (H* + J)·R / [(h* + k_v)·R + k_m·k_w]      mechanical time constant, s
    k_p = k_m / [(h* + k_v)·R + k_m·k_w]              speed per armature volt, rad/(V·s)
    T_e = L / R                                        electrical time constant, s

The drive's static speed gain from the amplifier INPUT U is ``k_u·k_p``.
The 2nd-order model (L neglected) is good when ``(H*+J)·R >> (h*+k_v)·L``
and ``T_m >> T_e``: :func:`inductance_ratio` and ``T_m/T_e`` say by how much.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from manipcad._lazy import ct
from manipcad.drives.params import Transmission, as_transmission, check_electrics
from manipcad.errors import ModelError
from manipcad.model.robot import Drive


def _load(drive: Drive, H_ii: float, h_i: float) -> tuple[float, float]:
    H_ii, h_i = float(H_ii), float(h_i)
    if not (math.isfinite(H_ii) and H_ii >= 0):
        raise ModelError(f"load inertia H_ii must be >= 0 and finite, got {H_ii}")
    if not math.isfinite(h_i):
        raise ModelError(f"load velocity coefficient h_i must be finite, got {h_i}")
    r2 = drive.ratio**2
    return H_ii / r2, h_i / r2


def _damped_load(drive: Drive, H_ii: float, h_i: float) -> tuple[float, float]:
    """(H*, (h* + k_v)·R + k_m·k_w); refuses an undamped drive (the latter <= 0)."""
    check_electrics(drive, need_L=False)
    Hs, hs = _load(drive, H_ii, h_i)
    den = (hs + drive.k_v) * drive.R + drive.k_m * drive.k_w
    if den <= 0:
        raise ModelError(f"(h*+k_v)·R + k_m·k_w = {den} <= 0: the drive is not damped")
    return Hs, den


def referred_load(drive: Drive, H_ii: float = 0.0, h_i: float = 0.0) -> tuple[float, float]:
    """The load referred to the motor shaft: (H*, h*) = (H_ii/i_r², h_i/i_r²).

    Args:
        drive: the drive (its ratio i_r).
        H_ii: joint-side inertia, kg·m² (kg for a prismatic joint).
        h_i: joint-side velocity coefficient, N·m·s/rad (N·s/m).

    Returns:
        (H* kg·m², h* N·m·s/rad), motor side.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.linear import referred_load
        >>> referred_load(Drive(ratio=10.0), 2.0, 0.5)
        (0.02, 0.005)
    """
    return _load(drive, H_ii, h_i)


def inertia_ratio(drive: Drive, H_min, H_max):
    """How much the inertia the drive moves changes over a load range, joint side:
    ρ = (J·i_r² + H_max)/(J·i_r² + H_min), -.

    Args:
        drive: the drive (J, i_r).
        H_min, H_max: the least and largest joint-side inertia H_ii, kg·m² (kg); floats
            or arrays that broadcast.

    Returns:
        ρ >= 1 for H_max >= H_min.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.linear import inertia_ratio
        >>> inertia_ratio(Drive(J=1e-4, ratio=10.0), 0.01, 0.03)     # (0.01 + 0.03)/(0.01 + 0.01)
        2.0
    """
    rotor = drive.reflected_inertia
    return (rotor + H_max) / (rotor + H_min)


def mechanical_time_constant(drive: Drive, H_ii: float = 0.0, h_i: float = 0.0) -> float:
    """T_m = (H* + J)·R / [(h* + k_v)·R + k_m·k_w], s.

    Args:
        drive, H_ii, h_i: the drive and its frozen joint-side load, as in
            :func:`referred_load`.

    Returns:
        T_m, s.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.linear import mechanical_time_constant
        >>> d = Drive(J=1e-4, ratio=10, R=1.0, L=1e-3, k_m=0.1, k_w=0.1)
        >>> round(mechanical_time_constant(d, H_ii=0.01), 9)    # (1e-4+1e-4)·1/0.01
        0.02
    """
    Hs, den = _damped_load(drive, H_ii, h_i)
    return (Hs + drive.J) * drive.R / den


def drive_gain(drive: Drive, H_ii: float = 0.0, h_i: float = 0.0) -> float:
    """k_p = k_m / [(h* + k_v)·R + k_m·k_w]: steady motor speed per armature volt.

    The speed per volt of amplifier INPUT is ``k_u·k_p``.

    Args:
        drive: the drive.
        H_ii: joint-side load inertia, kg·m² (does not enter k_p).
        h_i: joint-side velocity coefficient, N·m·s/rad.

    Returns:
        k_p, rad/(V·s).

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.linear import drive_gain
        >>> round(drive_gain(Drive(R=1.0, L=1e-3, k_m=0.1, k_w=0.1)), 12)   # 1/k_w without friction
        10.0
    """
    _, den = _damped_load(drive, H_ii, h_i)
    return drive.k_m / den


def electrical_time_constant(drive: Drive) -> float:
    """T_e = L / R, s.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.linear import electrical_time_constant
        >>> electrical_time_constant(Drive(R=2.0, L=1e-3, k_m=.1, k_w=.1))
        0.0005
    """
    check_electrics(drive, need_L=True)
    return drive.L / drive.R


def inductance_ratio(drive: Drive, H_ii: float = 0.0, h_i: float = 0.0) -> float:
    """The paper's check ``(H*+J)·R >> (h*+k_v)·L`` as the ratio of its sides.

    Args:
        drive, H_ii, h_i: the drive and its frozen joint-side load, as in
            :func:`referred_load`.

    Returns:
        (H*+J)·R / ((h*+k_v)·L), dimensionless (inf when h* + k_v = 0). A value
        of 100 means the inductance changes the linear term of the drive's
        characteristic polynomial by 1 %.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.linear import inductance_ratio
        >>> d = Drive(J=1e-4, k_v=1e-4, R=1.0, L=1e-3, k_m=.1, k_w=.1)
        >>> round(inductance_ratio(d), 6)
        1000.0
    """
    check_electrics(drive, need_L=True)
    Hs, hs = _load(drive, H_ii, h_i)
    den = (hs + drive.k_v) * drive.L
    return math.inf if den == 0 else (Hs + drive.J) * drive.R / den


@dataclass(frozen=True)
class DriveLinearization:
    """A drive linearized at a frozen load.

    Attributes:
        ss: StateSpace from the amplifier input U (V) to the joint angle q (rad).
        tf: the same as a TransferFunction, rad/V.
        ss_full: StateSpace with inputs (U V, τ_l N·m joint-side load torque)
            and every state as an output.
        states: state names in order (``q``, ``qd``, then ``theta_m``,
            ``omega_m`` for an elastic gear, then ``i`` for order 3).
        order: 3 (current is a state) or 2 (L neglected).
        H_star: load inertia referred to the motor, kg·m².
        h_star: velocity coefficient referred to the motor, N·m·s/rad.
        T_m: mechanical time constant (rigid gear), s.
        k_p: speed gain per armature volt, rad/(V·s).
        T_e: electrical time constant L/R, s (nan if L is unknown or 0).
        inductance_ratio: (H*+J)·R / ((h*+k_v)·L) (nan if L is unknown or 0).
        transmission: the elastic transmission, or None.
    """

    ss: ct.StateSpace
    tf: ct.TransferFunction
    ss_full: ct.StateSpace
    states: tuple[str, ...]
    order: int
    H_star: float
    h_star: float
    T_m: float
    k_p: float
    T_e: float
    inductance_ratio: float
    transmission: Transmission | None

    @property
    def time_constant_ratio(self) -> float:
        """T_m / T_e, dimensionless (the paper asks T_m >> L/R)."""
        return self.T_m / self.T_e if self.T_e > 0 else math.inf

    @property
    def A(self) -> np.ndarray:
        """State matrix, (nx, nx)."""
        return np.asarray(self.ss.A)

    @property
    def B(self) -> np.ndarray:
        """Input column for U, (nx, 1), per volt."""
        return np.asarray(self.ss.B)

    @property
    def B_load(self) -> np.ndarray:
        """Input column for the joint-side load torque τ_l, (nx, 1), per N·m."""
        return np.asarray(self.ss_full.B)[:, 1:2]


def linearize(
    drive: Drive,
    H_ii: float = 0.0,
    h_i: float = 0.0,
    *,
    order: int = 3,
    backlash: float | None = None,
    elasticity: Transmission | tuple[float, float] | float | None = None,
) -> DriveLinearization:
    """Linear model of one drive from U to q at a frozen load.

    Rigid gear, joint side (J_q = H_ii + J·i_r², b_q = h_i + k_v·i_r²)::

        order 3: x = (q, q̇, i)
            J_q·q̈ = i_r·k_m·i - b_q·q̇ - τ_l,   L·di/dt = k_u·U - R·i - k_w·i_r·q̇
            q/U = k_u·k_m·i_r / (s·[L·J_q·s² + (R·J_q + L·b_q)·s + R·b_q + i_r²·k_m·k_w])
        order 2: x = (q, q̇), i = (k_u·U - k_w·i_r·q̇)/R
            q/U = k_u·k_m·i_r / (s·[R·J_q·s + R·b_q + i_r²·k_m·k_w])
              = k_u·k_p / (i_r·s·(T_m·s + 1))

    Elastic gear (``elasticity`` given): x = (q, q̇, θ_m, ω_m[, i]) with
    ``H_ii·q̈ + h_i·q̇ + τ_l = τ_s``, ``J·ω̇_m + k_v·ω_m = k_m·i - τ_s/i_r`` and
    ``τ_s = k_s·(θ_m/i_r - q) + d_s·(ω_m/i_r - q̇)`` (in contact; the gap is
    left to :func:`manipcad.drives.transmission.backlash_residual`).

    Args:
        drive: the drive (R, k_m, k_w > 0; L > 0 for order 3).
        H_ii: joint-side load inertia, kg·m² (kg); > 0 for an elastic gear.
        h_i: joint-side velocity coefficient, N·m·s/rad (N·s/m).
        order: 3 (with L) or 2 (L neglected).
        backlash: half-width b of the gap, rad (needs ``elasticity``).
        elasticity: a :class:`Transmission`, k_s (N·m/rad) or (k_s, d_s).

    Returns:
        :class:`DriveLinearization` with ``.ss``, ``.tf``, ``.ss_full``,
        ``.T_m``, ``.k_p``, ``.T_e``, ``.inductance_ratio``.

    Raises:
        ModelError: missing/non-physical data, bad order, or an elastic gear
            with H_ii = 0 or J = 0.

    Example:
        >>> from manipcad.model.robot import Drive
        >>> from manipcad.drives.linear import linearize
        >>> d = Drive(J=2e-4, ratio=62.6, k_v=1.5e-3, R=2.1, L=1e-3, k_m=.228, k_w=.228, k_u=10)
        >>> lin = linearize(d, H_ii=2.0, h_i=0.0)
        >>> lin.states, round(lin.T_m, 4)
        (('q', 'qd', 'i'), 0.0271)
        >>> lin.tf.poles().size
        3
    """
    if order not in (2, 3):
        raise ModelError(f"drive model order must be 2 or 3, got {order}")
    check_electrics(drive, need_L=order == 3)
    tr = as_transmission(elasticity, backlash)
    Hs, hs = _load(drive, H_ii, h_i)
    r = float(drive.ratio)
    J, kv, R, km, kw, ku = drive.J, drive.k_v, drive.R, drive.k_m, drive.k_w, drive.k_u
    L = drive.L if order == 3 else 0.0
    H_ii, h_i = float(H_ii), float(h_i)

    if tr is None:
        Jq = H_ii + J * r * r
        bq = h_i + kv * r * r
        if Jq <= 0:
            raise ModelError("H_ii + J·i_r² must be > 0 for a rigid drive")
        if order == 3:
            A = [[0, 1, 0], [0, -bq / Jq, r * km / Jq], [0, -kw * r / L, -R / L]]
            B = [[0, 0], [0, -1 / Jq], [ku / L, 0]]
            states = ("q", "qd", "i")
            den = [L * Jq, R * Jq + L * bq, R * bq + r * r * km * kw, 0.0]
        else:
            A = [[0, 1], [0, -(bq + r * r * km * kw / R) / Jq]]
            B = [[0, 0], [r * km * ku / (R * Jq), -1 / Jq]]
            states = ("q", "qd")
            den = [R * Jq, R * bq + r * r * km * kw, 0.0]
        tf = ct.tf([ku * km * r], den, inputs="U", outputs="q")
    else:
        if H_ii <= 0 or J <= 0:
            raise ModelError("an elastic transmission needs H_ii > 0 and J > 0 "
                             "(a mass on each side of the spring)")
        ks, ds = tr.stiffness, tr.damping
        # rows: q, qd, theta_m, omega_m [, i]; tau_s = ks(th/r - q) + ds(w/r - qd)
        ts = np.array([-ks, -ds, ks / r, ds / r])  # tau_s = ts · (q, qd, th, w)
        a_qdd = ts / H_ii - np.array([0, h_i / H_ii, 0, 0])
        a_wd = -ts / (r * J) - np.array([0, 0, 0, kv / J])
        if order == 3:
            A = np.zeros((5, 5))
            A[0, 1] = 1
            A[1, :4] = a_qdd
            A[2, 3] = 1
            A[3, :4] = a_wd
            A[3, 4] = km / J
            A[4, 3] = -kw / L
            A[4, 4] = -R / L
            B = np.zeros((5, 2))
            B[4, 0] = ku / L
            states = ("q", "qd", "theta_m", "omega_m", "i")
        else:
            A = np.zeros((4, 4))
            A[0, 1] = 1
            A[1, :] = a_qdd
            A[2, 3] = 1
            A[3, :] = a_wd
            A[3, 3] -= km * kw / (R * J)
            B = np.zeros((4, 2))
            B[3, 0] = km * ku / (R * J)
            states = ("q", "qd", "theta_m", "omega_m")
        B[1, 1] = -1 / H_ii
        tf = None
    A = np.asarray(A, dtype=float)
    B = np.asarray(B, dtype=float)
    nx = A.shape[0]
    ss_full = ct.ss(A, B, np.eye(nx), np.zeros((nx, 2)), inputs=["U", "tau_load"],
                    outputs=list(states), states=list(states))
    C = np.zeros((1, nx))
    C[0, 0] = 1.0
    ss = ct.ss(A, B[:, :1], C, [[0.0]], inputs=["U"], outputs=["q"], states=list(states))
    if tf is None:
        tf = ct.ss2tf(ss, inputs="U", outputs="q")

    den_m = (hs + kv) * R + km * kw
    T_m = (Hs + J) * R / den_m if den_m > 0 else math.inf
    k_p = km / den_m if den_m > 0 else math.inf
    has_L = math.isfinite(drive.L) and drive.L > 0
    T_e = drive.L / R if has_L else math.nan
    if has_L:
        d_l = (hs + kv) * drive.L
        ratio_l = math.inf if d_l == 0 else (Hs + J) * R / d_l
    else:
        ratio_l = math.nan
    return DriveLinearization(ss=ss, tf=tf, ss_full=ss_full, states=states, order=order,
                              H_star=Hs, h_star=hs, T_m=T_m, k_p=k_p, T_e=T_e,
                              inductance_ratio=ratio_l, transmission=tr)
