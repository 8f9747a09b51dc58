"""Where the paper's claims hold: maps over the speed of laws (2) and the load ratio.

``run_claims(out_dir)`` runs, for every cell of a grid

- speed scale s of laws (2) (ω multiplied by s, the duration 1.6/s: the same
  motion, s times faster), ×
- the turning motor's load ratio ρ = (J·i_r² + H_11,max)/(J·i_r² + H_11,min)
  (:func:`arm_with_load_ratio`: a payload at the gripper up to the arm's rated
  payload, then the reach stroke moved towards the turning axis and lengthened,
  then the turning gear ratio; the first row is the arm as it is, ρ = 1.42 for
  the Fig. 2 arm, so the cell at s = 1 is the Fig. 3 experiment; where the
  levers cannot reach a row's ρ the arm at their ends is run and the ρ it
  achieves is reported),

on one of the arms (``ARMS``: ``light``, the catalog Fig. 2 arm;
``industrial``, about 3 kg more arm, 2 kg payload, a Harmonic Drive
CSF-20-100 on the turning joint; ``heavy``, 5 kg more arm, 5 kg payload, an
RE 65 on the CSF-20-100 and a 4.3:1 gearhead on the reach; or a robot file).
Every cell's arm is checked by the sizing module (:func:`sizing_failures`) on
laws (2) at the cell's speed scale; where a motor or gear is over its limits
the laws are time-scaled to the largest feasible speed scale below it
(:func:`feasible_speed_scale`), and claims.json says so per cell
(``speed_scale_run``, ``time_scaled``, ``sizing_failures``). Measured per cell:
the Fig. 3 experiment's regulators on the turning drive (the same support
regulators on the lift and the reach as ``study fig3``) and measures each
claim as a ratio against its like-for-like baseline:

- ``ace_tf_observable``, ``ace_tf_controllable``: max|ε| of ``none_sce`` /
  ``ace_tf`` in each realization (paper: ACE (1) considerably lowers the error;
  threshold 2);
- ``law3``: max|ε| of ``ace_tf`` (observable) / ``ace_de``, and
  ``law3_no_friction``: ``ace_tf`` / ``ace_de`` with law (3)'s dry-friction term
  off, so the exactness gain and the friction gain are told apart (threshold
  1.1);
- ``asvs_rise``: rise time (10-90 %) of ``vss`` / ``asvs`` for a step at the
  lightest load (paper: about 2 times faster; threshold 1.6);
  ``asvs_sliding_rate``: the ratio asvs / vss of the error's decay rate in the
  sliding phase (:func:`sliding_rate`: from 50 % to 10 % of the step, which
  leaves out the reaching phase); ``asvs_overshoot``:
  the overshoot of ``asvs`` at the lightest load (fraction of the step; the paper:
  none); ``vss_light_overshoot``: a ``vss`` tuned for the lightest load, stepped at
  the heaviest (why adaptation is needed);
- ``lqr_gs``: max|ε| of ``lqr`` / ``lqr_gs`` (paper: 6-8 times; threshold 6),
  attributed step by step: ``lqr_gs_gains_only`` (the scheduled gains alone:
  ``lqr`` and ``lqr_gs`` both without feed-forward), ``lqr_gs_feedforward``
  (+ the reference feed-forward at the current load instead of the nominal
  one), ``lqr_gs`` (+ the measured load torque); and
  ``lqr_equal_information``: a fixed-gain LQR (the ``lqr``'s one gain at the
  middle of the H_11 range) given the same measured H_11, c_1, Q_1 and
  feed-forward as ``lqr_gs``, / ``lqr_gs``: the share of the scheduled gains.

Per cell also: the fraction of time any amplifier saturates (over all runs),
the gripper's peak speed (m/s) and whether any run diverged. Every cell is
one task of :func:`manipcad.parallel.run_tasks` (Dask; ``workers=1`` serial),
cached under ``out_dir/cache`` by a hash of its inputs; its 14 closed-loop runs
(:func:`cell_plan`) are the units of work, handed out longest first
(:func:`run_cost`), in batches that shrink to single runs at the end
(:func:`manipcad.parallel.executor.guided`), so that the workers finish
together, and combined into the cell (:func:`cell_result`) whichever way they
ran. On a cluster the rows are sized (:func:`size_row`) in a child process forked
first (:class:`manipcad.parallel.child.ChildCall`), on the other core, while this
process imports distributed and starts the cluster. The cells simulate with
the general compiled kernels (``use_generated=False``): the simulator otherwise
uses a robot's generated kernels when some process has generated them, which
agree to about 1e-8 but not bit for bit, and a cell's result must not depend on
what another process left in the kernel cache.

Files: ``claims.json`` (rows over the load ratio,
columns over the speed scale), ``claims.png`` (one heat map per claim, the
threshold as a contour, saturated cells hatched) and ``report.html``.
"""

from __future__ import annotations

import datetime as _dt
import functools
import gc
import json
import math
import os
import shutil
import warnings
from collections.abc import Callable
from contextlib import ExitStack
from pathlib import Path
from typing import Any

import numpy as np

import manipcad
from manipcad.control import synthesize
from manipcad.control.design import inertia_range
from manipcad.drives.linear import inertia_ratio
from manipcad.dynamics import mass_matrix
from manipcad.errors import InputError, ManipcadWarning
from manipcad.fileio import json_safe, writable_folder
from manipcad.folders import clean_stale, temp_dir
from manipcad.model.robot import Robot
from manipcad.parallel import Pool, Split, run_tasks
from manipcad.parallel.child import ChildCall
from manipcad.parallel.executor import check_workers, default_workers, progress_reporter
from manipcad.report.claims import claims_html, draw_band, panel_groups, save_bands
from manipcad.sim import SimulationDiverged, simulate
from manipcad.sizing import required_drive
from manipcad.study.fig3 import (
    LAWS,
    LIFT,
    REACH,
    SKIP_ERRORS,
    TURN,
    _Hold,
    control_period,
    support_regulators,
)
from manipcad.trajectories import cosine, gripper_speed

#: the grids: speed scales (1 included) and load ratios (1.4 to 10)
#: (None: the arm's own load ratio, the arm unchanged; on the light arm the cell at speed
#: scale 1 is then the Fig. 3 experiment)
GRIDS = {
    "quick": {"speed_scale": [0.5, 1.0, 1.5, 2.0], "load_ratio": [None, 2.5, 5.0, 10.0]},
    "full": {"speed_scale": [0.25, 0.5, 0.75, 1.0, 1.25, 1.5, 2.0],
             "load_ratio": [None, 1.9, 2.5, 3.5, 5.0, 7.0, 10.0]},
}
#: the arm presets: name -> (catalog robot, rated payload at the gripper, kg: the largest
#: payload used to raise the load ratio)
ARMS = {"light": ("cylindrical", 2.0), "industrial": ("cylindrical_industrial", 2.0),
        "heavy": ("cylindrical_heavy", 5.0)}
