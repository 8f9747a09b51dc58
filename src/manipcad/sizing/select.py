"""Drive selection: the lightest (or least inertia, or least power) catalogue drive per joint.

For each joint, every candidate drive — each compatible (motor, gear) pair of
the catalogue, and each motor alone as a direct drive on a revolute joint —
is checked with the checks ``manipcad size`` makes
(:func:`manipcad.sizing.limits.check_rated`: the motor's continuous and peak
torque, speed and voltage, the gear's rated, repeated-peak and average output
torque, its max and average input speed) on every trajectory at both ends of
the payload range, and the feasible candidate with the least objective wins:

- ``"mass"``: the drive's mass, motor + gear, kg (default);
- ``"rotor_inertia"``: the rotor and gear inertia referred to the joint,
  J·i_r², kg·m² (kg for a prismatic joint);
- ``"power"``: the mean electrical power u_a·i over the run, the largest over
  the cases, W (what ``size`` reports as "mean u_a·i").

A candidate is feasible when every check passes with the margin: ``margin``
M means required·M <= rating for every rating, i.e. a check margin (1 -
required/rating) of at least 1 - 1/M; ``margin=1.0`` is exactly the limits
``size`` applies; the default :data:`DEFAULT_MARGIN` = 1.1 asks every rating
to be at least 1.1 × the need. A check that cannot be made ("unknown": a rating or the
gear efficiency the catalogue does not give) makes a candidate infeasible
unless ``allow_unknown`` (``size --allow-unknown``'s reading). "n/a" (a gear
check of a direct drive) passes.

How the candidates are evaluated at once: the rigid-body joint torque
P_rigid, q̇, q̈ of a joint do not depend on the joint's own drive, so one
inverse-dynamics pass per case (:func:`manipcad.sizing.motion.sample_motion`)
serves every candidate. The gear checks and the speed checks need only
per-joint statistics of that motion, scaled by each candidate's ratio
(peak and mean |ω_m| = |i_r|·peak and mean |q̇|), so they are decided for the
whole catalogue in O(C). The candidates that pass them are then evaluated
through the same motor model as ``size`` (:func:`~manipcad.sizing.motor.joint_torque`
and :func:`~manipcad.sizing.motor.motor_series`, broadcast over a (C, N)
block of candidates × samples): RMS and peak motor torque, peak armature
voltage, mean electrical power. A candidate whose gear efficiency is unknown
has its motor torque and voltage checks "unknown" (``size`` may call some of
them "fail"; both are infeasible).

The drives' own masses load the arm. Convention: a drive (motor + gear) sits
on the link before its joint — the link of the parent joint — as a point
mass at the joint's origin (``"before"``, the default); a drive mounted on
the base (``"base"``: a remote motor driving through a belt, a cable or a
shaft) loads nothing. The robot file overrides the convention per joint
(``drive_mounts: {joint: base}``, :attr:`Robot.drive_mounts`), and the
``mounts`` argument overrides the file. A joint's torque depends only on
the links it moves, so a drive's mass loads the joints proximal to it, never
its own joint. The selection sweeps the joints from the distal end to the
base (each joint chosen with the masses of the drives beyond it) and repeats
the sweep until no choice changes: the fixed point; :attr:`Selection.iterations`
counts the sweeps (the last one changes nothing). The result is verified by
:func:`~manipcad.sizing.requirements.required_drive` — ``size`` itself — on
every case; a candidate that fails there (a rounding at ``margin=1.0``) is
struck out and the sweep repeated.

Example:
    >>> import manipcad
    >>> from manipcad.sizing.select import select_drives
    >>> from manipcad.trajectories import cosine
    >>> arm = manipcad.load_robot("cylindrical").without_drives()
    >>> traj = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], 1.6)
    >>> sel = select_drives(arm, [traj], joints=["turn"], dt=5e-3)   # doctest: +SKIP
"""

from __future__ import annotations

import math
from collections.abc import Callable, Mapping, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from manipcad.catalog import compatible_pairs, drive_fields, gears, motors
from manipcad.errors import InputError, ManipcadError, require_choice
from manipcad.fileio import atomic_write_text, dump_yaml, json_safe
from manipcad.model.robot import (
    DRIVE_MOUNTS,
    PRISMATIC,
    Drive,
    Robot,
    combine_bodies,
    mounts_tuple,
)
from manipcad.model.tree_file import robot_to_dict
from manipcad.sizing.limits import (
    ALL_LIMITS,
    FAIL,
    NA,
    PASS,
    UNKNOWN,
    LimitCheck,
    check_rated,
    rating_table,
)
from manipcad.sizing.motion import SampledMotion, sample_motion
from manipcad.sizing.motor import joint_torque, motor_series
from manipcad.sizing.requirements import required_drive
from manipcad.sizing.stats import (
    peak,
    time_mean,
    time_rms,
    trapezoid_weights,
    weighted_cubic_mean,
)
from manipcad.trajectories.base import Trajectory

#: objectives: name -> (what is minimized, unit)
OBJECTIVES: dict[str, tuple[str, str]] = {
    "mass": ("drive mass, motor + gear", "kg"),
    "rotor_inertia": ("rotor + gear inertia at the joint, J·i_r²", "kg·m²"),
    "power": ("mean electrical power u_a·i, largest over the cases", "W"),
}
#: the default margin: every rating at least 1.1 × what the motion needs
DEFAULT_MARGIN = 1.1
#: mount conventions of a drive's mass (module docstring; Robot.drive_mounts)
MOUNTS = DRIVE_MOUNTS
#: the gear type of a candidate without a gear
DIRECT = "direct"
#: the checks decided per candidate from per-joint statistics (no time series)
_CHEAP = ("speed", "gear_continuous", "gear_peak", "gear_speed", "gear_average",
          "gear_average_speed")
#: the checks that need the candidate's motor time series
_SERIES = ("continuous", "peak", "voltage")
#: elements per vectorized block (candidates × samples)
_BLOCK = 200_000
#: samples of the lower-bound pass (every m-th sample of the grid, and the peaks)
_SCREEN_SAMPLES = 256
#: candidates per step of the evaluation in objective order
_CHUNK = 256
#: how many alternatives and rejected candidates a report lists per joint
N_ALTERNATIVES = 5
#: most sweeps of the fixed point before giving up
MAX_ITERATIONS = 10


