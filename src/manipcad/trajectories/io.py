"""Trajectory files: YAML load and save, validated with pydantic.

A file is one mapping with a ``type`` key and that type's fields, SI units
(joint values in rad or m, times in s). Examples::

    type: cosine            # q = q0 + A(1 - cos ωt), the paper's laws (2)
    amplitude: [0.5, 0.0, 0.25]   # A per joint, rad or m (one number: all joints)
    omega: [4.0, 0.0, 16.0]       # ω per joint, rad/s
    duration: 1.6                 # s (optional: one period of the slowest joint)
    q0: [0.0, 0.0, 0.0]           # start, rad or m (optional, default 0)

    type: quintic           # q_start, q_end (rad or m), duration (s)
    type: trapezoidal       # q_start, q_end, v_max (rad/s or m/s), a_max (rad/s² or m/s²)
    type: spline            # times (s, strictly increasing), points (one row per time)
    type: line              # robot, p_start, p_end (m), duration (s), q0,
                            #   profile (quintic|cubic|linear), orientation (free|fixed)
    type: circle            # robot, center (m), radius (m), normal, duration (s), q0,
                            #   angle (rad, default 2π), start, profile, orientation
    type: waypoints         # points (one pose a row, rad or m), move_time (s, one or
                            #   one per move), dwell (s, one or one per pose),
                            #   profile (quintic|trapezoidal), dither (rad or m, one or
                            #   one per joint: a sine at the end of each dwell),
                            #   dither_frequency (Hz)

``robot`` is a catalog name or a robot file path (relative paths are taken
from the trajectory file's folder). Unknown fields, wrong types, wrong
lengths and non-physical values raise :class:`manipcad.errors.InputError`
naming the file, the field (dotted, with [i] for list entries) and the reason.
Saving writes a temporary file beside the target and renames it over the
target, so an interrupted or failed save leaves any earlier file intact.
"""

from __future__ import annotations

import math
import os  # noqa: F401  (tests reach os.replace / os.fsync of the atomic save as io.os)
from collections.abc import Mapping
from pathlib import Path
from typing import Annotated, Any, Literal

import numpy as np
from pydantic import BaseModel, BeforeValidator, ConfigDict, ValidationError

from manipcad.errors import InputError, ManipcadError
from manipcad.fileio import (
    atomic_write_text,
    describe_error,
    dump_yaml,
    read_yaml,
    validation_error,
)
from manipcad.model.load import load_robot
from manipcad.model.robot import Robot
from manipcad.trajectories.base import Trajectory
from manipcad.trajectories.cartesian import circle, line
from manipcad.trajectories.cosine import cosine
from manipcad.trajectories.quintic import quintic
from manipcad.trajectories.spline import spline
from manipcad.trajectories.trapezoidal import trapezoidal
from manipcad.trajectories.waypoints import waypoints


def _listify(v: Any) -> Any:
    """Let a single number stand for a one-entry list (broadcast to every joint later)."""
    if isinstance(v, int | float) and not isinstance(v, bool):
        return [v]
    return v


Numbers = list[float]
NumbersOrOne = Annotated[list[float], BeforeValidator(_listify)]
Profile = Literal["quintic", "cubic", "linear"]
Orientation = Literal["free", "fixed"]


class _Schema(BaseModel):
    model_config = ConfigDict(extra="forbid", strict=True, allow_inf_nan=False)


class CosineFile(_Schema):
    """Fields of ``type: cosine`` (see :func:`manipcad.trajectories.cosine`)."""

    type: Literal["cosine"]
    amplitude: NumbersOrOne
    omega: NumbersOrOne
    duration: float | None = None
    q0: NumbersOrOne = [0.0]


class QuinticFile(_Schema):
    """Fields of ``type: quintic`` (see :func:`manipcad.trajectories.quintic`)."""

    type: Literal["quintic"]
    q_start: Numbers
    q_end: Numbers
    duration: float


class TrapezoidalFile(_Schema):
    """Fields of ``type: trapezoidal`` (see :func:`manipcad.trajectories.trapezoidal`)."""

    type: Literal["trapezoidal"]
    q_start: Numbers
    q_end: Numbers
    v_max: NumbersOrOne
    a_max: NumbersOrOne


