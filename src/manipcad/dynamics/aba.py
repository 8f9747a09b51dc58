"""O(n) articulated-body forward dynamics (paper 4.2, method 2, the "pursuit" method).

The paper's recursion

    q̈_i    = (S̄ᵢᵀ K_i S̄_i + J_i i_ri²)⁻¹ (P_i - S̄ᵢᵀ K_i ū_{i-1} - S̄ᵢᵀ G_i)
    K_{i-1} = μ̄_i + K_i - K_i S̄_i (S̄ᵢᵀ K_i S̄_i + J_i i_ri²)⁻¹ S̄ᵢᵀ K_i
    G_{i-1} = G_i + (bias of body i-1) + K_i S̄_i (…)⁻¹ (P_i - S̄ᵢᵀ G_i)

is Featherstone's articulated-body algorithm: K is the articulated inertia
(here ``IA``), G the articulated bias force (``pA``), ū the spatial
acceleration. We run it in body frames with spatial vectors [angular; linear]
at the body origin, three passes: velocities and bias forces base to tip,
articulated inertias tip to base, accelerations base to tip. Gravity is the
base acceleration -g; the drives add J·i_r² to D_i and their friction to the
bias, so ``drives=True`` inverts :func:`manipcad.inverse_dynamics` exactly.
"""

from __future__ import annotations

import numba as nb
import numpy as np

from manipcad.dynamics._kernels_common import (
    cross,
    drive_friction,
    jit,
    joint_transform,
    parent_of,
    rot,
    rot_t,
)
from manipcad.model.robot import COL_COM, COL_IC, COL_JR, COL_MASS, COL_TYPE

# per-body work row: R(9) p(3) v(6) c(6) IA(36) pA(6) U(6) D u a(6)
A_R, A_P, A_V, A_C, A_IA, A_PA, A_U, A_D, A_UU, A_A = 0, 9, 12, 18, 24, 60, 66, 72, 73, 74
ABA_WORK = 80


