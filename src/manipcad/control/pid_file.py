"""The short hand-written PID form of regulator files (``type: pid``).

One group gives a PID to each of its joints; every gain is one number (all joints of the
group) or a list with one entry per joint::

    # PID on every joint of the PUMA 560, sampled at 1 kHz
    type: pid
    period: 0.001          # sampling period, s (a multiple of the simulation step)
    kp: [800, 1500, 800, 100, 100, 60]   # V/rad (V/m); N·m/rad without drives
    ki: 0                  # V/(rad·s)
    kd: [20, 40, 20, 2, 2, 1]            # V·s/rad
    kff: 0                 # velocity feed-forward on q̇_ref, V·s/rad (optional)
    u_limit: 40            # output clip, V (N·m without drives); optional, default .inf
    joints: [waist, shoulder, elbow, wrist_roll, wrist_pitch, flange]  # optional: all

or several groups (``regulators:`` with a list of them). ``joints`` names the joints a
group controls (names, or 0-based indices; default: all joints of the robot).
"""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Mapping
from typing import Annotated, Any, Literal

from pydantic import BaseModel, BeforeValidator, ConfigDict, ValidationError

from manipcad.control.pid import PID_KP, pid
from manipcad.control.regulator import Regulator
from manipcad.errors import InputError, ManipcadError, ManipcadWarning
from manipcad.fileio import describe_error, validation_error
from manipcad.model.robot import Robot


def _listify(v: Any) -> Any:
    """Let one number stand for a one-entry list (broadcast to the group's joints)."""
    if isinstance(v, int | float) and not isinstance(v, bool):
        return [v]
    return v


Gains = Annotated[list[float], BeforeValidator(_listify)]


class GroupFile(BaseModel):
    """Fields every regulator group has."""

    model_config = ConfigDict(extra="forbid", strict=True)

    type: str
    period: float
    joints: list[str | int] | None = None


class PIDFile(GroupFile):
    """``type: pid``: gains of :func:`manipcad.control.pid` (one number or one per joint)."""

    type: Literal["pid"]
    kp: Gains
    ki: Gains = [0.0]
    kd: Gains = [0.0]
    kff: Gains = [0.0]
    u_limit: Gains = [math.inf]


def _build_pid(spec: PIDFile, joint: int, k: int) -> Regulator:
    def pick(values: list[float]) -> float:
        return values[0] if len(values) == 1 else values[k]

    return pid(joint, kp=pick(spec.kp), ki=pick(spec.ki), kd=pick(spec.kd),
               kff=pick(spec.kff), u_limit=pick(spec.u_limit), period=spec.period)


#: regulator type -> (schema, builder(schema, joint index, position in the group))
TYPES: dict[str, tuple[type[GroupFile], Callable[[Any, int, int], Regulator]]] = {
    "pid": (PIDFile, _build_pid),
}

#: per-type checks of the gain lists: field -> (predicate, reason)
_FINITE = (math.isfinite, "must be finite")
_CHECKS: dict[str, dict[str, tuple[Callable[[float], bool], str]]] = {
    "pid": {"kp": _FINITE, "ki": _FINITE, "kd": _FINITE, "kff": _FINITE,
            "u_limit": (lambda v: v > 0 and not math.isnan(v), "must be > 0 (.inf: no limit)")},
}


#: pydantic's union-branch names in error locations (not fields)
_UNION_TAGS = frozenset({"list[str]", "list[float]", "int", "str", "float"})


def short_pid_groups(groups: list, prefixes: list[str], robot: Robot, source: str,
                     dt: float | None, drives: bool) -> list[Regulator]:
    """The regulators of the short ``type: pid`` groups (one per joint of each group)."""
    out: list[Regulator] = []
    for group, prefix in zip(groups, prefixes, strict=True):
        for reg in _group(group, robot, source, prefix, dt):
            out.append(reg)
            _check_sign(reg, robot, drives, source, _join(prefix, "kp"))
    return out


def _check_sign(reg: Regulator, robot: Robot, drives: bool, source: str, where: str) -> None:
    """Warn when a PID's proportional gain gives positive feedback through the drive."""
    if reg.method != "pid":
        return
    j = int(reg.joints[0])
    d = robot.drives[j] if drives else None
    gain = 1.0 if d is None else math.copysign(1.0, d.ratio * d.k_u * d.k_m)
    kp = float(reg.params[PID_KP])
    if kp * gain < 0:
        why = (f"the drive's gear ratio is {d.ratio:g}, so the drive gain i_r·k_m·k_u/R is "
               f"{'negative' if gain < 0 else 'positive'}" if d is not None
               else "without a drive the output is the joint torque")
        warnings.warn(f"{source}: {where}: joint {robot.joint_names[j]!r} has kp = {kp:g}: "
                      f"positive feedback ({why}); give kp the sign "
                      f"{'-' if gain < 0 else '+'}", ManipcadWarning, stacklevel=3)


