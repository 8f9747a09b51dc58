"""``lqr`` and ``lqr_gs``: the quadratic-criterion method (6)-(7).

The drive at a frozen load (H_ii, h_i) is linear, ε̇ = A·ε + B·U (+ F(ε) + W:
dry friction, amplifier limit and the load torque, which the linear design
leaves out), with ε = (q, q̇, i) at order 3 (:func:`manipcad.drives.linearize`).
python-control's ``lqr`` minimizes ∫(εᵀQε + R·U²)dt with Bryson weights
``Q = diag(1/e_max², 1/ė_max², 1/i_max²)``, ``R = 1/U_max²``; the regulator is

    U = D_e·(q* − q) + D_v·(q̇* − q̇) − D_i·i + U_ff         (V)

with the model-inverse feed-forward (L neglected; J_q = H_ii + J·i_r²)
U_ff = (D_i + R/k_u)·(J_q·q̈* + k_v·i_r²·q̇* + τ_w)/(k_m·i_r) + k_w·i_r·q̇*/k_u,
which keeps e = ė = 0 along the reference; τ_w = c_i + Q_i is the measured
velocity torque and gravity (the W of (6)) when compensated.

- ``lqr``: one gain (D_e, D_v, D_i) and the feed-forward computed at the
  nominal load; no load signal measured.
- ``lqr_gs``: the gains computed ahead over a grid of (H_ii, h_i) and kept as a
  table (:class:`GainTable`); the compiled loop interpolates it bilinearly at
  the current H_ii and h_i = Ḣ_ii (backward difference) each period, clamped to
  the grid's edges, and the feed-forward at the current H_ii with τ_w
  compensated. Gravity Q_i enters the drive's linear model only as the
  disturbance W (it changes neither A nor B), so the table has no Q_i axis: the
  gains would be the same along it.

Elastic transmission (``transmission=``; backlash is designed for in contact,
where the linear model is the elastic one): the LQR of the model
ε = (q, q̇, θ_m, ω_m, i) (:func:`manipcad.drives.linearize` with ``elasticity``),
with the motor angle and speed errors weighed 1/(i_r·e_max)², 1/(i_r·ė_max)²;
the regulator adds D_θ·(θ_m* − θ_m) + D_ω·(ω_m* − ω_m) to (V), with
θ_m* = i_r·(q* + τ*/k_s) (τ* = H_ii·q̈* (+ τ_w) the torque the spring passes,
with the feed-forward) and ω_m* = i_r·q̇*. The simulator supplies θ_m, ω_m
(``S_THM``, ``S_WM``). The table then holds (D_e, D_v, D_i, D_θ, D_ω).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numba as nb
import numpy as np

from manipcad._lazy import ct
from manipcad.control.design import (
    DEFAULT_PERIOD,
    back_emf_feedforward,
    check_period,
    inertia_range,
    joint_drive,
    law_efficiency,
    packed,
)
from manipcad.control.kernels import load_rates, table_lookup
from manipcad.control.method import GEAR_EFFICIENCY_OPTIONAL, Method, TableLayout
from manipcad.control.regulator import Regulator, current_limit, u_limit
from manipcad.control.signals import (
    NPARAM,
    S_CI,
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
from manipcad.control.systems import nonlinear_system, static_gain
from manipcad.drives.dc import clip, required_joint_torque, rigid_current_for, static_input
from manipcad.drives.linear import linearize
from manipcad.drives.params import P_RATIO, Transmission, as_transmission
from manipcad.dynamics.gear import gear_factor
from manipcad.errors import InputError, ManipcadError, ModelError
from manipcad.fileio import file_number
from manipcad.model.robot import Drive, Robot

# grid sizes and axes of the gain table (H_ii kg·m², h = Ḣ_ii N·m·s/rad), output limit (V),
# reference feed-forward (1/0), load-torque compensation (1/0), feed-forward at the current
# load (1) or at LQ_HFIX (0, kg·m² joint side); gains per grid point (3 rigid model; 5 elastic
# model: D_e, D_v, D_i, D_θ, D_ω), joint-side stiffness k_s for the deflection of the
# motor-angle reference (0: θ_m* = i_r·q*); the table of each gain, nH×nV row-major, from LQ_TAB
LQ_NH, LQ_NV, LQ_H0, LQ_DH, LQ_V0, LQ_DV, LQ_ULIM = 16, 17, 18, 19, 20, 21, 22
LQ_FF, LQ_W, LQ_ADAPT, LQ_HFIX = 23, 24, 25, 26
LQ_NG, LQ_KS = 27, 28
# lqr_gs: the gear efficiency η its load model assumes (-; 0 or 1: none; the fixed lqr has
# no load model and stores none, so its law stays linear)
LQ_ETA = 29
LQ_TAB = 32
#: largest nH·nV a gain table may have (3 gains each)
LQ_MAXCELLS = (NPARAM - LQ_TAB) // 3
#: largest nH·nV of an elastic-model table (5 gains each)
LQ_MAXCELLS_EL = (NPARAM - LQ_TAB) // 5
FIELDS = {"u_limit_V": LQ_ULIM, "feedforward": LQ_FF, "load_torque_compensation": LQ_W,
          "feedforward_at_current_load": LQ_ADAPT, "H_ii_feedforward_kgm2": LQ_HFIX,
          "k_s_Nm_per_rad": LQ_KS}
#: lqr_gs also stores the gear efficiency its load model assumes
FIELDS_GS = {**FIELDS, "gear_efficiency": LQ_ETA}
#: the table's gains in files: key (with unit), in table order
GAIN_NAMES = ("D_e_V_per_rad", "D_v_V_s_per_rad", "D_i_V_per_A", "D_theta_V_per_rad",
              "D_omega_V_s_per_rad")


@nb.njit(cache=True)
def gain(p, k, H, h):
    """Gain k (0 D_e, 1 D_v, 2 D_i, 3 D_θ, 4 D_ω) at (H_ii, h) from the packed table."""
    nH = int(p[LQ_NH])
    nV = int(p[LQ_NV])
    return table_lookup(p, LQ_TAB + k * nH * nV, nH, nV, p[LQ_H0], p[LQ_DH], p[LQ_V0],
                        p[LQ_DV], H, h)


@nb.njit(cache=True)
def lqr_load(p, H, sig, j):
    """The load torque of the law's model along the reference, N·m (N): H_ii·q̈* (+ τ_w =
    c_i + Q_i, velocity torque and gravity, when compensated)."""
    tau = H * sig[j, S_QDDREF]
    if p[LQ_W] != 0.0:
        tau += sig[j, S_CI] + sig[j, S_QI]
    return tau


@nb.njit(cache=True)
def lqr_feedforward(p, Di, H, f, sig, j):
    """Model-inverse feed-forward of the reference (and of the load torque), V.

    With U = D_e·e + D_v·ė − D_i·i + U_ff, e = ė = 0 along the reference needs
    i* = (f·(H_ii·q̈* + τ_w) + J·i_r²·q̈* + k_v·i_r²·q̇*)/(k_m·i_r) and, L neglected,
    U_ff = D_i·i* + (R·i* + k_w·i_r·q̇*)/k_u; τ_w = c_i + Q_i (velocity torque and
    gravity) when compensated; f the gear factor (1/η motoring or holding, η braking;
    1 without losses); :func:`manipcad.drives.dc.required_joint_torque` and
    :func:`~manipcad.drives.dc.rigid_current_for`, as the computed torque's.
    """
    i_star = rigid_current_for(required_joint_torque(
        f, lqr_load(p, H, sig, j), sig[j, S_QDDREF], sig[j, S_QDREF], 0.0, p), p)
    return Di * i_star + static_input(i_star, p[P_RATIO] * sig[j, S_QDREF], p)


@nb.njit(cache=True)
def lqr_update(p, s, sig, j, Ts):
    """U = D_e·e + D_v·ė − D_i·i (+ U_ff), gains looked up at the current (H_ii, Ḣ_ii), V.

    With a gear efficiency η (lqr_gs with its feed-forward at the current load) the gear
    factor f = 1/η or η of the load the model has the gear pass (:func:`lqr_load`, power
    flow against the measured q̇; :func:`manipcad.dynamics.gear.gear_factor`) multiplies that
    load in U_ff and the load the gains are looked up at: (f·H_ii, f·Ḣ_ii), the inertia
    and velocity coefficient the motor feels through the gear.
    """
    if p[LQ_NH] > 1.0 or p[LQ_ADAPT] != 0.0:
        H = sig[j, S_HII]
    else:
        H = p[LQ_HFIX]
    h = 0.0
    if int(p[LQ_NV]) > 1:
        h, _ = load_rates(H, s, Ts)
    Hff = H if p[LQ_ADAPT] != 0.0 else p[LQ_HFIX]
    f = 1.0
    eta = p[LQ_ETA]
    if eta > 0.0 and eta != 1.0 and p[LQ_ADAPT] != 0.0 and p[LQ_FF] != 0.0:
        f = gear_factor(eta, lqr_load(p, Hff, sig, j), sig[j, S_QD])
    De = gain(p, 0, f * H, f * h)
    Dv = gain(p, 1, f * H, f * h)
    Di = gain(p, 2, f * H, f * h)
    e = sig[j, S_QREF] - sig[j, S_Q]
    ed = sig[j, S_QDREF] - sig[j, S_QD]
    U = De * e + Dv * ed - Di * sig[j, S_I]
    if p[LQ_NG] == 5.0:
        # elastic model: motor angle and speed errors against θ_m* = i_r·(q* + τ_s*/k_s),
        # ω_m* = i_r·q̇*
        r = p[P_RATIO]
        th = sig[j, S_QREF]
        if p[LQ_KS] > 0.0 and p[LQ_FF] != 0.0:
            th += lqr_load(p, Hff, sig, j) / p[LQ_KS]
        U += (gain(p, 3, H, h) * (r * th - sig[j, S_THM])
              + gain(p, 4, H, h) * (r * sig[j, S_QDREF] - sig[j, S_WM]))
    if p[LQ_FF] != 0.0:
        U += lqr_feedforward(p, Di, Hff, f, sig, j)
    return clip(U, p[LQ_ULIM])


_SPEC = {"e_max", "ed_max", "i_max", "u_max"}


@dataclass(frozen=True)
class Weights:
    """Bryson weights: largest acceptable error e_max (rad), velocity error ė_max (rad/s),
    current i_max (A) and input U_max (V)."""

    e_max: float
    ed_max: float
    i_max: float
    u_max: float

    def matrices(self, order: int, ratio: float | None = None) -> tuple[np.ndarray, np.ndarray]:
        """Q, R; with ``ratio`` (elastic model) the motor angle and speed errors weigh
        1/(i_r·e_max)² and 1/(i_r·ė_max)²."""
        q = [1 / self.e_max ** 2, 1 / self.ed_max ** 2]
        if ratio is not None:
            q += [1 / (ratio * self.e_max) ** 2, 1 / (ratio * self.ed_max) ** 2]
        if order == 3:
            q.append(1 / self.i_max ** 2)
        return np.diag(q), np.array([[1 / self.u_max ** 2]])


def weights_from_spec(spec, drive: Drive) -> Weights:
    spec = dict(spec or {})
    unknown = set(spec) - _SPEC
    if unknown:
        raise ManipcadError(f"unknown spec keys {sorted(unknown)}; known: {sorted(_SPEC)}")
    u_rated = u_limit(drive)
    ulim = u_rated if math.isfinite(u_rated) else 10.0
    i_rated = current_limit(drive)
    i_def = i_rated if math.isfinite(i_rated) else ulim / drive.R
    w = Weights(float(spec.get("e_max", 0.01)), float(spec.get("ed_max", 0.3)),
                float(spec.get("i_max", i_def)), float(spec.get("u_max", ulim)))
    for name in ("e_max", "ed_max", "i_max", "u_max"):
        v = getattr(w, name)
        if not (math.isfinite(v) and v > 0):
            raise ManipcadError(f"lqr spec {name} must be > 0, got {v}")
    if w.i_max > i_rated * (1 + 1e-12):
        raise ManipcadError(f"lqr spec i_max = {w.i_max:g} A is above the motor's current "
                            f"bound {i_rated:.4g} A (its peak current, at most 10× its rated "
                            f"current): the design would plan for currents the motor cannot "
                            f"take; give i_max <= {i_rated:.4g}")
    if w.u_max > u_rated * (1 + 1e-12):
        raise ManipcadError(f"lqr spec u_max = {w.u_max:g} V is above the drive's voltage "
                            f"bound {u_rated:.4g} V (amplifier limit, motor rated voltage); "
                            f"give u_max <= {u_rated:.4g}")
    return w


def _linearize(drive: Drive, H_ii: float, h_i: float, order: int,
               transmission: Transmission | None):
    try:
        return linearize(drive, H_ii, h_i, order=order, elasticity=transmission)
    except ModelError as exc:
        raise ManipcadError(f"lqr: {exc}") from exc


def _state_gains(gains, order: int, elastic: bool) -> np.ndarray:
    """The stored gains (D_e, D_v, D_i[, D_θ, D_ω]) in the linear model's state order."""
    g = np.asarray(gains, dtype=float)
    k = [g[0], g[1]] + ([g[3], g[4]] if elastic else [])
    if order == 3:
        k.append(g[2])
    return np.array(k).reshape(1, -1)


