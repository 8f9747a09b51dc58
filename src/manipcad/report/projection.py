"""The orthographic view of the base frame that the Robots page draws the arm in.

A viewer looks at the base origin from ``azimuth`` about the base z axis (from x
towards y) and ``elevation`` above the x-y plane, the base z axis drawn upwards;
points of the base frame (m) land on the screen (right, up) in m, equal scale.
"""

from __future__ import annotations

import numpy as np

#: the projected stick view's first view: azimuth, elevation (rad), a three-quarter view
VIEW = (np.radians(-60.0), np.radians(25.0))


def view_axes(azimuth: float, elevation: float) -> np.ndarray:
    """The viewer's axes for an orthographic view of the base frame.

    The viewer looks at the base origin from the direction at ``azimuth`` about the
    base z axis (from x towards y) and ``elevation`` above the x-y plane, the base z
    axis drawn upwards: the view turns the base frame by Rz(azimuth)·Ry(-elevation).

    Args:
        azimuth: rad (0: looking along -x, from the +x side).
        elevation: rad (π/2: from above, the top view).

    Returns:
        (3, 3) rows in the base frame: screen right, screen up, towards the viewer.

    Example:
        >>> view_axes(0.0, 0.0).round(12) + 0.0      # from +x: y to the right, z up
        array([[0., 1., 0.],
               [0., 0., 1.],
               [1., 0., 0.]])
    """
    ca, sa = np.cos(azimuth), np.sin(azimuth)
    ce, se = np.cos(elevation), np.sin(elevation)
    return np.array([[-sa, ca, 0.0],
                     [-se * ca, -se * sa, ce],
                     [ce * ca, ce * sa, se]])


def project(points, azimuth: float, elevation: float) -> np.ndarray:
    """Points of the base frame on the screen of the orthographic view (:func:`view_axes`).

    Args:
        points: (..., 3) positions in the base frame, m.
        azimuth, elevation: the view, rad.

    Returns:
        (..., 2) screen coordinates (right, up), m; equal scale on both.

    Example:
        >>> project([0.1, 0.2, 0.3], 0.0, 0.0).round(12)
        array([0.2, 0.3])
    """
    return np.asarray(points, dtype=float) @ view_axes(azimuth, elevation)[:2].T