#: the largest payload at the gripper of an arm given as a file, kg
MAX_PAYLOAD = 2.0
#: the load-ratio levers' last resort: a payload up to this many times the arm's rated one
#: (:func:`arm_with_load_ratio`; the sizing then slows laws (2) where a part fails)
OVERLOAD_MAX = 2.5
#: the reach-stroke lever (:func:`arm_with_load_ratio`): at its end the reach's retracted
#: position is moved SHIFT_MAX m towards the turning axis and the stroke of laws (2)'s q3
#: (0.5 m) lengthened to STROKE_MAX m
SHIFT_MAX, STROKE_MAX = 0.55, 1.0
#: the reach stroke of laws (2), m (q3 = 0.25(1 − cos 16t))
STROKE = 0.5
#: the gear-ratio lever: |i_r| at least this fraction of the arm's own
RATIO_MIN_FRACTION = 0.1
#: laws (2) are time-scaled down to at most this speed scale; below it a cell is skipped
SPEED_SCALE_MIN = 0.05
#: the claims: id -> (paper's words, threshold of the measured ratio)
CLAIMS = {
    "ace_tf_observable": ("ACE (1) considerably increases the dynamic accuracy (Fig. 3, curve 2 "
                          "against curve 1).", 2.0),
    "ace_tf_controllable": ("ACE (1) considerably increases the dynamic accuracy (Fig. 3, "
                            "curve 2 against curve 1).", 2.0),
    "law3": ("At gripper speeds above 1.5-2 m/s law (3) stabilizes the drive exactly at any "
             "rate of change of H*, h* (Fig. 3, curve 3).", 1.1),
    "law3_no_friction": ("Law (3) stabilizes the drive exactly (its exactness alone, without "
                         "its dry-friction term).", 1.1),
    "asvs_rise": ("Adaptation makes the drive about 2 times faster (sliding regime).", 1.6),
    "asvs_sliding_rate": ("Adaptation makes the drive about 2 times faster (sliding regime: "
                          "the decay rate of the error once sliding).", 1.6),
    "lqr_gs": ("Self-adaptation (gains scheduled over H_ii, h_i, Q_i) raises the accuracy "
               "6-8 times.", 6.0),
    "lqr_gs_gains_only": ("Self-adaptation raises the accuracy 6-8 times (the scheduled gains "
                          "alone: both without feed-forward).", 6.0),
    "lqr_gs_feedforward": ("Self-adaptation raises the accuracy 6-8 times (scheduled gains and "
                           "the feed-forward at the current load, no measured load torque).",
                           6.0),
    "lqr_equal_information": ("Self-adaptation raises the accuracy 6-8 times (against a "
                              "fixed-gain LQR given the same measured signals and feed-forward: "
                              "the scheduled gains' own share).", 6.0),
}
#: the tracking runs of a cell: label -> (method, options)
TRACKING = {
    "none_sce": ("none_sce", {}),
    "ace_tf_observable": ("ace_tf", {"realization": "observable"}),
    "ace_tf_controllable": ("ace_tf", {"realization": "controllable"}),
    "ace_de": ("ace_de", {}),
    "ace_de_no_friction": ("ace_de", {"friction": False}),
    "lqr": ("lqr", {}),
    "lqr_no_feedforward": ("lqr", {"feedforward": False}),
    "lqr_gs_gains_only": ("lqr_gs", {"feedforward": False, "load_torque": False}),
    "lqr_gs_feedforward": ("lqr_gs", {"feedforward": True, "load_torque": False}),
    "lqr_gs": ("lqr_gs", {}),
    # one gain (the lqr's, at the middle of the H_11 range) with the lqr_gs's measured
    # H_11, c_1, Q_1 and its feed-forward at the current load: load_range set per cell
    "lqr_equal_information": ("lqr_gs", {"load_range": "nominal"}),
}
#: ratio id -> (numerator run, denominator run)
RATIOS = {
    "ace_tf_observable": ("none_sce", "ace_tf_observable"),
    "ace_tf_controllable": ("none_sce", "ace_tf_controllable"),
    "law3": ("ace_tf_observable", "ace_de"),
    "law3_no_friction": ("ace_tf_observable", "ace_de_no_friction"),
    "lqr_gs": ("lqr", "lqr_gs"),
    "lqr_gs_gains_only": ("lqr_no_feedforward", "lqr_gs_gains_only"),
    "lqr_gs_feedforward": ("lqr", "lqr_gs_feedforward"),
    "lqr_equal_information": ("lqr_equal_information", "lqr_gs"),
}
#: the step of the turning drive, rad, and the length of a step run, s
STEP, STEP_T_END = 0.1, 0.4
#: a cell whose turning gear ratio the load-ratio lever lowered runs its steps longer, by
#: |i_r of the arm| / |i_r of the cell| (the joint's torque is that much smaller), up to
STEP_T_END_MAX = 4.0
#: a cell's code version (part of its cache key)
CELL_VERSION = "8"
#: an amplifier counts as saturated within this fraction of its limit
SATURATION_TOL = 1e-6
#: claims.png's resolution, dots per inch
FIGURE_DPI = 100


def _tool_point(arm: Robot) -> np.ndarray:
    return np.asarray(arm.tool_p, dtype=float)


def turn_load_range(arm: Robot, stroke: float = STROKE) -> tuple[float, float]:
    """H_11 (links only, kg·m²): its least and largest value over the reach stroke.

    Sampled at 201 points of q3 in [0, stroke] m (lift and turn at 0: H_11 does not
    depend on them); on the unchanged Fig. 2 arm these are q3 = 0 and 0.5 m.

    Example:
        >>> import manipcad
        >>> lo, hi = turn_load_range(manipcad.load_robot("cylindrical"))
        >>> round(lo, 4), round(hi, 4)
        (0.4738, 0.7652)
    """

    j, k = arm.joint_index(TURN), arm.joint_index(REACH)
    q = np.zeros((201, arm.n))
    q[:, k] = np.linspace(0.0, stroke, 201)
    H = mass_matrix(arm, q, drives=False)[:, j, j]
    return float(H.min()), float(H.max())


def _restroked(arm: Robot, lam: float) -> tuple[Robot, float, float]:
    """The arm with the reach-stroke lever at ``lam`` in [0, 1]: (arm, shift m, stroke m)."""
    if lam <= 0.0:
        return arm, 0.0, STROKE
    k = arm.joint_index(REACH)
    shift, stroke = SHIFT_MAX * lam, STROKE + (STROKE_MAX - STROKE) * lam
    offset = np.array(arm.offset, dtype=float)
    offset[k] -= shift
    changes = {"offset": offset}
    if arm.limits is not None:
        limits = np.array(arm.limits, dtype=float)
        limits[k] = (0.0, max(limits[k, 1], stroke))
        changes["limits"] = limits
    return arm.replace(**changes), shift, stroke


