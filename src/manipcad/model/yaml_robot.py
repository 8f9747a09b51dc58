"""Robot descriptions in YAML: parse, validate and map onto :class:`Robot`.

The schema is documented in docs/robot-yaml.md. In short (SI units throughout):

.. code-block:: yaml

    name: two-link arm
    convention: modified          # or standard (default modified, the paper's)
    gravity: [0, 0, -9.81]        # m/s², base frame
    source: where the numbers come from
    tool: {xyz: [0.1, 0, 0], rpy: [0, 0, 0]}   # in the last link frame, m, rad
    joints:
      - name: shoulder
        type: revolute            # or prismatic
        parent: base              # a joint name; default the previous joint
        dh: {a: 0, alpha: 0, d: 0, theta: 0}    # m, rad
        limits: [-pi, pi]         # rad or m
        velocity_limit: 3.0       # |q̇| allowed, rad/s or m/s (optional)
        effort_limit: 150         # |P| allowed, N·m or N (optional)
        link:
          mass: 2.0               # kg
          com: [0.2, 0, 0]        # m, in the link frame
          inertia: {ixx: 0.001, iyy: 0.03, izz: 0.03}   # kg·m², about the centre of mass
        drive: {motor: maxon_re40_148877, gear: harmonic_csf20_100}

Every number may also be written as a small arithmetic expression over the
constants ``pi``, ``deg`` (pi/180), ``rpm`` (2·pi/60 rad/s), ``inch``
(0.0254 m), ``mm`` (0.001 m) and ``gcm2`` (1e-7 kg·m², i.e. g·cm²), e.g.
``alpha: -pi/2``, ``limits: [-160*deg, 160*deg]``, ``J: 137*gcm2``.

Mapping onto the internal tree (see :mod:`manipcad.model.dh`):

* modified DH, row (a, alpha, d, theta):
  ``T = Rot_x(alpha)·Trans_x(a)·Rot_z(theta)·Trans_z(d)``. A revolute joint gets
  the placement ``Rot_x(alpha)·Trans_x(a)·Trans_z(d)`` (Rot_z and Trans_z
  commute) and the offset ``theta``; a prismatic joint gets
  ``Rot_x(alpha)·Trans_x(a)·Rot_z(theta)`` and the offset ``d``. Link data are
  in the link (proximal) frame already.
* standard DH, row (a, alpha, d, theta): ``T = Rot_z(theta)·Trans_z(d)·Trans_x(a)·Rot_x(alpha)``
  with link data in the distal frame. The joint's placement is its parent's
  distal part ``Trans_x(a_p)·Rot_x(alpha_p)`` (identity at the base) followed by
  the fixed part of its own motion (``Trans_z(d)`` revolute, ``Rot_z(theta)``
  prismatic); the link's centre and inertia are carried into the body frame;
  the last row's distal part becomes the tool frame (composed with ``tool:``).

Drives: explicit fields ``J, ratio, k_v, M_f, M_s, R, L, k_m, k_w, k_u, u_max`` (and
the ratings; ``M_s`` the static friction, default ``M_f``), ``elasticity`` (k_s
N·m/rad, or [k_s, d_s]) and ``backlash`` (b, rad, half the gap; joint side),
``efficiency`` and the gear ratings, or ``motor:`` and/or ``gear:`` names from the
catalog (a gear may be a list, a chain from the motor outwards), with any explicit
field overriding the composed value. Composition: ``J = J_motor + sum_k J_gear_k /
(i_1···i_{k-1})²`` on the motor shaft, ``ratio = prod_k direction_k·i_k``, the
electrical data and friction from the motor, ``u_max`` defaulting to the
motor's rated voltage, the gear's efficiency and ratings referred to the joint
(:func:`compose_gears`). A drive is rigid unless it gives ``elasticity`` or
``backlash`` (backlash alone takes the catalog gear's torsional stiffness as
the contact stiffness).

Every bad input raises :class:`~manipcad.errors.InputError` naming the file,
the dotted field (``joints[2].link.mass``) and the reason.
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping
from importlib.abc import Traversable
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, Field, ValidationError

from manipcad import fileio
from manipcad.catalog import compose_drive
from manipcad.catalog.files import GearSpec, MotorSpec, compose_gears
from manipcad.catalog.files import part_names as _catalog_names  # noqa: F401  (callers)
from manipcad.catalog.library import load_gear, load_motor
from manipcad.errors import InertiaWarning, InputError, ModelError
from manipcad.model import dh
from manipcad.model.robot import (
    PRISMATIC,
    REVOLUTE,
    Drive,
    Robot,
    triangle_breach,
    triangle_message,
)
from manipcad.schema import (
    CONSTANTS,
    Friction,
    Num,
    OptNum,
    evaluate,
    number_or_pair,
    problem,
)
from manipcad.schema import to_float as _to_float

# --------------------------------------------------------------------------- numbers

def _vector(n: int, what: str) -> Callable[[Any], tuple[float, ...]]:
    def convert(v: Any) -> tuple[float, ...]:
        if not isinstance(v, list | tuple) or len(v) != n:
            raise ValueError(f"expected a list of {n} numbers {what}, got {v!r}")
        out = []
        for k, x in enumerate(v):
            try:
                out.append(_to_float(x))
            except ValueError as exc:
                raise ValueError(f"item {k}: {exc}") from None
        return tuple(out)

    return convert


def _opt_pair(v: Any) -> tuple[float, ...] | None:
    return None if v is None else _vector(2, "[lower, upper]")(v)


def _names(v: Any) -> list[str] | None:
    if v is None:
        return None
    if isinstance(v, str):
        return [v]
    if isinstance(v, list) and v and all(isinstance(x, str) for x in v):
        return list(v)
    raise ValueError(f"expected a catalog name or a list of names, got {v!r}")


Vec3 = Annotated[tuple[float, float, float], BeforeValidator(_vector(3, "[x, y, z]"))]
OptPair = Annotated[tuple[float, float] | None, BeforeValidator(_opt_pair)]
NameList = Annotated[list[str] | None, BeforeValidator(_names)]

# --------------------------------------------------------------------------- schema


class _Spec(BaseModel):
    model_config = ConfigDict(extra="forbid", frozen=True)


class DHSpec(_Spec):
    """One Denavit-Hartenberg row: a (m), alpha (rad), d (m), theta (rad); missing ones are 0."""

    a: Num = 0.0
    alpha: Num = 0.0
    d: Num = 0.0
    theta: Num = 0.0


class InertiaSpec(_Spec):
    """Inertia tensor elements about the centre of mass, link axes, kg·m² (as URDF)."""

    ixx: Num = 0.0
    iyy: Num = 0.0
    izz: Num = 0.0
    ixy: Num = 0.0
    ixz: Num = 0.0
    iyz: Num = 0.0

    #: why a tensor that breaks the triangle inequality is kept as published (no warning)
    note: str = ""

    def matrix(self) -> np.ndarray:
        """The symmetric (3, 3) tensor, kg·m²."""
        return np.array([[self.ixx, self.ixy, self.ixz],
                         [self.ixy, self.iyy, self.iyz],
                         [self.ixz, self.iyz, self.izz]])


class LinkSpec(_Spec):
    """A link: mass (kg), centre of mass (m, link frame), inertia about it (kg·m²)."""

    mass: Num
    com: Vec3 = (0.0, 0.0, 0.0)
    inertia: InertiaSpec = InertiaSpec()


def _elasticity(v: Any) -> tuple[float, float] | None:
    """elasticity: a stiffness k_s (N·m/rad) or a [k_s, d_s] pair (N·m/rad, N·m·s/rad)."""
    return number_or_pair(v, "a stiffness or a [stiffness, damping] pair", lambda k: (k, 0.0))


Elasticity = Annotated[tuple[float, float] | None, BeforeValidator(_elasticity)]


class DriveSpec(_Spec):
    """A joint drive: catalog motor/gear names and/or explicit fields (SI units,
    motor side: J kg·m², ratio rad/rad or rad/m, k_v N·m·s/rad, M_f N·m (kinetic dry
    friction), M_s N·m (static, break-away friction, >= M_f; default M_f), R Ω, L H,
    k_m N·m/A, k_w V·s/rad, k_u V/V, u_max V, rated/peak torque N·m, max_speed
    rad/s, rated_voltage V, rated_current A; joint side: elasticity k_s N·m/rad
    or [k_s N·m/rad, d_s N·m·s/rad], backlash b rad (half the gap), gear
    ratings gear_rated_torque / gear_peak_torque / gear_average_torque N·m;
    gear_max_input_speed / gear_average_input_speed rad/s on the motor shaft;
    efficiency η in (0, 1], or "unknown" (what a
    gear without a stated efficiency gives: sizing does not assume η = 1);
    motor_name / gear_name are labels for reports when no catalog part is named;
    assumed maps a field to why its value is assumed rather than printed)."""

    motor: str | None = None
    gear: NameList = None
    motor_name: str | None = None
    gear_name: str | None = None
    elasticity: Elasticity = None
    backlash: OptNum = None
    efficiency: OptNum | Literal["unknown"] = None
    gear_rated_torque: OptNum = None
    gear_peak_torque: OptNum = None
    gear_max_input_speed: OptNum = None
    gear_average_torque: OptNum = None
    gear_average_input_speed: OptNum = None
    J: OptNum = None
    ratio: OptNum = None
    k_v: OptNum = None
    M_f: Friction = None
    M_s: Friction = None
    R: OptNum = None
    L: OptNum = None
    k_m: OptNum = None
    k_w: OptNum = None
    k_u: OptNum = None
    u_max: OptNum = None
    rated_torque: OptNum = None
    peak_torque: OptNum = None
    max_speed: OptNum = None
    rated_voltage: OptNum = None
    rated_current: OptNum = None
    assumed: dict[str, str] | None = None


class JointSpec(_Spec):
    """One joint, its DH row, limits (rad or m), link and optional drive."""

    name: str = Field(min_length=1)
    type: Literal["revolute", "prismatic"]
    parent: str | None = None
    dh: DHSpec = DHSpec()
    limits: OptPair = None
    velocity_limit: OptNum = None
    effort_limit: OptNum = None
    link: LinkSpec
    drive: DriveSpec | None = None


class ToolSpec(_Spec):
    """Tool frame in the last link frame: xyz (m) and roll-pitch-yaw (rad, fixed axes x, y, z)."""

    xyz: Vec3 = (0.0, 0.0, 0.0)
    rpy: Vec3 = (0.0, 0.0, 0.0)


class RobotSpec(_Spec):
    """A whole robot file."""

    name: str = Field(min_length=1)
    convention: Literal["modified", "standard"] = "modified"
    gravity: Vec3 = (0.0, 0.0, -9.81)
    source: str = ""
    description: str = ""
    tool: ToolSpec | None = None
    joints: list[JointSpec] = Field(min_length=1)
    drive_mounts: dict[str, Literal["before", "base"]] = {}


# --------------------------------------------------------------------------- reading


def read_yaml(source: str | Path | Traversable, label: str | None = None) -> Any:
    """Read a YAML file, rejecting duplicate keys; every failure (no such file,
    YAML syntax with the line...) is an :class:`InputError` naming the file as
    ``label`` (default its path). See :func:`manipcad.fileio.read_yaml`."""
    return fileio.read_yaml(source, label=label)


def _reason(err: Mapping[str, Any], root: type[BaseModel], data: dict[str, Any]) -> str:
    """The words for a pydantic error in a robot, motor or gear file, naming the
    joint (by its name in ``data``) when the error is inside one."""
    loc = err["loc"]
    if len(loc) >= 2 and loc[0] == "joints" and isinstance(loc[1], int):
        joints = data.get("joints")
        if isinstance(joints, list) and loc[1] < len(joints):
            j = joints[loc[1]]
            if isinstance(j, dict) and isinstance(j.get("name"), str):
                return f"{problem(err, root)} (joint {j['name']!r})"
    return problem(err, root)


def validate(model: type[BaseModel], data: Any, label: str, prefix: str = "") -> Any:
    """Validate parsed YAML against a schema model; the first problem becomes an
    :class:`InputError` (file ``label``, dotted field under ``prefix``)."""
    if not isinstance(data, dict):
        raise InputError(label, prefix, "expected a mapping of keys to values "
                         f"(see docs/robot-yaml.md), got {type(data).__name__}")
    try:
        return model.model_validate(data)
    except ValidationError as exc:
        raise fileio.validation_error(label, exc, lambda err: _reason(err, model, data),
                                      prefix=prefix) from None


# --------------------------------------------------------------------------- building


def load_yaml_robot(path: str | Path) -> Robot:
    """Load a robot from a YAML description (docs/robot-yaml.md).

    Args:
        path: the .yaml file (SI units: m, rad, kg, kg·m², and the drive units of
            :class:`~manipcad.model.robot.Drive`).

    Returns:
        The validated :class:`Robot`.

    Raises:
        InputError: naming the file, the dotted field and the reason, for YAML
            syntax errors, unknown keys, wrong types, missing fields, negative
            masses, inertias that are not positive semi-definite, unknown joint
            types, parents, motors or gears, and inconsistent models.

    Warns:
        ManipcadWarning: for an inertia that is positive semi-definite but breaks
            the triangle inequality (loaded as given).

    Example:
        >>> from manipcad.model.yaml_robot import load_yaml_robot
        >>> robot = load_yaml_robot("examples/two_link.yaml")  # doctest: +SKIP
    """
    path = Path(path)
    label = str(path)
    if path.is_dir():
        raise InputError(label, "", "is a directory, not a robot file")
    spec = validate(RobotSpec, read_yaml(path, label), label)
    return build_robot(spec, label, base_dir=path.parent)


def build_robot(spec: RobotSpec, label: str, base_dir: Path | None = None) -> Robot:
    """Map a validated :class:`RobotSpec` onto a :class:`Robot` (``label`` names
    the file in errors; ``base_dir`` resolves motor/gear paths)."""
    joints = spec.joints
    n = len(joints)
    index: dict[str, int] = {}
    parents: list[int] = []
    for i, j in enumerate(joints):
        if j.name == "base":
            raise InputError(label, f"joints[{i}].name",
                             "the name 'base' is reserved for the robot base")
        if j.name in index:
            raise InputError(label, f"joints[{i}].name", f"duplicate joint name {j.name!r}")
        index[j.name] = i
    for i, j in enumerate(joints):
        if j.parent is None:
            parents.append(i - 1)
        elif j.parent == "base":
            parents.append(-1)
        elif j.parent in index and index[j.parent] < i:
            parents.append(index[j.parent])
        elif j.parent in index:
            raise InputError(label, f"joints[{i}].parent",
                             f"parent {j.parent!r} must be listed before joint {j.name!r} "
                             "(parents first)")
        else:
            raise InputError(label, f"joints[{i}].parent",
                             f"unknown parent {j.parent!r}; expected 'base' or one of "
                             + ", ".join(repr(x.name) for x in joints[:i]))

    standard = spec.convention == "standard"
    R_pl = np.zeros((n, 3, 3))
    p_pl = np.zeros((n, 3))
    offset = np.zeros(n)
    mass = np.zeros(n)
    com = np.zeros((n, 3))
    inertia = np.zeros((n, 3, 3))
    limits = np.tile([-np.inf, np.inf], (n, 1))
    rates = {"velocity_limit": np.full(n, np.inf), "effort_limit": np.full(n, np.inf)}
    drives: list[Drive | None] = []
    for i, j in enumerate(joints):
        where = f"joints[{i}]"
        row = j.dh
        if standard:
            prow = joints[parents[i]].dh if parents[i] >= 0 else DHSpec()
            a_p, alpha_p = prow.a, prow.alpha
        else:
            a_p, alpha_p = row.a, row.alpha
        R0, p0 = dh.modified_placement(a_p, alpha_p)
        if j.type == REVOLUTE:
            R_pl[i], p_pl[i], offset[i] = R0, p0 + R0 @ np.array([0.0, 0.0, row.d]), row.theta
        else:
            R_pl[i], p_pl[i], offset[i] = R0 @ dh.rot_z(row.theta), p0, row.d

        m, c, I = _check_link(j.link, label, f"{where}.link")
        if standard:
            Rd, pd = dh.standard_distal(row.a, row.alpha)
            c, I = dh.distal_to_body(Rd, pd, c, I)
            I = 0.5 * (I + I.T)
        mass[i], com[i], inertia[i] = m, c, I

        if j.limits is not None:
            lo, hi = j.limits
            if lo > hi:
                raise InputError(label, f"{where}.limits",
                                 f"lower limit {lo} is above upper limit {hi}")
            limits[i] = lo, hi
        for key, values in rates.items():
            v = getattr(j, key)
            if v is not None:
                if not v > 0:
                    raise InputError(label, f"{where}.{key}", f"must be > 0 (leave it out for "
                                     f"no limit), got {v} (joint {j.name!r})")
                values[i] = v
        for key in ("a", "alpha", "d", "theta"):
            if not math.isfinite(getattr(row, key)):
                raise InputError(label, f"{where}.dh.{key}", f"must be finite, got "
                                 f"{getattr(row, key)} (joint {j.name!r})")
        try:
            drives.append(None if j.drive is None
                          else build_drive(j.drive, label, f"{where}.drive", base_dir))
        except InputError as exc:
            if exc.source != label or "(joint " in exc.reason:
                raise
            raise InputError(label, exc.field, f"{exc.reason} (joint {j.name!r})") from None

    tool_R, tool_p = np.eye(3), np.zeros(3)
    if spec.tool is not None:
        tool_R, tool_p = rpy_to_matrix(*spec.tool.rpy), np.array(spec.tool.xyz)
    if standard:
        Rd, pd = dh.standard_distal(joints[-1].dh.a, joints[-1].dh.alpha)
        tool_R, tool_p = Rd @ tool_R, pd + Rd @ tool_p

    for jname in spec.drive_mounts:
        if jname not in index:
            raise InputError(label, f"drive_mounts.{jname}", "no joint of that name; joints "
                             f"are {', '.join(index)}")
    try:
        return Robot.from_arrays(
            spec.name, [j.type for j in joints], parents, R_pl, p_pl, mass, com, inertia,
            offset=offset, joint_names=[j.name for j in joints], drives=drives,
            gravity=spec.gravity, limits=limits, tool_R=tool_R, tool_p=tool_p,
            source=spec.source.strip(), velocity_limits=rates["velocity_limit"],
            effort_limits=rates["effort_limit"], drive_mounts=spec.drive_mounts,
        )
    except ModelError as exc:
        field = "tool" if exc.field.startswith("tool") else (
            exc.field if exc.field == "gravity" else "")
        raise InputError(label, field, str(exc)) from None


def _check_link(link: LinkSpec, label: str, where: str) -> tuple[float, np.ndarray, np.ndarray]:
    """Mass (kg), centre (m) and inertia (kg·m²) of a link, checked physically."""
    if link.mass < 0 or not math.isfinite(link.mass):
        raise InputError(label, f"{where}.mass", f"mass must be >= 0 kg, got {link.mass}")
    c = np.array(link.com, dtype=float)
    if not np.all(np.isfinite(c)):
        raise InputError(label, f"{where}.com", "centre of mass must be finite")
    I = link.inertia.matrix()
    if not np.all(np.isfinite(I)):
        raise InputError(label, f"{where}.inertia", "inertia must be finite")
    eig = np.linalg.eigvalsh(I)
    tol = 1e-12 * max(1.0, float(np.abs(I).max()))
    if eig[0] < -tol:
        raise InputError(label, f"{where}.inertia",
                         "inertia tensor is not positive semi-definite: principal moments "
                         f"{np.array2string(eig, precision=6)} kg·m² (one is negative)")
    breach = triangle_breach(I)
    if breach is not None and not link.inertia.note:
        warnings.warn(f"{label}: {where}.inertia: {triangle_message(breach)}",
                      InertiaWarning, stacklevel=4)
    return float(link.mass), c, I


def build_drive(spec: DriveSpec, label: str, where: str, base_dir: Path | None = None) -> Drive:
    """Compose a :class:`Drive` from catalog motor/gear names and explicit fields
    (see the module docstring); errors name ``label`` and ``where``."""
    motor_name = gear_name = ""
    motor = None
    if spec.motor is not None:
        try:
            motor = load_motor(spec.motor, base_dir)
        except InputError as exc:
            if exc.field:  # a bad catalog motor file: name that file
                raise
            raise InputError(label, f"{where}.motor", f"unknown motor {spec.motor!r}; "
                             + exc.reason.removeprefix("unknown motor; ")) from None
        motor_name = spec.motor
    gears = []
    if spec.gear is not None:
        for k, g in enumerate(spec.gear):
            try:
                gears.append(load_gear(g, base_dir))
            except InputError as exc:
                if exc.field:
                    raise
                sub = f"{where}.gear" + (f"[{k}]" if len(spec.gear) > 1 else "")
                raise InputError(label, sub, f"unknown gear {g!r}; "
                                 + exc.reason.removeprefix("unknown gear; ")) from None
        gear_name = " + ".join(spec.gear)
    try:
        fields, gear_stiffness = compose_drive(motor, gears)
    except (OverflowError, ZeroDivisionError) as exc:
        raise InputError(label, f"{where}.gear", f"the gear chain ({len(gears)} gears) "
                         f"cannot be composed: its ratios' product overflows ({exc})") from None
    explicit = spec.model_dump(exclude={"motor", "gear", "motor_name", "gear_name",
                                        "elasticity", "assumed"}, exclude_none=True)
    if explicit.get("efficiency") == "unknown":
        explicit["efficiency"] = math.nan
    fields.update(explicit)
    # a value given in the robot file replaces the part's assumed one; the file's own
    # assumptions (a written-out robot's) are kept
    assumed = {k: why for k, why in fields.pop("assumed", ()) if k not in explicit}
    assumed.update(spec.assumed or {})
    if assumed:
        fields["assumed"] = tuple(sorted(assumed.items()))
    motor_name = spec.motor_name or motor_name
    gear_name = spec.gear_name or gear_name
    if spec.elasticity is not None:
        fields["stiffness"], fields["damping"] = spec.elasticity
    elif spec.backlash:
        if gear_stiffness is None:
            raise InputError(label, f"{where}.backlash", "backlash needs a contact stiffness: "
                             "give elasticity (k_s N·m/rad or [k_s, d_s]) or a catalog gear "
                             "with a torsional stiffness")
        fields["stiffness"] = gear_stiffness
    if spec.motor is None and spec.gear is None and ("J" not in fields or "ratio" not in fields):
        missing = "J" if "J" not in fields else "ratio"
        raise InputError(label, f"{where}.{missing}", "required field is missing (a drive "
                         "needs J and ratio, or a catalog motor:/gear:)")
    for key in ("J", "k_v", "R", "L", "k_m", "k_w", "u_max", "k_u", "backlash"):
        if key in fields and fields[key] < 0:
            raise InputError(label, f"{where}.{key}", f"must be >= 0, got {fields[key]}")
    if "ratio" in fields and fields["ratio"] == 0:
        raise InputError(label, f"{where}.ratio", "must be non-zero")
    try:
        return Drive(name=motor_name, gear=gear_name, **fields)
    except ModelError as exc:
        raise InputError(label, f"{where}.{exc.field}" if exc.field else where,
                         str(exc)) from None


def rpy_to_matrix(roll: float, pitch: float, yaw: float) -> np.ndarray:
    """Rotation Rot_z(yaw)·Rot_y(pitch)·Rot_x(roll) (fixed axes x, y, z; rad), as URDF."""
    cy, sy = math.cos(pitch), math.sin(pitch)
    Ry = np.array([[cy, 0.0, sy], [0.0, 1.0, 0.0], [-sy, 0.0, cy]])
    return dh.rot_z(yaw) @ Ry @ dh.rot_x(roll)


__all__ = [
    "load_yaml_robot", "build_robot", "build_drive", "compose_gears", "load_motor",
    "load_gear",
    "read_yaml", "validate", "evaluate", "rpy_to_matrix", "CONSTANTS",
    "RobotSpec", "JointSpec", "LinkSpec", "DHSpec", "InertiaSpec", "DriveSpec", "ToolSpec",
    "MotorSpec", "GearSpec", "PRISMATIC", "REVOLUTE",
]