def lqr_gains(drive: Drive, H_ii: float, h_i: float, weights: Weights,
              order: int = 3, transmission=None, period: float | None = None) -> np.ndarray:
    """(D_e V/rad, D_v V·s/rad, D_i V/A) of the LQR at a frozen load (D_i = 0 at order 2).

    Args:
        drive: the drive.
        H_ii: joint-side load inertia, kg·m²; h_i: velocity coefficient, N·m·s/rad.
        weights: :class:`Weights`.
        order: 3 (states q, q̇, i) or 2 (q, q̇).
        transmission: an elastic transmission (a :class:`Transmission`, k_s or
            (k_s, d_s); backlash is designed for in contact): the LQR of the model
            (q, q̇, θ_m, ω_m[, i]), and the gains are (D_e, D_v, D_i, D_θ V/rad, D_ω V·s/rad).
        period: the control period T, s: the LQR of the drive discretized with zero-order
            hold at T (``control.dlqr`` on ``c2d``, weights Q·T, R·T), so the sampled loop
            is stable at that period; None: the continuous-time LQR.
    """
    tr = as_transmission(transmission)
    lin = _linearize(drive, H_ii, h_i, order, tr)
    Q, R = weights.matrices(order, drive.ratio if tr is not None else None)
    if period is None:
        K, _, _ = ct.lqr(lin.A, lin.B, Q, R)
    else:
        sysd = ct.c2d(ct.ss(lin.A, lin.B, np.eye(lin.A.shape[0]), 0), float(period), "zoh")
        K, _, _ = ct.dlqr(sysd.A, sysd.B, np.asarray(Q) * period, np.asarray(R) * period)
    K = np.asarray(K).ravel()
    if tr is None:
        return np.array([K[0], K[1], K[2] if order == 3 else 0.0])
    return np.array([K[0], K[1], K[4] if order == 3 else 0.0, K[2], K[3]])


