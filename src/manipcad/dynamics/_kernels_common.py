"""Scalar building blocks shared by the compiled dynamics kernels.

Everything here is written with explicit scalar arithmetic on arrays passed in,
so the same source runs compiled (numba) and, for operation counting, as plain
Python on arrays of counting numbers (see :mod:`manipcad.dynamics.counts`).
Kernels call these helpers through module globals, which the counter swaps.

Speed notes (see docs/performance.md): the helpers address arrays as
``(array, row, column offset)`` instead of taking slices and return 3-vectors
as tuples; those with array arguments are inlined into the kernels at
numba-IR level (``inline="always"``). A slice, or a compiled call with an
array argument, makes numba count references to the array (an atomic
operation each); tuples stay in registers, and the compiler need not fear
that a store to one scratch array changes another.
"""

from __future__ import annotations

import math

import numba as nb

from manipcad.model.robot import (
    COL_BV,
    COL_FCN,
    COL_FCP,
    COL_OFFSET,
    COL_P,
    COL_PARENT,
    COL_R,
    COL_TYPE,
)

#: decorator of the kernels and of helpers without array arguments (LLVM inlines those)
jit = nb.njit(cache=True, fastmath=False, nogil=True)
#: decorator of the small helpers with array arguments, inlined at numba-IR level:
#: a compiled call would count references to each array argument (atomic operations)
inline = nb.njit(cache=True, fastmath=False, nogil=True, inline="always")


@inline
def joint_pose(table, i, qi, out, oR, oP):
    """Pose of body i in its parent's body frame at joint value qi (rad or m).

    Writes R (row-major, parent <- body) to ``out[i, oR:oR + 9]`` and p (m) to
    ``out[i, oP:oP + 3]``. For a revolute joint R = R_placement · Rot_z(qi + offset);
    for a prismatic one the placement origin moves along the placement's z column.
    """
    th = qi + table[i, COL_OFFSET]
    if table[i, COL_TYPE] == 0.0:
        c = math.cos(th)
        s = math.sin(th)
        for r in range(3):
            a = table[i, COL_R + 3 * r]
            b = table[i, COL_R + 3 * r + 1]
            out[i, oR + 3 * r] = a * c + b * s
            out[i, oR + 3 * r + 1] = b * c - a * s
            out[i, oR + 3 * r + 2] = table[i, COL_R + 3 * r + 2]
            out[i, oP + r] = table[i, COL_P + r]
    else:
        for r in range(3):
            for k in range(3):
                out[i, oR + 3 * r + k] = table[i, COL_R + 3 * r + k]
            out[i, oP + r] = table[i, COL_P + r] + table[i, COL_R + 3 * r + 2] * th


@inline
def rot_t(M, i, o, x, y, z):
    """Rᵀ (x, y, z) for R = M[i, o:o + 9] row-major (parent axes -> body axes)."""
    return (M[i, o] * x + M[i, o + 3] * y + M[i, o + 6] * z,
            M[i, o + 1] * x + M[i, o + 4] * y + M[i, o + 7] * z,
            M[i, o + 2] * x + M[i, o + 5] * y + M[i, o + 8] * z)


@inline
def rot(M, i, o, x, y, z):
    """R (x, y, z) for R = M[i, o:o + 9] row-major (body axes -> parent axes)."""
    return (M[i, o] * x + M[i, o + 1] * y + M[i, o + 2] * z,
            M[i, o + 3] * x + M[i, o + 4] * y + M[i, o + 5] * z,
            M[i, o + 6] * x + M[i, o + 7] * y + M[i, o + 8] * z)


@jit
def cross(ax, ay, az, bx, by, bz):
    """a × b of two 3-vectors given by their components."""
    return (ay * bz - az * by, az * bx - ax * bz, ax * by - ay * bx)


@inline
def drive_friction(table, i, qdi):
    """Joint-referred drive friction k_v·i_r²·qd + |i_r|·M_f·sign(qd), N·m or N."""
    f = table[i, COL_BV] * qdi
    if qdi > 0.0:
        f = f + table[i, COL_FCP]
    elif qdi < 0.0:
        f = f - table[i, COL_FCN]
    return f


@inline
def parent_of(table, i):
    """Parent index of joint i (-1 for the base)."""
    return int(table[i, COL_PARENT])
