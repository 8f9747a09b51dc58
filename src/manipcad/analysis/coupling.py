"""Coupling analysis: how far each drive's torque is from the decoupled form (paper section 2).

The paper writes the drive torque of joint i as P_i = H_ii q̈_i + h_i + Q_i + M_i
and recommends choosing kinematic schemes or mechanical devices
(counterweights, springs) that decouple the drives "where it is possible", so
that P_i takes the simplest form P_i = H_ii q̈_i + M_i, with H_ii changing only
with the gripped mass. Along a trajectory this module measures, per joint:

- the own inertial constituent H_ii q̈_i, the inertial coupling
  Σ_{j≠i} H_ij q̈_j, the velocity constituent h_i and the gravity constituent
  Q_i: peak and RMS (N·m, or N for prismatic joints), and the ratios of the
  peaks to the own inertial peak;
- how much H_ii varies (min, max, max/min): H_ii is the inertia of the links
  beyond joint i about axis i, so it varies only with the *other* joints;
- what mechanical gravity compensation can take off Q_i. Two devices, each
  acting between link i-1 and link i (so it loads joint i only, as internal
  forces of the links beyond joint i-1 cancel on the joints before), fitted by
  least squares along the trajectory:

  * a constant-torque (constant-force) spring: a constant c_0; the best one is
    the mean of Q_i, and what remains is the configuration-dependent part
    Q_i - mean(Q_i);
  * a balancer, the ideal counterweight or spring balancer of joint i, whose
    torque is a function of q_i only: c_0 + c_1 cos θ_i + c_2 sin θ_i for a
    revolute joint (θ_i = q_i + offset_i: a counterweight's first moment in
    the link's plane, plus a constant spring), c_0 + k·q_i for a prismatic
    joint (a counterweight on a pulley or a preloaded linear spring). It takes
    off all of Q_i when Q_i depends on q_i alone (a pendulum, a vertical
    lift, the PUMA shoulder while the elbow holds); what remains depends on
    the other joints and needs a device across several joints, or the drive.

Classification (``threshold`` ε, default 5 %, all relative to the peak of the
own inertial constituent, with the rotor's J·i_r² included when ``rotor=True``):

- ``decoupled``: (coupling peak + velocity peak) < ε, H_ii varies by less than
  ε ((max - min)/min) and the gravity left after the best balancer < ε: with
  that balancer fitted, P_i = H_ii q̈_i + M_i, the paper's simplest form;
- ``inertial``: not decoupled, but the velocity constituent and the gravity
  left after the balancer are < ε: the joint is coupled through inertia only
  (H_ii varying with the other joints and/or Σ H_ij q̈_j);
- ``full``: the velocity constituent or the gravity that no balancer of this
  joint removes is ≥ ε: the general form of P_i.

A joint that does not accelerate along the trajectory has no own inertial
constituent; a constituent that is zero too then counts as 0 %, one that is
not as infinitely large (a held joint that others disturb is not decoupled).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass
from pathlib import Path

import numpy as np

from manipcad.dynamics.components import torque_components
from manipcad.errors import InputError
from manipcad.fileio import json_safe
from manipcad.model.robot import COL_JR, REVOLUTE, Robot
from manipcad.trajectories.base import Trajectory
from manipcad.trajectories.io import load_trajectory

CLASSES = ("decoupled", "inertial", "full")
SOURCE = "coupling_analysis"
#: a constituent below this fraction of the joint's largest constituent counts as zero
NEGLIGIBLE = 1e-9


@dataclass(frozen=True)
class JointCoupling:
    """Coupling figures of one joint along a trajectory.

    Torques are in ``unit`` (N·m for a revolute joint, N for a prismatic one),
    inertias in ``inertia_unit`` (kg·m² or kg); ratios are plain fractions.

    Attributes:
        joint: the joint's name; index: its 0-based index; type: revolute or prismatic.
        unit, inertia_unit: the units of the torques and inertias below.
        moving: whether the joint accelerates along the trajectory.
        inertial_peak, inertial_rms: own inertial constituent H_ii q̈_i
            (plus J·i_r² q̈_i with ``rotor=True``).
        coupling_peak, coupling_rms: inertial coupling Σ_{j≠i} H_ij q̈_j.
        velocity_peak, velocity_rms: velocity constituent h_i.
        gravity_peak, gravity_rms: gravity constituent Q_i.
        coupling_ratio, velocity_ratio, gravity_ratio: the peaks over the own
            inertial peak (inf when the joint does not accelerate and the
            constituent is not zero).
        H_min, H_max: range of H_ii (plus J·i_r² with ``rotor=True``).
        H_ratio: H_max / H_min.
        rotor_inertia: J·i_r², the drive's joint-referred rotor inertia.
        gravity_constant: mean of Q_i, the best constant-torque spring (least squares).
        gravity_after_spring: peak of Q_i - gravity_constant, the configuration-dependent part.
        gravity_after_balancer: peak of Q_i minus the best balancer (function of q_i only).
        balancer: its coefficients: revolute (c_0, c_1, c_2) of
            c_0 + c_1 cos θ_i + c_2 sin θ_i, in the torque unit; prismatic (c_0, k)
            of c_0 + k·q_i, N and N/m.
        gravity_after_balancer_ratio: gravity_after_balancer over the own inertial peak.
        classification: "decoupled", "inertial" or "full".
        reasons: why, in words.
    """

    joint: str
    index: int
    type: str
    unit: str
    inertia_unit: str
    moving: bool
    inertial_peak: float
    inertial_rms: float
    coupling_peak: float
    coupling_rms: float
    velocity_peak: float
    velocity_rms: float
    gravity_peak: float
    gravity_rms: float
    coupling_ratio: float
    velocity_ratio: float
    gravity_ratio: float
    H_min: float
    H_max: float
    H_ratio: float
    rotor_inertia: float
    gravity_constant: float
    gravity_after_spring: float
    gravity_after_balancer: float
    balancer: tuple[float, ...]
    gravity_after_balancer_ratio: float
    classification: str
    reasons: tuple[str, ...]

    @property
    def H_variation(self) -> float:
        """(H_max - H_min) / H_min: the relative change of the joint's inertia."""
        return _ratio(self.H_max - self.H_min, self.H_min, self.H_max)