class SplineFile(_Schema):
    """Fields of ``type: spline`` (see :func:`manipcad.trajectories.spline`)."""

    type: Literal["spline"]
    times: Numbers
    points: list[Numbers]


class LineFile(_Schema):
    """Fields of ``type: line`` (see :func:`manipcad.trajectories.line`)."""

    type: Literal["line"]
    robot: str | None = None
    p_start: Numbers
    p_end: Numbers
    duration: float
    q0: Numbers
    profile: Profile = "quintic"
    orientation: Orientation = "free"


class CircleFile(_Schema):
    """Fields of ``type: circle`` (see :func:`manipcad.trajectories.circle`)."""

    type: Literal["circle"]
    robot: str | None = None
    center: Numbers
    radius: float
    normal: Numbers
    duration: float
    q0: Numbers
    angle: float = 2.0 * math.pi
    start: Numbers | None = None
    profile: Profile = "quintic"
    orientation: Orientation = "free"


class WaypointsFile(_Schema):
    """Fields of ``type: waypoints`` (see :func:`manipcad.trajectories.waypoints`)."""

    type: Literal["waypoints"]
    points: list[Numbers]
    move_time: NumbersOrOne
    dwell: NumbersOrOne = [0.0]
    profile: Literal["quintic", "trapezoidal"] = "quintic"
    dither: NumbersOrOne = [0.0]
    dither_frequency: float = 10.0


SCHEMAS: dict[str, type[_Schema]] = {
    "cosine": CosineFile, "quintic": QuinticFile, "trapezoidal": TrapezoidalFile,
    "spline": SplineFile, "line": LineFile, "circle": CircleFile, "waypoints": WaypointsFile,
}


def _pydantic_error(source: str, kind: str, exc: ValidationError) -> InputError:
    def reason(err: Mapping[str, Any]) -> str:
        if err["type"] == "extra_forbidden":
            allowed = ", ".join(SCHEMAS[kind].model_fields)
            return f"unknown field for a {kind!r} trajectory (fields: {allowed})"
        if err["type"] == "missing":
            return f"missing (required for a {kind!r} trajectory)"
        return describe_error(err)

    return validation_error(source, exc, reason)


def trajectory_from_dict(data: Any, source: str = "<dict>", *, robot: Robot | None = None,
                         base_dir: Path | None = None) -> Trajectory:
    """Build a trajectory from its YAML mapping (as :meth:`Trajectory.to_dict` gives).

    Args:
        data: the mapping; its ``type`` picks the law.
        source: the name used in errors (usually the file path).
        robot: for line and circle paths, the robot to use instead of the
            mapping's ``robot`` field.
        base_dir: folder that relative robot file paths are taken from.

    Returns:
        The :class:`Trajectory`.

    Raises:
        InputError: naming ``source``, the dotted field and the reason.

    Example:
        >>> traj = trajectory_from_dict({"type": "quintic", "q_start": [0.0],
        ...                              "q_end": [1.0], "duration": 2.0})
        >>> traj.duration
        2.0
    """
    if not isinstance(data, dict):
        raise InputError(source, "", "expected a mapping of trajectory fields with a 'type', "
                         f"got {type(data).__name__}")
    if "type" not in data:
        raise InputError(source, "type", f"missing; one of {', '.join(SCHEMAS)}")
    kind = data["type"]
    if not isinstance(kind, str) or kind not in SCHEMAS:
        raise InputError(source, "type", f"unknown trajectory type {kind!r}; expected one of "
                         f"{', '.join(SCHEMAS)}")
    try:
        spec = SCHEMAS[kind].model_validate(data)
    except ValidationError as exc:
        raise _pydantic_error(source, kind, exc) from None
    fields = spec.model_dump(exclude={"type"})
    try:
        if kind in ("line", "circle"):
            fields["robot"] = _resolve_robot(source, fields.pop("robot"), robot, base_dir)
            make = line if kind == "line" else circle
            traj = make(**fields)
        elif kind == "waypoints":
            traj = waypoints(fields.pop("points"), **fields)
        else:
            traj = {"cosine": cosine, "quintic": quintic, "trapezoidal": trapezoidal,
                    "spline": spline}[kind](**fields)
    except InputError as exc:
        if exc.source == source:
            raise
        if exc.source == kind:  # raised by the constructor: name the file
            raise InputError(source, exc.field, exc.reason) from None
        raise InputError(source, "", str(exc)) from None
    except ManipcadError as exc:
        raise InputError(source, "", f"the {kind} path cannot be followed: {exc}") from None
    except (ValueError, ArithmeticError) as exc:  # a numerical failure inside the law
        raise InputError(source, "", f"the {kind} trajectory cannot be built from these "
                         f"values: {exc}") from None
    _check_finite_samples(traj, source, kind)
    return traj


