"""Time statistics of sampled signals: peak, RMS and mean over a time grid.

Every function takes samples ``x`` of shape (N, ...) on the time grid ``t``
(N,) in seconds and reduces the first axis. RMS and mean are time averages
over [t[0], t[-1]] by the trapezoidal rule, so they do not depend on how the
grid is cut (a non-uniform grid is weighted right). A column holding a nan
gives nan (for example the current of a joint whose motor is unknown).
"""

from __future__ import annotations

import numpy as np


def peak(x: np.ndarray, axis: int = 0) -> np.ndarray:
    """Largest magnitude max |x| along ``axis`` (same unit as x).

    Example:
        >>> import numpy as np
        >>> peak(np.array([[1.0, -3.0], [-2.0, 2.0]])).tolist()
        [2.0, 3.0]
    """
    return np.max(np.abs(x), axis=axis)


def time_mean(x: np.ndarray, t: np.ndarray, axis: int = 0) -> np.ndarray:
    """Time average (1/T)∫x dt over the grid t (s), trapezoidal rule; unit of x.

    Example:
        >>> import numpy as np
        >>> float(time_mean(np.array([0.0, 1.0, 2.0]), np.array([0.0, 1.0, 2.0])))
        1.0
    """
    T = float(t[-1] - t[0])
    return np.trapezoid(x, t, axis=axis) / T


def time_rms(x: np.ndarray, t: np.ndarray, axis: int = 0) -> np.ndarray:
    """Root mean square sqrt((1/T)∫x² dt) over the grid t (s), trapezoidal rule; unit of x.

    Example:
        >>> import numpy as np
        >>> t = np.linspace(0.0, 1.0, 100001)
        >>> round(float(time_rms(np.sin(2 * np.pi * t), t)), 6)  # 1/sqrt(2)
        0.707107
    """
    return np.sqrt(time_mean(np.square(x), t, axis=axis))


def weighted_cubic_mean(x: np.ndarray, w: np.ndarray, t: np.ndarray, axis: int = 0) -> np.ndarray:
    """Cubic mean of |x| weighted by |w|, (∫|w|·|x|³ dt / ∫|w| dt)^(1/3) (trapezoids); unit of x.

    Harmonic Drive's "average load torque" (``x`` the output torque, ``w`` the
    output speed: the time a torque acts counts in proportion to the turns made
    under it). Where the weight integrates to 0 (a gear that never turns), the
    plain time cubic mean ((1/T)∫|x|³ dt)^(1/3) is returned, the limit of the
    weighted one for a uniformly vanishing speed.

    Args:
        x: (N, ...) samples (e.g. torque, N·m).
        w: (N, ...) weights, same shape (e.g. speed, rad/s; only |w| counts).
        t: (N,) time grid, s.
        axis: the time axis.

    Returns:
        The weighted cubic mean, unit of x (nan where x or w holds a nan).

    Example:
        >>> import numpy as np
        >>> t = np.array([0.0, 1.0, 1.0 + 1e-9, 2.0])      # 1 s at 1 rad/s, then 1 s at 3 rad/s
        >>> x = np.array([10.0, 10.0, 20.0, 20.0]); w = np.array([1.0, 1.0, 3.0, 3.0])
        >>> round(float(weighted_cubic_mean(x, w, t)), 4)   # ((1·1000 + 3·8000)/4)^(1/3)
        18.4202
    """
    a = np.abs(np.asarray(w, dtype=float))
    cube = np.abs(np.asarray(x, dtype=float)) ** 3
    den = np.trapezoid(a, t, axis=axis)
    num = np.trapezoid(a * cube, t, axis=axis)
    plain = time_mean(cube, t, axis=axis)
    with np.errstate(divide="ignore", invalid="ignore"):
        return np.cbrt(np.where(den > 0, num / np.where(den > 0, den, 1.0), plain))


def trapezoid_weights(t: np.ndarray) -> np.ndarray:
    """Weights w (s) with sum_k w_k·x_k = ∫x dt by the trapezoidal rule on the grid t (s),
    so that time_mean(x, t) = sum(w·x)/T. A sum over part of the samples bounds the
    whole from below when x >= 0 (how drive selection rules candidates out cheaply).

    Example:
        >>> import numpy as np
        >>> t = np.array([0.0, 1.0, 3.0])
        >>> trapezoid_weights(t).tolist()
        [0.5, 1.5, 1.0]
        >>> x = np.array([1.0, 2.0, 5.0])
        >>> float(trapezoid_weights(t) @ x / 3.0) == float(time_mean(x, t))
        True
    """
    t = np.asarray(t, dtype=float)
    h = np.diff(t)
    w = np.zeros_like(t)
    w[:-1] += h / 2
    w[1:] += h / 2
    return w

