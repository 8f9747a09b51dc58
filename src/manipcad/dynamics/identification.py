"""Identification of an unknown payload mass m_r from drive torques or currents (paper 4.1).

The paper separates the terms that hold the unknown mass in the inverse
dynamics and computes m_r from the measured drive torques and the torques the
unloaded robot would need, "from one drive only or (more exactly) from the
drives k"; when the manipulator can make short stops, a simpler static method.

For a point mass m_r at a known position ``com`` on the carrying link the
torque is affine in m_r, because the recursive Newton-Euler algorithm is
linear in the links' inertial parameters (mass, first moment, inertia about
the body origin):

    tau(q, q̇, q̈) = tau_0(q, q̇, q̈) + m_r · g(q, q̇, q̈)

- tau_0: the inverse dynamics of the unloaded robot (with the drive terms
  J·i_r²·q̈ + k_v·i_r²·q̇ + |i_r|·M_f·sign(q̇) when ``drives=True``), N·m or N;
- g: the torque a 1 kg point mass at ``com`` needs, N·m/kg or N/kg: the
  inverse dynamics of a copy of the robot whose links are massless and which
  carries only that 1 kg. It equals ``ID(robot.with_payload(1, com)) - tau_0``
  exactly, without the cancellation of that difference.

Through a gear of efficiency η < 1 (``drives=True``) the measured torque is the drive
terms plus f·P, the load P the gear passes times the factor f of
:func:`manipcad.dynamics.gear.gear_factor` (1/η motoring, η braking): each equation is
taken back through it, y = (tau − drive terms)/f − P_0 — in motion at each sample's
power flow, at a stop at its approach's (the held friction, the motor's, divided by f
too; docs/identification.md, "Through a gear with losses").

Methods (``method=``; docs/identification.md has the derivations):

- ``"motion"``: every sample and drive gives y = tau - tau_0 = m_r·g + e.
  Samples where a drive with dry friction moves slower than
  ``MOTION_SPEED`` are left out for that drive (the sign of its friction is
  not known there). Without q̈ (and q̇) the samples must be time-ordered and
  ``t`` given: they are differentiated (central differences).
- ``"stops"``: with ``t``, the stops of a time-ordered motion are found
  (:func:`find_stops`: every joint slower than ``STOP_SPEED`` for at least
  ``MIN_STOP``), each averaged into one equation, and the direction each joint
  last moved in before it stuck is recorded. At rest the drive holds with its
  dry friction anywhere inside the band [-F⁻, +F⁺]; after a motion in
  direction d the held friction sits at the edge of that direction. So
  ``friction="estimate"`` (default) fits, per drive, one unknown held-friction
  level per approach direction jointly with m_r (the within-direction
  variation of g identifies m_r); ``"model"`` subtracts the model's band edge
  d·F^d; ``"none"`` ignores friction. Without ``t`` (and q̇ = q̈ = 0 or None)
  each sample is one stop of unknown approach.
- ``"auto"``: motion when there are enough moving samples, else stops.

Each drive's noise variance is estimated from its own residuals (feasible
weighted least squares), var(m_r) = 1 / Σ_j Σ g²/σ_j². Each drive alone gives
m_j ± s_j; a drive whose m_j differs from m_r by more than the flag threshold
standard deviations of that difference (s_j² - s², the variance of the
difference for the weighted mean of independent drives) is *flagged*: the
data, the com, the friction or the model disagree there. The threshold is
:func:`flag_threshold` (family-wise false-alarm probability ``FLAG_ALPHA``).
"""

from __future__ import annotations

import csv
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from manipcad.dynamics.api import inverse_dynamics
from manipcad.dynamics.gear import gear_factor_array
from manipcad.errors import InputError, ManipcadError, ManipcadWarning, require_choice
from manipcad.fileio import read_text
from manipcad.model.robot import (
    COL_BV,
    COL_FCN,
    COL_FCP,
    COL_JR,
    PRISMATIC,
    REVOLUTE,
    Robot,
)

SOURCE = "identify_payload"
#: a drive whose regressor RMS is below this (N·m/kg or N/kg) gives no excitation
EXCITATION_ABS = 1e-9
#: ... or below this fraction of the strongest drive's regressor RMS
EXCITATION_REL = 1e-6
#: samples needed before the drives are weighted by their estimated noise
MIN_SAMPLES_FOR_WEIGHTS = 10
METHODS = ("stops", "motion", "auto")
FRICTION = ("estimate", "symmetric", "model", "none")
#: a stop: every joint slower than this, rad/s (revolute) and m/s (prismatic)
STOP_SPEED = {REVOLUTE: 1e-2, PRISMATIC: 1e-3}
#: a joint's approach direction: its last velocity above this fraction of the stop speed
DIRECTION_FRACTION = 0.02
#: stops: fewer equations per drive than this, after the held-friction levels, warn
MIN_STOP_EQUATIONS = 5
#: rounds of reassigning stops to the nearer held-friction level (friction="estimate")
REASSIGN_ROUNDS = 20
#: a stop lasts at least this long, s
MIN_STOP = 0.15
#: a dithered stop: every joint stays within this of the pose (rad, m), over whole cycles
#: of a joint's back-and-forth motion that each last at most DITHER_PERIOD_MAX, s
DITHER_BAND = {REVOLUTE: 0.05, PRISMATIC: 0.005}
DITHER_PERIOD_MAX = 0.5
#: ... and at least this many cycles
DITHER_CYCLES_MIN = 2
#: a dithered run's leading cycle in which some joint rests (slower than the stop speed)
#: for this fraction of a cycle longer than in the run's steadiest cycle is its start
#: transient, left out (measured on the PUMA: steady cycles within 0.02, transients 0.08+)
DITHER_REST_EXCESS = 0.05
#: the first fraction of each stop is left out (current and torque settling)
STOP_SETTLE = 0.25
#: ... and the last fraction (the next move may be starting)
STOP_END_TRIM = 0.1
#: motion: a drive with dry friction slower than this is left out at that sample, rad/s, m/s
MOTION_SPEED = {REVOLUTE: 2e-2, PRISMATIC: 2e-3}
#: motion without q̈: q̇ and the torques are smoothed over this time before q̇ is
#: differentiated, s
SMOOTH_TIME = 0.02
#: time-ordered motion samples: contiguous batches for the standard deviations
BATCHES = 20
#: moving samples "auto" needs to choose the motion method
AUTO_MIN_MOTION = 50
#: family-wise false-alarm probability of the disagreement flags (over the k drives)
FLAG_ALPHA = 1e-3
#: ... and a flagged drive's estimate differs from the joint one by more than this
#: fraction of it (model errors of a fraction of a percent are not worth a flag)
FLAG_RELATIVE = 0.01


def flag_threshold(k: int, dof: float = math.inf) -> float:
    """|z| beyond which one of k drives is flagged: the two-sided quantile at
    ``FLAG_ALPHA / k`` (Bonferroni) of Student's t with the drive's ``dof``
    degrees of freedom (its standard deviation is estimated from that many
    residuals; normal for many), so that consistent data raise a flag in about
    one fit in 1000 whatever the number of drives and equations.

    Example:
        >>> round(flag_threshold(1), 2), round(flag_threshold(6), 2)
        (3.29, 3.76)
        >>> round(flag_threshold(5, dof=10), 2)
        5.69
    """
    from scipy.stats import norm, t  # deferred: start-up cost: scipy loaded on first use

    p = FLAG_ALPHA / (2 * max(int(k), 1))
    if not math.isfinite(dof) or dof > 1e4:
        return float(norm.isf(p))
    return float(t.isf(p, max(dof, 1.0)))


@dataclass(frozen=True)
class Stop:
    """One stop found in time-ordered samples.

    Attributes:
        start, end: first and last sample time of the stop, s.
        first, last: their sample indices (inclusive).
        used: (first_used, last_used) the samples averaged (without the first
            ``STOP_SETTLE`` and the last ``STOP_END_TRIM`` of the stop).
        direction: (n,) per joint, the sign of its last motion before the stop
            (+1, -1; 0 if it had not moved since the samples began, or dithered).
        dither: the joints slid back and forth about the pose (a dithered stop,
            ``waypoints(dither=...)``): ``used`` spans whole cycles, over which the sliding
            friction averages to a constant per drive and the inertial torques to zero.
    """

    start: float
    end: float
    first: int
    last: int
    used: tuple[int, int]
    direction: np.ndarray = field(repr=False)
    dither: bool = False


