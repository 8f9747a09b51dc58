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
from manipcad.drives.params import KIND_ELASTIC, KIND_RIGID, KIND_RIGID_STATIC, P_KIND, P_RATIO
from manipcad.dynamics.aba import ABA_WORK, aba_one
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
    regulator_update,
)

#: divergence: joint speeds beyond this (rad/s or m/s) count as a runaway
MAX_SPEED = 1.0e4


@nb.njit(cache=True)
def _rates(x, U, dist, n, rtable, g, dtable, off, use_drives, tau, dx, fext, work, tmp):
    q = x[:n]
    qd = x[n:2 * n]
    for j in range(n):
        tau[j] = U[j]
    if use_drives:
        drive_rates(dtable, off, x[2 * n:], U, q, qd, tau, dx[2 * n:])
    for j in range(n):
        tau[j] = tau[j] + dist[j]
        dx[j] = qd[j]
    aba_one(rtable, g, q, qd, tau, fext, False, True, work, tmp, dx[n:2 * n])


@nb.njit(cache=True)
def _current(dtable, off, xd, U, qd, j):
    kind = int(dtable[j, P_KIND])
    if kind == KIND_RIGID:
        return xd[off[j]]
    if kind == KIND_ELASTIC:
        return xd[off[j] + 2]
    if kind == KIND_RIGID_STATIC:
        return static_current(U, dtable[j, P_RATIO] * qd, dtable[j])
    if kind != 0:  # elastic, L neglected: the current follows the motor speed
        return static_current(U, xd[off[j] + 1], dtable[j])
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
    x = x0.copy()
    xs = np.empty(nx)
    k1 = np.empty(nx)
    k2 = np.empty(nx)
    k3 = np.empty(nx)
    k4 = np.empty(nx)
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
    rec = 0
    for k in range(K + 1):
        q = x[:n]
        qd = x[n:2 * n]
        # sample the regulators due at this step
        due = False
        for j in range(n):
            if k % rsteps[j] == 0:
                due = True
        if due and need_comp:
            crba_one(ctable, q, False, cwork, tmp, H)
            rnea_one(ctable, nog, q, qd, zero, fext, False, False, rwork, tmp, hv)
            rnea_one(ctable, g, q, zero, zero, fext, False, False, rwork, tmp, qg)
        for j in range(n):
            if k % rsteps[j] != 0:
                continue
            sig[S_T] = k * dt
            sig[S_QREF] = QR[k, j]
            sig[S_QDREF] = QDR[k, j]
            sig[S_QDDREF] = QDDR[k, j]
            sig[S_Q] = q[j]
            sig[S_QD] = qd[j]
            sig[S_I] = _current(dtable, off, x[2 * n:], U[j], qd[j], j) if use_drives else 0.0
            if need_comp:
                sig[S_HII] = H[j, j]
                sig[S_HI] = hv[j]
                sig[S_QI] = qg[j]
            U[j] = regulator_update(rkind[j], rparam[j], rstate[j], sig, rsteps[j] * dt)
        d = DIST[k]
        _rates(x, U, d, n, rtable, g, dtable, off, use_drives, tau, k1, fext, work, tmp)
        if k % every == 0:
            T[rec] = k * dt
            for j in range(n):
                Q[rec, j] = q[j]
                QD[rec, j] = qd[j]
                U_out[rec, j] = U[j]
                I_out[rec, j] = (_current(dtable, off, x[2 * n:], U[j], qd[j], j)
                                 if use_drives else math.nan)
                TAU_out[rec, j] = tau[j]
            rec += 1
        if k == K:
            break
        for j in range(nx):
            if not math.isfinite(x[j]) or not math.isfinite(k1[j]):
                return 1, k, j % n if j < 2 * n else -1
        for j in range(n):
            if abs(x[n + j]) > MAX_SPEED:
                return 2, k, j
        # RK4 with U held and the disturbance at the step's start
        for j in range(nx):
            xs[j] = x[j] + 0.5 * dt * k1[j]
        _rates(xs, U, d, n, rtable, g, dtable, off, use_drives, tau, k2, fext, work, tmp)
        for j in range(nx):
            xs[j] = x[j] + 0.5 * dt * k2[j]
        _rates(xs, U, d, n, rtable, g, dtable, off, use_drives, tau, k3, fext, work, tmp)
        for j in range(nx):
            xs[j] = x[j] + dt * k3[j]
        _rates(xs, U, d, n, rtable, g, dtable, off, use_drives, tau, k4, fext, work, tmp)
        for j in range(nx):
            x[j] = x[j] + dt / 6.0 * (k1[j] + 2.0 * k2[j] + 2.0 * k3[j] + k4[j])
    return 0, K, -1
