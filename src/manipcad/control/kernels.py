"""Compiled pieces several regulators share: load-rate differences, the SCE, the gain table.

Every single-joint method's update has the signature ``law(p, s, sig, j, Ts) -> U``:
``p`` its parameter vector (float64, :data:`~manipcad.control.signals.NPARAM`), ``s``
its state vector (:data:`~manipcad.control.signals.NSTATE`, zero at t = 0), ``sig`` the
signal matrix (one row per joint, columns ``S_*``), ``j`` its joint, ``Ts`` its period
(s); it returns the amplifier input U, V (the joint torque, N·m or N, without a drive).

Parameter layout shared by the drive-based methods: indices ``0 .. NPAR-1`` hold the
drive the design assumed, packed by :func:`manipcad.drives.params.pack_drive` (so the
drive-law kernels of :mod:`manipcad.drives.laws` read it directly); the stationary
corrective element (SCE) of ``none_sce``, ``ace_de`` and ``ace_tf`` follows at
``R_KP .. R_ULIM``; a method's own parameters come after.
"""

from __future__ import annotations

import numba as nb

from manipcad.control.signals import S_Q, S_QD, S_QDDREF, S_QDREF, S_QREF

#: SCE: U = kp·e + kd·ė + kfv·q̇* + kfa·q̈* (V/rad, V·s/rad, V·s/rad, V·s²/rad), limit (V)
R_KP, R_KD, R_KFV, R_KFA, R_ULIM = 16, 17, 18, 19, 20

#: state entries shared by the laws that difference the load: history of H_ii and of a
#: motor-side torque (first-sample flags ST_INIT, ST_MINIT), a filter state, the slope c and S
ST_INIT, ST_H1, ST_H2, ST_H3, ST_M1, ST_M2, ST_X, ST_C, ST_S, ST_MINIT = range(10)


@nb.njit(cache=True)
def load_rates(H, s, Ts):
    """Backward-difference Ḣ_ii (kg·m²/s) and Ḧ_ii (kg·m²/s²); shifts the history in ``s``.

    Ḣ ≈ (3H_k − 4H_{k−1} + H_{k−2})/(2T), Ḧ ≈ (2H_k − 5H_{k−1} + 4H_{k−2} − H_{k−3})/T²
    (both O(T²)); the first sample starts the history at rest.
    """
    if s[ST_INIT] == 0.0:
        s[ST_INIT] = 1.0
        s[ST_H1] = H
        s[ST_H2] = H
        s[ST_H3] = H
    H1, H2, H3 = s[ST_H1], s[ST_H2], s[ST_H3]
    Hd = (3.0 * H - 4.0 * H1 + H2) / (2.0 * Ts)
    Hdd = (2.0 * H - 5.0 * H1 + 4.0 * H2 - H3) / (Ts * Ts)
    s[ST_H3] = H2
    s[ST_H2] = H1
    s[ST_H1] = H
    return Hd, Hdd


@nb.njit(cache=True)
def torque_rate(m, s, Ts):
    """Backward-difference ṁ (N·m/s) of a motor-side torque, O(T²); shifts its history."""
    if s[ST_MINIT] == 0.0:
        s[ST_MINIT] = 1.0
        s[ST_M1] = m
        s[ST_M2] = m
    md = (3.0 * m - 4.0 * s[ST_M1] + s[ST_M2]) / (2.0 * Ts)
    s[ST_M2] = s[ST_M1]
    s[ST_M1] = m
    return md


@nb.njit(cache=True)
def sce_output(p, sig, j):
    """The stationary corrective element: U = k_p·e + k_d·ė + k_fv·q̇* + k_fa·q̈*, V."""
    e = sig[j, S_QREF] - sig[j, S_Q]
    ed = sig[j, S_QDREF] - sig[j, S_QD]
    return (p[R_KP] * e + p[R_KD] * ed + p[R_KFV] * sig[j, S_QDREF]
            + p[R_KFA] * sig[j, S_QDDREF])


@nb.njit(cache=True)
def _grid_cell(x, x0, dx, n):
    """The cell of x on the uniform grid x0 + k·dx, k = 0..n-1, clamped to its edges:
    (index of the cell's lower corner, fraction 0..1 across the cell); (0, 0.0) for n = 1."""
    if n > 1:
        f = (x - x0) / dx
        f = min(max(f, 0.0), n - 1.0)
        i = min(int(f), n - 2)
        return i, f - i
    return 0, 0.0


@nb.njit(cache=True)
def table_lookup(p, base, nH, nV, H0, dH, V0, dV, H, h):
    """Bilinear interpolation in a gain table stored row-major (nH × nV) from ``p[base]``.

    The grid is uniform: H_ii = H0 + a·dH (kg·m²), h = V0 + b·dV (N·m·s/rad); the point
    is clamped to the grid's edges. Returns the interpolated gain.
    """
    iH, tH = _grid_cell(H, H0, dH, nH)
    iV, tV = _grid_cell(h, V0, dV, nV)
    g00 = p[base + iH * nV + iV]
    g01 = p[base + iH * nV + iV + 1] if nV > 1 else g00
    g10 = p[base + (iH + 1) * nV + iV] if nH > 1 else g00
    g11 = p[base + (iH + 1) * nV + iV + 1] if (nH > 1 and nV > 1) else (g10 if nH > 1 else g01)
    return (1.0 - tH) * ((1.0 - tV) * g00 + tV * g01) + tH * ((1.0 - tV) * g10 + tV * g11)
