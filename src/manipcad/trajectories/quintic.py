"""Quintic point-to-point moves: zero velocity and acceleration at both ends.

With τ = t / T and D = q_end - q_start, for 0 <= t <= T:

    s(τ)  = 10τ³ - 15τ⁴ + 6τ⁵,  s' = 30τ²(1 - τ)²,  s'' = 60τ(1 - τ)(1 - 2τ)
    q   = q_start + D s,   qd = D s' / T,   qdd = D s'' / T²

The peak velocity is 1.875 |D| / T (at τ = 1/2) and the peak acceleration
10 / √3 · |D| / T² ≈ 5.774 |D| / T² (at τ = 1/2 ∓ √3/6).
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numba as nb
import numpy as np

from manipcad.trajectories.base import PointToPoint, floats, positive, vector


def quintic_profile(tau: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """The normalised quintic s(τ) and its derivatives ds/dτ, d²s/dτ² for τ in [0, 1].

    Example:
        >>> import numpy as np
        >>> [float(v[0]) for v in quintic_profile(np.array([0.5]))]
        [0.5, 1.875, 0.0]
    """
    tau = np.asarray(tau, dtype=float)
    # numpy's τ³ (its pow, whose last bit a compiled pow need not share), the rest in one
    # compiled pass with numpy's operations in numpy's order (the same numbers): 18 array
    # passes were some 0.1 ms of the 10,001 rows of a 1 s simulation at 1e-4 s
    flat = np.ascontiguousarray(tau).reshape(-1)
    out = tuple(np.empty(flat.shape[0]) for _ in range(3))
    _quintic_rows(flat, flat**3, *out)
    return tuple(a.reshape(tau.shape) for a in out)


@nb.njit(cache=True)
def _quintic_rows(tau, tau3, s, sd, sdd):
    """s, ṡ, s̈ of :func:`quintic_profile` from τ and τ³ (1-D), each operation as numpy
    evaluates ``tau**3 * (10.0 + tau * (-15.0 + 6.0 * tau))``, ``30.0 * tau**2 * (1.0 -
    tau) ** 2`` (a square is x·x) and ``60.0 * tau * (1.0 - tau) * (1.0 - 2.0 * tau)``."""
    for k in range(tau.shape[0]):
        x = tau[k]
        u = 1.0 - x
        s[k] = tau3[k] * (10.0 + x * (-15.0 + 6.0 * x))
        sd[k] = (30.0 * (x * x)) * (u * u)
        sdd[k] = ((60.0 * x) * u) * (1.0 - 2.0 * x)


class QuinticTrajectory(PointToPoint):
    """A quintic move from q_start to q_end in ``duration``; build it with :func:`quintic`.

    Attributes:
        q_start, q_end: (n,) end positions, rad or m.

    Example:
        >>> traj = quintic([0.0, 0.0], [1.0, -0.5], 2.0)
        >>> traj.sample(2.0)[0].tolist()
        [1.0, -0.5]
    """

    kind = "quintic"

    def _profile(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        T = self._duration
        s, sd, sdd = quintic_profile(t / T)
        return s, sd / T, sdd / T**2

    def to_dict(self) -> dict[str, Any]:
        """The YAML mapping: type, q_start, q_end (rad or m), duration (s)."""
        return {"type": self.kind, "q_start": floats(self.q_start),
                "q_end": floats(self.q_end), "duration": float(self._duration)}


def quintic(q_start: Sequence[float], q_end: Sequence[float], duration: float,
            ) -> QuinticTrajectory:
    """A quintic point-to-point move with zero end velocities and accelerations.

    Args:
        q_start: (n,) start position, rad or m.
        q_end: (n,) end position, rad or m.
        duration: time of the move, s, > 0.

    Returns:
        A :class:`QuinticTrajectory`.

    Raises:
        InputError: different lengths, a duration <= 0, non-finite values.

    Example:
        >>> traj = quintic([0.0, 0.1], [1.0, 0.3], 1.5)
        >>> traj.duration
        1.5
    """
    src = "quintic"
    qs = vector(q_start, "q_start", src)
    qe = vector(q_end, "q_end", src, qs.shape[0])
    return QuinticTrajectory(qs, qe, positive(duration, "duration", src))
