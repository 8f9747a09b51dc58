"""The online payload estimator as a component of the closed loop (paper 4.1, conclusion).

A regulator reads signals and gives the amplifier inputs U; this component reads
signals and gives the *payload mass* the regulators' model assumes. Declared like a
regulator (what it reads, what it gives, its period), it runs inside the simulator at
its own period, through the same sampling step as the regulators
(:func:`manipcad.sim.loop.sample_due`):

- **needs** ``q``, ``q_dot`` and ``i`` (the armature currents: what a drive measures);
- **gives** ``payload_mass`` m̂ (kg): with ``simulate(..., model_payload="online")`` the
  model the moment constituents are computed from carries m̂ at the payload's centre
  of mass, so every regulator that reads ``H_ii``, ``c_i``, ``Q_i`` or ``H`` (the
  adaptive methods ``ace_tf``, ``ace_de``, ``asvs``, ``lqr_gs``: their H*, h*, the
  measured load torque, the gain-table lookup) reads the estimated payload instead of
  the nominal one. No regulator changes; none is named.

Per period T (sample s, time s·T):

1. the joint torques from the currents, τ_j = i_r·k_m·(i_j + ν_j)
   (:func:`manipcad.drives.dc.rigid_joint_torque`; ν: an optional simulated current
   noise, A); through a gear of efficiency η < 1 (window mean below) the part that
   reaches the gear's input passes only η of it (1/η braking), as the simulated plant
   and the sizing take it (:func:`manipcad.dynamics.gear.gear_factor`);
2. the mean acceleration over the two periods about the previous sample,
   q̈_{s−1} = (q̇_s − q̇_{s−2})/(2T) (no accelerometer; exact for that mean), and the
   joint torques averaged over the same window by the trapezoid rule,
   τ̄_{s−1} = (τ_{s−2} + 2·τ_{s−1} + τ_s)/4 (the current is smooth between samples and
   kinks at them, where U steps: a switching regulator's ripple would otherwise bias the
   estimate, since the instantaneous current and the mean acceleration disagree);
3. one step of recursive least squares with forgetting on that window (q, q̇ at s−1)
   (:func:`manipcad.dynamics.rls.payload_rls_step`: y = τ − τ_0(q, q̇, q̈) =
   m·g(q, q̇, q̈), two inverse-dynamics passes and 4k + 2 multiplications);
4. with ``feed``: the model's payload link rewritten as the nominal link plus a point
   mass max(m̂, 0) at the payload's centre (:func:`manipcad.model.robot.combine_bodies`).

So the estimate lags the measurement by one period, and the regulators read it at the
next sample (the estimator runs after them): two periods in all.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba as nb
import numpy as np

from manipcad.control.signals import S_I, S_Q, S_QD
from manipcad.drives.dc import dry_friction, rigid_joint_torque
from manipcad.drives.params import P_J, P_KV, P_RATIO, pack_drives
from manipcad.dynamics.counts import Counted, _counted, _plain, _Tally
from manipcad.dynamics.gear import gear_factor
from manipcad.dynamics.identification import link_frame
from manipcad.dynamics.rls import OnlinePayloadEstimator, payload_rls_step, rls_operation_counts
from manipcad.dynamics.rnea import RNEA_WORK
from manipcad.errors import ManipcadError
from manipcad.model.robot import COL_COM, COL_IC, COL_MASS, Robot, combine_bodies

#: the compiled component (numba-typed): see :func:`PayloadEstimator.pack`. ``on``: the
#: component runs; ``steps``: its period in integration steps; ``feed``: the model's payload
#: link follows the estimate; ``state``: the RLS state [m̂ kg, S, periods]; ``aux``:
#: [samples taken, 1 + the step last sampled (0: none)]; ``hist`` (5, n): q, q̇, τ of
#: the previous sample, q̇ and τ of the one before; ``log`` (M,): m̂ after each sample,
#: kg; ``noise`` (M, n): current noise, A
#: ``eta`` (n,): the gears' efficiency (1: none or unknown)
Estimator = namedtuple(
    "Estimator", "on steps feed state aux hist log noise dtable table0 table_unit gravity "
                 "sel w vmin lam info_min drives body cp base scratch eta")

#: what the component reads and what it gives
NEEDS = ("q", "q_dot", "i")
GIVES = ("payload_mass",)


@nb.njit(cache=True)
def payload_row(ctable, body, base, m, cp):
    """Write row ``body`` of the model table: the nominal link ``base`` plus a point mass
    m kg at cp (m, the body frame)."""
    Ic = np.empty((3, 3))
    for a in range(3):
        for b in range(3):
            Ic[a, b] = base[COL_IC + 3 * a + b]
    M, c, I = combine_bodies(base[COL_MASS], base[COL_COM:COL_COM + 3].copy(), Ic, m, cp,
                             np.zeros((3, 3)))
    ctable[body, COL_MASS] = M
    for a in range(3):
        ctable[body, COL_COM + a] = c[a]
        for b in range(3):
            ctable[body, COL_IC + 3 * a + b] = I[a, b]


@nb.njit(cache=True)
def estimator_update(est, sig, ctable, Ts):
    """One period of the component at sample s = ``est.aux[0]``: returns m̂, kg.

    Reads q, q̇, i of every joint from the signal matrix (columns of
    :mod:`manipcad.control.signals`), updates the RLS on the previous sample (see the
    module), logs m̂, and with ``est.feed`` rewrites the payload link of ``ctable``.
    """
    s = est.aux[0]
    n = sig.shape[0]
    h = est.hist
    zero_fext, work, tau0, gunit, y, gs, ws, qdd, tau = est.scratch
    for j in range(n):
        i = sig[j, S_I]
        if s < est.noise.shape[0]:
            i += est.noise[s, j]
        tau[j] = rigid_joint_torque(i, est.dtable[j])
    if s >= 2:
        for j in range(n):
            qdd[j] = (sig[j, S_QD] - h[3, j]) / (2.0 * Ts)
            h[4, j] = 0.25 * (h[4, j] + 2.0 * h[2, j] + tau[j])  # τ̄ of the window
            if est.eta[j] < 1.0:
                h[4, j] = _through_gear(h[4, j], qdd[j], h[1, j], est.eta[j], est.dtable[j])
        payload_rls_step(est.state, est.table0, est.table_unit, est.gravity, h[0], h[1], qdd,
                         h[4], est.sel, est.w, est.vmin, est.lam, est.info_min, est.drives,
                         zero_fext, work, tau0, gunit, y, gs, ws)
    for j in range(n):
        h[4, j] = h[2, j]
        h[3, j] = h[1, j]
        h[0, j] = sig[j, S_Q]
        h[1, j] = sig[j, S_QD]
        h[2, j] = tau[j]
    m = est.state[0]
    if s < est.log.shape[0]:
        est.log[s] = m
    est.aux[0] = s + 1
    if est.feed:
        payload_row(ctable, est.body, est.base, max(m, 0.0), est.cp)
    return m


@nb.njit(cache=True)
def _through_gear(tau, qdd, qd, eta, p):
    """The drive torque τ (N·m, N; i_r·k_m·i) as the lossless drive model the estimate
    fits would need it: the gear passes only g·T of the torque T that reaches its input
    (τ less the rotor's inertia and the motor's friction, D), g = 1/f with the plant's and
    the sizing's factor f (:func:`manipcad.dynamics.gear.gear_factor`); so D + g·T."""
    r = p[P_RATIO]
    D = p[P_J] * r * r * qdd + p[P_KV] * r * r * qd + r * dry_friction(r * qd, p)
    T = tau - D
    return D + T / gear_factor(eta, T, qd)


