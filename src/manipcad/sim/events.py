"""Stick–slip friction and gear losses in the simulated plant: modes, constrained
forward dynamics and the events both integrators locate.

Every joint whose rigid drive has dry friction (|i_r|·M_f, joint side) or a gear
efficiency η < 1 takes part (a *lossy* joint). Each has a mode, ``mode[j]``:

* ``+1`` / ``-1``: slipping in that direction: the kinetic friction of that
  direction opposes it, whatever the sign q̇ takes inside a step (the sign is a
  mode, switched at located events, never ``sign(q̇)`` of a stage);
* ``0``: stuck: q̇_j = q̈_j = 0, the friction holds whatever torque the motion of the
  others and the drive ask of it, up to the static friction |i_r|·M_s
  (:attr:`manipcad.model.robot.Drive.static_friction`, M_f where the data give none);
  once it breaks away it slides with the kinetic friction |i_r|·M_f.

Forward dynamics (the simulator's one right-hand side, :func:`manipcad.sim.loop._rates`,
with :func:`mode_torques` and :func:`constrained`): the multibody forward dynamics with the
drive terms (the generated kernels or the articulated-body method) gives q̈₀ of
H_d·q̈ = τ + τ_dist − c − f (H_d = H + diag(J·i_r²)); then, when a joint is stuck
or a gear has losses, with the mass matrix H_d:

* the gear passes g·T to the joint, T = τ_m − J·i_r²·q̈ − k_v·i_r²·q̇ − F the
  torque at its input, g = 1/f with f of :func:`manipcad.dynamics.gear.gear_factor`
  (the sizing's formula): row j becomes (H q̈ + c − τ_dist)_j = g_j·T_j, i.e. H_d's
  diagonal gains (g_j − 1)·J·i_r² and the right side
  (g_j − 1)·(τ_m − k_v·i_r²·q̇ − F);
  g's mode (motoring or braking) is found from T at q̈₀ and checked (at most three
  rounds);
* the stuck joints' rows and columns are taken out (q̈_S = 0) and the free joints'
  system solved by Cholesky; each stuck joint's holding torque P = (H q̈ + c −
  τ_dist)_s is checked against the loads its drive can hold at rest
  (:func:`manipcad.dynamics.gear.holding_band`): the margin
  ``min(P − lo, hi − P)`` (N·m or N) goes to ``marg[s]`` and the way it would
  break away to ``dirn[s]``.

Hard stops (``simulate(joint_limits="hard-stop")``, ``lims``): a joint reaching one is put
on it (an inelastic impact through the mass matrix, :func:`_impact`) and held like a stuck
joint (``lim`` ±1, mode 0) with the stop taking any load that pushes into it (that side
of its holding band open); it leaves when its margin, the other side, falls below zero.

Events (located by the integrators, :mod:`manipcad.sim.loop` and
:mod:`manipcad.sim.adaptive`): a slipping joint's d·q̇_j reaching zero (it stops:
stuck, or turned back at once when it cannot be held) and a stuck joint's margin
falling below zero (it breaks away in ``dirn``), and a joint's distance to its nearest
hard stop reaching zero. Several stuck joints are coupled
through H_d; when several cannot be held, the one furthest beyond its band is
released first and the rest solved again (:func:`settle`).
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba as nb
import numpy as np

from manipcad.drives.params import (
    KIND_ELASTIC,
    KIND_ELASTIC_STATIC,
    P_GAP,
    P_KIND,
    P_KS,
    P_MFN,
    P_MFP,
    P_RATIO,
    P_WEPS,
)
from manipcad.drives.transmission import contact_of, gear_torque
from manipcad.dynamics.crba import CRBA_WORK, crba_one
from manipcad.dynamics.forward_crba import cholesky_solve
from manipcad.dynamics.gear import gear_factor, holding_band
from manipcad.model.robot import COL_BV, COL_FCN, COL_FCP, COL_JR
from manipcad.sim.borrow import address, callee

#: columns of :attr:`Events.fric` (joint side, N·m or N; η -): kinetic friction against
#: positive and negative motion, static friction against positive and negative motion,
#: gear efficiency
FK_POS, FK_NEG, FS_POS, FS_NEG, F_ETA = range(5)

#: the hybrid plant's part of :class:`manipcad.sim.loop.Plant`: ``on`` (any lossy joint),
#: ``fric`` (n, 5) (see FK_POS..F_ETA), ``mode`` (n,) (+1, -1 slipping, 0 stuck; carried
#: from chunk to chunk), ``marg`` and ``dirn`` (n,) the stuck joints' margins (N·m, N;
#: +inf for the others) and break-away directions of the last right-hand side, ``e0``,
#: ``e1`` event values (below), ``xe`` (nx,) and ``Ke`` (1, nx) a state and its rates, and
#: scratch: ``tf``, ``b``, ``rhs``, ``frj``, ``gv`` (n,), ``A``, ``M`` (n, n), ``cw``
#: (n, CRBA_WORK), ``ctmp`` (8, 3); ``count`` (2,): mode switches, rounds of location;
#: ``log`` (LOG, 3): the first LOG switches' time (s), joint and new mode
#: ``il`` (8,) the bracket of the event being located (:func:`bracket_start`); hard stops
#: (``joint_limits="hard-stop"``): ``lims`` (n, 2) the stops' positions (rad, m; ±inf: none)
#: and ``lim`` (n,) where each joint is: 0 away from its stops, +1 / -1 held at its upper /
#: lower stop (then ``mode`` is 0); elastic gears (:func:`gear_part`): ``gear`` (any gear taking
#: part), ``gm`` (n, 5) per joint (one array: every array of the structure is passed at
#: every call): its gear's contact mode (+1 / -1 the teeth in contact on that flank, 0 in
#: the gap) and its motor shaft's mode (+1 / -1 sliding that way, 0 stuck), nan where the
#: gear or its shaft does not take part; the torque a stuck shaft holds (of the last
#: right-hand side), N·m; the shaft's static friction against positive and negative motor
#: motion, N·m (motor side); ``e0``, ``e1`` (4n, or 2n without ``gear``): the joints'
#: mode events, their distances to the nearest stop, then the gears' contact and shafts'
#: events
Events = namedtuple("Events", "on fric mode marg dirn e0 e1 xe Ke tf b rhs frj gv A M cw "
                              "ctmp count log il lim lims gear gm")

#: mode switches kept in :attr:`Events.log` (the rest are counted only)
LOG = 100000

#: most events located within one step of the fixed-step integrator (or one step of the
#: adaptive one); beyond, the rest of the step is taken as it is
MAX_EVENTS = 24


def events_part(fric: np.ndarray, qd0: np.ndarray, nx: int, stops=None,
                gears=None) -> Events:
    """The :class:`Events` of a run: ``fric`` (n, 5) (see :data:`FK_POS`), the initial
    joint speeds ``qd0`` (rad/s, m/s) set the modes (a lossy joint at rest starts
    stuck), ``nx`` the state's length; ``stops`` (n, 2): the joints' hard stops (lower,
    upper; rad or m, ±inf: none), or None; ``gears``: the elastic gears' initial modes and
    static friction (n, 5) (:func:`gear_part`), or None.

    Example:
        >>> import numpy as np
        >>> from manipcad.sim.events import events_part
        >>> ev = events_part(np.array([[1.0, 1.0, 1.0, 1.0, 1.0], [0, 0, 0, 0, 0.9],
        ...                            [0, 0, 0, 0, 1.0]]), np.array([0.0, -2.0, 3.0]), 9)
        >>> bool(ev.on), ev.mode.tolist()
        (True, [0.0, -1.0, 0.0])
    """
    fric = np.ascontiguousarray(fric, dtype=float)
    n = fric.shape[0]
    lossy = np.array([is_lossy(fric, j) for j in range(n)], dtype=bool)
    mode = np.where(lossy, np.sign(np.asarray(qd0, dtype=float)), 0.0)
    lims = (np.tile([-math.inf, math.inf], (n, 1)) if stops is None
            else np.array(stops, dtype=float).reshape(n, 2))
    gm = no_gears(n) if gears is None else gears
    gear = bool(np.isfinite(gm[:, :2]).any())
    on = bool(lossy.any()) or bool(np.isfinite(lims).any()) or gear
    ne = 4 * n if gear else 2 * n   # the gears' events only where a gear takes part
    return Events(on, fric, mode.astype(float), np.full(n, math.inf),
                  np.zeros(n), np.zeros(ne), np.zeros(ne), np.zeros(nx),
                  np.zeros((1, nx)),
                  np.zeros(n), np.zeros(n), np.zeros(n), np.zeros(n), np.ones(n),
                  np.zeros((n, n)), np.zeros((n, n)), np.zeros((n, CRBA_WORK)),
                  np.zeros((8, 3)), np.zeros(2, dtype=np.int64),
                  np.empty((LOG if on else 0, 3)), np.zeros(8), np.zeros(n), lims,
                  gear, np.array(gm, dtype=float))


def no_gears(n: int) -> np.ndarray:
    """The :attr:`Events.gm` of n joints none of which has a gear taking part."""
    gm = np.zeros((n, 5))
    gm[:, :2] = math.nan
    return gm


def gear_part(dtable: np.ndarray, off: np.ndarray, x0: np.ndarray, static) -> tuple:
    """The elastic gears' part of :func:`events_part`: :attr:`Events.gm` (n, 5).

    A gear with backlash (b > 0) takes part with its contact (its initial mode from the
    state, :func:`manipcad.drives.transmission.contact_of`); its motor shaft when it has
    dry friction and no linear zone (``P_WEPS`` 0): sliding the way it turns, stuck at
    rest (released at once if it cannot be held). The shaft's static friction against
    positive and negative motor motion (N·m, motor side) from ``static``, the drives'
    M_s pairs named after the joint direction (never below M_f).

    Args:
        dtable: (n, NPAR) packed drives; off: their states' offsets; x0: the initial
            state (q, q̇, drive states); static: (n, 2) M_s+, M_s- (N·m, motor side).

    Example:
        >>> import numpy as np
        >>> from manipcad.drives.params import pack_drives, state_offsets, Transmission
        >>> from manipcad.model.robot import Drive
        >>> t = pack_drives([Drive(J=1e-4, ratio=-10, R=1, L=1e-3, k_m=.1, k_w=.1,
        ...                        M_f=(0.02, 0.03))], [Transmission(1e3, 0.0, 1e-3)])
        >>> gear_part(t, state_offsets(t), np.zeros(5), [(0.04, 0.03)]).tolist()
        [[0.0, 0.0, 0.0, 0.03, 0.04]]
    """
    n = dtable.shape[0]
    gm = no_gears(n)
    static = np.asarray(static, dtype=float).reshape(n, 2)
    for j in range(n):
        p = dtable[j]
        if int(p[P_KIND]) not in (KIND_ELASTIC, KIND_ELASTIC_STATIC):
            continue
        o = 2 * n + off[j]
        r = p[P_RATIO]
        if p[P_GAP] > 0.0:
            gm[j, 0] = contact_of(x0[o] / r - x0[j], x0[o + 1] / r - x0[n + j], p)
        if (p[P_MFP] > 0.0 or p[P_MFN] > 0.0 or static[j].any()) and p[P_WEPS] == 0.0:
            gm[j, 1] = float(np.sign(x0[o + 1]))
            sp = max(static[j, 0], p[P_MFP])
            sn = max(static[j, 1], p[P_MFN])
            gm[j, 3:] = (sp, sn) if r > 0.0 else (sn, sp)
    return gm


def friction_table(dtable: np.ndarray, rtable: np.ndarray, efficiency, kinds,
                   static=None) -> np.ndarray:
    """(n, 5) :data:`FK_POS`..:data:`F_ETA` of the rigid drives: the joint-referred dry
    friction of the body table's drive columns (kinetic), the static friction, and the
    gears' efficiency (1 where unknown, nan, as the sizing takes it, or for the elastic
    kinds, whose friction is on the motor's own states).

    Args:
        dtable: (n, NPAR) packed drives; rtable: the body table with the drive terms.
        efficiency: (n,) the drives' η (nan: unknown).
        kinds: (n,) bool, the joints with a rigid drive.
        static: (n, 2) the static friction against positive and negative motion, joint
            side (|i_r|·M_s), N·m or N, taken where ``kinds`` (never below the kinetic);
            None: equal to the kinetic friction.

    Example:
        >>> import numpy as np
        >>> from manipcad.model.robot import COL_FCN, COL_FCP, TABLE_COLS
        >>> rt = np.zeros((1, TABLE_COLS)); rt[0, COL_FCP] = rt[0, COL_FCN] = 2.0
        >>> friction_table(None, rt, np.array([0.9]), np.array([True]),
        ...                np.array([[3.0, 2.5]])).tolist()
        [[2.0, 2.0, 3.0, 2.5, 0.9]]
    """

    n = rtable.shape[0]
    out = np.zeros((n, 5))
    out[:, FK_POS] = rtable[:, COL_FCP]
    out[:, FK_NEG] = rtable[:, COL_FCN]
    out[:, FS_POS] = rtable[:, COL_FCP]
    out[:, FS_NEG] = rtable[:, COL_FCN]
    if static is not None:
        static = np.asarray(static, dtype=float)
        for c, k in ((FS_POS, FK_POS), (FS_NEG, FK_NEG)):
            out[:, c] = np.where(kinds, np.maximum(static[:, c - FS_POS], out[:, k]),
                                 out[:, c])
    eta = np.where(np.isnan(efficiency), 1.0, np.asarray(efficiency, dtype=float))
    out[:, F_ETA] = np.where(kinds, eta, 1.0)
    return out


@nb.njit(cache=True)
def is_lossy(fric, j):
    """Whether joint j takes part in the hybrid model (dry friction or η < 1)."""
    return (fric[j, FK_POS] > 0.0 or fric[j, FK_NEG] > 0.0 or fric[j, FS_POS] > 0.0
            or fric[j, FS_NEG] > 0.0 or fric[j, F_ETA] < 1.0)


@nb.njit(cache=True, inline="always")
def held(mode, lim, fric, j):
    """Whether joint j is held at rest (q̇_j = q̈_j = 0): stuck in its friction, or at a hard
    stop (``mode``, ``lim``, ``fric`` of :class:`Events`; the arrays, not the structure:
    an inlined function's structure argument is a copy whose every array is counted)."""
    return mode[j] == 0.0 and (lim[j] != 0.0 or is_lossy(fric, j))


@nb.njit(cache=True, inline="always")
def _dry(fric, j, s):
    """The kinetic dry friction of joint j for motion of sign s (0: none), N·m or N."""
    if s > 0.0:
        return fric[j, FK_POS]
    if s < 0.0:
        return -fric[j, FK_NEG]
    return 0.0


@nb.njit(cache=True, inline="always")
def mode_torques(ev, qd, tau):
    """The joint torques the forward dynamics takes in a hybrid plant, into ``ev.tf``:
    ``tau`` (drives and disturbance, N·m or N) with each slipping lossy joint's kinetic
    friction that of its mode, not of sign(q̇) (the body table's); the stuck joints'
    margins reset to +inf. Returns whether q̈ then needs :func:`constrained` (a joint held,
    or a gear with losses). Inlined into the one right-hand side
    (:func:`manipcad.sim.loop._rates`)."""
    fric = ev.fric
    mode = ev.mode
    tf = ev.tf
    more = False
    for j in range(tau.shape[0]):
        tf[j] = tau[j]
        ev.marg[j] = math.inf
        if held(mode, ev.lim, fric, j):
            more = True
            continue
        if not is_lossy(fric, j):
            continue
        d = mode[j]
        if fric[j, F_ETA] < 1.0:
            more = True
        s = qd[j]
        sg = 1.0 if s > 0.0 else (-1.0 if s < 0.0 else 0.0)
        if sg != d:  # the kernel's friction is sign(q̇)'s: the mode's instead
            tf[j] = tau[j] + _dry(fric, j, sg) - _dry(fric, j, d)
    return more


@nb.njit(cache=True, inline="always")
def _mass(gen, gen_mass, rt, cw, ctmp, q, A):
    """H_d = H(q) + diag(J·i_r²) into A (n, n): the generated kernel ``gen_mass`` (with
    ``gen``) or the CRBA on the body table ``rt`` (scratch ``cw``, ``ctmp``)."""
    if gen:
        gen_mass(address(q), address(A))
        for j in range(q.shape[0]):
            A[j, j] += rt[j, COL_JR]
    else:
        crba_one(rt, q, True, cw, ctmp, A)


@nb.njit(cache=True, inline="always")
def _free_part(mode, lim, fric, A, M, n):
    """M (n, n): A with the held joints' rows and columns taken out (a unit row and column
    each: q̈ or Δq̇ of a held joint is 0); ``mode``, ``lim``, ``fric`` of :class:`Events`."""
    for i in range(n):
        held_i = held(mode, lim, fric, i)
        for k in range(n):
            M[i, k] = 0.0 if held_i or held(mode, lim, fric, k) else A[i, k]
        if held_i:
            M[i, i] = 1.0


@callee
def constrained(gen, gen_mass, rt, ev, q, qd, tau, dist, qdd):
    """q̈₀ (of the forward dynamics on :func:`mode_torques`) in ``qdd`` made the hybrid
    plant's: gear factors and held joints (module docstring); the held joints' margins
    into ``ev.marg`` and break-away directions into ``ev.dirn``. ``gen``, ``gen_mass``,
    ``rt``: the plant's generated kernels' flag, its mass-matrix kernel and its body table
    with the drive terms (:class:`manipcad.sim.loop.Plant`); ``ev`` its :class:`Events`.
    Returns False when H_d is not positive definite (q̈ NaN). A call of its own, made only
    when a joint is held or a gear has losses, with only the arrays it reads."""
    fric = ev.fric
    mode = ev.mode
    n = q.shape[0]
    A = ev.A
    M = ev.M
    b = ev.b
    rhs = ev.rhs
    frj = ev.frj
    gv = ev.gv
    _mass(gen, gen_mass, rt, ev.cw, ev.ctmp, q, A)
    for i in range(n):
        s = 0.0
        for k in range(n):
            s += A[i, k] * qdd[k]
        b[i] = s
    for j in range(n):
        d = mode[j] if is_lossy(fric, j) else qd[j]
        frj[j] = rt[j, COL_BV] * qd[j] + _dry(fric, j, d)
        gv[j] = 1.0
    for it in range(3):
        changed = False
        for j in range(n):
            if mode[j] != 0.0 and fric[j, F_ETA] < 1.0 and is_lossy(fric, j):
                T = tau[j] - dist[j] - rt[j, COL_JR] * qdd[j] - frj[j]
                g = 1.0 / gear_factor(fric[j, F_ETA], T, mode[j])
                if g != gv[j]:
                    gv[j] = g
                    changed = True
        if it > 0 and not changed:
            break
        _free_part(mode, ev.lim, fric, A, M, n)
        for i in range(n):
            if held(ev.mode, ev.lim, ev.fric, i):
                rhs[i] = 0.0
            else:
                M[i, i] += (gv[i] - 1.0) * rt[i, COL_JR]
                rhs[i] = b[i] + (gv[i] - 1.0) * (tau[i] - dist[i] - frj[i])
        if not cholesky_solve(M, rhs, qdd):
            for j in range(n):
                qdd[j] = math.nan
            return False
    for s_ in range(n):
        if not held(ev.mode, ev.lim, ev.fric, s_):
            continue
        P = tau[s_] - dist[s_] - b[s_]
        for k in range(n):
            P += A[s_, k] * qdd[k]
        lo, hi = holding_band(fric[s_, F_ETA], tau[s_] - dist[s_], fric[s_, FS_POS],
                              fric[s_, FS_NEG])
        # at a hard stop the stop holds any load pushing into it
        if ev.lim[s_] > 0.0:
            lo = -math.inf
        elif ev.lim[s_] < 0.0:
            hi = math.inf
        ev.marg[s_] = min(P - lo, hi - P)
        ev.dirn[s_] = 1.0 if P - lo < hi - P else -1.0
    return True


@callee
def _log(ev, t, j, what):
    """Keep the switch of joint j at t s in ``ev.log``: ``what`` its new mode (+1, -1, 0),
    or +2 / -2 reaching its upper / lower hard stop."""
    c = ev.count[0]
    if c < ev.log.shape[0]:
        ev.log[c, 0] = t
        ev.log[c, 1] = j
        ev.log[c, 2] = what
    ev.count[0] = c + 1


@callee
def _release(ev, j, t):
    """Joint j, held, breaks away at t s in its direction ``dirn`` (off its stop, if at
    one)."""
    ev.mode[j] = ev.dirn[j]
    ev.lim[j] = 0.0
    _log(ev, t, j, ev.mode[j])


@nb.njit(cache=True, inline="always")
def _has_stops(lims, j):
    """Whether joint j has a hard stop (``lims`` of :class:`Events`)."""
    return lims[j, 0] > -math.inf or lims[j, 1] < math.inf


@callee
def _contact(plant, x, n, j, t):
    """Joint j reaches its nearest hard stop at t s: q_j set on the stop, an inelastic
    impact (:func:`_impact`) brings q̇_j to 0, and the joint is held there."""
    ev = plant.ev
    lo = ev.lims[j, 0]
    hi = ev.lims[j, 1]
    side = 1.0 if hi - x[j] <= x[j] - lo else -1.0
    x[j] = hi if side > 0.0 else lo
    _impact(plant, x, n, j, t)
    x[n + j] = 0.0
    ev.mode[j] = 0.0
    ev.lim[j] = side
    _log(ev, t, j, 2.0 * side)


@callee
def _impact(plant, x, n, j, t):
    """The inelastic impact of joint j on its stop, at state x (t s): the stop's impulse
    λ·e_j (N·m·s, N·s) through the mass matrix H_d (drives' rotors included) of the joints
    not held, Δq̇ = λ·H_d⁻¹·e_j with λ such that q̇_j becomes 0; the held joints (stuck,
    at a stop) take their share rigidly. A slipping joint the impulse turns round slips
    the other way from here (its friction follows; one at exactly 0 is made stuck)."""
    ev = plant.ev
    u = ev.b    # H_d⁻¹·e_j of the joints not held (scratch: q in tf, e_j in rhs)
    for k in range(n):
        ev.tf[k] = x[k]
        ev.rhs[k] = 1.0 if k == j else 0.0
    _mass(plant.gen, plant.gen_mass, plant.rtable, ev.cw, ev.ctmp, ev.tf, ev.A)
    _free_part(ev.mode, ev.lim, ev.fric, ev.A, ev.M, n)
    if not cholesky_solve(ev.M, ev.rhs, u) or not u[j] > 0.0:
        return
    lam = -x[n + j] / u[j]
    for k in range(n):
        if k != j and not held(ev.mode, ev.lim, ev.fric, k):
            x[n + k] += lam * u[k]
            if is_lossy(ev.fric, k) and ev.mode[k] * x[n + k] <= 0.0:
                if x[n + k] == 0.0:
                    ev.mode[k] = 0.0
                else:
                    ev.mode[k] = 1.0 if x[n + k] > 0.0 else -1.0
                _log(ev, t, k, ev.mode[k])


@callee
def release_worst(plant, t):
    """Release the stuck joint furthest beyond its holding band (the last right-hand
    side's margins) in its break-away direction, at t s; whether one was."""
    ev = plant.ev
    worst = -1
    wm = 0.0
    for j in range(ev.mode.shape[0]):
        if held(ev.mode, ev.lim, ev.fric, j) and ev.marg[j] < wm:
            worst = j
            wm = ev.marg[j]
    if worst < 0:
        return False
    _release(ev, worst, t)
    return True


@callee
def event_values(plant, x, n, e):
    """The event functions at state x into ``e`` (4n; 2n without gears taking part):
    e[j] d·q̇_j of a slipping lossy joint (rad/s, m/s), the margin of a held one (N·m, N;
    of the last right-hand side, which must be x's), 0 for the others; e[n + j] a joint's
    distance to its nearest hard stop (rad, m) while away from its stops, 0 for the
    others; e[2n + j] its gear's
    contact event (:func:`_contact_value`, rad or m) and e[3n + j] its motor shaft's: s·ω_m
    sliding (rad/s), the margin stuck (N·m; of the last right-hand side), 0 where the
    gear or shaft does not take part."""
    joint_values(plant.ev, x, n, e)
    if plant.ev.gear:
        _gear_values(plant, x, n, e)


@nb.njit(cache=True, inline="always")
def values_at(plant, x, n, e):
    """:func:`event_values` with the joints' part inlined: a call only where a gear takes
    part (the integrators evaluate the events at every step)."""
    if plant.ev.gear:
        event_values(plant, x, n, e)
    else:
        joint_values(plant.ev, x, n, e)


@nb.njit(cache=True, inline="always")
def edge_due(ev, n, e0, e1):
    """Whether :func:`release_edge` has anything to do between the event values e0 and
    e1 (``ev`` the :class:`Events`; always where a gear takes part): the test inlined,
    the call only then."""
    if ev.gear:
        return True
    for j in range(n):
        if joint_edge(ev.mode, ev.lim, ev.fric, ev.lims, n, e0, e1, j):
            return True
    return False


@nb.njit(cache=True, inline="always")
def joint_values(ev, x, n, e):
    """The joints' part of :func:`event_values` (e[:2n]; ``ev`` the :class:`Events`):
    inlined into the fixed-step core's step without events."""
    for j in range(n):
        if held(ev.mode, ev.lim, ev.fric, j):
            e[j] = ev.marg[j]
        elif is_lossy(ev.fric, j):
            e[j] = ev.mode[j] * x[n + j]
        else:
            e[j] = 0.0
        if ev.lim[j] == 0.0 and _has_stops(ev.lims, j):
            e[n + j] = min(x[j] - ev.lims[j, 0], ev.lims[j, 1] - x[j])
        else:
            e[n + j] = 0.0


@callee
def _gear_values(plant, x, n, e):
    """The gears' part of :func:`event_values` (its own function: the rigid drives' runs
    never enter it)."""
    gm = plant.ev.gm
    for j in range(n):
        o = 2 * n + plant.off[j]
        c = gm[j, 0]
        if c == c:
            p = plant.dtable[j]
            r = p[P_RATIO]
            e[2 * n + j] = _contact_value(p, x[o] / r - x[j], x[o + 1] / r - x[n + j], c)
        s = gm[j, 1]
        if s == 0.0:
            e[3 * n + j] = _shaft_margin(gm, j)[0]
        elif s == s:
            e[3 * n + j] = s * x[o + 1]


@callee
def _contact_value(p, d, dd, c):
    """The contact event of a gear (packed drive ``p``) in contact mode c at δ, δ̇ (rad,
    rad/s; m, m/s), positive while the mode holds, rad (m): with u± = τ_s(±1)/k_s =
    δ ∓ b + (d_s/k_s)·δ̇ the contact's stretch, u+ in contact on the flank +1 (it opens
    when the contact would pull), -u- on the flank -1, and in the gap
    min(max(b - δ, -u+), max(δ + b, u-)): it closes when δ passes ±b with the contact
    pushing (the dead zone's clamp, :func:`manipcad.drives.transmission.contact_of`)."""
    k = p[P_KS]
    up = gear_torque(d, dd, p, 1.0) / k
    lo = gear_torque(d, dd, p, -1.0) / k
    if c > 0.0:
        return up
    if c < 0.0:
        return -lo
    b = p[P_GAP]
    return min(max(b - d, -up), max(d + b, lo))


@nb.njit(cache=True, inline="always")
def _shaft_margin(gm, j):
    """(margin N·m, break-away direction) of joint j's stuck motor shaft: its static
    friction against the torque it holds (``gm`` of :class:`Events`)."""
    up = gm[j, 3] - gm[j, 2]
    dn = gm[j, 2] + gm[j, 4]
    return min(up, dn), (1.0 if up < dn else -1.0)


@callee
def _gear_switch(plant, x, n, j, t, which):
    """Switch joint j's gear at t s: ``which`` 0 its contact (the gap closes on the flank
    δ points to, or the contact opens), 1 its motor shaft (a sliding one stops: ω_m = 0
    exactly, stuck; a stuck one breaks away in its margin's direction). Logged as 10 + the
    new contact mode, 20 + the shaft's new mode."""
    ev = plant.ev
    o = 2 * n + plant.off[j]
    if which == 0:
        if ev.gm[j, 0] == 0.0:
            d = x[o] / plant.dtable[j, P_RATIO] - x[j]
            ev.gm[j, 0] = 1.0 if d > 0.0 else -1.0
        else:
            ev.gm[j, 0] = 0.0
        _log(ev, t, j, 10.0 + ev.gm[j, 0])
    else:
        if ev.gm[j, 1] == 0.0:
            ev.gm[j, 1] = _shaft_margin(ev.gm, j)[1]
        else:
            ev.gm[j, 1] = 0.0
            x[o + 1] = 0.0
        _log(ev, t, j, 20.0 + ev.gm[j, 1])


@callee
def release_shafts(plant, t):
    """Release, at t s, the stuck motor shafts whose static friction cannot hold their
    torque (of the last right-hand side) in its direction; whether one was."""
    ev = plant.ev
    any_ = False
    if not ev.gear:
        return any_
    for j in range(ev.gm.shape[0]):
        if ev.gm[j, 1] == 0.0:
            m, d = _shaft_margin(ev.gm, j)
            if m < 0.0:
                ev.gm[j, 1] = d
                _log(ev, t, j, 20.0 + d)
                any_ = True
    return any_


@nb.njit(cache=True, inline="always")
def shaft_stuck(gm, n):
    """Whether a motor shaft is stuck (``gm`` of :class:`Events`)."""
    for j in range(n):
        if gm[j, 1] == 0.0:
            return True
    return False


@callee
def crossing(e0, e1):
    """The earliest-crossing measure min_j e1_j/e0_j over the events positive at the
    start (1.0 when there is none): below zero when one crossed."""
    phi = 1.0
    for j in range(e0.shape[0]):
        if e0[j] > 0.0:
            r = e1[j] / e0[j]
            if r < phi:
                phi = r
    return phi


@callee
def release_edge(plant, x, n, e0, e1, t):
    """Release, at t s, the held joints that sat on the edge of their holding band at
    a step's start (margin e0 = 0) and are past it at its end (e1 < 0): their break-away
    is at the start (the measure of :func:`crossing` cannot see it). Their direction is
    the end's (``dirn`` of the last right-hand side, at the step's end). Likewise a joint
    on (or past) a hard stop at the start (distance e0 <= 0) and into it at the end is
    put on the stop at the start (x, the step's start state, changed), and a gear whose
    contact event (or a stuck shaft whose margin) sat at 0 switched there. Whether one was;
    the caller then takes the step again."""
    ev = plant.ev
    any_ = False
    for j in range(n):
        edge = joint_edge(ev.mode, ev.lim, ev.fric, ev.lims, n, e0, e1, j)
        if edge == 1:
            _release(ev, j, t)
            any_ = True
        elif edge == 2:
            _contact(plant, x, n, j, t)
            any_ = True
    if ev.gear and _gear_edges(plant, x, n, e0, e1, t):
        any_ = True
    return any_


@nb.njit(cache=True, inline="always")
def joint_edge(mode, lim, fric, lims, n, e0, e1, j):
    """Joint j's edge event of :func:`release_edge` between the event values e0 and e1
    (``mode``, ``lim``, ``fric``, ``lims`` of :class:`Events`): 1 a held joint at its
    band's edge breaks away, 2 it is put on its hard stop, 0 neither."""
    if held(mode, lim, fric, j) and e0[j] <= 0.0 and e1[j] < 0.0:
        return 1
    if lim[j] == 0.0 and _has_stops(lims, j) and e0[n + j] <= 0.0 and e1[n + j] < 0.0:
        return 2
    return 0


@callee
def _gear_edges(plant, x, n, e0, e1, t):
    """The gears' part of :func:`release_edge`: a contact event (or a stuck shaft's
    margin) at 0 at the step's start and below at its end switches at the start."""
    ev = plant.ev
    any_ = False
    for j in range(n):
        if ev.gm[j, 0] == ev.gm[j, 0] and e0[2 * n + j] <= 0.0 and e1[2 * n + j] < 0.0:
            _gear_switch(plant, x, n, j, t, np.intp(0))
            any_ = True
        if ev.gm[j, 1] == 0.0 and e0[3 * n + j] <= 0.0 and e1[3 * n + j] < 0.0:
            _gear_switch(plant, x, n, j, t, np.intp(1))
            any_ = True
    return any_


@callee
def switch(plant, x, n, e0, e1, t):
    """Switch the modes of the joints whose events crossed (e0 > 0 >= e1): a slipping joint
    stops (stuck, q̇_j = 0 exactly; :func:`release_worst` turns it back if it cannot be
    held), a held one breaks away (``dirn``, of the last right-hand side at x), a joint
    reaching a hard stop is put on it (:func:`_contact`), a gear's contact closes or
    opens and its motor shaft sticks or breaks away (:func:`_gear_switch`); t: the time,
    s."""
    ev = plant.ev
    for j in range(n):
        if e0[j] > 0.0 and e1[j] <= 0.0:
            if held(ev.mode, ev.lim, ev.fric, j):
                _release(ev, j, t)
            elif is_lossy(ev.fric, j):
                ev.mode[j] = 0.0
                x[n + j] = 0.0
                _log(ev, t, j, 0.0)
        if e0[n + j] > 0.0 and e1[n + j] <= 0.0 and ev.lim[j] == 0.0:
            _contact(plant, x, n, j, t)
    if ev.gear:
        _gear_switches(plant, x, n, e0, e1, t)


@callee
def _gear_switches(plant, x, n, e0, e1, t):
    """The gears' part of :func:`switch`: those whose contact or shaft event crossed."""
    for j in range(n):
        for w in range(2):
            if e0[(2 + w) * n + j] > 0.0 and e1[(2 + w) * n + j] <= 0.0:
                _gear_switch(plant, x, n, j, t, w)


@callee
def _theta(il):
    """The next fraction to try of the bracket ``il`` (regula falsi), or -1 when located
    (to 1e-12 of the step, or after 60 rounds)."""
    lo, flo, hi, fhi = il[0], il[1], il[2], il[3]
    if hi - lo <= 1e-12 or fhi == 0.0 or il[5] >= 60:
        return -1.0
    th = hi - fhi * (hi - lo) / (fhi - flo)
    if not (lo < th < hi):
        th = 0.5 * (lo + hi)
    il[6] = th
    return th


@callee
def bracket_start(il, fhi):
    """Start locating the first crossing in a step whose end has the measure ``fhi`` < 0
    (:func:`crossing`; 1 at the start): the first fraction θ of the step to try.

    The Illinois method on the fraction θ in (0, 1]: the caller integrates from the
    step's start over θ·h, gives :func:`crossing` there to :func:`bracket_next`, and
    stops at -1; ``il[2]`` is then the located fraction (the crossing just past), and
    ``il[4]`` is 1 when the caller's last sub-step ended there.
    """
    il[0], il[1], il[2], il[3], il[4], il[5], il[7] = 0.0, 1.0, 1.0, fhi, 1.0, 0.0, 0.0
    return _theta(il)


@callee
def bracket_next(il, f):
    """Take the crossing measure ``f`` at the fraction last given; the next fraction, or
    -1 when located (:func:`bracket_start`)."""
    th = il[6]
    il[5] += 1.0
    if f <= 0.0:
        il[2], il[3], il[4] = th, f, 1.0
        if il[7] == -1.0:
            il[1] *= 0.5
        il[7] = -1.0
    else:
        il[0], il[1], il[4] = th, f, 0.0
        if il[7] == 1.0:
            il[3] *= 0.5
        il[7] = 1.0
    return _theta(il)


def no_events(n: int, nx: int) -> Events:
    """The :class:`Events` of a plant without lossy joints (``on`` false)."""
    return events_part(np.tile([0.0, 0.0, 0.0, 0.0, 1.0], (n, 1)), np.zeros(n), nx)
