"""Composite-rigid-body joint-space inertia matrix (paper 4.2, method 1).

The paper's block form

    I_i    = I_{i+1} + μ̄_i,            I_{n+1} = 0         (composite inertia)
    λ̄_i    = I_i · S̄_i                                      (force of unit motion)
    H_ij   = λ̄_iᵀ · S̄_j + J_i i_ri² δ_ij

kept in 3-vector form: each composite body is (mass m, first moment h = m·c,
inertia I_O about the body origin) in body axes; λ̄_i is the force screw
(f, n) that a unit motion of joint i causes on composite body i, carried
towards the base and projected on each ancestor's axis. Trees sum children.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from manipcad.dynamics._kernels_common import cross, jit, joint_pose, origin_inertia, parent_of, rot
from manipcad.model.robot import COL_JR, COL_TYPE

# per-body work row: R(9) p(3) m(1) h(3) I_O(9, about the body origin)
C_R, C_P, C_M, C_H, C_I = 0, 9, 12, 13, 16
CRBA_WORK = 25


@jit
def crba_one(table, q, drives, work, tmp, H):
    """Joint-space inertia matrix H (n, n) at q (kg·m², kg, kg·m for mixed).

    work is (n, CRBA_WORK) and tmp (at least 8 rows of 3 columns) scratch.
    """
    n = table.shape[0]
    for i in range(n):
        for j in range(n):
            H[i, j] = 0.0  # pairs on different branches of a tree stay zero
    for i in range(n):
        joint_pose(table, i, q[i], work, C_R, C_P)
        m, h0, h1, h2, i00, i01, i02, i11, i12, i22 = origin_inertia(table, i)
        work[i, C_M] = m
        work[i, C_H] = h0
        work[i, C_H + 1] = h1
        work[i, C_H + 2] = h2
        work[i, C_I] = i00
        work[i, C_I + 1] = i01
        work[i, C_I + 2] = i02
        work[i, C_I + 3] = i01
        work[i, C_I + 4] = i11
        work[i, C_I + 5] = i12
        work[i, C_I + 6] = i02
        work[i, C_I + 7] = i12
        work[i, C_I + 8] = i22
    # composite bodies, leaves first
    for i in range(n - 1, 0, -1):
        par = parent_of(table, i)
        if par < 0:
            continue
        _add_to_parent(work, i, par, tmp)
    for i in range(n):
        if table[i, COL_TYPE] == 0.0:
            # unit rotation about z: f = z × h, n = I_O z
            fx = -work[i, C_H + 1]
            fy = work[i, C_H]
            fz = 0.0
            nx = work[i, C_I + 2]
            ny = work[i, C_I + 5]
            nz = work[i, C_I + 8]
            hii = nz
        else:
            # unit translation along z: f = m z, n = h × z
            fx = 0.0
            fy = 0.0
            fz = work[i, C_M]
            nx = work[i, C_H + 1]
            ny = -work[i, C_H]
            nz = 0.0
            hii = fz
        if drives:
            hii = hii + table[i, COL_JR]
        H[i, i] = hii
        j = i
        par = parent_of(table, j)
        while par >= 0:
            # the force screw in the parent's axes: f' = R f, n' = R n + p × R f
            fx, fy, fz = rot(work, j, C_R, fx, fy, fz)
            rx, ry, rz = rot(work, j, C_R, nx, ny, nz)
            nx, ny, nz = cross(work[j, C_P], work[j, C_P + 1], work[j, C_P + 2], fx, fy, fz)
            nx = nx + rx
            ny = ny + ry
            nz = nz + rz
            j = par
            hij = nz if table[j, COL_TYPE] == 0.0 else fz
            H[i, j] = hij
            H[j, i] = hij
            par = parent_of(table, j)


@jit
def _add_to_parent(work, c, par, tmp):
    """Add composite body c (in its own axes) to its parent's, through (R, p) of c."""
    m = work[c, C_M]
    hr0, hr1, hr2 = rot(work, c, C_R, work[c, C_H], work[c, C_H + 1], work[c, C_H + 2])
    # R I_O Rᵀ, upper triangle: M = I_O Rᵀ (in tmp rows 5-7), then R M
    for a in range(3):
        for s in range(3):
            tmp[5 + a, s] = (work[c, C_I + 3 * a] * work[c, C_R + 3 * s]
                             + work[c, C_I + 3 * a + 1] * work[c, C_R + 3 * s + 1]
                             + work[c, C_I + 3 * a + 2] * work[c, C_R + 3 * s + 2])
    for r in range(3):
        for s in range(r, 3):
            work[par, C_I + 3 * r + s] = (work[par, C_I + 3 * r + s]
                                          + work[c, C_R + 3 * r] * tmp[5, s]
                                          + work[c, C_R + 3 * r + 1] * tmp[6, s]
                                          + work[c, C_R + 3 * r + 2] * tmp[7, s])
    # parallel axis with the origin moved by p: - [p][h'] - [h'][p] - m [p]²
    #  = (p·h')E·2 - p h'ᵀ - h' pᵀ + m(|p|²E - p pᵀ), with h' = R h
    p0 = work[c, C_P]
    p1 = work[c, C_P + 1]
    p2 = work[c, C_P + 2]
    ph = p0 * hr0 + p1 * hr1 + p2 * hr2
    pp = p0 * p0 + p1 * p1 + p2 * p2
    for r in range(3):
        pr = work[c, C_P + r]
        hrr = hr0 if r == 0 else (hr1 if r == 1 else hr2)
        for s in range(r, 3):
            ps = work[c, C_P + s]
            hrs = hr0 if s == 0 else (hr1 if s == 1 else hr2)
            v = -(pr * hrs + hrr * ps) - m * pr * ps
            if r == s:
                v = v + 2.0 * ph + m * pp
            work[par, C_I + 3 * r + s] = work[par, C_I + 3 * r + s] + v
    work[par, C_I + 3] = work[par, C_I + 1]
    work[par, C_I + 6] = work[par, C_I + 2]
    work[par, C_I + 7] = work[par, C_I + 5]
    work[par, C_H] = work[par, C_H] + hr0 + m * p0
    work[par, C_H + 1] = work[par, C_H + 1] + hr1 + m * p1
    work[par, C_H + 2] = work[par, C_H + 2] + hr2 + m * p2
    work[par, C_M] = work[par, C_M] + m


