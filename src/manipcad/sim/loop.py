"""The compiled closed-loop integration: multibody + drives + sampled regulators.

State x = [q (n), q̇ (n), drive states (see :mod:`manipcad.drives.coupling`)].
Each fixed step of RK4 holds the regulators' outputs U (zero-order hold); a
regulator is updated when its period in steps has elapsed, through the regulator
registry's compiled dispatch (:func:`manipcad.control.registry.dispatch`): the
loop knows no method by name. Joint torques come from the drives where a joint has
a drive model, otherwise the regulator output itself; plus the disturbance. The
multibody part is the articulated-body algorithm with the joint-referred rotor
inertia and friction of rigid gears in its table.

The compiled core takes four named structures (numba-typed namedtuples):

- :class:`Plant`: the robot's tables, gravity and the packed drives (packed once);
- :class:`Control`: the regulators' kind codes, parameters, states, joints, periods;
- :class:`Reference`: the reference and disturbance rows of the steps being run;
- :class:`Record`: the kept samples; and :class:`Work`, the state carried from one
  chunk of steps to the next (so memory follows the kept samples, not the steps).

Speed (docs/performance.md): :func:`run` makes every array it
touches in the step loop one without an owner (:func:`manipcad.sim.borrow.borrowed`), and
the functions called every step (sampling and signals, the regulators' dispatch,
recording, divergence checks) are inlined into it (``inline="always"``, numba IR): a call
of a compiled function passes every field of every array it takes (a 2-D array: nine
words; the :class:`Plant` alone some twenty arrays) and counts a reference to each.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba as nb
import numpy as np

from manipcad.analysis.realtime import components_one
from manipcad.control.estimator import estimator_update
from manipcad.control.registry import dispatch
from manipcad.control.signals import (
    NSIG,
    S_CI,
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
)
from manipcad.drives.coupling import drive_rates
from manipcad.drives.dc import rigid_drive_rate, static_current
from manipcad.drives.params import (
    KIND_ELASTIC,
    KIND_ELASTIC_STATIC,
    KIND_RIGID,
    KIND_RIGID_STATIC,
    P_KIND,
    P_RATIO,
)
from manipcad.dynamics.aba import ABA_WORK, aba_one
from manipcad.dynamics.crba import CRBA_WORK
from manipcad.dynamics.rnea import RNEA_WORK
from manipcad.rk4 import rk4_stage, rk4_update
from manipcad.sim.borrow import address, borrowed, callee, keep, row
from manipcad.sim.events import (
    MAX_EVENTS,
    bracket_next,
    bracket_start,
    constrained,
    crossing,
    edge_due,
    event_values,
    held,
    joint_values,
    mode_torques,
    release_edge,
    release_shafts,
    release_worst,
    shaft_stuck,
    switch,
)

#: divergence: joint speeds beyond this (rad/s or m/s) count as a runaway
MAX_SPEED = 1.0e4

#: row 0 of a rates matrix as the compiled code passes it to :func:`hybrid_at`: an int64
#: (numba types a literal 0 argument as Literal[int](0), a specialization of its own: the
#: hybrid plant's right-hand side compiled twice, once for row 0, once for the stages)
ROW0 = np.int64(0)

regulator_update = dispatch()

#: the robot: body tables (with and without the joint-referred drive terms), gravity (3,)
#: m/s², packed drives (n, NPAR), drive-state offsets (n+1,), drives on, any elastic drive,
#: joint limits (n, 2) rad or m (±inf: none); with ``gen`` the robot's generated C-ABI
#: kernels (manipcad.codegen.simulation_kernels) replace the general ones: forward
#: dynamics on rtable, links' mass matrix and moment components on ctable; ``ev`` the
#: stick-slip friction and gear losses (:class:`manipcad.sim.events.Events`; ``ev.on``
#: false: the plain forward dynamics, sign(q̇) friction where the table has any)
Plant = namedtuple("Plant", "rtable ctable g dtable off use_drives generic_drives limits "
                            "gen gen_fd gen_mass gen_comp pick ev")
#: a payload picked up at step ``step`` (-1: none): the plant's body table becomes ``rtable``
#: (with the drive terms) and, with ``model``, the regulators' model table ``ctable``;
#: ``done`` (1,) marks it done
Pickup = namedtuple("Pickup", "step rtable ctable model done")
#: the regulators (R of them): kind code (R,), parameters (R, NPARAM), states (R, NSTATE),
#: joints (R, n) and their count (R,), period in steps (R,), moment constituents needed,
#: and ``est``: the online payload estimator (:class:`manipcad.control.estimator.Estimator`,
#: ``on`` false when there is none)
Control = namedtuple("Control", "kind params state joints nj steps need_comp est")
#: rows of the steps being run: q*, q̇*, q̈* (m, n) and disturbance torques (m, n)
Reference = namedtuple("Reference", "q qd qdd dist")
#: kept samples: t (M,) s; q, q̇, U, i, τ (M, n)
Record = namedtuple("Record", "t q qd u i tau")
#: carried between chunks: state x, held outputs U (n,), steps to each regulator's next
#: sample (R,), [next record row, steps to the next record] (2,), per joint the largest
#: excursion beyond its limits (rad or m) and the time it first left them (s) (n, 2)
Work = namedtuple("Work", "x U wait rec excess")


@nb.njit(cache=True, inline="always")
def _torques(xs, U, dist, n, plant, q, qd, xd, dxd, tau, K4, st):
    """Joint torques (drives + disturbance) at state xs into tau; q, q̇ of xs into q, qd;
    the drive states' rates into row ``st`` of K4 (from column 2n)."""
    m = 2 * n
    dtable = plant.dtable
    off = plant.off
    for j in range(n):
        q[j] = xs[j]
        qd[j] = xs[n + j]
        tau[j] = U[j]
    if plant.use_drives:
        if plant.generic_drives:
            _generic(xs, U, plant, q, qd, xd, dxd, tau, K4, np.intp(st), m)
        else:
            for j in range(n):
                kind = int(dtable[j, P_KIND])
                if kind == KIND_RIGID or kind == KIND_RIGID_STATIC:
                    o = m + off[j]
                    i = xs[o] if kind == KIND_RIGID else 0.0
                    di, tj = rigid_drive_rate(i, U[j], qd[j], row(dtable, j))
                    if kind == KIND_RIGID:
                        K4[st, o] = di
                    tau[j] = tj
    for j in range(n):
        tau[j] = tau[j] + dist[j]