@dataclass(frozen=True)
class PayloadEstimate:
    """The identified payload mass and how well the data determine it.

    Attributes:
        mass: m_r, kg (returned as found, negative values included: see the warning).
        std: standard deviation of ``mass`` from the residual variance and the
            regressor, kg (nan with a single equation).
        residual: RMS of the fit residuals over the drives and equations used, N·m
            (N for prismatic joints).
        joints: indices of the drives used (0-based, the robot's joint order).
        joint_names: their names.
        method: "stops" (q̇ = q̈ = 0: gravity only) or "motion" (inertial,
            velocity and gravity terms).
        samples: number of samples (states) N given.
        com: the payload's centre of mass in the frame of ``link_name``, m (the
            estimate when ``com_estimated``).
        link: index of the carrying body (joint).
        link_name: the link the com is given in (a URDF link name or the
            body's link name).
        weighting: "noise" (drives weighted by their estimated noise variance)
            or "equal" (plain least squares).
        per_joint_mass: m_r from each drive used alone, kg, shape (k,).
        per_joint_std: its standard deviation, kg, shape (k,).
        per_joint_residual: RMS residual of each drive in the joint fit, N·m or N, (k,).
        excitation: RMS of each drive's regressor g over its equations, N·m/kg
            (N/kg for prismatic joints), shape (k,).
        flagged: names of the drives whose own estimate disagrees with ``mass``
            beyond their uncertainty (|z| > :func:`flag_threshold`).
        z: (k,) (m_j - m_r) / std of that difference per drive (nan if undefined).
        equations: (k,) equations (samples or stops) used per drive.
        stops: the stops used (method "stops" with time-ordered samples).
        friction: how the held friction at stops was handled ("estimate",
            "model", "none"; "model" for motion: the drive model's friction).
        held_friction: per drive used, {direction: level}, N·m or N: the held
            friction levels fitted at stops with ``friction="estimate"``.
        com_estimated: True when the com was estimated with the mass.
        com_std: (3,) standard deviation of the estimated com, m (nan otherwise).
        signal: "torque" or "current" (what was measured).
        notes: what was chosen and why (e.g. "auto" picking a method).
    """

    mass: float
    std: float
    residual: float
    joints: tuple[int, ...]
    joint_names: tuple[str, ...]
    method: str
    samples: int
    com: np.ndarray = field(repr=False)
    link: int = -1
    link_name: str = ""
    weighting: str = "equal"
    per_joint_mass: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    per_joint_std: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    per_joint_residual: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    excitation: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    flagged: tuple[str, ...] = ()
    z: np.ndarray = field(default_factory=lambda: np.zeros(0), repr=False)
    equations: np.ndarray = field(default_factory=lambda: np.zeros(0, int), repr=False)
    stops: tuple[Stop, ...] = field(default=(), repr=False)
    friction: str = "model"
    held_friction: tuple[dict, ...] = field(default=(), repr=False)
    com_estimated: bool = False
    com_std: np.ndarray = field(default_factory=lambda: np.full(3, np.nan), repr=False)
    signal: str = "torque"
    notes: tuple[str, ...] = ()

    def to_dict(self) -> dict:
        """A JSON-ready mapping (SI units: kg, N·m or N, m, s)."""
        def num(x: float):
            return None if not math.isfinite(x) else float(x)

        return {
            "mass_kg": num(self.mass), "std_kg": num(self.std),
            "residual_rms": num(self.residual), "method": self.method,
            "samples": self.samples, "stops": len(self.stops), "weighting": self.weighting,
            "signal": self.signal, "friction": self.friction,
            "link": self.link_name, "link_index": self.link,
            "com_m": [float(c) for c in self.com], "com_estimated": self.com_estimated,
            "com_std_m": [num(c) for c in self.com_std],
            "flagged": list(self.flagged), "notes": list(self.notes),
            "joints": [
                {"index": j, "name": nm, "mass_kg": num(m), "std_kg": num(s),
                 "residual_rms": num(r), "excitation_per_kg": num(e), "z": num(zz),
                 "equations": int(ne), "flagged": nm in self.flagged,
                 "held_friction": ({str(k): float(v) for k, v in self.held_friction[i].items()}
                                   if i < len(self.held_friction) else {})}
                for i, (j, nm, m, s, r, e, zz, ne) in enumerate(zip(
                    self.joints, self.joint_names, self.per_joint_mass, self.per_joint_std,
                    self.per_joint_residual, self.excitation, self.z, self.equations,
                    strict=True))
            ],
        }

    def __str__(self) -> str:
        flag = f"; drives disagreeing: {', '.join(self.flagged)}" if self.flagged else ""
        return (f"payload mass {self.mass:.4g} ± {self.std:.2g} kg ({self.method}, "
                f"{self.samples} samples, drives {', '.join(self.joint_names)}; "
                f"residual RMS {self.residual:.3g}{flag})")


def payload_regressor(robot: Robot, q, qd, qdd, *, com=None, link: int | str = -1) -> np.ndarray:
    """The torque a 1 kg point mass at ``com`` on ``link`` needs along a motion.

    Args:
        robot: the manipulator (its links' own masses do not matter here).
        q, qd, qdd: joint positions, velocities, accelerations (rad, rad/s, rad/s²
            or m, m/s, m/s²), shape (n,) or (N, n).
        com: the point mass's position in the link's frame, m; default the origin.
        link: the carrying link: a joint index or name (its body frame), or a
            link name (that link's own frame, e.g. a URDF link); default the last.

    Returns:
        g, N·m/kg (N/kg for prismatic joints), shaped like q: the inverse dynamics
        of a copy of the robot with massless links carrying only the 1 kg (no
        drive terms), equal to ``ID(robot.with_payload(1, com)) - ID(robot)``.

    Example:
        >>> import numpy as np, manipcad
        >>> from manipcad.dynamics.identification import payload_regressor
        >>> puma = manipcad.load_robot("puma560")
        >>> payload_regressor(puma, np.zeros(6), np.zeros(6), np.zeros(6)).shape
        (6,)
    """
    body, R, p, _ = link_frame(robot, link)
    unit = _unit_payload_robot(robot, R @ _com(com) + p, body)
    return inverse_dynamics(unit, q, qd, qdd, drives=False)


# ------------------------------------------------------------------ link frames


def link_frame(robot: Robot, link: int | str) -> tuple[int, np.ndarray, np.ndarray, str]:
    """The body carrying a link and the link's frame in that body.

    A joint index (0-based, negative from the end) or joint name means the body
    frame of that joint (the link it moves, in the internal frame with the joint
    axis along z). Any other name is a link name, and means that link's own
    frame (:meth:`manipcad.model.robot.Robot.link_frame`: for a URDF robot, the
    URDF link frame, links merged through fixed joints included).

    Args:
        robot: the manipulator.
        link: joint index or name, or link name.

    Returns:
        ``(body, R, p, name)``: body index 0..n-1, the frame's rotation (3, 3)
        and origin (3,) m in the body frame (a point c in the link frame is
        ``R @ c + p`` in the body frame), and the name.

    Raises:
        InputError: no such link or joint, or a link fixed to the base.

    Example:
        >>> import manipcad
        >>> body, R, p, name = link_frame(manipcad.load_robot("puma560"), -1)
        >>> body, R.tolist() == [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
        (5, True)
    """
    if isinstance(link, str) and link not in robot.joint_names:
        try:
            body, R, p = robot.link_frame(link)
        except ManipcadError as exc:
            raise InputError(SOURCE, "link", f"{exc}; or a joint name "
                             f"({', '.join(robot.joint_names)})") from None
        if body < 0:
            raise InputError(SOURCE, "link", f"link {link!r} is fixed to the base: a payload "
                             "there loads no drive")
        return int(body), np.asarray(R, float), np.asarray(p, float), link
    try:
        body = robot.joint_index(link)
    except (ManipcadError, TypeError, ValueError) as exc:
        raise InputError(SOURCE, "link", str(exc)) from None
    return body, np.eye(3), np.zeros(3), robot.joint_names[body]


# ------------------------------------------------------------------ stops


def find_stops(t, q, qd=None, *, joint_types=None, stop_speed=None,
               min_duration: float = MIN_STOP, settle: float = STOP_SETTLE) -> list[Stop]:
    """Find the stops in time-ordered samples and the direction each joint came from.

    A sample is at rest when every joint is slower than ``stop_speed`` (from
    ``qd``, or from central differences of ``q`` over ``t``); a stop is a run of
    such samples lasting at least ``min_duration``. A joint's approach
    direction is the sign of its velocity at the last sample up to the stop's
    end where it moved faster than ``DIRECTION_FRACTION`` of its
    ``stop_speed`` (0 if none) — or, when the joint creeps through the averaged
    part of the stop (net displacement above half that speed times its
    length), the direction of that creep: a joint that creeps into its rest
    inside the stop (a regulator's integral action pulling it back after an
    overshoot) holds with the friction of that creep's direction.

    Also the dithered stops (``Stop.dither``; ``waypoints(dither=...)``): runs of at least
    ``DITHER_CYCLES_MIN`` whole cycles of a back-and-forth motion about a pose, every joint
    within ``DITHER_BAND`` of it, the start transient left out (leading cycles in which
    the joints rest ``DITHER_REST_EXCESS`` of a cycle longer than in the steadiest);
    ``used`` spans the whole cycles, direction 0.

    Args:
        t: (N,) sample times, s, strictly increasing.
        q: (N, n) joint positions, rad or m.
        qd: (N, n) joint velocities, rad/s or m/s; None: differentiated from q.
        joint_types: n of "revolute"/"prismatic" (for the default speeds);
            default all revolute.
        stop_speed: one speed for all joints or one per joint (rad/s, m/s);
            default ``STOP_SPEED`` by joint type.
        min_duration: the shortest stop, s.
        settle: the first fraction of each stop to leave out of ``Stop.used``.

    Returns:
        The :class:`Stop` list in time order.

    Example:
        >>> import numpy as np
        >>> from manipcad.trajectories import waypoints
        >>> traj = waypoints([[0.0], [1.0], [0.2]], move_time=0.5, dwell=0.3)
        >>> t = np.arange(0.0, traj.duration, 1e-3)
        >>> q, qd, _ = traj.sample(t)
        >>> [(round(s.start, 1), round(s.end, 1), int(s.direction[0]))
        ...  for s in find_stops(t, q, qd)]
        [(0.0, 0.3, 0), (0.8, 1.1, 1), (1.6, 1.9, -1)]
    """
    T = np.asarray(t, dtype=float).reshape(-1)
    Q = np.asarray(q, dtype=float)
    if Q.ndim != 2 or Q.shape[0] != T.size:
        raise InputError(SOURCE, "t", f"{T.size} times for {Q.shape[0]} samples of q")
    if T.size < 3 or not np.all(np.diff(T) > 0):
        raise InputError(SOURCE, "t", "needs at least 3 strictly increasing sample times (s)")
    n = Q.shape[1]
    V = np.gradient(Q, T, axis=0) if qd is None else np.asarray(qd, dtype=float)
    types = joint_types or (REVOLUTE,) * n
    if stop_speed is None:
        vmax = np.array([STOP_SPEED[jt] for jt in types])
    else:
        vmax = np.broadcast_to(np.asarray(stop_speed, dtype=float), (n,)).copy()
    rest = np.all(np.abs(V) <= vmax, axis=1)
    creeping = np.abs(V) > DIRECTION_FRACTION * vmax
    edges = np.flatnonzero(np.diff(np.concatenate([[0], rest.astype(int), [0]])))
    out = []
    for a, b in zip(edges[::2], edges[1::2] - 1, strict=True):
        if T[b] - T[a] < min_duration:
            continue
        first_used = min(b, a + int(math.floor(settle * (b - a + 1))))
        # the last samples may already be the next move starting: left out too
        last_used = max(first_used, b - int(math.floor(STOP_END_TRIM * (b - a + 1))))
        # each joint's direction: its last motion up to the averaged window's end (a slow
        # creep inside the stop counts: the friction then sits at that direction's edge)
        direction = np.zeros(n, dtype=int)
        span = T[last_used] - T[first_used]
        for j in range(n):
            moved = Q[last_used, j] - Q[first_used, j]
            if span > 0 and abs(moved) > 0.5 * DIRECTION_FRACTION * vmax[j] * span:
                direction[j] = int(np.sign(moved))  # a creep through the averaged window
                continue
            idx = np.flatnonzero(creeping[:last_used + 1, j])
            if idx.size:
                direction[j] = int(np.sign(V[idx[-1], j]))
        out.append(Stop(float(T[a]), float(T[b]), int(a), int(b),
                        (int(first_used), int(last_used)), direction))
    out += _dither_stops(T, Q, V, types, vmax, min_duration)
    return sorted(out, key=lambda st: st.start)


