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
    add3,
    batch_twins,
    cross,
    drive_friction,
    get3,
    inline,
    jit,
    joint_pose,
    origin_inertia,
    parent_of,
    put3,
    rot_t,
)
from manipcad.model.robot import COL_COM, COL_JR, COL_TYPE

# per-body work row: R(9) p(3) v(6) c(4: the bias acceleration's nonzero components 0, 1,
# 3, 4) IA(21: the symmetric articulated inertia [[A, B], [Bᵀ, C]] as A's upper triangle
# a00 a01 a02 a11 a12 a22, B row-major, C's upper triangle) pA(6) U(6) D u a(6)
A_R, A_P, A_V, A_C, A_IA, A_PA, A_U, A_D, A_UU, A_A = 0, 9, 12, 18, 22, 43, 49, 55, 56, 57
ABA_WORK = 63
# offsets of the blocks inside IA
I_A, I_B, I_C = 0, 6, 15


@inline
def motion_to_child(work, i, par, o):
    """The parent's spatial motion vector [angular; linear] at ``work[par, o:o + 6]``
    (about the parent's origin, in its axes) seen at body i's origin in body i's
    axes: (Rᵀ ω, Rᵀ (ω × p + v)) with body i's placement (R, p) at ``A_R``, ``A_P``."""
    wx, wy, wz = get3(work, par, o)
    ox, oy, oz = rot_t(work, i, A_R, wx, wy, wz)
    tx, ty, tz = cross(wx, wy, wz, work[i, A_P], work[i, A_P + 1], work[i, A_P + 2])
    lx, ly, lz = rot_t(work, i, A_R, tx + work[par, o + 3], ty + work[par, o + 4],
                       tz + work[par, o + 5])
    return ox, oy, oz, lx, ly, lz


