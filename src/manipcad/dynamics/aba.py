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
    joint_pose,
    parent_of,
    rot,
    rot_t,
)
from manipcad.model.robot import COL_COM, COL_IC, COL_JR, COL_MASS, COL_TYPE

# per-body work row: R(9) p(3) v(6) c(6) IA(36) pA(6) U(6) D u a(6)
A_R, A_P, A_V, A_C, A_IA, A_PA, A_U, A_D, A_UU, A_A = 0, 9, 12, 18, 24, 60, 66, 72, 73, 74
ABA_WORK = 80
# scratch rows of tmp (at least 23 rows of 6 columns): pa, then 3x3 blocks M, A', B', C', PC, BP
T_PA, T_M, T_A, T_B, T_C, T_PC, T_BP = 4, 5, 8, 11, 14, 17, 20


@jit
def aba_one(table, g, q, qd, tau, fext, use_fext, drives, work, tmp, qdd):
    """Joint accelerations qdd (n,) from q, qd and joint torques tau (SI units).

    work is (n, ABA_WORK) and tmp (23, 6) scratch; fext (n, 6) as in
    :func:`manipcad.dynamics.rnea.rnea_one`.
    """
    n = table.shape[0]
    # pass 1: velocities, velocity-product accelerations, rigid inertias, bias forces
    for i in range(n):
        joint_pose(table, i, q[i], work, A_R, A_P)
        par = parent_of(table, i)
        if par < 0:
            ox = 0.0
            oy = 0.0
            oz = 0.0
            vx = 0.0
            vy = 0.0
            vz = 0.0
        else:
            opx = work[par, A_V]
            opy = work[par, A_V + 1]
            opz = work[par, A_V + 2]
            ox, oy, oz = rot_t(work, i, A_R, opx, opy, opz)
            tx, ty, tz = cross(opx, opy, opz, work[i, A_P], work[i, A_P + 1], work[i, A_P + 2])
            vx, vy, vz = rot_t(work, i, A_R, tx + work[par, A_V + 3],
                               ty + work[par, A_V + 4], tz + work[par, A_V + 5])
        qdi = qd[i]
        if table[i, COL_TYPE] == 0.0:
            oz = oz + qdi
            work[i, A_C] = oy * qdi
            work[i, A_C + 1] = -ox * qdi
            work[i, A_C + 2] = 0.0
            work[i, A_C + 3] = vy * qdi
            work[i, A_C + 4] = -vx * qdi
            work[i, A_C + 5] = 0.0
        else:
            vz = vz + qdi
            work[i, A_C] = 0.0
            work[i, A_C + 1] = 0.0
            work[i, A_C + 2] = 0.0
            work[i, A_C + 3] = oy * qdi
            work[i, A_C + 4] = -ox * qdi
            work[i, A_C + 5] = 0.0
        work[i, A_V] = ox
        work[i, A_V + 1] = oy
        work[i, A_V + 2] = oz
        work[i, A_V + 3] = vx
        work[i, A_V + 4] = vy
        work[i, A_V + 5] = vz
        _rigid_inertia(table, i, work)
        # bias force v ×* (I v) - f_ext, with I v = (I_O ω + m c × v, m (v + ω × c))
        m = table[i, COL_MASS]
        c0 = table[i, COL_COM]
        c1 = table[i, COL_COM + 1]
        c2 = table[i, COL_COM + 2]
        lx = work[i, A_IA] * ox + work[i, A_IA + 1] * oy + work[i, A_IA + 2] * oz
        ly = work[i, A_IA + 6] * ox + work[i, A_IA + 7] * oy + work[i, A_IA + 8] * oz
        lz = work[i, A_IA + 12] * ox + work[i, A_IA + 13] * oy + work[i, A_IA + 14] * oz
        tx, ty, tz = cross(c0, c1, c2, vx, vy, vz)
        lx = lx + m * tx
        ly = ly + m * ty
        lz = lz + m * tz
        tx, ty, tz = cross(ox, oy, oz, c0, c1, c2)
        kx = m * (vx + tx)
        ky = m * (vy + ty)
        kz = m * (vz + tz)
        ax, ay, az = cross(ox, oy, oz, lx, ly, lz)
        bx, by, bz = cross(vx, vy, vz, kx, ky, kz)
        fx, fy, fz = cross(ox, oy, oz, kx, ky, kz)
        nx = ax + bx
        ny = ay + by
        nz = az + bz
        if use_fext:
            nx = nx - fext[i, 3]
            ny = ny - fext[i, 4]
            nz = nz - fext[i, 5]
            fx = fx - fext[i, 0]
            fy = fy - fext[i, 1]
            fz = fz - fext[i, 2]
        work[i, A_PA] = nx
        work[i, A_PA + 1] = ny
        work[i, A_PA + 2] = nz
        work[i, A_PA + 3] = fx
        work[i, A_PA + 4] = fy
        work[i, A_PA + 5] = fz
    # pass 2: articulated inertias and bias forces, tip to base
    for i in range(n - 1, -1, -1):
        ax = 2 if table[i, COL_TYPE] == 0.0 else 5
        for r in range(6):
            work[i, A_U + r] = work[i, A_IA + 6 * r + ax]
        D = work[i, A_U + ax]
        u = tau[i] - work[i, A_PA + ax]
        if drives:
            D = D + table[i, COL_JR]
            u = u - drive_friction(table, i, qd[i])
        work[i, A_D] = D
        work[i, A_UU] = u
        par = parent_of(table, i)
        if par >= 0:
            Dinv = 1.0 / D
            # Ia = IA - U Uᵀ / D (kept in IA, it is not needed again)
            for r in range(6):
                Ur = work[i, A_U + r] * Dinv
                for s in range(r, 6):
                    work[i, A_IA + 6 * r + s] = work[i, A_IA + 6 * r + s] - Ur * work[i, A_U + s]
            for r in range(6):
                for s in range(r):
                    work[i, A_IA + 6 * r + s] = work[i, A_IA + 6 * s + r]
            # pa = pA + Ia c + U u / D
            uD = u * Dinv
            for r in range(6):
                acc = work[i, A_PA + r] + work[i, A_U + r] * uD
                for s in range(6):
                    acc = acc + work[i, A_IA + 6 * r + s] * work[i, A_C + s]
                tmp[T_PA, r] = acc
            _add_inertia_to_parent(work, i, par, tmp)
            # force to parent: n_p = R n + p × R f, f_p = R f
            nx, ny, nz = rot(work, i, A_R, tmp[T_PA, 0], tmp[T_PA, 1], tmp[T_PA, 2])
            fx, fy, fz = rot(work, i, A_R, tmp[T_PA, 3], tmp[T_PA, 4], tmp[T_PA, 5])
            cx, cy, cz = cross(work[i, A_P], work[i, A_P + 1], work[i, A_P + 2], fx, fy, fz)
            work[par, A_PA] = work[par, A_PA] + nx + cx
            work[par, A_PA + 1] = work[par, A_PA + 1] + ny + cy
            work[par, A_PA + 2] = work[par, A_PA + 2] + nz + cz
            work[par, A_PA + 3] = work[par, A_PA + 3] + fx
            work[par, A_PA + 4] = work[par, A_PA + 4] + fy
            work[par, A_PA + 5] = work[par, A_PA + 5] + fz
    # pass 3: accelerations, base to tip; the base accelerates by -g
    for i in range(n):
        par = parent_of(table, i)
        if par < 0:
            lx, ly, lz = rot_t(work, i, A_R, -g[0], -g[1], -g[2])
            a0 = work[i, A_C]
            a1 = work[i, A_C + 1]
            a2 = work[i, A_C + 2]
            a3 = lx + work[i, A_C + 3]
            a4 = ly + work[i, A_C + 4]
            a5 = lz + work[i, A_C + 5]
        else:
            apx = work[par, A_A]
            apy = work[par, A_A + 1]
            apz = work[par, A_A + 2]
            ox, oy, oz = rot_t(work, i, A_R, apx, apy, apz)
            tx, ty, tz = cross(apx, apy, apz, work[i, A_P], work[i, A_P + 1], work[i, A_P + 2])
            lx, ly, lz = rot_t(work, i, A_R, tx + work[par, A_A + 3], ty + work[par, A_A + 4],
                               tz + work[par, A_A + 5])
            a0 = ox + work[i, A_C]
            a1 = oy + work[i, A_C + 1]
            a2 = oz + work[i, A_C + 2]
            a3 = lx + work[i, A_C + 3]
            a4 = ly + work[i, A_C + 4]
            a5 = lz + work[i, A_C + 5]
        acc = work[i, A_UU]
        acc = acc - work[i, A_U] * a0
        acc = acc - work[i, A_U + 1] * a1
        acc = acc - work[i, A_U + 2] * a2
        acc = acc - work[i, A_U + 3] * a3
        acc = acc - work[i, A_U + 4] * a4
        acc = acc - work[i, A_U + 5] * a5
        qddi = acc / work[i, A_D]
        qdd[i] = qddi
        if table[i, COL_TYPE] == 0.0:
            a2 = a2 + qddi
        else:
            a5 = a5 + qddi
        work[i, A_A] = a0
        work[i, A_A + 1] = a1
        work[i, A_A + 2] = a2
        work[i, A_A + 3] = a3
        work[i, A_A + 4] = a4
        work[i, A_A + 5] = a5


