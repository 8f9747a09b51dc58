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

How much is stored is set by the run's ``record_every`` (see
:func:`record_every_for`: the regulators' sampling period by default).

Atomicity: everything is written into a hidden temporary sibling folder
(``.DIR.partial-PID-XXXX``), flushed to disk, and only then installed as DIR:

- DIR absent: one ``rename``.
- DIR present (``force=True``): one ``renameat2(RENAME_EXCHANGE)`` (Linux,
  through ctypes) swaps the two folders in a single step, so DIR is at every
  instant either the old result or the new one; the old one, now under the
  temporary name, is then deleted.
- Where the exchange is not available (other systems, some file systems), DIR
  is a symbolic link to a versioned folder ``.DIR.v-PID-XXXX`` beside it and
  the link is replaced atomically (``rename`` of a new link over it). An
  existing real folder is replaced there by two renames through
  ``.DIR.old-PID-XXXX``; a writer killed between them leaves DIR missing and
  the next save (or :func:`clean_stale`) renames the old folder back.

A writer killed at any moment (SIGKILL, SIGTERM) leaves DIR complete (old or
new) and at worst a hidden ``.DIR.partial-*``/``.DIR.old-*``/``.DIR.v-*``
folder; each name holds the writer's process id, and :func:`clean_stale`
(called by every save into the same folder) removes those of dead writers
(and versions older than the one the link points to, whoever made them).
An interrupted (Ctrl-C) or failed save removes its temporary folder and leaves
DIR as it was; Ctrl-C after the new result is in place raises
:class:`SaveInterrupted`, which says so. A DIR that exists and is not empty is
refused unless ``force=True``.
"""

from __future__ import annotations

import contextlib
import json
import os
import re
import shutil
import tempfile
import zipfile
import zlib
from collections.abc import Mapping, Sequence
from datetime import UTC, datetime
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.errors import InputError
from manipcad.fileio import dump_yaml, fsync_tree, json_safe
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


class SaveInterrupted(KeyboardInterrupt):
    """Ctrl-C arrived after the new result was installed: the save is complete.

    The message says where the result is; the old copy still being deleted is
    removed by the next save (:func:`clean_stale`).
    """

    def __str__(self) -> str:  # KeyboardInterrupt prints nothing by default
        return str(self.args[0]) if self.args else "interrupted"


def record_every_for(dt: float, periods: Sequence[float] = ()) -> int:
    """Record stride for a run: one sample per regulator period (the shortest one).

    Args:
        dt: the integration step, s (> 0).
        periods: the regulators' sampling periods, s (multiples of ``dt``).

    Returns:
        The number of steps between stored samples (>= 1): the largest step
        count that divides every period (so every regulator update is
        stored); 1 without regulators.

    Example:
        >>> record_every_for(1e-4, [1e-3, 5e-4])
        5
        >>> record_every_for(1e-4)
        1
    """
    import math

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
            (``name-1``, ``name-2``, ...), a mapping (dumped as ``name.yaml``)
            or an object with ``to_dict()`` (a trajectory; dumped likewise).
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
        SaveInterrupted: Ctrl-C after the new result was installed (it is complete).

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
        tmp = _temp_dir(parent, out.name, "partial")
    except OSError as exc:
        raise InputError(str(out), "", f"cannot create the folder: {exc.strerror or exc}") from None
    with _discard_on_failure(tmp, out, "write"):
        _write_all(tmp, result, inputs or {}, joint_types, status, message, run, plot, csv,
                   extra or {})
    install_folder(tmp, out, force=force)
    return out


def install_folder(tmp: str | Path, out: str | Path, *, force: bool = False) -> Path:
    """Install a complete folder ``tmp`` as ``out`` atomically (the module docstring's steps).

    ``tmp`` must be a sibling of ``out`` (same file system). On failure or
    Ctrl-C before the new folder is in place, ``tmp`` is deleted and ``out``
    is left as it was.

    Args:
        tmp: the complete new folder (e.g. made by :func:`temp_dir`).
        out: the target folder (or link, in the versioned layout).
        force: replace a non-empty existing ``out``.

    Returns:
        ``out``.

    Raises:
        InputError: ``out`` is a file, or a non-empty folder without ``force``,
            or the disk refuses the rename.
        SaveInterrupted: Ctrl-C after the new folder was installed.
    """
    tmp, out = Path(tmp), Path(out)
    with _discard_on_failure(tmp, out, "install"):
        old = _install(tmp, out, force)
    if old is not None:
        try:
            _remove(old)
        except KeyboardInterrupt:
            raise SaveInterrupted(f"interrupted after the new result was saved in {out}; "
                                  f"the old copy {old.name} is removed on the next save") from None
    return out


@contextlib.contextmanager
def _discard_on_failure(tmp: Path, out: Path, step: str):
    """Delete ``tmp`` if the block fails or is interrupted; OSError -> InputError on ``out``."""
    try:
        yield
    except BaseException as exc:
        shutil.rmtree(tmp, ignore_errors=True)
        if isinstance(exc, OSError):
            raise InputError(str(out), "", f"cannot {step} the result: "
                             f"{exc.strerror or exc}") from None
        raise


def _temp_dir(parent: Path, name: str, tag: str) -> Path:
    """A new hidden sibling folder ``.NAME.TAG-PID-XXXX`` (mode 0o755)."""
    tmp = Path(tempfile.mkdtemp(prefix=f".{name}.{tag}-{os.getpid()}-", dir=parent))
    os.chmod(tmp, 0o755)
    return tmp


def temp_dir(out: str | Path) -> Path:
    """A new temporary folder beside ``out`` to build its next content in (see
    :func:`install_folder`); its name marks it as this process's, so
    :func:`clean_stale` removes it if the process dies."""
    out = Path(out)
    parent = out.parent if str(out.parent) else Path(".")
    parent.mkdir(parents=True, exist_ok=True)
    return _temp_dir(parent, out.name, "partial")


def _remove(path: Path) -> None:
    if path.is_symlink() or path.is_file():
        path.unlink(missing_ok=True)
    else:
        shutil.rmtree(path, ignore_errors=True)


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
        from manipcad.report.plots import plot_errors

        title = None
        if status != "ok":
            title = f"{result.robot or 'robot'}: tracking error q_ref - q ({status})"
        plot_errors(result, tmp / ERRORS_PNG, joint_types=joint_types, title=title)

    fsync_tree(tmp)


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
    from manipcad.fileio import atomic_write

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
    if hasattr(value, "to_dict"):
        value = value.to_dict()
    if isinstance(value, Mapping):
        text = dump_yaml(jsonable(value), sort_keys=False, default_flow_style=None,
                              width=100, allow_unicode=True)
        (folder / f"{key}.yaml").write_text(text, encoding="utf-8")
        return
    raise InputError("inputs", key, f"expected a file path, a mapping or an object with "
                     f"to_dict(), got {type(value).__name__}")


# --------------------------------------------------------------------------- swapping

_EXCHANGE_OFF = os.environ.get("MANIPCAD_NO_RENAME_EXCHANGE", "") not in ("", "0")


def exchange(a: str | Path, b: str | Path) -> bool:
    """Swap two existing paths in one atomic step (``renameat2(RENAME_EXCHANGE)``,
    :func:`manipcad.fileio.exchange_paths`); off when ``MANIPCAD_NO_RENAME_EXCHANGE``
    is set (to exercise the versioned-link fallback).

    Returns:
        True when swapped; False when the platform or file system has no such
        call (then nothing changed). Other failures raise :class:`OSError`.
    """
    if _EXCHANGE_OFF:
        return False
    from manipcad.fileio import exchange_paths

    return exchange_paths(a, b)


def _install(tmp: Path, out: Path, force: bool) -> Path | None:
    """Install ``tmp`` as ``out``; return what is left to delete (the old copy) or None."""
    if out.is_symlink():  # the versioned layout: replace the link atomically
        if not force and any(out.iterdir()):
            raise InputError(str(out), "", "folder exists and is not empty; use --force "
                             "(force=True) to replace it")
        return _relink(tmp, out)
    if not out.exists():
        if exchange_supported(out.parent):
            os.rename(tmp, out)
            return None
        return _relink(tmp, out)
    if not out.is_dir():
        raise InputError(str(out), "", "exists and is not a folder")
    if not any(out.iterdir()):
        os.replace(tmp, out)  # POSIX rename may replace an empty folder
        return None
    if not force:
        raise InputError(str(out), "", "folder exists and is not empty; use --force "
                         "(force=True) to replace it")
    if exchange(tmp, out):
        return tmp  # now holds the old result
    # no exchange: two renames; a kill between them is repaired by clean_stale
    old = _temp_dir(out.parent, out.name, "old")
    os.rmdir(old)
    os.rename(out, old)
    try:
        os.rename(tmp, out)
    except BaseException:
        os.rename(old, out)
        raise
    return old


def _relink(tmp: Path, out: Path) -> Path | None:
    """The versioned layout: rename ``tmp`` to ``.NAME.v-PID-X`` and point the link at it."""
    version = _temp_dir(out.parent, out.name, "v")
    os.rmdir(version)
    os.rename(tmp, version)
    link = out.parent / f".{out.name}.link-{os.getpid()}-{version.name[-8:]}"
    try:
        os.symlink(version.name, link)
        previous = out.resolve() if out.is_symlink() else None
        os.replace(link, out)
    except BaseException:
        # an interrupt (SIGINT) can land after the replace returned, still in this
        # block: the link then already points at the new version, which must stay
        if not (out.is_symlink() and out.resolve() == version.resolve()):
            link.unlink(missing_ok=True)
            os.rename(version, tmp)
        raise
    if previous is not None and previous != version.resolve() and previous.parent == out.parent:
        return previous
    return None


def exchange_supported(folder: str | Path) -> bool:
    """Whether :func:`exchange` works in ``folder`` (tried once on two empty folders)."""
    folder = Path(folder)
    key = str(folder.resolve())
    if key not in _SUPPORTED:
        a = b = None
        try:
            a = Path(tempfile.mkdtemp(prefix=f".probe.partial-{os.getpid()}-", dir=folder))
            b = Path(tempfile.mkdtemp(prefix=f".probe.partial-{os.getpid()}-", dir=folder))
            _SUPPORTED[key] = exchange(a, b)
        except OSError:
            _SUPPORTED[key] = False
        finally:
            for p in (a, b):
                if p is not None:
                    shutil.rmtree(p, ignore_errors=True)
    return _SUPPORTED[key]


_SUPPORTED: dict[str, bool] = {}

#: hidden names the store makes beside a result: .NAME.TAG-PID-RANDOM
_LEFTOVER = re.compile(r"^\.(?P<name>.+)\.(?P<tag>partial|old|v|link)-(?P<pid>\d+)-[^-/]+$")
_LEGACY = re.compile(r"^\.(?P<name>.+)\.(?P<tag>partial|old)-[^-/]+$")


def _alive(pid: int) -> bool:
    from manipcad.fileio import _alive as alive  # one liveness test for every writer

    return alive(pid)


def leftovers(folder: str | Path, name: str | None = None) -> list[tuple[Path, str, bool]]:
    """The store's hidden temporary entries in a folder.

    Args:
        folder: the folder holding result folders.
        name: only those of this result name (None: all).

    Returns:
        (path, tag, writer_alive) per entry; tag is "partial", "old", "v"
        (a version of the versioned layout) or "link". Entries of an earlier
        manipcad without a process id in the name count as of a dead writer.
    """
    out = []
    folder = Path(folder)
    try:
        entries = list(folder.iterdir())
    except OSError:
        return []
    for p in entries:
        m = _LEFTOVER.match(p.name)
        if m is not None:
            alive = _alive(int(m["pid"]))
        else:
            m = _LEGACY.match(p.name)
            if m is None:
                continue
            alive = False
        if name is None or m["name"] == name:
            out.append((p, m["tag"], alive))
    return out


def clean_stale(folder: str | Path, name: str | None = None) -> list[str]:
    """Remove the leftovers of dead writers beside result folders; repair a half swap.

    A result folder NAME found missing while a dead writer's ``.NAME.old-*``
    exists (a kill between the two renames of the fallback swap) gets that
    folder back. Versions of the versioned layout no link points to are removed.

    Args:
        folder: the folder holding result folders.
        name: only the leftovers of this result name (None: all).

    Returns:
        One line per action taken ("removed .r.partial-12-ab", "restored r from ...").
    """
    folder = Path(folder)
    done: list[str] = []
    found = leftovers(folder, name)
    for p, tag, alive in found:
        if alive and not (tag == "v" and _superseded(p, folder)):
            continue
        m = _LEFTOVER.match(p.name) or _LEGACY.match(p.name)
        assert m is not None
        target = folder / m["name"]
        try:
            if tag == "old" and not target.exists() and not target.is_symlink():
                os.rename(p, target)
                done.append(f"restored {target.name} from {p.name}")
                continue
            if tag == "v":
                if target.is_symlink() and target.resolve() == p.resolve():
                    continue
                if not target.is_symlink() and not target.exists():
                    os.symlink(p.name, target)  # a link lost before it was made: keep data
                    done.append(f"restored {target.name} -> {p.name}")
                    continue
            _remove(p)
            done.append(f"removed {p.name}")
        except OSError:
            continue
    return done


def _superseded(version: Path, folder: Path) -> bool:
    """A version folder older than the one its link points to (no writer will link it)."""
    m = _LEFTOVER.match(version.name)
    link = folder / m["name"] if m else None
    if link is None or not link.is_symlink():
        return False
    try:
        current = link.resolve()
        return current != version.resolve() and (
            version.lstat().st_ctime_ns < current.lstat().st_ctime_ns)
    except OSError:
        return False


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
    from manipcad.sim.simulate import SimulationResult

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
           "metric_units", "SERIES", "jsonable", "write_csv", "clean_stale", "leftovers",
           "install_folder", "temp_dir", "exchange", "SaveInterrupted", "record_every_for",
           "result_arrays", "series_columns"]