def _dither_stops(T, Q, V, types, vmax, min_duration: float) -> list[Stop]:
    """Dithered stops: runs of at least ``DITHER_CYCLES_MIN`` whole cycles (between upward
    zero crossings of its velocity, each at most ``DITHER_PERIOD_MAX`` long, faster than
    the stop speed somewhere) of the joint that moves most, with every joint within
    ``DITHER_BAND`` of the run's mean pose, its start transient left out; the run spans at
    least ``min_duration``."""
    n = Q.shape[1]
    band = np.array([DITHER_BAND[jt] for jt in types])
    runs = []
    for j in range(n):
        up = np.flatnonzero((V[:-1, j] < 0) & (V[1:, j] >= 0)) + 1
        good = []
        for a, b in zip(up[:-1], up[1:], strict=True):
            seg = Q[a:b + 1, j]
            good.append(T[b] - T[a] <= DITHER_PERIOD_MAX and np.abs(V[a:b, j]).max() > vmax[j]
                        and seg.max() - seg.min() <= 2 * band[j])
        k = 0
        while k < len(good):
            if not good[k]:
                k += 1
                continue
            e = k
            while e + 1 < len(good) and good[e + 1]:
                e += 1
            nxt = e + 1
            # the cycles at a run's ends may be the start transient or cut by the next
            # move: drop the worse end until both are within 5 % of the median cycle
            span = np.diff(T[up[k:e + 2]])
            while span.size:
                med = float(np.median(span))
                dev0, dev1 = abs(span[0] - med), abs(span[-1] - med)
                if max(dev0, dev1) <= 0.05 * med:
                    break
                if dev0 >= dev1:
                    k, span = k + 1, span[1:]
                else:
                    e, span = e - 1, span[:-1]
            # the start transient: leading cycles in which some joint is at rest (stuck
            # from the stop) for longer than in the run's steadiest cycle — a sliding drive
            # rests only while it turns back. Within a few cycles of equal length it is not
            # told apart by its length; averaged in, its friction held inside the band biased
            # a 5 Hz dither on a 0.6 s dwell by -7 % (docs/identification.md)
            rest = np.array([np.mean(np.any(np.abs(V[up[c]:up[c + 1]]) <= vmax, axis=1))
                             for c in range(k, e + 1)])
            while rest.size and rest[0] > rest.min() + DITHER_REST_EXCESS:
                k, rest = k + 1, rest[1:]
            if e - k + 1 >= DITHER_CYCLES_MIN:
                runs.append((int(up[k]), int(up[e + 1]), j))
            k = nxt
    out: list[Stop] = []
    for a, b, _ in sorted(runs, key=lambda r: np.ptp(Q[r[0]:r[1], r[2]]), reverse=True):
        if T[b] - T[a] < min_duration or any(a < st.last and st.first < b for st in out):
            continue
        win = Q[a:b]
        if np.any(win.max(axis=0) - win.min(axis=0) > 2 * band):
            continue
        out.append(Stop(float(T[a]), float(T[b - 1]), a, b - 1, (a, b - 1),
                        np.zeros(n, dtype=int), dither=True))
    return out


# ------------------------------------------------------------------ identification


def identify_payload(robot: Robot, q, qd=None, qdd=None, tau=None, *, t=None, current=None,
                     method: str = "auto", com=None, link: int | str = -1, joints=None,
                     drives: bool = True, friction: str = "estimate",
                     estimate_com: bool = False, stop_speed=None,
                     min_stop: float = MIN_STOP) -> PayloadEstimate:
    """Identify an unknown payload mass m_r from drive torques or armature currents.

    Least squares over the chosen drives of tau - tau_0 = m_r · g (see the
    module docstring and docs/identification.md): tau_0 is what the unloaded
    robot needs, g what 1 kg at ``com`` needs.

    Args:
        robot: the unloaded manipulator (its known links and drives).
        q: joint positions, rad or m, shape (n,) or (N, n).
        qd: joint velocities, rad/s or m/s, same shape; None: from ``t`` and q
            (motion) or at rest (stops without ``t``).
        qdd: joint accelerations, rad/s² or m/s²; None: from ``t`` and qd.
        tau: measured drive torques at the joints, N·m (N for prismatic joints).
        t: (N,) sample times, s, strictly increasing: the samples are
            time-ordered (needed to find stops and to differentiate).
        current: measured armature currents, A, instead of ``tau``: the joint
            torque of the drive is i_r·k_m·i (the drive terms rotor inertia
            and friction are then in tau_0 with ``drives=True``).
        method: "stops", "motion" or "auto" (motion when the samples have at
            least ``AUTO_MIN_MOTION`` moving samples, else stops).
        com: the payload's centre of mass in the frame of ``link``, m, (3,);
            default that frame's origin. With ``estimate_com`` the starting guess.
        link: joint index or name (its body frame), or a link name (that link's
            own frame, e.g. a URDF link: see :func:`link_frame`); default the last.
        joints: the drives to use: indices (0-based) or names; default every
            drive the payload acts on along these samples.
        drives: ``tau`` includes the drive terms (rotor inertia, friction) of
            the robot's drive models; False: ``tau`` is the rigid-body torque.
        friction: at stops, "estimate" (held friction per drive and approach
            direction fitted jointly), "model" (the model's band edge), "none".
        estimate_com: estimate the com (in ``link``'s frame) with the mass.
        stop_speed: joints slower than this are at rest (rad/s, m/s; one value
            or one per joint); default ``STOP_SPEED``.
        min_stop: the shortest stop, s.

    Returns:
        :class:`PayloadEstimate` (``.mass`` kg, ``.std`` kg, ``.flagged``, the
        per-drive estimates, the stops...).

    Raises:
        InputError: wrong shapes, NaN or infinite values, unknown or repeated
            joints, no excitation, no stops found, no torque or current given.

    Warns:
        ManipcadWarning: the identified mass is negative, or drives disagree
            beyond their uncertainty (the flagged drives).

    Example:
        >>> import numpy as np, manipcad
        >>> puma = manipcad.load_robot("puma560")
        >>> q = np.random.default_rng(0).uniform(-1, 1, (20, 6))
        >>> z = np.zeros_like(q)
        >>> tau = manipcad.inverse_dynamics(puma.with_payload(2.0), q, z, z)
        >>> est = identify_payload(puma, q, None, None, tau, method="stops")
        >>> round(est.mass, 6), est.method
        (2.0, 'stops')
    """
    if not isinstance(robot, Robot):
        raise InputError(SOURCE, "robot", f"expected a manipcad Robot, got {type(robot).__name__}")
    require_choice(SOURCE, "method", method, METHODS)
    require_choice(SOURCE, "friction", friction, FRICTION, "friction handling")
    n = robot.n
    Q = _states("q", q, n)
    N = Q.shape[0]
    QD = None if qd is None else _states("qd", qd, n, N)
    QDD = None if qdd is None else _states("qdd", qdd, n, N)
    T = None
    if t is not None:
        T = _states("t", np.reshape(np.asarray(t, dtype=float), (-1, 1)), 1, N)[:, 0]
        if N >= 2 and not np.all(np.diff(T) > 0):
            raise InputError(SOURCE, "t", "sample times must be strictly increasing (s)")
    TAU, signal = _torques(robot, tau, current, N)
    body, R_l, p_l, link_name = link_frame(robot, link)
    c_link = _com(com)
    notes: list[str] = []

    at_rest = (QD is None or not QD.any()) and (QDD is None or not QDD.any())
    if method == "auto":
        if T is None and at_rest:
            method = "stops"
            notes.append("auto: samples at rest without times: each sample is a stop")
        elif not at_rest and QDD is not None:
            method = "motion"
            notes.append("auto: velocities and accelerations given -> motion")
        else:
            V = QD if QD is not None else np.gradient(Q, T, axis=0)
            moving = int(np.sum(np.any(np.abs(V) > _speeds(robot, MOTION_SPEED), axis=1)))
            method = "motion" if moving >= AUTO_MIN_MOTION else "stops"
            notes.append(f"auto: {moving} moving samples -> {method}")

    if method == "stops":
        eq = _stop_equations(robot, Q, QD, TAU, T, friction, stop_speed, min_stop, notes,
                             R_l @ c_link + p_l, body, drives)
        if eq.nuisance is None and friction in ("estimate", "symmetric"):
            friction = "none"  # no times: the approach directions are unknown
    else:
        if QD is None or QDD is None:
            if T is None:
                raise InputError(SOURCE, "t", "the motion method needs qd and qdd, or the "
                                 "sample times t to differentiate q (and qd)")
            if QD is None:
                QD = np.gradient(Q, T, axis=0)
            if QDD is None:
                QD, QDD, TAU, w = _smoothed(T, QD, TAU)
                notes.append(f"qdd from the derivative of qd smoothed over {w} samples; "
                             "torques smoothed alike")
        edge = 0 if qdd is not None else _window(T)
        eq = _motion_equations(robot, Q, QD, QDD, TAU, drives, edge, T is not None)
        friction = "model" if drives else "none"

    c_body = R_l @ c_link + p_l
    G = eq.regressor(robot, c_body, body)
    W = eq.mask

    def rms(X):
        return np.sqrt(np.sum((X * W) ** 2, axis=0) / np.maximum(W.sum(axis=0), 1))

    # how strongly the payload shows in each drive (before the held-friction levels)
    excitation = rms(eq.G_raw)
    if estimate_com:  # a drive the payload loads from some com nearby counts too
        for axis in np.eye(3) * 0.1:
            eq.regressor(robot, c_body + axis, body)
            excitation = np.maximum(excitation, rms(eq.G_raw))
        G = eq.regressor(robot, c_body, body)
    strongest = float(excitation.max())
    weak = (excitation <= EXCITATION_ABS) | (excitation <= EXCITATION_REL * strongest)
    if eq.nuisance is not None:
        # the levels absorb all of a drive's regressor when no direction class has stops at
        # poses where the payload's torque differs: too few stops, not too little payload
        spent = ~weak & (rms(G) <= 1e-6 * excitation)
        if spent.any():
            need = _stops_needed(robot, eq, np.flatnonzero(spent), spent=True)
            if joints is None and np.all(weak | spent):
                raise InputError(SOURCE, "q, t", f"too few stops to separate the payload from "
                                 f"the held friction: {need}")
            notes.append(f"left out, too few stops: {need}")
            weak = weak | spent
    sel = _select(robot, joints, weak, excitation, method, c_link, link_name)
    if eq.nuisance is not None and friction == "estimate":
        if estimate_com:  # the levels depend on the com: a first com before reassigning
            c_body, _ = _estimate_com(robot, eq, sel, c_body, body)
        moved = _reassign_directions(eq, robot, c_body, body, sel)
        if moved:
            notes.append(f"{moved} (stop, drive) approach directions corrected to the nearer "
                         "held-friction level")
        G = eq.regressor(robot, c_body, body)

    com_std = np.full(3, np.nan)
    if estimate_com:
        c_body, cov_c = _estimate_com(robot, eq, sel, c_body, body)
        G = eq.regressor(robot, c_body, body)
        c_link = R_l.T @ (c_body - p_l)
        com_std = np.sqrt(np.maximum(np.diag(R_l.T @ cov_c @ R_l), 0.0))
    fit = _fit(G[:, sel], eq.Y[:, sel], W[:, sel], eq.lost[sel], ordered=eq.ordered)
    m, std = fit["mass"], fit["std"]
    names = tuple(robot.joint_names[j] for j in sel)
    z_crit = np.array([flag_threshold(len(sel), dof) for dof in fit["dof"]])
    floor = FLAG_RELATIVE * max(abs(m), 3.0 * std if math.isfinite(std) else 0.0)
    flagged = tuple(nm for nm, zz, zc, mj in zip(names, fit["z"], z_crit, fit["m_j"],
                                                 strict=True)
                    if math.isfinite(zz) and abs(zz) > zc and abs(mj - m) > floor)
    held = tuple(eq.held(j, m) for j in sel)
    est = PayloadEstimate(
        mass=m, std=std, residual=fit["residual"], joints=tuple(int(j) for j in sel),
        joint_names=names, method=method, samples=N, com=c_link, link=body,
        link_name=link_name, weighting=fit["weighting"], per_joint_mass=fit["m_j"],
        per_joint_std=fit["std_j"], per_joint_residual=fit["res_j"],
        excitation=excitation[sel], flagged=flagged, z=fit["z"],
        equations=W[:, sel].sum(axis=0) - eq.lost[sel], stops=tuple(eq.stops),
        friction=friction, held_friction=held, com_estimated=bool(estimate_com),
        com_std=com_std, signal=signal, notes=tuple(notes))
    if m < 0:
        warnings.warn(ManipcadWarning(
            f"the identified payload mass is negative: {m:.4g} ± {std:.2g} kg (returned as "
            "found, not clipped); the measured torques are below what the unloaded robot "
            "needs: check the torque sign and units, the assumed com, the drive friction "
            "model and the robot's own link masses"), stacklevel=2)
    left = W[:, sel].sum(axis=0) - eq.lost[sel]
    if method == "stops" and eq.nuisance is not None and int(left.max()) < MIN_STOP_EQUATIONS:
        warnings.warn(ManipcadWarning(
            f"only {len(eq.stops)} stops: after fitting each drive's held-friction levels at "
            f"most {int(left.max())} equation(s) per drive remain, too few to trust the "
            f"estimate {m:.4g} ± {std:.2g} kg or its uncertainty; "
            f"{_stops_needed(robot, eq, sel)}; or use friction='model'"), stacklevel=2)
    if flagged:
        detail = ", ".join(f"{nm} {mj:.4g} ± {sj:.2g} kg ({zz:+.1f} σ)" for nm, mj, sj, zz in zip(
            names, fit["m_j"], fit["std_j"], fit["z"], strict=True) if nm in flagged)
        warnings.warn(ManipcadWarning(
            f"drives disagree beyond their uncertainty (|z| > {z_crit.min():.2f}) with the joint "
            f"estimate {m:.4g} ± {std:.2g} kg: {detail}; the assumed com (frame of link "
            f"{link_name!r}), the friction or the robot model do not fit these data"),
            stacklevel=2)
    return est