@callee
def _generic(xs, U, plant, q, qd, xd, dxd, tau, K4, st, m):
    """The generic drives' part of :func:`_torques` (elastic gears, in their modes
    ``plant.ev.gm``): a call of its own, so that the rigid drives' inlined right-hand side
    never reads the events' structure."""
    for j in range(xd.shape[0]):
        xd[j] = xs[m + j]
    drive_rates(plant.dtable, plant.off, xd, U, q, qd, tau, dxd, plant.ev.gm)
    for j in range(xd.shape[0]):
        K4[st, m + j] = dxd[j]


@nb.njit(cache=True, inline="always")
def _rates(xs, U, dist, n, plant, q, qd, xd, dxd, tau, qdd, K4, st, fext, work):
    """Right-hand side at state xs into row ``st`` of K4; joint torques into tau.

    The one place the simulator evaluates the closed loop's right-hand side (RK4 and
    the adaptive integrator both call it): drives (:func:`_torques`) then the
    multibody forward dynamics; with ``plant.ev.on`` the hybrid plant's
    (:mod:`manipcad.sim.events`): the torques of the slipping joints' modes
    (:func:`~manipcad.sim.events.mode_torques`, inlined) and, only while a joint is held
    or a gear has losses, the constrained q̈ (:func:`~manipcad.sim.events.constrained`,
    a call). The stuck joints' margins go into ``plant.ev.marg``.

    The general forward dynamics is a call of :func:`manipcad.dynamics.aba.aba_one`, not
    inlined: inlined into both integrators and the event code it cost some 8 s of CPU of
    a first run's compile and saved 1-3 % of a run (PUMA 560, RK4, general kernels).
    """
    _torques(xs, U, dist, n, plant, q, qd, xd, dxd, tau, K4, st)
    for j in range(n):
        K4[st, j] = qd[j]
    ev = plant.ev
    more = False
    tin = tau
    if ev.on:  # stick-slip friction, gear losses (manipcad.sim.events)
        more = mode_torques(ev, qd, tau)
        tin = ev.tf
    if plant.gen:
        if plant.gen_fd(address(q), address(qd), address(tin), address(qdd)) >= 0:
            for j in range(n):  # H not positive definite: the run stops as diverged
                qdd[j] = math.nan
            more = False
    elif not aba_one(plant.rtable, plant.g, q, qd, tin, fext, False, True, work, qdd):
        more = False
    if more:
        constrained(plant.gen, plant.gen_mass, plant.rtable, ev, q, qd, tau, dist, qdd)
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
        return static_current(U, dtable[j, P_RATIO] * qd, row(dtable, j))
    if kind != 0:  # elastic, L neglected: the current follows the motor speed
        return static_current(U, x[m + off[j] + 1], row(dtable, j))
    return math.nan


