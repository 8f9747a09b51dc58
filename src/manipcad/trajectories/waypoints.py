"""Point-to-point moves through poses with a dwell at each, as robot programs are written.

Poses P_0 .. P_{m-1} (joint vectors, rad or m). The motion holds each pose for
its dwell and moves to the next in its move time; the time line is

    [dwell_0][move_0][dwell_1][move_1] ... [move_{m-2}][dwell_{m-1}]

so the duration is Σ dwell + Σ move_time. Move k goes along the straight line
in joint space, q = P_k + s(t)·(P_{k+1} - P_k), all joints together, with the
path coordinate s from 0 to 1 and zero velocity at both ends:

- ``profile="quintic"``: s = 10τ³ - 15τ⁴ + 6τ⁵ (τ = t / T_k), the polynomial of
  :func:`manipcad.trajectories.quintic.quintic_profile`; zero acceleration at the ends;
- ``profile="trapezoidal"``: the trapezoidal velocity profile of
  :class:`manipcad.trajectories.trapezoidal.TrapezoidalTrajectory` stretched to
  T_k, with a third of the move accelerating, a third cruising at 1.5/T_k and a
  third braking (peak rate 1.5·|D|/T_k, acceleration 4.5·|D|/T_k²).

During a dwell q̇ = q̈ = 0: short stops, which the static payload identification
needs (:func:`manipcad.dynamics.identification.identify_payload`).
"""

from __future__ import annotations

import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np

from manipcad.dynamics.identification import DITHER_CYCLES_MIN, DITHER_PERIOD_MAX
from manipcad.errors import InputError, ManipcadWarning, require_choice
from manipcad.trajectories.base import Trajectory, floats, vector
from manipcad.trajectories.quintic import quintic_profile
from manipcad.trajectories.trapezoidal import trapezoidal

PROFILES = ("quintic", "trapezoidal")

#: the unit trapezoidal move (s from 0 to 1) with accelerating, cruising and braking
#: thirds: v = 1.5, a = 4.5 gives t_a = 1/3 and a duration of 1 (up to rounding)
_UNIT_TRAPEZOID = trapezoidal([0.0], [1.0], v_max=1.5, a_max=4.5)


