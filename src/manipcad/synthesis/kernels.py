"""Compiled control-period updates of the synthesized regulators.

:func:`manipcad.sim.regulators.regulator_update` dispatches to these by the
regulator's kind code. Every parameter vector starts with the joint's packed
drive vector (indices ``0 .. NPAR-1``, :mod:`manipcad.drives.params`), so the
drive-law kernels of :mod:`manipcad.drives.laws` read it directly; the method's
own parameters follow at the indices below. SI units throughout: V, rad, s,
N·m, kg·m² (joint side unless "motor side" or a ``*`` says otherwise).

Load derivatives. The laws use the split recommended in
docs/drive-equations.md §1.2: ``h_i = Ḣ_ii`` (the momentum split, exact for
the paper's Fig. 2 turning joint) and the rest of the velocity torque, gravity
and dry friction as the motor-side disturbance ``m_f``. The simulator supplies
``H_ii``, the velocity torque ``c_i(q, q̇)`` and gravity ``Q_i`` at each
sample; ``Ḣ_ii``, ``Ḧ_ii`` and ``ṁ_f`` are taken by backward differences over
the last samples (second-order accurate), as a digital controller would.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from manipcad.drives.dc import dry_friction
from manipcad.drives.laws import asvs_a, asvs_beta, asvs_voltage, law3_voltage
from manipcad.drives.params import P_J, P_KM, P_KU, P_KV, P_KW, P_R, P_RATIO
from manipcad.sim.regulators import (
    NPARAM,
    S_HI,
    S_HII,
    S_I,
    S_Q,
    S_QD,
    S_QDDREF,
    S_QDREF,
    S_QI,
    S_QREF,
    S_THM,
    S_WM,
)

KIND_ACE_DE = 2
KIND_ACE_TF = 3
KIND_ASVS = 4
KIND_LQR = 5
KIND_CT = 6
KIND_SCE = 7

# ---- common block after the packed drive vector (NPAR = 16 entries)
#: stationary corrective element (SCE): U = kp·e + kd·ė + kfv·q̇* + kfa·q̈*
R_KP, R_KD, R_KFV, R_KFA, R_ULIM = 16, 17, 18, 19, 20
# ace_de: nominal inertia J_n (kg·m², motor side), compensate dry friction (1/0),
# compensate the measured load torque (1/0)
AD_JN, AD_FRIC, AD_TORQUE = 21, 22, 23
# ace_tf: T_1 (s), realization (0 observable = quasi-stationary, 1 controllable),
# use h* = Ḣ* (1) or h* = 0 (0), floor of (h*+k_v)·R + k_m·k_w as a fraction of k_m·k_w
AT_T1, AT_FORM, AT_HDOT, AT_DENMIN = 21, 22, 23, 24
# asvs / vss: k_e (V/rad), k_s and k_g as multiples of their minima from (5),
# adapt (1: c, a, k_g from the current H_ii; 0: fixed), H* used when fixed (kg·m²,
# motor side), margin on c (fraction of the largest sliding slope), output limit (V),
# use the measured load torque in m_f (1/0)
AS_KE, AS_KSM, AS_KGM, AS_ADAPT, AS_HFIX, AS_CM, AS_ULIM, AS_TORQUE = 16, 17, 18, 19, 20, 21, 22, 23
# lqr / lqr_gs: grid sizes and axes of the gain table (H_ii kg·m², h_i N·m·s/rad),
# output limit, reference feed-forward (1/0), load-torque compensation (1/0), feed-forward
# at the current load (1) or at LQ_HFIX (0, kg·m² joint side);
# table of (D_e, D_v, D_i), each nH×nV row-major, from LQ_TAB
LQ_NH, LQ_NV, LQ_H0, LQ_DH, LQ_V0, LQ_DV, LQ_ULIM = 16, 17, 18, 19, 20, 21, 22
LQ_FF, LQ_W, LQ_ADAPT, LQ_HFIX = 23, 24, 25, 26
# elastic transmission: gains per grid point (3 rigid model; 5 elastic model, the table then
# holds D_e, D_v, D_i, D_θ, D_ω), joint-side stiffness k_s for the deflection of the
# motor-angle reference (0: θ_m* = i_r·q*)
LQ_NG, LQ_KS = 27, 28
LQ_TAB = 32
#: largest nH·nV a gain table may have (3 gains each)
LQ_MAXCELLS = (NPARAM - LQ_TAB) // 3
#: largest nH·nV of an elastic-model table (5 gains each)
LQ_MAXCELLS_EL = (NPARAM - LQ_TAB) // 5

# computed_torque: outer-loop gains k_p (1/s²), k_d (1/s), output limit (V),
# compensate dry friction (1/0)
CT_KP, CT_KD, CT_ULIM, CT_FRIC = 16, 17, 18, 19

# ---- state
ST_INIT, ST_H1, ST_H2, ST_H3, ST_M1, ST_M2, ST_X, ST_C, ST_S, ST_MINIT = range(10)


@nb.njit(cache=True)
def _clip(u, lim):
    if u > lim:
        return lim
    if u < -lim:
        return -lim
    return u


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
def sce_output(p, sig):
    """The stationary corrective element: U = k_p·e + k_d·ė + k_fv·q̇* + k_fa·q̈*, V."""
    e = sig[S_QREF] - sig[S_Q]
    ed = sig[S_QDREF] - sig[S_QD]
    return p[R_KP] * e + p[R_KD] * ed + p[R_KFV] * sig[S_QDREF] + p[R_KFA] * sig[S_QDDREF]


@nb.njit(cache=True)
def sce_update(p, s, sig, Ts):
    """The SCE alone on the drive (no corrector), clipped: U, V."""
    return _clip(sce_output(p, sig), p[R_ULIM])


@nb.njit(cache=True)
def ace_de_update(p, s, sig, Ts):
    """Law (3) after the SCE: the drive made the constant-coefficient nominal model.

    H* = H_ii/i_r², h* = Ḣ* (the momentum split), m_f = M_f·sgn ω_m +
    (c_i − Ḣ_ii·q̇_i + Q_i)/i_r; q̈ from the measured current by the shaft
    equation i_r·q̈ = (k_m·i − (h*+k_v)·ω_m − m_f)/(J+H*). Returns U_k, V.
    """
    r = p[P_RATIO]
    r2 = r * r
    qd = sig[S_QD]
    H = sig[S_HII]
    Hd, Hdd = load_rates(H, s, Ts)
    tau = 0.0
    if p[AD_TORQUE] != 0.0:
        # the velocity torque less the part written as h_i·q̇, plus gravity
        tau = sig[S_HI] - Hd * qd + sig[S_QI]
    md = torque_rate(tau / r, s, Ts)
    Hs = H / r2
    hs = Hd / r2
    hsd = Hdd / r2
    w = r * qd
    mf = tau / r
    if p[AD_FRIC] != 0.0:
        mf += dry_friction(w, p)
    qdd = (p[P_KM] * sig[S_I] - (hs + p[P_KV]) * w - mf) / ((p[P_J] + Hs) * r)
    U = sce_output(p, sig)
    Uk = law3_voltage(U, qd, qdd, Hs, hs, hs, hsd, mf, md, p[AD_JN], p)
    return _clip(Uk, p[R_ULIM])


@nb.njit(cache=True)
def ace_tf_update(p, s, sig, Ts):
    """ACE (1) after the SCE: W_k = (T_m·s + 1)/(k_p·k_w·(T_1·s + 1)) at the current load.

    Observable form (the quasi-stationary realization) or controllable form;
    the filter is integrated exactly over the period with the input held.
    Returns U_k, V.
    """
    r = p[P_RATIO]
    r2 = r * r
    Hd, _ = load_rates(sig[S_HII], s, Ts)
    Hs = sig[S_HII] / r2
    hs = Hd / r2 if p[AT_HDOT] != 0.0 else 0.0
    R = p[P_R]
    kmkw = p[P_KM] * p[P_KW]
    Jh = p[P_J] + Hs
    den = (hs + p[P_KV]) * R + kmkw
    dmin = p[AT_DENMIN] * kmkw
    if den < dmin:
        den = dmin
    T1 = p[AT_T1]
    U = sce_output(p, sig)
    x = s[ST_X]
    a = math.exp(-Ts / T1)
    if p[AT_FORM] != 0.0:
        # controllable: T1·ẋ = U − x, U_k = (T_m·ẋ + x)/(k_p·k_w)
        xd = (U - x) / T1
        Uk = (Jh * R * xd + den * x) / kmkw
        s[ST_X] = U + (x - U) * a
    else:
        # observable: T1·v̇ = −v + (1 − T_m/T1)·U, U_k = (T_m/T1·U + v)/(k_p·k_w)
        Tm = Jh * R / den
        Uk = (Jh * R / T1 * U + den * x) / kmkw
        s[ST_X] = x * a + (1.0 - a) * (1.0 - Tm / T1) * U
    return _clip(Uk, p[R_ULIM])


@nb.njit(cache=True)
def asvs_slope(a, beta, k_e):
    """Largest slope c of S = ė + c·e that keeps the sliding regime, 1/s.

    On S = 0 the e-term of Ṡ, (a·c − c² − |β|·k_e·sgn(S·e))·e, must push back:
    |c·(c − a)| <= |β|·k_e, i.e. c <= (a + √(a² + 4|β|k_e))/2 (the stationary
    root of (5) with sgn(S·e) = −1).
    """
    return 0.5 * (a + math.sqrt(a * a + 4.0 * abs(beta) * k_e))


@nb.njit(cache=True)
def asvs_update(p, s, sig, Ts):
    """Law (4) with the slope c and the gains of (5) at the current load (or fixed).

    U_k = (k_e·|e| + k_s·|m_f| + k_g·|q̈* + a·q̇*|)·sgn(S)·sgn(i_r), S = ė + c·e.
    Returns U_k, V.
    """
    r = p[P_RATIO]
    if p[AS_ADAPT] != 0.0:
        Hs = sig[S_HII] / (r * r)
    else:
        Hs = p[AS_HFIX]
    a = asvs_a(Hs, 0.0, p)
    beta = asvs_beta(Hs, p)
    k_e = p[AS_KE]
    c = p[AS_CM] * asvs_slope(a, beta, k_e)
    kmku = p[P_KM] * p[P_KU]
    k_s = p[AS_KSM] * p[P_R] / kmku
    k_g = p[AS_KGM] * p[P_R] * abs(r) * (p[P_J] + Hs) / kmku
    e = sig[S_QREF] - sig[S_Q]
    S = sig[S_QDREF] - sig[S_QD] + c * e
    d = sig[S_QDDREF] + a * sig[S_QDREF]
    mf = dry_friction(r * sig[S_QD], p)
    if p[AS_TORQUE] != 0.0:
        mf += (sig[S_HI] + sig[S_QI]) / r
    s[ST_C] = c
    s[ST_S] = S
    return _clip(asvs_voltage(e, S, mf, d, k_e, k_s, k_g, p), p[AS_ULIM])


@nb.njit(cache=True)
def table_lookup(p, k, H, h):
    """Bilinear interpolation of gain k (0 D_e, 1 D_v, 2 D_i) at (H_ii, h_i), clamped to the grid.
    """
    nH = int(p[LQ_NH])
    nV = int(p[LQ_NV])
    base = LQ_TAB + k * nH * nV
    if nH > 1:
        fH = (H - p[LQ_H0]) / p[LQ_DH]
        fH = min(max(fH, 0.0), nH - 1.0)
        iH = min(int(fH), nH - 2)
        tH = fH - iH
    else:
        iH, tH = 0, 0.0
    if nV > 1:
        fV = (h - p[LQ_V0]) / p[LQ_DV]
        fV = min(max(fV, 0.0), nV - 1.0)
        iV = min(int(fV), nV - 2)
        tV = fV - iV
    else:
        iV, tV = 0, 0.0
    g00 = p[base + iH * nV + iV]
    g01 = p[base + iH * nV + iV + 1] if nV > 1 else g00
    g10 = p[base + (iH + 1) * nV + iV] if nH > 1 else g00
    g11 = p[base + (iH + 1) * nV + iV + 1] if (nH > 1 and nV > 1) else (g10 if nH > 1 else g01)
    return (1.0 - tH) * ((1.0 - tV) * g00 + tV * g01) + tH * ((1.0 - tV) * g10 + tV * g11)


@nb.njit(cache=True)
def lqr_feedforward(p, Di, H, sig):
    """Model-inverse feed-forward of the reference (and of the load torque), V.

    With U = D_e·e + D_v·ė − D_i·i + U_ff, e = ė = 0 along the reference needs
    i* = (J_q·q̈* + k_v·i_r²·q̇* + τ_w)/(k_m·i_r) and, L neglected,
    U_ff = (D_i + R/k_u)·i* + k_w·i_r·q̇*/k_u with J_q = H_ii + J·i_r²;
    τ_w = c_i + Q_i (velocity torque and gravity) when compensated.
    """
    r = p[P_RATIO]
    g = (Di + p[P_R] / p[P_KU]) / (p[P_KM] * r)
    tau = (H + p[P_J] * r * r) * sig[S_QDDREF] + p[P_KV] * r * r * sig[S_QDREF]
    if p[LQ_W] != 0.0:
        tau += sig[S_HI] + sig[S_QI]
    return g * tau + p[P_KW] * r * sig[S_QDREF] / p[P_KU]


@nb.njit(cache=True)
def lqr_update(p, s, sig, Ts):
    """U = D_e·e + D_v·ė − D_i·i (+ U_ff), gains looked up at the current (H_ii, Ḣ_ii), V."""
    H = sig[S_HII]
    h = 0.0
    if int(p[LQ_NV]) > 1:
        h, _ = load_rates(H, s, Ts)
    De = table_lookup(p, 0, H, h)
    Dv = table_lookup(p, 1, H, h)
    Di = table_lookup(p, 2, H, h)
    e = sig[S_QREF] - sig[S_Q]
    ed = sig[S_QDREF] - sig[S_QD]
    U = De * e + Dv * ed - Di * sig[S_I]
    Hff = H if p[LQ_ADAPT] != 0.0 else p[LQ_HFIX]
    if p[LQ_NG] == 5.0:
        # elastic model: motor angle and speed errors against θ_m* = i_r·(q* + τ_s*/k_s),
        # ω_m* = i_r·q̇*
        r = p[P_RATIO]
        th = sig[S_QREF]
        if p[LQ_KS] > 0.0 and p[LQ_FF] != 0.0:
            tau = Hff * sig[S_QDDREF]
            if p[LQ_W] != 0.0:
                tau += sig[S_HI] + sig[S_QI]
            th += tau / p[LQ_KS]
        U += (table_lookup(p, 3, H, h) * (r * th - sig[S_THM])
              + table_lookup(p, 4, H, h) * (r * sig[S_QDREF] - sig[S_WM]))
    if p[LQ_FF] != 0.0:
        U += lqr_feedforward(p, Di, Hff, sig)
    return _clip(U, p[LQ_ULIM])


@nb.njit(cache=True)
def computed_torque_update(p, s, sig, Ts):
    """Decentralized computed torque through the drive model (L neglected), V.

    v = q̈* + k_d·ė + k_p·e; joint torque τ = (H_ii + J·i_r²)·v + k_v·i_r²·q̇ + c_i
    + Q_i (+ |i_r|·M_f·sgn q̇); current i* = τ/(k_m·i_r); U = (R·i* + k_w·i_r·q̇)/k_u.
    """
    r = p[P_RATIO]
    qd = sig[S_QD]
    v = (sig[S_QDDREF] + p[CT_KD] * (sig[S_QDREF] - qd)
         + p[CT_KP] * (sig[S_QREF] - sig[S_Q]))
    tau = ((sig[S_HII] + p[P_J] * r * r) * v + p[P_KV] * r * r * qd
           + sig[S_HI] + sig[S_QI])
    if p[CT_FRIC] != 0.0:
        tau += r * dry_friction(r * qd, p)
    i_star = tau / (p[P_KM] * r)
    return _clip((p[P_R] * i_star + p[P_KW] * r * qd) / p[P_KU], p[CT_ULIM])


def lookup_py(params: np.ndarray, H: float, h: float) -> np.ndarray:
    """The gains (D_e V/rad, D_v V·s/rad, D_i V/A[, D_θ V/rad, D_ω V·s/rad on the elastic
    model]) the compiled loop uses at (H_ii, h_i)."""
    p = np.asarray(params, dtype=float)
    ng = 5 if p[LQ_NG] == 5.0 else 3
    return np.array([table_lookup(p, k, float(H), float(h)) for k in range(ng)])
