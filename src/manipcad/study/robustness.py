"""Robustness to parameter uncertainty: the distribution of each method's max error.

``run_robustness(out_dir)`` designs the regulators of the Fig. 3 experiment (the
turning drive under laws (2), the same support regulators on the lift and the
reach as ``study fig3``) on the *nominal* arm, then simulates them on arms whose
parameters are off by up to ±x %:

- each link's mass (and its inertia tensor with it: the same factor),
- each drive's motor constants k_m and k_w (one factor per motor: they are one
  constant in SI units),
- the payload at the gripper,

each factor drawn uniformly from [1 − x, 1 + x] (``numpy.random.default_rng`` of
(seed, sample): sample k's arm does not depend on how many samples are run or
where). The regulators keep their nominal designs (gains, drive constants, load
ranges); the signals the adaptive methods read (H_ii, c_i, Q_i) are computed by
the simulator from the arm simulated, i.e. a perfect measurement of the true
arm (the online estimate of the payload is ``study pickup``).

Every sample is one task of :func:`manipcad.parallel.run_tasks` (Dask; ``workers=1``
serial), cached under ``out_dir/cache`` by a hash of its inputs, so more samples
compute only the new ones. The laws run at ``speed_scale`` or, where the nominal
arm with its payload fails the sizing there, time-scaled to the largest feasible
speed scale (:func:`manipcad.study.claims.feasible_speed_scale`; said in the file).

Files: ``robustness.json`` ({"arm", "uncertainty", "samples", "methods",
"nominal": {method: max|ε| rad}, "max_error": {method: [rad per sample]},
"summary": {method: {"median", "p5", "p95", "max", "worst_over_nominal"}},
"factors": [per sample], "diverged": {method: count}, "settings"}) and
``robustness.png`` (box plots of max|ε| per method, the nominal value marked).
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import os
import shutil
import tempfile
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.control import synthesize
from manipcad.control.registry import METHODS as REGISTRY
from manipcad.errors import InputError, ManipcadWarning
from manipcad.fileio import json_safe, writable_folder
from manipcad.model.robot import Robot
from manipcad.parallel import run_tasks
from manipcad.parallel.executor import check_workers
from manipcad.report.robustness import plot_robustness
from manipcad.sim import SimulationDiverged, simulate
from manipcad.study.claims import feasible_speed_scale, laws, resolve_arm
from manipcad.study.fig3 import (
    LAWS,
    REACH,
    SKIP_ERRORS,
    TURN,
    control_period,
    support_regulators,
)

#: the methods compared by default (the Fig. 3 tracking runs with a corrector or a law)
METHODS = ("none_sce", "ace_tf", "ace_de", "lqr", "lqr_gs")
#: the nominal payload at the gripper per arm preset, kg (light: near what its reach
#: carries on laws (2) at full speed; the presets: their rated payloads)
PAYLOAD = {"light": 0.1, "industrial": 2.0, "heavy": 5.0}
#: a sample's code version (part of its cache key)
SAMPLE_VERSION = "1"


def perturbed_arm(arm: Robot, payload: float, uncertainty: float, seed: int,
                  sample: int) -> tuple[Robot, dict[str, Any]]:
    """The arm with its link masses, motor constants and payload off by up to ±uncertainty.

    Args:
        arm: the nominal arm (no payload).
        payload: the nominal payload at the gripper (tool point, reach link), kg.
        uncertainty: the largest relative error x (0 <= x < 1): each factor is uniform
            in [1 − x, 1 + x].
        seed, sample: the random stream (``default_rng([seed, sample])``); sample −1
            is the nominal arm (every factor 1).

    Returns:
        ``(arm, factors)``: the arm with the payload, and {"mass": [per link],
        "motor": [per drive, None without one], "payload": factor}.

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> new, f = perturbed_arm(arm, 0.1, 0.1, seed=0, sample=0)
        >>> all(0.9 <= v <= 1.1 for v in f["mass"]), bool(new.mass[0] == arm.mass[0] * f["mass"][0])
        (True, True)
    """
    n = arm.n
    if sample < 0:
        fm, fk, fp = np.ones(n), np.ones(n), 1.0
    else:
        rng = np.random.default_rng([int(seed), int(sample)])
        u = rng.uniform(-uncertainty, uncertainty, size=2 * n + 1)
        fm, fk, fp = 1.0 + u[:n], 1.0 + u[n:2 * n], float(1.0 + u[2 * n])
    drives = tuple(None if d is None else d.replace(k_m=d.k_m * fk[j], k_w=d.k_w * fk[j])
                   for j, d in enumerate(arm.drives))
    new = arm.replace(mass=np.asarray(arm.mass, dtype=float) * fm,
                      inertia=np.asarray(arm.inertia, dtype=float) * fm[:, None, None],
                      drives=drives)
    if payload > 0:
        new = new.with_payload(payload * fp, np.asarray(arm.tool_p, dtype=float), link=REACH)
    return new, {"mass": fm.tolist(),
                 "motor": [None if d is None else float(fk[j]) for j, d in
                           enumerate(arm.drives)],
                 "payload": fp}


def robustness_sample(*, sample: int, arm: Robot, payload: float, uncertainty: float,
                      seed: int, methods: tuple[str, ...], speed_scale: float, t_end: float,
                      dt: float) -> dict:
    """One sample: each method designed on the nominal arm, run on the perturbed one.

    Returns:
        {"max_error": {method: rad or None}, "diverged": [methods], "skipped":
        {method: reason}, "factors": see :func:`perturbed_arm`}.
    """

    nominal = arm.with_payload(payload, np.asarray(arm.tool_p, dtype=float), link=REACH) \
        if payload > 0 else arm
    plant, factors = perturbed_arm(arm, payload, uncertainty, seed, sample)
    period = control_period(dt)
    support = support_regulators(nominal, period)
    traj = laws(speed_scale)
    out: dict[str, Any] = {"max_error": {}, "diverged": [], "skipped": {}, "factors": factors}
    for method in methods:
        try:
            reg = synthesize(nominal, TURN, method, period=period)
        except SKIP_ERRORS as exc:
            out["skipped"][method] = f"{type(exc).__name__}: {exc}"
            out["max_error"][method] = None
            continue
        try:
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ManipcadWarning)
                res = simulate(plant, t_end=t_end, dt=dt, trajectory=traj,
                               regulators=[reg, *support], use_generated=False)
        except SimulationDiverged:
            out["diverged"].append(method)
            out["max_error"][method] = None
            continue
        v = res.metrics[TURN]["max_error"]
        out["max_error"][method] = float(v) if math.isfinite(v) else None
    return out


def _check(samples, uncertainty, methods, speed_scale, seed, dt, t_end):

    if isinstance(samples, bool) or not isinstance(samples, int) or not 1 <= samples <= 10000:
        raise InputError("--samples", "", f"must be a whole number in [1, 10000], got "
                         f"{samples!r}")
    if not (isinstance(uncertainty, int | float) and math.isfinite(uncertainty)
            and 0 <= uncertainty < 1):
        raise InputError("--uncertainty", "", f"must be a fraction in [0, 1) (a percentage "
                         f"in [0, 100) on the command line), got {uncertainty!r}")
    if isinstance(methods, str):
        methods = [m.strip() for m in methods.split(",") if m.strip()]
    methods = tuple(methods)
    if not methods:
        raise InputError("--methods", "", "no method given")
    unknown = [m for m in methods if m not in REGISTRY]
    if unknown:
        raise InputError("--methods", "", f"unknown method(s) {', '.join(unknown)}; known: "
                         f"{', '.join(sorted(REGISTRY))}")
    if not (isinstance(speed_scale, int | float) and math.isfinite(speed_scale)
            and 0 < speed_scale <= 10):
        raise InputError("--speed-scale", "", f"must be in (0, 10], got {speed_scale!r}")
    if isinstance(seed, bool) or not isinstance(seed, int) or seed < 0:
        raise InputError("--seed", "", f"must be a whole number >= 0, got {seed!r}")
    if not (isinstance(dt, int | float) and math.isfinite(dt) and 0 < dt <= 1e-3):
        raise InputError("--dt", "", f"must be in (0, 1e-3] s, got {dt!r}")
    if t_end is not None and not (isinstance(t_end, int | float) and math.isfinite(t_end)
                                  and 0 < t_end <= 60):
        raise InputError("--t-end", "", f"must be in (0, 60] s, got {t_end!r}")
    return methods


def run_robustness(out_dir: str | Path, *, arm: str | Robot = "light", samples: int = 20,
                   uncertainty: float = 0.1, methods=METHODS, speed_scale: float = 1.0,
                   seed: int = 0, payload: float | None = None, t_end: float | None = None,
                   dt: float = 1e-4, workers: int | None = None, scheduler: str | None = None,
                   progress: bool = True) -> dict:
    """Run the robustness study and write robustness.json and robustness.png into ``out_dir``.

    Args:
        out_dir: the output folder (created; its parent must exist); the samples'
            cache in ``out_dir/cache``.
        arm: "light", "industrial", "heavy" (:data:`manipcad.study.claims.ARMS`), a
            robot file or a Robot with joints turn, lift, reach and drives.
        samples: perturbed arms, >= 1 (plus the nominal one).
        uncertainty: the largest relative parameter error x, in [0, 1) (0.1: ±10 %).
        methods: method names (a list or a comma-separated string).
        speed_scale: speed scale of laws (2) (time-scaled down where the nominal arm
            with its payload fails the sizing).
        seed: random seed, >= 0.
        payload: nominal payload at the gripper, kg (default :data:`PAYLOAD` of the
            preset; 0 for a file).
        t_end: length of each run, s (default the laws' duration 1.6/s).
        dt: integration step, s.
        workers, scheduler: as :func:`manipcad.parallel.run_tasks`.
        progress: show a progress bar of samples done.

    Returns:
        The robustness.json document.

    Raises:
        InputError: a bad argument (named), arm or output folder.

    Example:
        >>> from manipcad.study.robustness import run_robustness
        >>> doc = run_robustness("/tmp/rob", samples=4, workers=1)  # doctest: +SKIP
    """

    methods = _check(samples, uncertainty, methods, speed_scale, seed, dt, t_end)

    check_workers(workers, scheduler, "study robustness")
    out = writable_folder(out_dir)
    robot, arm_name, max_payload = resolve_arm(arm, "robustness")
    default_payload = PAYLOAD.get(arm, 0.0) if isinstance(arm, str) else 0.0
    m_p = default_payload if payload is None else payload
    if not (isinstance(m_p, int | float) and math.isfinite(m_p) and 0 <= m_p <= 10 *
            max_payload):
        raise InputError("--payload", "", f"must be a mass in kg >= 0, got {m_p!r}")
    nominal = robot.with_payload(m_p, np.asarray(robot.tool_p, dtype=float), link=REACH) \
        if m_p > 0 else robot
    s_run, fails = feasible_speed_scale(nominal, float(speed_scale))
    if s_run is None:
        raise InputError("--arm", "", f"{arm_name} with {m_p:g} kg fails the sizing on laws "
                         f"(2) even slowed down: {', '.join(fails)}")
    duration = LAWS["duration"] / s_run if t_end is None else float(t_end)
    tasks = [{"sample": k} for k in range(-1, samples)]
    out.mkdir(exist_ok=True)
    res = run_tasks(robustness_sample, tasks,
                    common={"arm": robot, "payload": float(m_p), "uncertainty": float(uncertainty),
                            "seed": seed, "methods": methods, "speed_scale": s_run,
                            "t_end": duration, "dt": dt},
                    workers=workers, scheduler=scheduler, cache_dir=out / "cache",
                    progress=progress, desc="robustness samples", version=SAMPLE_VERSION)
    nominal_res, rest = res[0], list(res[1:])
    errors = {m: [r["max_error"].get(m) for r in rest] for m in methods}
    summary = {}
    for m in methods:
        v = np.array([x for x in errors[m] if x is not None], dtype=float)
        nom = nominal_res["max_error"].get(m)
        summary[m] = ({} if v.size == 0 else {
            "median": float(np.median(v)), "p5": float(np.percentile(v, 5)),
            "p95": float(np.percentile(v, 95)), "max": float(v.max()),
            "worst_over_nominal": (float(v.max() / nom) if nom else None)})
    doc = json_safe({
        "study": "robustness",
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "arm": {"name": arm_name, "robot": robot.name, "payload_kg": m_p},
        "uncertainty": uncertainty, "samples": samples, "seed": seed, "methods": list(methods),
        "nominal": nominal_res["max_error"], "max_error": errors, "summary": summary,
        "diverged": {m: sum(m in r["diverged"] for r in rest) for m in methods},
        "skipped": nominal_res["skipped"],
        "factors": [r["factors"] for r in rest],
        "settings": {"speed_scale": float(speed_scale), "speed_scale_run": s_run,
                     "time_scaled": s_run != float(speed_scale), "sizing_failures": fails,
                     "t_end": duration, "dt": dt, "period": control_period(dt),
                     "perturbed": "link masses (with their inertia tensors), motor constants "
                     "k_m = k_w per drive, payload; each factor uniform in [1 − x, 1 + x]",
                     "designed_on": "the nominal arm (regulator gains, drive constants, load "
                     "ranges); the adaptive methods' H_ii, c_i, Q_i are the simulated arm's",
                     "samples_computed": res.computed, "samples_cached": res.cached},
        "units": {"max_error": "rad", "uncertainty": "fraction", "payload_kg": "kg",
                  "t_end": "s", "dt": "s"},
    })
    _write(out, doc)
    return doc


def _write(out: Path, doc: dict) -> None:
    """robustness.json and robustness.png, each written to a temporary file and renamed."""

    tmp = Path(tempfile.mkdtemp(prefix=".robustness.", dir=out))
    try:
        (tmp / "robustness.json").write_text(json.dumps(doc, indent=2, ensure_ascii=False)
                                             + "\n", encoding="utf-8")
        plot_robustness(doc, tmp / "robustness.png")
        for name in ("robustness.json", "robustness.png"):
            os.replace(tmp / name, out / name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
