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
import types

import numba as nb
import numpy as np

from manipcad.model.robot import (
    COL_BV,
    COL_COM,
    COL_FCN,
    COL_FCP,
    COL_IC,
    COL_MASS,
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
def get3(M, i, o):
    """The 3-vector M[i, o:o + 3] as a tuple."""
    return M[i, o], M[i, o + 1], M[i, o + 2]


@inline
def put3(M, i, o, x, y, z):
    """Store (x, y, z) in M[i, o:o + 3]."""
    M[i, o] = x
    M[i, o + 1] = y
    M[i, o + 2] = z


@inline
def add3(M, i, o, x, y, z):
    """Add (x, y, z) to M[i, o:o + 3]."""
    M[i, o] = M[i, o] + x
    M[i, o + 1] = M[i, o + 1] + y
    M[i, o + 2] = M[i, o + 2] + z


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


@inline
def origin_inertia(table, i):
    """Link i's mass (kg), first moment h = m·c (kg·m) and inertia about its body
    origin I_O = I_c + m (|c|² E - c cᵀ) (kg·m², upper triangle i00 i01 i02 i11 i12 i22),
    body axes: ``(m, h0, h1, h2, i00, i01, i02, i11, i12, i22)``."""
    m = table[i, COL_MASS]
    c0 = table[i, COL_COM]
    c1 = table[i, COL_COM + 1]
    c2 = table[i, COL_COM + 2]
    h0 = m * c0
    h1 = m * c1
    h2 = m * c2
    hc0 = h0 * c0
    hc1 = h1 * c1
    hc2 = h2 * c2
    return (m, h0, h1, h2,
            table[i, COL_IC] + hc1 + hc2,
            table[i, COL_IC + 1] - h0 * c1,
            table[i, COL_IC + 2] - h0 * c2,
            table[i, COL_IC + 4] + hc0 + hc2,
            table[i, COL_IC + 5] - h1 * c2,
            table[i, COL_IC + 8] + hc0 + hc1)


# ------------------------------------------------------- the twins of a batch kernel
# A batch kernel ``batch(table, g, X, Y, Z, FEXT, use_fext, drives, OUT)`` runs the
# states in the rows of X, Y, Z (N, n) into OUT and returns the index of the first
# state it could not solve, or -1. Its parallel twin and its one-state twin are the
# two templates below with ``BATCH`` bound to it. They are copies of the template's
# code under their own names rather than closures: numba's on-disk cache keys a
# closure by its pickled cells, and a pickled compiled function differs from process
# to process, so a closure would compile again in every process.

BATCH = None  # bound in each twin's globals


def _rows_in_chunks(table, g, X, Y, Z, FEXT, use_fext, drives, OUT, chunks):
    """The batch kernel on ``chunks`` chunks of rows, run on numba's threads."""
    N = X.shape[0]
    bad = np.empty(chunks, dtype=np.int64)
    for c in nb.prange(chunks):
        a = c * N // chunks
        b = (c + 1) * N // chunks
        k = BATCH(table, g, X[a:b], Y[a:b], Z[a:b], FEXT[a:b] if use_fext else FEXT,
                  use_fext, drives, OUT[a:b])
        bad[c] = k + a if k >= 0 else -1
    for c in range(chunks):
        if bad[c] >= 0:
            return bad[c]
    return -1


def _one_state(table, g, x, y, z, drives, out, fext, use_fext):
    """One state: the fast path of the public function, the batch kernel on a batch of one.

    Compiled on first use with fixed argument types, those of the batch path
    (see :func:`manipcad.dynamics._inputs.vector_kernel`); raises ValueError
    when a length is not n, so the caller can fall back to the checked path.
    """
    n = table.shape[0]
    if x.shape[0] != n or y.shape[0] != n or z.shape[0] != n or out.shape[0] != n:
        raise ValueError("a vector's length is not the number of joints")
    return BATCH(table, g, x.reshape((1, n)), y.reshape((1, n)), z.reshape((1, n)),
                 fext, use_fext, drives, out.reshape((1, n)))


def _bound(template, batch, name: str):
    func = types.FunctionType(template.__code__, dict(template.__globals__, BATCH=batch),
                              name)
    func.__qualname__ = name
    func.__doc__ = template.__doc__
    return func


def batch_twins(batch, prefix: str):
    """The parallel and the one-state twin of a batch kernel (see the note above).

    Returns ``(parallel, vector)``: ``parallel(*args, chunks)`` is compiled (cached)
    and runs on numba's threads; ``vector`` is plain Python, compiled with fixed
    argument types by :func:`manipcad.dynamics._inputs.vector_kernel`.
    """
    parallel = nb.njit(cache=True, nogil=True, parallel=True)(
        _bound(_rows_in_chunks, batch, f"{prefix}_batch_parallel"))
    return parallel, _bound(_one_state, batch, f"{prefix}_vector")