@jit
def aba_one(table, g, q, qd, tau, fext, use_fext, drives, work, qdd):
    """Joint accelerations qdd (n,) from q, qd and joint torques tau (SI units).

    work is (n, ABA_WORK) scratch; fext (n, 6) as in
    :func:`manipcad.dynamics.rnea.rnea_one`.
    The articulated inertias are kept as their 21 distinct entries and each
    joint's work in pass 2 is done on local scalars.

    Returns True; False, with qdd all nan, when a joint's articulated inertia
    about its axis is not positive (the joint moves no mass and no rotor: H
    is singular, the case the Cholesky of the CRBA method reports too).
    """
    n = table.shape[0]
    # pass 1: velocities, velocity-product accelerations, rigid inertias, bias forces
    for i in range(n):
        joint_pose(table, i, q[i], work, A_R, A_P)
        par = parent_of(table, i)
        if par < 0:
            ox, oy, oz, vx, vy, vz = 0.0, 0.0, 0.0, 0.0, 0.0, 0.0
        else:
            ox, oy, oz, vx, vy, vz = motion_to_child(work, i, par, A_V)
        qdi = qd[i]
        if table[i, COL_TYPE] == 0.0:
            oz = oz + qdi
            e0, e1, e3, e4 = oy * qdi, -ox * qdi, vy * qdi, -vx * qdi
        else:
            vz = vz + qdi
            e0, e1, e3, e4 = 0.0, 0.0, oy * qdi, -ox * qdi
        put3(work, i, A_C, e0, e1, e3)
        work[i, A_C + 3] = e4
        put3(work, i, A_V, ox, oy, oz)
        put3(work, i, A_V + 3, vx, vy, vz)
        # rigid spatial inertia at the body origin: [[I_O, m[c]×], [-m[c]×, m E]]
        m, h0, h1, h2, i00, i01, i02, i11, i12, i22 = origin_inertia(table, i)
        put3(work, i, A_IA, i00, i01, i02)
        put3(work, i, A_IA + 3, i11, i12, i22)
        put3(work, i, A_IA + I_B, 0.0, -h2, h1)
        put3(work, i, A_IA + I_B + 3, h2, 0.0, -h0)
        put3(work, i, A_IA + I_B + 6, -h1, h0, 0.0)
        put3(work, i, A_IA + I_C, m, 0.0, 0.0)
        put3(work, i, A_IA + I_C + 3, m, 0.0, m)
        # bias force v ×* (I v) - f_ext, with I v = (I_O ω + m c × v, m (v + ω × c))
        c0, c1, c2 = get3(table, i, COL_COM)
        lx = i00 * ox + i01 * oy + i02 * oz
        ly = i01 * ox + i11 * oy + i12 * oz
        lz = i02 * ox + i12 * oy + i22 * oz
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
        put3(work, i, A_PA, ax + bx, ay + by, az + bz)
        put3(work, i, A_PA + 3, fx, fy, fz)
        if use_fext:
            add3(work, i, A_PA, -fext[i, 3], -fext[i, 4], -fext[i, 5])
            add3(work, i, A_PA + 3, -fext[i, 0], -fext[i, 1], -fext[i, 2])
    # pass 2: articulated inertias and bias forces, tip to base
    for i in range(n - 1, -1, -1):
        a00, a01, a02 = get3(work, i, A_IA)
        a11, a12, a22 = get3(work, i, A_IA + 3)
        b00, b01, b02 = get3(work, i, A_IA + I_B)
        b10, b11, b12 = get3(work, i, A_IA + I_B + 3)
        b20, b21, b22 = get3(work, i, A_IA + I_B + 6)
        c00, c01, c02 = get3(work, i, A_IA + I_C)
        c11, c12, c22 = get3(work, i, A_IA + I_C + 3)
        # U = IA S: the column of the joint axis (z of rotation, or of translation)
        if table[i, COL_TYPE] == 0.0:
            u0, u1, u2, u3, u4, u5 = a02, a12, a22, b20, b21, b22
            D = a22
            u = tau[i] - work[i, A_PA + 2]
        else:
            u0, u1, u2, u3, u4, u5 = b02, b12, b22, c02, c12, c22
            D = c22
            u = tau[i] - work[i, A_PA + 5]
        if drives:
            D = D + table[i, COL_JR]
            u = u - drive_friction(table, i, qd[i])
        put3(work, i, A_U, u0, u1, u2)
        put3(work, i, A_U + 3, u3, u4, u5)
        work[i, A_D] = D
        work[i, A_UU] = u
        if not D > 0.0:
            # the joint moves no mass (nor rotor): H is singular, as crba's Cholesky finds
            for k in range(n):
                qdd[k] = np.nan
            return False
        par = parent_of(table, i)
        if par < 0:
            continue
        Dinv = 1.0 / D
        # Ia = IA - U Uᵀ / D, by blocks
        w0, w1, w2, w3, w4, w5 = u0 * Dinv, u1 * Dinv, u2 * Dinv, u3 * Dinv, u4 * Dinv, u5 * Dinv
        a00, a01, a02, a11, a12, a22 = _minus_outer_sym(a00, a01, a02, a11, a12, a22,
                                                        w0, w1, w2, u0, u1, u2)
        b00, b01, b02, b10, b11, b12, b20, b21, b22 = _minus_outer(
            b00, b01, b02, b10, b11, b12, b20, b21, b22, w0, w1, w2, u3, u4, u5)
        c00, c01, c02, c11, c12, c22 = _minus_outer_sym(c00, c01, c02, c11, c12, c22,
                                                        w3, w4, w5, u3, u4, u5)
        # pa = pA + U u / D + Ia c (c has no components 2 and 5)
        uD = u * Dinv
        e0, e1, e3 = get3(work, i, A_C)
        e4 = work[i, A_C + 3]
        pa0 = work[i, A_PA] + u0 * uD + a00 * e0 + a01 * e1 + b00 * e3 + b01 * e4
        pa1 = work[i, A_PA + 1] + u1 * uD + a01 * e0 + a11 * e1 + b10 * e3 + b11 * e4
        pa2 = work[i, A_PA + 2] + u2 * uD + a02 * e0 + a12 * e1 + b20 * e3 + b21 * e4
        pa3 = work[i, A_PA + 3] + u3 * uD + b00 * e0 + b10 * e1 + c00 * e3 + c01 * e4
        pa4 = work[i, A_PA + 4] + u4 * uD + b01 * e0 + b11 * e1 + c01 * e3 + c11 * e4
        pa5 = work[i, A_PA + 5] + u5 * uD + b02 * e0 + b12 * e1 + c02 * e3 + c12 * e4
        # into the parent's axes: A' = R A Rᵀ, B' = R B Rᵀ, C' = R C Rᵀ
        r00, r01, r02 = get3(work, i, A_R)
        r10, r11, r12 = get3(work, i, A_R + 3)
        r20, r21, r22 = get3(work, i, A_R + 6)
        a00, a01, a02, a11, a12, a22 = _rot_sym(r00, r01, r02, r10, r11, r12, r20, r21, r22,
                                                a00, a01, a02, a11, a12, a22)
        c00, c01, c02, c11, c12, c22 = _rot_sym(r00, r01, r02, r10, r11, r12, r20, r21, r22,
                                                c00, c01, c02, c11, c12, c22)
        b00, b01, b02, b10, b11, b12, b20, b21, b22 = _rot_gen(
            r00, r01, r02, r10, r11, r12, r20, r21, r22,
            b00, b01, b02, b10, b11, b12, b20, b21, b22)
        # the shift by p (P = [p]×): A'' = A' - B'P - (B'P)ᵀ - P C' P, B'' = B' + P C'
        p0, p1, p2 = get3(work, i, A_P)
        # PC = P C'
        k00 = p1 * c02 - p2 * c01
        k01 = p1 * c12 - p2 * c11
        k02 = p1 * c22 - p2 * c12
        k10 = p2 * c00 - p0 * c02
        k11 = p2 * c01 - p0 * c12
        k12 = p2 * c02 - p0 * c22
        k20 = p0 * c01 - p1 * c00
        k21 = p0 * c11 - p1 * c01
        k22 = p0 * c12 - p1 * c02
        # BP = B' P
        m00 = b01 * p2 - b02 * p1
        m01 = b02 * p0 - b00 * p2
        m02 = b00 * p1 - b01 * p0
        m10 = b11 * p2 - b12 * p1
        m11 = b12 * p0 - b10 * p2
        m12 = b10 * p1 - b11 * p0
        m20 = b21 * p2 - b22 * p1
        m21 = b22 * p0 - b20 * p2
        m22 = b20 * p1 - b21 * p0
        add3(work, par, A_IA, a00 - m00 - m00 - (k01 * p2 - k02 * p1),
             a01 - m01 - m10 - (k02 * p0 - k00 * p2), a02 - m02 - m20 - (k00 * p1 - k01 * p0))
        add3(work, par, A_IA + 3, a11 - m11 - m11 - (k12 * p0 - k10 * p2),
             a12 - m12 - m21 - (k10 * p1 - k11 * p0), a22 - m22 - m22 - (k20 * p1 - k21 * p0))
        add3(work, par, A_IA + I_B, b00 + k00, b01 + k01, b02 + k02)
        add3(work, par, A_IA + I_B + 3, b10 + k10, b11 + k11, b12 + k12)
        add3(work, par, A_IA + I_B + 6, b20 + k20, b21 + k21, b22 + k22)
        add3(work, par, A_IA + I_C, c00, c01, c02)
        add3(work, par, A_IA + I_C + 3, c11, c12, c22)
        # force to parent: n_p = R n + p × R f, f_p = R f
        nx = r00 * pa0 + r01 * pa1 + r02 * pa2
        ny = r10 * pa0 + r11 * pa1 + r12 * pa2
        nz = r20 * pa0 + r21 * pa1 + r22 * pa2
        fx = r00 * pa3 + r01 * pa4 + r02 * pa5
        fy = r10 * pa3 + r11 * pa4 + r12 * pa5
        fz = r20 * pa3 + r21 * pa4 + r22 * pa5
        cx, cy, cz = cross(p0, p1, p2, fx, fy, fz)
        add3(work, par, A_PA, nx, ny, nz)
        add3(work, par, A_PA, cx, cy, cz)
        add3(work, par, A_PA + 3, fx, fy, fz)
    # pass 3: accelerations, base to tip; the base accelerates by -g
    for i in range(n):
        par = parent_of(table, i)
        e0, e1, e3 = get3(work, i, A_C)
        e4 = work[i, A_C + 3]
        if par < 0:
            lx, ly, lz = rot_t(work, i, A_R, -g[0], -g[1], -g[2])
            a0, a1, a2 = e0, e1, 0.0
        else:
            ox, oy, oz, lx, ly, lz = motion_to_child(work, i, par, A_A)
            a0, a1, a2 = ox + e0, oy + e1, oz
        a3, a4, a5 = lx + e3, ly + e4, lz
        u0, u1, u2 = get3(work, i, A_U)
        u3, u4, u5 = get3(work, i, A_U + 3)
        acc = work[i, A_UU] - u0 * a0 - u1 * a1 - u2 * a2 - u3 * a3 - u4 * a4 - u5 * a5
        qddi = acc / work[i, A_D]
        qdd[i] = qddi
        if table[i, COL_TYPE] == 0.0:
            a2 = a2 + qddi
        else:
            a5 = a5 + qddi
        put3(work, i, A_A, a0, a1, a2)
        put3(work, i, A_A + 3, a3, a4, a5)
    return True


