"""The cosine law q = q0 + A(1 - cos ωt) of the paper's Fig. 3 (laws (2)).

Per joint i, for 0 <= t <= duration:

    q_i   = q0_i + A_i (1 - cos ω_i t)
    qd_i  = A_i ω_i sin ω_i t
    qdd_i = A_i ω_i² cos ω_i t

The motion starts at rest (qd = 0) but with the acceleration A·ω², and returns
to q0 at rest after each period 2π/ω. A joint with A = 0 or ω = 0 holds q0.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np

from manipcad.errors import InputError
from manipcad.trajectories.base import Trajectory, floats, positive, vector


class CosineTrajectory(Trajectory):
    """q = q0 + A(1 - cos ωt) per joint; build it with :func:`cosine`.

    Attributes:
        amplitude: (n,) A, rad or m.
        omega: (n,) ω, rad/s.
        q0: (n,) start position, rad or m.

    Example:
        >>> traj = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], duration=1.6)
        >>> traj.sample(0.0)[2].tolist()  # the start acceleration A·ω², rad/s² or m/s²
        [8.0, 0.0, 64.0]
    """

    kind = "cosine"

    def __init__(self, amplitude: np.ndarray, omega: np.ndarray, duration: float,
                 q0: np.ndarray) -> None:
        self.amplitude, self.omega, self.q0 = amplitude, omega, q0
        self._duration = duration

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.amplitude.shape[0]

    @property
    def duration(self) -> float:
        """Length of the motion, s."""
        return self._duration

    def _evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        wt = t[:, None] * self.omega[None, :]
        A, w = self.amplitude, self.omega
        q = self.q0 + A * (1.0 - np.cos(wt))
        qd = A * w * np.sin(wt)
        qdd = A * w * w * np.cos(wt)
        return q, qd, qdd

    def to_dict(self) -> dict[str, Any]:
        """The YAML mapping: type, amplitude (rad or m), omega (rad/s), duration (s), q0."""
        return {"type": self.kind, "amplitude": floats(self.amplitude),
                "omega": floats(self.omega), "duration": float(self.duration),
                "q0": floats(self.q0)}


def cosine(amplitude: Sequence[float] | float, omega: Sequence[float] | float,
           duration: float | None = None, q0: Sequence[float] | float = 0.0,
           ) -> CosineTrajectory:
    """The cosine law q = q0 + A(1 - cos ωt) (the paper's laws (2)).

    Args:
        amplitude: A per joint, rad or m (a single value is used for every joint).
        omega: ω per joint, rad/s, >= 0 (a single value is used for every joint).
        duration: length of the motion, s, >= 0; default one period 2π/ω of the
            slowest moving joint (0 when no joint moves). After it the
            trajectory holds (qd = qdd = 0).
        q0: start position per joint, rad or m (one value for all, default 0).

    Returns:
        A :class:`CosineTrajectory`.

    Raises:
        InputError: lengths that differ, negative ω or duration, non-finite values.

    Example:
        >>> # the paper's Fig. 3: q1 = 0.5(1 - cos 4t), q2 held, q3 = 0.25(1 - cos 16t)
        >>> traj = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], duration=1.6)
        >>> traj.n
        3
    """
    src = "cosine"
    n = max(np.size(amplitude), np.size(omega))
    A = vector(amplitude, "amplitude", src, n, allow_scalar=True)
    W = vector(omega, "omega", src, n, allow_scalar=True)
    neg = np.flatnonzero(W < 0)
    if neg.size:
        raise InputError(src, f"omega[{neg[0]}]", f"must be >= 0 rad/s, got {W[neg[0]]}")
    Q0 = vector(q0, "q0", src, n, allow_scalar=True)
    if duration is None:
        moving = W[(W > 0) & (A != 0)]
        T = float(2.0 * np.pi / moving.min()) if moving.size else 0.0
    else:
        T = positive(duration, "duration", src, allow_zero=True)
    return CosineTrajectory(A, W, T, Q0)