@dataclass(frozen=True)
class CouplingReport:
    """The coupling analysis of a robot along a trajectory.

    Attributes:
        robot: the robot's name.
        joints: one :class:`JointCoupling` per joint.
        threshold: ε of the classification (fraction).
        dt: sampling step, s; samples: number of samples; duration: s.
        rotor: whether the rotor inertias J·i_r² count as own inertia.
        trajectory: a short description of the trajectory.
    """

    robot: str
    joints: tuple[JointCoupling, ...]
    threshold: float
    dt: float
    samples: int
    duration: float
    rotor: bool
    trajectory: str = ""

    @property
    def classes(self) -> tuple[str, ...]:
        """The classification of each joint."""
        return tuple(j.classification for j in self.joints)

    @property
    def overall(self) -> str:
        """The most coupled class over the joints ("decoupled" < "inertial" < "full")."""
        return max(self.classes, key=CLASSES.index)

    def __getitem__(self, joint: int | str) -> JointCoupling:
        """A joint's figures by index or name."""
        if isinstance(joint, str):
            for j in self.joints:
                if j.joint == joint:
                    return j
            raise KeyError(joint)
        return self.joints[joint]

    def to_dict(self) -> dict:
        """A JSON-ready mapping (SI units; inf as the string "inf")."""
        out = {k: v for k, v in asdict(self).items() if k != "joints"}
        out["overall"] = self.overall
        out["joints"] = []
        for j in self.joints:
            d = asdict(j)
            d["H_variation"] = j.H_variation
            out["joints"].append(json_safe(d))
        return json_safe(out)