@jit
def _minus_outer_sym(x00, x01, x02, x11, x12, x22, w0, w1, w2, u0, u1, u2):
    """X - w uᵀ for a symmetric 3x3 X given by its upper triangle and w parallel to u
    (so the result is symmetric); returns the upper triangle."""
    return (x00 - w0 * u0, x01 - w0 * u1, x02 - w0 * u2,
            x11 - w1 * u1, x12 - w1 * u2, x22 - w2 * u2)


@jit
def _minus_outer(x00, x01, x02, x10, x11, x12, x20, x21, x22, w0, w1, w2, u0, u1, u2):
    """X - w uᵀ of a general 3x3 X (row-major); returns it row-major."""
    return (x00 - w0 * u0, x01 - w0 * u1, x02 - w0 * u2,
            x10 - w1 * u0, x11 - w1 * u1, x12 - w1 * u2,
            x20 - w2 * u0, x21 - w2 * u1, x22 - w2 * u2)


@jit
def _mul_upper(a00, a01, a02, a10, a11, a12, a20, a21, a22,
               b00, b01, b02, b10, b11, b12, b20, b21, b22):
    """The upper triangle of A B for two 3x3 matrices (row-major)."""
    return (a00 * b00 + a01 * b10 + a02 * b20,
            a00 * b01 + a01 * b11 + a02 * b21,
            a00 * b02 + a01 * b12 + a02 * b22,
            a10 * b01 + a11 * b11 + a12 * b21,
            a10 * b02 + a11 * b12 + a12 * b22,
            a20 * b02 + a21 * b12 + a22 * b22)