@nb.njit(cache=True, inline="always")
def _signals(plant, ctrl, x, U, k, kr, dt, ref, sig, H, comp):
    """Fill the signal matrix (one row per joint) at step k (reference row kr)."""
    n = plant.rtable.shape[0]
    m = 2 * n
    dtable = plant.dtable
    off = plant.off
    q, qd, zero, rwork, cwork, tmp, Hii, hv, qg = comp
    if ctrl.need_comp:
        for j in range(n):
            q[j] = x[j]
            qd[j] = x[n + j]
        if plant.gen:
            plant.gen_mass(address(q), address(H))
            plant.gen_comp(address(q), address(qd), address(Hii), address(hv), address(qg))
        else:
            components_one(plant.ctable, plant.g, q, qd, zero, rwork, cwork, tmp, H, Hii, hv,
                           qg)
    for j in range(n):
        sig[j, S_T] = k * dt
        sig[j, S_QREF] = ref.q[kr, j]
        sig[j, S_QDREF] = ref.qd[kr, j]
        sig[j, S_QDDREF] = ref.qdd[kr, j]
        sig[j, S_Q] = x[j]
        sig[j, S_QD] = x[n + j]
        if plant.use_drives:
            sig[j, S_I] = _current(dtable, off, x, m, U[j], x[n + j], j)
            kind = int(dtable[j, P_KIND])
        else:
            sig[j, S_I] = 0.0
            kind = 0
        if kind == KIND_ELASTIC or kind == KIND_ELASTIC_STATIC:
            sig[j, S_THM] = x[m + off[j]]
            sig[j, S_WM] = x[m + off[j] + 1]
        else:
            sig[j, S_THM] = dtable[j, P_RATIO] * x[j]
            sig[j, S_WM] = dtable[j, P_RATIO] * x[n + j]
        if ctrl.need_comp:
            sig[j, S_HII] = Hii[j]
            sig[j, S_CI] = hv[j]
            sig[j, S_QI] = qg[j]


@nb.njit(cache=True, inline="always")
def write_record(plant, rec, row, t, x, U, tau):
    """Kept sample ``row``: time t s, q, q̇, U, armature currents (A) and torques tau."""
    n = plant.rtable.shape[0]
    rec.t[row] = t
    for j in range(n):
        rec.q[row, j] = x[j]
        rec.qd[row, j] = x[n + j]
        rec.u[row, j] = U[j]
        rec.i[row, j] = (_current(plant.dtable, plant.off, x, 2 * n, U[j], x[n + j], j)
                         if plant.use_drives else math.nan)
        rec.tau[row, j] = tau[j]


@nb.njit(cache=True, inline="always")
def keep_sample(plant, rec, work, t, every, x, U, tau):
    """Record the state x at t s (U, torques tau) when a kept sample is due (every
    ``every`` steps; ``work.rec``: next row, steps to the next sample)."""
    if work.rec[1] == 0:
        work.rec[1] = every
        write_record(plant, rec, work.rec[0], t, x, U, tau)
        work.rec[0] += 1
    work.rec[1] -= 1


@nb.njit(cache=True, inline="always")
def check_state(plant, work, x, xdot, t, stop_at_limits):
    """Divergence and joint limits at state x (rate xdot), time t s: (status, joint).

    status 0 fine, 1 NaN (joint, or -1 for a drive state), 2 a speed above
    :data:`MAX_SPEED`, 3 a joint left its limits with ``stop_at_limits``; each joint's
    largest excursion beyond its limits and the time it first left them go into
    ``work.excess``.
    """
    n = plant.rtable.shape[0]
    m = 2 * n
    for j in range(x.shape[0]):
        if not math.isfinite(x[j]) or not math.isfinite(xdot[j]):
            return 1, j % n if j < m else -1
    for j in range(n):
        if abs(x[n + j]) > MAX_SPEED:
            return 2, j
    for j in range(n):
        ex = max(plant.limits[j, 0] - x[j], x[j] - plant.limits[j, 1])
        if ex > work.excess[j, 0]:
            if work.excess[j, 0] == 0.0:
                work.excess[j, 1] = t
            work.excess[j, 0] = ex
            if stop_at_limits:
                return 3, j
    return 0, -1


