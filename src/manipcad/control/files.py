"""Regulator files: every method saved with everything needed to run it, no re-synthesis.

A file made by ``manipcad synthesize --out`` (or :meth:`Regulator.save`,
:func:`save_regulators`)::

    manipcad_version: 0.1.0
    robot: {name: cylindrical, hash: 3f1c...}       # the model it was designed for
    regulators:
    - method: ace_de                                # a name of manipcad.control.METHODS
      joints: [turn]                                # joint names (one, or several when the
                                                    #   method spans joints)
      period_s: 0.0001                              # sampling period, s
      law: "ace_de (turn): U = ..."                 # the law with its numbers (for people)
      spec: {bandwidth: 30.0, damping: 1.0}         # what it was designed for
      options: {realization: observable}            # synthesis options given
      drive_assumed: {J_kgm2: ..., ratio: ..., R_ohm: ..., ...}   # the drive of the design
      gains: {kp_V_per_rad: ..., kd_V_s_per_rad: ..., ...}       # the method's parameters
      table:                                        # lqr / lqr_gs only: the gain table
        H_ii_grid_kgm2: [...]                       #   uniform, increasing
        h_grid_Nms_per_rad: [...]                   #   h = Ḣ_ii axis (one point: none)
        D_e_V_per_rad: [[...], ...]                 #   one row per H_ii point
        ...
      design: {...}                                 # design numbers, for reading only

Units are in the keys (a drive's: :data:`manipcad.drives.params.PACKED_FIELDS`). Floats
are written with ``repr`` (YAML round-trips them exactly), so a regulator read back runs
bit for bit as the one saved. Hand-written files may also
use the short PID form (``type: pid`` with one gain or one per joint; see
:func:`regulators_from_dict`).

Bad files raise :class:`manipcad.errors.InputError` naming the file, the dotted field
(``regulators[1].gains.kd_V_s_per_rad``) and the reason: unknown method or field, missing
or non-monotone table grid, wrong lengths, NaN or infinite values, a non-positive period or
one that is not a multiple of the simulation step, a joint in two groups, a table that does
not cover the robot's load range, a file made for another robot (``allow_other_robot``).
A field a method marks optional (:attr:`~manipcad.control.method.Method.optional_fields`:
``gear_efficiency``, which files made before the laws modelled the gear's losses lack) is
not refused when missing: its default is taken (η = 1, the law those files were made
with), a :class:`~manipcad.errors.ManipcadWarning` names file and field, and the
regulator's law says so.
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.control.complexity import realization_complexity
from manipcad.control.pid_file import short_pid_groups
from manipcad.control.registry import METHODS, method
from manipcad.control.regulator import Regulator
from manipcad.control.signals import NPARAM
from manipcad.drives.params import NPAR, P_KIND, P_RATIO, PACKED_FIELDS
from manipcad.errors import InputError, ManipcadError, ManipcadWarning
from manipcad.fileio import atomic_write_text, dump_yaml, file_number, json_safe, read_yaml
from manipcad.model.hashing import robot_hash
from manipcad.model.robot import Robot
from manipcad.version import __version__

_GROUP_KEYS = {"method", "joints", "period_s", "law", "spec", "options", "drive_assumed",
               "drives_assumed", "gains", "table", "design"}


# ---------------------------------------------------------------- writing
def regulator_to_dict(reg: Regulator) -> dict[str, Any]:
    """One regulator as a file group (plain, YAML/JSON-safe values; floats exact)."""
    m = method(reg.method)
    p = np.asarray(reg.params, dtype=float)
    names = list(reg.joint_names) or [str(j) for j in reg.joints]
    g: dict[str, Any] = {"method": reg.method, "joints": names, "period_s": float(reg.period),
                         "law": reg.law, "spec": json_safe(dict(reg.spec)),
                         "options": json_safe(dict(reg.options))}
    if m.drive_blocks == 1:
        g["drive_assumed"] = {k: float(p[i]) for k, i in PACKED_FIELDS.items()}
    elif m.drive_blocks == "per_joint":
        base = m.drive_base
        g["drives_assumed"] = {
            nm: {**{k: float(p[base + a * NPAR + i]) for k, i in PACKED_FIELDS.items()},
                 **{k: float(p[i0 + a]) for k, i0 in m.joint_fields.items()}}
            for a, nm in enumerate(names)}
    g["gains"] = {k: float(p[i]) for k, i in m.fields.items()}
    if m.table:
        g["table"] = m.table.to_file(p)
    g["design"] = json_safe({k: v for k, v in reg.design.items()
                             if k not in ("table", "weights", "transmission")})
    return g


def save_regulators(regs: Sequence[Regulator], path: str | Path, *,
                    robot: Robot | None = None) -> Path:
    """Write regulators to one YAML file, atomically (an existing file is replaced whole).

    Args:
        regs: the regulators (any methods, different joints).
        path: the file to write.
        robot: the robot they were made for (default: the name and hash they carry).

    Returns:
        The path written.

    Example:
        >>> import manipcad, tempfile, os
        >>> arm = manipcad.load_robot("cylindrical")
        >>> reg = manipcad.synthesize(arm, "turn", "ace_de")
        >>> path = os.path.join(tempfile.mkdtemp(), "reg.yaml")
        >>> _ = save_regulators([reg], path)
        >>> back = manipcad.load_regulators(path, arm)
        >>> bool((back[0].params == reg.params).all())
        True
    """
    text = regulators_yaml(regs, robot=robot)
    return atomic_write_text(path, text)


def regulators_document(regs: Sequence[Regulator], *, robot: Robot | None = None) -> dict:
    """The whole file as a mapping (what ``--json`` prints)."""
    regs = list(regs)
    if not regs:
        raise ManipcadError("no regulator to save")
    if robot is not None:
        rob = {"name": robot.name, "hash": robot_hash(robot)}
    else:
        rob = {"name": regs[0].robot, "hash": regs[0].robot_hash}
    return {"manipcad_version": __version__, "robot": rob,
            "regulators": [regulator_to_dict(r) for r in regs]}


def regulators_yaml(regs: Sequence[Regulator], *, robot: Robot | None = None) -> str:
    """The file's YAML text."""
    doc = regulators_document(regs, robot=robot)
    head = ("# manipcad regulator file: SI units (in the keys); made by manipcad "
            f"{doc['manipcad_version']}\n")
    return head + dump_yaml(doc, sort_keys=False, allow_unicode=True, width=100)


