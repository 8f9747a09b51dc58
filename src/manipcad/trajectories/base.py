"""The :class:`Trajectory` interface shared by every motion law, and argument checks.

A trajectory gives the desired joint positions q (rad or m), velocities qd
(rad/s or m/s) and accelerations qdd (rad/s² or m/s²) of all n joints as
functions of time t (s), for 0 <= t. It is defined on [0, duration]; after
``duration`` it holds: q stays at its final value and qd = qdd = 0 (a law
whose velocity is not zero at ``duration``, such as a cosine law cut
mid-period, therefore jumps there).
"""

from __future__ import annotations

from abc import ABC, abstractmethod
from typing import Any

import numba as nb
import numpy as np

from manipcad.errors import InputError


class Trajectory(ABC):
    """A joint-space motion law q(t) of n joints, sampled with its derivatives.

    Subclasses implement :meth:`_evaluate` on times inside [0, duration] and
    :meth:`to_dict`; :meth:`sample` adds the argument checks and the hold after
    ``duration``.

    Example:
        >>> import numpy as np
        >>> from manipcad.trajectories import cosine
        >>> traj = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], duration=1.6)
        >>> q, qd, qdd = traj.sample(np.linspace(0.0, 1.6, 5))
        >>> q.shape, traj.n, traj.duration
        ((5, 3), 3, 1.6)
    """

    #: the ``type`` key of the YAML schema
    kind: str = ""

    #: each row of :meth:`sample` depends on its own time only, not on the other times
    #: sampled with it (so a row is the same in any batch; the simulator then takes the
    #: start q(0) from the first chunk's rows instead of sampling t = 0 apart)
    rows_independent: bool = True

    @property
    @abstractmethod
    def n(self) -> int:
        """Number of joints."""

    @property
    @abstractmethod
    def duration(self) -> float:
        """Length of the motion, s; the trajectory holds its final state afterwards."""

    @abstractmethod
    def _evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """q, qd, qdd of shape (len(t), n) for times 0 <= t <= duration (s)."""

    @abstractmethod
    def to_dict(self) -> dict[str, Any]:
        """The YAML mapping of this trajectory (``type`` plus its fields, SI units)."""

    def sample(self, t: float | np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Positions, velocities and accelerations at times t.

        Args:
            t: a time or a 1-D array of times, s, each >= 0 and finite.

        Returns:
            ``(q, qd, qdd)``, each of shape (len(t), n) for an array (or (n,)
            for a scalar t): rad, rad/s, rad/s² for revolute joints and m, m/s,
            m/s² for prismatic ones. After ``duration`` q holds its final value
            and qd = qdd = 0.

        Raises:
            InputError: negative, non-finite or multi-dimensional times.

        Example:
            >>> from manipcad.trajectories import quintic
            >>> q, qd, qdd = quintic([0.0], [1.0], 2.0).sample(1.0)
            >>> float(q[0]), float(qd[0])
            (0.5, 0.9375)
        """
        tt = np.asarray(t, dtype=float)
        scalar = tt.ndim == 0
        tt = np.atleast_1d(tt)
        if tt.ndim != 1:
            raise InputError("t", "", f"expected a time or a 1-D array of times, got shape "
                             f"{np.shape(t)}")
        if not np.all(np.isfinite(tt)) or np.any(tt < 0):
            raise InputError("t", "", "times must be finite and >= 0 s")
        T = self.duration
        held = tt > T
        q, qd, qdd = self._evaluate(np.minimum(tt, T))
        if held.any():
            qd[held] = 0.0
            qdd[held] = 0.0
        if scalar:
            return q[0], qd[0], qdd[0]
        return q, qd, qdd

    def __repr__(self) -> str:
        return f"{type(self).__name__}(n={self.n}, duration={self.duration:g} s)"


class PointToPoint(Trajectory):
    """A joint-space move along the straight line from q_start to q_end.

    All joints follow one path coordinate s(t), from 0 at t = 0 to 1 at
    ``duration``: q = q_start + s·D, qd = ṡ·D, qdd = s̈·D with D = q_end - q_start,
    so they start and stop together. Subclasses give s, ṡ (1/s) and s̈ (1/s²)
    by :meth:`_profile`, and the YAML mapping by :meth:`to_dict`.

    Attributes:
        q_start, q_end: (n,) end positions, rad or m.
    """

    def __init__(self, q_start: np.ndarray, q_end: np.ndarray, duration: float) -> None:
        self.q_start, self.q_end = q_start, q_end
        self._duration = duration

    @property
    def n(self) -> int:
        """Number of joints."""
        return self.q_start.shape[0]

    @property
    def duration(self) -> float:
        """Length of the move, s."""
        return self._duration

    @abstractmethod
    def _profile(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """s (1), ṡ (1/s) and s̈ (1/s²), each of shape (len(t),), for 0 <= t <= duration (s)."""

    def _evaluate(self, t: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        s, sd, sdd = self._profile(t)
        q0 = np.ascontiguousarray(self.q_start, dtype=float)
        D = np.ascontiguousarray(self.q_end - q0)
        # compiled rather than numpy's broadcast of (K, 1) against (n,), whose inner loop
        # is n long: the same numbers, 2.0 against 3.6 µs for one row, 12.7 against
        # 49.8 µs for 1,000 (about 0.2 ms per product for the 10,001 rows of a 1 s
        # simulation at 1e-4 s)
        out = tuple(np.empty((len(t), len(D))) for _ in range(3))
        _along(q0, np.ascontiguousarray(s, dtype=float), np.ascontiguousarray(sd, dtype=float),
               np.ascontiguousarray(sdd, dtype=float), D, *out)
        return out


@nb.njit(cache=True)
def _along(q0, s, sd, sdd, D, Q, QD, QDD):
    """Q = q0 + s·D, QD = sd·D, QDD = sdd·D row by row (s, sd, sdd (K,); q0, D (n,))."""
    for k in range(s.shape[0]):
        for j in range(D.shape[0]):
            Q[k, j] = q0[j] + s[k] * D[j]
            QD[k, j] = sd[k] * D[j]
            QDD[k, j] = sdd[k] * D[j]


# ------------------------------------------------------------------ argument checks
def vector(value: Any, field: str, source: str, n: int | None = None, *,
           allow_scalar: bool = False) -> np.ndarray:
    """A finite 1-D float array from ``value``; raises :class:`InputError` naming the field.

    Args:
        value: a sequence of numbers (or one number when ``allow_scalar``).
        field: the field name reported in errors.
        source: the constructor or file name reported in errors.
        n: the required length, or None for any length >= 1.
        allow_scalar: broadcast a single number (or a 1-element list) to length n.

    Example:
        >>> vector([1, 2], "q_start", "quintic").tolist()
        [1.0, 2.0]
    """
    try:
        a = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise InputError(source, field, f"expected a list of numbers, got {value!r}") from None
    if allow_scalar and n is not None and a.size == 1:
        a = np.full(n, float(a.reshape(-1)[0]))
    if a.ndim != 1 or a.size == 0:
        raise InputError(source, field, f"expected a non-empty list of numbers, got shape "
                         f"{a.shape}")
    if n is not None and a.shape[0] != n:
        raise InputError(source, field, f"has {a.shape[0]} entries, expected {n} (one per joint)")
    bad = np.flatnonzero(~np.isfinite(a))
    if bad.size:
        raise InputError(source, f"{field}[{bad[0]}]", "must be a finite number")
    return a


def positive(value: Any, field: str, source: str, *, allow_zero: bool = False) -> float:
    """A finite float > 0 (or >= 0); raises :class:`InputError` naming the field.

    Example:
        >>> positive(1.5, "duration", "quintic")
        1.5
    """
    try:
        v = float(value)
    except (TypeError, ValueError):
        raise InputError(source, field, f"expected a number, got {value!r}") from None
    if not np.isfinite(v) or v < 0 or (v == 0 and not allow_zero):
        bound = ">= 0" if allow_zero else "> 0"
        raise InputError(source, field, f"must be a finite number {bound}, got {value!r}")
    return v


def floats(a: np.ndarray) -> list[Any]:
    """Plain Python floats (nested lists) for YAML output.

    Example:
        >>> import numpy as np
        >>> floats(np.array([1, 2]))
        [1.0, 2.0]
    """
    return np.asarray(a, dtype=float).tolist()