@jit
def _mul(a00, a01, a02, a10, a11, a12, a20, a21, a22,
         b00, b01, b02, b10, b11, b12, b20, b21, b22):
    """A B for two 3x3 matrices (row-major); returns it row-major."""
    y00, y01, y02, y11, y12, y22 = _mul_upper(a00, a01, a02, a10, a11, a12, a20, a21, a22,
                                              b00, b01, b02, b10, b11, b12, b20, b21, b22)
    return (y00, y01, y02,
            a10 * b00 + a11 * b10 + a12 * b20, y11, y12,
            a20 * b00 + a21 * b10 + a22 * b20, a20 * b01 + a21 * b11 + a22 * b21, y22)


@jit
def _rot_sym(r00, r01, r02, r10, r11, r12, r20, r21, r22, x00, x01, x02, x11, x12, x22):
    """R X Rᵀ of a symmetric 3x3 X given by its upper triangle; returns the upper triangle."""
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = _mul(  # X Rᵀ
        x00, x01, x02, x01, x11, x12, x02, x12, x22,
        r00, r10, r20, r01, r11, r21, r02, r12, r22)
    return _mul_upper(r00, r01, r02, r10, r11, r12, r20, r21, r22,
                      m00, m01, m02, m10, m11, m12, m20, m21, m22)


@jit
def _rot_gen(r00, r01, r02, r10, r11, r12, r20, r21, r22,
             x00, x01, x02, x10, x11, x12, x20, x21, x22):
    """R X Rᵀ of a general 3x3 X (row-major); returns it row-major."""
    m00, m01, m02, m10, m11, m12, m20, m21, m22 = _mul(  # X Rᵀ
        x00, x01, x02, x10, x11, x12, x20, x21, x22,
        r00, r10, r20, r01, r11, r21, r02, r12, r22)
    return _mul(r00, r01, r02, r10, r11, r12, r20, r21, r22,
                m00, m01, m02, m10, m11, m12, m20, m21, m22)


#: the same source inlined into the loop over states (see ``rnea_state``)
aba_state = nb.njit(nogil=True, inline="always")(aba_one.py_func)


@jit
def aba_batch(table, g, Q, QD, TAU, FEXT, use_fext, drives, QDD):
    """Forward dynamics of N states: rows of Q, QD, TAU (N, n) -> QDD (N, n); returns
    the index of the first state where H is singular (see :func:`aba_one`), or -1.

    The one loop over states (see :func:`manipcad.dynamics.rnea.rnea_batch`).
    """
    n = table.shape[0]
    work = np.empty((n, ABA_WORK))
    for k in range(Q.shape[0]):
        if not aba_state(table, g, Q[k], QD[k], TAU[k], FEXT[k if use_fext else 0],
                         use_fext, drives, work, QDD[k]):
            return k
    return -1


#: :func:`aba_batch` on chunks of rows on numba's threads, and on one state
aba_batch_parallel, aba_vector = batch_twins(aba_batch, "aba")