# ---------------------------------------------------------------- reading
def load_regulators(path: str | Path, robot: Robot, *, dt: float | None = None,
                    drives: bool = True, allow_other_robot: bool = False) -> list[Regulator]:
    """Load the regulators of a robot from a regulator file.

    Args:
        path: the file (this module's format, or the short ``type: pid`` form).
        robot: the robot the file's joints belong to.
        dt: the simulation step, s; if given, every period must be a multiple of it.
        drives: whether the run simulates the drives (for the PID sign check).
        allow_other_robot: accept a file made for a robot with another model hash.

    Returns:
        The regulators, for :func:`manipcad.simulate`.

    Raises:
        InputError: naming the file, the dotted field and the reason.
    """
    data = read_yaml(path, "a mapping with 'regulators' (or a 'type')")
    return regulators_from_dict(data, robot, str(path), dt=dt, drives=drives,
                                allow_other_robot=allow_other_robot)


def regulators_from_dict(data: Any, robot: Robot, source: str = "<dict>", *,
                         dt: float | None = None, drives: bool = True,
                         allow_other_robot: bool = False) -> list[Regulator]:
    """Build the regulators of a robot from a regulator file's mapping (see the module).

    Example:
        >>> import manipcad
        >>> from manipcad.control.files import regulators_from_dict
        >>> arm = manipcad.load_robot("cylindrical")
        >>> regs = regulators_from_dict({"type": "pid", "period": 1e-3, "kp": [3640, 2170],
        ...                              "kd": [0, 48], "joints": ["lift", "reach"]}, arm)
        >>> [r.joints for r in regs]
        [(1,), (2,)]
    """
    if not isinstance(data, dict):
        raise InputError(source, "", "expected a mapping with 'regulators' (or a 'type'), got "
                         f"{type(data).__name__}")
    if "type" in data:
        regs = short_pid_groups([data], [""], robot, source, dt, drives)
        return _owned(regs, [""] * len(regs), robot, source)
    if "regulators" not in data:
        raise InputError(source, "type", "missing: a file holds 'regulators:' (a list of "
                         "groups) or one short group with 'type: pid'")
    extra = sorted(set(data) - {"manipcad_version", "robot", "regulators"})
    if extra:
        raise InputError(source, extra[0], "unknown field beside 'regulators' (expected "
                         "manipcad_version, robot, regulators; put it inside a group)")
    groups = data.get("regulators")
    if not isinstance(groups, list) or not groups:
        raise InputError(source, "regulators", "expected a non-empty list of regulator groups")
    _check_robot(data.get("robot"), robot, source, allow_other_robot)
    out: list[Regulator] = []
    at: list[str] = []
    for g, group in enumerate(groups):
        where = f"regulators[{g}]"
        if isinstance(group, dict) and "type" in group:
            regs = short_pid_groups([group], [where], robot, source, dt, drives)
        else:
            regs = [_group(group, robot, source, where, dt)]
        out += regs
        at += [where] * len(regs)
    return _owned(out, at, robot, source)


