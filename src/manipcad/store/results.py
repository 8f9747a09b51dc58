"""The results store: one folder per simulation run, written all at once or not at all.

``save_result(result, DIR, inputs=...)`` writes::

    DIR/inputs/           copies of the files the run used (robot, trajectory,
                          regulators), or YAML dumps of in-memory inputs
    DIR/timeseries.csv    t and, per joint, q, qd, q_ref, qd_ref, error, u,
                          current, tau; units in the header ("waist.q [rad]")
    DIR/timeseries.npz    the same arrays at full precision (``load_result``)
    DIR/metrics.json      status, robot, settings, per-joint metrics and their units
    DIR/errors.png        the tracking errors over time, one panel per joint

Atomicity: everything is written into a hidden temporary sibling folder
(``.DIR.partial-XXXX``), flushed to disk, and renamed to DIR only when
complete. An interrupted or failed save removes the temporary folder and
leaves DIR as it was. A DIR that exists and is not empty is refused unless
``force=True``; then the old DIR is moved aside, the new one renamed in, and
the old one deleted (moved back if the rename fails), so DIR is never a mix of
two runs.
"""

from __future__ import annotations

import json
import os
import shutil
import tempfile
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from manipcad.errors import InputError
from manipcad.fileio import json_safe

#: the arrays of a result kept in the store, in column order per joint
SERIES = ("q", "qd", "q_ref", "qd_ref", "error", "u", "current", "tau")

#: file names inside a result folder
TIMESERIES_CSV = "timeseries.csv"
TIMESERIES_NPZ = "timeseries.npz"
METRICS_JSON = "metrics.json"
ERRORS_PNG = "errors.png"
INPUTS_DIR = "inputs"


def series_units(joint_type: str | None, drives: bool) -> dict[str, str]:
    """SI unit of each stored quantity of one joint.

    Args:
        joint_type: "revolute", "prismatic" or None (unknown: "rad|m" etc.).
        drives: whether the run had drive models (then u is a voltage).

    Example:
        >>> series_units("prismatic", True)["tau"]
        'N'
    """
    pos, vel, force = {"revolute": ("rad", "rad/s", "N·m"),
                       "prismatic": ("m", "m/s", "N")}.get(
        joint_type or "", ("rad|m", "rad/s|m/s", "N·m|N"))
    return {"q": pos, "qd": vel, "q_ref": pos, "qd_ref": vel, "error": pos,
            "u": "V" if drives else force, "current": "A", "tau": force}


def metric_units(joint_type: str | None, drives: bool) -> dict[str, str]:
    """SI unit of each per-joint metric of :func:`manipcad.sim.metrics.joint_metrics`."""
    s = series_units(joint_type, drives)
    return {"max_error": s["q"], "rms_error": s["q"], "overshoot": "1 (fraction of the step)",
            "rise_time": "s", "settling_time": "s", "effort_rms": s["u"], "energy": "J"}


#: JSON-ready values (nan -> null, ±inf -> "inf"/"-inf"); see :func:`manipcad.fileio.json_safe`
jsonable = json_safe


def check_out_dir(out_dir: str | Path, *, force: bool = False) -> Path:
    """Check that a result folder may be written (before spending time on a run).

    Args:
        out_dir: the result folder.
        force: allow replacing a non-empty folder.

    Returns:
        The folder as a :class:`Path`.

    Raises:
        InputError: it is a file, or a non-empty folder without ``force``.
    """
    out = Path(out_dir)
    if out.exists() or out.is_symlink():
        if not out.is_dir():
            raise InputError(str(out), "", "exists and is not a folder")
        if any(out.iterdir()) and not force:
            raise InputError(str(out), "", "folder exists and is not empty; use --force "
                             "(force=True) to replace it")
    return out