@nb.njit(cache=True, inline="always")
def _estimator_due(est, k):
    """Whether the online payload estimator samples at step k (never when ``est.on`` is
    false: a run without one carries :func:`manipcad.control.estimator.no_estimator`, of
    the same numba type, so each integrator compiles once for runs with and without)."""
    # (the adaptive integrator samples a chunk's last step again as the next one's
    # first: never twice)
    due = est.on and k % est.steps == 0 and est.aux[1] != k + 1
    if due:
        est.aux[1] = k + 1
    return due


@nb.njit(cache=True, inline="always")
def sample_due(plant, ctrl, x, U, k, kr, dt, ref, sig, H, comp, wait):
    """Sample the regulators due at step k (``wait[r] == 0``): fill the signal matrix once,
    run each due regulator through the registry's dispatch (its output held in U) and set
    its ``wait`` to its period in steps. Both integrators call this, so the regulators see
    the same instants and signals whichever integrates between them. Here too: a payload
    picked up at step ``plant.pick.step`` (:func:`_pick_up`), and the online payload
    estimator every ``ctrl.est.steps`` steps, after the regulators."""
    pick = plant.pick
    if pick.step >= 0 and pick.done[0] == 0 and k >= pick.step:
        _pick_up(plant)
    est = ctrl.est
    est_due = _estimator_due(est, k)
    R = ctrl.kind.shape[0]
    due = est_due
    for r in range(R):
        if wait[r] == 0:
            due = True
    if not due:
        return
    _signals(plant, ctrl, x, U, k, kr, dt, ref, sig, H, comp)
    for r in range(R):
        if wait[r] == 0:
            wait[r] = ctrl.steps[r]
            regulator_update(ctrl.kind[r], row(ctrl.params, r), row(ctrl.state, r), sig, H,
                             row(ctrl.joints, r), ctrl.nj[r], ctrl.steps[r] * dt, U)
    # the estimator after the regulators: they read its estimate at the next sample
    if est_due:
        estimator_update(est, sig, plant.ctable, est.steps * dt)


@callee
def _copy(dst, src):
    """dst[:, :] = src for two C arrays of one shape, element by element (a slice
    assignment compiles its broadcasting and the shape check's message too: 3.4 s of
    :func:`_pick_up`'s compile on a cold cache, against 0.3 s)."""
    for i in range(src.shape[0]):
        for c in range(src.shape[1]):
            dst[i, c] = src[i, c]


@callee
def _pick_up(plant):
    """The payload step: the plant's table (and, if the model follows it, the model's)."""
    pick = plant.pick
    pick.done[0] = 1
    _copy(plant.rtable, pick.rtable)
    if pick.model:
        _copy(plant.ctable, pick.ctable)


@nb.njit(cache=True, no_cfunc_wrapper=True)  # no C-ABI entry: nothing uses one
def scratch(n, nx):
    """The work arrays both integrators need (allocated once per call of the core, never
    in the step loop): q, q̇, q̈ (n,), the drive states and their rates (nx − 2n,),
    the joint torques (n,), the signal matrix (n, NSIG), H (n, n), the external forces
    (n, 6), the ABA's work rows, and the moment components' work tuple."""
    m = 2 * n
    comp = (np.empty(n), np.empty(n), np.zeros(n), np.empty((n, RNEA_WORK)),
            np.empty((n, CRBA_WORK)), np.zeros((8, 3)), np.empty(n), np.empty(n), np.empty(n))
    return (np.empty(n), np.empty(n), np.empty(n), np.empty(nx - m), np.empty(nx - m),
            np.empty(n), np.zeros((n, NSIG)), np.zeros((n, n)), np.zeros((n, 6)),
            np.empty((n, ABA_WORK)), comp)