#: the same source inlined into the loop over states (see ``rnea_state``)
crba_state = nb.njit(nogil=True, inline="always")(crba_one.py_func)


@jit
def crba_batch(table, Q, drives, HOUT):
    """Inertia matrices of N configurations: Q (N, n) -> HOUT (N, n, n).

    The one loop over states (see :func:`manipcad.dynamics.rnea.rnea_batch`).
    """
    n = table.shape[0]
    work = np.empty((n, CRBA_WORK))
    tmp = np.zeros((8, 3))
    for k in range(Q.shape[0]):
        crba_state(table, Q[k], drives, work, tmp, HOUT[k])


@nb.njit(cache=True, nogil=True, parallel=True)
def crba_batch_parallel(table, Q, drives, HOUT, chunks):
    """:func:`crba_batch` on ``chunks`` chunks of rows, run on numba's threads."""
    N = Q.shape[0]
    for c in nb.prange(chunks):
        a = c * N // chunks
        b = (c + 1) * N // chunks
        crba_batch(table, Q[a:b], drives, HOUT[a:b])


def crba_vector(table, q, drives, H):
    """One configuration: the fast path of the public function (see ``rnea_vector``)."""
    n = table.shape[0]
    if q.shape[0] != n or H.shape[0] != n or H.shape[1] != n:
        raise ValueError("q's length is not the number of joints")
    crba_batch(table, q.reshape((1, n)), drives, H.reshape((1, n, n)))
