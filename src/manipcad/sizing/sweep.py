"""Gear-ratio sweep: which ratios let a joint's motor meet all its limits, and the best one.

For one joint, keep the motor (R, L, k_m, k_w, J, k_v, M_f and its ratings)
and the motion, and vary the gear ratio |i_r|. The rigid-body joint torque
P_rigid does not depend on the ratio, so every ratio is evaluated from one
inverse-dynamics pass (:mod:`manipcad.sizing.motion`), vectorized over the
ratios (arrays of shape (R, N)):

    P(i_r)   = P_rigid + (J·q̈ + k_v·q̇)·i_r² + |i_r|·M_f(q̇)    joint torque, N·m (N)
    T_m(i_r) = P(i_r) / i_r                                    motor torque, N·m
    ω_m      = i_r·q̇,   i = T_m/k_m,   u_a = R·i + L·di/dt + k_w·ω_m

A small ratio needs a large motor torque for the load (P_rigid/i_r); a large
one spends it on accelerating the rotor (J·i_r·q̈) and runs the motor fast
(speed and back-EMF limits). The feasible ratios are those where every known
limit of :mod:`manipcad.sizing.limits` holds; its edges are refined by
bisection between grid points to 1e-12 relative.

Best ratio, by ``criterion``:

- ``"rms_torque"`` (default): the feasible ratio with the least RMS motor
  torque, i.e. the least RMS current and copper heating (R·i_rms²). Without
  friction and with a rigid load this is the classic inertia-matching ratio
  i_r⁴ = mean(P_rigid²) / (J²·mean(q̈²));
- ``"peak_current"``: the feasible ratio with the least peak current (the
  smallest amplifier).

The grid minimum is refined with a bounded Brent search inside its feasible
interval. The motor's J (rotor plus gear, on the motor shaft), k_v and M_f
are kept as they are at every ratio: a real gearbox of another ratio has
another inertia and efficiency, so check the chosen ratio with the real gear.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from manipcad.errors import InputError, ModelError, require_choice
from manipcad.model.robot import Drive, Robot
from manipcad.sizing.limits import LIMITS, margin, motor_limits
from manipcad.sizing.motion import sample_motion
from manipcad.sizing.motor import joint_torque, motor_series
from manipcad.sizing.stats import peak, time_rms
from manipcad.trajectories.base import Trajectory

CRITERIA = {"rms_torque": ("RMS motor torque", "N·m"), "peak_current": ("peak current", "A")}
#: elements per vectorized block (ratios × samples)
_BLOCK = 500_000


@dataclass(frozen=True)
class RatioSweep:
    """The gear ratios a joint's motor can run the motion with.

    All ratios are magnitudes |i_r| in rad/rad (rad/m for a prismatic joint);
    the drive's direction (sign of i_r) is kept in the computation.

    Attributes:
        joint: joint name.
        index: joint index.
        motor: the motor's catalog name ("" if none).
        ratio: the drive's present ratio, signed.
        criterion: "rms_torque" or "peak_current" (what ``best_ratio`` minimizes).
        ratios: (R,) the swept ratios, ascending.
        rms_motor_torque: (R,) RMS motor torque, N·m.
        peak_motor_torque: (R,) peak motor torque, N·m.
        peak_motor_speed: (R,) peak motor speed, rad/s.
        peak_current: (R,) peak armature current, A (nan if k_m unknown).
        rms_current: (R,) RMS armature current, A.
        peak_voltage: (R,) peak armature voltage, V (nan if electrics unknown).
        limits: the motor's ratings: limit name -> value (N·m, N·m, rad/s, V; nan unknown).
        limits_used: the names of the known limits, the ones checked.
        margins: limit name -> (R,) margin 1 - required/limit (nan for unknown limits).
        feasible: (R,) True where every used limit holds.
        intervals: feasible ratio intervals ((low, high), ...), edges refined.
        ratio_min, ratio_max: smallest and largest feasible ratio (nan if none).
        best_ratio: the feasible ratio minimizing the criterion (nan if none).
        best_value: the criterion there, N·m or A.
        optimum_ratio: the ratio minimizing the criterion over the whole grid,
            feasible or not (refined).
        bounded_by_grid: True if a feasible interval reaches the end of the
            grid, i.e. the true range may be wider than reported.
    """

    joint: str
    index: int
    motor: str
    ratio: float
    criterion: str
    ratios: np.ndarray
    rms_motor_torque: np.ndarray
    peak_motor_torque: np.ndarray
    peak_motor_speed: np.ndarray
    peak_current: np.ndarray
    rms_current: np.ndarray
    peak_voltage: np.ndarray
    limits: dict[str, float]
    limits_used: tuple[str, ...]
    margins: dict[str, np.ndarray]
    feasible: np.ndarray
    intervals: tuple[tuple[float, float], ...]
    ratio_min: float
    ratio_max: float
    best_ratio: float
    best_value: float
    optimum_ratio: float
    bounded_by_grid: bool

    def __repr__(self) -> str:
        return (f"RatioSweep({self.joint!r}, feasible |i_r| in [{self.ratio_min:.4g}, "
                f"{self.ratio_max:.4g}], best {self.best_ratio:.4g} by {self.criterion}, "
                f"present {abs(self.ratio):.4g})")


#: the per-ratio quantities of a sweep, in RatioSweep's field names
_SERIES = ("rms_motor_torque", "peak_motor_torque", "peak_motor_speed", "peak_current",
           "rms_current", "peak_voltage")
#: cache version of the grid cells (change when _Evaluator's results change)
_CELL_VERSION = "1"


class _Evaluator:
    """Evaluate one joint's motor quantities at any array of ratio magnitudes.

    ``t`` (s) and ``cols`` (P_rigid, q̇, q̈, dP_rigid/dt, jerk of the joint, SI units)
    are the sampled motion's columns of this joint: the inputs of a grid cell.
    """

    def __init__(self, t: np.ndarray, cols: tuple[np.ndarray, ...], drive: Drive) -> None:
        self.t = t
        self.drive = drive
        self.sign = 1.0 if drive.ratio > 0 else -1.0
        self.cols = cols
        self.limits = motor_limits(drive)
        self.used = tuple(k for k, v in self.limits.items() if math.isfinite(v) and v > 0)

    def __call__(self, r_abs: np.ndarray) -> dict[str, np.ndarray]:
        r_abs = np.atleast_1d(np.asarray(r_abs, dtype=float))
        tau_rigid, qd, qdd, dtau, jerk = self.cols
        step = max(1, _BLOCK // max(1, qd.shape[0]))
        parts: list[dict[str, np.ndarray]] = []
        for k in range(0, r_abs.shape[0], step):
            r = self.sign * r_abs[k:k + step, None]
            tau = joint_torque(self.drive, r, tau_rigid, qd, qdd)
            s = motor_series(self.drive, r, tau, qd, qdd, dtau, jerk, tau_rigid)
            parts.append({
                "rms_motor_torque": time_rms(s.torque, self.t, axis=1),
                "peak_motor_torque": peak(s.torque, axis=1),
                "peak_motor_speed": peak(s.speed, axis=1),
                "peak_current": peak(s.current, axis=1),
                "rms_current": time_rms(s.current, self.t, axis=1),
                "peak_voltage": peak(s.voltage, axis=1),
            })
        out = {key: np.concatenate([p[key] for p in parts]) for key in parts[0]}
        req = {"continuous": out["rms_motor_torque"], "peak": out["peak_motor_torque"],
               "speed": out["peak_motor_speed"], "voltage": out["peak_voltage"]}
        margins = {name: margin(req[name], self.limits[name]) for name in LIMITS}
        feas = np.ones(r_abs.shape, dtype=bool)
        for name in self.used:
            feas &= margins[name] >= 0
        out["margins"] = margins
        out["feasible"] = feas
        return out

    def feasible(self, r_abs: np.ndarray) -> np.ndarray:
        return self(r_abs)["feasible"]


def _grid_cells(tasks: list[dict], *, t: np.ndarray, cols: tuple[np.ndarray, ...],
                drive: Drive) -> list[dict]:
    """One executor chunk of sweep cells: each task ``{"ratio": |i_r|}`` -> its quantities
    (the :data:`_SERIES` values, the margins per limit and ``feasible``), SI units."""
    val = _Evaluator(t, cols, drive)(np.array([task["ratio"] for task in tasks], dtype=float))
    out = []
    for k in range(len(tasks)):
        cell = {key: float(val[key][k]) for key in _SERIES}
        cell["margins"] = {name: float(m[k]) for name, m in val["margins"].items()}
        cell["feasible"] = bool(val["feasible"][k])
        out.append(cell)
    return out


def _evaluate_grid(ev: _Evaluator, grid: np.ndarray, *, workers: int | None,
                   scheduler: str | None, cache_dir: Any, progress: bool) -> dict:
    """``ev(grid)``, cell by cell through :func:`manipcad.parallel.run_tasks`."""
    if workers == 1 and scheduler is None and cache_dir is None:
        return ev(grid)
    # deferred: start-up cost: keeps manipcad.parallel out of import manipcad
    from manipcad.parallel import run_tasks

    chunk = max(1, min(_BLOCK // max(1, ev.t.shape[0]), math.ceil(grid.size / 16)))
    cells = run_tasks(_grid_cells, [{"ratio": float(r)} for r in grid],
                      common={"t": ev.t, "cols": ev.cols, "drive": ev.drive},
                      workers=workers, scheduler=scheduler, cache_dir=cache_dir, chunk=chunk,
                      batched=True, progress=progress, desc=f"ratio sweep {ev.drive.name}",
                      version=_CELL_VERSION)
    out = {key: np.array([c[key] for c in cells]) for key in _SERIES}
    out["margins"] = {name: np.array([c["margins"][name] for c in cells]) for name in LIMITS}
    out["feasible"] = np.array([c["feasible"] for c in cells], dtype=bool)
    return out


def _default_ratios(ratio: float) -> np.ndarray:
    r0 = abs(ratio)
    return np.geomspace(r0 / 20.0, r0 * 20.0, 601)


def _check_ratios(ratios: Any) -> np.ndarray:
    try:
        r = np.asarray(ratios, dtype=float).reshape(-1)
    except (TypeError, ValueError):
        raise InputError("ratios", "", "expected a list of numbers (|i_r|, rad/rad or rad/m)"
                         ) from None
    if r.size < 2:
        raise InputError("ratios", "", "give at least two ratios to sweep")
    if not np.all(np.isfinite(r)) or np.any(r <= 0):
        raise InputError("ratios", "", "every ratio must be a finite number > 0 (magnitudes "
                         "|i_r|; the drive's direction is kept)")
    return np.unique(r)


def _bisect(ev: _Evaluator, good: np.ndarray, bad: np.ndarray) -> np.ndarray:
    """Edges between feasible ``good`` and infeasible ``bad`` ratios, to 1e-12 relative."""
    good, bad = good.copy(), bad.copy()
    for _ in range(200):
        if np.all(np.abs(np.log(good / bad)) < 1e-12):
            break
        mid = np.sqrt(good * bad)
        f = ev.feasible(mid)
        good = np.where(f, mid, good)
        bad = np.where(f, bad, mid)
    return good


def _refine_min(ev: _Evaluator, key: str, lo: float, hi: float, x0: float, v0: float,
                need_feasible: bool) -> tuple[float, float]:
    """Bounded Brent search of ev(r)[key] on [lo, hi] in log r; keeps (x0, v0) if not better."""
    if not hi > lo:
        return x0, v0

    def f(u: float) -> float:
        val = ev(np.array([math.exp(u)]))
        if need_feasible and not val["feasible"][0]:
            return math.inf
        return float(val[key][0])

    from scipy.optimize import minimize_scalar  # deferred: start-up cost: scipy on first use

    res = minimize_scalar(f, bounds=(math.log(lo), math.log(hi)), method="bounded",
                          options={"xatol": 1e-10})
    if res.success and math.isfinite(res.fun) and res.fun < v0:
        return float(math.exp(res.x)), float(res.fun)
    return x0, v0


def ratio_sweep(robot: Robot, trajectory: Trajectory, joint: int | str, ratios: Any = None, *,
                criterion: str = "rms_torque", t_end: float | None = None, dt: float = 1e-3,
                payload: Any = None, workers: int | None = 1, scheduler: str | None = None,
                cache_dir: Any = None, progress: bool = False) -> RatioSweep:
    """Sweep one joint's gear ratio: feasible range and best ratio for its motor.

    Args:
        robot: the manipulator with its drives.
        trajectory: the motion (``robot.n`` joints).
        joint: the joint, index or name; it must have a drive.
        ratios: the ratio magnitudes |i_r| to try (rad/rad, rad/m for a
            prismatic joint), > 0; default 601 values spaced evenly in log
            from 1/20 to 20 times the present ratio.
        criterion: "rms_torque" (least RMS motor torque: least heating) or
            "peak_current" (least peak current: smallest amplifier).
        t_end, dt, payload: as in :func:`~manipcad.sizing.required_drive`.
        workers, scheduler, cache_dir, progress: how the grid's ratios (the
            cells) are computed, as in :func:`manipcad.parallel.run_tasks`:
            default ``workers=1``, serial in this process (the grid is
            vectorized and takes milliseconds to seconds, less than a
            cluster's start-up); ``workers=None`` one worker process per core,
            ``scheduler="tcp://HOST:PORT"`` a running cluster; ``cache_dir`` a
            folder where each ratio's result is kept by a hash of its inputs
            (the motion's columns, the drive, the ratio), so a rerun or a wider
            grid computes only the new ratios. The edges' bisection and the
            best ratio's refinement run in this process. The results are the
            same whichever way the cells ran.

    Returns:
        :class:`RatioSweep`.

    Raises:
        ModelError: the joint has no drive, or its motor has no known rating.
        InputError: bad ratios or criterion, or the arguments of ``required_drive``.

    Example:
        >>> import manipcad
        >>> from manipcad.sizing import ratio_sweep
        >>> from manipcad.trajectories import cosine
        >>> arm = manipcad.load_robot("cylindrical")
        >>> sw = ratio_sweep(arm, cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], 1.6), "turn")
        >>> bool(sw.ratio_min <= sw.best_ratio <= sw.ratio_max)
        True
    """
    require_choice("criterion", "", criterion, CRITERIA, "criterion")
    j = robot.joint_index(joint)
    name = robot.joint_names[j]
    drive = robot.drives[j]
    if drive is None:
        raise ModelError(f"joint {name!r} has no drive: nothing to sweep")
    if criterion == "peak_current" and not math.isfinite(drive.k_m):
        raise ModelError(f"joint {name!r}: the motor's k_m is unknown, so the peak current "
                         "is; use criterion='rms_torque'")
    grid = _check_ratios(_default_ratios(drive.ratio) if ratios is None else ratios)
    motion = sample_motion(robot, trajectory, t_end=t_end, dt=dt, payload=payload)
    ev = _Evaluator(motion.t, (motion.tau_rigid[:, j], motion.qd[:, j], motion.qdd[:, j],
                               motion.dtau_rigid[:, j], motion.jerk[:, j]), drive)
    if not ev.used:
        raise ModelError(f"joint {name!r}: motor {drive.name or '(unnamed)'} has no known "
                         "rating (rated_torque, peak_torque, max_speed or a voltage limit); "
                         "nothing to check the ratios against")
    val = _evaluate_grid(ev, grid, workers=workers, scheduler=scheduler, cache_dir=cache_dir,
                         progress=progress)
    feas = val["feasible"]
    key = {"rms_torque": "rms_motor_torque", "peak_current": "peak_current"}[criterion]

    # feasible intervals, edges refined
    intervals: list[tuple[float, float]] = []
    runs = np.flatnonzero(np.diff(np.concatenate([[0], feas.astype(int), [0]])))
    starts, ends = runs[::2], runs[1::2] - 1
    lo_edges = {s: grid[s] for s in starts}
    hi_edges = {e: grid[e] for e in ends}
    inner_lo = [s for s in starts if s > 0]
    inner_hi = [e for e in ends if e < grid.size - 1]
    if inner_lo:
        ref = _bisect(ev, grid[inner_lo], grid[[s - 1 for s in inner_lo]])
        lo_edges.update(zip(inner_lo, ref, strict=True))
    if inner_hi:
        ref = _bisect(ev, grid[inner_hi], grid[[e + 1 for e in inner_hi]])
        hi_edges.update(zip(inner_hi, ref, strict=True))
    for s, e in zip(starts, ends, strict=True):
        intervals.append((float(lo_edges[s]), float(hi_edges[e])))
    bounded = bool(feas.size and (feas[0] or feas[-1]))

    # unconstrained optimum over the grid, refined between its neighbours
    vals = val[key]
    k_all = int(np.nanargmin(vals))
    optimum, _ = _refine_min(ev, key, grid[max(k_all - 1, 0)], grid[min(k_all + 1, grid.size - 1)],
                             float(grid[k_all]), float(vals[k_all]), need_feasible=False)
    # constrained best: the feasible grid minimum, refined inside its interval
    best, best_value = math.nan, math.nan
    if feas.any():
        masked = np.where(feas, vals, np.inf)
        k = int(np.argmin(masked))
        lo_i, hi_i = next((a, b) for a, b in intervals if a <= grid[k] <= b)
        lo = max(grid[max(k - 1, 0)], lo_i)
        hi = min(grid[min(k + 1, grid.size - 1)], hi_i)
        best, best_value = _refine_min(ev, key, lo, hi, float(grid[k]), float(vals[k]),
                                       need_feasible=True)
    return RatioSweep(
        joint=name, index=j, motor=drive.name, ratio=float(drive.ratio), criterion=criterion,
        ratios=grid, rms_motor_torque=val["rms_motor_torque"],
        peak_motor_torque=val["peak_motor_torque"], peak_motor_speed=val["peak_motor_speed"],
        peak_current=val["peak_current"], rms_current=val["rms_current"],
        peak_voltage=val["peak_voltage"], limits=ev.limits, limits_used=ev.used,
        margins=val["margins"], feasible=feas, intervals=tuple(intervals),
        ratio_min=intervals[0][0] if intervals else math.nan,
        ratio_max=intervals[-1][1] if intervals else math.nan,
        best_ratio=best, best_value=best_value, optimum_ratio=optimum,
        bounded_by_grid=bounded,
    )
