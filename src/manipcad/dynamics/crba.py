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

from manipcad.dynamics._kernels_common import cross, jit, joint_transform, parent_of, rot
from manipcad.model.robot import COL_COM, COL_IC, COL_JR, COL_MASS, COL_TYPE

# per-body work row: R(9) p(3) m(1) h(3) I_O(9, about the body origin)
C_R, C_P, C_M, C_H, C_I = 0, 9, 12, 13, 16
CRBA_WORK = 25


@jit
def crba_one(table, q, drives, work, tmp, H):
    """Joint-space inertia matrix H (n, n) at q (kg·m², kg, kg·m for mixed)."""
    n = table.shape[0]
    t0 = tmp[0]
    t1 = tmp[1]
    f = tmp[2]
    nn = tmp[3]
    for i in range(n):
        for j in range(n):
            H[i, j] = 0.0  # pairs on different branches of a tree stay zero
    for i in range(n):
        w = work[i]
        joint_transform(table, i, q[i], w[C_R:C_R + 9], w[C_P:C_P + 3])
        m = table[i, COL_MASS]
        c = table[i, COL_COM:COL_COM + 3]
        Ic = table[i, COL_IC:COL_IC + 9]
        w[C_M] = m
        h = w[C_H:C_H + 3]
        for k in range(3):
            h[k] = m * c[k]
        # I_O = I_c + m (|c|² E - c cᵀ)
        hc0 = h[0] * c[0]
        hc1 = h[1] * c[1]
        hc2 = h[2] * c[2]
        I = w[C_I:C_I + 9]
        I[0] = Ic[0] + hc1 + hc2
        I[4] = Ic[4] + hc0 + hc2
        I[8] = Ic[8] + hc0 + hc1
        I[1] = Ic[1] - h[0] * c[1]
        I[2] = Ic[2] - h[0] * c[2]
        I[5] = Ic[5] - h[1] * c[2]
        I[3] = I[1]
        I[6] = I[2]
        I[7] = I[5]
    # composite bodies, leaves first
    for i in range(n - 1, 0, -1):
        par = parent_of(table, i)
        if par < 0:
            continue
        _add_to_parent(work[i], work[par], tmp)
    for i in range(n):
        w = work[i]
        h = w[C_H:C_H + 3]
        I = w[C_I:C_I + 9]
        if table[i, COL_TYPE] == 0.0:
            # unit rotation about z: f = z × h, n = I_O z
            f[0] = -h[1]
            f[1] = h[0]
            f[2] = 0.0
            nn[0] = I[2]
            nn[1] = I[5]
            nn[2] = I[8]
            H[i, i] = nn[2]
        else:
            # unit translation along z: f = m z, n = h × z
            f[0] = 0.0
            f[1] = 0.0
            f[2] = w[C_M]
            nn[0] = h[1]
            nn[1] = -h[0]
            nn[2] = 0.0
            H[i, i] = f[2]
        if drives:
            H[i, i] = H[i, i] + table[i, COL_JR]
        j = i
        par = parent_of(table, j)
        while par >= 0:
            wj = work[j]
            R = wj[C_R:C_R + 9]
            rot(R, f, t0)
            rot(R, nn, t1)
            cross(wj[C_P:C_P + 3], t0, nn)
            for k in range(3):
                f[k] = t0[k]
                nn[k] = nn[k] + t1[k]
            j = par
            if table[j, COL_TYPE] == 0.0:
                H[i, j] = nn[2]
            else:
                H[i, j] = f[2]
            H[j, i] = H[i, j]
            par = parent_of(table, j)


@jit
def _add_to_parent(wc, wp, tmp):
    """Add composite body c (in its own axes) to its parent's, through (R, p) of c."""
    R = wc[C_R:C_R + 9]
    p = wc[C_P:C_P + 3]
    m = wc[C_M]
    hr = tmp[4]
    rot(R, wc[C_H:C_H + 3], hr)
    # R I_O Rᵀ, upper triangle: M = I_O Rᵀ, then R M
    I = wc[C_I:C_I + 9]
    M = tmp[5:8]
    for a in range(3):
        for s in range(3):
            M[a, s] = (I[3 * a] * R[3 * s] + I[3 * a + 1] * R[3 * s + 1]
                       + I[3 * a + 2] * R[3 * s + 2])
    Ip = wp[C_I:C_I + 9]
    for r in range(3):
        for s in range(r, 3):
            Ip[3 * r + s] = (Ip[3 * r + s] + R[3 * r] * M[0, s] + R[3 * r + 1] * M[1, s]
                             + R[3 * r + 2] * M[2, s])
    # parallel axis with the origin moved by p: - [p][h'] - [h'][p] - m [p]²
    #  = (p·h')E·2 - p h'ᵀ - h' pᵀ + m(|p|²E - p pᵀ), with h' = R h
    ph = p[0] * hr[0] + p[1] * hr[1] + p[2] * hr[2]
    pp = p[0] * p[0] + p[1] * p[1] + p[2] * p[2]
    for r in range(3):
        for s in range(r, 3):
            v = -(p[r] * hr[s] + hr[r] * p[s]) - m * p[r] * p[s]
            if r == s:
                v = v + 2.0 * ph + m * pp
            Ip[3 * r + s] = Ip[3 * r + s] + v
    for r in range(3):
        for s in range(r):
            Ip[3 * r + s] = Ip[3 * s + r]
    hp = wp[C_H:C_H + 3]
    for k in range(3):
        hp[k] = hp[k] + hr[k] + m * p[k]
    wp[C_M] = wp[C_M] + m


@nb.njit(cache=True, nogil=True)
def crba_batch(table, Q, drives, HOUT):
    """Inertia matrices of N configurations: Q (N, n) -> HOUT (N, n, n)."""
    n = table.shape[0]
    work = np.empty((n, CRBA_WORK))
    tmp = np.zeros((8, 3))
    for k in range(Q.shape[0]):
        crba_one(table, Q[k], drives, work, tmp, HOUT[k])
