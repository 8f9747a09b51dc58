"""Smooth motion through via points: a clamped C2 cubic spline per joint.

Given times t_0 < t_1 < ... < t_m (s) and the joint positions at them, each
joint follows the cubic spline through the points with continuous velocity
and acceleration and zero velocity at t_0 and t_m (SciPy's ``CubicSpline``
with ``bc_type="clamped"``). The trajectory holds the first point before t_0
and the last one after t_m = duration.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from manipcad.errors import InputError
from manipcad.trajectories.base import Trajectory, floats, vector


class SplineTrajectory(Trajectory):
    """A clamped cubic spline through via points; build it with :func:`spline`.

    Attributes:
        times: (m,) via-point times, s.
        points: (m, n) via-point positions, rad or m.

    Example:
        >>> traj = spline([0.0, 1.0, 2.0], [[0.0], [1.0], [0.5]])
        >>> traj.sample(1.0)[0].tolist()
        [1.0]
    """

    kind = "spline"

    def __init__(self, times: np.ndarray, points: np.ndarray) -> None:
        self.times, self.points = times, points
        # deferred: start-up cost: scipy.interpolate, 1 s to import, on first use
        from scipy.interpolate import CubicSpline

        self._q = CubicSpline(times, points, axis=0, bc_type="clamped")
        self._qd = self._q.derivative(1)
        self._qdd = self._q.derivative(2)

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.points.shape[1]

    @property
    def duration(self) -> float:
        """The last via-point time, s."""
        return float(self.times[-1])

    def _evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        q, qd, qdd = self._q(t), self._qd(t), self._qdd(t)
        before = t < self.times[0]
        if before.any():
            q[before] = self.points[0]
            qd[before] = 0.0
            qdd[before] = 0.0
        return q, qd, qdd

    def to_dict(self) -> dict[str, Any]:
        """The YAML mapping: type, times (s), points (one row per time, rad or m)."""
        return {"type": self.kind, "times": floats(self.times), "points": floats(self.points)}


def spline(times: Sequence[float], points: Sequence[Sequence[float]]) -> SplineTrajectory:
    """A C2 cubic spline through via points with zero end velocities.

    Args:
        times: (m,) strictly increasing times of the via points, s, >= 0; m >= 2.
        points: (m, n) joint positions at those times, rad or m.

    Returns:
        A :class:`SplineTrajectory` of duration ``times[-1]``.

    Raises:
        InputError: times not strictly increasing or negative, fewer than two
            points, rows of different lengths, a count of points that differs
            from the count of times, non-finite values.

    Example:
        >>> traj = spline([0.0, 0.5, 1.5], [[0.0, 0.0], [0.3, 0.1], [1.0, -0.2]])
        >>> traj.n, traj.duration
        (2, 1.5)
    """
    src = "spline"
    t = vector(times, "times", src)
    if t.shape[0] < 2:
        raise InputError(src, "times", "needs at least two via points")
    if t[0] < 0:
        raise InputError(src, "times[0]", f"must be >= 0 s, got {t[0]}")
    step = np.flatnonzero(np.diff(t) <= 0)
    if step.size:
        i = int(step[0]) + 1
        raise InputError(src, f"times[{i}]", f"times must be strictly increasing: "
                         f"{t[i]} s follows {t[i - 1]} s")
    if isinstance(points, np.ndarray):
        rows = list(points) if points.ndim >= 1 else [points]
    else:
        try:
            rows = list(points)
        except TypeError:
            raise InputError(src, "points", "expected a list of joint vectors") from None
    if len(rows) != t.shape[0]:
        raise InputError(src, "points", f"has {len(rows)} rows for {t.shape[0]} times")
    first = vector(rows[0], "points[0]", src)
    P = np.array([first] + [vector(r, f"points[{i}]", src, first.shape[0])
                            for i, r in enumerate(rows[1:], start=1)])
    return SplineTrajectory(t, P)
