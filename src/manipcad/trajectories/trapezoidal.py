"""Trapezoidal-velocity point-to-point moves, synchronised across joints.

All joints move along the straight line q = q_start + s(t)·D in joint space
(D = q_end - q_start), driven by one scalar path coordinate s from 0 to 1 with
a trapezoidal velocity profile, so they start, cruise and stop together. The
limits of joint i bound the path rate and acceleration:

    ṡ <= V = min_i v_max_i / |D_i|,   s̈ <= A = min_i a_max_i / |D_i|.

The fastest such profile accelerates at A for t_a = V / A, cruises at V and
brakes at A: T = t_a + 1/V. When V²/A > 1 the cruise speed is not reached and
the profile is triangular: t_a = 1/√A, T = 2 t_a, peak rate A·t_a. Every joint
then stays within its own v_max and a_max, and the limiting joint reaches them.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np

from manipcad.errors import InputError
from manipcad.trajectories.base import PointToPoint, floats, vector


class TrapezoidalTrajectory(PointToPoint):
    """A synchronised trapezoidal move; build it with :func:`trapezoidal`.

    Attributes:
        q_start, q_end: (n,) end positions, rad or m.
        v_max, a_max: (n,) the limits given, rad/s or m/s and rad/s² or m/s².
        t_accel: length of the acceleration (and braking) phase, s.
        triangular: True when the cruise velocity is never reached.
        peak_velocity: (n,) the joints' largest |qd|, rad/s or m/s.
        peak_acceleration: (n,) the joints' |qdd| while accelerating, rad/s² or m/s².

    Example:
        >>> traj = trapezoidal([0.0], [1.0], v_max=1.0, a_max=2.0)
        >>> traj.duration, traj.t_accel, traj.triangular
        (1.5, 0.5, False)
    """

    kind = "trapezoidal"

    def __init__(self, q_start: np.ndarray, q_end: np.ndarray, v_max: np.ndarray,
                 a_max: np.ndarray) -> None:
        self.v_max, self.a_max = v_max, a_max
        D = np.abs(q_end - q_start)
        moving = D > 0
        if not moving.any():
            self._A = self._V = 0.0
            self.t_accel, duration, self.triangular = 0.0, 0.0, True
        else:
            V = float(np.min(v_max[moving] / D[moving]))
            A = float(np.min(a_max[moving] / D[moving]))
            if V * V / A > 1.0:
                self.t_accel = 1.0 / math.sqrt(A)
                V = A * self.t_accel
                duration, self.triangular = 2.0 * self.t_accel, True
            else:
                self.t_accel = V / A
                duration, self.triangular = self.t_accel + 1.0 / V, False
            self._A, self._V = A, V
        super().__init__(q_start, q_end, duration)
        self.peak_velocity = D * self._V
        self.peak_acceleration = D * self._A

    def _profile(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        A, V, ta, T = self._A, self._V, self.t_accel, self._duration
        s = np.empty_like(t)
        sd = np.empty_like(t)
        sdd = np.empty_like(t)
        acc = t <= ta
        dec = (t > T - ta) & ~acc
        cru = ~acc & ~dec
        s[acc], sd[acc], sdd[acc] = 0.5 * A * t[acc] ** 2, A * t[acc], A
        tc = t[cru]
        s[cru], sd[cru], sdd[cru] = 0.5 * A * ta**2 + V * (tc - ta), V, 0.0
        r = T - t[dec]
        s[dec], sd[dec], sdd[dec] = 1.0 - 0.5 * A * r**2, A * r, -A
        if T == 0.0:
            s[:] = 0.0
        return s, sd, sdd

    def to_dict(self) -> dict[str, Any]:
        """The YAML mapping: type, q_start, q_end (rad or m), v_max (rad/s or m/s),
        a_max (rad/s² or m/s²)."""
        return {"type": self.kind, "q_start": floats(self.q_start),
                "q_end": floats(self.q_end), "v_max": floats(self.v_max),
                "a_max": floats(self.a_max)}


def trapezoidal(q_start: Sequence[float], q_end: Sequence[float], *,
                v_max: Sequence[float] | float, a_max: Sequence[float] | float,
                ) -> TrapezoidalTrajectory:
    """The fastest synchronised trapezoidal-velocity move within per-joint limits.

    Args:
        q_start: (n,) start position, rad or m.
        q_end: (n,) end position, rad or m.
        v_max: velocity limit per joint (or one for all), rad/s or m/s, > 0.
        a_max: acceleration limit per joint (or one for all), rad/s² or m/s², > 0.

    Returns:
        A :class:`TrapezoidalTrajectory` whose duration (s) is the least the
        limits allow for a straight line in joint space; triangular when the
        velocity limit is not reached. Zero duration when q_start == q_end.

    Raises:
        InputError: different lengths, limits <= 0, non-finite values.

    Example:
        >>> traj = trapezoidal([0.0, 0.0], [1.0, 0.2], v_max=[2.0, 2.0], a_max=1.0)
        >>> traj.triangular, traj.duration  # v_max not reached: 2·√(1/1) s
        (True, 2.0)
    """
    src = "trapezoidal"
    qs = vector(q_start, "q_start", src)
    n = qs.shape[0]
    qe = vector(q_end, "q_end", src, n)
    lim = {}
    for name, value in (("v_max", v_max), ("a_max", a_max)):
        a = vector(value, name, src, n, allow_scalar=True)
        bad = np.flatnonzero(a <= 0)
        if bad.size:
            raise InputError(src, f"{name}[{bad[0]}]", f"must be > 0, got {a[bad[0]]}")
        lim[name] = a
    return TrapezoidalTrajectory(qs, qe, lim["v_max"], lim["a_max"])


