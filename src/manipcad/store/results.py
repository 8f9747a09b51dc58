"""The results store: one folder per simulation run, written all at once or not at all.

``save_result(result, DIR, inputs=...)`` writes::

    DIR/inputs/           copies of the files the run used (robot, trajectory,
                          regulators), or YAML dumps of in-memory inputs
    DIR/timeseries.npz    t and, per joint, q, qd, q_ref, qd_ref, error, u,
                          current, tau at full precision (float64), compressed
                          (``load_result``); units in ``metrics.json``
    DIR/timeseries.csv    the same as text with units in the header
                          ("waist.q [rad]"); only with ``csv=True`` (the
                          workspace writes it on export, :func:`write_csv`)
    DIR/metrics.json      status, robot, settings, per-joint metrics and their units, and the
                          run checks {joint: {check: {value, limit, unit, verdict}}} when
                          made (docs/checks.md)
    DIR/errors.png        the tracking errors over time, one panel per joint

How much is stored is set by the run's ``every`` (see
:func:`every_for`: the regulators' sampling period by default).

Atomicity: the folder is written by :func:`manipcad.folders.write_folder`: into a
hidden sibling folder, flushed, then installed as DIR in one step (a rename, or an
exchange of the two folders); a writer killed at any moment leaves DIR complete (old or
new), and the next save removes what it left. Ctrl-C after the new result is in place
raises :class:`~manipcad.folders.SaveInterrupted`, which says so. A DIR that exists and
is not empty is refused unless ``force=True``, and ``force`` replaces only a result
folder (one with ``metrics.json``).
"""

from __future__ import annotations

import json
import math
import shutil
import zipfile
import zlib
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.errors import InputError
from manipcad.fileio import atomic_write, dump_yaml, json_safe
from manipcad.folders import clean_stale, write_folder
from manipcad.model.tree_file import save_robot
from manipcad.report.plots import plot_errors
from manipcad.sim.result import SimulationResult
from manipcad.sim.series import SERIES, result_arrays, series_columns, series_units  # noqa: F401
from manipcad.version import __version__

#: file names inside a result folder
TIMESERIES_CSV = "timeseries.csv"
TIMESERIES_NPZ = "timeseries.npz"
METRICS_JSON = "metrics.json"
ERRORS_PNG = "errors.png"
INPUTS_DIR = "inputs"


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
        InputError: it is a file, a non-empty folder without ``force``, or, with
            ``force``, a non-empty folder that is not a manipcad result (no
            ``metrics.json``): a user's folder is never replaced.
    """
    out = Path(out_dir)
    if out.exists() or out.is_symlink():
        if not out.is_dir():
            raise InputError(str(out), "", "exists and is not a folder")
        if any(out.iterdir()):
            if not force:
                raise InputError(str(out), "", "folder exists and is not empty; use --force "
                                 "(force=True) to replace it")
            if not (out / METRICS_JSON).is_file():
                raise InputError(str(out), "", f"not a manipcad result folder (no "
                                 f"{METRICS_JSON}); --force replaces only a result: choose "
                                 "another folder, or empty or remove this one yourself")
    return out


def result_document(result, *, joint_types: Sequence[str] | None = None,
                    status: str = "ok", message: str = "",
                    inputs: Mapping[str, Any] | None = None,
                    run: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The metrics.json document of a result (also what ``manipcad simulate --json`` prints)."""
    drives = bool(result.settings.get("drives", True))
    names = list(result.joint_names)
    types = list(joint_types) if joint_types is not None else [None] * len(names)
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
    if getattr(result, "checks", None):
        doc["checks"] = result.checks
    if run:
        doc["run"] = dict(run)
    if inputs:
        doc["inputs"] = {k: _describe_input(k, v) for k, v in inputs.items()}
    doc["manipcad_version"] = __version__
    doc["created"] = datetime.now(UTC).isoformat(timespec="seconds")
    return jsonable(doc)


def _describe_input(key: str, v: Any) -> Any:
    """What metrics.json says of an input: a file's path as given, a robot object by its
    name and stored file (never a temporary file that is gone after the run)."""
    if isinstance(v, str | Path):
        return str(v)
    if isinstance(v, list | tuple) and all(isinstance(x, str | Path) for x in v):
        return [str(x) for x in v]
    if _is_robot(v):
        return f"{INPUTS_DIR}/{key}.yaml (the robot {v.name!r} as it ran)"
    return f"<{type(v).__name__}> (dumped to {INPUTS_DIR}/)"


def _is_robot(v: Any) -> bool:
    """A :class:`manipcad.model.Robot` (told by its fields: this layer names no class
    of the model)."""
    return all(hasattr(v, a) for a in ("joint_types", "drives", "joint_names", "table"))