class NoFeasibleDrive(ManipcadError):
    """No candidate drive meets every check on a joint.

    Attributes:
        joint: the joint's name.
        closest: the candidate whose worst check margin is the largest (a dict
            as in :meth:`Candidate.to_dict`), or None when there are none.
        check: the check it fails (the worst), or "".
        considered: how many candidates were checked.
    """

    def __init__(self, joint: str, closest: dict | None, check: str, considered: int,
                 reason: str = "", need: float = 0.0) -> None:
        self.joint, self.closest, self.check, self.considered = joint, closest, check, considered
        if closest is None:
            msg = (f"joint {joint!r}: no candidate drive to check "
                   f"({reason or 'none in the catalogue'})")
        else:
            c = (closest.get("checks") or {}).get(check) or {}
            m = c.get("margin")
            if c.get("status") == UNKNOWN:
                how = f"cannot be checked: {check} unknown"
            elif c.get("status") == PASS and m is not None:
                how = (f"leaves {m:.1%} of its {check} rating, under the margin asked "
                       f"({need:.1%} of every rating)")
            elif m is not None:
                how = f"fails {check} (margin {m:+.1%})"
            else:
                how = closest.get("reason") or "fails"
            msg = (f"joint {joint!r}: no feasible drive among {considered} candidates; the "
                   f"closest, {closest['label']}, {how}")
        super().__init__(msg)


# --------------------------------------------------------------------------- candidates


@dataclass(frozen=True)
class Part:
    """A candidate drive: a motor and a gear (or none) from the catalogue.

    Attributes:
        motor: the motor's catalogue name (its key).
        gear: the gear's catalogue name, "" for a direct drive.
        maker: the motor's maker (lower case, e.g. "maxon").
        gear_type: "planetary", "harmonic", ... or "direct".
        mass: motor + gear mass, kg (nan if either is unknown).
        drive: the :class:`~manipcad.model.robot.Drive` the pair makes, as a
            robot file naming them would (gear efficiency, ratings referred to
            the joint and the motor shaft).
    """

    motor: str
    gear: str
    maker: str
    gear_type: str
    mass: float
    drive: Drive

    @property
    def label(self) -> str:
        """"MOTOR + GEAR" or "MOTOR (direct)"."""
        return f"{self.motor} + {self.gear}" if self.gear else f"{self.motor} (direct)"


class _Arrays:
    """Candidate drives' numbers as (C, 1) arrays, duck-typed as a :class:`Drive`
    for :func:`joint_torque` and :func:`motor_series` (module docstring)."""

    FIELDS = ("J", "k_v", "R", "L", "k_m", "k_w", "efficiency", "ratio")

    def __init__(self, columns: Mapping[str, np.ndarray]) -> None:
        for name in self.FIELDS:
            setattr(self, name, np.asarray(columns[name], dtype=float).reshape(-1, 1))
        self.M_f = (np.asarray(columns["M_f+"], dtype=float).reshape(-1, 1),
                    np.asarray(columns["M_f-"], dtype=float).reshape(-1, 1))

    def take(self, idx) -> _Arrays:
        out = object.__new__(_Arrays)
        for name in self.FIELDS:
            setattr(out, name, getattr(self, name)[idx])
        out.M_f = (self.M_f[0][idx], self.M_f[1][idx])
        return out


@dataclass
class CandidateTable:
    """Candidate drives as arrays, one row per (motor, gear) pair or direct drive.

    Attributes:
        motor, gear: (C,) part names ("" gear: a direct drive).
        maker, gear_type: (C,) lower-case maker of the motor; gear type or "direct".
        mass: (C,) motor + gear mass, kg (nan unknown).
        ratio: (C,) signed gear ratio i_r; J: (C,) rotor + gear inertia, kg·m².
        arrays: the drive numbers for the motor model (:class:`_Arrays`).
        rated: check name -> (C,) rating (:func:`~manipcad.sizing.limits.rating_table`'s form).
        geared: (C,) bool, the candidate has a gear.
        drive_of: row -> its :class:`Drive`, built by the parts library's own
            composition (what a robot file naming the pair gives).
    """

    motor: np.ndarray
    gear: np.ndarray
    maker: np.ndarray
    gear_type: np.ndarray
    mass: np.ndarray
    ratio: np.ndarray
    J: np.ndarray
    arrays: _Arrays
    rated: dict[str, np.ndarray]
    geared: np.ndarray
    drive_of: Callable[[int], Drive]
    _parts: dict[int, Part] = field(default_factory=dict, repr=False)

    def __len__(self) -> int:
        return int(self.motor.shape[0])

    def part(self, i: int) -> Part:
        """Candidate ``i`` as a :class:`Part` (its Drive built on first use)."""
        i = int(i)
        if i not in self._parts:
            self._parts[i] = Part(str(self.motor[i]), str(self.gear[i]), str(self.maker[i]),
                                  str(self.gear_type[i]), float(self.mass[i]), self.drive_of(i))
        return self._parts[i]

    def take(self, rows) -> CandidateTable:
        """The candidates at ``rows`` (indices or a boolean mask) as a table of their own.

        Example:
            >>> t = candidate_table()
            >>> sub = t.take(t.motor == "MM_614949")
            >>> set(sub.motor), len(sub) > 1
            ({'MM_614949'}, True)
        """
        rows = np.flatnonzero(rows) if np.asarray(rows).dtype == bool else np.asarray(rows)
        parent = self.drive_of
        return CandidateTable(
            motor=self.motor[rows], gear=self.gear[rows], maker=self.maker[rows],
            gear_type=self.gear_type[rows], mass=self.mass[rows], ratio=self.ratio[rows],
            J=self.J[rows], arrays=self.arrays.take(rows),
            rated={k: v[rows] for k, v in self.rated.items()}, geared=self.geared[rows],
            drive_of=lambda i: parent(int(rows[i])))

    def label(self, i: int) -> str:
        m, g = str(self.motor[i]), str(self.gear[i])
        return f"{m} + {g}" if g else f"{m} (direct)"

    @classmethod
    def from_parts(cls, parts: Sequence[Part]) -> CandidateTable:
        """A table of ready-made parts (their Drives give every number)."""
        drives = [p.drive for p in parts]
        rated, geared = rating_table(drives)
        cols = {k: np.array([float(getattr(d, k)) for d in drives]) for k in _Arrays.FIELDS}
        cols["M_f+"] = np.array([d.M_f[0] for d in drives])
        cols["M_f-"] = np.array([d.M_f[1] for d in drives])
        parts = tuple(parts)
        return cls(motor=np.array([p.motor for p in parts], dtype=object),
                   gear=np.array([p.gear for p in parts], dtype=object),
                   maker=np.array([p.maker.lower() for p in parts], dtype=object),
                   gear_type=np.array([p.gear_type.lower() for p in parts], dtype=object),
                   mass=np.array([p.mass for p in parts], dtype=float),
                   ratio=cols["ratio"], J=cols["J"], arrays=_Arrays(cols), rated=rated,
                   geared=geared, drive_of=lambda i: parts[i].drive)


def _column(df, name: str, rows: np.ndarray) -> np.ndarray:
    return df[name].to_numpy(dtype=float)[rows]


def _finite_or_nan(x: np.ndarray) -> np.ndarray:
    """A rating the data sheet does not bound (inf) is not known as a number: nan,
    as the parts library's composition leaves it out (:func:`manipcad.catalog.compose_gears`)."""
    return np.where(np.isfinite(x), x, np.nan)


