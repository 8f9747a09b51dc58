"""The compiled closed-loop integration: multibody + drives + sampled regulators.

State x = [q (n), q̇ (n), drive states (see :mod:`manipcad.drives.coupling`)].
Each fixed step of RK4 holds the regulators' outputs U (zero-order hold);
a regulator is updated when the step index is a multiple of its period in
steps. Joint torques: from the drives (``drive_rates``) where a joint has a
drive model, otherwise the regulator output itself; plus the disturbance. The
multibody part is the articulated-body algorithm with the joint-referred
rotor inertia and friction of rigid gears in its table.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from manipcad.drives.coupling import drive_rates
from manipcad.drives.dc import static_current
from manipcad.drives.params import (
    KIND_ELASTIC,
    KIND_ELASTIC_STATIC,
    KIND_RIGID,
    KIND_RIGID_STATIC,
    P_KIND,
    P_KM,
    P_KU,
    P_KW,
    P_L,
    P_R,
    P_RATIO,
    P_UMAX,
)
from manipcad.dynamics.aba import ABA_WORK, aba_state
from manipcad.dynamics.crba import CRBA_WORK, crba_one
from manipcad.dynamics.rnea import RNEA_WORK, rnea_one
from manipcad.sim.regulators import (
    NSIG,
    S_HI,
    S_HII,
    S_I,
    S_Q,
    S_QD,
    S_QDDREF,
    S_QDREF,
    S_QI,
    S_QREF,
    S_T,
    S_THM,
    S_WM,
    regulator_update,
)

#: divergence: joint speeds beyond this (rad/s or m/s) count as a runaway
MAX_SPEED = 1.0e4


@nb.njit(cache=True, inline="always")
def _amplifier(dtable, j, U):
    """Amplifier output clip(k_u·U, -u_max, u_max), V (as ``drives.dc.amplifier_voltage``)."""
    u = dtable[j, P_KU] * U
    u_max = dtable[j, P_UMAX]
    if u > u_max:
        return u_max
    if u < -u_max:
        return -u_max
    return u


@nb.njit(cache=True, inline="always")
def _rates(xs, U, DIST, k, n, rtable, g, dtable, off, use_drives, generic_drives,
           q, qd, xd, dxd, tau, qdd, K4, st, fext, work, tmp):
    """Right-hand side at state xs into row ``st`` of K4; joint torques into tau.

    Inlined into :func:`run` and free of array views (numba counts references
    to every view and every array argument of a compiled call with atomics).
    Rigid drives (the common case) are written out; elastic ones go through
    :func:`manipcad.drives.coupling.drive_rates` on copies of their states.
    """
    m = 2 * n
    for j in range(n):
        q[j] = xs[j]
        qd[j] = xs[n + j]
        tau[j] = U[j]
    if use_drives:
        if generic_drives:
            for j in range(xd.shape[0]):
                xd[j] = xs[m + j]
            drive_rates(dtable, off, xd, U, q, qd, tau, dxd)
            for j in range(xd.shape[0]):
                K4[st, m + j] = dxd[j]
        else:
            # rigid gears only: drives.dc.rigid_drive_rate written out
            for j in range(n):
                kind = int(dtable[j, P_KIND])
                if kind == KIND_RIGID:
                    o = m + off[j]
                    i = xs[o]
                    omega = dtable[j, P_RATIO] * qd[j]
                    u_a = _amplifier(dtable, j, U[j])
                    K4[st, o] = ((u_a - dtable[j, P_R] * i - dtable[j, P_KW] * omega)
                                 / dtable[j, P_L])
                    tau[j] = dtable[j, P_RATIO] * dtable[j, P_KM] * i
                elif kind == KIND_RIGID_STATIC:
                    omega = dtable[j, P_RATIO] * qd[j]
                    u_a = _amplifier(dtable, j, U[j])
                    i = (u_a - dtable[j, P_KW] * omega) / dtable[j, P_R]
                    tau[j] = dtable[j, P_RATIO] * dtable[j, P_KM] * i
    for j in range(n):
        tau[j] = tau[j] + DIST[k, j]
        K4[st, j] = qd[j]
    aba_state(rtable, g, q, qd, tau, fext, False, True, work, tmp, qdd)
    for j in range(n):
        K4[st, n + j] = qdd[j]


@nb.njit(cache=True, inline="always")
def _current(dtable, off, x, m, U, qd, j):
    """Armature current of joint j's drive from the state x (drive states from index m)."""
    kind = int(dtable[j, P_KIND])
    if kind == KIND_RIGID:
        return x[m + off[j]]
    if kind == KIND_ELASTIC:
        return x[m + off[j] + 2]
    if kind == KIND_RIGID_STATIC:
        return static_current(U, dtable[j, P_RATIO] * qd, dtable[j])
    if kind != 0:  # elastic, L neglected: the current follows the motor speed
        return static_current(U, x[m + off[j] + 1], dtable[j])
    return math.nan