def closed_loop_poles(drive: Drive, H_ii: float, h_i: float, gains, order: int = 3,
                      transmission=None) -> np.ndarray:
    """Poles of the frozen-load drive with U = −D·ε (rad/s)."""
    tr = as_transmission(transmission)
    lin = _linearize(drive, H_ii, h_i, order, tr)
    K = _state_gains(gains, order, tr is not None)
    return np.linalg.eigvals(lin.A - lin.B @ K)


@dataclass
class GainTable:
    """LQR gains tabulated over (H_ii kg·m², h_i N·m·s/rad).

    Attributes:
        H: (nH,) grid of H_ii; h: (nV,) grid of h_i.
        gains: (nH, nV, 3) D_e, D_v, D_i, or (nH, nV, 5) with D_θ, D_ω of the elastic model.
    """

    H: np.ndarray
    h: np.ndarray
    gains: np.ndarray

    def at(self, H_ii: float, h_i: float = 0.0) -> np.ndarray:
        """Interpolated gains at a load inside the table: the compiled lookup the regulator
        runs (:func:`gain`), D_e V/rad, D_v V·s/rad, D_i V/A (, D_θ V/rad, D_ω V·s/rad).

        Raises:
            ManipcadError: the load is outside the table.
        """
        for v, ax, name in ((H_ii, self.H, "H_ii"), (h_i, self.h, "h_i")):
            lo, hi = ax[0], ax[-1]
            tol = 1e-12 * max(1.0, abs(lo), abs(hi))
            if not (lo - tol <= v <= hi + tol):
                raise ManipcadError(f"load outside the gain table: {name} = {v:g} not in "
                                    f"[{lo:g}, {hi:g}]")
        p = np.zeros(NPARAM)
        pack_table(p, self, math.inf)
        return np.array([gain(p, k, float(H_ii), float(h_i))
                         for k in range(self.gains.shape[-1])])

    def fit(self, degree: int = 2):
        """Fit each gain by a polynomial in (H_ii, h_i) of total degree ``degree`` (least squares).

        The "fitted functions" alternative to the table: fewer numbers stored.

        Returns:
            (f, max_rel_err): ``f(H_ii, h_i) -> (D_e, D_v, D_i)`` and the largest
            relative error of the fit at the grid points.
        """
        degree = int(degree)
        if degree < 0:
            raise ManipcadError(f"fit degree must be >= 0, got {degree}")
        HH, hh = np.meshgrid(self.H, self.h, indexing="ij")
        Hs = (HH.ravel() - self.H.mean()) / (np.ptp(self.H) or 1.0)
        vs = (hh.ravel() - self.h.mean()) / (np.ptp(self.h) or 1.0)
        terms = [(a, b) for a in range(degree + 1) for b in range(degree + 1 - a)
                 if (a == 0 or len(self.H) > a) and (b == 0 or len(self.h) > b)]

        def basis(x, y):
            return np.stack([x ** a * y ** b for a, b in terms], axis=-1)

        A = basis(Hs, vs)
        G = self.gains.reshape(-1, self.gains.shape[-1])
        coef, *_ = np.linalg.lstsq(A, G, rcond=None)
        err = float(np.max(np.abs(A @ coef - G) / np.maximum(np.abs(G), 1e-300)))
        H0, Hw = self.H.mean(), (np.ptp(self.H) or 1.0)
        v0, vw = self.h.mean(), (np.ptp(self.h) or 1.0)

        def f(H_ii: float, h_i: float = 0.0) -> np.ndarray:
            return basis(np.asarray((H_ii - H0) / Hw), np.asarray((h_i - v0) / vw)) @ coef

        return f, err


