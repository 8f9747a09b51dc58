"""The pickup study: an unknown payload gripped mid-trajectory, identified in real time.

``run_pickup(out_dir)`` runs, on the Fig. 2 arm by default (the catalog's
``cylindrical``: the paper's own arm, whose turning drive's load depends on the reach
and so on what the gripper holds), laws (2) with a payload of ``mass`` kg gripped at the
tool point at ``t_pick`` s. The turning drive is controlled by each adaptive method
(``ace_tf``, ``ace_de``, ``asvs``, ``lqr_gs``; the lift and the reach by the Fig. 3
study's PIDs), three times, differing only in what the regulator's model knows of the
payload (``simulate(model_payload=...)``):

- ``true_mass``: the model follows the plant (the payload known the instant it is gripped);
- ``online``: the model carries the online estimate of
  :class:`~manipcad.control.estimator.PayloadEstimator` (RLS with forgetting, run inside
  the loop at the regulator period on the armature currents, with current noise);
- ``nominal``: the model stays the unloaded arm.

It writes ``pickup.json`` — ``{"true_mass": kg, "estimate_final": kg,
"estimate_settling_time": s, "max_error_after_pickup": {METHOD: {"true_mass": rad,
"online": rad, "nominal": rad}}}`` plus the settings, the estimator's counted operations
per period, each method's estimate and the errors once the estimate has settled — and
``pickup.png`` (the estimate converging; the tracking error of each method in the three
cases). ``estimate_final`` and ``estimate_settling_time`` are those of the first
method's online run (each method's are under ``estimate_by_method``: the estimator sees
the motion each regulator makes); the settling time counts from the pickup to the last
time the estimate is outside ±2 % of the true mass (null: it never settles).

The regulators are designed for the load range from the unloaded arm to the arm carrying
``mass`` (a designer knows the payload range, not the payload), so the three cases differ
only in the model signals the law reads.
"""

from __future__ import annotations

import datetime as _dt
import json
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

import manipcad
from manipcad.control import synthesize
from manipcad.control.design import inertia_range
from manipcad.control.estimator import PayloadEstimator
from manipcad.errors import InputError, ManipcadError, ManipcadWarning
from manipcad.fileio import json_safe, writable_folder
from manipcad.folders import write_folder
from manipcad.model.robot import Robot
from manipcad.report.pickup import plot_pickup
from manipcad.sim import simulate
from manipcad.sim.integrate import INTEGRATORS
from manipcad.study.fig3 import LAWS, LIFT, REACH, TURN, support_regulators
from manipcad.trajectories import cosine
from manipcad.version import __version__

#: the adaptive methods of the study (they read H_ii, c_i, Q_i or look up a table over H_ii)
METHODS = ("ace_tf", "ace_de", "asvs", "lqr_gs")
#: the study's three cases -> simulate(model_payload=...)
CASES = {"true_mass": "true", "online": "online", "nominal": "nominal"}
#: defaults: payload kg (what the Fig. 2 arm's reach motor carries on laws (2)
#: continuously, see its catalog file), pickup time s, run length s, step s, current noise A,
#: forgetting factor (memory 100 periods, 10 ms at the step: with 500 periods, 50 ms, the
#: model carried a mass still converging for ~0.2 s after the pickup, and law (3) kept only
#: 70 % of what knowing the mass gains; the estimate's jitter at 100 periods, 0.3 % of
#: the mass, costs little: docs/identification.md)
MASS, T_PICK, T_END, DT, NOISE, FORGETTING = 0.1, 0.6, 1.6, 1e-4, 0.02, 0.99
#: the estimate has settled when it stays within this fraction of the true mass
BAND = 0.02


@dataclass
class PickupResult:
    """What :func:`run_pickup` computed and wrote.

    Attributes:
        out_dir: the folder written; files: name -> path (pickup.json, pickup.png).
        data: the content of pickup.json.
        runs: method -> case -> :class:`~manipcad.sim.SimulationResult`.
    """

    out_dir: Path
    files: dict[str, Path]
    data: dict
    runs: dict = field(default_factory=dict)