def _join(prefix: str, field: str) -> str:
    return f"{prefix}.{field}" if prefix else field


def _group(data: Any, robot: Robot, source: str, prefix: str,
           dt: float | None) -> list[Regulator]:
    if not isinstance(data, dict):
        raise InputError(source, prefix, "expected a mapping with a 'type', got "
                         f"{type(data).__name__}")
    if "type" not in data:
        raise InputError(source, _join(prefix, "type"), f"missing; one of {', '.join(TYPES)}")
    kind = data["type"]
    if not isinstance(kind, str) or kind not in TYPES:
        raise InputError(source, _join(prefix, "type"),
                         f"unknown regulator type {kind!r}; expected one of {', '.join(TYPES)}")
    schema, build = TYPES[kind]
    # YAML reads 1e-3 as a string and 1 as an int: give pydantic floats where floats are due
    data = {k: _floats(v) if k not in ("type", "joints") else v for k, v in data.items()}
    try:
        spec = schema.model_validate(data)
    except ValidationError as exc:
        def reason(err: Mapping[str, Any]) -> str:
            if err["type"] == "extra_forbidden":
                return (f"unknown field for a {kind!r} regulator "
                        f"(fields: {', '.join(schema.model_fields)})")
            if err["type"] == "missing":
                return f"missing (required for a {kind!r} regulator)"
            return describe_error(err)

        raise validation_error(source, exc, reason, prefix=prefix, skip=_UNION_TAGS) from None

    if not (math.isfinite(spec.period) and spec.period > 0):
        raise InputError(source, _join(prefix, "period"),
                         f"must be > 0 s and finite, got {spec.period}")
    if dt is not None:
        steps = spec.period / dt
        if round(steps) < 1 or abs(steps - round(steps)) > 1e-6 * steps:
            raise InputError(source, _join(prefix, "period"),
                             f"{spec.period:g} s is not a multiple of the simulation step "
                             f"dt = {dt:g} s")

    if spec.joints is None:
        joints = list(range(robot.n))
    else:
        if not spec.joints:
            raise InputError(source, _join(prefix, "joints"), "empty list; leave the field "
                             "out to control every joint")
        joints = []
        for k, name in enumerate(spec.joints):
            if isinstance(name, int) and not 0 <= name < robot.n:
                raise InputError(source, _join(prefix, f"joints[{k}]"),
                                 f"no joint {name}: indices are 0-based, 0..{robot.n - 1}")
            try:
                j = robot.joint_index(name)
            except ManipcadError:
                raise InputError(source, _join(prefix, f"joints[{k}]"),
                                 f"no joint {name!r} in robot {robot.name!r}; joints are "
                                 f"{', '.join(robot.joint_names)}") from None
            if j in joints:
                raise InputError(source, _join(prefix, f"joints[{k}]"),
                                 f"joint {robot.joint_names[j]!r} listed twice")
            joints.append(j)

    m = len(joints)
    what = "the group's joints" if spec.joints is not None else f"robot {robot.name!r}'s joints"
    for name, (ok, reason) in _CHECKS[kind].items():
        values = getattr(spec, name)
        if len(values) not in (1, m):
            raise InputError(source, _join(prefix, name),
                             f"has {len(values)} entries; expected one number or {m} "
                             f"(one per joint of {what})")
        for k, v in enumerate(values):
            if not ok(v):
                field = _join(prefix, name) + (f"[{k}]" if len(values) > 1 else "")
                raise InputError(source, field, f"{reason}, got {v}")
    regs = []
    for k, j in enumerate(joints):
        try:
            reg = build(spec, j, k)
            reg.joint_names = (robot.joint_names[j],)
            reg.robot = robot.name
            regs.append(reg)
        except ManipcadError as exc:  # the constructor's own checks
            raise InputError(source, prefix, str(exc)) from None
    return regs


def _floats(v: Any) -> Any:
    """Numbers as floats (YAML gives ints for ``1`` and strings for ``1e-3``)."""
    if isinstance(v, list):
        return [_floats(x) for x in v]
    if isinstance(v, bool):
        return v
    if isinstance(v, int):
        return float(v)
    if isinstance(v, str):
        try:
            return float(v)
        except ValueError:
            return v
    return v
