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
    rot_t,
)
from manipcad.model.robot import COL_COM, COL_IC, COL_JR, COL_MASS, COL_TYPE

# per-body work row: R(9) p(3) v(6) c(4: the bias acceleration's nonzero components 0, 1,
# 3, 4) IA(21: the symmetric articulated inertia [[A, B], [Bᵀ, C]] as A's upper triangle
# a00 a01 a02 a11 a12 a22, B row-major, C's upper triangle) pA(6) U(6) D u a(6)
A_R, A_P, A_V, A_C, A_IA, A_PA, A_U, A_D, A_UU, A_A = 0, 9, 12, 18, 22, 43, 49, 55, 56, 57
ABA_WORK = 63
# offsets of the blocks inside IA
I_A, I_B, I_C = 0, 6, 15


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
            work[i, A_C + 2] = vy * qdi
            work[i, A_C + 3] = -vx * qdi
        else:
            vz = vz + qdi
            work[i, A_C] = 0.0
            work[i, A_C + 1] = 0.0
            work[i, A_C + 2] = oy * qdi
            work[i, A_C + 3] = -ox * qdi
        work[i, A_V] = ox
        work[i, A_V + 1] = oy
        work[i, A_V + 2] = oz
        work[i, A_V + 3] = vx
        work[i, A_V + 4] = vy
        work[i, A_V + 5] = vz
        # rigid spatial inertia at the body origin: [[I_O, m[c]×], [-m[c]×, m E]]
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
        i00 = table[i, COL_IC] + hc1 + hc2
        i11 = table[i, COL_IC + 4] + hc0 + hc2
        i22 = table[i, COL_IC + 8] + hc0 + hc1
        i01 = table[i, COL_IC + 1] - h0 * c1
        i02 = table[i, COL_IC + 2] - h0 * c2
        i12 = table[i, COL_IC + 5] - h1 * c2
        o = A_IA
        work[i, o] = i00
        work[i, o + 1] = i01
        work[i, o + 2] = i02
        work[i, o + 3] = i11
        work[i, o + 4] = i12
        work[i, o + 5] = i22
        o = A_IA + I_B
        work[i, o] = 0.0
        work[i, o + 1] = -h2
        work[i, o + 2] = h1
        work[i, o + 3] = h2
        work[i, o + 4] = 0.0
        work[i, o + 5] = -h0
        work[i, o + 6] = -h1
        work[i, o + 7] = h0
        work[i, o + 8] = 0.0
        o = A_IA + I_C
        work[i, o] = m
        work[i, o + 1] = 0.0
        work[i, o + 2] = 0.0
        work[i, o + 3] = m
        work[i, o + 4] = 0.0
        work[i, o + 5] = m
        # bias force v ×* (I v) - f_ext, with I v = (I_O ω + m c × v, m (v + ω × c))
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
        o = A_IA
        a00 = work[i, o]
        a01 = work[i, o + 1]
        a02 = work[i, o + 2]
        a11 = work[i, o + 3]
        a12 = work[i, o + 4]
        a22 = work[i, o + 5]
        o = A_IA + I_B
        b00 = work[i, o]
        b01 = work[i, o + 1]
        b02 = work[i, o + 2]
        b10 = work[i, o + 3]
        b11 = work[i, o + 4]
        b12 = work[i, o + 5]
        b20 = work[i, o + 6]
        b21 = work[i, o + 7]
        b22 = work[i, o + 8]
        o = A_IA + I_C
        c00 = work[i, o]
        c01 = work[i, o + 1]
        c02 = work[i, o + 2]
        c11 = work[i, o + 3]
        c12 = work[i, o + 4]
        c22 = work[i, o + 5]
        # U = IA S: the column of the joint axis (z of rotation, or of translation)
        if table[i, COL_TYPE] == 0.0:
            u0 = a02
            u1 = a12
            u2 = a22
            u3 = b20
            u4 = b21
            u5 = b22
            D = a22
            u = tau[i] - work[i, A_PA + 2]
        else:
            u0 = b02
            u1 = b12
            u2 = b22
            u3 = c02
            u4 = c12
            u5 = c22
            D = c22
            u = tau[i] - work[i, A_PA + 5]
        if drives:
            D = D + table[i, COL_JR]
            u = u - drive_friction(table, i, qd[i])
        work[i, A_U] = u0
        work[i, A_U + 1] = u1
        work[i, A_U + 2] = u2
        work[i, A_U + 3] = u3
        work[i, A_U + 4] = u4
        work[i, A_U + 5] = u5
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
        # Ia = IA - U Uᵀ / D
        w0 = u0 * Dinv
        w1 = u1 * Dinv
        w2 = u2 * Dinv
        w3 = u3 * Dinv
        w4 = u4 * Dinv
        w5 = u5 * Dinv
        a00 = a00 - w0 * u0
        a01 = a01 - w0 * u1
        a02 = a02 - w0 * u2
        a11 = a11 - w1 * u1
        a12 = a12 - w1 * u2
        a22 = a22 - w2 * u2
        b00 = b00 - w0 * u3
        b01 = b01 - w0 * u4
        b02 = b02 - w0 * u5
        b10 = b10 - w1 * u3
        b11 = b11 - w1 * u4
        b12 = b12 - w1 * u5
        b20 = b20 - w2 * u3
        b21 = b21 - w2 * u4
        b22 = b22 - w2 * u5
        c00 = c00 - w3 * u3
        c01 = c01 - w3 * u4
        c02 = c02 - w3 * u5
        c11 = c11 - w4 * u4
        c12 = c12 - w4 * u5
        c22 = c22 - w5 * u5
        # pa = pA + U u / D + Ia c (c has no components 2 and 5)
        uD = u * Dinv
        e0 = work[i, A_C]
        e1 = work[i, A_C + 1]
        e3 = work[i, A_C + 2]
        e4 = work[i, A_C + 3]
        pa0 = work[i, A_PA] + u0 * uD + a00 * e0 + a01 * e1 + b00 * e3 + b01 * e4
        pa1 = work[i, A_PA + 1] + u1 * uD + a01 * e0 + a11 * e1 + b10 * e3 + b11 * e4
        pa2 = work[i, A_PA + 2] + u2 * uD + a02 * e0 + a12 * e1 + b20 * e3 + b21 * e4
        pa3 = work[i, A_PA + 3] + u3 * uD + b00 * e0 + b10 * e1 + c00 * e3 + c01 * e4
        pa4 = work[i, A_PA + 4] + u4 * uD + b01 * e0 + b11 * e1 + c01 * e3 + c11 * e4
        pa5 = work[i, A_PA + 5] + u5 * uD + b02 * e0 + b12 * e1 + c02 * e3 + c12 * e4
        # into the parent's axes: A' = R A Rᵀ, B' = R B Rᵀ, C' = R C Rᵀ
        o = A_R
        r00 = work[i, o]
        r01 = work[i, o + 1]
        r02 = work[i, o + 2]
        r10 = work[i, o + 3]
        r11 = work[i, o + 4]
        r12 = work[i, o + 5]
        r20 = work[i, o + 6]
        r21 = work[i, o + 7]
        r22 = work[i, o + 8]
        a00, a01, a02, a11, a12, a22 = _rot_sym(r00, r01, r02, r10, r11, r12, r20, r21, r22,
                                                a00, a01, a02, a11, a12, a22)
        c00, c01, c02, c11, c12, c22 = _rot_sym(r00, r01, r02, r10, r11, r12, r20, r21, r22,
                                                c00, c01, c02, c11, c12, c22)
        b00, b01, b02, b10, b11, b12, b20, b21, b22 = _rot_gen(
            r00, r01, r02, r10, r11, r12, r20, r21, r22,
            b00, b01, b02, b10, b11, b12, b20, b21, b22)
        # the shift by p (P = [p]×): A'' = A' - B'P - (B'P)ᵀ - P C' P, B'' = B' + P C'
        p0 = work[i, A_P]
        p1 = work[i, A_P + 1]
        p2 = work[i, A_P + 2]
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
        o = A_IA
        work[par, o] = work[par, o] + (a00 - m00 - m00 - (k01 * p2 - k02 * p1))
        work[par, o + 1] = work[par, o + 1] + (a01 - m01 - m10 - (k02 * p0 - k00 * p2))
        work[par, o + 2] = work[par, o + 2] + (a02 - m02 - m20 - (k00 * p1 - k01 * p0))
        work[par, o + 3] = work[par, o + 3] + (a11 - m11 - m11 - (k12 * p0 - k10 * p2))
        work[par, o + 4] = work[par, o + 4] + (a12 - m12 - m21 - (k10 * p1 - k11 * p0))
        work[par, o + 5] = work[par, o + 5] + (a22 - m22 - m22 - (k20 * p1 - k21 * p0))
        o = A_IA + I_B
        work[par, o] = work[par, o] + (b00 + k00)
        work[par, o + 1] = work[par, o + 1] + (b01 + k01)
        work[par, o + 2] = work[par, o + 2] + (b02 + k02)
        work[par, o + 3] = work[par, o + 3] + (b10 + k10)
        work[par, o + 4] = work[par, o + 4] + (b11 + k11)
        work[par, o + 5] = work[par, o + 5] + (b12 + k12)
        work[par, o + 6] = work[par, o + 6] + (b20 + k20)
        work[par, o + 7] = work[par, o + 7] + (b21 + k21)
        work[par, o + 8] = work[par, o + 8] + (b22 + k22)
        o = A_IA + I_C
        work[par, o] = work[par, o] + c00
        work[par, o + 1] = work[par, o + 1] + c01
        work[par, o + 2] = work[par, o + 2] + c02
        work[par, o + 3] = work[par, o + 3] + c11
        work[par, o + 4] = work[par, o + 4] + c12
        work[par, o + 5] = work[par, o + 5] + c22
        # force to parent: n_p = R n + p × R f, f_p = R f
        nx = r00 * pa0 + r01 * pa1 + r02 * pa2
        ny = r10 * pa0 + r11 * pa1 + r12 * pa2
        nz = r20 * pa0 + r21 * pa1 + r22 * pa2
        fx = r00 * pa3 + r01 * pa4 + r02 * pa5
        fy = r10 * pa3 + r11 * pa4 + r12 * pa5
        fz = r20 * pa3 + r21 * pa4 + r22 * pa5
        cx, cy, cz = cross(p0, p1, p2, fx, fy, fz)
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
            a2 = 0.0
            a3 = lx + work[i, A_C + 2]
            a4 = ly + work[i, A_C + 3]
            a5 = lz
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
            a2 = oz
            a3 = lx + work[i, A_C + 2]
            a4 = ly + work[i, A_C + 3]
            a5 = lz
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
    return True