def gain_cell(H: float, h: float, drive: Drive, weights: Weights, order: int, tr,
              period: float | None) -> np.ndarray:
    """The LQR gains at one grid point (a task of :func:`gain_table`'s executor)."""
    return lqr_gains(drive, H, h, weights, order, tr, period)


def gain_table(drive: Drive, H_grid, h_grid, weights: Weights, order: int = 3, *,
               progress: bool = False, n_jobs: int = 1, transmission=None,
               period: float | None = None, scheduler: str | None = None) -> GainTable:
    """Compute the LQR gains at every grid point, on the sweep executor.

    Args:
        drive: the drive; H_grid, h_grid: the axes (kg·m², N·m·s/rad).
        weights: :class:`Weights`; order: 3 or 2.
        progress: show a progress bar (rich) while computing.
        n_jobs: worker processes of a local Dask cluster (1: in this process;
            :func:`manipcad.parallel.run_tasks`).
        transmission: an elastic transmission: the gains of the elastic model (5 each).
        period: design each point in discrete time at this control period, s
            (:func:`lqr_gains`); None: continuous time.
        scheduler: address of a running Dask scheduler (``tcp://HOST:PORT``) instead.

    Returns:
        :class:`GainTable` (the same whichever way the points ran).
    """
    # deferred: start-up cost: keeps manipcad.parallel out of import manipcad
    from manipcad.parallel import run_tasks

    H_grid = np.asarray(H_grid, dtype=float)
    h_grid = np.asarray(h_grid, dtype=float)
    n_jobs = int(n_jobs)
    if n_jobs < 1:
        raise ManipcadError(f"n_jobs must be >= 1, got {n_jobs}")
    idx = [(a, b) for a in range(len(H_grid)) for b in range(len(h_grid))]
    tr = as_transmission(transmission)
    rows = run_tasks(gain_cell, [{"H": float(H_grid[a]), "h": float(h_grid[b])} for a, b in idx],
                     common={"drive": drive, "weights": weights, "order": order, "tr": tr,
                             "period": period},
                     workers=None if scheduler else n_jobs, scheduler=scheduler,
                     progress=progress, desc="lqr_gs gain table")
    g = np.empty((len(H_grid), len(h_grid), 3 if tr is None else 5))
    for (a, b), row in zip(idx, rows, strict=True):
        g[a, b] = row
    return GainTable(H_grid, h_grid, g)