def catalogue_table(prismatic: bool = False, ws: Any = None) -> CandidateTable:
    """Every candidate drive of the parts library (:mod:`manipcad.catalog`) for a
    revolute (or prismatic) joint, as arrays.

    The candidates: each compatible (motor, gear) pair of
    :func:`manipcad.catalog.compatible_pairs` (the makers' tables, and the
    library's adapter rule for gears without one) whose gear suits the joint
    (rotary gears for a revolute joint; screws, racks and belts for a prismatic
    one), and each motor alone as a direct drive on a revolute joint. The
    numbers are those of the Drive a robot file naming the pair gets
    (:func:`manipcad.catalog.drive_fields`) for a single gear: J = J_motor +
    J_gear (kg·m², motor shaft), i_r = direction·ratio, the gear's efficiency,
    its output ratings (N·m) and input-speed limits (rad/s) as printed, the
    motor's ratings; the voltage limit is the rated voltage. Each reported
    candidate's Drive is built by ``drive_fields`` itself (and the tests hold
    the arrays to it).

    Args:
        prismatic: candidates for a prismatic joint.
        ws: a workspace folder whose motor and gear files join the library.

    Returns:
        :class:`CandidateTable`.

    Example:
        >>> t = catalogue_table()
        >>> len(t) > 10000, bool(t.part(0).drive.ratio == t.ratio[0])
        (True, True)
    """

    m = motors(ws=ws)
    # a part without the numbers a Drive needs (rotor or gear inertia, a positive
    # resistance) cannot be modelled: left out
    J_m, R_m = m["J"].to_numpy(float), m["R"].to_numpy(float)
    m = m[np.isfinite(J_m) & (J_m >= 0) & (np.isnan(R_m) | (R_m > 0))]
    g = gears(ws=ws)
    J_g = g["J"].to_numpy(float)
    g = g[(g["linear"] == bool(prismatic)).to_numpy() & np.isfinite(J_g) & (J_g >= 0)]
    pairs = compatible_pairs(m, g)
    mi = m.index.get_indexer(pairs["motor"])
    gi = g.index.get_indexer(pairs["gear"])
    direct = np.arange(len(m)) if not prismatic else np.zeros(0, dtype=int)
    M = np.concatenate([mi, direct])
    P, D = len(mi), len(direct)
    nan_d = np.full(D, np.nan)

    def gear_col(name: str) -> np.ndarray:
        return np.concatenate([_column(g, name, gi), nan_d])

    ratio = np.concatenate([g["direction"].to_numpy(float)[gi] * g["ratio"].to_numpy(float)[gi],
                            np.ones(D)])
    J = _column(m, "J", M) + np.concatenate([_column(g, "J", gi), np.zeros(D)])
    cols = {"J": J, "ratio": ratio, "k_v": _column(m, "k_v", M), "R": _column(m, "R", M),
            "L": _column(m, "L", M), "k_m": _column(m, "k_m", M), "k_w": _column(m, "k_w", M),
            "efficiency": np.concatenate([_column(g, "efficiency", gi), np.ones(D)]),
            "M_f+": _column(m, "M_f", M), "M_f-": _column(m, "M_f", M)}
    rated = {"continuous": _column(m, "rated_torque", M), "peak": _column(m, "peak_torque", M),
             "speed": _column(m, "max_speed", M), "voltage": _column(m, "rated_voltage", M),
             "gear_continuous": _finite_or_nan(gear_col("max_continuous_torque")),
             "gear_peak": _finite_or_nan(gear_col("max_intermittent_torque")),
             "gear_speed": _finite_or_nan(gear_col("max_input_speed")),
             "gear_average": _finite_or_nan(gear_col("max_average_torque")),
             "gear_average_speed": _finite_or_nan(gear_col("max_average_input_speed"))}
    motor_names = m.index.to_numpy(dtype=object)[M]
    gear_names = np.concatenate([g.index.to_numpy(dtype=object)[gi],
                                 np.full(D, "", dtype=object)])
    mass = _column(m, "mass", M) + np.concatenate([_column(g, "mass", gi), np.zeros(D)])

    def drive_of(i: int) -> Drive:
        gear = str(gear_names[i])
        return Drive(**drive_fields(str(motor_names[i]), gear if gear else ()))

    return CandidateTable(
        motor=motor_names, gear=gear_names,
        maker=np.array([str(x).lower() for x in m["maker"].to_numpy()[M]], dtype=object),
        gear_type=np.concatenate([g["type"].to_numpy(dtype=object)[gi],
                                  np.full(D, DIRECT, dtype=object)]),
        mass=mass, ratio=ratio, J=J, arrays=_Arrays(cols), rated=rated,
        geared=np.concatenate([np.ones(P, dtype=bool), np.zeros(D, dtype=bool)]),
        drive_of=drive_of)


#: where the candidates come from: a function (prismatic, ws) -> CandidateTable
TABLE_SOURCE: Callable[..., CandidateTable] = catalogue_table

_TABLES: dict[tuple, CandidateTable] = {}


def candidate_table(prismatic: bool = False, ws: Any = None) -> CandidateTable:
    """The candidate drives of the parts library for a revolute (or prismatic) joint,
    built once per source and workspace (:func:`catalogue_table`).

    The cache is keyed by the source function itself, not its ``id``: the key holds it, so
    a source replaced and freed cannot have its address reused by the next one, which
    would then be handed the old source's table."""
    key = (TABLE_SOURCE, prismatic, None if ws is None else str(ws))
    if key not in _TABLES:
        _TABLES[key] = TABLE_SOURCE(prismatic, ws)
    return _TABLES[key]


# --------------------------------------------------------------------------- results


@dataclass(frozen=True)
class Candidate:
    """One candidate drive as the report gives it.

    Attributes:
        part: the motor and gear.
        objective: the objective's value (unit of :data:`OBJECTIVES`), nan if unknown.
        feasible: every check passes with the margin.
        checks: check name -> (required, rating, margin, status), the worst case
            over trajectories and payloads (units of :data:`ALL_LIMITS`; margin
            1 - required/rating). The motor torque and voltage checks of a
            candidate that fails a gear or speed check are not computed
            (status "not evaluated").
        binding: the check with the least margin ("" if none has one).
        binding_margin: its margin.
        reason: why it is infeasible, in words ("" if feasible).
        bounded: its motor torque and voltage requirements are lower bounds
            (from part of the samples: enough to rule it out), so its margins
            there are upper bounds.
    """

    part: Part
    objective: float
    feasible: bool
    checks: dict[str, tuple[float, float, float, str]]
    binding: str
    binding_margin: float
    reason: str = ""
    bounded: bool = False

    @property
    def label(self) -> str:
        return self.part.label

    def to_dict(self) -> dict[str, Any]:
        """JSON-ready: motor, gear, maker, gear_type, ratio, mass (kg), rotor_inertia
        (J·i_r², kg·m²), objective, feasible, binding, binding_margin, worst_margin,
        reason, checks {name: {required, rating, margin, status}}."""

        d = self.part.drive
        worst = [v[2] for v in self.checks.values() if math.isfinite(v[2])]
        return json_safe({
            "label": self.label, "motor": self.part.motor, "gear": self.part.gear or None,
            "maker": self.part.maker, "gear_type": self.part.gear_type,
            "ratio": float(d.ratio), "mass": self.part.mass,
            "rotor_inertia": float(d.reflected_inertia), "objective": self.objective,
            "feasible": self.feasible, "binding": self.binding or None,
            "binding_margin": self.binding_margin,
            "worst_margin": min(worst) if worst else None, "reason": self.reason or None,
            "bounded": self.bounded,
            "checks": {k: {"required": v[0], "rating": v[1], "margin": v[2], "status": v[3]}
                       for k, v in self.checks.items()},
        })