def _owned(regs: list[Regulator], at: list[str], robot: Robot,
           source: str) -> list[Regulator]:
    owner: dict[int, str] = {}
    for reg, where in zip(regs, at, strict=True):
        for j in reg.joints:
            if j in owner and owner[j] != where:
                raise InputError(source, f"{where}.joints" if where else "joints",
                                 f"joint {robot.joint_names[j]!r} already has a regulator "
                                 f"(in {owner[j] or 'the file'})")
            owner[j] = where
    return regs


def _check_robot(rob: Any, robot: Robot, source: str, allow: bool) -> None:
    if rob is None:
        return
    if not isinstance(rob, dict) or set(rob) - {"name", "hash"}:
        raise InputError(source, "robot", "expected {name: ..., hash: ...}")
    h = rob.get("hash")
    if h and h != robot_hash(robot) and not allow:
        raise InputError(source, "robot.hash",
                         f"the file was made for robot {rob.get('name')!r} with model hash "
                         f"{h}, not for {robot.name!r} (hash {robot_hash(robot)}); "
                         "re-synthesize, or allow it (--allow-other-robot)")


def _mapping(source: str, where: str, v: Any, keys: dict[str, int], *,
             inf_ok: Sequence[str] = (), optional: dict | None = None,
             assumed: list[str] | None = None) -> dict[str, float]:
    """The numbers of a file's mapping with exactly ``keys``; a key of ``optional`` (key ->
    (value, meaning)) may be missing: its value is taken and "field: meaning" appended to
    ``assumed``."""
    if not isinstance(v, dict):
        raise InputError(source, where, f"expected a mapping with {', '.join(keys)}")
    unknown = sorted(set(v) - set(keys))
    if unknown:
        raise InputError(source, f"{where}.{unknown[0]}",
                         f"unknown field (fields: {', '.join(keys)})")
    optional = optional or {}
    missing = [k for k in keys if k not in v and k not in optional]
    if missing:
        raise InputError(source, f"{where}.{missing[0]}", "missing")
    out = {}
    for k in keys:
        if k in v:
            out[k] = file_number(source, f"{where}.{k}", v[k], allow_inf=k in inf_ok)
        else:
            out[k], meaning = optional[k]
            if assumed is not None:
                assumed.append(f"{where}.{k} missing: {meaning}")
    return out


def _check_efficiency(source: str, where: str, values: dict[str, float]) -> None:
    eta = values.get("gear_efficiency")
    if eta is not None and not 0 < eta <= 1:
        raise InputError(source, f"{where}.gear_efficiency",
                         f"must be in (0, 1] (the gear's efficiency η, -), got {eta}")


_INF_OK = ("u_limit_V", "u_max_V", "H_ii_feedforward_kgm2")