@jit
def aba_one(table, g, q, qd, tau, fext, use_fext, drives, work, tmp, qdd):
    """Joint accelerations qdd (n,) from q, qd and joint torques tau (SI units)."""
    n = table.shape[0]
    t0 = tmp[0]
    t1 = tmp[1]
    t2 = tmp[2]
    t3 = tmp[3]
    # pass 1: velocities, velocity-product accelerations, rigid inertias, bias forces
    for i in range(n):
        w = work[i]
        R = w[A_R:A_R + 9]
        p = w[A_P:A_P + 3]
        joint_transform(table, i, q[i], R, p)
        om = w[A_V:A_V + 3]
        vl = w[A_V + 3:A_V + 6]
        par = parent_of(table, i)
        if par < 0:
            for k in range(3):
                om[k] = 0.0
                vl[k] = 0.0
        else:
            wp = work[par]
            rot_t(R, wp[A_V:A_V + 3], om)
            cross(wp[A_V:A_V + 3], p, t0)
            for k in range(3):
                t0[k] = t0[k] + wp[A_V + 3 + k]
            rot_t(R, t0, vl)
        c = w[A_C:A_C + 6]
        qdi = qd[i]
        if table[i, COL_TYPE] == 0.0:
            om[2] = om[2] + qdi
            c[0] = om[1] * qdi
            c[1] = -om[0] * qdi
            c[2] = 0.0
            c[3] = vl[1] * qdi
            c[4] = -vl[0] * qdi
            c[5] = 0.0
        else:
            vl[2] = vl[2] + qdi
            c[0] = 0.0
            c[1] = 0.0
            c[2] = 0.0
            c[3] = om[1] * qdi
            c[4] = -om[0] * qdi
            c[5] = 0.0
        _rigid_inertia(table, i, w[A_IA:A_IA + 36])
        # bias force v ×* (I v) - f_ext, with I v = (I_O ω + m c × v, m (v + ω × c))
        IA = w[A_IA:A_IA + 36]
        m = table[i, COL_MASS]
        cm = table[i, COL_COM:COL_COM + 3]
        for r in range(3):
            t1[r] = IA[6 * r] * om[0] + IA[6 * r + 1] * om[1] + IA[6 * r + 2] * om[2]
        cross(cm, vl, t0)
        for r in range(3):
            t1[r] = t1[r] + m * t0[r]
        cross(om, cm, t0)
        for r in range(3):
            t2[r] = m * (vl[r] + t0[r])
        pA = w[A_PA:A_PA + 6]
        cross(om, t1, t0)
        cross(vl, t2, t3)
        for r in range(3):
            pA[r] = t0[r] + t3[r]
        cross(om, t2, t0)
        for r in range(3):
            pA[3 + r] = t0[r]
        if use_fext:
            for r in range(3):
                pA[r] = pA[r] - fext[i, 3 + r]
                pA[3 + r] = pA[3 + r] - fext[i, r]
    # pass 2: articulated inertias and bias forces, tip to base
    for i in range(n - 1, -1, -1):
        w = work[i]
        IA = w[A_IA:A_IA + 36]
        pA = w[A_PA:A_PA + 6]
        U = w[A_U:A_U + 6]
        ax = 2 if table[i, COL_TYPE] == 0.0 else 5
        for r in range(6):
            U[r] = IA[6 * r + ax]
        D = U[ax]
        u = tau[i] - pA[ax]
        if drives:
            D = D + table[i, COL_JR]
            u = u - drive_friction(table, i, qd[i])
        w[A_D] = D
        w[A_UU] = u
        par = parent_of(table, i)
        if par >= 0:
            Dinv = 1.0 / D
            c = w[A_C:A_C + 6]
            # Ia = IA - U Uᵀ / D (kept in IA, it is not needed again)
            for r in range(6):
                Ur = U[r] * Dinv
                for s in range(r, 6):
                    IA[6 * r + s] = IA[6 * r + s] - Ur * U[s]
            for r in range(6):
                for s in range(r):
                    IA[6 * r + s] = IA[6 * s + r]
            # pa = pA + Ia c + U u / D
            uD = u * Dinv
            pa = tmp[4]
            for r in range(6):
                acc = pA[r] + U[r] * uD
                for s in range(6):
                    acc = acc + IA[6 * r + s] * c[s]
                pa[r] = acc
            wp = work[par]
            R = w[A_R:A_R + 9]
            p = w[A_P:A_P + 3]
            _add_inertia_to_parent(R, p, IA, wp[A_IA:A_IA + 36], tmp)
            # force to parent: n_p = R n + p × R f, f_p = R f
            rot(R, pa[0:3], t0)
            rot(R, pa[3:6], t1)
            cross(p, t1, t2)
            for r in range(3):
                wp[A_PA + r] = wp[A_PA + r] + t0[r] + t2[r]
                wp[A_PA + 3 + r] = wp[A_PA + 3 + r] + t1[r]
    # pass 3: accelerations, base to tip; the base accelerates by -g
    for i in range(n):
        w = work[i]
        R = w[A_R:A_R + 9]
        p = w[A_P:A_P + 3]
        a = w[A_A:A_A + 6]
        c = w[A_C:A_C + 6]
        par = parent_of(table, i)
        if par < 0:
            for k in range(3):
                t0[k] = -g[k]
            rot_t(R, t0, t1)
            a[0] = c[0]
            a[1] = c[1]
            a[2] = c[2]
            for k in range(3):
                a[3 + k] = t1[k] + c[3 + k]
        else:
            ap = work[par][A_A:A_A + 6]
            rot_t(R, ap[0:3], t0)
            cross(ap[0:3], p, t1)
            for k in range(3):
                t1[k] = t1[k] + ap[3 + k]
            rot_t(R, t1, t2)
            for k in range(3):
                a[k] = t0[k] + c[k]
                a[3 + k] = t2[k] + c[3 + k]
        U = w[A_U:A_U + 6]
        acc = w[A_UU]
        for r in range(6):
            acc = acc - U[r] * a[r]
        qddi = acc / w[A_D]
        qdd[i] = qddi
        if table[i, COL_TYPE] == 0.0:
            a[2] = a[2] + qddi
        else:
            a[5] = a[5] + qddi


@jit
def _rigid_inertia(table, i, IA):
    """Spatial inertia of link i at its body origin: [[I_O, m[c]×], [-m[c]×, m E]]."""
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
    b = COL_IC
    IA[0] = table[i, b] + hc1 + hc2
    IA[7] = table[i, b + 4] + hc0 + hc2
    IA[14] = table[i, b + 8] + hc0 + hc1
    IA[1] = table[i, b + 1] - h0 * c1
    IA[2] = table[i, b + 2] - h0 * c2
    IA[8] = table[i, b + 5] - h1 * c2
    IA[6] = IA[1]
    IA[12] = IA[2]
    IA[13] = IA[8]
    # B = m[c]×, rows 0-2 cols 3-5
    IA[3] = 0.0
    IA[4] = -h2
    IA[5] = h1
    IA[9] = h2
    IA[10] = 0.0
    IA[11] = -h0
    IA[15] = -h1
    IA[16] = h0
    IA[17] = 0.0
    # C = m E
    for r in range(3):
        for s in range(3):
            IA[6 * (3 + r) + 3 + s] = m if r == s else 0.0
    # Bᵀ
    for r in range(3):
        for s in range(3):
            IA[6 * (3 + r) + s] = IA[6 * s + 3 + r]