def pack_table(p: np.ndarray, table: GainTable, ulim: float,
                tr: Transmission | None = None) -> None:
    nH, nV = len(table.H), len(table.h)
    ng = table.gains.shape[-1]
    cells = LQ_MAXCELLS if ng == 3 else LQ_MAXCELLS_EL
    if nH * nV > cells:
        raise ManipcadError(f"gain table {nH}×{nV} too large for the compiled regulator "
                            f"(at most {cells} grid points)")
    for ax, name in ((table.H, "H_ii"), (table.h, "h_i")):
        if len(ax) > 1 and not np.allclose(np.diff(ax), ax[1] - ax[0], rtol=1e-9,
                                           atol=1e-12 * np.abs(ax).max()):
            raise ManipcadError(f"the {name} grid must be uniform")
    p[LQ_NH], p[LQ_NV] = nH, nV
    p[LQ_H0] = table.H[0]
    p[LQ_DH] = table.H[1] - table.H[0] if nH > 1 else 1.0
    p[LQ_V0] = table.h[0]
    p[LQ_DV] = table.h[1] - table.h[0] if nV > 1 else 1.0
    p[LQ_ULIM] = ulim
    p[LQ_NG] = ng
    p[LQ_KS] = tr.stiffness if tr is not None else 0.0
    for k in range(ng):
        p[LQ_TAB + k * nH * nV: LQ_TAB + (k + 1) * nH * nV] = table.gains[:, :, k].ravel()


def _check_order(d: Drive, order: int) -> None:
    if order not in (2, 3):
        raise ManipcadError(f"order must be 2 or 3, got {order}")
    if order == 3 and not (math.isfinite(d.L) and d.L > 0):
        raise ManipcadError("lqr of order 3 needs the armature inductance L > 0; use order=2")


def synthesize_lqr(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                   load_range=None, H_nominal: float | None = None,
                   order: int = 3, feedforward: bool = True,
                   transmission=None) -> Regulator:
    """One LQR gain at the nominal load (default the middle of the H_ii range).

    Args:
        robot, joint: the joint.
        spec: Bryson weights ``{"e_max": rad (0.01), "ed_max": rad/s (0.3),
            "i_max": A (the motor's peak current, at most 10× its rated current:
            :func:`~manipcad.control.regulator.current_limit`; larger is refused),
            "u_max": V (u_max/k_u; larger is refused)}``.
        period: control period, s.
        load_range: (H_min, H_max), kg·m².
        H_nominal: the design load, kg·m².
        order: 3 (with the current) or 2.
        feedforward: the reference feed-forward U_ff at the nominal load.
        transmission: the joint's elastic transmission (:class:`Transmission`, k_s or
            (k_s, d_s); with backlash, designed in contact): the LQR of the elastic model,
            which also feeds back the motor angle and speed errors against
            θ_m* = i_r·(q* + τ*/k_s), ω_m* = i_r·q̇*.
    """
    period = check_period(period)
    j, d = joint_drive(robot, joint)
    _check_order(d, order)
    Hmin, Hmax = inertia_range(robot, j, load_range)
    H = 0.5 * (Hmin + Hmax) if H_nominal is None else float(H_nominal)
    if not (math.isfinite(H) and H >= 0):
        raise ManipcadError(f"H_nominal must be >= 0 kg·m², got {H}")
    w = weights_from_spec(spec, d)
    tr = _transmission(transmission)
    table = gain_table(d, [H], [0.0], w, order, transmission=tr, period=period)
    g = table.gains[0, 0]
    p = packed(d, order)
    ulim = u_limit(d)
    pack_table(p, table, ulim, tr)
    p[LQ_FF], p[LQ_W], p[LQ_ADAPT], p[LQ_HFIX] = float(feedforward), 0.0, 0.0, H
    poles = closed_loop_poles(d, H, 0.0, g, order, tr)
    name = robot.joint_names[j]
    kf = (g[2] + d.R / d.k_u) / (d.k_m * d.ratio)
    ff = (f" + {kf * (H + d.reflected_inertia):.6g}·q̈* + "
          f"{kf * d.k_v * d.ratio ** 2 + back_emf_feedforward(d):.6g}·q̇*") if feedforward else ""
    el = (f" + {g[3]:.6g}·(θ_m* − θ_m) + {g[4]:.6g}·(ω_m* − ω_m)" if tr is not None else "")
    on = (f"elastic model k_s = {tr.stiffness:g} N·m/rad, d_s = {tr.damping:g} N·m·s/rad, "
          if tr is not None else "")
    law = (f"lqr ({name}): U = {g[0]:.6g}·e + {g[1]:.6g}·ė − {g[2]:.6g}·i{el}{ff} "
           f"(discrete-time LQR at T = {period:g} s, {on}at "
           f"H_ii = {H:.4g} kg·m², h_i = 0; Bryson e_max = {w.e_max:g} rad, "
           f"ė_max = {w.ed_max:g} rad/s, "
           f"i_max = {w.i_max:g} A, U_max = {w.u_max:g} V); |U| <= {ulim:g} V, T = {period:g} s")
    needs = (["q", "q_dot", "q_ref", "q_dot_ref"] + (["i"] if order == 3 else [])
             + (["theta_m", "omega_m"] if tr is not None else [])
             + (["q_ddot_ref"] if feedforward else []))
    lin = _linearize(d, H, 0.0, order, tr)
    K = _state_gains(g, order, tr is not None)
    ref = np.zeros(lin.A.shape[0])
    ref[0] = 1.0
    if tr is not None:
        ref[2] = d.ratio
    return Regulator(
        method="lqr", joints=(j,), period=period, params=p, needs=tuple(needs), law=law,
        design={"gains": g, "H_nominal": H, "load_range": (Hmin, Hmax), "weights": w,
                "closed_loop_poles": [complex(z) for z in poles], "table": table,
                "transmission": tr},
        linear={"plant": lin.ss,
                "closed_loop": ct.ss(lin.A - lin.B @ K, lin.B * float((K @ ref)[0]),
                                     np.eye(lin.A.shape[0])[:1], 0)})