def _group(group: Any, robot: Robot, source: str, where: str,
           dt: float | None) -> Regulator:
    if not isinstance(group, dict):
        raise InputError(source, where, f"expected a mapping with a 'method', got "
                         f"{type(group).__name__}")
    unknown = sorted(set(group) - _GROUP_KEYS)
    if unknown:
        raise InputError(source, f"{where}.{unknown[0]}",
                         f"unknown field (fields: {', '.join(sorted(_GROUP_KEYS))})")
    name = group.get("method")
    if name not in METHODS:
        raise InputError(source, f"{where}.method",
                         f"unknown method {name!r}; expected one of {', '.join(METHODS)}")
    m = METHODS[name]
    period = file_number(source, f"{where}.period_s", group.get("period_s"), positive=True)
    if dt is not None:
        steps = period / dt
        if round(steps) < 1 or abs(steps - round(steps)) > 1e-6 * steps:
            raise InputError(source, f"{where}.period_s", f"{period:g} s is not a multiple "
                             f"of the simulation step dt = {dt:g} s")
    joints = _joints(group.get("joints"), robot, source, f"{where}.joints", m.spans)
    p = np.zeros(NPARAM)
    assumed: list[str] = []
    if m.drive_blocks == 1:
        d = _mapping(source, f"{where}.drive_assumed", group.get("drive_assumed"),
                     PACKED_FIELDS, inf_ok=_INF_OK)
        for k, i in PACKED_FIELDS.items():
            p[i] = d[k]
        _check_drive(source, f"{where}.drive_assumed", p, 0)
    elif m.drive_blocks == "per_joint":
        ds = group.get("drives_assumed")
        names = [robot.joint_names[j] for j in joints]
        if not isinstance(ds, dict) or sorted(ds) != sorted(names):
            raise InputError(source, f"{where}.drives_assumed",
                             f"expected one drive per joint of the group: {', '.join(names)}")
        base = m.drive_base
        keys = {**PACKED_FIELDS, **m.joint_fields}
        for a, nm in enumerate(names):
            d = _mapping(source, f"{where}.drives_assumed.{nm}", ds[nm], keys, inf_ok=_INF_OK,
                         optional=m.optional_fields, assumed=assumed)
            _check_efficiency(source, f"{where}.drives_assumed.{nm}", d)
            for k, i in PACKED_FIELDS.items():
                p[base + a * NPAR + i] = d[k]
            for k, i0 in m.joint_fields.items():
                p[i0 + a] = d[k]
            _check_drive(source, f"{where}.drives_assumed.{nm}", p, base + a * NPAR)
    gains = _mapping(source, f"{where}.gains", group.get("gains"), m.fields, inf_ok=_INF_OK,
                     optional=m.optional_fields, assumed=assumed)
    _check_efficiency(source, f"{where}.gains", gains)
    for k, i in m.fields.items():
        p[i] = gains[k]
    for k in ("u_limit_V",):
        if k in gains and not gains[k] > 0:
            raise InputError(source, f"{where}.gains.{k}", f"must be > 0, got {gains[k]}")
    if m.table:
        m.table.from_file(group.get("table"), p, robot, joints[0], source, f"{where}.table")
    for key in ("spec", "options", "design"):
        if not isinstance(group.get(key, {}), dict):
            raise InputError(source, f"{where}.{key}", "expected a mapping")
    law = group.get("law", "")
    if not isinstance(law, str):
        raise InputError(source, f"{where}.law", "expected a string")
    for note in assumed:
        # an older file: the value taken for a field it lacks, said in the law and warned
        warnings.warn(f"{source}: {note}", ManipcadWarning, stacklevel=4)
        law = f"{law} [{note}]" if law else f"[{note}]"
    return Regulator(
        method=name, joints=tuple(joints), period=period, params=p,
        needs=_needs_of(name, p, joints), law=law, spec=dict(group.get("spec") or {}),
        options=dict(group.get("options") or {}), design=dict(group.get("design") or {}),
        joint_names=tuple(robot.joint_names[j] for j in joints), robot=robot.name,
        robot_hash=robot_hash(robot))


def _needs_of(name: str, p: np.ndarray, joints: list[int]) -> tuple[str, ...]:
    """The signals a loaded regulator reads, counted from its law (see :mod:`.complexity`)."""
    probe = Regulator(method=name, joints=tuple(joints), period=1e-3, params=p)
    return tuple(realization_complexity(probe)["signals"])


def _joints(v: Any, robot: Robot, source: str, where: str, spans: bool) -> list[int]:
    if not isinstance(v, list) or not v:
        raise InputError(source, where, "expected a non-empty list of joint names")
    if len(v) > 1 and not spans:
        raise InputError(source, where, "this method controls one joint per group; "
                         "give one joint")
    out = []
    for k, name in enumerate(v):
        if isinstance(name, bool) or not isinstance(name, str | int):
            raise InputError(source, f"{where}[{k}]", f"expected a joint name, got {name!r}")
        if isinstance(name, int) and not 0 <= name < robot.n:
            raise InputError(source, f"{where}[{k}]", f"no joint {name} (0-based, the robot "
                             f"has {robot.n})")
        try:
            j = robot.joint_index(name)
        except (ManipcadError, KeyError, IndexError, ValueError):
            raise InputError(source, f"{where}[{k}]",
                             f"no joint {name!r} in robot {robot.name!r}; joints are "
                             f"{', '.join(robot.joint_names)}") from None
        if j in out:
            raise InputError(source, f"{where}[{k}]",
                             f"joint {robot.joint_names[j]!r} listed twice")
        out.append(j)
    return out


def _check_drive(source: str, where: str, p: np.ndarray, o: int) -> None:
    for k in ("R_ohm", "k_m_Nm_per_A", "k_u"):
        i = PACKED_FIELDS[k]
        if not p[o + i] > 0:
            raise InputError(source, f"{where}.{k}", f"must be > 0, got {p[o + i]}")
    if p[o + P_RATIO] == 0:
        raise InputError(source, f"{where}.ratio", "must be nonzero")
    if p[o + P_KIND] not in (0, 1, 2, 3, 4):
        raise InputError(source, f"{where}.kind", f"must be one of 0..4, got {p[o + P_KIND]}")


__all__ = ["load_regulators", "save_regulators", "regulators_from_dict", "regulator_to_dict",
           "regulators_yaml", "regulators_document"]
