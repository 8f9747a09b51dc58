"""The verification sweep: one coupled closed-loop simulation per case, on the executor.

A case is a plant (the nominal arm at one payload with one uncertainty sample), a
trajectory and the regulators (a regulator file's mapping, as ``manipcad simulate``
reads it). :func:`run_case` simulates it and judges every joint
(:func:`manipcad.design.judge.judge`); :func:`run_sweep` runs a list of cases with
:func:`manipcad.parallel.run_tasks` (serial with one worker, Dask otherwise, or a cluster
given by address), each case cached under ``cache_dir`` by a hash of its inputs: a rerun
computes only the cases whose plant, trajectory, regulators or settings changed.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

import numpy as np

from manipcad.control.files import regulators_from_dict
from manipcad.design.judge import FAIL, judge, tracking_check
from manipcad.errors import ManipcadError, ManipcadWarning
from manipcad.parallel import run_tasks
from manipcad.sim import SimulationDiverged, simulate

#: the task code's version (part of every cache key): change it when run_case's results change
CASE_VERSION = "2"
#: points of the stored envelopes (max over bins of the kept samples)
ENVELOPE_POINTS = 400


def _envelope(t: np.ndarray, x: np.ndarray, points: int = ENVELOPE_POINTS
              ) -> tuple[list[float], list[list[float]]]:
    """(bin start times s, per bin the max |x| of each column): a plot of ≤ ``points`` bins."""
    k = len(t)
    if k == 0:
        return [], []
    edges = np.linspace(0, k, min(points, k) + 1).astype(int)
    starts = edges[:-1]
    ax = np.abs(x)
    env = np.maximum.reduceat(ax, starts, axis=0)
    return t[starts].tolist(), env.tolist()


def run_case(*, plant, trajectory, regulators: dict, dt: float, t_end: float, every: int,
             accuracy: float, judged: tuple[int, ...], keep_result: bool = True) -> dict:
    """Simulate one case and judge it.

    Args:
        plant: the simulated :class:`~manipcad.model.robot.Robot` (payload, uncertainty).
        trajectory: the reference.
        regulators: a regulator file's mapping (``regulators_document``), loaded for the
            plant as ``manipcad simulate --allow-other-robot`` loads it.
        dt: integration step (RK4), s; t_end: simulated time, s.
        every: record stride (one sample per regulator period, as ``simulate`` keeps).
        accuracy: the largest tracking error asked, rad or m.
        judged: the joints whose tracking error is designed.
        keep_result: return the time series too (to store as a result).

    Returns:
        {"status": "ok" | "diverged" | "refused" (the regulators cannot run on the plant),
        "message", "metrics": {joint: {...}},
        "checks": {joint: {check: {value, limit, unit, verdict}}}, "max_error":
        {joint: rad}, "envelope": {"t", "error", "torque", "speed"} (max |·| per bin),
        "peak": {"torque", "speed", "current"} per joint, "result": the
        SimulationResult or None}.
    """

    names = list(plant.joint_names)
    out: dict[str, Any] = {"status": "ok", "message": ""}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        try:
            regs = regulators_from_dict(regulators, plant, "<design>", dt=dt,
                                        allow_other_robot=True)
            res = simulate(plant, t_end=t_end, dt=dt, trajectory=trajectory, regulators=regs,
                           every=every, use_generated=False)
        except (SimulationDiverged, ManipcadError) as exc:
            status = "diverged" if isinstance(exc, SimulationDiverged) else "refused"
            out.update(status=status, message=str(exc), metrics={}, result=None,
                       max_error={n: None for n in names}, envelope=None, peak=None)
            unit = {n: "m" if t == "prismatic" else "rad"
                    for n, t in zip(names, plant.joint_types, strict=True)}
            out["checks"] = {n: ({"tracking": tracking_check(math.inf, accuracy, unit[n])}
                                 if j in judged else {"run": {"value": None, "limit": None,
                                                              "unit": "", "verdict": FAIL}})
                             for j, n in enumerate(names)}
            return out
    metrics = res.metrics
    out["metrics"] = metrics
    out["max_error"] = {n: float(metrics[n]["max_error"]) for n in names}
    out["checks"] = judge(res, plant, accuracy=accuracy, judged=judged)
    t, e_env = _envelope(res.t, res.error)
    _, tau_env = _envelope(res.t, res.tau)
    _, qd_env = _envelope(res.t, res.qd)
    out["envelope"] = {"t": t, "error": e_env, "torque": tau_env, "speed": qd_env}
    cur = np.where(np.isfinite(res.current), np.abs(res.current), 0.0)
    out["peak"] = {"torque": np.abs(res.tau).max(axis=0).tolist(),
                   "speed": np.abs(res.qd).max(axis=0).tolist(),
                   "current": cur.max(axis=0).tolist()}
    out["result"] = res if keep_result else None
    return out


def run_sweep(cases: list[dict], *, common: dict, workers: int | None = None,
              scheduler: str | None = None, pool=None, cache_dir=None, progress=False,
              desc: str = "design cases"):
    """Run :func:`run_case` on every case (a mapping of its own arguments).

    Args:
        cases: per case {"plant", "trajectory", "regulators"} (and "t_end").
        common: the arguments every case shares ({"dt", "every", "accuracy", "judged",
            "keep_result"} and, when all share it, "t_end").
        workers, scheduler, pool: as :func:`manipcad.parallel.run_tasks`.
        cache_dir: the per-case result cache (None: none).
        progress: a progress bar (True), a callable given the fraction done, or False.

    Returns:
        :class:`manipcad.parallel.executor.Results` in case order (``.computed``, ``.cached``).
    """

    if not cases:
        raise ManipcadError("no case to run")
    kw: dict[str, Any] = {"workers": None, "scheduler": None, "pool": pool} if pool is not None \
        else {"workers": workers, "scheduler": scheduler}
    return run_tasks(run_case, cases, common=common, cache_dir=cache_dir, progress=progress,
                     desc=desc, version=CASE_VERSION,
                     cost=lambda c: float(c.get("t_end", common.get("t_end", 1.0))), **kw)


__all__ = ["run_case", "run_sweep", "CASE_VERSION"]