class _Equations:
    """Measured y = tau - tau_0 per equation (row) and drive, and how to build g.

    ``nuisance[j]``: a matrix A_j (rows × p_j) of the held-friction unknowns of
    drive j at stops (or None): y_j = m·g_j + A_j·θ_j + e_j. They are eliminated by
    projecting y_j and g_j on the orthogonal complement of A_j's columns, which
    costs ``lost[j]`` = rank(A_j) equations.

    At stops with a lossy gear, ``gear`` = (held, P0, judge, eta): the held torques
    (rows × n, N·m or N), the unloaded robot's load P0, the torque at the gear's input
    less the model's friction of each approach direction (rows × n × 3, for d = −1, 0,
    +1: the sign of the power flow) and η (n,); then each row is divided by its gear
    factor f (:func:`_stop_factors`), y = held/f − P0, and A_j's rows by f too (the held
    friction is the motor's, before the gear). :meth:`redirect` redoes both when the
    approach directions change.
    """

    def __init__(self, Q, QD, QDD, Y, mask, lost, nuisance=None, stops=(), ordered=False,
                 directions=None, avg=None, gear=None, factor=None):
        self.Q, self.QD, self.QDD, self.Y0 = Q, QD, QDD, Y
        # (rows × samples) the mean each equation takes of the samples' dynamics (a
        # dithered stop averages its window), or None: one sample per equation
        self.avg = avg
        self.ordered = ordered  # rows are consecutive samples in time
        self.mask = mask
        self.lost = lost
        self.nuisance = nuisance
        self.directions = directions  # (E, n) approach direction per stop, or None
        self.stops = stops
        self.gear = gear
        self.factor = factor  # (E, n) gear factor each row was divided by, or None
        self.Y = self._project(Y)

    def redirect(self, dirs: np.ndarray, nuisance_of) -> None:
        """New approach directions ``dirs`` (E, n): the gear factors, y and the
        held-friction unknowns (``nuisance_of(dirs, g, factor)`` per drive) again."""
        Y, factor = self.Y0, self.factor
        if self.gear is not None:
            held, P0, judge, eta = self.gear
            factor = _stop_factors(judge, dirs, eta)
            Y = held / factor - P0
        nuisance = [nuisance_of(dirs[:, j], self.G_raw[:, j], None if factor is None else
                                factor[:, j]) if self.nuisance[j] is not None else None
                    for j in range(dirs.shape[1])]
        lost = np.array([np.linalg.matrix_rank(A) if A is not None else 0 for A in nuisance])
        self.__init__(self.Q, self.QD, self.QDD, Y, self.mask, lost, nuisance, self.stops,
                      directions=dirs, avg=self.avg, gear=self.gear, factor=factor)

    def _project(self, X: np.ndarray) -> np.ndarray:
        if self.nuisance is None:
            return X
        out = X.copy()
        for j, A in enumerate(self.nuisance):
            if A is not None:
                out[:, j] -= A @ (np.linalg.pinv(A) @ X[:, j])
        return out

    def regressor(self, robot: Robot, c_body: np.ndarray, body: int) -> np.ndarray:
        """g of a 1 kg point mass at c_body (m, body frame) on ``body``, projected like Y."""
        unit = _unit_payload_robot(robot, c_body, body)
        self.G_raw = inverse_dynamics(unit, self.Q, self.QD, self.QDD, drives=False)
        if self.avg is not None:
            self.G_raw = self.avg @ self.G_raw
        return self._project(self.G_raw)

    def held(self, j: int, m: float) -> dict:
        """The fitted held friction of drive j per approach direction, N·m or N, referred
        to the joint on the motor's side of the gear (from the nuisance fit of y - m·g with
        the last :meth:`regressor`)."""
        if self.nuisance is None or self.nuisance[j] is None:
            return {}
        A = self.nuisance[j]
        fitted = A @ (np.linalg.pinv(A) @ (self.Y0[:, j] - m * self.G_raw[:, j]))
        if self.factor is not None:
            fitted = fitted * self.factor[:, j]
        return {int(d): float(np.mean(fitted[self.directions[:, j] == d]))
                for d in np.unique(self.directions[:, j])}


