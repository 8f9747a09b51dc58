"""Online payload identification: recursive least squares with forgetting, compiled.

At every regulator period the drives give one equation each (see
:mod:`manipcad.dynamics.identification`):

    y_j = tau_j - tau_0,j(q, q̇, q̈) = m_r · g_j(q, q̇, q̈) + e_j

(tau_0: the unloaded robot's inverse dynamics with its drive terms; g: the
torque 1 kg at the payload's com needs). The estimate after period t minimises
the exponentially forgotten weighted sum of squares

    Σ_{s ≤ t} λ^(t-s) Σ_j w_j (y_sj - g_sj·m)²   (+ λ^t · S_0 · (m - m_0)², a prior),

whose recursive form for the one parameter m is (state [m, S]):

    a = Σ_j w_j g_j²,   b = Σ_j w_j g_j (y_j - g_j m)
    S ← λ·S + a,        m ← m + b / S

(S: the information, kg⁻²·(N·m)²·weight; with λ = 1 this is exactly batch
least squares; a period without information, S = 0, leaves m as it is). The
effective memory is 1/(1 - λ) periods. ``info_min`` keeps S from decaying
below a floor while the payload is not excited (no wind-up of the gain).

:func:`rls_update` is the per-period update (state array in, estimate out):
4k + 2 multiplications (divisions counted as multiplications) and 3k + 2
additions for k drives (:func:`rls_operation_counts`, counted by running the
kernel's source). :func:`payload_rls_step` adds the two inverse dynamics passes
(unloaded robot with drives, unit payload) and the k subtractions y = tau - tau_0:
2 × RNEA + (4k + 2) mul + (4k + 2) add per period.
:class:`OnlinePayloadEstimator` wraps it for Python.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np

from manipcad.dynamics.counts import Counted, _counted, _plain, _Tally
from manipcad.dynamics.identification import (
    MOTION_SPEED,
    _unit_payload_robot,
    link_frame,
)
from manipcad.dynamics.rnea import RNEA_WORK, rnea_one
from manipcad.errors import InputError
from manipcad.model.robot import COL_FCN, COL_FCP, Robot

#: the estimator's state array: [m_r (kg), S (information), periods updated]
STATE_SIZE = 3
ST_MASS, ST_INFO, ST_COUNT = 0, 1, 2
SOURCE = "OnlinePayloadEstimator"


@nb.njit(cache=True)
def rls_update(state, y, g, w, lam, info_min):
    """One period of the recursive least squares with forgetting (see the module docstring).

    Args:
        state: (STATE_SIZE,) [m_r kg, S, periods], updated in place.
        y: (k,) tau - tau_0 of the drives used, N·m or N.
        g: (k,) their payload regressor, N·m/kg or N/kg.
        w: (k,) weights (1/σ_j², or 0 to leave a drive out this period).
        lam: forgetting factor λ in (0, 1].
        info_min: floor of S (0: none).

    Returns:
        The estimate m_r, kg.
    """
    m = state[0]
    a = 0.0
    b = 0.0
    for j in range(y.shape[0]):
        wg = w[j] * g[j]
        b += wg * (y[j] - g[j] * m)
        a += wg * g[j]
    S = lam * state[1] + a
    if S < info_min:
        S = info_min
    if S > 0.0:
        m = m + b / S
    state[0] = m
    state[1] = S
    state[2] += 1.0
    return m


@nb.njit(cache=True)
def payload_rls_step(state, table0, table_unit, gravity, q, qd, qdd, tau, sel, w, vmin, lam,
                     info_min, drives, zero_fext, work, tau0, gunit, y, gs, ws):
    """One regulator period of the online payload estimator, from one measured state.

    Args:
        state: (STATE_SIZE,) estimator state, updated in place.
        table0: the unloaded robot's model table; table_unit: the massless robot
            carrying 1 kg at the com (``OnlinePayloadEstimator`` builds both).
        gravity: (3,) m/s².
        q, qd, qdd: (n,) the joint state, rad, rad/s, rad/s² (m, m/s, m/s²).
        tau: (n,) measured drive torques at the joints, N·m or N.
        sel: (k,) indices of the drives used; w: (k,) their weights.
        vmin: (k,) a drive slower than this is left out this period (its dry
            friction's sign is unknown), rad/s or m/s; 0 for none.
        lam, info_min: as in :func:`rls_update`.
        drives: tau includes the drive terms (rotor inertia, friction).
        zero_fext, work, tau0, gunit, y, gs, ws: scratch ((n, 6) zeros,
            (n, RNEA_WORK), (n,), (n,), (k,), (k,), (k,)).

    Returns:
        The estimate m_r, kg.
    """
    rnea_one(table0, gravity, q, qd, qdd, zero_fext, False, drives, work, tau0)
    # no drive terms, by a run-time flag as ``drives`` (one compiled rnea_one for both)
    rnea_one(table_unit, gravity, q, qd, qdd, zero_fext, False, bool(0), work, gunit)
    for i in range(sel.shape[0]):
        j = sel[i]
        y[i] = tau[j] - tau0[j]
        gs[i] = gunit[j]
        ws[i] = w[i] if abs(qd[j]) >= vmin[i] else 0.0
    return rls_update(state, y, gs, ws, lam, info_min)


@nb.njit(cache=True)
def _run(state, table0, table_unit, gravity, Q, QD, QDD, TAU, sel, w, vmin, lam, info_min,
         drives, out):
    n = Q.shape[1]
    k = sel.shape[0]
    zero_fext = np.zeros((n, 6))
    work = np.empty((n, RNEA_WORK))
    tau0 = np.empty(n)
    gunit = np.empty(n)
    y = np.empty(k)
    gs = np.empty(k)
    ws = np.empty(k)
    for t in range(Q.shape[0]):
        out[t] = payload_rls_step(state, table0, table_unit, gravity, Q[t], QD[t], QDD[t],
                                  TAU[t], sel, w, vmin, lam, info_min, drives, zero_fext, work,
                                  tau0, gunit, y, gs, ws)


class OnlinePayloadEstimator:
    """The online payload estimator of one robot: compiled RLS with forgetting.

    Args:
        robot: the unloaded robot (its links and drives).
        com: the payload's centre of mass in the frame of ``link``, m.
        link: joint index or name (its body frame) or link name (its own
            frame), as in :func:`~manipcad.dynamics.identification.identify_payload`.
        forgetting: λ in (0, 1]; memory 1/(1 - λ) periods.
        joints: drives used (indices or names; default all).
        weights: per drive used, 1/σ_j² ((N·m)⁻² or N⁻²); default 1.
        prior_mass: the starting estimate m_0, kg.
        prior_info: S_0, the information of the prior (0: none).
        info_min: the floor of S (0: none).
        drives: the measured torques include the drive terms.
        min_speed: a drive with dry friction slower than this is left out at that
            period; default ``MOTION_SPEED`` by joint type (rad/s, m/s).

    Example:
        >>> import numpy as np, manipcad
        >>> arm = manipcad.load_robot("puma560")
        >>> est = OnlinePayloadEstimator(arm, forgetting=1.0, min_speed=0.0)  # samples at rest
        >>> q = np.random.default_rng(0).uniform(-1, 1, (50, 6))
        >>> z = np.zeros_like(q)
        >>> tau = manipcad.inverse_dynamics(arm.with_payload(1.5), q, z, z)
        >>> round(float(est.run(q, z, z, tau)[-1]), 9)
        1.5
    """

    def __init__(self, robot: Robot, *, com=None, link: int | str = -1,
                 forgetting: float = 0.999, joints=None, weights=None,
                 prior_mass: float = 0.0, prior_info: float = 0.0, info_min: float = 0.0,
                 drives: bool = True, min_speed=None) -> None:
        if not isinstance(robot, Robot):
            raise InputError(SOURCE, "robot", f"expected a manipcad Robot, got "
                             f"{type(robot).__name__}")
        if not (0.0 < float(forgetting) <= 1.0):
            raise InputError(SOURCE, "forgetting", f"must be in (0, 1], got {forgetting!r}")
        for name, v in (("prior_info", prior_info), ("info_min", info_min)):
            if not (math.isfinite(float(v)) and float(v) >= 0):
                raise InputError(SOURCE, name, f"must be a finite number >= 0, got {v!r}")
        if not math.isfinite(float(prior_mass)):
            raise InputError(SOURCE, "prior_mass", f"must be finite, got {prior_mass!r}")
        body, R, p, self.link_name = link_frame(robot, link)
        c = np.zeros(3) if com is None else np.asarray(com, dtype=float).reshape(3)
        self.robot = robot
        self.n = robot.n
        if joints is None:
            sel = list(range(robot.n))
        else:
            items = [joints] if isinstance(joints, str | int) else list(joints)
            try:
                sel = [robot.joint_index(j) for j in items]
            except Exception as exc:  # noqa: BLE001 - named as the argument
                raise InputError(SOURCE, "joints", str(exc)) from None
        self.sel = np.asarray(sel, dtype=np.int64)
        k = self.sel.size
        self.w = np.ones(k) if weights is None else np.broadcast_to(
            np.asarray(weights, dtype=float), (k,)).copy()
        if np.any(self.w < 0) or not np.all(np.isfinite(self.w)):
            raise InputError(SOURCE, "weights", "must be finite numbers >= 0")
        tab = np.asarray(robot.table)
        dry = (tab[:, COL_FCP] > 0) | (tab[:, COL_FCN] > 0)
        if min_speed is None:
            vmin = np.array([MOTION_SPEED[robot.joint_types[j]] if (drives and dry[j]) else 0.0
                             for j in self.sel])
        else:
            vmin = np.broadcast_to(np.asarray(min_speed, dtype=float), (k,)).copy()
        self.vmin = vmin
        self.table0 = np.ascontiguousarray(robot.table)
        self.table_unit = np.ascontiguousarray(_unit_payload_robot(robot, R @ c + p, body).table)
        self.gravity = np.asarray(robot.gravity, dtype=float)
        self.lam = float(forgetting)
        self.info_min = float(info_min)
        self.drives = bool(drives)
        self.state = np.array([float(prior_mass), float(prior_info), 0.0])

    @property
    def mass(self) -> float:
        """The current estimate m_r, kg."""
        return float(self.state[ST_MASS])

    def run(self, q, qd, qdd, tau) -> np.ndarray:
        """Feed N periods' samples (each (N, n), SI units); returns the estimate after each, kg.

        The loop runs compiled; the state carries on to the next call.
        """
        arrays = []
        for name, x in (("q", q), ("qd", qd), ("qdd", qdd), ("tau", tau)):
            a = np.asarray(x, dtype=float)
            a = a.reshape(1, -1) if a.ndim == 1 else a
            if a.ndim != 2 or a.shape[1] != self.n or (arrays and a.shape != arrays[0].shape):
                raise InputError(SOURCE, name, f"expected shape (N, {self.n}) like q, got "
                                 f"{np.shape(x)}")
            if not np.all(np.isfinite(a)):
                raise InputError(SOURCE, name, "values must be finite")
            arrays.append(np.ascontiguousarray(a))
        out = np.empty(arrays[0].shape[0])
        _run(self.state, self.table0, self.table_unit, self.gravity, *arrays, self.sel, self.w,
             self.vmin, self.lam, self.info_min, self.drives, out)
        return out


def rls_operation_counts(k: int) -> dict[str, int]:
    """Multiplications and additions of :func:`rls_update` for k drives, counted by
    running its source on counting numbers (as :mod:`manipcad.dynamics.counts`).

    Example:
        >>> rls_operation_counts(6)
        {'mul': 26, 'add': 20}
    """

    if int(k) < 1:
        raise InputError("rls_operation_counts", "k", f"must be >= 1, got {k}")
    rng = np.random.default_rng(0)
    state = _counted([0.5, 2.0, 0.0])
    y, g, w = (_counted(rng.uniform(0.5, 1.5, int(k))) for _ in range(3))
    Counted.tally = _Tally()
    _plain(rls_update)(state, y, g, w, Counted(0.99), Counted(0.0))
    tally = Counted.tally
    # the period counter state[2] += 1 is bookkeeping, not arithmetic on the data
    return {"mul": tally.mul, "add": tally.add - 1}