def _h_ratio(arm: Robot, m_p: float, lam: float) -> float:
    new, _, stroke = _restroked(arm, lam)
    if m_p > 0:
        new = new.with_payload(m_p, _tool_point(arm), link=REACH)
    lo, hi = turn_load_range(new, stroke)
    return hi / lo


def _bisect(f, lo: float, hi: float, target: float, tol: float = 1e-6) -> float:
    """The least x in [lo, hi] with f(x) >= target, f increasing (f(hi) >= target)."""
    for _ in range(60):
        if hi - lo <= tol * max(1.0, abs(hi)):
            break
        mid = 0.5 * (lo + hi)
        if f(mid) >= target:
            hi = mid
        else:
            lo = mid
    return hi


def arm_with_load_ratio(arm: Robot, rho: float, *, max_payload: float = MAX_PAYLOAD
                        ) -> tuple[Robot, dict[str, Any]]:
    """The arm changed so that the turning motor's load ratio is ``rho`` (or as near as it goes).

    ρ = (J·i_r² + H_max)/(J·i_r² + H_min), H over the reach stroke. The levers, the least
    change first, each only as far as needed for H_max/H_min ≥ 1.05·ρ:

    1. a payload m_p at the gripper (the tool point on the reach link), up to
       ``max_payload`` kg;
    2. with ``max_payload`` not enough, the reach stroke: its retracted position moved
       towards the turning axis by up to ``SHIFT_MAX`` m and laws (2)'s q3 stroke
       lengthened from 0.5 m to up to ``STROKE_MAX`` m, together (one lever λ in [0, 1];
       the reach link's mass is kept: a longer tube is not added);
    3. with the stroke at its end still not enough, a payload above ``max_payload``, up
       to ``OVERLOAD_MAX`` times it (``info["over_rated"]``: the rotor inertia can only
       lower ρ, so past this point no gear ratio reaches it; the row's laws (2) are then
       time-scaled by the sizing where a motor or gear fails, see
       :func:`feasible_speed_scale`);
    4. then the turning gear ratio so that J·i_r² = (H_max − ρ·H_min)/(ρ − 1) (its sign
       kept; |i_r| at least ``RATIO_MIN_FRACTION`` of the arm's own).

    When the levers at their ends do not reach ρ, the arm at those ends is returned and
    ``info["reached"]`` is False: ``info["load_ratio"]`` is always the ratio achieved.

    Args:
        arm: an arm with joints turn, lift, reach and a drive on turn.
        rho: the load ratio wanted, > 1.
        max_payload: the largest payload at the gripper, kg (>= 0).

    Returns:
        ``(arm, info)``: the new arm and {"payload_kg", "over_rated", "shift_m", "stroke_m",
        "ratio", "H_11_min", "H_11_max", "load_ratio", "target", "reached"} (kg, bool, m, m,
        rad/rad, kg·m², kg·m², 1, 1, bool).

    The arm's own ratio (:func:`own_load_ratio`) returns the arm unchanged.

    Example:
        >>> import manipcad
        >>> arm, info = arm_with_load_ratio(manipcad.load_robot("cylindrical"), 1.9)
        >>> round(info["load_ratio"], 9), round(info["payload_kg"], 3), info["stroke_m"]
        (1.9, 0.436, 0.5)
    """
    if not (isinstance(rho, int | float) and math.isfinite(rho) and rho > 1.0):
        raise InputError("load_ratio", "", f"must be a number > 1, got {rho!r}")
    if not (isinstance(max_payload, int | float) and math.isfinite(max_payload)
            and max_payload >= 0):
        raise InputError("max_payload", "", f"must be a number >= 0 kg, got {max_payload!r}")
    j = arm.joint_index(TURN)
    d = arm.drives[j]
    own = own_load_ratio(arm)
    hmin, hmax = turn_load_range(arm)
    base = {"payload_kg": 0.0, "over_rated": False, "shift_m": 0.0, "stroke_m": STROKE,
            "ratio": d.ratio, "H_11_min": hmin, "H_11_max": hmax, "load_ratio": own,
            "target": float(rho), "reached": True}
    if abs(rho / own - 1.0) < 1e-9:
        return arm, base
    target = 1.05 * rho
    m_p, lam = 0.0, 0.0
    if hmax / hmin < target and max_payload > 0:
        m_p = (max_payload if _h_ratio(arm, max_payload, 0.0) < target
               else _bisect(lambda m: _h_ratio(arm, m, 0.0), 0.0, max_payload, target))
    if _h_ratio(arm, m_p, 0.0) < target:
        lam = (1.0 if _h_ratio(arm, m_p, 1.0) < target
               else _bisect(lambda x: _h_ratio(arm, m_p, x), 0.0, 1.0, target))
    if lam >= 1.0 and max_payload > 0 and _h_ratio(arm, m_p, 1.0) < target:
        top = OVERLOAD_MAX * max_payload
        m_p = (top if _h_ratio(arm, top, 1.0) < target
               else _bisect(lambda m: _h_ratio(arm, m, 1.0), m_p, top, target))
    new, shift, stroke = _restroked(arm, lam)
    if m_p > 0:
        new = new.with_payload(m_p, _tool_point(arm), link=REACH)
    hmin, hmax = turn_load_range(new, stroke)
    Jr2 = max((hmax - rho * hmin) / (rho - 1.0), d.J * (RATIO_MIN_FRACTION * d.ratio) ** 2)
    ratio = math.copysign(math.sqrt(Jr2 / d.J), d.ratio)
    drives = list(new.drives)
    drives[j] = d.replace(ratio=ratio)
    new = new.replace(drives=tuple(drives))
    got = inertia_ratio(drives[j], hmin, hmax)
    return new, {"payload_kg": m_p, "over_rated": bool(m_p > max_payload), "shift_m": shift,
                 "stroke_m": stroke, "ratio": ratio, "H_11_min": hmin, "H_11_max": hmax,
                 "load_ratio": got, "target": float(rho),
                 "reached": bool(abs(got / rho - 1.0) < 1e-6)}


def own_load_ratio(arm: Robot) -> float:
    """The turning motor's load ratio (J·i_r² + H_max)/(J·i_r² + H_min) of the arm as it is.

    Example:
        >>> import manipcad
        >>> round(own_load_ratio(manipcad.load_robot("cylindrical")), 3)
        1.422
    """
    lo, hi = turn_load_range(arm)
    return inertia_ratio(arm.drives[arm.joint_index(TURN)], lo, hi)


def laws(speed_scale: float, stroke: float = STROKE):
    """Laws (2) at speed scale s with a reach stroke (m): q1 = 0.5(1 − cos 4s·t) rad,
    q3 = stroke/2·(1 − cos 16s·t) m, for 1.6/s s.

    Example:
        >>> laws(2.0).duration
        0.8
    """

    s = float(speed_scale)
    amp = list(LAWS["amplitude"])
    amp[2] = 0.5 * stroke
    return cosine(amp, [w * s for w in LAWS["omega"]], LAWS["duration"] / s)