def _unit_profile(profile: str, tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """s(τ), ds/dτ, d²s/dτ² of a unit move for τ in [0, 1]."""
    if profile == "quintic":
        return quintic_profile(tau)
    D = _UNIT_TRAPEZOID.duration
    s, sd, sdd = _UNIT_TRAPEZOID._profile(np.clip(tau, 0.0, 1.0) * D)
    return s, sd * D, sdd * D * D


class WaypointsTrajectory(Trajectory):
    """Moves through poses with a dwell at each; build it with :func:`waypoints`.

    Attributes:
        points: (m, n) the poses, rad or m.
        move_time: (m - 1,) time of each move, s.
        dwell: (m,) time held at each pose, s.
        profile: "quintic" or "trapezoidal".

    Example:
        >>> traj = waypoints([[0.0], [1.0], [0.5]], move_time=1.0, dwell=0.5)
        >>> traj.duration
        3.5
        >>> traj.dwell_intervals().tolist()
        [[0.0, 0.5], [1.5, 2.0], [3.0, 3.5]]
    """

    kind = "waypoints"

    def __init__(self, points: np.ndarray, move_time: np.ndarray, dwell: np.ndarray,
                 profile: str, *, dither: np.ndarray | None = None,
                 dither_frequency: float = 10.0) -> None:
        self.points, self.move_time, self.dwell, self.profile = points, move_time, dwell, profile
        self.dither = np.zeros(points.shape[1]) if dither is None else dither
        self.dither_frequency = float(dither_frequency)
        m = points.shape[0]
        # phase k: 2j = dwell at pose j, 2j + 1 = move j -> j + 1
        lengths = np.empty(2 * m - 1)
        lengths[0::2] = dwell
        lengths[1::2] = move_time
        self._ends = np.cumsum(lengths)
        self._starts = self._ends - lengths

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.points.shape[1]

    @property
    def duration(self) -> float:
        """Σ dwell + Σ move_time, s."""
        return float(self._ends[-1])

    def dwell_intervals(self) -> np.ndarray:
        """(m, 2) start and end time of each dwell, s (the stops)."""
        return np.stack([self._starts[0::2], self._ends[0::2]], axis=1)

    def _evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        phase = np.minimum(np.searchsorted(self._ends, t, side="right"), self._ends.size - 1)
        # a time exactly at a phase end belongs to the next phase; the last end to the last
        pose = phase // 2
        moving = (phase % 2) == 1
        q = self.points[pose].copy()
        qd = np.zeros_like(q)
        qdd = np.zeros_like(q)
        if moving.any():
            k = pose[moving]
            T = self.move_time[k]
            tau = (t[moving] - self._starts[phase[moving]]) / T
            s, sd, sdd = _unit_profile(self.profile, tau)
            D = self.points[k + 1] - self.points[k]
            q[moving] = self.points[k] + s[:, None] * D
            qd[moving] = (sd / T)[:, None] * D
            qdd[moving] = (sdd / T**2)[:, None] * D
        if self.dither.any():
            start = self.dither_intervals()[pose, 0]
            on = ~moving & (pose > 0) & (t > start)
            w = 2.0 * np.pi * self.dither_frequency
            x = w * (t[on] - start[on])
            q[on] += np.sin(x)[:, None] * self.dither
            qd[on] += (w * np.cos(x))[:, None] * self.dither
            qdd[on] -= (w * w * np.sin(x))[:, None] * self.dither
        return q, qd, qdd

    def dither_intervals(self) -> np.ndarray:
        """(m, 2) start and end of the dither at each pose, s: the whole cycles that fit in
        its dwell, at the dwell's end (start = end: none; never at the first pose)."""
        ends = self._ends[0::2]
        cycles = np.floor(self.dwell * self.dither_frequency + 1e-9)
        cycles[0] = 0.0
        if not self.dither.any():
            cycles[:] = 0.0
        return np.stack([ends - cycles / self.dither_frequency, ends], axis=1)

    def to_dict(self) -> dict[str, Any]:
        """The YAML mapping: type, points (rad or m), move_time and dwell (s), profile."""
        out = {"type": self.kind, "points": floats(self.points),
               "move_time": floats(self.move_time), "dwell": floats(self.dwell),
               "profile": self.profile}
        if self.dither.any():
            out["dither"] = floats(self.dither)
            out["dither_frequency"] = self.dither_frequency
        return out


def waypoints(points: Sequence[Sequence[float]], *, move_time: Sequence[float] | float,
              dwell: Sequence[float] | float = 0.0, profile: str = "quintic",
              dither: Sequence[float] | float = 0.0, dither_frequency: float = 10.0,
              ) -> WaypointsTrajectory:
    """Point-to-point moves through poses with a dwell at each.

    Args:
        points: (m, n) poses, one a row, rad or m; m >= 2.
        move_time: time of each move, s, > 0: one number for all or m - 1 numbers.
        dwell: time held at each pose, s, >= 0: one number for all or m numbers
            (the first is held before the first move, the last after the last).
        profile: "quintic" (zero end accelerations) or "trapezoidal" (thirds).
        dither: amplitude a of a dither at every dwell after the first, rad or m (one
            number for all joints or n numbers, >= 0; 0: none): the dwell ends with the
            whole cycles of q = P_k + a·sin(2π·f·τ) that fit in it, so every drive slides
            back and forth about the pose and its dry friction, sliding, averages out over
            the cycles instead of holding anywhere in its band (what the payload
            identification at stops needs, docs/identification.md).
        dither_frequency: f, Hz (> 0).

    Returns:
        A :class:`WaypointsTrajectory` of duration Σ dwell + Σ move_time (s).

    Raises:
        InputError: fewer than two poses, rows of different lengths, wrong
            counts, move times <= 0, negative dwells, non-finite values, an
            unknown profile.

    Example:
        >>> traj = waypoints([[0.0, 0.0], [1.0, -1.0]], move_time=[2.0], dwell=[0.0, 1.0],
        ...                  profile="trapezoidal")
        >>> q, qd, qdd = traj.sample(1.0)
        >>> q.tolist(), qd.tolist()
        ([0.5, -0.5], [0.75, -0.75])
    """
    src = "waypoints"
    try:
        P = np.asarray(points, dtype=float)
    except (TypeError, ValueError):
        raise InputError(src, "points", "expected rows of numbers (one pose a row, rad or m) "
                         "of equal length") from None
    if P.ndim != 2 or P.shape[0] < 2 or P.shape[1] == 0:
        raise InputError(src, "points", f"expected at least two poses, each a row of joint "
                         f"values (rad or m), got shape {P.shape}")
    bad = np.argwhere(~np.isfinite(P))
    if bad.size:
        raise InputError(src, f"points[{bad[0, 0]}][{bad[0, 1]}]", "must be a finite number")
    m = P.shape[0]
    T = vector(move_time, "move_time", src, m - 1, allow_scalar=True)
    if np.any(T <= 0):
        k = int(np.flatnonzero(T <= 0)[0])
        raise InputError(src, f"move_time[{k}]", f"must be > 0 s, got {T[k]}")
    W = vector(dwell, "dwell", src, m, allow_scalar=True)
    if np.any(W < 0):
        k = int(np.flatnonzero(W < 0)[0])
        raise InputError(src, f"dwell[{k}]", f"must be >= 0 s, got {W[k]}")
    require_choice(src, "profile", profile, PROFILES)
    A = vector(dither, "dither", src, P.shape[1], allow_scalar=True)
    if np.any(A < 0):
        k = int(np.flatnonzero(A < 0)[0])
        raise InputError(src, f"dither[{k}]", f"must be >= 0 (rad or m), got {A[k]}")
    f = float(dither_frequency)
    if not (np.isfinite(f) and f > 0):
        raise InputError(src, "dither_frequency", f"must be > 0 Hz, got {dither_frequency}")
    if A.any():
        _check_dither_cycles(src, W, f)
    return WaypointsTrajectory(P, T, W, profile, dither=A, dither_frequency=f)


def _check_dither_cycles(src: str, dwell: np.ndarray, f: float) -> None:
    """Warn when a dithered dwell cannot give the identification at stops its whole cycles:
    its first cycle is the start transient (the drives still stuck from the stop; left
    out), and ``DITHER_CYCLES_MIN`` steady cycles of at most ``DITHER_PERIOD_MAX`` must
    remain (:func:`manipcad.dynamics.identification.find_stops`)."""
    need = DITHER_CYCLES_MIN + 1
    held = dwell[1:][dwell[1:] > 0]
    short = held[np.floor(held * f + 1e-9) < need]
    if 1.0 / f > DITHER_PERIOD_MAX or short.size:
        low = max(1.0 / DITHER_PERIOD_MAX, need / float(held.min())) if held.size else \
            1.0 / DITHER_PERIOD_MAX
        warnings.warn(ManipcadWarning(
            f"{src}: dither_frequency {f:g} Hz gives "
            + (f"a period over {DITHER_PERIOD_MAX:g} s" if 1.0 / f > DITHER_PERIOD_MAX else
               f"{int(np.floor(short.min() * f + 1e-9))} whole cycle(s) in the "
               f"{short.min():g} s dwell")
            + f": the payload identification at stops needs {need} whole cycles of at "
            f"most {DITHER_PERIOD_MAX:g} s per dwell (the first is the start transient, "
            f"left out): use dither_frequency >= {low:.3g} Hz with these dwells, or longer "
            "dwells"), stacklevel=3)