@dataclass(frozen=True)
class JointChoice:
    """The selection of one joint.

    Attributes:
        joint: its name; index: its index.
        chosen: the winner.
        alternatives: the next feasible candidates by objective (up to 5).
        rejected: the candidates with a smaller objective than the winner that
            fail, least objective first (up to 5), each with its reason.
        considered: how many candidates were checked; feasible: how many pass
            (among those evaluated: all unless ``skipped``).
        mount: "before" or "base"; mount_link: the link carrying the drive's
            mass ("" for the base); drive_mass: the winner's mass, kg.
        evaluated: candidates whose motor torque and voltage checks were made
            (the others failed a gear or speed check first, or were skipped).
        skipped: candidates that pass the gear and speed checks but were not
            evaluated further, being heavier (larger objective) than the winner
            and its alternatives (``count_all`` evaluates them).
    """

    joint: str
    index: int
    chosen: Candidate
    alternatives: tuple[Candidate, ...]
    rejected: tuple[Candidate, ...]
    considered: int
    feasible: int
    mount: str
    mount_link: str
    evaluated: int = 0
    skipped: int = 0

    def to_dict(self) -> dict[str, Any]:
        return {"joint": self.joint, "chosen": self.chosen.to_dict(),
                "alternatives": [c.to_dict() for c in self.alternatives],
                "rejected": [c.to_dict() for c in self.rejected],
                "considered": self.considered, "feasible": self.feasible,
                "evaluated": self.evaluated, "skipped": self.skipped,
                "mount": self.mount, "mount_link": self.mount_link or None,
                "drive_mass": self.chosen.part.mass}


@dataclass(frozen=True)
class Selection:
    """Drives chosen from the catalogue for a robot.

    Attributes:
        robot: the robot with the chosen drives, each drive's mass added as a
            point mass to the link carrying it (:func:`with_drive_masses`);
            its ``source`` says so. Save it with :func:`save_selection`.
        joints: per selected joint, its :class:`JointChoice` (joint order).
        iterations: sweeps to the fixed point (the last changed nothing).
        objective: "mass", "rotor_inertia" or "power"; margin: M (ratings >=
            M × required).
        payloads: the payload masses checked, kg (both ends of the range).
        trajectories: the trajectories' labels.
        dt: the sampling step, s.
        verified: every selected joint passes ``size``'s checks
            (:func:`~manipcad.sizing.requirements.required_drive`) on every case.
    """

    robot: Robot
    joints: tuple[JointChoice, ...]
    iterations: int
    objective: str
    margin: float
    payloads: tuple[float, ...]
    trajectories: tuple[str, ...]
    dt: float
    verified: bool = False
    history: tuple[tuple[str, ...], ...] = field(default=(), repr=False)

    @property
    def total_drive_mass(self) -> float:
        """Sum of the chosen drives' masses, kg."""
        return float(sum(c.chosen.part.mass for c in self.joints))

    @property
    def report(self) -> dict[str, Any]:
        """The report as JSON-ready data (:meth:`to_dict`)."""
        return self.to_dict()

    def to_dict(self) -> dict[str, Any]:
        """``{"robot", "objective", "objective_unit", "margin", "payloads" (kg),
        "trajectories", "dt" (s), "iterations", "verified", "total_drive_mass" (kg),
        "joints": [JointChoice.to_dict()]}``."""
        return {"robot": self.robot.name, "objective": self.objective,
                "objective_unit": OBJECTIVES[self.objective][1], "margin": self.margin,
                "payloads": list(self.payloads), "trajectories": list(self.trajectories),
                "dt": self.dt, "iterations": self.iterations, "verified": self.verified,
                "total_drive_mass": self.total_drive_mass,
                "joints": [c.to_dict() for c in self.joints]}


# --------------------------------------------------------------------------- masses


def mount_body(robot: Robot, joint: int, mount: str = "before") -> int:
    """The body that carries a drive's mass: the parent link of the joint for
    "before" (-1: the base), -1 for "base".

    Example:
        >>> import manipcad
        >>> mount_body(manipcad.load_robot("puma560"), 2)
        1
    """
    if mount not in MOUNTS:
        raise InputError("mount", robot.joint_names[joint], f"unknown mount {mount!r}; "
                         f"expected one of {', '.join(MOUNTS)}")
    return int(robot.parent[joint]) if mount == "before" else -1


def with_drive_masses(robot: Robot, masses: Mapping[int, float],
                      mounts: Mapping[int, str] | None = None) -> Robot:
    """The robot with each drive's mass as a point mass on the link that carries it.

    Args:
        robot: the robot.
        masses: joint index -> drive mass (motor + gear), kg.
        mounts: joint index -> "before" (on the parent joint's link, at this
            joint's origin: the convention) or "base" (not on the arm: adds
            nothing); default the robot's own ``drive_mounts`` (its file's).

    Returns:
        A new robot (this one is unchanged).

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("puma560")
        >>> heavier = with_drive_masses(arm, {2: 1.5})
        >>> round(float(heavier.mass[1] - arm.mass[1]), 9)
        1.5
    """
    if mounts is None:
        mounts = {robot.joint_index(j): m for j, m in robot.drive_mounts}
    mass, com, inertia = robot.mass.copy(), robot.com.copy(), robot.inertia.copy()
    for j, m in masses.items():
        if not (math.isfinite(m) and m >= 0):
            raise InputError("drive mass", robot.joint_names[j], f"must be >= 0 kg, got {m}")
        b = mount_body(robot, j, mounts.get(j, "before"))
        if b < 0 or m == 0:
            continue
        mass[b], com[b], inertia[b] = combine_bodies(mass[b], com[b], inertia[b], float(m),
                                                     robot.placement_p[j], np.zeros((3, 3)))
    return robot.replace(mass=mass, com=com, inertia=inertia)


# --------------------------------------------------------------------------- evaluation


