"""Integrating a built closed loop (:mod:`manipcad.sim.closed_loop`) chunk by chunk: the
integrators by name and their tolerances, the reference and disturbance rows each chunk
reads, the calls of the compiled cores (:mod:`manipcad.sim.loop` for RK4,
:mod:`manipcad.sim.adaptive` for the error-controlled pairs), and why a fixed-step run
diverged when a drive's electrical mode is the cause."""

from __future__ import annotations

import math
from typing import NamedTuple

import numpy as np

from manipcad.drives.params import KIND_ELASTIC, KIND_RIGID, P_KIND, P_L, P_R
from manipcad.errors import InputError, ManipcadError
from manipcad.model.robot import Robot
from manipcad.sim import adaptive as _adaptive
from manipcad.sim import loop as _loop
from manipcad.sim.adaptive import STATS, TABLEAUS
from manipcad.sim.direct import DirectCall
from manipcad.sim.loop import Record, Reference, Work

#: the compiled cores, called without numba's typing of the named structures at every
#: call once their types are known (:mod:`manipcad.sim.direct`: about 0.1 ms a call)
run = DirectCall(_loop.run)
run_adaptive = DirectCall(_adaptive.run_adaptive)

#: steps integrated per call of the compiled core (the reference is sampled per chunk,
#: so memory follows the kept samples)
CHUNK = 20000

#: the integrators by name: None for the fixed-step RK4, else (the embedded pair of
#: :data:`manipcad.sim.adaptive.TABLEAUS`, the rigid drives' currents advanced exactly)
INTEGRATORS = {"rk4": None,
               "adaptive": ("dp54", False),
               "adaptive-exact": ("dp54", True),
               "adaptive-bs32": ("bs32", False),
               "adaptive-exact-bs32": ("bs32", True)}

#: the adaptive integrators' default tolerances: relative (-), absolute (rad, rad/s)
RTOL = 1e-6
ATOL = 1e-8


def integrator_options(integrator, rtol, atol):
    """(None or (pair, exact) of :data:`INTEGRATORS`, rtol, atol) checked; one clear error
    naming the argument."""
    if not isinstance(integrator, str) or integrator not in INTEGRATORS:
        raise ManipcadError(f"integrator must be one of {', '.join(INTEGRATORS)}, got "
                            f"{integrator!r}")
    if integrator == "rk4":
        for name, v in (("rtol", rtol), ("atol", atol)):
            if v is not None:
                raise ManipcadError(f"{name} applies to the adaptive integrators only "
                                    "(the fixed-step RK4's accuracy is set by dt)")
        return None, None, None
    rtol = RTOL if rtol is None else rtol
    atol = ATOL if atol is None else atol
    try:
        rtol, atol = float(rtol), float(atol)
    except (TypeError, ValueError):
        raise ManipcadError(f"rtol and atol must be numbers, got {rtol!r}, {atol!r}") from None
    if not (1e-12 <= rtol <= 0.1):
        raise ManipcadError(f"rtol must be in [1e-12, 0.1] (relative error per step), "
                            f"got {rtol}")
    if not (atol > 0 and math.isfinite(atol)):
        raise ManipcadError(f"atol must be a finite number > 0 (rad, m, rad/s or m/s), "
                            f"got {atol}")
    return INTEGRATORS[integrator], rtol, atol


def _rows_or_hold(trajectory, x_q, t_rows, n):
    if trajectory is not None:
        return reference_rows(trajectory, t_rows, n)
    m = len(t_rows)
    return np.tile(x_q, (m, 1)), np.zeros((m, n)), np.zeros((m, n))



class Integrated(NamedTuple):
    """What the compiled loop left: the kept samples ``rec`` (:class:`~manipcad.sim.loop.Record`,
    ``work.rec[0]`` of them), its ``work`` (the final state, the limit excursions), the
    status (0 done, 1 NaN, 2 runaway speed, 3 a joint beyond its limits with "stop") with
    the step and joint, the adaptive integrator's counters ``stats`` (else None) and the
    reference rows ``sampled`` (t, q*, q̇*) the RK4 loop ran on when they cover the run
    (else None)."""

    rec: Record
    work: Work
    status: int
    step: int
    joint: int
    stats: np.ndarray | None
    sampled: tuple | None


