"""Small rotation helpers shared by the kinematics and the Cartesian trajectories.

All functions accept a single rotation or a batch (leading axes) and work in
radians.
"""

from __future__ import annotations

import numpy as np


def rot_z_batch(theta: np.ndarray) -> np.ndarray:
    """Rotations about z by angles theta (rad), shape (...,) -> (..., 3, 3).

    Example:
        >>> import numpy as np
        >>> rot_z_batch(np.array([np.pi / 2])).round(12)[0, 0]
        array([ 0., -1.,  0.])
    """
    theta = np.asarray(theta, dtype=float)
    c, s = np.cos(theta), np.sin(theta)
    out = np.zeros(theta.shape + (3, 3))
    out[..., 0, 0] = c
    out[..., 0, 1] = -s
    out[..., 1, 0] = s
    out[..., 1, 1] = c
    out[..., 2, 2] = 1.0
    return out


def rotation_vector(R: np.ndarray) -> np.ndarray:
    """The rotation vector (axis times angle, rad) of rotation matrices, (..., 3, 3) -> (..., 3).

    The logarithm map of SO(3), accurate near 0 and near pi.

    Example:
        >>> import numpy as np
        >>> from manipcad.kinematics.rotations import rot_z_batch
        >>> rotation_vector(rot_z_batch(np.array(0.3))).round(12)
        array([0. , 0. , 0.3])
    """
    R = np.asarray(R, dtype=float)
    flat = R.reshape(-1, 3, 3)
    out = np.empty((flat.shape[0], 3))
    for k, M in enumerate(flat):
        out[k] = _log_one(M)
    return out.reshape(R.shape[:-2] + (3,))


def _log_one(M: np.ndarray) -> np.ndarray:
    w = np.array([M[2, 1] - M[1, 2], M[0, 2] - M[2, 0], M[1, 0] - M[0, 1]])
    cos = np.clip((np.trace(M) - 1.0) / 2.0, -1.0, 1.0)
    sin = 0.5 * np.linalg.norm(w)
    angle = np.arctan2(sin, cos)
    if angle < 1e-6:
        # first-order series: w/2 * (1 + angle²/6)
        return 0.5 * w * (1.0 + angle * angle / 6.0)
    if np.pi - angle > 1e-4:
        return w * (angle / (2.0 * sin))
    # near pi: the axis from the symmetric part, its sign from w
    S = 0.5 * (M + M.T) - cos * np.eye(3)
    axis = S[np.argmax(np.diag(S))]
    axis = axis / np.linalg.norm(axis)
    if axis @ w < 0:
        axis = -axis
    return axis * angle


def skew(v: np.ndarray) -> np.ndarray:
    """The cross-product matrix [v]x of vectors, (..., 3) -> (..., 3, 3).

    Example:
        >>> import numpy as np
        >>> skew(np.array([0.0, 0.0, 1.0])) @ np.array([1.0, 0.0, 0.0])
        array([0., 1., 0.])
    """
    v = np.asarray(v, dtype=float)
    out = np.zeros(v.shape + (3,))
    out[..., 0, 1] = -v[..., 2]
    out[..., 0, 2] = v[..., 1]
    out[..., 1, 0] = v[..., 2]
    out[..., 1, 2] = -v[..., 0]
    out[..., 2, 0] = -v[..., 1]
    out[..., 2, 1] = v[..., 0]
    return out


def cross(a: np.ndarray, b: np.ndarray) -> np.ndarray:
    """Cross product of 3-vectors along the last axis (a faster np.cross for small batches).

    Example:
        >>> import numpy as np
        >>> cross(np.array([1.0, 0.0, 0.0]), np.array([0.0, 1.0, 0.0]))
        array([0., 0., 1.])
    """
    a0, a1, a2 = a[..., 0], a[..., 1], a[..., 2]
    b0, b1, b2 = b[..., 0], b[..., 1], b[..., 2]
    return np.stack([a1 * b2 - a2 * b1, a2 * b0 - a0 * b2, a0 * b1 - a1 * b0], axis=-1)
