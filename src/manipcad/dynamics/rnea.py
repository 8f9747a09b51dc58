"""Recursive Newton-Euler inverse dynamics (paper 4.1).

The paper's algorithm in body (link) frames with modified-DH placements:

    ω_i  = A_i^{i-1} ω_{i-1} + q̇_i l_i              (revolute)
    ω̇_i  = A_i^{i-1} ω̇_{i-1} + (A_i^{i-1} ω_{i-1}) × q̇_i l_i + q̈_i l_i
    P̈*_i = A_i^{i-1} (P̈*_{i-1} + Ω_{i-1} P*_i) [+ 2 q̇_i ω_i × l_i + q̈_i l_i  (prismatic)]
    r̈_i  = P̈*_i + Ω_i r*_i,                          P̈*_0 = -g
    f̂_i  = Σ_children A f̂_c + m_i r̈_i - F̃_i
    n̂_i  = Σ_children (A n̂_c + P*_c × A f̂_c) + r*_i × m_i r̈_i + τ_i ω̇_i + ω_i × τ_i ω_i - R_i
    P_i  = l_iᵀ n̂_i (revolute) or l_iᵀ f̂_i (prismatic)

where Ω x = ω̇ × x + ω × (ω × x). Gravity enters as the base acceleration -g.
The tree form sums over children instead of the single link i+1.
With drives the joint torque gains J·i_r²·q̈ + k_v·i_r²·q̇ + |i_r|·M_f·sign(q̇).
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

# per-body work row: R(9) p(3) w(3) wd(3) a(3) f(3) n(3)
W_R, W_P, W_W, W_WD, W_A, W_F, W_N = 0, 9, 12, 15, 18, 21, 24
RNEA_WORK = 27


@jit
def rnea_one(table, g, q, qd, qdd, fext, use_fext, drives, work, tmp, tau):
    """Inverse dynamics of one state: tau (n,) from q, qd, qdd (SI units).

    work is (n, RNEA_WORK) and tmp (6, 3) scratch; fext (n, 6) is read when
    use_fext is true: [force, moment about the body origin] on each link, body axes.
    """
    n = table.shape[0]
    t0 = tmp[0]
    t1 = tmp[1]
    t2 = tmp[2]
    t3 = tmp[3]
    for i in range(n):
        w = work[i]
        R = w[W_R:W_R + 9]
        p = w[W_P:W_P + 3]
        om = w[W_W:W_W + 3]
        omd = w[W_WD:W_WD + 3]
        acc = w[W_A:W_A + 3]
        joint_transform(table, i, q[i], R, p)
        par = parent_of(table, i)
        if par < 0:
            # the base is at rest and accelerates by -g (gravity as an inertial force)
            om[0] = 0.0
            om[1] = 0.0
            om[2] = 0.0
            omd[0] = 0.0
            omd[1] = 0.0
            omd[2] = 0.0
            t0[0] = -g[0]
            t0[1] = -g[1]
            t0[2] = -g[2]
            rot_t(R, t0, acc)
        else:
            wp = work[par]
            omp = wp[W_W:W_W + 3]
            omdp = wp[W_WD:W_WD + 3]
            rot_t(R, omp, om)
            rot_t(R, omdp, omd)
            # a_p + ω̇_p × p + ω_p × (ω_p × p), then into body axes
            cross(omdp, p, t0)
            cross(omp, p, t1)
            cross(omp, t1, t2)
            ap = wp[W_A:W_A + 3]
            t3[0] = ap[0] + t0[0] + t2[0]
            t3[1] = ap[1] + t0[1] + t2[1]
            t3[2] = ap[2] + t0[2] + t2[2]
            rot_t(R, t3, acc)
        if table[i, COL_TYPE] == 0.0:
            # (A ω_p) × l q̇ + l q̈, with l = z
            omd[0] = omd[0] + om[1] * qd[i]
            omd[1] = omd[1] - om[0] * qd[i]
            omd[2] = omd[2] + qdd[i]
            om[2] = om[2] + qd[i]
        else:
            # 2 q̇ ω × l + l q̈
            acc[0] = acc[0] + 2.0 * om[1] * qd[i]
            acc[1] = acc[1] - 2.0 * om[0] * qd[i]
            acc[2] = acc[2] + qdd[i]
        # acceleration of the centre of mass r̈ = a + ω̇ × r* + ω × (ω × r*)
        c = table[i, COL_COM:COL_COM + 3]
        m = table[i, COL_MASS]
        cross(omd, c, t0)
        cross(om, c, t1)
        cross(om, t1, t2)
        f = w[W_F:W_F + 3]
        nn = w[W_N:W_N + 3]
        for k in range(3):
            f[k] = m * (acc[k] + t0[k] + t2[k])
        # τ ω̇ + ω × τ ω + r* × m r̈
        Ic = table[i, COL_IC:COL_IC + 9]
        rot(Ic, om, t1)
        cross(om, t1, t2)
        rot(Ic, omd, t1)
        cross(c, f, t0)
        for k in range(3):
            nn[k] = t1[k] + t2[k] + t0[k]
        if use_fext:
            for k in range(3):
                f[k] = f[k] - fext[i, k]
                nn[k] = nn[k] - fext[i, 3 + k]
    for i in range(n - 1, -1, -1):
        w = work[i]
        f = w[W_F:W_F + 3]
        nn = w[W_N:W_N + 3]
        if table[i, COL_TYPE] == 0.0:
            tau[i] = nn[2]
        else:
            tau[i] = f[2]
        if drives:
            tau[i] = tau[i] + table[i, COL_JR] * qdd[i] + drive_friction(table, i, qd[i])
        par = parent_of(table, i)
        if par >= 0:
            wp = work[par]
            R = w[W_R:W_R + 9]
            p = w[W_P:W_P + 3]
            rot(R, f, t0)
            rot(R, nn, t1)
            cross(p, t0, t2)
            for k in range(3):
                wp[W_F + k] = wp[W_F + k] + t0[k]
                wp[W_N + k] = wp[W_N + k] + t1[k] + t2[k]


@nb.njit(cache=True, nogil=True)
def rnea_batch(table, g, Q, QD, QDD, FEXT, use_fext, drives, TAU):
    """Inverse dynamics of N states: rows of Q, QD, QDD (N, n) -> TAU (N, n)."""
    n = table.shape[0]
    work = np.empty((n, RNEA_WORK))
    tmp = np.empty((6, 3))
    for k in range(Q.shape[0]):
        rnea_one(table, g, Q[k], QD[k], QDD[k], FEXT[k if use_fext else 0],
                 use_fext, drives, work, tmp, TAU[k])
