"""Argument checks shared by the public dynamics functions (kept cheap: they run per call)."""

from __future__ import annotations

import numpy as np

from manipcad.errors import ManipcadError

_NO_FEXT = np.zeros((1, 1, 6))


def as_states(n: int, **arrays) -> tuple[list[np.ndarray], bool]:
    """Coerce joint arrays to (N, n) float64; return them and whether the input was one state.

    Raises ManipcadError naming the argument when a shape is wrong. NaN propagates
    to the result as in numpy (no per-call scan: this runs on every call).
    """
    out = []
    shape = None
    for name, x in arrays.items():
        a = x if type(x) is np.ndarray and x.dtype == np.float64 else np.asarray(x, np.float64)
        if a.ndim == 1:
            a = a.reshape(1, -1)
        elif a.ndim != 2:
            raise ManipcadError(f"{name} must have shape (n,) or (N, n) with n = {n}, "
                                f"got {np.shape(x)}")
        if a.shape[1] != n:
            raise ManipcadError(f"{name} must have n = {n} columns (one per joint), "
                                f"got shape {np.shape(x)}")
        if shape is None:
            shape, single = a.shape, np.ndim(x) == 1
        elif a.shape != shape or (np.ndim(x) == 1) != single:
            raise ManipcadError(f"{name} has shape {np.shape(x)}, the first argument "
                                f"{shape[1:] if single else shape}")
        out.append(a if a.flags.c_contiguous else np.ascontiguousarray(a))
    return out, single


def as_gravity(robot, gravity) -> np.ndarray:
    """The gravity vector (3,), m/s²: the robot's unless one is given."""
    if gravity is None:
        return robot.gravity
    g = np.asarray(gravity, dtype=np.float64)
    if g.shape != (3,) or not np.isfinite(g).all():
        raise ManipcadError("gravity must be a finite vector of shape (3,), "
                            f"got {np.shape(gravity)}")
    return g


def as_fext(n: int, N: int, single: bool, f_ext) -> tuple[np.ndarray, bool]:
    """External wrenches as (N, n, 6) [force N, moment N·m] per link, or a dummy when None."""
    if f_ext is None:
        return _NO_FEXT, False
    f = np.asarray(f_ext, dtype=np.float64)
    if f.shape == (n, 6):
        f = np.broadcast_to(f, (N, n, 6))
    elif f.shape != (N, n, 6) or single:
        want = f"({n}, 6)" if single else f"({n}, 6) or ({N}, {n}, 6)"
        raise ManipcadError(f"f_ext must have shape {want}: [force, moment] per link, "
                            f"got {f.shape}")
    if not np.isfinite(f).all():
        raise ManipcadError("f_ext holds NaN or infinite values")
    return np.ascontiguousarray(f), True