def _friction_unknowns(d: np.ndarray, g: np.ndarray, friction: str,
                       factor: np.ndarray | None = None) -> np.ndarray | None:
    """A_j for one drive at stops: one held-friction level per approach direction
    ("estimate"; if that leaves g no excitation — a regressor constant within each
    direction, such as a vertical axis's weight — one level ±f for both), or one
    symmetric level ±f ("symmetric"); plus a level of its own for the stops of
    direction 0 (a joint that had not moved). ``factor``: each row's gear factor, which
    the row was divided by; the held friction is the motor's, on the input side of the
    gear, so its columns are divided by it too."""
    scale = 1.0 if factor is None else 1.0 / factor[:, None]
    if friction == "estimate":
        A = np.stack([(d == c).astype(float) for c in np.unique(d)], axis=1) * scale
        left = g - A @ (np.linalg.pinv(A) @ g)
        if np.linalg.norm(left) > 1e-3 * np.linalg.norm(g):
            return A
    cols = [d.astype(float)] if np.any(d != 0) else []
    if np.any(d == 0):
        cols.append((d == 0).astype(float))
    return np.stack(cols, axis=1) * scale if cols else None


def _reassign_directions(eq: _Equations, robot: Robot, c_body, body: int, sel) -> int:
    """Held friction at stops, estimated jointly: each (stop, drive) holds at one of the
    drive's two levels, the edges of its friction band. Starting from the approach
    directions found in the motion, alternately fit m_r and the levels, and give each
    stop the level nearer to its y - m_r·g, until no assignment changes (at most
    ``REASSIGN_ROUNDS``). A lossy gear's factor follows the direction (the approach
    decides the power flow). Changes ``eq`` in place; returns the number of changes."""
    start = eq.directions.copy()
    for _ in range(REASSIGN_ROUNDS):
        G = eq.regressor(robot, c_body, body)
        m = _fit(G[:, sel], eq.Y[:, sel], eq.mask[:, sel], eq.lost[sel])["mass"]
        dirs = eq.directions.copy()
        for j in sel:
            d = dirs[:, j]
            if not (np.any(d > 0) and np.any(d < 0)) or eq.nuisance[j].shape[1] != \
                    np.unique(d).size:
                continue  # one direction only, or a symmetric level: nothing to choose
            # the held friction each stop would have after either approach: through a
            # lossy gear the approach also decides the factor on the load
            if eq.gear is None:
                up = down = eq.Y0[:, j] - m * eq.G_raw[:, j]
            else:
                held, P0, judge, eta = eq.gear
                load = P0[:, j] + m * eq.G_raw[:, j]
                up, down = (held[:, j] - _stop_factors(judge, np.full_like(dirs, c), eta)[:, j]
                            * load for c in (1, -1))
            hi, lo = float(np.mean(up[d > 0])), float(np.mean(down[d < 0]))
            if hi <= lo:
                continue  # levels not ordered like a friction band: keep the motion's
            nz = d != 0
            d[nz] = np.where(np.abs(up[nz] - hi) < np.abs(down[nz] - lo), 1, -1)
        if np.array_equal(dirs, eq.directions):
            break
        eq.redirect(dirs, lambda d, g, f: _friction_unknowns(d, g, "estimate", f))
    return int(np.sum(eq.directions != start))


def _efficiencies(robot: Robot) -> np.ndarray:
    """Each drive's gear efficiency η, (n,): 1 without a drive or where it is unknown
    (nan; as the sizing takes it)."""
    eta = np.array([1.0 if d is None else float(d.efficiency) for d in robot.drives])
    return np.where(np.isfinite(eta), eta, 1.0)


def _friction_edge(tab: np.ndarray, s: np.ndarray) -> np.ndarray:
    """The model's dry friction at the joint, N·m (N), of motion in the sign of ``s``
    (speeds or approach directions, (N, n)): the positive level where s > 0, minus the
    negative one where s < 0, 0 where s = 0 (``tab``: the robot's table)."""
    return np.where(s > 0, tab[:, COL_FCP], np.where(s < 0, -tab[:, COL_FCN], 0.0))


def _stop_factors(judge: np.ndarray, dirs: np.ndarray, eta: np.ndarray) -> np.ndarray:
    """The gear factor f (:func:`manipcad.dynamics.gear.gear_factor`) of each stop and
    drive, (E, n), from its approach direction d: the torque a drive holds at rest is the
    one it came to rest with, sliding in direction d, so the power flowed as it did then
    — motoring (f = 1/η) when the load at the gear's input pushed along d, braking
    (f = η) when it pushed against it. ``judge`` (E, n, 3): that load (the held torque less
    the model's friction of direction d, N·m or N) for d = −1, 0, +1. A stop of direction 0
    (no approach seen, or dithered: factors applied per sample) has f = 1."""
    load = np.take_along_axis(judge, (dirs + 1)[:, :, None], axis=2)[:, :, 0]
    return np.where(dirs == 0, 1.0, gear_factor_array(eta, load, dirs))


def _through_gear(robot: Robot, TAU, QD, QDD, eta, dry: bool) -> np.ndarray:
    """The load the gear passes to the joint, (N, n), N·m or N, of measured drive torques
    at the joint: T = τ − J·i_r²·q̈ − k_v·i_r²·q̇ (− the model's dry friction with ``dry``)
    reaches the gear's input, and the gear passes T/f with f of
    :func:`manipcad.dynamics.gear.gear_factor` at the torque less the model's dry friction
    and the speed q̇ (the simulated plant's law). Without ``dry`` the dry friction stays in
    the result, divided by f like the rest (the stops' held-friction levels take it)."""
    tab = np.asarray(robot.table)
    T = TAU - tab[:, COL_JR] * QDD - tab[:, COL_BV] * QD
    F = _friction_edge(tab, QD)
    f = gear_factor_array(eta, T - F, QD)
    return ((T - F) if dry else T) / f


def _stop_equations(robot, Q, QD, TAU, T, friction, stop_speed, min_stop, notes, c_body, body,
                    drives=True):
    n = robot.n
    if T is None:  # each sample is one stop of unknown approach
        if QD is not None and QD.any():
            raise InputError(SOURCE, "qd", "the stops method without sample times takes "
                             "samples at rest (qd zero or None); give t to find the stops")
        Qs, Ts, dirs, stops = Q, TAU, np.zeros(Q.shape, dtype=int), []
        if friction in ("estimate", "symmetric"):
            notes.append("no sample times: approach directions unknown, held friction not "
                         "estimated")
            friction = "none"
    else:
        stops = find_stops(T, Q, QD, joint_types=robot.joint_types, stop_speed=stop_speed,
                           min_duration=min_stop)
        if stops and stops[0].start - T[0] < min_stop and friction != "none" \
                and len(stops) > 1:
            # at rest from the first sample: no approach, the friction held is unknown
            stops = stops[1:]
            notes.append("the rest at the start (no approach seen) left out")
        if not stops:
            raise InputError(SOURCE, "q, t", f"no stops found: no run of at least {min_stop:g} s "
                             "in which every joint is at rest (see stop_speed)")
        Qs = np.array([Q[s.used[0]:s.used[1] + 1].mean(axis=0) for s in stops])
        Ts = np.array([TAU[s.used[0]:s.used[1] + 1].mean(axis=0) for s in stops])
        dirs = np.array([s.direction for s in stops])
        dithered = sum(s.dither for s in stops)
        notes.append(f"{len(stops)} stops found" + (f", {dithered} of them dithered (the "
                                                    "sliding friction averaged over whole "
                                                    "cycles)" if dithered else ""))
    eta = _efficiencies(robot) if drives else np.ones(n)
    lossy = bool(np.any(eta < 1.0))
    Z = np.zeros_like(Qs)
    QD_s = QDD_s = Z
    avg = None
    if any(s.dither for s in stops):
        # a dithered stop's equation is the mean over its window of the whole dynamics
        # (q̈ from q̇): its inertial and velocity torques do not vanish sample by sample;
        # the drive's torque is taken through the gear sample by sample (its factor
        # switches with the sliding direction), the rotor's inertia and viscous friction
        # before it
        V = np.gradient(Q, T, axis=0) if QD is None else QD
        rows, cols, parts = [], [], []
        at = 0
        for k, st in enumerate(stops):
            if st.dither:
                a, b = st.used[0], st.used[1] + 1
                A_ = np.gradient(V[a:b], T[a:b], axis=0)
                held = (_through_gear(robot, TAU[a:b], V[a:b], A_, eta, dry=False) if drives
                        else TAU[a:b])
                parts.append((Q[a:b], V[a:b], A_, held))
                m = b - a
            else:
                parts.append((Qs[k:k + 1], Z[k:k + 1], Z[k:k + 1], Ts[k:k + 1]))
                m = 1
            rows += [k] * m
            cols += list(range(at, at + m))
            at += m
        avg = np.zeros((len(stops), at))
        avg[rows, cols] = 1.0
        avg /= avg.sum(axis=1, keepdims=True)
        Qs, QD_s, QDD_s, Ts = (np.concatenate([p_[i] for p_ in parts]) for i in range(4))
        Ts = avg @ Ts
    P0 = _averaged(avg, inverse_dynamics(robot, Qs, QD_s, QDD_s, drives=False))
    gear = factor = None
    tab = np.asarray(robot.table)
    edge = _friction_edge(tab, dirs)
    if lossy and T is not None:
        # the torque at the gear's input after an approach from each side, less the
        # model's friction there: its sign and d's give the power flow (motoring/braking)
        judge = np.stack([Ts + tab[:, COL_FCN], Ts, Ts - tab[:, COL_FCP]], axis=2)
        gear = (Ts, P0, judge, eta)
        factor = _stop_factors(judge, dirs, eta)
    Y = Ts / (1.0 if factor is None else factor) - P0
    lost = np.zeros(n, dtype=int)
    nuisance = None
    if friction == "model":
        Y = Y - edge / (1.0 if factor is None else factor)
    elif friction in ("estimate", "symmetric"):
        G = _averaged(avg, inverse_dynamics(_unit_payload_robot(robot, c_body, body), Qs, QD_s,
                                            QDD_s, drives=False))
        nuisance = [_friction_unknowns(dirs[:, j], G[:, j], friction,
                                       None if factor is None else factor[:, j])
                    for j in range(n)]
        lost = np.array([np.linalg.matrix_rank(A) if A is not None else 0 for A in nuisance])
    return _Equations(Qs, QD_s, QDD_s, Y, np.ones(Y.shape, dtype=bool), lost, nuisance, stops,
                      directions=dirs, avg=avg, gear=gear, factor=factor)