def settling_time(t, m, true_mass: float, t_pick: float, band: float = BAND) -> float | None:
    """Time after ``t_pick`` (s) from which the estimate m (kg) at times t (s) stays within
    ``band``·true_mass of the true mass; None if it is outside at the last sample.

    Example:
        >>> settling_time([0, 1, 2, 3], [0, 0.5, 0.99, 1.0], 1.0, 0.5)
        1.5
    """
    t, m = np.asarray(t, dtype=float), np.asarray(m, dtype=float)
    out = np.abs(m - true_mass) > band * true_mass
    after = t >= t_pick
    if not after.any() or out[-1]:
        return None
    bad = np.nonzero(out & after)[0]
    return 0.0 if bad.size == 0 else float(t[bad[-1] + 1] - t_pick)


def _check(mass, t_pick, t_end, dt, current_noise, forgetting) -> None:
    for name, v in (("mass", mass), ("t_pick", t_pick), ("t_end", t_end), ("dt", dt),
                    ("current_noise", current_noise), ("forgetting", forgetting)):
        if not (isinstance(v, int | float) and math.isfinite(v)):
            raise InputError(name, "", f"must be a finite number, got {v!r}")
    if not mass > 0:
        raise InputError("mass", "", f"must be > 0 kg (the payload picked up), got {mass}")
    if not (0 < dt <= 1e-2):
        raise InputError("dt", "", f"must be in (0, 0.01] s, got {dt}")
    if not t_end >= 10 * dt:
        raise InputError("t_end", "", f"must be >= 10·dt s, got {t_end}")
    if not (0 < t_pick < t_end):
        raise InputError("t_pick", "", f"must be inside the run (0, t_end = {t_end:g} s), "
                         f"got {t_pick}")
    if current_noise < 0:
        raise InputError("current_noise", "", f"must be >= 0 A, got {current_noise}")
    if not (0 < forgetting <= 1):
        raise InputError("forgetting", "", f"must be in (0, 1], got {forgetting}")


def _setup(arm: Robot, period: float, t_end: float):
    """(joints under study, trajectory, support regulators) for the arm."""

    if set((TURN, LIFT, REACH)) <= set(arm.joint_names):
        traj = cosine(list(LAWS["amplitude"]), list(LAWS["omega"]), max(LAWS["duration"],
                                                                       t_end))
        return [arm.joint_index(TURN)], traj, support_regulators(arm, period)
    # another arm: every joint under the method, a cosine law on each (0.3 rad or 0.1 m,
    # 2 rad/s)
    amp = [0.1 if jt == "prismatic" else 0.3 for jt in arm.joint_types]
    return list(range(arm.n)), cosine(amp, [2.0] * arm.n, t_end), []


