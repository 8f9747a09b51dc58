"""What an item is: its kind recognized from the content, its validation, its hash, its metrics.

Validation uses the same loaders (schemas and messages) as everywhere else:
``load_robot``, ``load_motor``, ``load_gear``, ``load_trajectory``, the
regulator files' loader and ``load_result``.
"""

from __future__ import annotations

import hashlib
import math
import os
import warnings
from collections.abc import Collection
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.control import load_regulators
from manipcad.errors import InputError, ManipcadWarning
from manipcad.fileio import read_yaml
from manipcad.model.load import catalog_names, load_robot
from manipcad.model.yaml_robot import load_gear, load_motor
from manipcad.store.results import load_result
from manipcad.trajectories import load_trajectory
from manipcad.trajectories.io import SCHEMAS
from manipcad.workspace.names import kind_of

#: the marker of a bundle folder made by ``ws export``
BUNDLE_MANIFEST = "manipcad-bundle.json"

_GEAR_TYPES = ("planetary", "harmonic", "spur", "ball_screw", "rack_pinion", "belt")


def file_hash(path: Path) -> str:
    """SHA-256 of a file's bytes, hex."""
    h = hashlib.sha256()
    with open(path, "rb") as fh:
        for block in iter(lambda: fh.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def content_hash(path: Path, skip: Collection[str] = ()) -> str:
    """SHA-256 of an item: a file's bytes, or a folder's files (relative names and
    bytes, in sorted order; hidden names and the relative names in ``skip`` left out), hex.

    Example:
        >>> import tempfile, pathlib
        >>> p = pathlib.Path(tempfile.mkdtemp()) / "a.yaml"
        >>> _ = p.write_text("x: 1\\n")
        >>> content_hash(p)[:12]
        'd09edadd173a'
    """
    if not path.is_dir():
        return file_hash(path)
    h = hashlib.sha256()
    for dirpath, dirs, files in os.walk(path):
        dirs[:] = sorted(d for d in dirs if not d.startswith("."))
        for f in sorted(files):
            if f.startswith("."):
                continue
            full = Path(dirpath) / f
            if str(full.relative_to(path)) in skip:
                continue
            h.update(str(full.relative_to(path)).encode() + b"\0")
            h.update(file_hash(full).encode() + b"\n")
    return h.hexdigest()


def _yaml_data(path: Path) -> Any:

    return read_yaml(path, unique_keys=False)


def detect_kind(path: Path) -> str:
    """The kind of a file or folder from its content.

    Folders: a result (metrics.json and timeseries.npz), a bundle (``ws
    export``), else a study. Files: .urdf and MJCF/URDF XML are robots; YAML by
    its keys: ``joints``/``urdf`` robot, ``k_m`` and ``R`` motor, a gear
    ``type`` with ``ratio`` gear, a trajectory ``type`` trajectory,
    ``regulators`` or ``period`` regulator.

    Raises:
        InputError: the kind cannot be told (use ``--kind``).
    """
    src = str(path)
    if path.is_dir():
        if (path / BUNDLE_MANIFEST).is_file():
            return "bundle"
        if (path / "metrics.json").is_file() and (path / "timeseries.npz").is_file():
            return "results"
        return "studies"
    suffix = path.suffix.lower()
    if suffix in (".urdf", ".xml", ".mjcf"):
        head = path.read_bytes()[:4096].decode("utf-8", "replace")
        if "<robot" in head or "<mujoco" in head:
            return "robots"
        raise InputError(src, "", "an XML file that is neither URDF (<robot>) nor MJCF "
                         "(<mujoco>)")
    if suffix not in (".yaml", ".yml"):
        raise InputError(src, "", f"cannot tell the kind of a {suffix or 'suffix-less'} file; "
                         "workspace files are .yaml, .urdf or MJCF .xml (or give --kind)")
    data = _yaml_data(path)
    if not isinstance(data, dict):
        raise InputError(src, "", "expected a mapping; cannot tell the kind (give --kind)")

    joints = data.get("joints")
    if "urdf" in data or isinstance(joints, list) and joints and all(
            isinstance(j, dict) for j in joints):
        return "robots"
    if "k_m" in data and "R" in data:
        return "motors"
    if "ratio" in data and data.get("type") in _GEAR_TYPES:
        return "gears"
    if data.get("type") in SCHEMAS:
        return "trajectories"
    if "regulators" in data or "period" in data or "period_s" in data or "method" in data:
        return "regulators"
    raise InputError(src, "", "cannot tell the kind from the keys "
                     f"({', '.join(map(str, list(data)[:6]))}); give --kind")


def validate_item(kind: str, path: Path, *, robot=None) -> dict[str, Any]:
    """Load an item with the project's own loader; raise its error if it is bad.

    Args:
        kind: the item kind (:data:`manipcad.workspace.names.KINDS`).
        path: its file or folder.
        robot: for regulators and Cartesian trajectories, the robot to check
            them against (a :class:`~manipcad.model.Robot`), or None.

    Returns:
        Facts for the listing: ``{"summary": text}`` and, for results, the
        metrics document and ``status``.

    Raises:
        InputError, ModelError: what the loader says (file, field, reason).
    """
    kind = kind_of(kind)
    src = str(path)
    if kind == "results":

        res, doc = load_result(path)
        return {"summary": f"{doc.get('robot', '')}: {len(res.t)} samples to "
                           f"t = {doc.get('t_final')} s, {doc.get('status', '?')}",
                "status": doc.get("status"), "doc": doc, "result": res}
    if kind == "studies":
        if not path.is_dir() or not any(p for p in path.iterdir() if not p.name.startswith(".")):
            raise InputError(src, "", "a study is a folder with its files; this one is empty")
        return {"summary": f"{sum(1 for _ in path.rglob('*'))} files"}
    if not path.is_file():
        raise InputError(src, "", "no such file" if not path.exists() else "is not a file")
    if kind == "robots":
        r = _load_any_robot(path)
        kinds = "".join("R" if t == "revolute" else "P" for t in r.joint_types)
        return {"summary": f"{r.name}: {r.n} joints {kinds}"
                           + (", drives" if r.has_drives else "")}
    if kind == "motors":

        m = load_motor(str(path.resolve()))
        return {"summary": f"J = {m.J:g} kg·m², R = {m.R:g} Ω, k_m = {m.k_m:g} N·m/A"}
    if kind == "gears":

        g = load_gear(str(path.resolve()))
        return {"summary": f"{g.type}, ratio {g.ratio:g}"}
    if kind == "trajectories":

        t = load_trajectory(path, robot=robot)
        return {"summary": f"{type(t).__name__}, {t.n} joints, {float(t.duration):g} s"}
    # regulators
    return {"summary": _check_regulator(path, robot)}


def _load_any_robot(path: Path):

    return load_robot(path)


def regulator_robot_name(path: Path) -> str | None:
    """The robot a regulator file names (``robot: {name: ...}`` or ``robot: NAME``), or None."""
    try:
        data = _yaml_data(path)
    except InputError:
        return None
    ref = data.get("robot") if isinstance(data, dict) else None
    if isinstance(ref, dict):
        ref = ref.get("name")
    return ref if isinstance(ref, str) and ref else None


def _check_regulator(path: Path, robot) -> str:
    """A regulator file: with the regulator loader against ``robot`` (given, or the
    catalog robot the file names); otherwise its structure (groups with a type or
    method and a positive period)."""
    src = str(path)
    data = _yaml_data(path)
    if robot is None:
        name = regulator_robot_name(path)
        if name is not None:

            if name in catalog_names("robots"):
                robot = _quiet(load_robot, name)
    if robot is not None:

        regs = _quiet(load_regulators, path, robot)
        return f"{len(regs)} joints of {robot.name}"
    if not isinstance(data, dict):
        raise InputError(src, "", "expected a mapping with a 'type' or a 'regulators' list")
    groups = data["regulators"] if "regulators" in data else [data]
    if not isinstance(groups, list) or not groups:
        raise InputError(src, "regulators", "expected a non-empty list of regulator groups")
    types = []
    for g, group in enumerate(groups):
        where = f"regulators[{g}]." if "regulators" in data else ""
        kind = group.get("type", group.get("method")) if isinstance(group, dict) else None
        if not isinstance(kind, str):
            raise InputError(src, f"{where}type", "missing: each group needs a 'type' "
                             "(or a 'method')")
        period = group.get("period", group.get("period_s"))
        if not (isinstance(period, int | float) and not isinstance(period, bool)
                and math.isfinite(period) and period > 0):
            raise InputError(src, f"{where}period", f"must be a number > 0 s, got {period!r}")
        types.append(kind)
    return f"{', '.join(types)} (checked against a robot when one is given)"


def _quiet(fn, *args):
    """Call a loader with its data warnings silenced (shown where the data is used)."""


    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return fn(*args)


def check_metrics(checks) -> dict[tuple[str, str], float]:
    """The indexed figures of a result's run checks (metrics.json ``checks``): per joint,
    ``fails`` and ``unknowns`` (how many of its checks fail or are unknown) and
    ``check_NAME``, each check's value (its unit in docs/checks.md); nothing for a
    result without checks.

    Example:
        >>> check_metrics({"elbow": {"saturation": {"value": 1.0, "limit": 0.02, "unit": "-",
        ...                                         "verdict": "fail"}}})
        {('elbow', 'fails'): 1.0, ('elbow', 'unknowns'): 0.0, ('elbow', 'check_saturation'): 1.0}
    """
    out: dict[tuple[str, str], float] = {}
    if not isinstance(checks, dict):
        return out
    for joint, per in checks.items():
        if not isinstance(per, dict):
            continue
        verdicts = [c.get("verdict") for c in per.values() if isinstance(c, dict)]
        out[(joint, "fails")] = float(verdicts.count("fail"))
        out[(joint, "unknowns")] = float(verdicts.count("unknown"))
        for name, c in per.items():
            v = c.get("value") if isinstance(c, dict) else None
            if isinstance(v, int | float) and not isinstance(v, bool) and math.isfinite(v):
                out[(joint, f"check_{name}")] = float(v)
    return out


def result_metrics(doc: dict[str, Any], res) -> dict[tuple[str, str], float]:
    """The indexed metrics of a result: (joint, metric) -> value, and (``*``, metric)
    the largest over the joints (SI units: :data:`manipcad.workspace.where.METRICS`).

    Values that are nan or missing are left out.
    """
    out: dict[tuple[str, str], float] = {}
    names = list(res.joint_names)
    per = doc.get("metrics", {}) or {}
    with np.errstate(invalid="ignore"):
        extra = {
            "peak_torque": np.nanmax(np.abs(res.tau), axis=0) if len(res.t) else None,
            "rms_torque": np.sqrt(np.nanmean(res.tau**2, axis=0)) if len(res.t) else None,
            "peak_power": (np.nanmax(np.abs(res.tau * res.qd), axis=0)
                           if len(res.t) else None),
        }
        cur = np.asarray(res.current, dtype=float)
        if len(res.t) and np.isfinite(cur).any():
            extra["peak_current"] = np.nanmax(np.abs(cur), axis=0)
            extra["rms_current"] = np.sqrt(np.nanmean(cur**2, axis=0))
    for j, name in enumerate(names):
        for metric, value in (per.get(name) or {}).items():
            if isinstance(value, int | float) and not isinstance(value, bool) \
                    and math.isfinite(value):
                out[(name, metric)] = float(value)
        for metric, arr in extra.items():
            if arr is not None and math.isfinite(float(arr[j])):
                out[(name, metric)] = float(arr[j])
    out.update(check_metrics(doc.get("checks")))
    metrics = {m for (_, m) in out}
    for m in metrics:
        vals = [v for (j, mm), v in out.items() if mm == m]
        out[("*", m)] = max(vals)
    out[("*", "samples")] = float(len(res.t))
    if len(res.t):
        out[("*", "t_final")] = float(res.t[-1])
    return out