def _transmission(transmission) -> Transmission | None:
    try:
        return as_transmission(transmission)
    except (ModelError, TypeError, ValueError) as exc:
        raise ManipcadError(f"lqr transmission: {exc}") from exc


def synthesize_lqr_gs(robot: Robot, joint, *, spec=None, period: float = DEFAULT_PERIOD,
                      load_range=None, h_range=None, grid=None, order: int = 3,
                      progress: bool = False, n_jobs: int = 1, scheduler: str | None = None,
                      feedforward: bool = True,
                      load_torque: bool = True, transmission=None) -> Regulator:
    """LQR gains scheduled on the load from a table computed ahead.

    Args:
        robot, joint: the joint.
        spec: Bryson weights, as :func:`synthesize_lqr`.
        period: control period, s.
        load_range: (H_min, H_max), kg·m² (the H_ii axis).
        h_range: (h_min, h_max) of h_i = Ḣ_ii, N·m·s/rad (default: no h axis, h_i = 0).
        grid: (nH, nV) grid points (default (8, 1), or (8, 7) with an h_range);
            at most 74 points in all (the compiled table's room).
        order: 3 or 2.
        progress: show a progress bar while the table is computed.
        n_jobs: worker processes of a local Dask cluster for the grid (1: none); or
        scheduler: a running Dask scheduler's address (:mod:`manipcad.parallel`).
        feedforward: the reference feed-forward U_ff at the current load.
        load_torque: compensate the measured velocity torque and gravity τ_w in U_ff.
        transmission: the joint's elastic transmission, as :func:`synthesize_lqr`: the table
            holds the elastic model's gains (D_e, D_v, D_i, D_θ, D_ω; at most 44 points).
    """
    period = check_period(period)
    j, d = joint_drive(robot, joint)
    _check_order(d, order)
    Hmin, Hmax = inertia_range(robot, j, load_range)
    if h_range is None:
        hl, hh = 0.0, 0.0
    else:
        try:
            hl, hh = (float(v) for v in h_range)
        except (TypeError, ValueError) as exc:
            raise ManipcadError(f"h_range must be a pair (h_min, h_max), got {h_range!r}") from exc
        if not (math.isfinite(hl) and math.isfinite(hh) and hl <= hh):
            raise ManipcadError(f"h_range must satisfy h_min <= h_max, got {h_range!r}")
    if Hmax - Hmin <= 1e-9 * max(abs(Hmax), 1e-300):
        Hmin = Hmax = 0.5 * (Hmin + Hmax)  # the load does not vary: one grid point
        if grid is None:
            grid = (1, 1 if hl == hh else 7)
    if grid is None:
        grid = (8, 1 if hl == hh else 7)
    nH, nV = (int(v) for v in grid)
    if nH < 1 or nV < 1 or (Hmin < Hmax and nH < 2) or (hl < hh and nV < 2):
        raise ManipcadError(f"grid {grid} must have >= 2 points along each axis with a range")
    tr = _transmission(transmission)
    cells = LQ_MAXCELLS if tr is None else LQ_MAXCELLS_EL
    if nH * nV > cells:
        raise ManipcadError(f"grid {nH}×{nV} too large: at most {cells} points")
    # the gear's losses in the load model: the law looks its gains up at f·H_ii, f·h_i
    # (f = 1/η motoring, η braking), so the table spans [η·H_min, H_max/η] (the elastic
    # plant models no gear losses; without the feed-forward the law has no load model)
    eta = law_efficiency(d) if (tr is None and feedforward) else 1.0
    H_grid = np.linspace(eta * Hmin, Hmax / eta, nH) if Hmin < Hmax else np.array([Hmin])
    h_grid = (np.linspace(min(eta * hl, hl / eta), max(eta * hh, hh / eta), nV) if hl < hh
              else np.array([hl]))
    w = weights_from_spec(spec, d)
    table = gain_table(d, H_grid, h_grid, w, order, progress=progress, n_jobs=n_jobs,
                       scheduler=scheduler,
                       transmission=tr, period=period)
    p = packed(d, order)
    ulim = u_limit(d)
    pack_table(p, table, ulim, tr)
    p[LQ_FF], p[LQ_W], p[LQ_ADAPT] = float(feedforward), float(feedforward and load_torque), 1.0
    p[LQ_ETA] = eta
    name = robot.joint_names[j]
    g = table.gains
    ffw = ""
    if feedforward:
        ffw = (" + (D_i + R/k_u)·(f·(H_ii·q̈*" + (" + c_i + Q_i" if load_torque else "")
               + ") + J·i_r²·q̈* + k_v·i_r²·q̇*)/(k_m·i_r) + k_w·i_r·q̇*/k_u")
    el = ""
    if tr is not None:
        el = (f" + D_θ·(θ_m* − θ_m) + D_ω·(ω_m* − ω_m) [elastic model k_s = {tr.stiffness:g} "
              f"N·m/rad, d_s = {tr.damping:g} N·m·s/rad; D_θ in [{g[..., 3].min():.4g}, "
              f"{g[..., 3].max():.4g}] V/rad, D_ω in [{g[..., 4].min():.4g}, "
              f"{g[..., 4].max():.4g}] V·s/rad]")
    law = (f"lqr_gs ({name}): U = D_e·e + D_v·ė − D_i·i{el}{ffw}, gains bilinear in a "
           f"{len(H_grid)}×"
           f"{len(h_grid)} table over H_ii in [{H_grid[0]:.4g}, {H_grid[-1]:.4g}] kg·m², "
           f"h_i = Ḣ_ii in [{h_grid[0]:.4g}, {h_grid[-1]:.4g}] N·m·s/rad (clamped at the "
           f"edges), looked up at f·H_ii, f·h_i; f = 1/η motoring or holding, η braking, "
           f"η = {eta:g} (the gear factor also on the load in U_ff); D_e in "
           f"[{g[..., 0].min():.4g}, {g[..., 0].max():.4g}] V/rad, D_v in "
           f"[{g[..., 1].min():.4g}, {g[..., 1].max():.4g}] V·s/rad, D_i in "
           f"[{g[..., 2].min():.4g}, {g[..., 2].max():.4g}] V/A (discrete-time LQR at the "
           f"period, Bryson e_max = "
           f"{w.e_max:g} rad, ė_max = {w.ed_max:g} rad/s, i_max = {w.i_max:g} A, "
           f"U_max = {w.u_max:g} V); |U| <= {ulim:g} V, T = {period:g} s")
    needs = ["q", "q_dot", "q_ref", "q_dot_ref", "H_ii"] + (["i"] if order == 3 else [])
    if tr is not None:
        needs += ["theta_m", "omega_m"]
    if feedforward:
        needs.append("q_ddot_ref")
        if load_torque:
            needs += ["c_i", "Q_i"]
    return Regulator(
        method="lqr_gs", joints=(j,), period=period, params=p, needs=tuple(needs), law=law,
        design={"table": table, "load_range": (Hmin, Hmax), "h_range": (hl, hh),
                "weights": w, "transmission": tr, "gear_efficiency": eta})