def sizing_failures(arm: Robot, speed_scale: float, stroke: float = STROKE) -> list[str]:
    """The motor and gear limits the arm fails on laws (2) at this speed scale.

    Runs :func:`manipcad.sizing.required_drive` (1 ms grid) and lists "joint: limit" for
    every check whose status is "fail" (an unknown rating is not a failure).

    Example:
        >>> import manipcad
        >>> sizing_failures(manipcad.load_robot("cylindrical"), 1.0)
        []
    """

    req = required_drive(arm, laws(speed_scale, stroke), dt=1e-3)
    return [f"{arm.joint_names[j]}: {name}" for name, c in req.checks.items()
            for j, st in enumerate(c.status) if st == "fail"]


def feasible_speed_scale(arm: Robot, speed_scale: float, stroke: float = STROKE, *,
                         known: dict[float, list[str]] | None = None
                         ) -> tuple[float | None, list[str]]:
    """The speed scale a cell runs at: ``speed_scale`` if the sizing passes, else laws (2)
    time-scaled to the largest feasible speed scale below it.

    The bisection (geometric, from ``SPEED_SCALE_MIN`` to ``speed_scale``) takes the
    sizing's failures to grow with the speed scale: a point at or below a speed scale
    known to pass passes, one at or above a speed scale known to fail fails, without
    running the sizing there; ``SPEED_SCALE_MIN`` itself (the longest trajectory, 32 s of
    laws (2): a third of a row's sizing) is sized only when no point of the bisection
    passed.

    Args:
        arm, speed_scale, stroke: as :func:`sizing_failures`.
        known: {speed scale: :func:`sizing_failures` there} already computed (read, and
            completed with every speed scale sized here).

    Returns:
        ``(s_run, failures)``: s_run (``speed_scale`` itself, or the largest feasible
        value found by bisection to 1 %, rounded down to 3 significant digits; None when
        not even ``SPEED_SCALE_MIN`` passes) and the limits failed at ``speed_scale``.

    Example:
        >>> import manipcad
        >>> feasible_speed_scale(manipcad.load_robot("cylindrical"), 1.0)
        (1.0, [])
    """
    memo = known if known is not None else {}

    def failures(s: float) -> list[str]:
        if s not in memo:
            memo[s] = sizing_failures(arm, s, stroke)
        return memo[s]

    def fails(s: float) -> bool:
        if any(k <= s and f for k, f in memo.items()):
            return True
        if any(k >= s and not f for k, f in memo.items()):
            return False
        return bool(failures(s))

    fails_here = failures(float(speed_scale))
    if not fails_here:
        return float(speed_scale), []
    lo, hi = SPEED_SCALE_MIN, float(speed_scale)
    while hi / lo > 1.01:
        mid = math.sqrt(lo * hi)
        if fails(mid):
            hi = mid
        else:
            lo = mid
    if lo == SPEED_SCALE_MIN and fails(SPEED_SCALE_MIN):
        return None, fails_here
    e = math.floor(math.log10(lo)) - 2
    return round(math.floor(lo / 10.0**e) * 10.0**e, -e), fails_here


def _saturation(res, arm: Robot) -> float:
    """Fraction of the samples at which any drive's amplifier is at its limit."""
    sat = np.zeros(res.t.shape, dtype=bool)
    for j, d in enumerate(arm.drives):
        if d is None or not math.isfinite(d.u_max):
            continue
        sat |= np.abs(d.k_u * res.u[:, j]) >= d.u_max * (1.0 - SATURATION_TOL)
    return float(sat.mean()) if sat.size else 0.0


def claims_cell(*, speed_scale: float, load_ratio: float, arm: Robot, dt: float,
                max_payload: float = MAX_PAYLOAD) -> dict:
    """One cell of the claims maps: every run and the ratios (SI units; see the module).

    ``speed_scale`` is the speed scale the laws run at (after any time scaling, see
    :func:`feasible_speed_scale`); the arm is :func:`arm_with_load_ratio` of ``arm``.
    The same as :func:`cell_plan`, :func:`claims_run` on each of its runs, then
    :func:`cell_result` (what the executor does run by run on a cluster).

    Returns a dict with "max_error" (rad per tracking run), "rise_time" (s),
    "overshoot" (fraction), "ratio" (claim id -> measured ratio), "saturation",
    "peak_gripper_speed" (m/s), "diverged", "skipped" (run -> reason), "arm" (the
    load-ratio change).
    """
    state, runs = cell_plan(speed_scale=speed_scale, load_ratio=load_ratio, arm=arm, dt=dt,
                            max_payload=max_payload)
    return cell_result(state, [claims_run(**r) for r in runs])


def cell_plan(*, speed_scale: float, load_ratio: float, arm: Robot, dt: float,
              max_payload: float = MAX_PAYLOAD,
              row: tuple[Robot, dict] | None = None) -> tuple[dict, list[dict]]:
    """A cell's arm and its closed-loop runs, each the arguments of :func:`claims_run`.

    ``row``: the row's ``arm_with_load_ratio(arm, load_ratio, max_payload=max_payload)``
    when already computed (:func:`size_row`'s "robot" and "arm"), not computed again.

    Returns:
        ``(state, runs)``: state {"arm": the load-ratio change (see
        :func:`arm_with_load_ratio`), "peak_gripper_speed": m/s, "step_t_end": s} for
        :func:`cell_result`; runs: one dict per run (label, robot, regulator method and
        options, dt s, t_end s, trajectory, q0 rad/m, kind "tracking" or "step").

    Example:
        >>> import manipcad
        >>> state, runs = cell_plan(speed_scale=1.0, load_ratio=2.5, dt=1e-4,
        ...                         arm=manipcad.load_robot("cylindrical"))
        >>> len(runs), runs[0]["label"], runs[0]["t_end"], round(state["step_t_end"], 3)
        (14, 'none_sce', 1.6, 0.514)
    """

    cell_arm, info = row if row is not None else arm_with_load_ratio(
        arm, load_ratio, max_payload=max_payload)
    s = float(speed_scale)
    duration = LAWS["duration"] / s
    traj = laws(s, info["stroke_m"])
    peak = float(np.max(gripper_speed(cell_arm, traj, np.linspace(0.0, duration, 801))))
    j1 = cell_arm.joint_index(TURN)
    h_lo, h_hi = inertia_range(cell_arm, j1)
    common = {"arm": cell_arm, "dt": dt}
    runs = []
    for label, (method, options) in TRACKING.items():
        if options.get("load_range") == "nominal":
            mid = 0.5 * (h_lo + h_hi)
            options = {**options, "load_range": (mid, mid)}
        runs.append({**common, "label": label, "method": method, "options": options,
                     "t_end": duration, "trajectory": traj, "q0": None, "kind": "tracking"})
    j3 = cell_arm.joint_index(REACH)
    slower = abs(arm.drives[j1].ratio / info["ratio"])
    step_t_end = min(STEP_T_END * max(1.0, slower), max(STEP_T_END, STEP_T_END_MAX))
    steps = {"vss": ("vss", {}, 0.0), "asvs": ("asvs", {}, 0.0),
             "vss_light": ("vss", {"load_range": (info["H_11_min"], info["H_11_min"])},
                           info["stroke_m"])}
    for label, (method, options, q3) in steps.items():
        q0 = np.zeros(cell_arm.n)
        q0[j3] = q3
        ref = q0.copy()
        ref[j1] = STEP
        runs.append({**common, "label": label, "method": method, "options": options,
                     "t_end": step_t_end, "trajectory": _Hold(ref), "q0": q0,
                     "kind": "step"})
    return {"arm": info, "peak_gripper_speed": peak, "step_t_end": step_t_end}, runs


