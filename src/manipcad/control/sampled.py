"""Is the sampled loop stable? The regulator as it runs, closed around its drive at a frozen load.

Gains designed in continuous time (or for another period) can make the digital loop
unstable: a regulator sampled every T seconds with zero-order hold sees the drive
discretized exactly (``A_d = e^{A·T}``, ``B_d = ∫e^{A·t}dt·B``). This module builds one
period of that loop with the regulator's own compiled law (so what is checked is what
runs), takes its Jacobian at rest (exact for the linear laws: P, PD, PID, SCE, LQR,
computed torque, and law (3)/ACE (1) at a frozen load) and its eigenvalues. With
|λ|max >= 1 the regulator is refused, naming the largest period (with these gains) for
which the loop is stable.

The drive is the third-order rigid-gear model of :func:`manipcad.drives.linear.linearize`
at the ends of the regulator's H_ii range; dry friction, the amplifier limit and the
switching laws (``asvs``, ``vss``: a sliding regime is not an eigenvalue question) are
outside this check.
"""

from __future__ import annotations

import numpy as np

from manipcad.control.registry import method
from manipcad.control.regulator import Regulator
from manipcad.control.signals import (
    NSIG,
    S_HII,
    S_I,
    S_Q,
    S_QD,
    S_THM,
    S_WM,
)
from manipcad.drives.linear import linearize
from manipcad.drives.params import P_MFN, P_MFP
from manipcad.errors import ManipcadError


def _discrete(drive, H: float, T: float) -> tuple[np.ndarray, np.ndarray]:
    lin = linearize(drive, H, 0.0, order=3)
    A, B = np.asarray(lin.A, float), np.asarray(lin.B, float).reshape(-1, 1)
    n = A.shape[0]
    M = np.zeros((n + 1, n + 1))
    M[:n, :n] = A * T
    M[:n, n:] = B * T
    from scipy.linalg import expm  # deferred: start-up cost: scipy.linalg on first use

    E = expm(M)
    return E[:n, :n], E[:n, n:]


def spectral_radius(reg: Regulator, drive, H: float, period: float | None = None) -> float:
    """|λ|max of one period of the sampled loop (the regulator's law around the drive at
    joint-side inertia H, kg·m²), at ``period`` s (default the regulator's)."""
    m = method(reg.method)
    law = m.update
    T = float(reg.period if period is None else period)
    Ad, Bd = _discrete(drive, H, T)
    p = np.array(reg.params, dtype=float)
    if m.drive_blocks == 1:  # dry friction is outside a linear check
        p[P_MFP] = p[P_MFN] = 0.0
    r = drive.ratio
    dyn = m.dynamic_states
    nx = Ad.shape[0]

    def signals(x):
        sig = np.zeros((1, NSIG))
        sig[0, S_Q], sig[0, S_QD], sig[0, S_I] = x[0], x[1], x[2]
        sig[0, S_HII] = H
        sig[0, S_THM], sig[0, S_WM] = r * x[0], r * x[1]
        return sig

    # the law's history (load differences) at rest: a few periods at equilibrium
    s0 = np.zeros(16)
    for _ in range(4):
        law(p, s0, signals(np.zeros(nx)), 0, T)

    def step(z):
        x = z[:nx]
        s = s0.copy()
        for k, idx in enumerate(dyn):
            s[idx] = z[nx + k]
        U = law(p, s, signals(x), 0, T)
        return np.concatenate([Ad @ x + Bd[:, 0] * U, [s[idx] for idx in dyn]])

    nz = nx + len(dyn)
    f0 = step(np.zeros(nz))
    J = np.empty((nz, nz))
    h = 1e-6
    for k in range(nz):
        z = np.zeros(nz)
        z[k] = h
        J[:, k] = (step(z) - f0) / h
    return float(np.abs(np.linalg.eigvals(J)).max())


def check_sampled(reg: Regulator, drive, loads: tuple[float, ...]) -> dict:
    """Refuse a regulator whose sampled loop is unstable at any of ``loads`` (kg·m²).

    Returns:
        ``{"spectral_radius": |λ|max over the loads, "stable_period_max": s}`` (the
        largest period, in a geometric scan down from the regulator's, that is stable with
        these gains; equal to the period when it is stable).

    Raises:
        ManipcadError: unstable, naming |λ|, the load and the stable period range.
    """
    if not method(reg.method).linear:
        return {}
    rho = {H: spectral_radius(reg, drive, H) for H in loads}
    worst_H = max(rho, key=rho.get)
    if rho[worst_H] < 1.0 - 1e-9:
        return {"spectral_radius": rho[worst_H], "stable_period_max": reg.period}
    stable = 0.0
    for T in np.geomspace(reg.period, reg.period / 1000.0, 61)[1:]:
        if max(spectral_radius(reg, drive, H, T) for H in loads) < 1.0 - 1e-9:
            stable = float(T)
            break
    names = ", ".join(reg.joint_names) or str(reg.joints[0])
    where = (f"periods up to {stable:.3g} s are stable with these gains; re-synthesize "
             f"with period={stable:.3g} or below, or with gains for this period" if stable
             else f"no period down to {reg.period / 1000:.3g} s is stable with these gains "
                  "(check their signs and size)")
    raise ManipcadError(
        f"{reg.method} on {names}: the sampled loop is unstable at the period "
        f"{reg.period:g} s (|λ|max = {rho[worst_H]:.4g} at H_ii = {worst_H:.4g} kg·m²); "
        f"{where}")