def gain_table_to_file(p: np.ndarray) -> dict[str, Any]:
    """The gain table of a parameter vector as its regulator-file mapping: the H_ii and
    h grids (kg·m², N·m·s/rad) and one rows-over-H_ii matrix per gain."""
    nH, nV, ng = int(p[LQ_NH]), int(p[LQ_NV]), int(p[LQ_NG])
    out: dict[str, Any] = {
        "H_ii_grid_kgm2": [float(p[LQ_H0] + a * p[LQ_DH]) if a else float(p[LQ_H0])
                           for a in range(nH)],
        "H_ii_step_kgm2": float(p[LQ_DH]),
        "h_grid_Nms_per_rad": [float(p[LQ_V0] + b * p[LQ_DV]) if b else float(p[LQ_V0])
                               for b in range(nV)],
        "h_step_Nms_per_rad": float(p[LQ_DV]),
    }
    for k in range(ng):
        vals = p[LQ_TAB + k * nH * nV: LQ_TAB + (k + 1) * nH * nV].reshape(nH, nV)
        out[GAIN_NAMES[k]] = [[float(v) for v in row] for row in vals]
    return out


def gain_table_from_file(t: Any, p: np.ndarray, robot: Robot, j: int, source: str,
                         where: str) -> None:
    """Check a regulator file's gain table and write it into the parameter vector p.

    One :class:`~manipcad.errors.InputError` naming ``source``, the dotted field
    (``where`` ...) and why: missing, non-increasing or non-uniform grids, the wrong
    gains or shapes, too many cells, or an H_ii range that does not cover joint j's.
    """
    if not isinstance(t, dict):
        raise InputError(source, where, "missing: the gain table (H_ii_grid_kgm2, "
                         "h_grid_Nms_per_rad, D_e_V_per_rad, ...)")
    axes = {}
    for key in ("H_ii_grid_kgm2", "h_grid_Nms_per_rad"):
        ax = t.get(key)
        if not isinstance(ax, list) or not ax:
            raise InputError(source, f"{where}.{key}", "missing or empty: a list of numbers")
        axes[key] = np.array([file_number(source, f"{where}.{key}[{k}]", v)
                              for k, v in enumerate(ax)])
        a = axes[key]
        if len(a) > 1 and not np.all(np.diff(a) > 0):
            raise InputError(source, f"{where}.{key}", "must be strictly increasing")
    steps = {}
    for key, ax in (("H_ii_step_kgm2", "H_ii_grid_kgm2"), ("h_step_Nms_per_rad",
                                                          "h_grid_Nms_per_rad")):
        a = axes[ax]
        st = file_number(source, f"{where}.{key}", t.get(key, a[1] - a[0] if len(a) > 1 else 1.0),
                  positive=True)
        if len(a) > 1 and not np.allclose(np.diff(a), st, rtol=1e-9,
                                          atol=1e-12 * np.abs(a).max()):
            raise InputError(source, f"{where}.{ax}", f"must be uniform with step {st:g}")
        steps[key] = st
    H, h = axes["H_ii_grid_kgm2"], axes["h_grid_Nms_per_rad"]
    nH, nV = len(H), len(h)
    present = [k for k in GAIN_NAMES if k in t]
    ng = len(present)
    if present != list(GAIN_NAMES[:3]) and present != list(GAIN_NAMES):
        raise InputError(source, where, f"expected the gains {', '.join(GAIN_NAMES[:3])} "
                         f"(and {', '.join(GAIN_NAMES[3:])} on the elastic model)")
    unknown = sorted(set(t) - set(GAIN_NAMES) - set(axes) - set(steps))
    if unknown:
        raise InputError(source, f"{where}.{unknown[0]}", "unknown field")
    if nH * nV > (LQ_MAXCELLS if ng == 3 else LQ_MAXCELLS_EL):
        raise InputError(source, where, f"{nH}×{nV} grid points: too many for the compiled "
                         "table")
    p[LQ_NH], p[LQ_NV], p[LQ_NG] = nH, nV, ng
    p[LQ_H0], p[LQ_DH] = H[0], steps["H_ii_step_kgm2"]
    p[LQ_V0], p[LQ_DV] = h[0], steps["h_step_Nms_per_rad"]
    for k, key in enumerate(present):
        rows = t[key]
        if not isinstance(rows, list) or len(rows) != nH or any(
                not isinstance(r, list) or len(r) != nV for r in rows):
            raise InputError(source, f"{where}.{key}", f"expected {nH} rows of {nV} numbers "
                             "(one row per H_ii grid point)")
        vals = [file_number(source, f"{where}.{key}[{a}][{b}]", v)
                for a, r in enumerate(rows) for b, v in enumerate(r)]
        p[LQ_TAB + k * nH * nV: LQ_TAB + (k + 1) * nH * nV] = vals
    lo, hi = inertia_range(robot, j)
    tol = 1e-6 * max(hi, 1e-12)
    if nH > 1 and (H[0] > lo + tol or H[-1] < hi - tol):
        raise InputError(source, f"{where}.H_ii_grid_kgm2",
                         f"the table covers H_ii in [{H[0]:.6g}, {H[-1]:.6g}] kg·m², but "
                         f"joint {robot.joint_names[j]!r} of {robot.name!r} spans "
                         f"[{lo:.6g}, {hi:.6g}]; re-synthesize for this robot")