def _columns(motion: SampledMotion, j: int) -> tuple[np.ndarray, ...]:
    return (motion.tau_rigid[:, j], motion.qd[:, j], motion.qdd[:, j],
            motion.dtau_rigid[:, j], motion.jerk[:, j])


def _series_requirements(arr: _Arrays, motion: SampledMotion, j: int,
                         rows: np.ndarray | None = None, *, power: bool = True
                         ) -> dict[str, np.ndarray]:
    """RMS and peak motor torque (N·m), peak armature voltage (V) and mean
    electrical power (W) of each candidate on one motion: ``size``'s motor model
    (:func:`joint_torque`, :func:`motor_series`) broadcast over the candidates.

    With ``rows`` (sample indices), only those samples are evaluated and the
    results are lower bounds: the peaks over part of the grid, and the RMS from
    the part of the trapezoidal sum those samples make (no power then)."""
    cols = _columns(motion, j)
    t = motion.t
    if rows is not None:
        cols = tuple(c[rows] for c in cols)
        w = trapezoid_weights(t)[rows] / float(t[-1] - t[0])
    tau_rigid, qd, qdd, dtau, jerk = cols
    C = arr.ratio.shape[0]
    out = {k: np.empty(C) for k in ("continuous", "peak", "voltage", "power")}
    step = max(1, _BLOCK // max(1, qd.shape[0]))
    for k in range(0, C, step):
        sub = arr.take(slice(k, k + step))
        tau = joint_torque(sub, sub.ratio, tau_rigid, qd, qdd)
        s = motor_series(sub, sub.ratio, tau, qd, qdd, dtau, jerk, tau_rigid)
        sl = slice(k, k + sub.ratio.shape[0])
        out["peak"][sl] = peak(s.torque, axis=1)
        out["voltage"][sl] = peak(s.voltage, axis=1)
        if rows is None:
            out["continuous"][sl] = time_rms(s.torque, t, axis=1)
            out["power"][sl] = (time_mean(s.voltage * s.current, t, axis=1) if power
                                else np.nan)
        else:
            out["continuous"][sl] = np.sqrt(np.square(s.torque) @ w)
            out["power"][sl] = np.nan
    return out


def _screen_rows(motion: SampledMotion, j: int) -> np.ndarray:
    """The samples of the cheap lower-bound pass: every m-th sample (about
    :data:`_SCREEN_SAMPLES`) and where each input of the motor model peaks."""
    N = motion.t.shape[0]
    m = max(1, N // _SCREEN_SAMPLES)
    extra = [int(np.argmax(np.abs(c))) for c in _columns(motion, j)]
    return np.unique(np.concatenate([np.arange(0, N, m), extra]))


@dataclass
class _JointEval:
    """Every candidate of one joint: worst-case requirements, checks, feasibility."""

    idx: np.ndarray                 # candidate indices into the table
    checks: dict[str, LimitCheck]
    evaluated: np.ndarray           # motor series computed (exactly or as bounds)
    bounded: np.ndarray             # motor checks from lower bounds of the requirement
    ok: np.ndarray                  # every check passes with the margin
    objective: np.ndarray
    worst: np.ndarray               # least finite margin over the checks (nan: none)
    unknown_objective: np.ndarray
    skipped: np.ndarray             # could be feasible, not evaluated: heavier than needed


def _evaluate_joint(table: CandidateTable, idx: np.ndarray, motions: Sequence[SampledMotion],
                    j: int, need: float, allow_unknown: bool, objective: str,
                    want: int | None = None) -> _JointEval:
    """Check the candidates ``idx`` on joint ``j`` over the motions (module docstring).

    Three passes, each on fewer candidates: the gear and speed checks from the
    joint's statistics (exact, O(C)); lower bounds of the motor torque and
    voltage requirements on a few hundred samples (a candidate that fails with
    its lower bound fails); the full motor series of the rest. With ``want``
    (and an objective known before the series: mass, rotor inertia) the last
    two passes go through the candidates in objective order and stop once
    ``want`` feasible ones are found (ties included): the rest are "skipped"."""
    r = np.abs(table.ratio[idx])
    C = idx.size
    rated = {k: v[idx] for k, v in table.rated.items()}
    geared = table.geared[idx]
    req: dict[str, np.ndarray] = {k: np.full(C, -np.inf) for k in ALL_LIMITS}
    for mo in motions:
        tau_rigid, qd = mo.tau_rigid[:, j], mo.qd[:, j]
        stats = {"gear_continuous": float(time_rms(tau_rigid, mo.t)),
                 "gear_peak": float(peak(tau_rigid)),
                 "gear_average": float(weighted_cubic_mean(tau_rigid, qd, mo.t)),
                 "speed": r * float(peak(qd)),
                 "gear_average_speed": r * float(time_mean(np.abs(qd), mo.t))}
        stats["gear_speed"] = stats["speed"]
        for k in _CHEAP:
            req[k] = np.maximum(req[k], stats[k])
    cheap = check_rated({k: req[k] for k in _CHEAP}, rated, geared)
    passing = np.ones(C, dtype=bool)
    for k in _CHEAP:
        passing &= _ok(cheap[k], need, allow_unknown)
    eta_unknown = np.isnan(table.arrays.efficiency[idx, 0])
    mass_known = np.isfinite(table.mass[idx])
    # the motor series: of the candidates that pass the cheap checks and could be chosen
    series_ok = passing & mass_known & (~eta_unknown | allow_unknown)
    for k in _SERIES:
        req[k] = np.full(C, np.nan)
    power = np.full(C, np.nan)
    bounded = np.zeros(C, dtype=bool)
    done = np.zeros(C, dtype=bool)

    screen = {id(mo): _screen_rows(mo, j) for mo in motions}

    def run(sel: np.ndarray) -> None:
        """Screen, then fully evaluate, the candidates at positions ``sel``."""
        done[sel] = True
        arr = table.arrays.take(idx[sel])
        lower = {k: np.full(sel.size, -np.inf) for k in _SERIES}
        for mo in motions:
            s = _series_requirements(arr, mo, j, screen[id(mo)])
            for k in _SERIES:
                lower[k] = np.maximum(lower[k], s[k])
        lb = check_rated(lower, {k: rated[k][sel] for k in _SERIES}, geared[sel])
        out = np.zeros(sel.size, dtype=bool)
        for k in _SERIES:
            out |= ~_ok(lb[k], need, False)
        out &= ~eta_unknown[sel]       # at η unknown the values at η = 1 bound nothing
        for k in _SERIES:
            req[k][sel[out]] = lower[k][out]
        bounded[sel[out]] = True
        full = sel[~out]
        if full.size:
            arr = arr.take(~out)
            worst = {k: np.full(full.size, -np.inf) for k in (*_SERIES, "power")}
            for mo in motions:
                s = _series_requirements(arr, mo, j, power=objective == "power")
                for k in worst:
                    worst[k] = np.maximum(worst[k], s[k])
            for k in _SERIES:
                req[k][full] = worst[k]
            power[full] = worst["power"]

    eligible = np.flatnonzero(series_ok)
    if objective == "power" or want is None:
        run(eligible)
    else:
        value = (table.mass[idx] if objective == "mass"
                 else table.J[idx] * table.ratio[idx] ** 2)[eligible]
        order = eligible[np.argsort(value, kind="stable")]
        value = np.sort(value, kind="stable")
        pos, found, limit = 0, 0, math.inf
        while pos < order.size and value[pos] <= limit:
            stop = pos + _CHUNK
            chunk = order[pos:stop]
            chunk = chunk[value[pos:stop] <= limit]
            run(chunk)
            chk = check_rated({k: req[k][chunk] for k in _SERIES},
                              {k: rated[k][chunk] for k in _SERIES}, geared[chunk])
            good = ~bounded[chunk]
            for k in _SERIES:
                good &= _ok(chk[k], need, allow_unknown) | (allow_unknown & eta_unknown[chunk])
            hits = np.flatnonzero(good)
            if found < want <= found + hits.size:
                limit = float(value[pos + hits[want - found - 1]])
            found += hits.size
            pos = stop
    series = check_rated({k: req[k] for k in _SERIES}, rated, geared)
    checks: dict[str, LimitCheck] = {}
    for name in ALL_LIMITS:
        c = series[name] if name in _SERIES else cheap[name]
        if name in _SERIES:
            st = np.array(c.status, dtype=object)
            st[~done] = "not evaluated"
            st[passing & eta_unknown] = UNKNOWN
            m = np.where(passing & eta_unknown, np.nan, c.margin)
            c = LimitCheck(c.name, c.description, c.unit, c.required, c.limit, m,
                           tuple(st.tolist()))
        checks[name] = c
    ok = done & ~bounded
    for k in _SERIES:
        ok &= _ok(checks[k], need, allow_unknown)
    value = {"mass": table.mass[idx], "rotor_inertia": table.J[idx] * table.ratio[idx] ** 2,
             "power": power}[objective]
    unknown_obj = ~np.isfinite(value) | ~mass_known       # the mass loads the arm
    margins = np.vstack([checks[k].margin for k in ALL_LIMITS])
    finite = np.where(np.isfinite(margins), margins, np.inf)
    worst_m = finite.min(axis=0)
    worst_m[~np.isfinite(worst_m)] = np.nan
    return _JointEval(idx=idx, checks=checks, evaluated=done, bounded=bounded,
                      ok=ok & ~unknown_obj, objective=value, worst=worst_m,
                      unknown_objective=unknown_obj, skipped=series_ok & ~done)


def _ok(check: LimitCheck, need: float, allow_unknown: bool) -> np.ndarray:
    """Per candidate: the check passes with the margin (``need`` = 1 - 1/M), is n/a,
    or is unknown and unknowns are allowed."""
    st = np.array(check.status)
    m = np.where(np.isfinite(check.margin), check.margin, -np.inf)
    good = ((st == PASS) & (m >= need)) | (st == NA)
    if allow_unknown:
        good |= st == UNKNOWN
    return good


def _candidate(table: CandidateTable, ev: _JointEval, k: int, need: float) -> Candidate:
    """The report entry of candidate ``k`` (position in ``ev.idx``)."""
    checks = {name: (float(c.required[k]), float(c.limit[k]), float(c.margin[k]), c.status[k])
              for name, c in ev.checks.items()}
    graded = [(v[2], name) for name, v in checks.items() if math.isfinite(v[2])]
    binding, bmargin = ("", math.nan) if not graded else (min(graded)[1], min(graded)[0])
    reason = ""
    if not ev.ok[k]:
        fails = sorted((v[2], n) for n, v in checks.items() if v[3] == FAIL)
        short = sorted((v[2], n) for n, v in checks.items() if v[3] == PASS and v[2] < need)
        unknown = [n for n, v in checks.items() if v[3] == UNKNOWN]
        bound = bool(ev.bounded[k])

        def pct(m: float, n: str) -> str:
            at_most = "at most " if bound and n in _SERIES else ""
            return f"{n} ({at_most}{m:+.0%})"

        if fails:
            reason = "fails " + ", ".join(pct(m, n) for m, n in fails)
        elif short:
            reason = "margin under the one asked: " + ", ".join(pct(m, n) for m, n in short)
        elif unknown:
            reason = "cannot be checked: " + ", ".join(unknown) + " unknown"
        elif ev.unknown_objective[k]:
            reason = ("mass unknown (the catalogue gives none; a drive's mass loads the arm)"
                      if not math.isfinite(table.mass[ev.idx[k]]) else "objective unknown")
    return Candidate(part=table.part(ev.idx[k]), objective=float(ev.objective[k]),
                     feasible=bool(ev.ok[k]), checks=checks, binding=binding,
                     binding_margin=bmargin, reason=reason, bounded=bool(ev.bounded[k]))


def _failing_check(cand: Candidate, need: float) -> str:
    fails = sorted((v[2], n) for n, v in cand.checks.items()
                   if v[3] == FAIL or (v[3] == PASS and v[2] < need))
    if fails:
        return fails[0][1]
    unknown = [n for n, v in cand.checks.items() if v[3] == UNKNOWN]
    return unknown[0] if unknown else ("objective" if not math.isfinite(cand.objective) else "")


def _choose(table: CandidateTable, ev: _JointEval, name: str, j: int, need: float,
            banned: set[int]) -> tuple[int, JointChoice | None]:
    """The winner's position in ``ev.idx`` and the joint's report (``banned``: table
    rows struck out); raises :class:`NoFeasibleDrive` when none is feasible."""
    ok = ev.ok & ~np.isin(ev.idx, np.fromiter(banned, dtype=int, count=len(banned)))
    order = np.lexsort((-np.nan_to_num(ev.worst, nan=-np.inf),
                        np.where(np.isfinite(ev.objective), ev.objective, np.inf)))
    feas = order[ok[order]]
    if not feas.size:
        raise _no_feasible(table, ev, name, need)
    win = int(feas[0])
    alts = tuple(_candidate(table, ev, k, need) for k in feas[1:1 + N_ALTERNATIVES])
    obj = ev.objective[order]
    lighter = order[~ok[order] & np.isfinite(obj) & (obj <= ev.objective[win])][:N_ALTERNATIVES]
    rejected = tuple(_candidate(table, ev, k, need) for k in lighter)
    choice = JointChoice(joint=name, index=j, chosen=_candidate(table, ev, win, need),
                         alternatives=alts, rejected=rejected, considered=int(ev.idx.size),
                         feasible=int(ok.sum()), mount="", mount_link="",
                         evaluated=int(ev.evaluated.sum()), skipped=int(ev.skipped.sum()))
    return win, choice


def _no_feasible(table: CandidateTable, ev: _JointEval, name: str, need: float) -> NoFeasibleDrive:
    if ev.idx.size == 0:
        return NoFeasibleDrive(name, None, "", 0, "no candidate passes the maker and gear "
                               "type filters")
    # the closest: the largest worst margin; a candidate not evaluated on the motor
    # checks has a worst margin at most its cheap one, so rank all by what is known
    w = np.where(np.isfinite(ev.worst), ev.worst, -np.inf)
    partial = ~np.isfinite(table.mass[ev.idx])        # never eligible: no mass
    for c in ev.checks.values():
        st = np.array(c.status, dtype=object)
        partial |= (st == UNKNOWN) | (st == "not evaluated")
    k = int(np.lexsort((-w, partial))[0])     # fully checked first, then the best worst margin
    cand = _candidate(table, ev, k, need)
    return NoFeasibleDrive(name, cand.to_dict(), _failing_check(cand, need), int(ev.idx.size),
                           need=need)


# --------------------------------------------------------------------------- selection


def _label(traj: Any, k: int) -> str:
    return str(getattr(traj, "label", "") or getattr(traj, "name", "") or f"trajectory {k + 1}")


def _payload_ends(payload: Any, payload_range: Any) -> tuple[float, ...]:
    if payload is not None and payload_range is not None:
        raise InputError("payload", "", "give a payload or a payload range, not both")
    if payload_range is not None:
        try:
            lo, hi = (float(x) for x in payload_range)
        except (TypeError, ValueError):
            raise InputError("payload_range", "", "expected two masses LO, HI (kg)") from None
        if not (math.isfinite(lo) and math.isfinite(hi) and 0 <= lo <= hi):
            raise InputError("payload_range", "", f"needs 0 <= LO <= HI kg, got {lo}, {hi}")
        return (lo,) if lo == hi else (lo, hi)
    if payload is None:
        return (0.0,)
    try:
        p = float(payload)
    except (TypeError, ValueError):
        raise InputError("payload", "", f"expected a mass in kg, got {payload!r}") from None
    if not (math.isfinite(p) and p >= 0):
        raise InputError("payload", "", f"must be a mass >= 0 kg, got {p}")
    return (p,)


def _filter(table: CandidateTable, makers: Sequence[str] | None,
            gear_types: Sequence[str] | None) -> np.ndarray:
    keep = np.ones(len(table), dtype=bool)
    if makers:
        want = {m.strip().lower() for m in makers if m.strip()}
        known = set(table.maker.tolist())
        bad = sorted(want - known)
        if bad:
            raise InputError("makers", "", f"no parts of {', '.join(bad)}; makers: "
                             f"{', '.join(sorted(known))}")
        keep &= np.isin(table.maker, list(want))
    if gear_types:
        want = {g.strip().lower() for g in gear_types if g.strip()}
        known = set(table.gear_type.tolist()) | {DIRECT}
        bad = sorted(want - known)
        if bad:
            raise InputError("gear_types", "", f"unknown gear type {', '.join(bad)}; types: "
                             f"{', '.join(sorted(known))}")
        keep &= np.isin(table.gear_type, list(want))
    return np.flatnonzero(keep)


def select_drives(robot: Robot, trajectories: Sequence[Trajectory], *,
                  payload: float | None = None,
                  payload_range: tuple[float, float] | None = None,
                  objective: str = "mass", margin: float = DEFAULT_MARGIN,
                  makers: Sequence[str] | None = None,
                  gear_types: Sequence[str] | None = None,
                  joints: Sequence[int | str] | None = None,
                  mounts: Mapping[int | str, str] | None = None,
                  allow_unknown: bool = False, dt: float = 1e-3,
                  t_end: float | None = None, verify: bool = True, ws: Any = None,
                  count_all: bool = False) -> Selection:
    """Choose each joint's drive from the catalogue (module docstring).

    Args:
        robot: the arm; its link masses must not already hold drive masses.
            The selected joints' drives are replaced; the others keep theirs.
        trajectories: one or more trajectories of ``robot.n`` joints.
        payload: a payload mass on the last link, kg (added to any payload the
            robot already carries; at the tool point, as ``size --payload``).
        payload_range: (LO, HI) kg: both ends are checked. Give one of the two or neither.
        objective: "mass" (default), "rotor_inertia" or "power" (:data:`OBJECTIVES`).
        margin: M >= 1: every rating at least M × what the motion needs
            (default :data:`DEFAULT_MARGIN`; 1.0 is ``size``'s limits).
        makers: keep only motors of these makers (e.g. ["maxon", "faulhaber"]).
        gear_types: keep only these gear types ("planetary", "harmonic", ...;
            "direct" for no gear).
        joints: the joints to select for (names or indices; default all).
        mounts: joint -> "before" or "base": where its drive's mass sits (default
            the robot's ``drive_mounts``, from its file, else "before").
        allow_unknown: accept a check that cannot be made (``size --allow-unknown``).
        dt: sampling step, s (``size``'s default 1e-3).
        t_end: end of every run, s (default each trajectory's duration).
        verify: check the result with :func:`~manipcad.sizing.requirements.required_drive`.
        ws: a workspace folder whose motor and gear files join the catalogue.
        count_all: evaluate every candidate, so that the feasible counts are
            complete; by default (objectives mass and rotor_inertia) the motor
            series are evaluated in objective order only until the winner and
            its alternatives are found, and the heavier candidates that pass the
            gear and speed checks are counted as "skipped".

    Returns:
        :class:`Selection`.

    Raises:
        NoFeasibleDrive: a joint has no feasible candidate (naming it, the
            closest candidate and the check it fails).
        InputError: bad arguments.

    Example:
        >>> import manipcad
        >>> from manipcad.trajectories import cosine
        >>> arm = manipcad.load_robot("cylindrical").without_drives()
        >>> traj = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], 1.6)
        >>> sel = select_drives(arm, [traj], joints=["turn"], dt=1e-2, margin=1.0)
        >>> sel.joints[0].joint, sel.joints[0].chosen.feasible
        ('turn', True)
    """
    require_choice("objective", "", objective, OBJECTIVES, "objective")
    try:
        margin = float(margin)
    except (TypeError, ValueError):
        raise InputError("margin", "", f"expected a number >= 1, got {margin!r}") from None
    if not (math.isfinite(margin) and margin >= 1.0):
        raise InputError("margin", "", f"must be a number >= 1 (1.0: exactly the ratings), "
                         f"got {margin}")
    trajectories = list(trajectories)
    if not trajectories:
        raise InputError("trajectories", "", "give at least one trajectory")
    payloads = _payload_ends(payload, payload_range)
    need = 1.0 - 1.0 / margin
    sel_joints = (list(range(robot.n)) if joints is None
                  else sorted({robot.joint_index(j) for j in joints}))
    mount_of = {j: "before" for j in range(robot.n)}
    for name, m in robot.drive_mounts:             # the robot file's drive_mounts
        mount_of[robot.joint_index(name)] = m
    for key, m in (mounts or {}).items():
        j = robot.joint_index(key)
        mount_body(robot, j, m)
        mount_of[j] = m
    if "selected by manipcad select" in robot.source:
        raise InputError("robot", "", "its link masses already hold the drive masses of a "
                         "previous selection (see its source); select on the robot it was "
                         "made from")
    cand_idx = {}
    for j in sel_joints:
        table = candidate_table(robot.joint_types[j] == PRISMATIC, ws)
        cand_idx[j] = _filter(table, makers, gear_types)

    drives = list(robot.drives)
    masses: dict[int, float] = {}
    banned: dict[int, set[int]] = {j: set() for j in sel_joints}
    chosen: dict[int, JointChoice] = {}
    history: list[tuple[str, ...]] = []
    cache: dict[tuple, list[SampledMotion]] = {}

    def motions_for(current: dict[int, float]) -> list[SampledMotion]:
        key = tuple(sorted(current.items()))
        if key not in cache:
            arm = with_drive_masses(robot, current, mount_of)
            cache.clear()
            cache[key] = [sample_motion(arm, tr, t_end=t_end, dt=dt, payload=p)
                          for tr in trajectories for p in payloads]
        return cache[key]

    # a joint's torque depends only on the bodies it moves: the masses mounted on them
    moved = [set() for _ in range(robot.n)]
    for b in range(robot.n):
        a = b
        while a >= 0:
            moved[a].add(b)
            a = int(robot.parent[a])
    evaluated: dict[tuple, _JointEval] = {}

    def evaluate(j: int, table: CandidateTable) -> _JointEval:
        want = None if count_all else 1 + N_ALTERNATIVES + len(banned[j])
        key = (j, want, tuple(sorted((k, m) for k, m in masses.items()
                                     if mount_body(robot, k, mount_of[k]) in moved[j])))
        if key not in evaluated:
            evaluated[key] = _evaluate_joint(table, cand_idx[j], motions_for(masses), j, need,
                                             allow_unknown, objective, want)
        return evaluated[key]

    iterations = 0
    verified = False
    rows: dict[int, int] = {}
    for _ in range(MAX_ITERATIONS):
        iterations += 1
        changed = False
        for j in sorted(sel_joints, reverse=True):
            table = candidate_table(robot.joint_types[j] == PRISMATIC, ws)
            ev = evaluate(j, table)
            win, choice = _choose(table, ev, robot.joint_names[j], j, need, banned[j])
            body = mount_body(robot, j, mount_of[j])
            choice = JointChoice(**{**choice.__dict__, "mount": mount_of[j],
                                    "mount_link": "" if body < 0 else robot.link_names[body]})
            part = choice.chosen.part
            if j not in chosen or chosen[j].chosen.part != part:
                changed = True
            chosen[j] = choice
            rows[j] = int(ev.idx[win])
            masses[j] = part.mass
            drives[j] = part.drive
        history.append(tuple(chosen[j].chosen.label for j in sel_joints))
        if changed:
            continue
        if not verify:
            break
        failed = _verify(robot, drives, masses, mount_of, trajectories, payloads, sel_joints,
                         dt, t_end, allow_unknown)
        if not failed:
            verified = True
            break
        for j in failed:
            banned[j].add(rows[j])
    else:
        raise ManipcadError(f"drive selection did not reach a fixed point in {MAX_ITERATIONS} "
                            f"sweeps (choices per sweep: {history})")
    arm = with_drive_masses(robot, masses, mount_of).replace(drives=tuple(drives))
    note = ("drives selected by manipcad select (" + objective + f", margin {margin:g}); "
            "link masses include the drives' masses: " + ", ".join(
                f"{robot.joint_names[j]} {masses[j]:.4g} kg on "
                f"{chosen[j].mount_link or 'the base'}" for j in sel_joints))
    arm = arm.replace(source=(robot.source + "; " if robot.source else "") + note,
                      drive_mounts=mounts_tuple({robot.joint_names[j]: m
                                                 for j, m in mount_of.items()}))
    return Selection(robot=arm, joints=tuple(chosen[j] for j in sel_joints),
                     iterations=iterations, objective=objective, margin=margin,
                     payloads=payloads,
                     trajectories=tuple(_label(t, k) for k, t in enumerate(trajectories)),
                     dt=dt, verified=verified, history=tuple(history))


def _verify(robot: Robot, drives: list, masses: dict[int, float], mounts: dict[int, str],
            trajectories: Sequence[Trajectory], payloads: Sequence[float],
            joints: Sequence[int], dt: float, t_end: float | None,
            allow_unknown: bool) -> list[int]:
    """The selected joints that ``size`` (:func:`required_drive`) does not pass on some case,
    by the drive checks (:data:`ALL_LIMITS`): the joint's own position, speed and torque
    limits are the trajectory's, which no drive changes."""

    arm = with_drive_masses(robot, masses, mounts).replace(drives=tuple(drives))
    bad = set()
    for tr in trajectories:
        for p in payloads:
            req = required_drive(arm, tr, t_end=t_end, dt=dt, payload=p)
            for j in joints:
                states = {c.status[j] for name, c in req.checks.items() if name in ALL_LIMITS}
                if FAIL in states or (UNKNOWN in states and not allow_unknown):
                    bad.add(j)
    return sorted(bad)


def save_selection(selection: Selection, path: Any) -> Any:
    """Write the selected robot as a tree-form robot file (:meth:`Robot.save`'s form)
    with a header naming the chosen parts, their masses and where they sit.

    Args:
        selection: the result of :func:`select_drives`.
        path: the .yaml file (str or Path; its folder must exist).

    Returns:
        The path written.
    """

    lines = ["# manipcad robot, tree form (docs/robot-files.md); SI units: m, rad, kg, kg·m²,",
             "# drive fields as in robot files (motor side J kg·m², R Ω, L H, k_m N·m/A, ...).",
             f"# Drives selected by `manipcad select` (objective {selection.objective}, margin "
             f"{selection.margin:g}, payloads {', '.join(f'{p:g}' for p in selection.payloads)}"
             " kg):"]
    for c in selection.joints:
        lines.append(f"#   {c.joint}: {c.chosen.label}, {c.chosen.part.mass:.4g} kg on "
                     f"{c.mount_link or 'the base'}")
    lines.append("# The link masses include these drive masses (point masses at the joint "
                 "origins).")
    text = "\n".join(lines) + "\n" + dump_yaml(
        robot_to_dict(selection.robot), sort_keys=False, allow_unicode=True,
        default_flow_style=None, width=100)
    return atomic_write_text(path, text)


__all__ = ["select_drives", "Selection", "JointChoice", "Candidate", "Part", "NoFeasibleDrive",
           "OBJECTIVES", "DEFAULT_MARGIN", "with_drive_masses", "save_selection",
           "catalogue_table", "candidate_table", "CandidateTable", "mount_body"]