def claims_run(*, arm: Robot, label: str, method: str, options: dict, dt: float,
               t_end: float, trajectory, q0, kind: str) -> dict:
    """One closed-loop run of a cell (:func:`cell_plan`): the method on the turning drive,
    the support PIDs on the lift and the reach, the general compiled kernels.

    Returns:
        {"label", "skipped": reason or None, "diverged": bool, "warning": text or None,
        "saturation": fraction of samples, "metrics": {"max_error": rad} (tracking) or
        {"rise_time": s, "overshoot": fraction, "sliding_rate": 1/s} (step), values None
        where not finite}; metrics None when skipped.
    """

    out = {"label": label, "skipped": None, "diverged": False, "warning": None,
           "saturation": 0.0, "metrics": None}
    period = control_period(dt)
    try:
        reg = synthesize(arm, TURN, method, period=period, **options)
    except SKIP_ERRORS as exc:
        out["skipped"] = f"{type(exc).__name__}: {exc}"
        return out
    sim = {"t_end": t_end, "trajectory": trajectory}
    if q0 is not None:
        sim["q0"] = q0
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", ManipcadWarning)
            res = simulate(arm, dt=dt, regulators=[reg, *support_regulators(arm, period)],
                           use_generated=False, **sim)
    except SimulationDiverged as exc:
        out["diverged"] = True
        out["skipped"] = f"diverged: {exc}"
        return out
    for w in caught:  # kept with the cell (e.g. joints past their limits), not printed
        if issubclass(w.category, ManipcadWarning):
            out["warning"] = str(w.message)
    out["saturation"] = _saturation(res, arm)

    def finite(v):
        return float(v) if math.isfinite(v) else None

    m = res.metrics[TURN]
    if kind == "tracking":
        out["metrics"] = {"max_error": finite(m["max_error"])}
    else:
        j1 = arm.joint_index(TURN)
        out["metrics"] = {"rise_time": finite(m["rise_time"]),
                          "overshoot": finite(m["overshoot"]),
                          "sliding_rate": sliding_rate(res.t, res.q_ref[:, j1] - res.q[:, j1],
                                                       STEP)}
    return out


def cell_result(state: dict, runs: list[dict]) -> dict:
    """A cell's result from its plan's state and its runs' results (:func:`claims_cell`)."""
    out: dict[str, Any] = {"max_error": {}, "rise_time": {}, "overshoot": {}, "ratio": {},
                           "saturation": 0.0, "diverged": False, "skipped": {},
                           "warnings": {}, "sliding_rate": {}, "arm": state["arm"],
                           "peak_gripper_speed": state["peak_gripper_speed"]}
    sat = 0.0
    for r in runs:
        label = r["label"]
        out["diverged"] = out["diverged"] or r["diverged"]
        if r["skipped"] is not None:
            out["skipped"][label] = r["skipped"]
            continue
        if r["warning"] is not None:
            out["warnings"][label] = r["warning"]
        sat = max(sat, r["saturation"])
        m = r["metrics"]
        if "max_error" in m:
            out["max_error"][label] = m["max_error"]
        else:
            out["rise_time"][label] = m["rise_time"]
            out["overshoot"][label] = m["overshoot"]
            out["sliding_rate"][label] = m["sliding_rate"]
    out["step_t_end"] = state["step_t_end"]
    step_t_end = state["step_t_end"]
    mx = out["max_error"]
    for cid, (a, b) in RATIOS.items():
        out["ratio"][cid] = _ratio(mx.get(a), mx.get(b))
    out["ratio"]["asvs_rise"] = _ratio(out["rise_time"].get("vss"), out["rise_time"].get("asvs"))
    if out["rise_time"].get("vss") is None and out["rise_time"].get("asvs"):
        # the vss does not reach 90 % of the step within the step run: a lower bound
        out["ratio_lower_bound"] = {"asvs_rise": step_t_end / out["rise_time"]["asvs"]}
    out["ratio"]["asvs_sliding_rate"] = _ratio(out["sliding_rate"].get("asvs"),
                                               out["sliding_rate"].get("vss"))
    out["saturation"] = sat
    return out


def warm_worker() -> None:
    """Load the simulator's compiled kernels in this process (a spawned worker, e.g. of a
    cluster the user runs, at its start; forked workers have the study's process's):
    a 1 ms closed-loop run of the Fig. 2 arm, so the first cell does not pay for it;
    and import what draws the figure's panels (matplotlib's Agg canvas and its font
    list), so the last task does not either.

    Then the objects alive are frozen (``gc.collect(); gc.freeze()``): the worker's
    collector no longer scans the imported modules and loaded kernels (about 300,000
    objects) in every full collection of the study's tasks. A forked worker inherits
    them frozen already (:mod:`manipcad.parallel`); a worker of a cluster the user runs
    (spawned, ``--scheduler``) spent 0.22-0.24 s per study in the collector without,
    0.02 s with. Cyclic garbage among the frozen objects is not collected later
    (reference counting still frees the rest)."""

    # deferred: the warm-up itself: imported ahead in the worker (see above)
    import matplotlib.backends.backend_agg  # noqa: F401
    import matplotlib.figure  # noqa: F401


    arm = manipcad.load_robot(ARMS["light"][0])
    period = control_period(1e-4)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        simulate(arm, t_end=1e-3, dt=1e-4, use_generated=False,
                 regulators=[synthesize(arm, TURN, "none_sce", period=period),
                             *support_regulators(arm, period)])
    gc.collect()
    gc.freeze()


#: a run's time estimate (:func:`run_cost`), s of simulated time: the cost of a step run's
#: simulated second against a tracking run's, and the gain table of a scheduled LQR
COST_STEP, COST_TABLE = 0.4, 1.3