def run_pickup(out_dir: str | Path, *, robot: Robot | str | None = None, mass: float = MASS,
               t_pick: float = T_PICK, t_end: float = T_END, dt: float = DT,
               period: float | None = None, current_noise: float = NOISE,
               forgetting: float = FORGETTING, methods=None, seed: int = 0,
               integrator: str = "rk4") -> PickupResult:
    """Run the pickup study and write pickup.json and pickup.png into ``out_dir``.

    Args:
        out_dir: the output folder (created or replaced whole; its parent must exist).
        robot: a Robot or a catalog name/file (default the Fig. 2 arm ``cylindrical``).
            An arm with joints turn, lift, reach runs laws (2) with the turn under study;
            another runs a cosine on every joint, each under the method.
        mass: the payload gripped, kg (> 0), at the tool point of the last link.
        t_pick: when it is gripped, s (inside the run); t_end: the run's length, s.
        dt: integration step, s; period: the regulators' and the estimator's period, s
            (default dt).
        current_noise: standard deviation of the noise on the currents the estimator
            reads, A.
        forgetting: the estimator's forgetting factor λ (memory period/(1 − λ) s).
        methods: a subset of :data:`METHODS` (list or comma-separated string).
        seed: the current noise's seed.
        integrator: the runs' integrator, "rk4" or an adaptive one ("adaptive",
            "adaptive-exact", ... of :func:`manipcad.simulate`; with an adaptive one
            ``t_pick`` must be a multiple of ``period``).

    Returns:
        :class:`PickupResult`.

    Raises:
        InputError: a bad argument (named) or output folder.

    Example:
        >>> from manipcad.study.pickup import run_pickup
        >>> res = run_pickup("/tmp/pickup", t_end=0.4, t_pick=0.1)  # doctest: +SKIP
        >>> sorted(res.data["max_error_after_pickup"])  # doctest: +SKIP
        ['ace_de', 'ace_tf', 'asvs', 'lqr_gs']
    """

    _check(mass, t_pick, t_end, dt, current_noise, forgetting)
    if integrator not in INTEGRATORS:
        raise InputError("integrator", "", f"{integrator!r}: expected one of "
                         f"{', '.join(INTEGRATORS)}")
    period = dt if period is None else period
    if not (isinstance(period, int | float) and math.isfinite(period) and period >= dt):
        raise InputError("period", "", f"must be a number of s >= dt, got {period!r}")
    if integrator != "rk4" and abs(t_pick / period - round(t_pick / period)) > 1e-9:
        raise InputError("t_pick", "", f"{t_pick:g} s: with integrator={integrator!r} the "
                         f"pickup must fall on a sample instant (a multiple of the period "
                         f"{period:g} s)")
    if isinstance(methods, str):
        methods = [m.strip() for m in methods.split(",") if m.strip()]
    methods = list(METHODS if methods is None else methods)
    bad = [m for m in methods if m not in METHODS]
    if bad or not methods:
        raise InputError("methods", "", f"must be among {', '.join(METHODS)}, got {bad or '[]'}")
    out = writable_folder(out_dir)
    arm = manipcad.load_robot("cylindrical" if robot is None else robot) \
        if not isinstance(robot, Robot) else robot
    if not arm.has_drives:
        raise InputError(arm.name, "drives", "the pickup study needs a drive on every joint")
    # the study measures what knowing the payload gains, not what modelling the gears'
    # losses does (which the simulated plant has, and ACE (1)'s quasi-stationary
    # realization cannot model: docs/synthesis.md), so it runs on lossless gears
    arm = arm.replace(drives=tuple(None if d is None else d.replace(efficiency=1.0)
                                   for d in arm.drives))
    com = [float(c) for c in arm.tool_p]
    joints, traj, support = _setup(arm, period, t_end)
    loaded = arm.with_payload(mass, com)
    est = PayloadEstimator(arm, period=period, com=com, forgetting=forgetting,
                           current_noise=current_noise, seed=seed)
    cx = est.realization_complexity()
    data: dict[str, Any] = {
        "true_mass": float(mass), "estimate_final": None, "estimate_settling_time": None,
        "max_error_after_pickup": {},
        "max_error_after_settling": {}, "estimate_by_method": {}, "skipped": {},
        "estimator": {"description": est.describe(), "operations_per_period": cx,
                      "forgetting": forgetting, "period": period,
                      "current_noise": current_noise, "seed": seed},
        "settings": {"robot": arm.name, "joints": [arm.joint_names[j] for j in joints],
                     "t_pick": t_pick, "t_end": t_end, "dt": dt, "period": period,
                     "integrator": integrator,
                     "payload_com": com, "payload_link": arm.joint_names[-1],
                     "methods": methods, "band": BAND,
                     "trajectory": "laws (2) of the Fig. 3 study" if support else
                                   "cosine on every joint (0.3 rad or 0.1 m, 2 rad/s)"},
        "units": {"true_mass": "kg", "estimate_final": "kg", "estimate_settling_time":
                  "s after the pickup", "max_error_after_pickup": "rad (m for a prismatic "
                  "joint)", "period": "s", "current_noise": "A", "t_pick": "s"},
        "paper": "conclusion: the dynamics algorithms ensure identification of parameter "
                 "variables of drives loaded at real time (the adaptive regulators need it)",
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "manipcad_version": __version__,
    }
    runs: dict[str, dict] = {}
    for meth in methods:
        try:
            regs = []
            for j in joints:
                lr = (inertia_range(arm, j)[0], inertia_range(loaded, j)[1])
                regs.append(synthesize(arm, j, meth, period=period, load_range=lr))
        except ManipcadError as exc:
            data["skipped"][meth] = f"synthesis refused: {exc}"
            continue
        runs[meth] = {}
        for case, mode in CASES.items():
            with warnings.catch_warnings():
                warnings.simplefilter("ignore", ManipcadWarning)
                try:
                    runs[meth][case] = simulate(
                        arm, t_end=t_end, dt=dt, trajectory=traj, regulators=[*regs, *support],
                        pickup={"mass": mass, "t": t_pick, "com": com},
                        estimator=est if mode == "online" else None, model_payload=mode,
                        integrator=integrator)
                except ManipcadError as exc:
                    data["skipped"][f"{meth}/{case}"] = f"run failed: {exc}"
    for meth, cases in runs.items():
        if "online" in cases:
            pe = cases["online"].payload_estimate
            ts = settling_time(pe[:, 0], pe[:, 1], mass, t_pick)
            data["estimate_by_method"][meth] = {"final": float(pe[-1, 1]), "settling_time": ts}
            if data["estimate_final"] is None:
                data["estimate_final"], data["estimate_settling_time"] = float(pe[-1, 1]), ts
        settle = data["estimate_by_method"].get(meth, {}).get("settling_time")
        data["max_error_after_pickup"][meth] = {}
        data["max_error_after_settling"][meth] = {}
        for case, res in cases.items():
            e = np.abs(res.error[:, joints])
            after = res.t >= t_pick - 1e-12
            data["max_error_after_pickup"][meth][case] = float(e[after].max())
            if settle is not None:
                late = res.t >= t_pick + settle - 1e-12
                data["max_error_after_settling"][meth][case] = float(e[late].max())
    data["findings"] = findings(data)
    files = _write(out, data, runs)
    return PickupResult(out, files, data, runs)


