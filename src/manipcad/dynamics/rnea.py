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
    add3,
    batch_twins,
    cross,
    drive_friction,
    get3,
    jit,
    joint_pose,
    parent_of,
    put3,
    rot,
    rot_t,
)
from manipcad.model.robot import COL_COM, COL_IC, COL_JR, COL_MASS, COL_TYPE

# per-body work row: R(9) p(3) w(3) wd(3) a(3) f(3) n(3)
W_R, W_P, W_W, W_WD, W_A, W_F, W_N = 0, 9, 12, 15, 18, 21, 24
RNEA_WORK = 27


@jit
def rnea_one(table, g, q, qd, qdd, fext, use_fext, drives, work, tau):
    """Inverse dynamics of one state: tau (n,) from q, qd, qdd (SI units).

    work is (n, RNEA_WORK) scratch; fext (n, 6) is read when use_fext is true:
    [force, moment about the body origin] on each link, body axes.
    """
    n = table.shape[0]
    for i in range(n):
        joint_pose(table, i, q[i], work, W_R, W_P)
        par = parent_of(table, i)
        if par < 0:
            # the base is at rest and accelerates by -g (gravity as an inertial force)
            wx, wy, wz = 0.0, 0.0, 0.0
            dx, dy, dz = 0.0, 0.0, 0.0
            ax, ay, az = rot_t(work, i, W_R, -g[0], -g[1], -g[2])
        else:
            opx, opy, opz = get3(work, par, W_W)
            dpx, dpy, dpz = get3(work, par, W_WD)
            px, py, pz = get3(work, i, W_P)
            wx, wy, wz = rot_t(work, i, W_R, opx, opy, opz)
            dx, dy, dz = rot_t(work, i, W_R, dpx, dpy, dpz)
            # the classical acceleration of the origin a_p + ω̇_p × p + ω_p × (ω_p × p),
            # in body axes (the articulated-body method carries spatial ones instead)
            bx, by, bz = cross(dpx, dpy, dpz, px, py, pz)
            cx, cy, cz = cross(opx, opy, opz, px, py, pz)
            ex, ey, ez = cross(opx, opy, opz, cx, cy, cz)
            ax, ay, az = rot_t(work, i, W_R, work[par, W_A] + bx + ex,
                               work[par, W_A + 1] + by + ey, work[par, W_A + 2] + bz + ez)
        qdi = qd[i]
        qddi = qdd[i]
        if table[i, COL_TYPE] == 0.0:
            # (A ω_p) × l q̇ + l q̈, with l = z
            dx = dx + wy * qdi
            dy = dy - wx * qdi
            dz = dz + qddi
            wz = wz + qdi
        else:
            # 2 q̇ ω × l + l q̈
            ax = ax + 2.0 * wy * qdi
            ay = ay - 2.0 * wx * qdi
            az = az + qddi
        put3(work, i, W_W, wx, wy, wz)
        put3(work, i, W_WD, dx, dy, dz)
        put3(work, i, W_A, ax, ay, az)
        # acceleration of the centre of mass r̈ = a + ω̇ × r* + ω × (ω × r*)
        m = table[i, COL_MASS]
        c0, c1, c2 = get3(table, i, COL_COM)
        t0x, t0y, t0z = cross(dx, dy, dz, c0, c1, c2)
        t1x, t1y, t1z = cross(wx, wy, wz, c0, c1, c2)
        t2x, t2y, t2z = cross(wx, wy, wz, t1x, t1y, t1z)
        fx = m * (ax + t0x + t2x)
        fy = m * (ay + t0y + t2y)
        fz = m * (az + t0z + t2z)
        # τ ω̇ + ω × τ ω + r* × m r̈
        ix, iy, iz = rot(table, i, COL_IC, wx, wy, wz)
        t2x, t2y, t2z = cross(wx, wy, wz, ix, iy, iz)
        t1x, t1y, t1z = rot(table, i, COL_IC, dx, dy, dz)
        t0x, t0y, t0z = cross(c0, c1, c2, fx, fy, fz)
        put3(work, i, W_F, fx, fy, fz)
        put3(work, i, W_N, t1x + t2x + t0x, t1y + t2y + t0y, t1z + t2z + t0z)
        if use_fext:
            add3(work, i, W_F, -fext[i, 0], -fext[i, 1], -fext[i, 2])
            add3(work, i, W_N, -fext[i, 3], -fext[i, 4], -fext[i, 5])
    for i in range(n - 1, -1, -1):
        fx, fy, fz = get3(work, i, W_F)
        nx, ny, nz = get3(work, i, W_N)
        t = nz if table[i, COL_TYPE] == 0.0 else fz
        if drives:
            t = t + table[i, COL_JR] * qdd[i] + drive_friction(table, i, qd[i])
        tau[i] = t
        par = parent_of(table, i)
        if par >= 0:
            # f_p += R f, n_p += R n + p × R f
            rfx, rfy, rfz = rot(work, i, W_R, fx, fy, fz)
            rnx, rny, rnz = rot(work, i, W_R, nx, ny, nz)
            px, py, pz = get3(work, i, W_P)
            cx, cy, cz = cross(px, py, pz, rfx, rfy, rfz)
            add3(work, par, W_F, rfx, rfy, rfz)
            add3(work, par, W_N, rnx, rny, rnz)
            add3(work, par, W_N, cx, cy, cz)


#: the same source inlined into the loop over states (saves a call and the
#: reference counting of its nine array arguments per state)
rnea_state = nb.njit(nogil=True, inline="always")(rnea_one.py_func)


@jit
def rnea_batch(table, g, Q, QD, QDD, FEXT, use_fext, drives, TAU):
    """Inverse dynamics of N states: rows of Q, QD, QDD (N, n) -> TAU (N, n); returns -1
    (every state has torques: the return of a batch kernel, see
    :func:`manipcad.dynamics._kernels_common.batch_twins`).

    The one loop over states: the parallel batch runs it on chunks of rows and
    the one-state fast path on a batch of one, so all share one compiled kernel.
    """
    n = table.shape[0]
    work = np.empty((n, RNEA_WORK))
    for k in range(Q.shape[0]):
        rnea_state(table, g, Q[k], QD[k], QDD[k], FEXT[k if use_fext else 0],
                   use_fext, drives, work, TAU[k])
    return -1


#: :func:`rnea_batch` on chunks of rows on numba's threads, and on one state
rnea_batch_parallel, rnea_vector = batch_twins(rnea_batch, "rnea")