@jit
def _rot_sym(r00, r01, r02, r10, r11, r12, r20, r21, r22, x00, x01, x02, x11, x12, x22):
    """R X Rᵀ of a symmetric 3x3 X given by its upper triangle; returns the upper triangle."""
    # M = X Rᵀ
    m00 = x00 * r00 + x01 * r01 + x02 * r02
    m01 = x00 * r10 + x01 * r11 + x02 * r12
    m02 = x00 * r20 + x01 * r21 + x02 * r22
    m10 = x01 * r00 + x11 * r01 + x12 * r02
    m11 = x01 * r10 + x11 * r11 + x12 * r12
    m12 = x01 * r20 + x11 * r21 + x12 * r22
    m20 = x02 * r00 + x12 * r01 + x22 * r02
    m21 = x02 * r10 + x12 * r11 + x22 * r12
    m22 = x02 * r20 + x12 * r21 + x22 * r22
    return (r00 * m00 + r01 * m10 + r02 * m20,
            r00 * m01 + r01 * m11 + r02 * m21,
            r00 * m02 + r01 * m12 + r02 * m22,
            r10 * m01 + r11 * m11 + r12 * m21,
            r10 * m02 + r11 * m12 + r12 * m22,
            r20 * m02 + r21 * m12 + r22 * m22)