def result_document(result, *, joint_types: Sequence[str] | None = None,
                    status: str = "ok", message: str = "",
                    inputs: Mapping[str, Any] | None = None,
                    run: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The metrics.json document of a result (also what ``manipcad simulate --json`` prints)."""
    drives = bool(result.settings.get("drives", True))
    names = list(result.joint_names)
    types = list(joint_types) if joint_types is not None else [None] * len(names)
    from manipcad import __version__

    doc: dict[str, Any] = {
        "status": status,
        "robot": result.robot,
        "joints": names,
        "joint_types": list(joint_types) if joint_types is not None else None,
        "t_final": float(result.t[-1]) if len(result.t) else None,
        "samples": len(result.t),
        "settings": dict(result.settings),
        "metrics": result.metrics,
        "units": {name: metric_units(jt, drives) for name, jt in zip(names, types, strict=True)},
    }
    if message:
        doc["message"] = message
    if run:
        doc["run"] = dict(run)
    if inputs:
        doc["inputs"] = {k: _describe_input(v) for k, v in inputs.items()}
    doc["manipcad_version"] = __version__
    doc["created"] = datetime.now(UTC).isoformat(timespec="seconds")
    return jsonable(doc)


def _describe_input(v: Any) -> Any:
    if isinstance(v, str | Path):
        return str(v)
    if isinstance(v, list | tuple) and all(isinstance(x, str | Path) for x in v):
        return [str(x) for x in v]
    return f"<{type(v).__name__}> (dumped to {INPUTS_DIR}/)"


def save_result(result, out_dir: str | Path, *, inputs: Mapping[str, Any] | None = None,
                joint_types: Sequence[str] | None = None, force: bool = False,
                status: str = "ok", message: str = "",
                run: Mapping[str, Any] | None = None, plot: bool = True) -> Path:
    """Write a simulation result to a folder, atomically (see the module docstring).

    Args:
        result: a :class:`manipcad.sim.SimulationResult` (a diverged run's
            partial ``.result`` too: pass ``status="diverged"`` and the message).
        out_dir: the result folder; created with its parents if needed.
        inputs: what the run used, copied into ``DIR/inputs/``: name -> a file
            path (copied as ``name`` + its suffix), a list of file paths
            (``name-1``, ``name-2``, ...), a mapping (dumped as ``name.yaml``)
            or an object with ``to_dict()`` (a trajectory; dumped likewise).
        joint_types: "revolute"/"prismatic" per joint (``robot.joint_types``),
            for the units in the header and the plot; None: "rad|m".
        force: replace a non-empty existing folder (only once the new one is complete).
        status: "ok" or "diverged", recorded in metrics.json.
        message: the divergence message, recorded in metrics.json.
        run: extra facts of the run (command-line settings) for metrics.json.
        plot: also write errors.png.

    Returns:
        The result folder.

    Raises:
        InputError: the folder is a file or is not empty (without ``force``),
            an input file cannot be read, or the disk refuses the write.

    Example:
        >>> import manipcad
        >>> from manipcad.sim import simulate
        >>> from manipcad.store import save_result
        >>> arm = manipcad.load_robot("cylindrical")  # doctest: +SKIP
        >>> res = simulate(arm, t_end=0.1, dt=1e-3, drives=False)  # doctest: +SKIP
        >>> save_result(res, "/tmp/run1", joint_types=arm.joint_types, force=True)  # doctest: +SKIP
        PosixPath('/tmp/run1')
    """
    out = check_out_dir(out_dir, force=force)
    parent = out.parent if str(out.parent) else Path(".")
    try:
        parent.mkdir(parents=True, exist_ok=True)
        tmp = Path(tempfile.mkdtemp(prefix=f".{out.name}.partial-", dir=parent))
    except OSError as exc:
        raise InputError(str(out), "", f"cannot create the folder: {exc.strerror or exc}") from None
    try:
        _write_all(tmp, result, inputs or {}, joint_types, status, message, run, plot)
        _install(tmp, out, force)
    except BaseException as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if isinstance(exc, OSError):
            raise InputError(str(out), "", f"cannot write the result: "
                             f"{exc.strerror or exc}") from None
        raise
    return out


def _write_all(tmp: Path, result, inputs: Mapping[str, Any], joint_types, status: str,
               message: str, run, plot: bool) -> None:
    drives = bool(result.settings.get("drives", True))
    names = list(result.joint_names)
    n = len(names)
    types = list(joint_types) if joint_types is not None else [None] * n
    if len(types) != n:
        raise InputError("joint_types", "", f"{len(types)} entries for {n} joints")

    # inputs
    folder = tmp / INPUTS_DIR
    folder.mkdir()
    for key, value in inputs.items():
        _write_input(folder, key, value)

    # time series: the npz at full precision, the CSV for people and spreadsheets
    arrays = {"t": np.asarray(result.t, dtype=float)}
    for name in SERIES:
        arrays[name] = np.asarray(getattr(result, name), dtype=float)
    np.savez(tmp / TIMESERIES_NPZ, joint_names=np.array(names), **arrays)
    header = ["t [s]"]
    cols = [arrays["t"][:, None]]
    for j, (name, jt) in enumerate(zip(names, types, strict=True)):
        units = series_units(jt, drives)
        for s in SERIES:
            header.append(f"{name}.{s} [{units[s]}]")
            cols.append(arrays[s][:, j:j + 1])
    table = np.hstack(cols) if len(arrays["t"]) else np.empty((0, len(header)))
    with open(tmp / TIMESERIES_CSV, "w", encoding="utf-8", newline="") as fh:
        fh.write(",".join(header) + "\n")
        np.savetxt(fh, table, delimiter=",", fmt="%.10g")

    # metrics
    doc = result_document(result, joint_types=joint_types, status=status, message=message,
                          inputs=inputs, run=run)
    (tmp / METRICS_JSON).write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")

    if plot:
        from manipcad.report.plots import plot_errors

        title = None
        if status != "ok":
            title = f"{result.robot or 'robot'}: tracking error q_ref - q ({status})"
        plot_errors(result, tmp / ERRORS_PNG, joint_types=joint_types, title=title)

    _fsync_tree(tmp)


def _write_input(folder: Path, key: str, value: Any) -> None:
    if isinstance(value, list | tuple) and value and all(isinstance(v, str | Path)
                                                         for v in value):
        if len(value) == 1:
            _write_input(folder, key, value[0])
            return
        for k, v in enumerate(value, start=1):
            _write_input(folder, f"{key}-{k}", v)
        return
    if isinstance(value, str | Path):
        src = Path(value)
        if not src.is_file():
            raise InputError(str(src), "", f"input {key!r} is not a readable file")
        shutil.copyfile(src, folder / f"{key}{src.suffix}")
        return
    if hasattr(value, "to_dict"):
        value = value.to_dict()
    if isinstance(value, Mapping):
        text = yaml.safe_dump(jsonable(value), sort_keys=False, default_flow_style=None,
                              width=100, allow_unicode=True)
        (folder / f"{key}.yaml").write_text(text, encoding="utf-8")
        return
    raise InputError("inputs", key, f"expected a file path, a mapping or an object with "
                     f"to_dict(), got {type(value).__name__}")


def _fsync_tree(root: Path) -> None:
    for dirpath, _dirs, files in os.walk(root):
        for f in files:
            fd = os.open(os.path.join(dirpath, f), os.O_RDONLY)
            try:
                os.fsync(fd)
            finally:
                os.close(fd)
    try:
        fd = os.open(root, os.O_RDONLY)
    except OSError:
        return
    try:
        os.fsync(fd)
    finally:
        os.close(fd)


def _install(tmp: Path, out: Path, force: bool) -> None:
    """Rename the complete temporary folder to ``out``; replace a non-empty one only if forced."""
    os.chmod(tmp, 0o755)
    if not out.exists():
        os.rename(tmp, out)
        return
    if not out.is_dir():
        raise InputError(str(out), "", "exists and is not a folder")
    if not any(out.iterdir()):
        os.replace(tmp, out)  # POSIX rename may replace an empty folder
        return
    if not force:
        raise InputError(str(out), "", "folder exists and is not empty; use --force "
                         "(force=True) to replace it")
    old = Path(tempfile.mkdtemp(prefix=f".{out.name}.old-", dir=out.parent))
    os.rmdir(old)
    os.rename(out, old)
    try:
        os.rename(tmp, out)
    except BaseException:
        os.rename(old, out)
        raise
    shutil.rmtree(old, ignore_errors=True)


def load_result(out_dir: str | Path):
    """Read back a result folder written by :func:`save_result`.

    Returns:
        (result, document): a :class:`manipcad.sim.SimulationResult` with the
        stored arrays, settings and metrics, and the metrics.json document.

    Raises:
        InputError: the folder or one of its files is missing or unreadable.
    """
    from manipcad.sim.simulate import SimulationResult

    out = Path(out_dir)
    npz, meta = out / TIMESERIES_NPZ, out / METRICS_JSON
    for f in (npz, meta):
        if not f.is_file():
            raise InputError(str(f), "", "no such file (not a manipcad result folder?)")
    try:
        doc = json.loads(meta.read_text(encoding="utf-8"))
        with np.load(npz) as data:
            arrays = {k: data[k] for k in data.files}
    except (OSError, ValueError) as exc:
        raise InputError(str(out), "", f"cannot read the result: {exc}") from None
    res = SimulationResult(
        t=arrays["t"], q=arrays["q"], qd=arrays["qd"], q_ref=arrays["q_ref"],
        qd_ref=arrays["qd_ref"], u=arrays["u"], current=arrays["current"], tau=arrays["tau"],
        joint_names=tuple(str(s) for s in arrays["joint_names"]), robot=doc.get("robot", ""),
        settings=doc.get("settings", {}), metrics=doc.get("metrics", {}))
    return res, doc


__all__ = ["save_result", "load_result", "check_out_dir", "result_document", "series_units",
           "metric_units", "SERIES", "jsonable"]