@nb.njit(cache=True, no_cfunc_wrapper=True)  # no C-ABI entry: nothing uses one
def run(plant, ctrl, ref, rec, work, k0, K, dt, every, last, stop_at_limits):
    """Integrate the steps k0 .. k0+K−1 (RK4, dt s) from ``work.x``; record every ``every``.

    ``ref`` holds the rows of steps k0 .. k0+K (K+1 rows). With ``last`` the state at
    step k0+K is sampled and recorded too and the run ends there. A joint beyond its
    limits is recorded in ``work.excess``; with ``stop_at_limits`` the run stops there.
    Returns (status, step, joint): status 0 done, 1 NaN, 2 runaway speed, 3 a joint left
    its limits.
    """
    n = plant.rtable.shape[0]
    nx = work.x.shape[0]
    own = (np.empty(nx), np.empty((4, nx)), scratch(n, nx))
    # every array of the steps without an owner (borrow.borrowed): no atomic reference
    # counts in the step loop; the caller holds the arguments, ``own`` is held to the end
    plant, ctrl, ref, rec, work, bare = borrowed((plant, ctrl, ref, rec, work, own))
    xs, K4, scr = bare
    q, qd, qdd, xd, dxd, tau, sig, H, fext, awork, comp = scr
    x = work.x
    U = work.U
    wait = work.wait
    R = ctrl.kind.shape[0]
    kend = K + 1 if last else K
    ev = plant.ev
    hyb = ev.on
    # elastic gears' events: every step through the event code (hybrid_step)
    gears = hyb and ev.gear
    xn = ev.xe
    for kr in range(kend):
        k = k0 + kr
        sample_due(plant, ctrl, x, U, k, kr, dt, ref, sig, H, comp, wait)
        for r in range(R):
            wait[r] -= 1
        dist = row(ref.dist, kr)
        # the four RK4 stages (manipcad.rk4) with U held and the disturbance at the
        # step's start; with stick-slip friction or gear losses (plant.ev) the first
        # with consistent modes (settle: only where a held joint's margin is below 0)
        for st in range(4):
            if gears:
                if st != 0:
                    break
                settle(plant, x, U, dist, n, scr, K4, k * dt)
            else:
                rk4_stage(x, K4, st, dt, xs)
                _rates(xs, U, dist, n, plant, q, qd, xd, dxd, tau, qdd, K4, st, fext, awork)
                if st != 0:
                    continue
                if hyb and _beyond(ev.mode, ev.lim, ev.fric, ev.marg, n):
                    settle(plant, x, U, dist, n, scr, K4, k * dt)
            keep_sample(plant, rec, work, k * dt, every, x, U, tau)
            if last and kr == K:
                return 0, k, -1
            status, joint = check_state(plant, work, x, row(K4, 0), k * dt, stop_at_limits)
            if status:
                return status, k, joint
            if hyb and not gears:
                joint_values(ev, x, n, ev.e0)
        if not hyb:
            rk4_update(x, K4, dt, x)
        elif gears or _step_events(plant, x, U, dist, n, scr, K4, dt, xn):
            # an event in the step (or at its start): the step again, the events located
            if not gears:
                settle(plant, x, U, dist, n, scr, K4, k * dt)
            hybrid_step(plant, x, U, dist, k * dt, dt, n, scr, K4, xs, xn)
        else:
            for j in range(x.shape[0]):
                x[j] = xn[j]
    keep(own)
    return 0, k0 + K, -1


@nb.njit(cache=True, inline="always")
def _beyond(mode, lim, fric, marg, n):
    """Whether a held joint's margin (of the last right-hand side) is below zero: the
    rates need :func:`settle` (the arrays of :class:`~manipcad.sim.events.Events`)."""
    for j in range(n):
        if held(mode, lim, fric, j) and marg[j] < 0.0:
            return True
    return False


@nb.njit(cache=True, inline="always")
def _step_events(plant, x, U, dist, n, sc, K, dt, xn):
    """The end of an RK4 step of dt s of the hybrid plant without elastic gears, its four
    stages in K and the event values at x in ``plant.ev.e0``: the new state into ``xn``
    (the held joints' margins there from the rates at xn) and its event values into
    ``plant.ev.e1``, as :func:`_rk4_sub` makes them. Whether an event happens in the step
    (:func:`manipcad.sim.events.crossing` below 0) or at its start
    (:func:`manipcad.sim.events.joint_edge`): then :func:`hybrid_step` takes the step
    again and locates them. Inlined into :func:`run`: a step without events calls nothing
    but the rates at xn where a joint is held."""
    ev = plant.ev
    rk4_update(x, K, dt, xn)
    for j in range(n):
        if ev.mode[j] == 0.0 and ev.marg[j] < math.inf:
            hybrid_at(xn, U, dist, n, plant, sc, ev.Ke, ROW0)
            break
    joint_values(ev, xn, n, ev.e1)
    return edge_due(ev, n, ev.e0, ev.e1) or crossing(ev.e0, ev.e1) < 0.0