def _stops_needed(robot: Robot, eq: _Equations, drives, spent: bool = False) -> str:
    """What the stops give each of ``drives`` and what they need, in words.

    With one held-friction level per approach direction (dithered stops and joints that
    had not moved: one level), a class of k stops tells the mass only through how the
    payload's torque g differs among them: k − 1 equations if g differs, 0 if all its
    stops are at one pose. :data:`MIN_STOP_EQUATIONS` equations are needed per drive.
    """
    label = {1: "approached from +", -1: "from −", 0: "dithered or not approached"}
    parts = []
    for j in drives:
        d = eq.directions[:, j]
        g = eq.G_raw[:, j]
        tol = 1e-3 * max(float(np.abs(g).max()), 1e-300)
        counts = []
        for c in (1, -1, 0):
            k = int(np.sum(d == c))
            if not k:
                continue
            poses = np.unique(np.round(g[d == c] / tol)).size
            counts.append(f"{k} {label[c]} ({poses} distinct pose{'s' * (poses != 1)})")
        A = eq.nuisance[j] if eq.nuisance is not None else None
        sym = A is not None and A.shape[1] < np.unique(d).size
        left = d.size - int(eq.lost[j])
        got = (f"its {int(eq.lost[j])} held-friction level(s) absorb all of the payload's "
               f"torque" if spent else f"{left} equation(s) left after {int(eq.lost[j])} "
               f"held-friction level(s)")
        parts.append(f"drive {robot.joint_names[j]}: {', '.join(counts)}, {got}"
                     + (" (one level ±f for both directions: the friction taken as "
                        "symmetric)" if sym else ""))
    return ("; ".join(parts) + f" — each approach direction's stops must include at least "
            f"2 poses where the payload's torque differs, and {MIN_STOP_EQUATIONS} equations "
            f"are needed per drive: {MIN_STOP_EQUATIONS // 2 + 2} stops at different poses from "
            f"each direction, or {MIN_STOP_EQUATIONS + 1} dithered stops "
            f"(waypoints dither=...)")


def _averaged(avg, X: np.ndarray) -> np.ndarray:
    """avg @ X, or X without an averaging matrix."""
    return X if avg is None else avg @ X


def _motion_equations(robot, Q, QD, QDD, TAU, drives, edge, ordered):
    # with drives: the load the gear passes, (τ − the drive terms)/f, less the unloaded
    # robot's rigid-body load
    P0 = inverse_dynamics(robot, Q, QD, QDD, drives=False)
    Y = (_through_gear(robot, TAU, QD, QDD, _efficiencies(robot), dry=True) if drives
         else TAU) - P0
    mask = np.ones(Q.shape, dtype=bool)
    if drives:
        tab = np.asarray(robot.table)
        dry = (tab[:, COL_FCP] > 0) | (tab[:, COL_FCN] > 0)
        slow = (np.abs(QD) < _speeds(robot, MOTION_SPEED)) & dry
        for _ in range(edge):  # a smoothing window spanning a friction reversal
            slow = slow | np.roll(slow, 1, axis=0) | np.roll(slow, -1, axis=0)
        mask &= ~slow
    if edge:
        mask[:edge, :] = False  # the smoothing windows are cut at the ends
        mask[-edge:, :] = False
    return _Equations(Q, QD, QDD, Y, mask, np.zeros(robot.n, dtype=int), ordered=ordered)


def _window(T: np.ndarray) -> int:
    """Half-width in samples of the smoothing window (``SMOOTH_TIME`` s, at least 1)."""
    dt = float(np.median(np.diff(T))) if T.size > 1 else 1.0
    return max(1, int(round(0.5 * SMOOTH_TIME / dt)))


def _smoothed(T, QD, TAU):
    """q̇ and the torques smoothed by the same centred moving average (twice: a
    triangular window of ``SMOOTH_TIME``), q̈ the derivative of the smoothed q̇.

    The dynamics are linear in q̈, so the smoothed torque equals H·(smoothed q̈) plus
    the smoothed other terms; those vary slowly and are evaluated at the smoothed q̇.
    Differentiating the raw q̇ instead amplifies the ripple of sampled regulators
    (their voltage steps each period)."""
    h = _window(T)
    k = np.ones(h + 1) / (h + 1)

    def smooth(X):
        out = np.empty_like(X)
        for j in range(X.shape[1]):
            out[:, j] = np.convolve(np.convolve(X[:, j], k, mode="same"), k, mode="same")
        return out

    QDs = smooth(QD)
    return QDs, np.gradient(QDs, T, axis=0), smooth(TAU), h


def _speeds(robot: Robot, table: dict) -> np.ndarray:
    return np.array([table[jt] for jt in robot.joint_types])


def _torques(robot: Robot, tau, current, N: int) -> tuple[np.ndarray, str]:
    if (tau is None) == (current is None):
        raise InputError(SOURCE, "tau, current", "give the measured torques (tau) or the "
                         "armature currents (current), one of them")
    if tau is not None:
        return _states("tau", tau, robot.n, N), "torque"
    I = _states("current", current, robot.n, N)
    gain = np.empty(robot.n)
    for j, d in enumerate(robot.drives):
        if d is None or not math.isfinite(d.k_m) or d.k_m <= 0:
            raise InputError(SOURCE, "current", f"joint {robot.joint_names[j]!r} has no drive "
                             "with a torque constant k_m: its current gives no torque")
        # the drive's joint torque i_r·k_m·i (drives.dc.rigid_joint_torque, which this
        # layer below drives/ cannot import)
        gain[j] = d.ratio * d.k_m
    return I * gain, "current"


def _ar1_inflation(R: np.ndarray, W: np.ndarray) -> np.ndarray:
    """Per drive, the variance factor (1 + ρ)/(1 - ρ) of residuals correlated in time
    (ρ their lag-1 autocorrelation over consecutive used samples; ≥ 1, ≤ their count)."""
    f = np.ones(R.shape[1])
    for j in range(R.shape[1]):
        both = W[1:, j] & W[:-1, j]
        r0, r1 = R[:-1, j][both], R[1:, j][both]
        den = float(np.sum(r0 * r0))
        if r0.size < 3 or den <= 0:
            continue
        rho = min(max(float(np.sum(r0 * r1)) / den, 0.0), 0.999999)
        f[j] = min((1.0 + rho) / (1.0 - rho), max(float(W[:, j].sum()), 1.0))
    return f


def _fit(G: np.ndarray, Y: np.ndarray, W: np.ndarray, lost: np.ndarray,
         ordered: bool = False) -> dict:
    """Weighted least squares of Y = m·G over the equations W (per drive ``lost`` dof);
    ``ordered``: the rows are consecutive samples in time, whose residuals may be
    correlated: the drives are weighted with an AR(1) variance factor, and the
    standard deviations come from ``BATCHES`` batch means (t with B - 1 degrees of
    freedom for the flags)."""
    Gm, Ym = G * W, Y * W
    k = G.shape[1]
    n_j = W.sum(axis=0) - lost  # effective equations per drive
    gg = np.sum(Gm**2, axis=0)
    gy = np.sum(Gm * Ym, axis=0)
    m = float(gy.sum() / gg.sum())
    R = Ym - m * Gm
    M = int(n_j.sum())
    weighting = "equal"
    with np.errstate(invalid="ignore", divide="ignore"):
        m_j = gy / gg
    R_j = Ym - m_j * Gm
    infl = _ar1_inflation(R_j, W) if ordered else np.ones(k)
    if k > 1 and n_j.min() >= MIN_SAMPLES_FOR_WEIGHTS:
        weighting = "noise"
        for _ in range(2):
            var = _drive_variance(R, Ym, n_j, M) * infl
            m = float((gy / var).sum() / (gg / var).sum())
            R = Ym - m * Gm
        var = _drive_variance(R, Ym, n_j, M) * infl
        std = math.sqrt(1.0 / float((gg / var).sum()))
    else:
        s2 = float(np.sum(R**2)) / (M - 1) if M > 1 else math.nan
        std = math.sqrt(s2 * float(infl.max()) / float(gg.sum())) if M > 1 else math.nan
    with np.errstate(invalid="ignore", divide="ignore"):
        std_j = np.where(n_j > 1, np.sqrt(np.sum(R_j**2, axis=0) / np.maximum(n_j - 1, 1) / gg
                                          * infl), np.nan)
        dvar = std_j**2 - std**2
        z = np.where((k > 1) & (dvar > 0), (m_j - m) / np.sqrt(np.abs(dvar)), np.nan)
    dof = np.maximum(n_j - 1, 1).astype(float)
    N = G.shape[0]
    if ordered and N >= BATCHES * 10:
        # batch means: the influence of each of B contiguous blocks of samples on the
        # estimates; their spread is the variance, whatever the residuals' correlation
        w = 1.0 / var if weighting == "noise" else np.ones(k)
        edges = np.linspace(0, N, BATCHES + 1).astype(int)
        gg_b = np.add.reduceat(Gm**2, edges[:-1], axis=0)  # (B, k)
        gy_b = np.add.reduceat(Gm * Ym, edges[:-1], axis=0)
        info = float((w * gg).sum())
        infl_m = ((gy_b - m * gg_b) * w).sum(axis=1) / info  # (B,)
        with np.errstate(invalid="ignore", divide="ignore"):
            infl_j = (gy_b - m_j * gg_b) / gg  # (B, k)
        c = BATCHES / (BATCHES - 1.0)
        std = math.sqrt(c * float(np.sum(infl_m**2)))
        std_j = np.sqrt(c * np.sum(infl_j**2, axis=0))
        dvar = c * np.sum((infl_j - infl_m[:, None]) ** 2, axis=0)
        with np.errstate(invalid="ignore", divide="ignore"):
            z = np.where((k > 1) & (dvar > 0), (m_j - m) / np.sqrt(dvar), np.nan)
        dof = np.full(k, BATCHES - 1.0)
    res_j = np.sqrt(np.sum(R**2, axis=0) / np.maximum(W.sum(axis=0), 1))
    return {"mass": m, "std": std, "weighting": weighting, "m_j": m_j, "std_j": std_j, "dof": dof,
            "z": z, "res_j": res_j, "residual": float(np.sqrt(np.sum(R**2) / max(W.sum(), 1)))}