def run_cost(run: dict) -> float:
    """A run's time estimate (for handing out the longest first), in simulated seconds of
    a tracking run: its length, plus the gain table's synthesis of an ``lqr_gs`` over a
    load range (measured on the light arm: a 1.6 s tracking run about 0.35 s, a table
    about 0.3 s, a step run's second 0.4 of a tracking run's).

    Example:
        >>> run_cost({"t_end": 1.6, "kind": "tracking", "method": "lqr", "options": {}})
        1.6
    """
    c = float(run["t_end"]) * (1.0 if run["kind"] == "tracking" else COST_STEP)
    lr = run["options"].get("load_range")
    if run["method"] == "lqr_gs" and not (isinstance(lr, tuple) and lr[0] == lr[1]):
        c += COST_TABLE
    return c


def sliding_rate(t: np.ndarray, e: np.ndarray, step: float) -> float | None:
    """The error's decay rate in the sliding phase of a step response, 1/s.

    ln(5) / (the time from |e| = 0.5·|step| to |e| = 0.1·|step|, both crossed last
    from above): the reaching phase (before the error first falls to half the step)
    is left out, and a sliding error e(t) = e_0·exp(−c·t) gives its slope c.
    None when the error does not fall below 10 % of the step.

    Example:
        >>> import numpy as np
        >>> t = np.linspace(0.0, 1.0, 10001)
        >>> round(sliding_rate(t, 0.1 * np.exp(-20.0 * t), 0.1), 3)
        20.0
    """
    a = np.abs(np.asarray(e, dtype=float)) / abs(step)
    below = np.flatnonzero(a <= 0.1)
    if below.size == 0:
        return None
    k10 = int(below[0])
    above = np.flatnonzero(a[:k10] > 0.5)
    if above.size == 0:
        return None
    k50 = int(above[-1]) + 1

    def crossing(k: int, level: float) -> float:  # linear between samples k-1 and k
        if k == 0 or a[k - 1] == a[k]:
            return float(t[k])
        return float(t[k - 1] + (a[k - 1] - level) / (a[k - 1] - a[k]) * (t[k] - t[k - 1]))

    dt = crossing(k10, 0.1) - crossing(k50, 0.5)
    return math.log(5.0) / dt if dt > 0 else None


def _ratio(a, b):
    if a is None or b is None or not (math.isfinite(a) and math.isfinite(b)) or b <= 0:
        return None
    return a / b


def _where(claim: str, grid: dict, ratio: list[list], threshold: float) -> str:
    """One sentence: the cells (ρ achieved, speed scale run) where the ratio reaches the
    threshold."""
    runs = grid.get("speed_scale_run")
    holds = [(rho, s if runs is None else runs[i][k])
             for i, rho in enumerate(grid["load_ratio"])
             for k, s in enumerate(grid["speed_scale"])
             if ratio[i][k] is not None and ratio[i][k] >= threshold]
    total = sum(1 for row in ratio for v in row if v is not None)
    if not holds:
        return f"nowhere on this grid (0 of {total} cells reach {threshold:g})"
    rhos = sorted({r for r, _ in holds})
    speeds = sorted({s for _, s in holds})
    return (f"in {len(holds)} of {total} cells: load ratios "
            f"{', '.join(f'{r:.3g}' for r in rhos)} at speed scales (as run) "
            f"{', '.join(f'{s:.3g}' for s in speeds)}")


def resolve_arm(arm: str | Robot, study: str = "claims") -> tuple[Robot, str, float]:
    """The arm of a study: ``(robot, name, largest payload kg)`` from a preset name
    (``ARMS``), a robot file or a Robot, checked to have joints turn, lift, reach with drives.

    Raises:
        InputError: the file cannot be read; the arm's joints are not exactly turn
            (revolute), lift and reach (prismatic), each with a drive (the message names
            the joints the arm has and what is missing).

    Example:
        >>> robot, name, m = resolve_arm("heavy")
        >>> robot.name, m
        ('cylindrical arm, heavy preset (5 kg payload)', 5.0)
    """

    if isinstance(arm, Robot):
        robot, arm_name, max_payload = arm, arm.name, MAX_PAYLOAD
    elif arm in ARMS:
        robot, arm_name, max_payload = manipcad.load_robot(ARMS[arm][0]), arm, ARMS[arm][1]
    else:
        robot, arm_name, max_payload = manipcad.load_robot(arm), str(arm), MAX_PAYLOAD
    want = {TURN: "revolute", LIFT: "prismatic", REACH: "prismatic"}
    has = ", ".join(f"{nm} ({jt})" for nm, jt in zip(robot.joint_names, robot.joint_types,
                                                      strict=True))
    need = (f"the {study} study runs the paper's cylindrical arm (laws (2) move three joints): "
            "it needs exactly the joints turn (revolute, about the vertical), lift "
            "(prismatic) and reach (prismatic), in this order, each with a drive")
    if tuple(robot.joint_names) != tuple(want):
        missing = [nm for nm in want if nm not in robot.joint_names]
        raise InputError(str(arm_name), "joints", f"{need}; this arm has {has}"
                         + (f" (no {', '.join(missing)})" if missing else "")
                         + ": name its joints so, or use --arm light, industrial or heavy")
    for name, kind in want.items():
        j = robot.joint_index(name)
        if robot.joint_types[j] != kind:
            raise InputError(str(arm_name), name, f"{need}; joint {name!r} is "
                             f"{robot.joint_types[j]}")
        if robot.drives[j] is None:
            raise InputError(str(arm_name), name, f"{need}; joint {name!r} has no drive")
    return robot, arm_name, max_payload


def run_claims(out_dir: str | Path, *, arm: str | Robot = "light", grid: str = "quick",
               workers: int | None = None, scheduler: str | None = None, dt: float = 1e-4,
               progress: bool | Callable[[float], None] = True) -> dict:
    """Run the claims maps and write claims.json, claims.png and report.html into ``out_dir``.

    Args:
        out_dir: the output folder (created; its parent must exist); the cells'
            cache is kept in ``out_dir/cache``.
        arm: "light" (the catalog Fig. 2 arm), "industrial", "heavy" (the presets,
            ``ARMS``), a robot file or a Robot with joints turn, lift, reach and drives
            (the largest payload then ``MAX_PAYLOAD``).
        grid: "quick" (4 × 4 cells) or "full" (7 × 7).
        workers, scheduler: as :func:`manipcad.parallel.run_tasks` (default one
            worker process per core; 1: serial).
        dt: integration step, s.
        progress: show a progress bar of cells done; or a callable, called with the
            fraction of the cells done (0..1).

    Returns:
        The claims.json document.

    Raises:
        InputError: bad arguments, arm or output folder.

    Example:
        >>> from manipcad.study.claims import run_claims
        >>> doc = run_claims("/tmp/claims", workers=1)  # doctest: +SKIP
        >>> sorted(doc["claims"])  # doctest: +SKIP
    """

    check_workers(workers, scheduler, "study claims")
    if grid not in GRIDS:
        raise InputError("--grid", "", f"{grid!r}: expected one of {', '.join(GRIDS)}")
    if not (isinstance(dt, int | float) and math.isfinite(dt) and 0 < dt <= 1e-3):
        raise InputError("dt", "", f"must be in (0, 1e-3] s, got {dt!r}")
    out = writable_folder(out_dir)
    robot, arm_name, max_payload = resolve_arm(arm, "claims")
    g = dict(GRIDS[grid])
    targets = [own_load_ratio(robot) if r is None else r for r in g["load_ratio"]]
    g["load_ratio"] = targets
    # per row the arm; per cell the speed scale the sizing allows (laws (2) time-scaled
    # where the motors or gears are over their limits)
    size = functools.partial(_size_rows, robot, max_payload, g["speed_scale"], targets)
    created = not out.exists()
    out.mkdir(exist_ok=True)
    clean_stale(out, "claims")  # the files' folder of a writer killed earlier
    try:
        return _run_claims(out, robot, arm_name, max_payload, g, size, dt, workers,
                           scheduler, progress)
    except BaseException:
        # a run that failed before any cell was cached (a scheduler not reachable, bad
        # arguments found late, Ctrl-C) leaves no folder it made; cached cells are kept
        # for the next run to resume from
        if created and not any((out / "cache").glob("*/*.pkl")):
            shutil.rmtree(out, ignore_errors=True)
        raise