@jit
def _rot_gen(r00, r01, r02, r10, r11, r12, r20, r21, r22,
             x00, x01, x02, x10, x11, x12, x20, x21, x22):
    """R X Rᵀ of a general 3x3 X (row-major); returns it row-major."""
    m00 = x00 * r00 + x01 * r01 + x02 * r02
    m01 = x00 * r10 + x01 * r11 + x02 * r12
    m02 = x00 * r20 + x01 * r21 + x02 * r22
    m10 = x10 * r00 + x11 * r01 + x12 * r02
    m11 = x10 * r10 + x11 * r11 + x12 * r12
    m12 = x10 * r20 + x11 * r21 + x12 * r22
    m20 = x20 * r00 + x21 * r01 + x22 * r02
    m21 = x20 * r10 + x21 * r11 + x22 * r12
    m22 = x20 * r20 + x21 * r21 + x22 * r22
    return (r00 * m00 + r01 * m10 + r02 * m20,
            r00 * m01 + r01 * m11 + r02 * m21,
            r00 * m02 + r01 * m12 + r02 * m22,
            r10 * m00 + r11 * m10 + r12 * m20,
            r10 * m01 + r11 * m11 + r12 * m21,
            r10 * m02 + r11 * m12 + r12 * m22,
            r20 * m00 + r21 * m10 + r22 * m20,
            r20 * m01 + r21 * m11 + r22 * m21,
            r20 * m02 + r21 * m12 + r22 * m22)


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


@nb.njit(cache=True, nogil=True, parallel=True)
def aba_batch_parallel(table, g, Q, QD, TAU, FEXT, use_fext, drives, QDD, chunks):
    """:func:`aba_batch` on ``chunks`` chunks of rows, run on numba's threads."""
    N = Q.shape[0]
    bad = np.empty(chunks, dtype=np.int64)
    for c in nb.prange(chunks):
        a = c * N // chunks
        b = (c + 1) * N // chunks
        k = aba_batch(table, g, Q[a:b], QD[a:b], TAU[a:b], FEXT[a:b] if use_fext else FEXT,
                      use_fext, drives, QDD[a:b])
        bad[c] = k + a if k >= 0 else -1
    for c in range(chunks):
        if bad[c] >= 0:
            return bad[c]
    return -1


def aba_vector(table, g, q, qd, tau, drives, qdd, fext, use_fext):
    """One state: the fast path of the public function (see ``rnea_vector``)."""
    n = table.shape[0]
    if q.shape[0] != n or qd.shape[0] != n or tau.shape[0] != n or qdd.shape[0] != n:
        raise ValueError("a vector's length is not the number of joints")
    return aba_batch(table, g, q.reshape((1, n)), qd.reshape((1, n)), tau.reshape((1, n)),
                     fext, use_fext, drives, qdd.reshape((1, n)))