@jit
def _rigid_inertia(table, i, work):
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
    o = A_IA
    work[i, o] = table[i, b] + hc1 + hc2
    work[i, o + 7] = table[i, b + 4] + hc0 + hc2
    work[i, o + 14] = table[i, b + 8] + hc0 + hc1
    i01 = table[i, b + 1] - h0 * c1
    i02 = table[i, b + 2] - h0 * c2
    i12 = table[i, b + 5] - h1 * c2
    work[i, o + 1] = i01
    work[i, o + 2] = i02
    work[i, o + 8] = i12
    work[i, o + 6] = i01
    work[i, o + 12] = i02
    work[i, o + 13] = i12
    # B = m[c]× (rows 0-2, columns 3-5) and Bᵀ (rows 3-5, columns 0-2)
    work[i, o + 3] = 0.0
    work[i, o + 4] = -h2
    work[i, o + 5] = h1
    work[i, o + 9] = h2
    work[i, o + 10] = 0.0
    work[i, o + 11] = -h0
    work[i, o + 15] = -h1
    work[i, o + 16] = h0
    work[i, o + 17] = 0.0
    for r in range(3):
        for s in range(3):
            work[i, o + 6 * (3 + r) + s] = work[i, o + 6 * s + 3 + r]
    # C = m E
    for r in range(3):
        for s in range(3):
            work[i, o + 6 * (3 + r) + 3 + s] = m if r == s else 0.0