def _estimate_com(robot, eq, sel, c0, body):
    """(com in the body frame, its 3×3 covariance) fitted with the mass."""
    from scipy.optimize import least_squares  # deferred: start-up cost: scipy loaded on first use

    W = eq.mask[:, sel]

    def g_of(c):
        return eq.regressor(robot, c, body)[:, sel]

    G0 = g_of(c0)
    fit0 = _fit(G0, eq.Y[:, sel], W, eq.lost[sel])
    # each drive's residual variance, floored relative to its torques as in _fit's weights:
    # noise-free data (a drive whose residual is rounding) keep finite, sane weights
    Yw = eq.Y[:, sel] * W
    scale = np.sqrt(np.mean(Yw**2, axis=0)) + np.sqrt(np.mean(Yw**2))
    var = np.maximum(fit0["res_j"] ** 2, (1e-12 * scale) ** 2 + 1e-300)
    # residuals correlated in time count as fewer equations (the largest drive factor)
    infl = float(_ar1_inflation(eq.Y[:, sel] - fit0["mass"] * G0, W).max()) if eq.ordered \
        else 1.0
    w = W / np.sqrt(var)

    def resid(x):
        return ((eq.Y[:, sel] - x[0] * g_of(x[1:])) * w).ravel()

    x0 = np.concatenate([[fit0["mass"]], c0])
    sol = least_squares(resid, x0, x_scale="jac", xtol=1e-12, ftol=1e-12, gtol=1e-12)
    J = sol.jac
    dof = max(int(W.sum() - eq.lost[sel].sum()) - 4, 1)
    s2 = float(np.sum(sol.fun**2)) / dof
    try:
        cov = np.linalg.inv(J.T @ J) * s2 * infl
    except np.linalg.LinAlgError:
        cov = np.full((4, 4), np.nan)
    if abs(sol.x[0]) < 1e-12:
        raise InputError(SOURCE, "estimate_com", "the mass comes out zero: the com is "
                         "undetermined")
    return sol.x[1:], cov[1:, 1:]


# ------------------------------------------------------------------ CSV data files


@dataclass(frozen=True)
class TorqueData:
    """Samples read from a torque data file, each array (N, n) in SI units.

    Attributes:
        q: joint positions, rad or m.
        qd: joint velocities, rad/s or m/s; None when the file has no qd columns.
        qdd: joint accelerations, rad/s² or m/s²; None when the file has no qdd columns.
        tau: measured drive torques, N·m or N; None when the file has none.
        source: the file.
        t: (N,) sample times, s; None when the file has no time column.
        current: armature currents, A; None when the file has none.
    """

    q: np.ndarray
    qd: np.ndarray | None
    qdd: np.ndarray | None
    tau: np.ndarray | None
    source: str = ""
    t: np.ndarray | None = None
    current: np.ndarray | None = None


def result_torque_data(result, robot: Robot, source: str) -> TorqueData:
    """The samples of a simulation result (its recorded q, q̇, torques and currents) as
    measured data for :func:`identify_payload`.

    Args:
        result: a :class:`manipcad.sim.SimulationResult` (e.g. read back with
            :func:`manipcad.store.results.load_result`): t (s), q (rad|m), qd, tau (N·m|N),
            current (A) and its joint names.
        robot: the robot to identify with; its joints must be the result's.
        source: the result's name or folder, for messages.

    Returns:
        :class:`TorqueData` with q, qd, tau and t; the currents when every joint has them
        (a joint without a drive model records nan), else None; qdd None (differentiated).

    Raises:
        InputError: the result's joints are not the robot's.

    Example:
        >>> import numpy as np, manipcad
        >>> from manipcad.sim import SimulationResult
        >>> arm = manipcad.load_robot("cylindrical")
        >>> z = np.zeros((3, 3))
        >>> res = SimulationResult(np.arange(3.0), z, z, z, z, z, z + np.nan, z,
        ...                        arm.joint_names)
        >>> d = result_torque_data(res, arm, "r1")
        >>> d.q.shape, d.current is None
        ((3, 3), True)
    """
    if tuple(result.joint_names) != tuple(robot.joint_names):
        raise InputError(source, "joint_names", f"the result's joints "
                         f"{', '.join(result.joint_names)} are not the robot's "
                         f"({', '.join(robot.joint_names)})")
    current = np.asarray(result.current)
    current = current if current.size and np.all(np.isfinite(current)) else None
    return TorqueData(np.asarray(result.q), np.asarray(result.qd), None,
                      np.asarray(result.tau), str(source), np.asarray(result.t), current)


KINDS = ("q", "qd", "qdd", "tau", "current")
UNITS = {"q": "rad or m", "qd": "rad/s or m/s", "qdd": "rad/s² or m/s²", "tau": "N·m or N",
         "current": "A"}
TIME_COLUMNS = ("t", "time")
#: the unit a column's header may name in brackets (``tau1 [N·m]``), per kind and joint
#: type (SI only: a header naming another unit, ``[deg]``, ``[lbf·in]``, is refused, never
#: read as SI); ``rad|m`` etc. are a stored result's units for joints of unknown type
SI_UNITS = {
    "q": {"revolute": ("rad",), "prismatic": ("m",), "": ("rad|m",)},
    "qd": {"revolute": ("rad/s",), "prismatic": ("m/s",), "": ("rad/s|m/s",)},
    "qdd": {"revolute": ("rad/s²", "rad/s^2", "rad/s2"),
            "prismatic": ("m/s²", "m/s^2", "m/s2"), "": ("rad/s²|m/s²",)},
    "tau": {"revolute": ("N·m", "Nm", "N*m", "N.m", "N⋅m"), "prismatic": ("N",),
            "": ("N·m|N",)},
    "current": {"revolute": ("A",), "prismatic": ("A",), "": ("A",)},
    "t": {"": ("s",)},
}
#: largest magnitude of a CSV value: the least squares square the samples, and a value
#: whose square overflows (1e308) would make every estimate nan
MAX_CSV_VALUE = 1e100
#: columns of a stored simulation result (timeseries.csv) that identification does not read
RESULT_IGNORED = ("q_ref", "qd_ref", "error", "u")


def column_names(robot: Robot) -> dict[str, tuple[str, int]]:
    """Accepted CSV header names -> (kind, joint index).

    Per joint i (1-based number k = i + 1, name NAME): ``q{k}``, ``qd{k}``,
    ``qdd{k}``, ``tau{k}``, ``current{k}`` and ``q_NAME``, ... ``current_NAME``,
    and the columns of a stored result's timeseries.csv, ``NAME.q``,
    ``NAME.qd``, ``NAME.tau``, ``NAME.current`` (a unit in brackets after the
    name, as in ``shoulder.q [rad]``, is allowed on every column).

    Example:
        >>> import manipcad
        >>> names = column_names(manipcad.load_robot("cylindrical"))
        >>> names["qd2"], names["tau_reach"], names["turn.current"]
        (('qd', 1), ('tau', 2), ('current', 0))
    """
    out: dict[str, tuple[str, int]] = {}
    for i in range(robot.n):
        for kind in KINDS:
            out[f"{kind}{i + 1}"] = (kind, i)
    for i, name in enumerate(robot.joint_names):
        for kind in KINDS:
            out.setdefault(f"{kind}_{name}", (kind, i))  # a number form wins a clash
            out.setdefault(f"{name}.{kind}", (kind, i))
    return out


def load_torque_data(path: str | Path, robot: Robot) -> TorqueData:
    """Read a CSV file of joint states and measured drive torques.

    Format: comma-separated, one header line, then one sample per line; lines
    starting with ``#`` and blank lines are skipped. Columns (any order), per
    joint numbered 1..n or named by the robot's joint names:

    - ``q1..qn`` or ``q_NAME``: positions, rad (revolute) or m (prismatic);
    - ``qd1..qdn`` or ``qd_NAME``: velocities, rad/s or m/s;
    - ``qdd1..qddn`` or ``qdd_NAME``: accelerations, rad/s² or m/s²;
    - ``tau1..taun`` or ``tau_NAME``: measured drive torques, N·m or N;
    - ``current1..currentn`` or ``current_NAME``: armature currents, A;
    - a stored simulation result's ``timeseries.csv`` as it is: ``t [s]``,
      ``NAME.q [rad]``, ``NAME.qd``, ``NAME.tau``, ``NAME.current`` (its
      ``q_ref``, ``qd_ref``, ``error`` and ``u`` columns are skipped);
    - optionally ``t`` or ``time`` (s): the sample times (the samples are
      then time-ordered: stops can be found, q and qd differentiated).

    q is required for every joint, and tau or current for every joint; qd
    and qdd each for every joint or for none.

    Args:
        path: the CSV file.
        robot: the robot whose joints the columns name.

    Returns:
        :class:`TorqueData`.

    Raises:
        InputError: naming the file, the line and column, and the reason (no
            such file, no header, unknown, repeated or missing column, wrong
            number of fields, a value that is not a finite number, no data).
    """
    src = str(path)
    text = read_text(path, src, encoding="utf-8-sig")
    accepted = column_names(robot)
    header: list[str] | None = None
    cols: list[tuple[str, int] | None] = []
    rows: list[list[float]] = []
    for lineno, fields in _csv_lines(src, text):
        if header is None:
            header = [f.strip() for f in fields]
            cols = _header(src, lineno, header, accepted, robot)
            continue
        if len(fields) != len(header):
            raise InputError(src, f"line {lineno}", f"{len(fields)} fields, the header has "
                             f"{len(header)}")
        row = []
        for name, value in zip(header, fields, strict=True):
            try:
                x = float(value)
            except ValueError:
                raise InputError(src, f"line {lineno}, column {name}",
                                 f"{value.strip()!r} is not a number") from None
            if not math.isfinite(x):
                raise InputError(src, f"line {lineno}, column {name}",
                                 f"{value.strip()!r} is not a finite number")
            if abs(x) > MAX_CSV_VALUE:
                raise InputError(src, f"line {lineno}, column {name}",
                                 f"{value.strip()!r} is too large (more than "
                                 f"{MAX_CSV_VALUE:g} in magnitude; not a measurement in SI "
                                 "units)")
            row.append(x)
        rows.append(row)
    if header is None:
        raise InputError(src, "", "empty file: expected a header line (q1.., tau1.., ...) "
                         "and data lines")
    if not rows:
        raise InputError(src, "", "no data lines after the header")
    data = np.asarray(rows, dtype=float)
    arrays = {kind: None for kind in KINDS}
    for kind in KINDS:
        idx = [next((c for c, col in enumerate(cols) if col == (kind, i)), -1)
               for i in range(robot.n)]
        if all(c >= 0 for c in idx):
            arrays[kind] = data[:, idx]
    times = None
    tcol = [c for c, col in enumerate(cols) if col == ("t", -1)]
    if tcol:
        times = data[:, tcol[0]]
        bad = np.flatnonzero(np.diff(times) <= 0)
        if bad.size:
            raise InputError(src, f"line of sample {bad[0] + 2}, column {header[tcol[0]]}",
                             "sample times must be strictly increasing (s)")
    return TorqueData(arrays["q"], arrays["qd"], arrays["qdd"], arrays["tau"], src, times,
                      arrays["current"])


