"""Comparing stored results and re-running one from its stored inputs."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.control.files import load_regulators
from manipcad.errors import InputError
from manipcad.model.load import load_robot
from manipcad.report.plots import compare_figure
from manipcad.sim import simulate
from manipcad.store.results import SERIES, load_result
from manipcad.trajectories import load_trajectory
from manipcad.workspace.core import Workspace

#: the columns of ``ws compare`` (largest over the joints; SI units)
COMPARE_METRICS = (("max_error", "rad|m"), ("rms_error", "rad|m"), ("peak_torque", "N·m|N"),
                   ("peak_current", "A"), ("peak_power", "W"), ("energy", "J"))

#: short table headings of :data:`COMPARE_METRICS`
COMPARE_HEADINGS = {"max_error": "max|e|", "rms_error": "RMS e", "peak_torque": "peak τ",
                    "peak_current": "peak i", "peak_power": "peak P", "energy": "energy"}


def compare(ws: Workspace, refs: list[str], *, quantities=("error", "tau", "current")):
    """Metrics of several stored results side by side, and their overlaid plots.

    Args:
        ws: the workspace.
        refs: result names (or ``results/NAME``), at least one.
        quantities: the figure's columns (:func:`manipcad.report.plots.compare_figure`).

    Returns:
        (rows, figure): one dict per result (``name``, ``status``, ``robot`` and
        the :data:`COMPARE_METRICS`, largest over the joints, None if absent)
        and a :class:`matplotlib.figure.Figure` (None if the results' joints differ).

    Raises:
        InputError: no such result, or an item that is not a result.
    """

    if not refs:
        raise InputError("ws compare", "", "name at least one result")
    rows, results, labels, types = [], [], [], None
    for ref in refs:
        item = ws.get(ref)
        if item.kind != "results":
            raise InputError(ref, "", f"is a {item.kind[:-1]}, not a result")
        res, doc = load_result(ws.path(item))
        rows.append({"name": item.name, "status": item.status, "robot": doc.get("robot"),
                     **{m: item.metrics.get(m) for m, _ in COMPARE_METRICS}})
        results.append(res)
        labels.append(item.name)
        types = types or doc.get("joint_types")
    same = all(list(r.joint_names) == list(results[0].joint_names) for r in results)
    fig = compare_figure(results, labels, joint_types=types, quantities=quantities) \
        if same else None
    return rows, fig


@dataclass
class Rerun:
    """What :func:`rerun` found.

    Attributes:
        name: the result re-run.
        identical: every stored array and metric equals the new run's exactly.
        max_abs_diff: per stored quantity (t, q, qd, ...), the largest |new - stored|.
        metrics: per "joint.metric": (stored, new).
        result: the new :class:`manipcad.sim.SimulationResult`.
    """

    name: str
    identical: bool
    max_abs_diff: dict[str, float]
    metrics: dict[str, tuple[Any, Any]] = field(default_factory=dict)
    result: Any = None


def rerun(ws: Workspace, ref: str) -> Rerun:
    """Run a stored result again from its stored inputs and settings and compare.

    The inputs are the copies in ``results/NAME/inputs/`` (robot, trajectory,
    regulators); the settings are the run's (``t_end``, ``dt``, ``every``,
    ``drives``, ``payload`` in metrics.json's ``run``, else its ``settings``).

    Returns:
        A :class:`Rerun`; ``identical`` is True when every array and metric is
        bit-for-bit equal.

    Raises:
        InputError: not a result, or its stored inputs are incomplete (named).
    """

    item = ws.get(ref)
    if item.kind != "results":
        raise InputError(ref, "", f"is a {item.kind[:-1]}, not a result")
    folder = ws.path(item)
    stored, doc = load_result(folder)
    new = run_from_folder(folder, doc)
    diffs = {}
    for s in ("t", *SERIES):
        a, b = np.asarray(getattr(stored, s)), np.asarray(getattr(new, s))
        if a.shape != b.shape:
            diffs[s] = math.inf
            continue
        with np.errstate(invalid="ignore"):
            d = np.abs(a - b)
        both_nan = np.isnan(a) & np.isnan(b)
        d = np.where(both_nan, 0.0, d)
        diffs[s] = float(np.nanmax(d, initial=0.0)) if not np.isnan(d).any() else math.inf
    metrics = {}
    same_metrics = True
    for joint, per in (doc.get("metrics") or {}).items():
        for m, old in per.items():
            val = (new.metrics.get(joint) or {}).get(m)
            val = None if isinstance(val, float) and math.isnan(val) else val
            metrics[f"{joint}.{m}"] = (old, val)
            same_metrics &= old == val
    identical = same_metrics and all(v == 0.0 for v in diffs.values())
    return Rerun(item.name, identical, diffs, metrics, new)


def run_from_folder(folder: Path, doc: dict[str, Any]):
    """Simulate again from a result folder's ``inputs/`` and recorded settings."""

    inputs = folder / "inputs"
    run = dict(doc.get("settings") or {})
    run.update(doc.get("run") or {})
    robot_files = sorted(inputs.glob("robot.*"))
    traj_files = sorted(inputs.glob("trajectory.*"))
    if not robot_files:
        raise InputError(str(inputs), "robot", "no stored robot file; cannot re-run")
    for key in ("t_end", "dt"):
        if not isinstance(run.get(key), int | float):
            raise InputError(str(folder / "metrics.json"), f"run.{key}", "missing; cannot "
                             "re-run")
    robot = load_robot(robot_files[0])
    drives = bool(run.get("drives", True))
    dt = float(run["dt"])
    traj = load_trajectory(traj_files[0], robot=robot) if traj_files else None
    regs = []
    for f in sorted(inputs.glob("regulator*.*"), key=_input_order):
        regs += load_regulators(f, robot, dt=dt, drives=drives)
    # the numerical path the run took (kernels, integrator, drive order) is part of it:
    # a rerun takes the same, so that it is identical bit for bit
    same = {k: run[k] for k in ("integrator", "rtol", "atol", "order") if k in run}
    if "generated" in run:
        same["use_generated"] = bool(run["generated"])
    return simulate(robot, t_end=float(run["t_end"]), dt=dt, trajectory=traj,
                    regulators=regs, payload=run.get("payload"), drives=drives,
                    every=int(run.get("every") or 1),
                    **same)


def _input_order(p: Path) -> tuple[int, str]:
    tail = p.stem.rsplit("-", 1)[-1]
    return (int(tail) if tail.isdigit() else 0, p.name)