@callee
def hybrid_at(xs, U, dist, n, plant, sc, K, st):
    """The hybrid plant's right-hand side at xs into row ``st`` of K (the stuck joints'
    margins into ``plant.ev.marg``): :func:`_rates` with ``plant.ev.on``, one compiled copy
    for the event code of both integrators."""
    q, qd, qdd, xd, dxd, tau, sig, H, fext, awork, comp = sc
    _rates(xs, U, dist, n, plant, q, qd, xd, dxd, tau, qdd, K, st, fext, awork)


@callee
def settle(plant, x, U, dist, n, sc, K, t):
    """The rates at x (time t s) into K[0] with consistent modes: while a stuck joint
    cannot be held, release the one furthest beyond its band and solve again
    (:func:`manipcad.sim.events.release_worst`); likewise every stuck motor shaft of an
    elastic gear that cannot be held (:func:`manipcad.sim.events.release_shafts`)."""
    for _ in range(2 * n + 1):
        hybrid_at(x, U, dist, n, plant, sc, K, ROW0)
        shafts = plant.ev.gear and release_shafts(plant, t)
        if not release_worst(plant, t) and not shafts:
            return


@callee
def _rk4_sub(plant, x, U, dist, n, sc, K, h, xs, xn, e1):
    """An RK4 step of h s from x (K[0] its rates) into xn, the modes held; the event
    values at xn into e1 (the rates at xn computed for the stuck joints' and motor shafts'
    margins)."""
    ev = plant.ev
    for st in range(1, 4):
        rk4_stage(x, K, st, h, xs)
        hybrid_at(xs, U, dist, n, plant, sc, K, st)
    rk4_update(x, K, h, xn)
    again = True
    for j in range(n):
        if ev.mode[j] == 0.0 and ev.marg[j] < math.inf:
            hybrid_at(xn, U, dist, n, plant, sc, ev.Ke, ROW0)
            again = False
            break
    if again and ev.gear and shaft_stuck(ev.gm, n):
        hybrid_at(xn, U, dist, n, plant, sc, ev.Ke, ROW0)
    event_values(plant, xn, n, e1)


@callee
def hybrid_step(plant, x, U, dist, t, dt, n, sc, K, xs, xn):
    """One RK4 step of dt s from x at t s (K[0]: its settled rates) with the events located.

    A step that crosses an event (a slipping joint's d·q̇ reaching 0, a stuck joint's margin
    below 0: :mod:`manipcad.sim.events`) is cut at it: the fraction θ of the step where
    the first crossing happens is found by the Illinois method on RK4 steps of θ·h from
    the step's start (to 1e-12 of the step), the modes switched there, and the rest of the
    step integrated from that state; the regulators' sample instants stay on the grid.
    """
    ev = plant.ev
    e0 = ev.e0
    e1 = ev.e1
    h = dt
    for _ in range(MAX_EVENTS):
        event_values(plant, x, n, e0)
        _rk4_sub(plant, x, U, dist, n, sc, K, h, xs, xn, e1)
        if release_edge(plant, x, n, e0, e1, t):
            settle(plant, x, U, dist, n, sc, K, t)
            continue
        fhi = crossing(e0, e1)
        if fhi >= 0.0:
            break
        il = ev.il
        th = bracket_start(il, fhi)
        while th > 0.0:
            _rk4_sub(plant, x, U, dist, n, sc, K, h * th, xs, xn, e1)
            th = bracket_next(il, crossing(e0, e1))
        hi = il[2]
        ev.count[1] += int(il[5])
        if il[4] == 0.0:
            _rk4_sub(plant, x, U, dist, n, sc, K, h * hi, xs, xn, e1)
        for j in range(x.shape[0]):
            x[j] = xn[j]
        t += h * hi
        switch(plant, x, n, e0, e1, t)
        h = h * (1.0 - hi)
        settle(plant, x, U, dist, n, sc, K, t)
        if h <= 0.0:
            return
    else:   # too many events in one step: the rest taken as it is
        _rk4_sub(plant, x, U, dist, n, sc, K, h, xs, xn, e1)
    for j in range(x.shape[0]):
        x[j] = xn[j]