@jit
def _add_inertia_to_parent(work, i, par, tmp):
    """IA[par] += Xᵀ Ia X for the child-to-parent transform (R, p) of body i.

    With blocks Ia = [[A, B], [Bᵀ, C]] rotated into parent axes (A', B', C')
    and P = [p]×: A'' = A' - B'P - (B'P)ᵀ - P C' P, B'' = B' + P C', C'' = C'.
    """
    _sandwich(work, i, 0, 0, tmp, T_A)
    _sandwich(work, i, 0, 3, tmp, T_B)
    _sandwich(work, i, 3, 3, tmp, T_C)
    p0 = work[i, A_P]
    p1 = work[i, A_P + 1]
    p2 = work[i, A_P + 2]
    # PC = P C' (P = [p]×), BP = B' P
    for s in range(3):
        tmp[T_PC, s] = p1 * tmp[T_C + 2, s] - p2 * tmp[T_C + 1, s]
        tmp[T_PC + 1, s] = p2 * tmp[T_C, s] - p0 * tmp[T_C + 2, s]
        tmp[T_PC + 2, s] = p0 * tmp[T_C + 1, s] - p1 * tmp[T_C, s]
    for r in range(3):
        # (B P)[r, :] = B[r, :] P: columns of P are e_k × p ... written out
        tmp[T_BP + r, 0] = tmp[T_B + r, 1] * p2 - tmp[T_B + r, 2] * p1
        tmp[T_BP + r, 1] = tmp[T_B + r, 2] * p0 - tmp[T_B + r, 0] * p2
        tmp[T_BP + r, 2] = tmp[T_B + r, 0] * p1 - tmp[T_B + r, 1] * p0
    # P C' P = PC P
    o = A_IA
    for r in range(3):
        for s in range(r, 3):
            # (PC P)[r, s]
            if s == 0:
                pcp = tmp[T_PC + r, 1] * p2 - tmp[T_PC + r, 2] * p1
            elif s == 1:
                pcp = tmp[T_PC + r, 2] * p0 - tmp[T_PC + r, 0] * p2
            else:
                pcp = tmp[T_PC + r, 0] * p1 - tmp[T_PC + r, 1] * p0
            v = tmp[T_A + r, s] - tmp[T_BP + r, s] - tmp[T_BP + s, r] - pcp
            work[par, o + 6 * r + s] = work[par, o + 6 * r + s] + v
            if s != r:
                work[par, o + 6 * s + r] = work[par, o + 6 * r + s]
    for r in range(3):
        for s in range(3):
            b = tmp[T_B + r, s] + tmp[T_PC + r, s]
            work[par, o + 6 * r + 3 + s] = work[par, o + 6 * r + 3 + s] + b
            work[par, o + 6 * (3 + s) + r] = work[par, o + 6 * r + 3 + s]
    for r in range(3):
        for s in range(r, 3):
            work[par, o + 6 * (3 + r) + 3 + s] = (work[par, o + 6 * (3 + r) + 3 + s]
                                                  + tmp[T_C + r, s])
            if s != r:
                work[par, o + 6 * (3 + s) + 3 + r] = work[par, o + 6 * (3 + r) + 3 + s]


