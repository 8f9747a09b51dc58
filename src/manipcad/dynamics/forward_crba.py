"""Forward dynamics by the mass matrix and Cholesky (paper 4.2, method 1).

H q̈ = T* with T* = P - ĥ (8): the velocity, gravity, external and friction
torques ĥ come from the inverse dynamics at q̈ = 0, H from the composite
rigid-body algorithm, and the system is solved by Cholesky ("Holetsky").
"""

from __future__ import annotations

import math

import numpy as np

from manipcad.dynamics._kernels_common import batch_twins, jit
from manipcad.dynamics.crba import CRBA_WORK, crba_state
from manipcad.dynamics.rnea import RNEA_WORK, rnea_state


@jit
def cholesky_solve(H, b, x):
    """Solve H x = b in place of H (lower Cholesky factor) for symmetric positive definite H."""
    n = H.shape[0]
    for j in range(n):
        d = H[j, j]
        for k in range(j):
            d = d - H[j, k] * H[j, k]
        if d <= 0.0:
            return False
        d = math.sqrt(d)
        H[j, j] = d
        for i in range(j + 1, n):
            s = H[i, j]
            for k in range(j):
                s = s - H[i, k] * H[j, k]
            H[i, j] = s / d
    for i in range(n):
        s = b[i]
        for k in range(i):
            s = s - H[i, k] * x[k]
        x[i] = s / H[i, i]
    for i in range(n - 1, -1, -1):
        s = x[i]
        for k in range(i + 1, n):
            s = s - H[k, i] * x[k]
        x[i] = s / H[i, i]
    return True


@jit
def crba_fd_batch(table, g, Q, QD, TAU, FEXT, use_fext, drives, QDD):
    """Forward dynamics of N states by H q̈ = tau - ĥ; returns the index of the
    first state whose H is not positive definite, or -1.

    The one loop over states (see :func:`manipcad.dynamics.rnea.rnea_batch`).
    """
    n = table.shape[0]
    rwork = np.empty((n, RNEA_WORK))
    cwork = np.empty((n, CRBA_WORK))
    tmp = np.zeros((8, 3))
    H = np.empty((n, n))
    zero = np.zeros(n)
    bias = np.empty(n)
    for k in range(Q.shape[0]):
        rnea_state(table, g, Q[k], QD[k], zero, FEXT[k if use_fext else 0],
                   use_fext, drives, rwork, bias)
        crba_state(table, Q[k], drives, cwork, tmp, H)
        for i in range(n):
            bias[i] = TAU[k, i] - bias[i]
        if not cholesky_solve(H, bias, QDD[k]):
            return k
    return -1


#: :func:`crba_fd_batch` on chunks of rows on numba's threads, and on one state
crba_fd_batch_parallel, crba_fd_vector = batch_twins(crba_fd_batch, "crba_fd")