def every_for(dt: float, periods: Sequence[float] = ()) -> int:
    """Record stride for a run: one sample per regulator period (the shortest one).

    Args:
        dt: the integration step, s (> 0).
        periods: the regulators' sampling periods, s (multiples of ``dt``).

    Returns:
        The number of steps between stored samples (>= 1): the largest step
        count that divides every period (so every regulator update is
        stored); 1 without regulators.

    Example:
        >>> every_for(1e-4, [1e-3, 5e-4])
        5
        >>> every_for(1e-4)
        1
    """

    steps = [int(round(float(p) / dt)) for p in periods]
    steps = [k for k in steps if k >= 1]
    return max(1, math.gcd(*steps)) if steps else 1


def save_result(result, out_dir: str | Path, *, inputs: Mapping[str, Any] | None = None,
                joint_types: Sequence[str] | None = None, force: bool = False,
                status: str = "ok", message: str = "",
                run: Mapping[str, Any] | None = None, plot: bool = True,
                csv: bool = True, extra: Mapping[str, Any] | None = None) -> Path:
    """Write a simulation result to a folder, atomically (see the module docstring).

    Args:
        result: a :class:`manipcad.sim.SimulationResult` (a diverged run's
            partial ``.result`` too: pass ``status="diverged"`` and the message).
        out_dir: the result folder; created with its parents if needed.
        inputs: what the run used, copied into ``DIR/inputs/``: name -> a file
            path (copied as ``name`` + its suffix), a list of file paths
            (``name-1``, ``name-2``, ...), a :class:`~manipcad.model.Robot` (saved
            in its self-contained tree form as ``name.yaml``; metrics.json names it
            so), a mapping (dumped as ``name.yaml``) or an object with ``to_dict()``
            (a trajectory; dumped likewise).
        joint_types: "revolute"/"prismatic" per joint (``robot.joint_types``),
            for the units in the header and the plot; None: "rad|m".
        force: replace a non-empty existing folder (only once the new one is complete).
        status: "ok" or "diverged", recorded in metrics.json.
        message: the divergence message, recorded in metrics.json.
        run: extra facts of the run (command-line settings) for metrics.json.
        plot: also write errors.png.
        csv: also write timeseries.csv (text, units in the header).
        extra: more JSON files to write in the folder: file name -> document.

    Returns:
        The result folder.

    Raises:
        InputError: the folder is a file or is not empty (without ``force``),
            an input file cannot be read, or the disk refuses the write.
        manipcad.folders.SaveInterrupted: Ctrl-C after the new result was installed (it is
            complete).

    Example:
        >>> import manipcad
        >>> from manipcad.sim import simulate
        >>> from manipcad.store import save_result
        >>> arm = manipcad.load_robot("cylindrical")  # doctest: +SKIP
        >>> res = simulate(arm, t_end=0.1, dt=1e-3, drives=False)  # doctest: +SKIP
        >>> save_result(res, "/tmp/run1", joint_types=arm.joint_types, force=True)  # doctest: +SKIP
        PosixPath('/tmp/run1')
    """
    out = Path(out_dir)
    parent = out.parent if str(out.parent) else Path(".")
    if parent.is_dir():
        clean_stale(parent, out.name)
    check_out_dir(out, force=force)
    try:
        parent.mkdir(parents=True, exist_ok=True)
    except OSError as exc:
        raise InputError(str(out), "", f"cannot create the folder: {exc.strerror or exc}") from None
    with write_folder(out, force=force) as tmp:
        _write_all(tmp, result, inputs or {}, joint_types, status, message, run, plot, csv,
                   extra or {})
    return out


def _write_all(tmp: Path, result, inputs: Mapping[str, Any], joint_types, status: str,
               message: str, run, plot: bool, csv: bool, extra: Mapping[str, Any]) -> None:
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

    # time series: the npz at full precision, compressed; the CSV on request
    arrays = result_arrays(result)
    np.savez_compressed(tmp / TIMESERIES_NPZ, joint_names=np.array(names), **arrays)
    if csv:
        write_csv(result, tmp / TIMESERIES_CSV, joint_types=joint_types)

    # metrics
    doc = result_document(result, joint_types=joint_types, status=status, message=message,
                          inputs=inputs, run=run)
    (tmp / METRICS_JSON).write_text(json.dumps(doc, indent=2) + "\n", encoding="utf-8")
    for fname, document in extra.items():
        if Path(fname).name != fname:
            raise InputError("extra", fname, "must be a plain file name")
        (tmp / fname).write_text(json.dumps(jsonable(document), indent=2) + "\n",
                                 encoding="utf-8")

    if plot:

        title = None
        if status != "ok":
            title = f"{result.robot or 'robot'}: tracking error q_ref - q ({status})"
        plot_errors(result, tmp / ERRORS_PNG, joint_types=joint_types, title=title)