@jit
def _add_inertia_to_parent(R, p, Ia, IP, tmp):
    """IP += Xᵀ Ia X for the child-to-parent transform (R, p).

    With blocks Ia = [[A, B], [Bᵀ, C]] rotated into parent axes (A', B', C')
    and P = [p]×: A'' = A' - B'P - (B'P)ᵀ - P C' P, B'' = B' + P C', C'' = C'.
    """
    M = tmp[5:8]  # 3x3 scratch
    Ar = tmp[8:11]
    Br = tmp[11:14]
    Cr = tmp[14:17]
    _sandwich(R, Ia, 0, 0, M, Ar)
    _sandwich(R, Ia, 0, 3, M, Br)
    _sandwich(R, Ia, 3, 3, M, Cr)
    p0 = p[0]
    p1 = p[1]
    p2 = p[2]
    # PC = P C' (P = [p]×), BP = B' P
    PC = tmp[17:20]
    BP = tmp[20:23]
    for s in range(3):
        PC[0, s] = p1 * Cr[2, s] - p2 * Cr[1, s]
        PC[1, s] = p2 * Cr[0, s] - p0 * Cr[2, s]
        PC[2, s] = p0 * Cr[1, s] - p1 * Cr[0, s]
    for r in range(3):
        # (B P)[r, :] = B[r, :] P: columns of P are e_k × p ... written out
        BP[r, 0] = Br[r, 1] * p2 - Br[r, 2] * p1
        BP[r, 1] = Br[r, 2] * p0 - Br[r, 0] * p2
        BP[r, 2] = Br[r, 0] * p1 - Br[r, 1] * p0
    # P C' P = PC P
    for r in range(3):
        for s in range(r, 3):
            # (PC P)[r, s]
            if s == 0:
                pcp = PC[r, 1] * p2 - PC[r, 2] * p1
            elif s == 1:
                pcp = PC[r, 2] * p0 - PC[r, 0] * p2
            else:
                pcp = PC[r, 0] * p1 - PC[r, 1] * p0
            v = Ar[r, s] - BP[r, s] - BP[s, r] - pcp
            IP[6 * r + s] = IP[6 * r + s] + v
            if s != r:
                IP[6 * s + r] = IP[6 * r + s]
    for r in range(3):
        for s in range(3):
            b = Br[r, s] + PC[r, s]
            IP[6 * r + 3 + s] = IP[6 * r + 3 + s] + b
            IP[6 * (3 + s) + r] = IP[6 * r + 3 + s]
    for r in range(3):
        for s in range(r, 3):
            IP[6 * (3 + r) + 3 + s] = IP[6 * (3 + r) + 3 + s] + Cr[r, s]
            if s != r:
                IP[6 * (3 + s) + 3 + r] = IP[6 * (3 + r) + 3 + s]


@jit
def _sandwich(R, Ia, r0, c0, M, out):
    """out = R X Rᵀ for the 3x3 block X = Ia[r0:r0+3, c0:c0+3] (6x6 flat)."""
    for a in range(3):
        for s in range(3):
            M[a, s] = (Ia[6 * (r0 + a) + c0] * R[3 * s] + Ia[6 * (r0 + a) + c0 + 1] * R[3 * s + 1]
                       + Ia[6 * (r0 + a) + c0 + 2] * R[3 * s + 2])
    for r in range(3):
        for s in range(3):
            out[r, s] = R[3 * r] * M[0, s] + R[3 * r + 1] * M[1, s] + R[3 * r + 2] * M[2, s]


@nb.njit(cache=True, nogil=True)
def aba_batch(table, g, Q, QD, TAU, FEXT, use_fext, drives, QDD):
    """Forward dynamics of N states: rows of Q, QD, TAU (N, n) -> QDD (N, n)."""
    n = table.shape[0]
    work = np.empty((n, ABA_WORK))
    tmp = np.empty((23, 6))
    for k in range(Q.shape[0]):
        aba_one(table, g, Q[k], QD[k], TAU[k], FEXT[k if use_fext else 0],
                use_fext, drives, work, tmp, QDD[k])