@nb.njit(cache=True)
def run(rtable, ctable, g, dtable, off, use_drives, rkind, rparam, rstate, rsteps, need_comp,
        QR, QDR, QDDR, DIST, x0, dt, K, every, T, Q, QD, U_out, I_out, TAU_out):
    """Integrate K RK4 steps of dt seconds from x0; record every ``every`` steps.

    Returns (status, step, joint): status 0 done, 1 NaN, 2 runaway speed.
    ``ctable`` is the rigid-body table used for the regulators' constituents.
    """
    n = rtable.shape[0]
    nx = x0.shape[0]
    m = 2 * n
    x = x0.copy()
    xs = np.empty(nx)
    K4 = np.empty((4, nx))
    q = np.empty(n)
    qd = np.empty(n)
    qdd = np.empty(n)
    xd = np.empty(nx - m)
    dxd = np.empty(nx - m)
    tau = np.empty(n)
    U = np.zeros(n)
    sig = np.zeros(NSIG)
    fext = np.zeros((n, 6))
    work = np.empty((n, ABA_WORK))
    tmp = np.empty((23, 6))
    rwork = np.empty((n, RNEA_WORK))
    cwork = np.empty((n, CRBA_WORK))
    H = np.empty((n, n))
    zero = np.zeros(n)
    nog = np.zeros(3)
    hv = np.empty(n)
    qg = np.empty(n)
    generic_drives = False
    for j in range(n):
        kind = int(dtable[j, P_KIND])
        if kind != 0 and kind != KIND_RIGID and kind != KIND_RIGID_STATIC:
            generic_drives = True
    h2 = 0.5 * dt
    h6 = dt / 6.0
    rec = 0
    # steps until each regulator's next sample, and until the next recorded step
    # (counters instead of k % period: an integer division each is slow)
    wait = np.zeros(n, dtype=np.int64)
    wait_rec = 0
    for k in range(K + 1):
        # sample the regulators due at this step
        due = False
        for j in range(n):
            if wait[j] == 0:
                due = True
        if due and need_comp:
            for j in range(n):
                q[j] = x[j]
                qd[j] = x[n + j]
            crba_one(ctable, q, False, cwork, tmp, H)
            rnea_one(ctable, nog, q, qd, zero, fext, False, False, rwork, tmp, hv)
            rnea_one(ctable, g, q, zero, zero, fext, False, False, rwork, tmp, qg)
        for j in range(n):
            if wait[j] != 0:
                wait[j] -= 1
                continue
            wait[j] = rsteps[j] - 1
            sig[S_T] = k * dt
            sig[S_QREF] = QR[k, j]
            sig[S_QDREF] = QDR[k, j]
            sig[S_QDDREF] = QDDR[k, j]
            sig[S_Q] = x[j]
            sig[S_QD] = x[n + j]
            sig[S_I] = _current(dtable, off, x, m, U[j], x[n + j], j) if use_drives else 0.0
            kind = int(dtable[j, P_KIND]) if use_drives else 0
            if kind == KIND_ELASTIC or kind == KIND_ELASTIC_STATIC:
                sig[S_THM] = x[m + off[j]]
                sig[S_WM] = x[m + off[j] + 1]
            else:
                sig[S_THM] = dtable[j, P_RATIO] * x[j]
                sig[S_WM] = dtable[j, P_RATIO] * x[n + j]
            if need_comp:
                sig[S_HII] = H[j, j]
                sig[S_HI] = hv[j]
                sig[S_QI] = qg[j]
            U[j] = regulator_update(rkind[j], rparam[j], rstate[j], sig, rsteps[j] * dt)
        # the four RK4 stages with U held and the disturbance at the step's start;
        # one call site of the inlined right-hand side
        for st in range(4):
            if st == 0:
                for j in range(nx):
                    xs[j] = x[j]
            elif st == 3:
                for j in range(nx):
                    xs[j] = x[j] + dt * K4[2, j]
            else:
                for j in range(nx):
                    xs[j] = x[j] + h2 * K4[st - 1, j]
            _rates(xs, U, DIST, k, n, rtable, g, dtable, off, use_drives, generic_drives,
                   q, qd, xd, dxd, tau, qdd, K4, st, fext, work, tmp)
            if st != 0:
                continue
            if wait_rec == 0:
                wait_rec = every
                T[rec] = k * dt
                for j in range(n):
                    Q[rec, j] = x[j]
                    QD[rec, j] = x[n + j]
                    U_out[rec, j] = U[j]
                    I_out[rec, j] = (_current(dtable, off, x, m, U[j], x[n + j], j)
                                     if use_drives else math.nan)
                    TAU_out[rec, j] = tau[j]
                rec += 1
            wait_rec -= 1
            if k == K:
                return 0, K, -1
            for j in range(nx):
                if not math.isfinite(x[j]) or not math.isfinite(K4[0, j]):
                    return 1, k, j % n if j < m else -1
            for j in range(n):
                if abs(x[n + j]) > MAX_SPEED:
                    return 2, k, j
        for j in range(nx):
            x[j] = x[j] + h6 * (K4[0, j] + 2.0 * K4[1, j] + 2.0 * K4[2, j] + K4[3, j])
    return 0, K, -1