def findings(data: dict) -> list[str]:
    """One sentence per method: does the online estimate bring it near the true-mass run?"""
    out = []
    for meth, e in data["max_error_after_pickup"].items():
        if not {"true_mass", "online", "nominal"} <= set(e):
            continue
        tm, on, no = e["true_mass"], e["online"], e["nominal"]
        s = data["max_error_after_settling"].get(meth, {})
        if no <= tm:
            verdict = (f"knowing the payload does not help {meth}: max |e| after the pickup "
                       f"{tm:.3g} rad with the true mass, {no:.3g} rad with the nominal model")
        elif on < no:
            gain = (no - on) / (no - tm)
            verdict = (f"{meth}: the online estimate recovers {100 * gain:.0f} % of what "
                       f"knowing the mass gains (max |e| after the pickup: nominal {no:.3g}, "
                       f"online {on:.3g}, true mass {tm:.3g} rad)")
        else:
            verdict = (f"{meth}: the online estimate does not help (max |e| after the pickup: "
                       f"nominal {no:.3g}, online {on:.3g}, true mass {tm:.3g} rad)")
        if s:
            verdict += (f"; once the estimate settled: nominal {s['nominal']:.3g}, online "
                        f"{s['online']:.3g}, true mass {s['true_mass']:.3g} rad")
        out.append(verdict)
    return out


def _write(out: Path, data: dict, runs: dict) -> dict[str, Path]:

    with write_folder(out) as tmp:
        (tmp / "pickup.json").write_text(json.dumps(json_safe(data), indent=2,
                                                    ensure_ascii=False) + "\n")
        plot_pickup(data, runs, tmp / "pickup.png")
    return {"pickup.json": out / "pickup.json", "pickup.png": out / "pickup.png"}