def gain_table_entries(p: np.ndarray) -> range:
    """The parameter indices the gain table of p occupies (all stored, read or not)."""
    return range(LQ_TAB, LQ_TAB + int(p[LQ_NH] * p[LQ_NV] * p[LQ_NG]))


def export_lqr(reg: Regulator):
    """``lqr`` in python-control: a static gain (:func:`static_gain`, the clip left out)
    while its gains are fixed and its feed-forward at the design load, the law then linear
    in its signals (q, q̇, i, q*, q̇*, q̈*, ... ); with the feed-forward at the current
    load (``feedforward_at_current_load``) a discrete-time nonlinear I/O system.

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> sys_ = export_lqr(manipcad.synthesize(arm, "turn", "lqr", period=1e-3))
        >>> sys_.nstates, sys_.input_labels
        (0, ['q_ref', 'q_dot_ref', 'q_ddot_ref', 'q', 'q_dot', 'i'])
    """
    p = reg.params
    fixed = int(p[LQ_NH]) == 1 and int(p[LQ_NV]) == 1 and p[LQ_ADAPT] == 0.0
    gain_sys = static_gain(reg, lqr_update, LQ_ULIM) if fixed else None
    return nonlinear_system(reg, lqr_update) if gain_sys is None else gain_sys


#: the LQR gain table's place in the regulator file and in the parameters
GAIN_TABLE = TableLayout(to_file=gain_table_to_file, from_file=gain_table_from_file,
                         entries=gain_table_entries)


LQR = Method(
    name="lqr", synthesize=synthesize_lqr, update=lqr_update, section="3.3 (7), fixed",
    summary="LQR gains at the nominal load (no scheduling), with feed-forward",
    fields=FIELDS, table=GAIN_TABLE, export=export_lqr,
    linear=True)

LQR_GS = Method(
    name="lqr_gs", synthesize=synthesize_lqr_gs, update=lqr_update, section="3.3 (6)-(7)",
    summary="LQR gains scheduled on H_ii (and Ḣ_ii) from a table computed ahead",
    fields=FIELDS_GS, table=GAIN_TABLE,
    linear=True, optional_fields=GEAR_EFFICIENCY_OPTIONAL)
