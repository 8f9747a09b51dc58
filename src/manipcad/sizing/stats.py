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