def no_estimator() -> Estimator:
    """The component of a run without an estimator: ``on`` false, every array empty.

    Its numba type is that of :meth:`PayloadEstimator.pack`'s (the same field types:
    empty arrays of the same dtypes and dimensions), so the simulator's core compiles
    ONE specialization per integrator, with or without an estimator (two before: the
    estimator's variant cost 17-53 s of compile on a cold cache). The core tests
    ``on`` first and reads nothing else of it.
    """
    f1 = np.zeros(0)
    f2 = np.zeros((0, 0))
    return Estimator(
        False, 1, False, f1, np.zeros(0, dtype=np.int64), f2, f1, f2, f2, f2, f2, f1,
        np.zeros(0, dtype=np.int64), f1, f1, 1.0, 0.0, False, 0, f1, f1, _scratch(0, 0), f1)


def _own(a) -> np.ndarray:
    """A writable contiguous copy (read-only arrays would compile the loop a second time)."""
    return np.array(a, order="C", copy=True)


def _scratch(n: int, k: int):
    return (np.zeros((n, 6)), np.empty((n, RNEA_WORK)), np.empty(n),
            np.empty(n), np.empty(k), np.empty(k), np.empty(k), np.zeros(n), np.zeros(n))


class PayloadEstimator:
    """The online payload estimator, a closed-loop component (``simulate(estimator=...)``).

    Args:
        robot: the robot as the regulators' model knows it (without the unknown payload).
        period: its sampling period, s (a multiple of the simulation's dt).
        com: the payload's centre of mass in the frame of ``link``, m (the grasp point:
            known; the mass is not).
        link: as :class:`~manipcad.dynamics.rls.OnlinePayloadEstimator` (default the last).
        forgetting: λ in (0, 1]; memory 1/(1 − λ) periods.
        joints: drives used (indices or names; default all with a drive).
        weights: per drive used, 1/σ_j² ((N·m)⁻² or N⁻²); default 1.
        prior_mass: the starting estimate, kg; prior_info: its information (0: none).
        info_min: floor of the information S (no wind-up while nothing excites the payload).
        min_speed: a drive slower than this is left out of that period (rad/s or m/s;
            default by joint type where the drive has dry friction).
        current_noise: standard deviation of a simulated noise on the measured currents
            the estimator reads, A (0: none; the regulators read the currents noise-free).
        seed: the noise's random seed.

    Attributes:
        needs, gives: the signals read (``q``, ``q_dot``, ``i``) and given (``payload_mass``).

    Example:
        >>> import manipcad
        >>> est = PayloadEstimator(manipcad.load_robot("cylindrical"), period=1e-3)
        >>> est.needs, est.gives
        (('q', 'q_dot', 'i'), ('payload_mass',))
        >>> est.realization_complexity()["mul"] > 0
        True
    """

    needs = NEEDS
    gives = GIVES

    def __init__(self, robot: Robot, *, period: float = 1e-3, com=None, link: int | str = -1,
                 forgetting: float = 0.999, joints=None, weights=None,
                 prior_mass: float = 0.0, prior_info: float = 0.0, info_min: float = 0.0,
                 min_speed=None, current_noise: float = 0.0, seed: int = 0) -> None:
        if not isinstance(robot, Robot):
            raise ManipcadError(f"PayloadEstimator: robot must be a manipcad Robot, got "
                                f"{type(robot).__name__}")
        if not robot.has_drives:
            raise ManipcadError(f"PayloadEstimator: robot {robot.name!r} has no drives: the "
                                "estimator reads the armature currents")
        if joints is None:
            joints = [j for j in range(robot.n) if robot.drives[j] is not None]
        try:
            period = float(period)
        except (TypeError, ValueError):
            raise ManipcadError(f"PayloadEstimator: period must be a number of s, got "
                                f"{period!r}") from None
        if not (period > 0 and math.isfinite(period)):
            raise ManipcadError(f"PayloadEstimator: period must be > 0 s, got {period}")
        if not (math.isfinite(float(current_noise)) and float(current_noise) >= 0):
            raise ManipcadError(f"PayloadEstimator: current_noise must be >= 0 A, got "
                                f"{current_noise!r}")
        self.core = OnlinePayloadEstimator(
            robot, com=com, link=link, forgetting=forgetting, joints=joints, weights=weights,
            prior_mass=prior_mass, prior_info=prior_info, info_min=info_min, drives=True,
            min_speed=min_speed)
        for j in self.core.sel:
            d = robot.drives[j]
            if d is None or not (math.isfinite(d.k_m) and d.k_m > 0):
                raise ManipcadError(f"PayloadEstimator: joint {robot.joint_names[j]!r} has no "
                                    "drive with a torque constant k_m: its current gives no "
                                    "torque")
        self.robot = robot
        self.period = period
        self.current_noise = float(current_noise)
        self.seed = int(seed)
        self.com = np.zeros(3) if com is None else np.asarray(com, dtype=float).reshape(3)
        self.link = link

    @property
    def body(self) -> int:
        """The body (joint index) that carries the payload."""

        return link_frame(self.robot, self.link)[0]

    @property
    def com_in_body(self) -> np.ndarray:
        """The payload's centre of mass in the body frame of :attr:`body`, m."""

        _, R, p, _ = link_frame(self.robot, self.link)
        return R @ self.com + p

    def describe(self) -> str:
        """What the component does, with its numbers."""
        c = self.core
        names = ", ".join(self.robot.joint_names[j] for j in c.sel)
        return (f"online payload estimator: RLS with forgetting λ = {c.lam:g} (memory "
                f"{'∞' if c.lam == 1 else f'{1 / (1 - c.lam):.4g}'} periods), period "
                f"{self.period:g} s, drives {names}; reads q, q̇, i; gives the payload mass "
                f"at {np.round(self.com_in_body, 6).tolist()} m in body "
                f"{self.robot.joint_names[self.body]!r}")

    def pack(self, dt: float, samples: int, ctable: np.ndarray, *, feed: bool) -> Estimator:
        """The compiled component for a run at step ``dt`` s with ``samples`` samples; the
        model table ``ctable`` (n, TABLE_COLS) is the one ``feed`` rewrites."""
        s = self.period / dt
        if abs(s - round(s)) > 1e-6 * s or round(s) < 1:
            raise ManipcadError(f"estimator period {self.period:g} s is not a multiple of "
                                f"dt = {dt:g} s")
        n = self.robot.n
        c = self.core
        rng = np.random.default_rng(self.seed)
        noise = (rng.normal(0.0, self.current_noise, (samples, n)) if self.current_noise > 0
                 else np.zeros((0, n)))
        dtable = pack_drives(self.robot.drives)
        body = self.body
        return Estimator(
            True, int(round(s)), bool(feed), c.state.copy(), np.zeros(2, dtype=np.int64),
            np.zeros((5, n)), np.full(samples, np.nan), noise, dtable, _own(c.table0),
            _own(c.table_unit), _own(c.gravity), _own(c.sel), _own(c.w), _own(c.vmin),
            float(c.lam), float(c.info_min), bool(c.drives),
            int(body), np.ascontiguousarray(self.com_in_body),
            np.ascontiguousarray(ctable[body], dtype=float).copy(), _scratch(n, c.sel.size),
            np.array([1.0 if d is None or math.isnan(d.efficiency) else float(d.efficiency)
                      for d in self.robot.drives]))

    def realization_complexity(self) -> dict:
        """Operations per period, counted by running :func:`estimator_update`'s own source
        on counting numbers (as :meth:`~manipcad.control.regulator.Regulator.
        realization_complexity`): ``{"mul", "add", "func", "ops_per_period", "rls": {mul,
        add}, "signals", "period"}``. The two inverse-dynamics passes are in the totals;
        ``rls`` is the recursive least squares alone (4k + 2 mul)."""

        n = self.robot.n
        est = self.pack(self.period, 4, np.asarray(self.robot.table), feed=False)
        rng = np.random.default_rng(3)
        fields = est._asdict()
        for key in ("state", "hist", "table0", "table_unit", "gravity", "w", "vmin", "dtable"):
            fields[key] = _counted(np.asarray(fields[key], dtype=float))
        fields["hist"] = _counted(rng.uniform(0.2, 1.0, (5, n)))
        fields["state"] = _counted([0.3, 5.0, 10.0])
        fields["lam"] = Counted(est.lam)
        fields["info_min"] = Counted(est.info_min)
        fields["aux"] = np.array([5, 0])
        fields["log"] = np.empty(8, dtype=object)
        fields["scratch"] = tuple(np.empty(a.shape, dtype=object) for a in est.scratch)
        fields["scratch"][0][:] = Counted(0.0)
        sig = _counted(rng.uniform(0.2, 1.0, (n, 12)))
        Counted.tally = _Tally()
        _plain(estimator_update)(Estimator(**fields), sig, None, Counted(self.period))
        t = Counted.tally
        # the sample counter is bookkeeping, not arithmetic on the data
        mul, add = t.mul, t.add - 1
        return {"mul": mul, "add": add, "func": t.func, "ops_per_period": mul + add + t.func,
                "rls": rls_operation_counts(int(self.core.sel.size)),
                "signals": list(NEEDS), "gives": list(GIVES), "period": self.period}


__all__ = ["PayloadEstimator", "Estimator", "estimator_update", "no_estimator", "payload_row",
           "NEEDS", "GIVES"]