def integrate(loop, start, *, n: int, steps: int, dt: float, every: int, joint_limits: str,
              adaptive, rtol, atol, trajectory, disturbance, progress) -> Integrated:
    """Run a built closed loop (:class:`manipcad.sim.closed_loop.ClosedLoop`, used once: its
    state is integrated in place) from its :class:`~manipcad.sim.closed_loop.Start` for
    ``steps`` steps of ``dt`` s, keeping every ``every``-th: RK4 when ``adaptive`` is None,
    else the pair ``adaptive`` of :data:`INTEGRATORS` at tolerances ``rtol``, ``atol``
    (arguments as :func:`manipcad.sim.simulate`'s)."""
    M = steps // every + 1
    rec = Record(np.empty(M), *(np.empty((M, n)) for _ in range(5)))
    work = Work(loop.x0, np.zeros(n), np.zeros(len(loop.ctrl.kind), dtype=np.int64),
                np.zeros(2, dtype=np.int64), np.zeros((n, 2)))
    dist_of = disturbance_source(disturbance, steps, n)
    stats = sampled = None  # sampled: (t, q*, q̇*) the loop ran on, when the kept samples'
    if adaptive:
        status, step, joint, stats = run_adaptive_chunks(
            loop.plant, loop.ctrl, rec, work, steps, float(dt), every, joint_limits,
            trajectory, start.q, dist_of, varies(disturbance), n, rtol, atol, progress,
            *adaptive)
    else:
        status, step, joint, sampled = run_rk4(
            loop.plant, loop.ctrl, rec, work, steps, float(dt), every, joint_limits,
            trajectory, start.q, dist_of, n, progress, start.first)
    return Integrated(rec, work, status, step, joint, stats, sampled)


def run_rk4(plant, ctrl, rec, work, K, dt, every, joint_limits, trajectory, x_q, dist_of,
             n, progress, first=None):
    """The fixed-step RK4 run, chunk by chunk; (status, step, joint, sampled): ``sampled``
    the times, q* and q̇* of the reference rows the loop ran on when the whole run was one
    chunk along a trajectory (else None). ``first``: the first chunk's times and reference
    rows (t, q*, q̇*, q̈*) when sampled already."""
    status, step, joint = 0, 0, -1
    sampled = None
    for k0 in range(0, K + 1, CHUNK):
        steps = min(CHUNK, K - k0)
        last = k0 + steps == K
        if k0 == 0 and first is not None:
            t_rows, rows = first[0], first[1:]
        else:
            t_rows = np.arange(k0, k0 + steps + 1) * dt
            rows = _rows_or_hold(trajectory, x_q, t_rows, n)
        ref = Reference(*rows, dist_of(k0, t_rows))
        status, step, joint = run(plant, ctrl, ref, rec, work, k0, steps, dt, every,
                                  last, joint_limits == "stop")
        if progress is not None:
            progress(min(1.0, (k0 + steps) / K))
        if status or last:
            if k0 == 0 and trajectory is not None:
                sampled = (t_rows, ref.q, ref.qd)
            break
    return status, step, joint, sampled


def varies(disturbance) -> bool:
    """Does the disturbance change from step to step (callable or a table of rows)?"""
    if disturbance is None:
        return False
    if callable(disturbance):
        return True
    d = np.asarray(disturbance, dtype=float)
    return d.ndim == 2 and bool((d != d[:1]).any())


