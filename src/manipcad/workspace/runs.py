"""Comparing stored results and re-running one from its stored inputs."""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.errors import InputError
from manipcad.report.plots import compare_figure
from manipcad.store.results import SERIES, load_result
from manipcad.store.run import execute, stored_spec
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

    The run is the stored description (metrics.json's ``run``,
    :meth:`manipcad.store.run.RunSpec.from_dict`, what an earlier version did not store
    taken from its ``settings``) on the copies of its inputs in ``results/NAME/inputs/``
    (robot, trajectory, regulators): :func:`manipcad.store.run.stored_spec`.

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
    """Simulate again from a result folder's ``inputs/`` and recorded run
    (:func:`manipcad.store.run.stored_spec`); the new :class:`~manipcad.sim.SimulationResult`."""
    return execute(stored_spec(folder, doc)).result


def to_workspace(ws: Workspace, name: str | None = None, *, force: bool = False,
                 trajectory: str | None = None, regulators=None):
    """A :data:`manipcad.store.run.ResultStore` that stores a result in the workspace as
    ``results/NAME`` and indexes it (:meth:`Workspace.store_result`); it returns the
    indexed :class:`~manipcad.workspace.core.Item`.

    Args:
        ws: the workspace.
        name: the result's name; None: one is made.
        force: replace a result of the same name.
        trajectory, regulators: how the inputs are referred to (workspace names or
            files); default the run's files.
    """

    def store(result, *, robot, spec, run, status="ok", message=""):
        return ws.store_result(result, name=name, robot=robot,
                               trajectory=spec.trajectory if trajectory is None else trajectory,
                               regulators=list(spec.regulators if regulators is None
                                               else regulators),
                               run=run, joint_types=robot.joint_types, force=force,
                               status=status, message=message)

    return store
