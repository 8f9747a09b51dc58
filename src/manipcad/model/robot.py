"""The manipulator model: a kinematic tree of revolute and prismatic joints.

Every joint ``i`` is a fixed placement ``(R_i, p_i)`` relative to its parent's
body frame (the base frame when ``parent[i] == -1``) followed by a motion about
the local z axis: a rotation by ``q_i + offset_i`` (revolute) or a translation
by ``q_i + offset_i`` (prismatic). The body frame of link ``i`` is the frame
after that motion, so

    T_parent_i(q) = [R_i, p_i] · Rot_z(q_i + offset_i)        (revolute)
    T_parent_i(q) = [R_i, p_i] · Trans_z(q_i + offset_i)      (prismatic)

This is the modified Denavit-Hartenberg frame the paper uses (section 4.1);
standard DH and URDF are mapped onto it by the loaders.

The model holds the description only; the compiled algorithms read one packed
table (:attr:`Robot.table`) so a call passes few arrays and allocates little.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

import numpy as np
from numba.extending import register_jitable

from manipcad.errors import InertiaWarning, InputError, ManipcadWarning, ModelError
from manipcad.model.html import robot_html

#: where a drive's own mass can sit (Robot.drive_mounts): on the link before its joint,
#: or off the arm
DRIVE_MOUNTS = ("before", "base")

REVOLUTE = "revolute"
PRISMATIC = "prismatic"
JOINT_TYPES = (REVOLUTE, PRISMATIC)

# Column layout of the packed model table read by the compiled kernels.
COL_R = 0  # 9: placement rotation, row-major (parent <- joint)
COL_P = 9  # 3: placement translation in the parent body frame, m
COL_OFFSET = 12  # joint offset added to q, rad or m
COL_TYPE = 13  # 0 revolute, 1 prismatic
COL_PARENT = 14  # parent index, -1 for the base
COL_MASS = 15  # kg
COL_COM = 16  # 3: centre of mass in the body frame, m
COL_IC = 19  # 9: inertia about the centre of mass in the body frame, kg·m²
COL_JR = 28  # J·i_r², joint-referred rotor inertia, kg·m² (or kg for prismatic)
COL_BV = 29  # k_v·i_r², joint-referred viscous friction, N·m·s/rad
COL_FCP = 30  # |i_r|·M_f+, joint-referred dry friction in positive motion, N·m
COL_FCN = 31  # |i_r|·M_f-, joint-referred dry friction magnitude in negative motion, N·m
TABLE_COLS = 32


@dataclass(frozen=True)
class Drive:
    """A DC servo drive of one joint: motor, power amplifier and gearbox (paper 3.1).

    All motor quantities are on the motor side of the gearbox; the joint sees
    the rotor inertia as ``J·i_r²``, the viscous friction as ``k_v·i_r²·qd`` and
    the dry friction as ``|i_r|·M_f·sign(qd)``.

    Attributes:
        J: rotor plus gearbox inertia on the motor shaft, kg·m².
        ratio: gear ratio i_r = motor angle / joint coordinate (rad/rad, or rad/m
            for a prismatic joint); its sign gives the direction.
        k_v: viscous friction on the motor shaft, N·m·s/rad.
        M_f: dry (Coulomb) friction on the motor shaft as (positive motion,
            negative motion) magnitudes, N·m: the kinetic friction of a turning motor.
        M_s: static (break-away) friction on the motor shaft as (positive, negative)
            magnitudes, N·m, each >= the matching M_f: a stuck drive breaks away only
            when the torque on it exceeds M_s, then slides with M_f. None (the
            default, what drive data without a break-away value give): equal to M_f
            (:attr:`static_friction` gives the pair in force).
        R: armature resistance, Ω.
        L: armature inductance, H.
        k_m: torque constant, N·m/A.
        k_w: back-EMF constant, V·s/rad.
        k_u: power amplifier gain, V/V.
        u_max: amplifier output limit (the edge of its linear zone), V.
        name: catalog name of the motor, or "".
        gear: catalog name of the gearbox, or "".
        rated_torque: continuous motor torque, N·m (nan if unknown).
        peak_torque: peak motor torque, N·m (nan if unknown).
        max_speed: maximum motor speed, rad/s (nan if unknown).
        rated_voltage: rated armature voltage, V (nan if unknown).
        rated_current: continuous armature current, A (nan if unknown).
        stiffness: torsional stiffness k_s of the transmission, joint side,
            N·m/rad (N/m for a prismatic joint); inf for a rigid gear.
        damping: damping d_s of the transmission, joint side, N·m·s/rad (N·s/m).
        backlash: half-width b of the gear's backlash gap, joint side, rad (m);
            needs a finite stiffness (the contact stiffness).
        efficiency: gear (chain) efficiency in (0, 1]; the motor supplies
            P/(i_r·η) while it drives the load and P·η/i_r while the load
            drives it back (docs/sizing.md); 1 when no gear is given, nan when the
            gear's efficiency is unknown (its source gives none: sizing then
            reports the motor torque and voltage checks it cannot make as unknown).
        gear_rated_torque: the gear's rated (continuous) output torque, N·m
            (N), referred to the joint (nan if unknown).
        gear_peak_torque: the gear's repeated-peak output torque, N·m (N),
            referred to the joint (nan if unknown).
        gear_max_input_speed: the gear's maximum input speed, referred to the
            motor shaft, rad/s (nan if unknown).
        gear_average_torque: the gear's limit for the average load torque (a
            strain-wave catalogue's rating), N·m (N), referred to the joint
            (nan if unknown or not rated).
        gear_average_input_speed: the gear's limit for the average input
            speed, referred to the motor shaft, rad/s (nan if unknown or not rated).
        assumed: the fields whose values are assumed rather than printed on a
            data sheet, as sorted (field, why) pairs, e.g. (("efficiency", "Harmonic
            Drive AG's efficiency model ..."),); ``size --strict`` takes them as unknown.
    """

    J: float = 0.0
    ratio: float = 1.0
    k_v: float = 0.0
    M_f: tuple[float, float] = (0.0, 0.0)
    M_s: tuple[float, float] | None = None
    R: float = float("nan")
    L: float = float("nan")
    k_m: float = float("nan")
    k_w: float = float("nan")
    k_u: float = 1.0
    u_max: float = float("inf")
    name: str = ""
    gear: str = ""
    rated_torque: float = float("nan")
    peak_torque: float = float("nan")
    max_speed: float = float("nan")
    rated_voltage: float = float("nan")
    rated_current: float = float("nan")
    stiffness: float = float("inf")
    damping: float = 0.0
    backlash: float = 0.0
    efficiency: float = 1.0
    gear_rated_torque: float = float("nan")
    gear_peak_torque: float = float("nan")
    gear_max_input_speed: float = float("nan")
    gear_average_torque: float = float("nan")
    gear_average_input_speed: float = float("nan")
    assumed: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        mf = self.M_f
        if np.ndim(mf) == 0:
            mf = (float(mf), float(mf))
        elif len(mf) != 2:
            raise ModelError("drive M_f must be one value or a [positive, negative] pair")
        # the negative-motion value may be given signed, as Corke's Tc-
        object.__setattr__(self, "M_f", (abs(float(mf[0])), abs(float(mf[1]))))
        ms = self.M_s
        if ms is not None:
            if np.ndim(ms) == 0:
                ms = (float(ms), float(ms))
            elif len(ms) != 2:
                raise ModelError("drive M_s must be one value or a [positive, negative] pair",
                                 field="M_s")
            ms = (abs(float(ms[0])), abs(float(ms[1])))
            if not all(math.isfinite(x) for x in ms):
                raise ModelError(f"drive M_s must be finite (N·m), got {ms}", field="M_s")
            if ms[0] < self.M_f[0] or ms[1] < self.M_f[1]:
                raise ModelError(f"drive M_s (static friction, {ms[0]:g}, {ms[1]:g} N·m) must "
                                 f"be >= M_f (kinetic, {self.M_f[0]:g}, {self.M_f[1]:g} N·m) "
                                 "in each direction", field="M_s")
            object.__setattr__(self, "M_s", None if ms == self.M_f else ms)
        assumed = dict(self.assumed)
        if set(assumed) - {f.name for f in dataclasses.fields(self)}:
            raise ModelError(f"drive assumed names no drive field: "
                             f"{sorted(set(assumed) - {f.name for f in dataclasses.fields(self)})}",
                             field="assumed")
        object.__setattr__(self, "assumed", tuple(sorted(assumed.items())))
        _check_drive_values(self)
        if not (float(self.stiffness) > 0):
            raise ModelError(f"drive stiffness must be > 0 N·m/rad (inf: rigid), "
                             f"got {self.stiffness}")
        for name in ("damping", "backlash"):
            v = float(getattr(self, name))
            if not (math.isfinite(v) and v >= 0):
                raise ModelError(f"drive {name} must be finite and >= 0, got {v}")
        if self.backlash > 0 and not math.isfinite(self.stiffness):
            raise ModelError("drive backlash needs a contact stiffness: give a finite "
                             "stiffness (elasticity) too")
        if math.isnan(float(self.efficiency)):   # one nan object: equal drives compare equal
            object.__setattr__(self, "efficiency", math.nan)
        elif not 0 < float(self.efficiency) <= 1:
            raise ModelError(f"drive efficiency must be in (0, 1] (nan: unknown), "
                             f"got {self.efficiency}")

    @property
    def static_friction(self) -> tuple[float, float]:
        """The static (break-away) friction in force, (positive, negative) motion, N·m on
        the motor shaft: ``M_s``, or ``M_f`` where none is given.

        Example:
            >>> Drive(M_f=0.1).static_friction, Drive(M_f=0.1, M_s=(0.15, 0.1)).static_friction
            ((0.1, 0.1), (0.15, 0.1))
        """
        return self.M_f if self.M_s is None else self.M_s

    @property
    def reflected_inertia(self) -> float:
        """The rotor's inertia as the joint sees it through the gear, J·i_r², kg·m² (kg on
        a prismatic joint).

        Example:
            >>> Drive(J=0.25, ratio=4.0).reflected_inertia
            4.0
        """
        return self.J * self.ratio**2

    @property
    def elastic(self) -> bool:
        """True when the transmission has a finite stiffness (elastic or with backlash)."""
        return math.isfinite(self.stiffness)

    @property
    def peak_current(self) -> float:
        """The motor's peak armature current, peak_torque/k_m, A (nan if either is unknown).

        Example:
            >>> round(Drive(k_m=0.2 * (2 / 3) ** 0.5, peak_torque=4.06).peak_current, 2)
            24.86
        """
        if not (self.k_m > 0):
            return math.nan
        return float(self.peak_torque) / float(self.k_m)

    @property
    def continuous_current(self) -> float:
        """The motor's continuous armature current, A: rated_torque/k_m, else (no rated
        torque) rated_current; nan if unknown.

        Example:
            >>> Drive(k_m=0.1, rated_torque=0.5).continuous_current, Drive(rated_current=4.9
            ...                                                             ).continuous_current
            (5.0, 4.9)
        """
        if math.isfinite(float(self.rated_torque)):
            return float(self.rated_torque) / float(self.k_m)
        return float(self.rated_current)

    @property
    def has_electrics(self) -> bool:
        """True when R, L, k_m and k_w are all known (the drive can be simulated)."""
        return all(np.isfinite([self.R, self.L, self.k_m, self.k_w]))

    def replace(self, **changes) -> Drive:
        """A copy with some fields changed."""
        return dataclasses.replace(self, **changes)


#: largest transmission ratio a drive may have (rad/rad, or rad/m for a screw): far above
#: any built gear train (harmonic drives 30..160, a 1 mm screw 6283 rad/m), far below
#: where the reflected inertia J·ratio² overflows
MAX_RATIO = 1e6


def _check_drive_values(d: Drive) -> None:
    """Every drive value finite and physical (nan only for "unknown", inf only for
    "no limit"); a :class:`ModelError` naming the field otherwise."""

    def fail(name: str, rule: str, v: object) -> ModelError:
        return ModelError(f"drive {name} must be {rule}, got {v}", field=name)

    for name in ("J", "k_v"):
        v = float(getattr(d, name))
        if not (math.isfinite(v) and v >= 0):
            raise fail(name, "finite and >= 0", v)
    if not (math.isfinite(float(d.k_u)) and d.k_u > 0):  # 0: the drive cannot act
        raise fail("k_u", "> 0 V/V and finite (the amplifier's gain)", d.k_u)
    if not (math.isfinite(float(d.ratio)) and d.ratio != 0):
        raise fail("ratio", "finite and non-zero", d.ratio)
    if abs(float(d.ratio)) > MAX_RATIO:
        raise fail("ratio", f"at most {MAX_RATIO:g} in magnitude (rad/rad or rad/m; its "
                   "square scales the rotor inertia)", d.ratio)
    if not all(math.isfinite(x) for x in d.M_f):
        raise fail("M_f", "finite (N·m)", d.M_f)
    # the electrical data: nan = unknown (no simulation), else finite; R > 0
    for name in ("L", "k_w"):
        v = float(getattr(d, name))
        if not (math.isnan(v) or (math.isfinite(v) and v >= 0)):
            raise fail(name, "finite and >= 0 (nan: unknown)", v)
    if not (math.isnan(float(d.k_m)) or (math.isfinite(float(d.k_m)) and d.k_m > 0)):
        raise fail("k_m", "> 0 N·m/A and finite (nan: unknown; 0: the motor makes no "
                   "torque)", d.k_m)
    if not (math.isnan(float(d.R)) or (math.isfinite(float(d.R)) and d.R > 0)):
        raise fail("R", "> 0 Ω and finite (nan: unknown)", d.R)
    if not float(d.u_max) > 0:
        raise fail("u_max", "> 0 V (inf: no limit)", d.u_max)
    for name in ("rated_torque", "peak_torque", "max_speed", "rated_voltage", "rated_current",
                 "gear_rated_torque", "gear_peak_torque", "gear_max_input_speed",
                 "gear_average_torque", "gear_average_input_speed"):
        v = float(getattr(d, name))
        if not (math.isnan(v) or (math.isfinite(v) and v >= 0)):
            raise fail(name, "finite and >= 0 (nan: unknown)", v)


@dataclass(frozen=True)
class Robot:
    """A manipulator: kinematic tree, link inertias, drives and gravity.

    Build one with :func:`manipcad.load_robot` or :meth:`Robot.from_arrays`.

    Attributes:
        name: the robot's name.
        joint_names: one name per joint, length n.
        joint_types: "revolute" or "prismatic" per joint.
        parent: parent joint index per joint, -1 for the base; parents precede children.
        placement_R: (n, 3, 3) rotation of each joint frame in its parent body frame.
        placement_p: (n, 3) origin of each joint frame in its parent body frame, m.
        offset: (n,) added to q before the joint motion, rad or m.
        mass: (n,) link masses, kg.
        com: (n, 3) centres of mass in the body frames, m.
        inertia: (n, 3, 3) inertia tensors about the centres of mass, body axes, kg·m².
        drives: one :class:`Drive` or None per joint.
        gravity: (3,) gravity in the base frame, m/s².
        limits: (n, 2) lower and upper joint limits, rad or m (±inf if none).
        velocity_limits: (n,) largest joint speed |q̇| allowed, rad/s or m/s
            (inf if none; a URDF's ``<limit velocity>``).
        effort_limits: (n,) largest joint torque |P| allowed, N·m or N (inf if
            none; a URDF's ``<limit effort>``).
        link_names: one name per moving link (the body of joint i is link i).
        tool_R, tool_p: the tool (gripper) frame in the last link's body frame.
        source: where the model comes from (file, data set).
        frames: named frames fixed to a body, as ``(name, body, R, p)``: the
            body index (-1 for the base), the frame's rotation (3, 3) and
            origin (3,) m in that body's frame. A URDF gives one per URDF link
            (the link's own frame, which differs from the body frame by the
            axis alignment, and links merged through fixed joints); see
            :meth:`link_frame`.
        drive_mounts: where a drive's own mass (motor + gear) sits, for the
            joints that differ from the convention, as ``((joint name, mount),
            ...)``: "before" (the convention: on the link before the joint, at
            the joint's origin) or "base" (off the arm: a remote motor driving
            through a belt, cable or shaft). Read by drive selection
            (:mod:`manipcad.sizing.select`), which puts the chosen drives'
            masses on the links; robot files give it as ``drive_mounts: {joint: base}``.
    """

    name: str
    joint_names: tuple[str, ...]
    joint_types: tuple[str, ...]
    parent: np.ndarray
    placement_R: np.ndarray
    placement_p: np.ndarray
    offset: np.ndarray
    mass: np.ndarray
    com: np.ndarray
    inertia: np.ndarray
    drives: tuple[Drive | None, ...]
    gravity: np.ndarray = field(default_factory=lambda: np.array([0.0, 0.0, -9.81]))
    limits: np.ndarray | None = None
    link_names: tuple[str, ...] = ()
    tool_R: np.ndarray = field(default_factory=lambda: np.eye(3))
    tool_p: np.ndarray = field(default_factory=lambda: np.zeros(3))
    source: str = ""
    frames: tuple = ()
    velocity_limits: np.ndarray | None = None
    effort_limits: np.ndarray | None = None
    drive_mounts: tuple[tuple[str, str], ...] = ()

    def __post_init__(self) -> None:
        # no speed or torque limit unless given: (n,) inf
        for key in ("velocity_limits", "effort_limits"):
            if getattr(self, key) is None:
                object.__setattr__(self, key, np.full(len(self.joint_types), np.inf))

    # ------------------------------------------------------------------ build
    @classmethod
    def from_arrays(
        cls,
        name: str,
        joint_types: Sequence[str],
        parent: Sequence[int],
        placement_R: np.ndarray,
        placement_p: np.ndarray,
        mass: Sequence[float],
        com: np.ndarray,
        inertia: np.ndarray,
        *,
        offset: Sequence[float] | None = None,
        joint_names: Sequence[str] | None = None,
        drives: Sequence[Drive | None] | None = None,
        gravity: Sequence[float] = (0.0, 0.0, -9.81),
        limits: np.ndarray | None = None,
        link_names: Sequence[str] | None = None,
        tool_R: np.ndarray | None = None,
        tool_p: np.ndarray | None = None,
        source: str = "",
        frames: Sequence = (),
        velocity_limits: Sequence[float] | None = None,
        effort_limits: Sequence[float] | None = None,
        drive_mounts: Mapping[str, str] | Sequence[tuple[str, str]] = (),
    ) -> Robot:
        """Build and validate a robot from per-joint arrays (see the class docstring)."""
        n = len(joint_types)
        f = np.asarray
        robot = cls(
            name=name,
            joint_names=tuple(joint_names or (f"q{i + 1}" for i in range(n))),
            joint_types=tuple(joint_types),
            parent=f(parent, dtype=np.int64).reshape(-1),
            placement_R=f(placement_R, dtype=float).reshape(-1, 3, 3),
            placement_p=f(placement_p, dtype=float).reshape(-1, 3),
            offset=np.zeros(n) if offset is None else f(offset, dtype=float).reshape(-1),
            mass=f(mass, dtype=float).reshape(-1),
            com=f(com, dtype=float).reshape(-1, 3),
            inertia=f(inertia, dtype=float).reshape(-1, 3, 3),
            drives=tuple(drives) if drives is not None else (None,) * n,
            gravity=f(gravity, dtype=float).reshape(3),
            limits=(
                np.tile([-np.inf, np.inf], (n, 1)) if limits is None
                else f(limits, dtype=float).reshape(-1, 2)
            ),
            link_names=tuple(link_names or (f"link{i + 1}" for i in range(n))),
            tool_R=np.eye(3) if tool_R is None else f(tool_R, dtype=float).reshape(3, 3),
            tool_p=np.zeros(3) if tool_p is None else f(tool_p, dtype=float).reshape(3),
            source=source,
            frames=tuple((str(nm), int(b), f(R, dtype=float).reshape(3, 3),
                          f(p, dtype=float).reshape(3)) for nm, b, R, p in frames),
            velocity_limits=(np.full(n, np.inf) if velocity_limits is None
                             else f(velocity_limits, dtype=float).reshape(-1)),
            effort_limits=(np.full(n, np.inf) if effort_limits is None
                           else f(effort_limits, dtype=float).reshape(-1)),
            drive_mounts=mounts_tuple(drive_mounts),
        )
        robot.validate()
        return robot

    def validate(self) -> None:
        """Check shapes, tree order and physical values; raise :class:`ModelError`."""
        n = self.n
        shapes = {
            "joint_names": (len(self.joint_names),), "parent": self.parent.shape,
            "placement_R": self.placement_R.shape[:1], "placement_p": self.placement_p.shape[:1],
            "offset": self.offset.shape, "mass": self.mass.shape, "com": self.com.shape[:1],
            "inertia": self.inertia.shape[:1], "drives": (len(self.drives),),
            "limits": self.limits.shape[:1], "link_names": (len(self.link_names),),
            "velocity_limits": np.shape(self.velocity_limits),
            "effort_limits": np.shape(self.effort_limits),
        }
        for key, shape in shapes.items():
            if shape != (n,):
                raise ModelError(f"{key} has {shape[0]} entries for {n} joints")
        for i, t in enumerate(self.joint_types):
            if t not in JOINT_TYPES:
                raise ModelError(f"joint {self.joint_names[i]!r}: unknown joint type {t!r} "
                                 f"(expected one of {', '.join(JOINT_TYPES)})")
            if not -1 <= self.parent[i] < i:
                raise ModelError(f"joint {self.joint_names[i]!r}: parent index {self.parent[i]} "
                                 "must name an earlier joint or the base (-1)")
        if len(set(self.joint_names)) != n:
            raise ModelError("joint names must be unique")
        for joint, mount in self.drive_mounts:
            if joint not in self.joint_names:
                raise ModelError(f"drive_mounts: no joint named {joint!r}; joints are "
                                 f"{', '.join(self.joint_names)}", field="drive_mounts")
            if mount not in DRIVE_MOUNTS:
                raise ModelError(f"drive_mounts: {joint}: unknown mount {mount!r}; expected "
                                 f"one of {', '.join(DRIVE_MOUNTS)}", field="drive_mounts")
        names = set()
        for name, body, R, p in self.frames:
            if name in names:
                raise ModelError(f"frame {name!r} is given twice")
            names.add(name)
            if not -1 <= body < n:
                raise ModelError(f"frame {name!r}: body index {body} out of range")
            if (np.shape(R) != (3, 3) or np.shape(p) != (3,)
                    or not np.allclose(R @ R.T, np.eye(3), atol=1e-9)):
                raise ModelError(f"frame {name!r}: not a rotation (3, 3) and origin (3,)")
        _check_finite(self)
        for i in range(n):
            where = f"link of joint {self.joint_names[i]!r}"
            if not np.isfinite(self.mass[i]) or self.mass[i] < 0:
                raise ModelError(f"{where}: mass must be >= 0 kg, got {self.mass[i]}")
            I = self.inertia[i]
            if not np.allclose(I, I.T, atol=1e-12 * max(1.0, np.abs(I).max())):
                raise ModelError(f"{where}: inertia tensor is not symmetric")
            if np.linalg.eigvalsh(I).min() < -1e-12 * max(1.0, np.abs(I).max()):
                raise ModelError(f"{where}: inertia tensor is not positive semi-definite "
                                 f"(eigenvalues {np.linalg.eigvalsh(I)})")
            Rp = self.placement_R[i]
            if not np.allclose(Rp @ Rp.T, np.eye(3), atol=1e-9) or np.linalg.det(Rp) < 0:
                raise ModelError(f"joint {self.joint_names[i]!r}: placement is not a rotation")

    # ------------------------------------------------------------ properties
    @property
    def n(self) -> int:
        """Number of joints (degrees of freedom)."""
        return len(self.joint_types)

    @property
    def has_drives(self) -> bool:
        """True when at least one joint has a drive."""
        return any(d is not None for d in self.drives)

    @functools.cached_property
    def table(self) -> np.ndarray:
        """The packed (n, TABLE_COLS) model table the compiled kernels read (read-only;
        packed from the fields on first use: the robot's own derived data)."""
        return _pack(self)

    def __getstate__(self) -> dict:
        # the packed table is derived: unpickled it would be a writable array, another type
        # for numba than the read-only one _pack makes, so every kernel the copy runs would
        # compile (and cache) a second specialization; the copy packs its own instead
        state = dict(self.__dict__)
        state.pop("table", None)
        return state

    def __setstate__(self, state: dict) -> None:
        self.__dict__.update(state)
        self.__post_init__()   # a robot pickled before it had speed and torque limits

    def drive(self, joint: int | str) -> Drive:
        """The drive of a joint (index or name); raises if the joint has none."""
        i = self.joint_index(joint)
        d = self.drives[i]
        if d is None:
            raise ModelError(f"joint {self.joint_names[i]!r} has no drive")
        return d

    def joint_index(self, joint: int | str) -> int:
        """Index of a joint given by index or name."""
        if isinstance(joint, str):
            try:
                return self.joint_names.index(joint)
            except ValueError:
                raise ModelError(f"no joint named {joint!r}; joints are "
                                 f"{', '.join(self.joint_names)}") from None
        if not -self.n <= int(joint) < self.n:
            raise ModelError(f"joint index {joint} out of range for {self.n} joints")
        return int(joint) % self.n

    @property
    def all_link_names(self) -> tuple[str, ...]:
        """Every name :meth:`link_frame` accepts: the named frames, then the link names."""
        named = tuple(f[0] for f in self.frames)
        return named + tuple(x for x in self.link_names if x not in named)

    def link_frame(self, link: str | int) -> tuple[int, np.ndarray, np.ndarray]:
        """Where a named link's own frame is: its body index and pose in that body.

        Args:
            link: a link name (a URDF link, including links merged through
                fixed joints, or a name in :attr:`link_names`), or a link
                number 1..n (link k is the body moved by joint k).

        Returns:
            ``(body, R, p)``: body index 0..n-1 (-1 for the base), rotation
            (3, 3) and origin (3,) m of the link frame in the body frame. For a
            URDF link, a centre of mass ``c`` given in the URDF link frame is
            ``R @ c + p`` in the body frame.

        Raises:
            ModelError: no such link (naming the links there are).

        Example:
            >>> import manipcad
            >>> body, R, p = manipcad.load_robot("puma560").link_frame(6)
            >>> body, R.tolist() == [[1, 0, 0], [0, 1, 0], [0, 0, 1]]
            (5, True)
        """
        if isinstance(link, int | np.integer) and not isinstance(link, bool):
            if not 1 <= int(link) <= self.n:
                raise ModelError(f"link number {link} out of range 1..{self.n}")
            return int(link) - 1, np.eye(3), np.zeros(3)
        for name, body, R, p in self.frames:
            if name == link:
                return body, R.copy(), p.copy()
        if link in self.link_names:
            return self.link_names.index(link), np.eye(3), np.zeros(3)
        raise ModelError(f"no link named {link!r}; links are "
                         f"{', '.join(self.all_link_names)} (or numbers 1..{self.n})")

    def link_index(self, link: str | int) -> int:
        """The body index 0..n-1 that carries a named link (see :meth:`link_frame`);
        raises :class:`ModelError` for the base or an unknown link."""
        body = self.link_frame(link)[0]
        if body < 0:
            raise ModelError(f"link {link!r} is fixed to the base; nothing moves it")
        return body

    # ---------------------------------------------------------- new robots
    def replace(self, **changes) -> Robot:
        """A validated copy with some fields changed."""
        new = dataclasses.replace(self, **changes)
        new.validate()
        return new

    def with_payload(self, mass: float, com: Sequence[float] = (0.0, 0.0, 0.0),
                     inertia: np.ndarray | None = None, *, link: int | str = -1) -> Robot:
        """A new robot carrying a rigid payload on one link (default the last).

        Args:
            mass: payload mass, kg (>= 0).
            com: payload centre of mass, m: in the frame of the link when
                ``link`` is a link name (a URDF link's own frame, see
                :meth:`link_frame`), else in the body frame of the joint.
            inertia: (3, 3) payload inertia about its own centre of mass, in
                the same axes as ``com``, kg·m²; None for a point mass.
            link: a link name (:attr:`all_link_names`), or a joint index or
                joint name (the link that joint moves).

        Returns:
            A new :class:`Robot`; this one is unchanged.

        Example:
            >>> import manipcad
            >>> puma = manipcad.load_robot("puma560")
            >>> loaded = puma.with_payload(2.0, com=(0, 0, 0.1))
        """
        R_l, p_l = np.eye(3), np.zeros(3)
        if isinstance(link, str) and link in self.all_link_names:
            i, R_l, p_l = self.link_frame(link)
            if i < 0:
                raise ModelError(f"payload link {link!r} is fixed to the base")
        elif isinstance(link, str) and link not in self.joint_names:
            raise ModelError(f"no link or joint named {link!r} to carry the payload; links "
                             f"are {', '.join(self.all_link_names)}; joints are "
                             f"{', '.join(self.joint_names)}")
        else:
            i = self.joint_index(link)
        try:
            m_p = float(mass)
        except (TypeError, ValueError):
            raise ModelError(f"payload mass must be a number (kg), got {mass!r}",
                             field="mass") from None
        if not np.isfinite(m_p) or m_p < 0:
            raise ModelError(f"payload mass must be >= 0 kg, got {mass}", field="mass")
        try:
            c_p = np.asarray(com, dtype=float).reshape(3)
        except (TypeError, ValueError):
            raise ModelError(f"payload com must be 3 numbers (m), got {com!r}",
                             field="com") from None
        if not np.isfinite(c_p).all():
            raise ModelError(f"payload com must be finite (m), got {c_p}", field="com")
        c_p = R_l @ c_p + p_l
        try:
            I_p = (np.zeros((3, 3)) if inertia is None
                   else np.asarray(inertia, float).reshape(3, 3))
        except (TypeError, ValueError):
            raise ModelError("payload inertia must be a (3, 3) tensor of numbers, kg·m², got "
                             f"{inertia!r}"[:200], field="inertia") from None
        if not np.isfinite(I_p).all() or not np.allclose(I_p, I_p.T):
            raise ModelError("payload inertia must be a finite symmetric (3, 3) tensor, "
                             "kg·m²", field="inertia")
        if np.linalg.eigvalsh(I_p).min() < -1e-12 * max(1.0, np.abs(I_p).max()):
            raise ModelError("payload inertia must be positive semi-definite, principal "
                             f"moments {np.linalg.eigvalsh(I_p)} kg·m²", field="inertia")
        I_p = R_l @ I_p @ R_l.T
        m, c, Ic = combine_bodies(self.mass[i], self.com[i], self.inertia[i], m_p, c_p, I_p)
        mass_new, com_new, in_new = self.mass.copy(), self.com.copy(), self.inertia.copy()
        mass_new[i], com_new[i], in_new[i] = m, c, Ic
        return self.replace(mass=mass_new, com=com_new, inertia=in_new)

    def _repr_html_(self) -> str:
        return robot_html(self)

    def without_drives(self) -> Robot:
        """The same robot with no drives (pure rigid body)."""
        return self.replace(drives=(None,) * self.n)

    def __repr__(self) -> str:
        kinds = "".join("R" if t == REVOLUTE else "P" for t in self.joint_types)
        return f"Robot({self.name!r}, n={self.n}, joints={kinds})"


def require_robot(robot, source: str) -> Robot:
    """``robot`` itself when it is a :class:`Robot`, else an InputError naming it.

    The public functions that take a robot call it first, so that a robot's name, None
    or a file path says what the argument takes instead of raising Python's own
    AttributeError deep inside.

    Args:
        robot: the value given as the ``robot`` argument.
        source: the function's name, named in the error.

    Returns:
        ``robot``.

    Raises:
        InputError: (field ``robot``) anything but a Robot, with the way to make one.

    Example:
        >>> require_robot("puma560", "inverse_dynamics")  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        manipcad.errors.InputError: inverse_dynamics: robot: expected a manipcad Robot ...
    """
    if not isinstance(robot, Robot):
        got = f"{type(robot).__name__} {robot!r}"[:120]
        raise InputError(source, "robot", "expected a manipcad Robot (a catalog robot or "
                         "file: manipcad.load_robot('puma560') or "
                         f"manipcad.load_robot('arm.yaml')), got {got}")
    return robot


def mounts_tuple(mounts: Mapping[str, str] | Sequence[tuple[str, str]]
                 ) -> tuple[tuple[str, str], ...]:
    """Drive mounts as :attr:`Robot.drive_mounts` holds them: sorted (joint, mount) pairs
    (the conventional "before" left out).

    Example:
        >>> mounts_tuple({"elbow": "base", "wrist": "before"})
        (('elbow', 'base'),)
    """
    items = mounts.items() if isinstance(mounts, Mapping) else mounts
    return tuple(sorted((str(j), str(m)) for j, m in items if m != "before"))


def _check_finite(robot: Robot) -> None:
    """Every model number finite (limits may be ±inf, never nan, lower <= upper)."""
    arrays = {"placement_R": robot.placement_R, "placement_p": robot.placement_p,
              "offset": robot.offset, "mass": robot.mass, "com": robot.com,
              "inertia": robot.inertia}
    for key, a in arrays.items():
        bad = np.argwhere(~np.isfinite(a.reshape(robot.n, -1)))
        if len(bad):
            i = int(bad[0][0])
            raise ModelError(f"joint {robot.joint_names[i]!r}: {key} must be finite, got "
                             f"{a[i].tolist()}", field=key)
    for key in ("gravity", "tool_R", "tool_p"):
        a = np.asarray(getattr(robot, key))
        if not np.isfinite(a).all():
            raise ModelError(f"{key} must be finite, got {a.tolist()}", field=key)
    lim = robot.limits
    bad = np.argwhere(np.isnan(lim) | (lim[:, :1] > lim[:, 1:]))
    if len(bad):
        i = int(bad[0][0])
        raise ModelError(f"joint {robot.joint_names[i]!r}: limits must be lower <= upper "
                         f"(±inf: none, never nan), got {lim[i].tolist()}", field="limits")
    for key in ("velocity_limits", "effort_limits"):
        a = np.asarray(getattr(robot, key), dtype=float)
        bad = np.flatnonzero(~(a > 0))
        if len(bad):
            i = int(bad[0])
            raise ModelError(f"joint {robot.joint_names[i]!r}: {key[:-7]} limit must be > 0 "
                             f"(inf: none), got {a[i]}", field=key)


def triangle_breach(I: np.ndarray) -> np.ndarray | None:
    """The principal moments (kg·m², ascending) of an inertia tensor that breaks the
    triangle inequality I1 + I2 >= I3 (no rigid body has it), else None.

    Args:
        I: (3, 3) symmetric inertia tensor about the centre of mass, kg·m²,
            positive semi-definite.

    Example:
        >>> triangle_breach(np.diag([0.0, 0.35, 0.0]))
        array([0.  , 0.  , 0.35])
        >>> triangle_breach(np.diag([0.2, 0.2, 0.35])) is None
        True
    """
    eig = np.linalg.eigvalsh(I)
    tol = 1e-12 * max(1.0, float(np.abs(I).max()))
    return eig if eig[0] + eig[1] < eig[2] - tol - 1e-9 * float(eig[2]) else None


def triangle_message(eig: np.ndarray) -> str:
    """The words for principal moments that break the triangle inequality."""
    return (f"principal moments {np.array2string(eig, precision=6)} kg·m² break the "
            "triangle inequality (I1 + I2 >= I3), so no rigid body has them; loaded as given")


def inertia_notes(robot: Robot) -> list[str]:
    """One line per link whose inertia breaks the triangle inequality (published data
    sometimes do: the PUMA 560's links 1 and 3), for ``manipcad robots show``.

    Example:
        >>> import manipcad
        >>> [n.split(":")[0] for n in inertia_notes(manipcad.load_robot("puma560"))]
        ['joints[0].link.inertia (link1)', 'joints[2].link.inertia (link3)']
    """
    out = []
    for i in range(robot.n):
        eig = triangle_breach(robot.inertia[i])
        if eig is not None:
            out.append(f"joints[{i}].link.inertia ({robot.link_names[i]}): "
                       f"{triangle_message(eig)}")
    return out


def loader_notes(caught, robot: Robot) -> list[str]:
    """What to tell about a loaded robot's data: the loader's warnings (``caught``, from
    ``warnings.catch_warnings(record=True)``) but the inertia ones, then
    :func:`inertia_notes` (each link once, whether its file noted it or not)."""
    return [str(w.message) for w in caught if issubclass(w.category, ManipcadWarning)
            and not issubclass(w.category, InertiaWarning)] + inertia_notes(robot)


@register_jitable
def combine_bodies(m1: float, c1: np.ndarray, I1: np.ndarray,
                   m2: float, c2: np.ndarray, I2: np.ndarray):
    """Merge two rigid bodies given in one frame (masses kg, centres m, inertias
    about their own centres kg·m²) into one: (mass, centre, inertia about it).

    Plain Python, and callable from compiled (numba) code too: the online payload
    estimator writes the model's payload link with it each period
    (:mod:`manipcad.control.estimator`)."""
    m = m1 + m2
    if m <= 0:
        return 0.0, np.zeros(3), I1 + I2
    c = (m1 * c1 + m2 * c2) / m
    return m, c, I1 + I2 + _shift(m1, c1 - c) + _shift(m2, c2 - c)


@register_jitable
def _shift(m: float, d: np.ndarray) -> np.ndarray:
    """Parallel-axis term m(|d|²E - d dᵀ), kg·m².

    Element by element (the same operations as ``m * (d @ d * np.eye(3) - np.outer(d,
    d))``, so the same values): compiled for the online payload estimator, numpy's
    ``outer`` and ``eye`` cost seconds of numba's compile on a cold cache."""
    dd = d @ d
    out = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            out[a, b] = m * (dd * (1.0 if a == b else 0.0) - d[a] * d[b])
    return out


def _pack(robot: Robot) -> np.ndarray:
    t = np.zeros((robot.n, TABLE_COLS))
    t[:, COL_R:COL_R + 9] = robot.placement_R.reshape(-1, 9)
    t[:, COL_P:COL_P + 3] = robot.placement_p
    t[:, COL_OFFSET] = robot.offset
    t[:, COL_TYPE] = [0.0 if jt == REVOLUTE else 1.0 for jt in robot.joint_types]
    t[:, COL_PARENT] = robot.parent
    t[:, COL_MASS] = robot.mass
    t[:, COL_COM:COL_COM + 3] = robot.com
    t[:, COL_IC:COL_IC + 9] = robot.inertia.reshape(-1, 9)
    for i, d in enumerate(robot.drives):
        if d is not None:
            t[i, COL_JR] = d.reflected_inertia
            t[i, COL_BV] = d.k_v * d.ratio**2
            t[i, COL_FCP] = abs(d.ratio) * d.M_f[0]
            t[i, COL_FCN] = abs(d.ratio) * d.M_f[1]
    t.setflags(write=False)
    return t