def _run_claims(out: Path, robot: Robot, arm_name: str, max_payload: float, g: dict,
                size: Callable[[], list[dict]], dt: float, workers: int | None,
                scheduler: str | None, progress: bool | Callable[[float], None]) -> dict:
    """:func:`run_claims` once its arguments are checked and ``out`` exists."""

    with ExitStack() as stack:
        # a fresh run on a cluster: the rows are sized in a child process forked first,
        # on the other core, while this one imports distributed and starts the cluster
        # (and the workers load their kernels); with cached cells the cluster is started,
        # by run_tasks, only if some cell is missing
        pool = None
        fresh = not any((out / "cache").glob("*/*.pkl"))
        if fresh and (scheduler is not None or (workers or default_workers()) > 1):
            size = stack.enter_context(ChildCall(size)).result
            pool = stack.enter_context(Pool(workers=workers, scheduler=scheduler,
                                            warm=warm_worker))
        sized = size()
        mine, res = _compute_cells(out, robot, max_payload, g, sized, dt, pool, progress,
                                   workers, scheduler)
        return _claims_doc(out, robot, arm_name, max_payload, g, sized, mine, res, dt, pool)


def _size_rows(arm: Robot, max_payload: float, speed_scales: list[float],
               targets: list[float]) -> list[dict]:
    """:func:`size_row` of every row, in order."""
    return [size_row(arm=arm, max_payload=max_payload, speed_scales=speed_scales,
                     load_ratio=rho) for rho in targets]


def _compute_cells(out: Path, robot: Robot, max_payload: float, g: dict, sized: list[dict],
                   dt: float, pool, progress, workers: int | None,
                   scheduler: str | None) -> tuple[list[dict], Any]:
    """The grid's cells (a time-scaled cell of a row once), computed or from the cache:
    the tasks and their results."""

    targets, S = g["load_ratio"], len(g["speed_scale"])
    mine = list({(targets[i], s_run): {"speed_scale": s_run, "load_ratio": targets[i]}
                 for i, row in enumerate(sized) for s_run in row["speed_scale_run"]
                 if s_run is not None}.values())
    row_of = {targets[i]: (r["robot"], r["arm"]) for i, r in enumerate(sized)}
    with ExitStack() as stack:
        shown = _cells_progress(stack, progress, len(targets) * S)
        # each cell is cached whole; on a cluster its runs are the units of work,
        # handed out longest first, so that the workers finish together
        res = run_tasks(claims_cell, mine, common={"arm": robot, "dt": dt,
                                                   "max_payload": max_payload},
                        workers=None if pool is not None else workers,
                        scheduler=None if pool is not None else scheduler, pool=pool,
                        cache_dir=out / "cache", progress=shown, version=CELL_VERSION,
                        cost=run_cost,
                        split=Split(plan=lambda task, common: cell_plan(
                            **common, **task, row=row_of[task["load_ratio"]]),
                            run=claims_run, combine=cell_result))
        if shown:
            shown(1.0)
    return mine, res


def _claims_doc(out: Path, robot: Robot, arm_name: str, max_payload: float, g: dict,
                sized: list[dict], mine: list[dict], res, dt: float, pool) -> dict:
    """The claims.json document of the computed cells, written with its figure and report."""
    targets = g["load_ratio"]
    where = {(t["load_ratio"], t["speed_scale"]): k for k, t in enumerate(mine)}
    rows = [r["arm"] for r in sized]
    runs = [r["speed_scale_run"] for r in sized]
    fails = [r["sizing_failures"] for r in sized]
    cells = []
    for i, rho in enumerate(targets):
        for k, s_run in enumerate(runs[i]):
            if s_run is None:
                cells.append(_infeasible_cell(rows[i], g["speed_scale"][k]))
            else:
                cells.append(res[where[(rho, s_run)]])
    R, S = len(g["load_ratio"]), len(g["speed_scale"])

    def table(fn):
        return [[fn(cells[i * S + k]) for k in range(S)] for i in range(R)]

    # the where-sentences name the load ratios achieved and the speed scales run
    g_run = {"speed_scale": g["speed_scale"], "speed_scale_run": runs,
             "load_ratio": [info["load_ratio"] for info in rows]}
    claims = {}
    for cid, (paper, threshold) in CLAIMS.items():
        ratio = table(lambda c, cid=cid: c["ratio"].get(cid))
        claims[cid] = {
            "paper": paper, "threshold": threshold, "ratio": ratio,
            "holds": [[None if v is None else bool(v >= threshold) for v in row]
                      for row in ratio],
            "where_it_holds": _where(cid, g_run, ratio, threshold),
        }
    for cid, label, what in (("asvs_overshoot", "asvs", "overshoot of asvs at the lightest "
                              "load, fraction of the step (paper: none)"),
                             ("vss_light_overshoot", "vss_light", "overshoot of a vss tuned "
                              "for the lightest load, stepped at the heaviest")):
        vals = table(lambda c, label=label: c["overshoot"].get(label))
        claims[cid] = {"paper": what, "threshold": 0.001, "ratio": vals,
                       "holds": [[None if v is None else bool(v <= 0.001) for v in row]
                                 for row in vals],
                       "where_it_holds": _where_below(g, vals, 0.001)}
    doc = {
        "study": "claims",
        "created": _dt.datetime.now(_dt.UTC).isoformat(timespec="seconds"),
        "arm": {"name": arm_name, "robot": robot.name, "max_payload_kg": max_payload,
                "cells": table(lambda c: c["arm"])},
        "grid": {"speed_scale": g["speed_scale"], "load_ratio": g["load_ratio"]},
        "load_ratio_achieved": [[rows[i]["load_ratio"]] * S for i in range(R)],
        "speed_scale_run": runs,
        "time_scaled": [[r != s for r, s in zip(row, g["speed_scale"], strict=True)]
                        for row in runs],
        "sizing_failures": fails,
        "claims": claims,
        "saturation": table(lambda c: c["saturation"]),
        "peak_gripper_speed": table(lambda c: c["peak_gripper_speed"]),
        "diverged": table(lambda c: c["diverged"]),
        "max_error": table(lambda c: c["max_error"]),
        "rise_time": table(lambda c: c["rise_time"]),
        "ratio_lower_bound": table(lambda c: c.get("ratio_lower_bound", {})),
        "sliding_rate": table(lambda c: c.get("sliding_rate", {})),
        "skipped": table(lambda c: c["skipped"]),
        "warnings": table(lambda c: c.get("warnings", {})),
        "settings": {"dt": dt, "period": control_period(dt), "step": STEP,
                     "step_t_end": STEP_T_END,
                     "step_t_end_cells": table(lambda c: c.get("step_t_end")),
                     "laws": "q1 = 0.5(1 − cos 4s·t) rad, q3 = stroke/2·(1 − cos 16s·t) m "
                     "(stroke 0.5 m unless the load-ratio lever lengthened it: "
                     "arm.cells[..].stroke_m), duration 1.6/s s", "cells_computed":
                     res.computed, "cells_cached": res.cached,
                     "time_scaling": "a cell whose arm fails a motor or gear limit of the "
                     "sizing module on laws (2) at its speed scale runs at the largest "
                     "feasible speed scale below it (speed_scale_run; time_scaled true); "
                     "sizing_failures lists the limits failed at the requested scale",
                     "levers": "load ratio raised by a payload at the gripper (up to "
                     "max_payload_kg), then the reach stroke (retracted position moved up "
                     f"to {SHIFT_MAX:g} m towards the turning axis, q3 stroke lengthened to "
                     f"up to {STROKE_MAX:g} m), then a payload above max_payload_kg (up to "
                     f"{OVERLOAD_MAX:g} times it; arm.cells[..].over_rated, the laws "
                     "time-scaled where the sizing fails), then the turning gear ratio; "
                     "load_ratio_achieved per row"},
        "units": {"ratio": "1", "saturation": "fraction of time", "peak_gripper_speed": "m/s",
                  "sliding_rate": "1/s",
                  "max_error": "rad", "rise_time": "s", "overshoot": "fraction of the step"},
    }
    doc = json_safe(doc)
    _write(out, doc, pool)
    return doc