@jit
def _sandwich(work, i, r0, c0, tmp, out):
    """tmp[out:out+3, :3] = R X Rᵀ for the block X = Ia[r0:r0+3, c0:c0+3] of body i."""
    o = A_IA + 6 * r0 + c0
    for a in range(3):
        for s in range(3):
            tmp[T_M + a, s] = (work[i, o + 6 * a] * work[i, A_R + 3 * s]
                               + work[i, o + 6 * a + 1] * work[i, A_R + 3 * s + 1]
                               + work[i, o + 6 * a + 2] * work[i, A_R + 3 * s + 2])
    for r in range(3):
        for s in range(3):
            tmp[out + r, s] = (work[i, A_R + 3 * r] * tmp[T_M, s]
                               + work[i, A_R + 3 * r + 1] * tmp[T_M + 1, s]
                               + work[i, A_R + 3 * r + 2] * tmp[T_M + 2, s])


#: the same source inlined into the loop over states (see ``rnea_state``)
aba_state = nb.njit(nogil=True, inline="always")(aba_one.py_func)


@jit
def aba_batch(table, g, Q, QD, TAU, FEXT, use_fext, drives, QDD):
    """Forward dynamics of N states: rows of Q, QD, TAU (N, n) -> QDD (N, n).

    The one loop over states (see :func:`manipcad.dynamics.rnea.rnea_batch`).
    """
    n = table.shape[0]
    work = np.empty((n, ABA_WORK))
    tmp = np.empty((23, 6))
    for k in range(Q.shape[0]):
        aba_state(table, g, Q[k], QD[k], TAU[k], FEXT[k if use_fext else 0],
                  use_fext, drives, work, tmp, QDD[k])


@nb.njit(cache=True, nogil=True, parallel=True)
def aba_batch_parallel(table, g, Q, QD, TAU, FEXT, use_fext, drives, QDD, chunks):
    """:func:`aba_batch` on ``chunks`` chunks of rows, run on numba's threads."""
    N = Q.shape[0]
    for c in nb.prange(chunks):
        a = c * N // chunks
        b = (c + 1) * N // chunks
        aba_batch(table, g, Q[a:b], QD[a:b], TAU[a:b], FEXT[a:b] if use_fext else FEXT,
                  use_fext, drives, QDD[a:b])


def aba_vector(table, g, q, qd, tau, drives, qdd, fext, use_fext):
    """One state: the fast path of the public function (see ``rnea_vector``)."""
    n = table.shape[0]
    if q.shape[0] != n or qd.shape[0] != n or tau.shape[0] != n or qdd.shape[0] != n:
        raise ValueError("a vector's length is not the number of joints")
    aba_batch(table, g, q.reshape((1, n)), qd.reshape((1, n)), tau.reshape((1, n)),
              fext, use_fext, drives, qdd.reshape((1, n)))
