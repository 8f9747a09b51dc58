"""Scalar building blocks shared by the compiled dynamics kernels.

Everything here is written with explicit scalar arithmetic on arrays passed in,
so the same source runs compiled (numba) and, for operation counting, as plain
Python on arrays of counting numbers (see :mod:`manipcad.dynamics.counts`).
Kernels call these helpers through module globals, which the counter swaps.
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

jit = nb.njit(cache=True, fastmath=False, nogil=True)


@jit
def joint_transform(table, i, qi, R, p):
    """Pose of body i in its parent's body frame at joint value qi (rad or m).

    Writes R (9, row-major, parent <- body) and p (3, m). For a revolute joint
    R = R_placement · Rot_z(qi + offset); for a prismatic one the placement
    origin moves along the placement's z column.
    """
    th = qi + table[i, COL_OFFSET]
    if table[i, COL_TYPE] == 0.0:
        c = math.cos(th)
        s = math.sin(th)
        for r in range(3):
            a = table[i, COL_R + 3 * r]
            b = table[i, COL_R + 3 * r + 1]
            R[3 * r] = a * c + b * s
            R[3 * r + 1] = b * c - a * s
            R[3 * r + 2] = table[i, COL_R + 3 * r + 2]
            p[r] = table[i, COL_P + r]
    else:
        for r in range(3):
            for k in range(3):
                R[3 * r + k] = table[i, COL_R + 3 * r + k]
            p[r] = table[i, COL_P + r] + table[i, COL_R + 3 * r + 2] * th


@jit
def rot_t(R, v, out):
    """out = Rᵀ v (parent axes -> body axes)."""
    out[0] = R[0] * v[0] + R[3] * v[1] + R[6] * v[2]
    out[1] = R[1] * v[0] + R[4] * v[1] + R[7] * v[2]
    out[2] = R[2] * v[0] + R[5] * v[1] + R[8] * v[2]


@jit
def rot(R, v, out):
    """out = R v (body axes -> parent axes)."""
    out[0] = R[0] * v[0] + R[1] * v[1] + R[2] * v[2]
    out[1] = R[3] * v[0] + R[4] * v[1] + R[5] * v[2]
    out[2] = R[6] * v[0] + R[7] * v[1] + R[8] * v[2]


@jit
def cross(a, b, out):
    """out = a × b (out must not alias a or b)."""
    out[0] = a[1] * b[2] - a[2] * b[1]
    out[1] = a[2] * b[0] - a[0] * b[2]
    out[2] = a[0] * b[1] - a[1] * b[0]


@jit
def drive_friction(table, i, qdi):
    """Joint-referred drive friction k_v·i_r²·qd + |i_r|·M_f·sign(qd), N·m or N."""
    f = table[i, COL_BV] * qdi
    if qdi > 0.0:
        f = f + table[i, COL_FCP]
    elif qdi < 0.0:
        f = f - table[i, COL_FCN]
    return f


@jit
def parent_of(table, i):
    """Parent index of joint i (-1 for the base)."""
    return int(table[i, COL_PARENT])