def _cells_progress(stack: ExitStack, progress, total: int):
    """The progress argument of the cells' :func:`run_tasks` call: a callable given the
    fraction of the computed cells done, shown in whole cells of the grid's ``total`` (a
    time-scaled cell is computed once for several) as a bar (or given as a fraction 0..1
    to a callable ``progress``); False without progress."""

    if not progress:
        return False
    advance = progress_reporter(stack, progress, "claims cells", total)
    seen = [0]

    def fraction(f: float) -> None:
        now = min(total, math.floor(f * total + 1e-9))
        if now > seen[0]:
            advance(now - seen[0])
            seen[0] = now

    return fraction


def size_row(*, arm: Robot, load_ratio: float, max_payload: float,
             speed_scales: list[float]) -> dict:
    """One row of the grid: the arm at the load ratio and, per speed scale, the speed scale
    its cell runs at (the sizing's, see :func:`feasible_speed_scale`).

    One bisection per row, from the row's largest speed scale, so that the time-scaled
    cells of a row run at one speed scale (computed once).

    Returns:
        {"arm": the load-ratio change (:func:`arm_with_load_ratio`), "robot": the row's
        arm (for :func:`cell_plan`), "speed_scale_run":
        per speed scale the one run (None: infeasible even at ``SPEED_SCALE_MIN``),
        "sizing_failures": per speed scale the limits failed there}.

    Example:
        >>> import manipcad
        >>> row = size_row(arm=manipcad.load_robot("cylindrical"), load_ratio=2.5,
        ...                max_payload=2.0, speed_scales=[0.5, 1.0, 2.0])
        >>> row["speed_scale_run"], row["sizing_failures"][0]
        ([0.5, 0.575, 0.575], [])
    """
    row_arm, info = arm_with_load_ratio(arm, load_ratio, max_payload=max_payload)
    # the grid's speed scales sized first: the bisection then skips the points they decide
    known = {float(s): sizing_failures(row_arm, float(s), info["stroke_m"])
             for s in speed_scales}
    s_max, _ = feasible_speed_scale(row_arm, max(speed_scales), info["stroke_m"], known=known)
    runs, fails = [], []
    for s in speed_scales:
        f = known[float(s)]
        runs.append(s if not f else (None if s_max is None else min(s, s_max)))
        fails.append(f)
    return {"arm": info, "robot": row_arm, "speed_scale_run": runs, "sizing_failures": fails}


def _infeasible_cell(info: dict, speed_scale: float) -> dict:
    """A cell whose arm fails the sizing even at ``SPEED_SCALE_MIN``: nothing run."""
    return {"max_error": {}, "rise_time": {}, "overshoot": {}, "ratio": {}, "saturation": None,
            "diverged": False, "warnings": {}, "sliding_rate": {}, "arm": info,
            "peak_gripper_speed": None,
            "skipped": {"cell": f"the motors or gears fail the sizing on laws (2) even at "
                                f"speed scale {SPEED_SCALE_MIN:g}"}}


def _where_below(grid, vals, limit):
    ok = sum(1 for row in vals for v in row if v is not None and v <= limit)
    total = sum(1 for row in vals for v in row if v is not None)
    return f"in {ok} of {total} cells the overshoot is at most {limit:g}"


def _write(out: Path, doc: dict, pool=None) -> None:
    """claims.json, claims.png and report.html, each written to a temporary file and renamed.

    With a ``pool`` the figure's panels are drawn in groups, one per worker, and each
    group's rows encoded there (:func:`manipcad.report.claims.draw_band`): the same
    pixels as drawn whole.
    """

    tmp = temp_dir(out / "claims")  # named as the folder writer's: cleaned if we die
    try:
        (tmp / "claims.json").write_text(json.dumps(doc, indent=2, ensure_ascii=False) + "\n",
                                         encoding="utf-8")
        groups = panel_groups(doc, 1 if pool is None else pool.slots())
        bands = run_tasks(draw_band, [{"ids": ids} for ids in groups],
                          common={"doc": doc, "dpi": FIGURE_DPI},
                          workers=None if pool is not None else 1, pool=pool,
                          progress=False)
        if pool is not None:  # the cluster closes while the PNG and the report are written
            pool.release()
        save_bands(list(bands), tmp / "claims.png", dpi=FIGURE_DPI)
        (tmp / "report.html").write_text(claims_html(doc, tmp / "claims.png"), encoding="utf-8")
        for name in ("claims.json", "claims.png", "report.html"):
            os.replace(tmp / name, out / name)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