#: samples taken at load to check that a law's values stay finite
CHECK_SAMPLES = 33


def _check_finite_samples(traj: Trajectory, source: str, kind: str) -> None:
    """Refuse a law whose duration, positions, speeds or accelerations are not finite
    at :data:`CHECK_SAMPLES` evenly spread times (values that overflow, e.g. an
    amplitude of 1e300 rad), instead of giving NaN torques later."""
    T = traj.duration
    if not (math.isfinite(T) and T >= 0):
        raise InputError(source, "", f"the {kind} trajectory lasts {T} s; expected a finite "
                         "duration (check the speeds, accelerations and times)")
    with np.errstate(all="ignore"):
        q, qd, qdd = traj.sample(np.linspace(0.0, T, CHECK_SAMPLES))
    for name, a in (("positions", q), ("speeds", qd), ("accelerations", qdd)):
        if not np.isfinite(a).all():
            raise InputError(source, "", f"the {kind} trajectory's {name} are not finite "
                             "(the values overflow: check the amplitudes, speeds and times)")


def _resolve_robot(source: str, ref: str | None, robot: Robot | None,
                   base_dir: Path | None) -> Robot:

    if robot is not None:
        return robot
    if not ref:
        raise InputError(source, "robot", "missing: a catalog robot name or a robot file path")
    path = Path(ref)
    if base_dir is not None and not path.is_absolute() and (
            path.suffix.lower() in (".yaml", ".yml", ".urdf") or len(path.parts) > 1):
        path = base_dir / path
        ref = str(path)
    try:
        return load_robot(ref)
    except ManipcadError as exc:
        raise InputError(source, "robot", f"cannot load robot {ref!r}: {exc}") from None


def load_trajectory(path: str | Path, *, robot: Robot | None = None) -> Trajectory:
    """Load a trajectory from a YAML file.

    Args:
        path: the file (schema in this module's docstring; SI units).
        robot: for line and circle paths, use this robot instead of the file's
            ``robot`` field (which may then be left out).

    Returns:
        The :class:`Trajectory`.

    Raises:
        InputError: naming the file, the dotted field and the reason (no such
            file, YAML syntax, unknown type or field, wrong lengths, negative
            duration, times not increasing, an unreachable path...).

    Example:
        >>> from manipcad.trajectories import load_trajectory
        >>> traj = load_trajectory("examples/fig3_laws.yaml")  # doctest: +SKIP
        >>> traj.n, traj.duration  # doctest: +SKIP
        (3, 1.6)
    """
    data = read_yaml(path, "a mapping with a 'type'")
    return trajectory_from_dict(data, str(path), robot=robot, base_dir=Path(path).parent)


def save_trajectory(trajectory: Trajectory, path: str | Path) -> Path:
    """Save a trajectory as YAML, atomically.

    The text is written to a temporary file in the target's folder, flushed to
    disk and renamed over the target; if anything fails (or the run is
    interrupted) the temporary file is removed and an existing file at
    ``path`` is left as it was.

    Args:
        trajectory: any :class:`Trajectory`.
        path: the target file (its folder must exist).

    Returns:
        The path written.

    Raises:
        InputError: the folder does not exist or cannot be written.

    Example:
        >>> from manipcad.trajectories import cosine, save_trajectory
        >>> save_trajectory(cosine([0.5], [4.0], 1.6), "/tmp/q1.yaml")  # doctest: +SKIP
        PosixPath('/tmp/q1.yaml')
    """
    text = ("# manipcad trajectory; SI units: joint values rad or m, times s\n"
            + dump_yaml(trajectory.to_dict(), sort_keys=False, default_flow_style=None,
                             width=100))
    return atomic_write_text(path, text)