def run_adaptive_chunks(plant, ctrl, rec, work, K, dt, every, joint_limits, trajectory, x_q,
                  dist_of, varies, n, rtol, atol, progress, pair, exact):
    """The adaptive run, chunk by chunk; (status, step, joint, counters).

    The reference is sampled only at the regulators' sample grid (the gcd of their
    periods in steps); a disturbance that changes every step makes every step a
    hold interval (and the grid every step).
    """
    stride = int(np.gcd.reduce(ctrl.steps)) if len(ctrl.steps) else max(K, 1)
    hold = K + 1
    if varies:
        stride, hold = 1, 1
    stats = np.zeros(STATS)
    tab = TABLEAUS[pair]
    chunk = CHUNK * stride
    status, step, joint = 0, 0, -1
    for k0 in range(0, K + 1, chunk):
        steps = min(chunk, K - k0)
        last = k0 + steps == K
        t_rows = (k0 + stride * np.arange(steps // stride + 1)) * dt
        ks = k0 + stride * np.arange(steps // stride + 1)
        ref = Reference(*_rows_or_hold(trajectory, x_q, t_rows, n),
                        _rows_at(dist_of, k0, ks, dt, stride))
        status, step, joint = run_adaptive(plant, ctrl, ref, rec, work, k0, steps, dt, every,
                                           last, joint_limits == "stop", stride, hold, tab,
                                           rtol, atol, stats, exact)
        if progress is not None:
            progress(min(1.0, (k0 + steps) / K))
        if status or last:
            break
    return status, step, joint, stats


def _rows_at(dist_of, k0, ks, dt, stride):
    """Disturbance rows at the steps ks (the source gives consecutive steps from k0)."""
    if stride == 1:
        return dist_of(k0, ks * dt)
    return np.ascontiguousarray(dist_of(k0, ks * dt)[:1].repeat(len(ks), axis=0))




def reference_rows(trajectory, t: np.ndarray, n: int):
    q, qd, qdd = trajectory.sample(t)
    arrays = [np.ascontiguousarray(a, dtype=float) for a in (q, qd, qdd)]
    for a in arrays:
        if a.shape != (len(t), n):
            raise ManipcadError(f"trajectory has {a.shape[-1]} joints, the robot {n}")
        if not np.isfinite(a).all():
            raise ManipcadError("trajectory samples hold NaN or infinite values")
    return arrays


#: per joint count, zero disturbance rows shared by the runs without a disturbance (the
#: compiled cores only read a Reference's rows): not zero-filled again at every call
#: (0.48 MB for 10,001 rows of 6 joints), at most a chunk's rows (CHUNK + 1) each
_ZEROS: dict[int, np.ndarray] = {}


def _zero_rows(m: int, n: int) -> np.ndarray:
    """(m, n) zeros, a C-contiguous view of :data:`_ZEROS` (never to be written)."""
    z = _ZEROS.get(n)
    if z is None or z.shape[0] < m:
        z = _ZEROS[n] = np.zeros((max(m, CHUNK + 1), n))
    return z[:m]


def disturbance_source(disturbance, K: int, n: int):
    """A function (first step, times of the chunk) -> disturbance rows (len(t), n), N·m."""
    if disturbance is None:
        return lambda k0, t: _zero_rows(len(t), n)
    if callable(disturbance):
        def rows(k0, t):
            d = np.asarray(disturbance(t), dtype=float)
            if d.shape == (n,):
                d = np.broadcast_to(d, (len(t), n))
            if d.shape != (len(t), n) or not np.isfinite(d).all():
                raise ManipcadError(f"disturbance(t) must return finite values of shape "
                                    f"({len(t)}, {n}), got {d.shape}")
            return np.ascontiguousarray(d)
        return rows
    try:
        d = None if isinstance(disturbance, str | bytes) else np.asarray(disturbance, float)
    except (TypeError, ValueError):
        d = None
    if d is None:
        raise InputError("simulate", "disturbance", f"expected joint torques (N·m or N): "
                         f"an ({n},) array, a ({K + 1}, {n}) array of one row per step, or "
                         f"a function of the times t (s) returning (len(t), {n}); got "
                         f"{type(disturbance).__name__} {disturbance!r}"[:300])
    if d.shape not in ((n,), (K + 1, n)) or not np.isfinite(d).all():
        raise ManipcadError(f"disturbance must be finite with shape ({n},) or "
                            f"({K + 1}, {n}), got {d.shape}")
    if d.shape == (n,):
        return lambda k0, t: np.ascontiguousarray(np.broadcast_to(d, (len(t), n)))
    return lambda k0, t: np.ascontiguousarray(d[k0:k0 + len(t)])




#: RK4's stability limit on the negative real axis: a mode x' = -x/T is integrated
#: stably for dt < RK4_REAL_LIMIT·T (|1 + z + z²/2 + z³/6 + z⁴/24| = 1 at z = -2.785)
RK4_REAL_LIMIT = 2.785


def electrical_cause(robot: Robot, dtable: np.ndarray, dt: float) -> str | None:
    """Why a fixed-step RK4 run diverged when a drive's current is the cause, else None.

    A drive whose armature current is a state (inductance L > 0) has the electrical
    mode di/dt ≈ -(R/L)·i: RK4 is unstable on it for dt > 2.785·L/R and the current
    blows up first; the torque it makes then throws any joint (often another one)
    beyond the speed limit. The drive with the smallest time constant among those
    the step cannot resolve is named, with a step that works.

    Parameters:
        robot: the simulated robot (joint names).
        dtable: the packed drives (n, NPAR) the run used (R in Ω, L in H).
        dt: the RK4 step, s.

    Returns:
        a sentence naming the joint, its L, R, L/R (s) and a step that works, or None
        when every drive's electrical mode is within RK4's stability limit.

    Example:
        >>> import manipcad
        >>> from manipcad.drives.params import pack_drives
        >>> arm = manipcad.load_robot("puma560")         # L/R = 0.25 ms to 0.48 ms
        >>> electrical_cause(arm, pack_drives(arm.drives), 1e-4) is None
        True
        >>> print(electrical_cause(arm, pack_drives(arm.drives), 2e-3))  # doctest: +ELLIPSIS
        joint 'wrist_roll''s drive: the step dt = 0.002 s is too large ... use dt <= 0.00025 s, ...
    """

    worst = None
    for j, nm in enumerate(robot.joint_names):
        if int(dtable[j, P_KIND]) not in (KIND_RIGID, KIND_ELASTIC):
            continue
        L, R = float(dtable[j, P_L]), float(dtable[j, P_R])
        if not (L > 0.0 and R > 0.0):
            continue
        T = L / R
        if dt > RK4_REAL_LIMIT * T and (worst is None or T < worst[1]):
            worst = (nm, T, L, R)
    if worst is None:
        return None
    nm, T, L, R = worst
    return (f"joint {nm!r}'s drive: the step dt = {dt:.3g} s is too large for its electrical "
            f"time constant L/R = {L:.3g} H / {R:.3g} Ω = {T:.3g} s (RK4 is stable for "
            f"dt < {RK4_REAL_LIMIT}·L/R = {RK4_REAL_LIMIT * T:.3g} s): use dt <= {T:.2g} s, "
            f"or L: 0 for joint {nm!r} to neglect the inductance")



__all__ = ["integrate", "Integrated", "run", "run_adaptive", "CHUNK", "INTEGRATORS", "RTOL",
           "ATOL", "RK4_REAL_LIMIT", "integrator_options", "reference_rows", "run_rk4",
           "run_adaptive_chunks", "varies", "disturbance_source", "electrical_cause"]