def coupling_analysis(robot: Robot, trajectory: Trajectory | str | Path, *, dt: float = 1e-3,
                      threshold: float = 0.05, rotor: bool = False) -> CouplingReport:
    """Measure each joint's coupling constituents along a trajectory and classify it.

    Args:
        robot: the manipulator.
        trajectory: a :class:`~manipcad.trajectories.Trajectory` or a trajectory
            YAML file (line and circle paths use ``robot``).
        dt: sampling step, s (> 0); the samples run from 0 to the trajectory's
            duration inclusive.
        threshold: ε of the classification, a fraction in (0, 1) (default 5 %).
        rotor: count the drive's rotor inertia J·i_r² as part of the joint's own
            inertia (the motor moves it too; a high gear ratio makes a drive
            look decoupled). Default False: the paper's H_ii of the links.

    Returns:
        :class:`CouplingReport`, one :class:`JointCoupling` per joint (see the
        module docstring for the figures and the classification rules).

    Raises:
        InputError: a bad trajectory file, a trajectory with another number of
            joints, a non-positive dt, a threshold outside (0, 1), a zero duration.

    Example:
        >>> import manipcad
        >>> from manipcad.trajectories import cosine
        >>> arm = manipcad.load_robot("cylindrical")
        >>> traj = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], duration=1.6)
        >>> coupling_analysis(arm, traj)["turn"].classification
        'full'
    """
    traj = _trajectory(robot, trajectory)
    dt = _positive(dt, "dt")
    threshold = _positive(threshold, "threshold")
    if threshold >= 1:
        raise InputError(SOURCE, "threshold", f"must be a fraction in (0, 1), got {threshold}")
    T = float(traj.duration)
    if not T > 0:
        raise InputError(SOURCE, "trajectory", "has zero duration: nothing to analyse")
    steps = int(math.floor(T / dt + 1e-9))
    t = np.arange(steps + 1) * dt
    if T - t[-1] > 1e-9 * max(T, 1.0):
        t = np.append(t, T)
    q, qd, qdd = traj.sample(t)
    parts = torque_components(robot, q, qd, qdd)
    rotor_j = robot.table[:, COL_JR].copy()
    H_ii = parts.H_ii + (rotor_j if rotor else 0.0)
    own = parts.inertial + (parts.rotor if rotor else 0.0)

    joints = []
    for i in range(robot.n):
        joints.append(_joint(robot, i, q[:, i], qdd[:, i], own[:, i], parts.coupling[:, i],
                             parts.velocity[:, i], parts.gravity[:, i], H_ii[:, i],
                             float(rotor_j[i]), threshold, rotor))
    return CouplingReport(robot.name, tuple(joints), threshold, dt, len(t), T, rotor, repr(traj))


# ------------------------------------------------------------------ one joint