def write_csv(result, path: str | Path, *, joint_types: Sequence[str] | None = None) -> Path:
    """Write a result's time series as CSV: ``t [s]`` then, per joint, each of
    :data:`SERIES` with its unit in the header ("waist.q [rad]"), 10 significant digits.

    Args:
        result: a :class:`manipcad.sim.SimulationResult`.
        path: the CSV file to write (replaced atomically).
        joint_types: "revolute"/"prismatic" per joint for the units; None: "rad|m".

    Returns:
        The path written.
    """

    columns = series_columns(result, joint_types)
    header = [h for h, _ in columns]
    table = np.column_stack([a for _, a in columns])

    def write(fh) -> None:
        fh.write(",".join(header) + "\n")
        np.savetxt(fh, table, delimiter=",", fmt="%.10g")

    return atomic_write(path, write)


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
    if _is_robot(value):           # its self-contained tree form, which loads back identical
        save_robot(value, folder / f"{key}.yaml")
        return
    if hasattr(value, "to_dict"):
        value = value.to_dict()
    if isinstance(value, Mapping):
        text = dump_yaml(jsonable(value), sort_keys=False, default_flow_style=None,
                              width=100, allow_unicode=True)
        (folder / f"{key}.yaml").write_text(text, encoding="utf-8")
        return
    raise InputError("inputs", key, f"expected a file path, a mapping or an object with "
                     f"to_dict(), got {type(value).__name__}")


# --------------------------------------------------------------------------- reading


def load_result(out_dir: str | Path):
    """Read back a result folder written by :func:`save_result`.

    Args:
        out_dir: the result folder.

    Returns:
        (result, document): a :class:`manipcad.sim.SimulationResult` with the
        stored arrays, settings and metrics, and the metrics.json document.

    Raises:
        InputError: naming the file and what is wrong: missing, truncated or
            not an npz archive, an array missing or of the wrong shape, JSON
            that does not parse.
    """

    out = Path(out_dir)
    if not out.is_dir():
        raise InputError(str(out), "", "no such result folder" if not out.exists()
                         else "is not a folder (a manipcad result is a folder)")
    npz, meta = out / TIMESERIES_NPZ, out / METRICS_JSON
    for f in (npz, meta):
        if not f.is_file():
            raise InputError(str(f), "", "no such file (not a manipcad result folder?)")
    try:
        doc = json.loads(meta.read_text(encoding="utf-8"))
    except (OSError, ValueError) as exc:
        raise InputError(str(meta), "", f"cannot read the metrics document: {exc}") from None
    if not isinstance(doc, dict):
        raise InputError(str(meta), "", "expected a JSON object")
    arrays = _read_npz(npz)
    res = SimulationResult(
        t=arrays["t"], q=arrays["q"], qd=arrays["qd"], q_ref=arrays["q_ref"],
        qd_ref=arrays["qd_ref"], u=arrays["u"], current=arrays["current"], tau=arrays["tau"],
        joint_names=tuple(str(s) for s in arrays["joint_names"]), robot=doc.get("robot", ""),
        settings=doc.get("settings", {}), metrics=doc.get("metrics", {}),
        checks=doc.get("checks") if isinstance(doc.get("checks"), dict) else None)
    return res, doc


def _read_npz(npz: Path) -> dict[str, np.ndarray]:
    """The arrays of timeseries.npz, checked: all present, float (K,) / (K, n)."""
    src = str(npz)
    try:
        with np.load(npz, allow_pickle=False) as data:
            missing = [k for k in ("joint_names", "t", *SERIES) if k not in data.files]
            if missing:
                raise InputError(src, missing[0], "array missing from the archive"
                                 + (f" (also {', '.join(missing[1:])})" if missing[1:] else ""))
            arrays = {k: data[k] for k in ("joint_names", "t", *SERIES)}
    except InputError:
        raise
    except (zipfile.BadZipFile, EOFError) as exc:
        raise InputError(src, "", f"truncated or not an npz archive ({exc})") from None
    except (OSError, ValueError, KeyError, zlib.error) as exc:
        raise InputError(src, "", f"corrupt archive: {type(exc).__name__}: {exc}") from None
    names = arrays["joint_names"]
    if names.ndim != 1:
        raise InputError(src, "joint_names", f"expected a 1-D array, got shape {names.shape}")
    k, n = arrays["t"].shape[0] if arrays["t"].ndim == 1 else -1, names.shape[0]
    if k < 0:
        raise InputError(src, "t", f"expected a 1-D array, got shape {arrays['t'].shape}")
    for s in SERIES:
        a = arrays[s]
        if a.shape != (k, n):
            raise InputError(src, s, f"has shape {a.shape}, expected ({k}, {n}) "
                             "(samples, joints)")
        if a.dtype.kind != "f":
            raise InputError(src, s, f"has dtype {a.dtype}, expected float")
    return arrays


__all__ = ["save_result", "load_result", "check_out_dir", "result_document", "series_units",
           "metric_units", "SERIES", "jsonable", "write_csv", "every_for", "result_arrays",
           "series_columns"]