def check_estimate(est: PayloadEstimate, source: str) -> PayloadEstimate:
    """Refuse an estimate that is not a number, never report it: the command line's and
    the web application's check after :func:`identify_payload`.

    Args:
        est: the estimate.
        source: the data it came from (a file), for the error.

    Returns:
        ``est`` when its mass (and an estimated centre of mass) are finite.

    Raises:
        ManipcadError: "the data determine no payload mass (nan)" with the likely cause.
    """
    bad_com = est.com_estimated and not np.all(np.isfinite(est.com))
    if math.isfinite(est.mass) and not bad_com:
        return est
    what = "payload mass" if not math.isfinite(est.mass) else "centre of mass"
    raise ManipcadError(
        f"{source}: the data determine no {what} (the fit gives nan): its least squares "
        "are singular" + (", e.g. too little excitation to separate the mass "
                                        "from the centre of mass (--estimate-com)"
                                        if est.com_estimated else "")
        + "; nothing is reported")


def _csv_lines(src: str, text: str):
    """(line number, fields) of the non-blank, non-comment lines."""
    lines = text.splitlines()
    for lineno, line in enumerate(lines, start=1):
        if not line.strip() or line.lstrip().startswith("#"):
            continue
        try:
            fields = next(csv.reader([line]))
        except csv.Error as exc:
            raise InputError(src, f"line {lineno}", f"not a CSV line: {exc}") from None
        yield lineno, fields


def _check_unit(src: str, lineno: int, k: int, full: str, unit: str | None, kind: str,
                joint_type: str) -> None:
    """Refuse a column whose header names a unit that is not the SI unit read."""
    if unit is None:
        return
    table = SI_UNITS[kind]
    ok = table.get(joint_type, ()) + table.get("", ())
    if unit.replace(" ", "") not in {u.replace(" ", "") for u in ok}:
        want = ok[0]
        raise InputError(src, f"line {lineno}, column {k}",
                         f"{full!r}: the unit {unit!r} is not the SI unit this column is read "
                         f"in ({want}); convert the values to SI and name the unit so")


def _header(src: str, lineno: int, header: list[str], accepted: dict, robot: Robot):
    cols: list[tuple[str, int] | None] = []
    seen: dict[tuple[str, int], str] = {}
    times = 0
    for k, full in enumerate(header, start=1):
        name = full.split("[", 1)[0].strip() if full.endswith("]") and "[" in full else full
        unit = full[len(full.split("[", 1)[0]) + 1:-1].strip() if name != full else None
        if name.lower() in TIME_COLUMNS:
            times += 1
            if times > 1:
                raise InputError(src, f"line {lineno}, column {k}", "a second time column")
            _check_unit(src, lineno, k, full, unit, "t", "")
            cols.append(("t", -1))
            continue
        if "." in name and name.rsplit(".", 1)[1] in RESULT_IGNORED \
                and name.rsplit(".", 1)[0] in robot.joint_names:
            cols.append(None)
            continue
        if name not in accepted:
            n = robot.n
            raise InputError(src, f"line {lineno}, column {k}",
                             f"unknown column {full!r}; expected q1..q{n}, qd1..qd{n}, "
                             f"qdd1..qdd{n}, tau1..tau{n} or current1..current{n} (or q_NAME, "
                             f"NAME.q, ... with the joint names "
                             f"{', '.join(robot.joint_names)}) and optionally t")
        key = accepted[name]
        _check_unit(src, lineno, k, full, unit, key[0], robot.joint_types[key[1]])
        if key in seen:
            raise InputError(src, f"line {lineno}, column {k}",
                             f"column {name!r} repeats column {seen[key]!r}")
        seen[key] = name
        cols.append(key)
    for kind in KINDS:
        missing = [f"{kind}{i + 1}" for i in range(robot.n) if (kind, i) not in seen]
        if not missing:
            continue
        if kind == "q" or len(missing) < robot.n:
            need = "required" if kind == "q" else "needed when any such column is given"
            raise InputError(src, f"line {lineno}",
                             f"missing column(s) {', '.join(missing)} ({UNITS[kind]}; {need})")
    if not any(k[0] in ("tau", "current") for k in seen):
        raise InputError(src, f"line {lineno}", f"missing column(s) tau1..tau{robot.n} "
                         f"(N·m or N) or current1..current{robot.n} (A): the measured torques "
                         "or currents")
    return cols


# ------------------------------------------------------------------ helpers


def _states(name: str, x, n: int, N: int | None = None) -> np.ndarray:
    try:
        a = np.asarray(x, dtype=float)
    except (TypeError, ValueError):
        raise InputError(SOURCE, name, "expected an array of numbers") from None
    if a.ndim == 1:
        a = a.reshape(1, -1)
    if a.ndim != 2 or a.shape[1] != n:
        raise InputError(SOURCE, name, f"must have shape (n,) or (N, n) with n = {n} joints, "
                         f"got {np.shape(x)}")
    if N is not None and a.shape[0] != N:
        raise InputError(SOURCE, name, f"has {a.shape[0]} samples, q has {N}")
    if a.shape[0] == 0:
        raise InputError(SOURCE, name, "no samples")
    bad = np.argwhere(~np.isfinite(a))
    if bad.size:
        raise InputError(SOURCE, f"{name}[{bad[0, 0]}, {bad[0, 1]}]", "is not a finite number")
    return np.ascontiguousarray(a)


def _com(com) -> np.ndarray:
    if com is None:
        return np.zeros(3)
    try:
        c = np.asarray(com, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError(SOURCE, "com", "expected three numbers x, y, z in m") from None
    if c.shape != (3,) or not np.isfinite(c).all():
        raise InputError(SOURCE, "com", f"expected three finite numbers x, y, z in m, got {com!r}")
    return c


def _unit_payload_robot(robot: Robot, com: np.ndarray, link: int) -> Robot:
    """The robot with massless links and no drives, carrying 1 kg at ``com`` on ``link``."""
    n = robot.n
    bare = robot.replace(mass=np.zeros(n), com=np.zeros((n, 3)), inertia=np.zeros((n, 3, 3)),
                         drives=(None,) * n)
    return bare.with_payload(1.0, com, link=link)


def _select(robot: Robot, joints, weak: np.ndarray, excitation: np.ndarray, method: str,
            com: np.ndarray, link_name: str) -> np.ndarray:
    """The drives to use, as indices; raises InputError on bad names or no excitation."""
    where = (f"a point mass at com = {com.tolist()} m in the frame of link {link_name!r}"
             f" ({'at stops: gravity only' if method == 'stops' else 'along this motion'})")
    if joints is None:
        sel = np.flatnonzero(~weak)
        if sel.size == 0:
            raise InputError(SOURCE, "q, qd, qdd",
                             f"no excitation: {where} exerts no torque on any drive (regressor "
                             f"RMS <= {EXCITATION_ABS:g} N·m/kg); use samples with motion or "
                             "other configurations")
        return sel
    items = [joints] if isinstance(joints, str | int | np.integer) else list(joints)
    if not items:
        raise InputError(SOURCE, "joints", "empty list: name at least one drive")
    sel = []
    for k, j in enumerate(items):
        try:
            i = robot.joint_index(j if isinstance(j, str) else int(j))
        except (ManipcadError, TypeError, ValueError) as exc:
            raise InputError(SOURCE, f"joints[{k}]", str(exc)) from None
        if i in sel:
            raise InputError(SOURCE, f"joints[{k}]",
                             f"joint {robot.joint_names[i]!r} is named twice")
        if weak[i]:
            unit = "N·m/kg" if robot.joint_types[i] == REVOLUTE else "N/kg"
            raise InputError(SOURCE, f"joints[{k}]",
                             f"no excitation: {where} exerts no torque on joint "
                             f"{robot.joint_names[i]!r} (regressor RMS {excitation[i]:.2g} "
                             f"{unit}); drop it or use other samples")
        sel.append(i)
    return np.asarray(sel, dtype=np.int64)


def _drive_variance(R: np.ndarray, Y: np.ndarray, n_j: np.ndarray, M: int) -> np.ndarray:
    """Each drive's noise variance from its residuals (one parameter fitted over M
    equations, n_j of them this drive's), floored so that noise-free data keep
    finite weights."""
    var = np.sum(R**2, axis=0) / np.maximum(n_j * (M - 1) / M, 1e-300)
    scale = np.sqrt(np.mean(Y**2, axis=0)) + np.sqrt(np.mean(R**2))
    return np.maximum(var, (1e-12 * scale) ** 2 + 1e-300)