def _joint(robot: Robot, i: int, q, qdd, own, coup, vel, grav, H, rotor_inertia: float,
           eps: float, rotor: bool) -> JointCoupling:
    revolute = robot.joint_types[i] == REVOLUTE
    unit, iunit = ("N·m", "kg·m²") if revolute else ("N", "kg")
    series = {"own": own, "coup": coup, "vel": vel, "grav": grav}
    scale = max(float(np.abs(x).max()) for x in series.values())
    for k, x in series.items():  # round-off of a zero constituent (e.g. 1e-15 N) is zero
        if np.abs(x).max() <= NEGLIGIBLE * scale:
            series[k] = np.zeros_like(x)
    own, coup, vel, grav = series["own"], series["coup"], series["vel"], series["grav"]
    peak = {k: float(np.abs(x).max()) for k, x in series.items()}
    rms = {k: float(np.sqrt(np.mean(x**2))) for k, x in series.items()}
    A = peak["own"]
    moving = bool(np.abs(qdd).max() > 0.0)

    g_const = float(np.mean(grav))
    after_spring = float(np.abs(grav - g_const).max())
    if revolute:
        th = q + robot.offset[i]
        basis = np.column_stack([np.ones_like(th), np.cos(th), np.sin(th)])
    else:
        basis = np.column_stack([np.ones_like(q), q])
    coef, *_ = np.linalg.lstsq(basis, grav, rcond=None)
    after_bal = float(np.abs(grav - basis @ coef).max())
    tiny = NEGLIGIBLE * max(scale, 1e-300)  # round-off of an exact fit counts as zero
    after_spring = 0.0 if after_spring <= tiny else after_spring
    after_bal = 0.0 if after_bal <= tiny else after_bal

    r_c = _ratio(peak["coup"], A, scale)
    r_v = _ratio(peak["vel"], A, scale)
    r_g = _ratio(peak["grav"], A, scale)
    r_gb = _ratio(after_bal, A, scale)
    H_min, H_max = float(H.min()), float(H.max())
    dH = _ratio(H_max - H_min, H_min, H_max)
    H_ratio = H_max / H_min if H_min > 0 else (1.0 if H_max == 0 else math.inf)

    def pct(x: float) -> str:
        return "∞" if math.isinf(x) else f"{100 * x:.1f} %"

    e = pct(eps)
    own_name = "H_ii·q̈_i" + (" + J·i_r²·q̈_i" if rotor else "")
    reasons = []
    if not moving:
        reasons.append("the joint is held (no acceleration) along this trajectory")
    small_cv = r_c + r_v < eps
    small_H = dH < eps
    small_v = r_v < eps
    small_g = r_gb < eps
    reasons.append(f"coupling + velocity = {pct(r_c)} + {pct(r_v)} of the own inertial "
                   f"peak {A:.4g} {unit} ({own_name}); threshold {e}")
    reasons.append(f"H_ii varies by {pct(dH)} ({H_min:.4g}..{H_max:.4g} {iunit}) with the "
                   "other joints")
    if peak["grav"] == 0:
        reasons.append("no gravity constituent")
    elif after_bal == 0:
        reasons.append(f"gravity (peak {peak['grav']:.4g} {unit}) depends on q_i only: "
                       "a balancer (counterweight or spring) takes it all off")
    else:
        reasons.append(f"gravity left after the best balancer: {after_bal:.4g} {unit} = "
                       f"{pct(r_gb)} of the own inertial peak (depends on other joints)")
    if small_cv and small_H and small_g:
        cls = "decoupled"
        reasons.append(f"all below {e}: P_i = H_ii·q̈_i + M_i once gravity is balanced")
    elif small_v and small_g:
        cls = "inertial"
        reasons.append(f"velocity and unbalanced gravity below {e}: coupled through "
                       "inertia only (H_ii variation, Σ H_ij·q̈_j)")
    else:
        cls = "full"
        what = []
        if not small_v:
            what.append(f"velocity constituent {pct(r_v)}")
        if not small_g:
            what.append(f"gravity from other joints {pct(r_gb)}")
        reasons.append(f"{' and '.join(what)} >= {e}: the general form of P_i")

    return JointCoupling(
        joint=robot.joint_names[i], index=i, type=robot.joint_types[i], unit=unit,
        inertia_unit=iunit, moving=moving,
        inertial_peak=A, inertial_rms=rms["own"],
        coupling_peak=peak["coup"], coupling_rms=rms["coup"],
        velocity_peak=peak["vel"], velocity_rms=rms["vel"],
        gravity_peak=peak["grav"], gravity_rms=rms["grav"],
        coupling_ratio=r_c, velocity_ratio=r_v, gravity_ratio=r_g,
        H_min=H_min, H_max=H_max, H_ratio=H_ratio, rotor_inertia=rotor_inertia,
        gravity_constant=g_const, gravity_after_spring=after_spring,
        gravity_after_balancer=after_bal, balancer=tuple(float(c) for c in coef),
        gravity_after_balancer_ratio=r_gb, classification=cls, reasons=tuple(reasons))


# ------------------------------------------------------------------ helpers


def _ratio(num: float, den: float, scale: float) -> float:
    """num / den, with 0/0 = 0 and x/0 = inf; values below NEGLIGIBLE·scale count as 0."""
    tiny = NEGLIGIBLE * max(abs(scale), 1e-300)
    if abs(num) <= tiny:
        return 0.0
    if abs(den) <= tiny:
        return math.inf
    return abs(num) / abs(den)


def _positive(x, name: str) -> float:
    try:
        v = float(x)
    except (TypeError, ValueError):
        raise InputError(SOURCE, name, f"expected a number, got {x!r}") from None
    if not math.isfinite(v) or v <= 0:
        raise InputError(SOURCE, name, f"must be a finite number > 0, got {x!r}")
    return v


def _trajectory(robot: Robot, trajectory) -> Trajectory:
    if isinstance(trajectory, str | Path):

        src = str(trajectory)
        traj = load_trajectory(trajectory, robot=robot)
    elif isinstance(trajectory, Trajectory):
        src, traj = "trajectory", trajectory
    else:
        raise InputError(SOURCE, "trajectory", "expected a Trajectory or a trajectory file, "
                         f"got {type(trajectory).__name__}")
    if traj.n != robot.n:
        raise InputError(src, "", f"the trajectory moves {traj.n} joints, the robot "
                         f"{robot.name!r} has {robot.n}")
    return traj
