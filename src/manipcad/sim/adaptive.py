"""Error-controlled integration of the closed loop, with the stiff armature current exact.

The fixed-step RK4 of :mod:`manipcad.sim.loop` must take steps well below the
drives' electrical time constant L/R (0.3–0.5 ms), whatever the accuracy asked.
Here the step is set by the accuracy and by the regulators' sample instants:

* the regulators are sampled exactly as in RK4 (same instants k·dt, same signals,
  same dispatch) and their outputs U held in between (zero-order hold); no step
  crosses a sample instant (nor a step of dt where the disturbance changes);
* the mechanics (q, q̇) are advanced by an explicit embedded Runge–Kutta pair,
  Dormand–Prince 5(4) (``integrator="adaptive"``, ``"adaptive-exact"``) or
  Bogacki–Shampine 3(2) (``"adaptive-bs32"``, ``"adaptive-exact-bs32"``: 3
  right-hand sides per step against 6, for steps the sample period bounds anyway),
  one stepping code for any pair (:class:`Tableau`), the local error of the lower
  order kept below ``atol + rtol·|y|`` (RMS over q and q̇);
* the armature currents: either in the pair with q, q̇ (``exact=False``,
  ``integrator="adaptive"``: the step then also bounded by the pair's stability,
  about 3·L/R), or (``exact=True``, ``"adaptive-exact"``) by the exact solution of
  the armature equation L·di/dt + R·i + k_w·ω_m = u_a(U) at every stage
  (:func:`manipcad.drives.dc.armature_current_poly`, exponential-integrator φ
  functions), U held and the motor speed linear over the stage: no step limit from
  L/R. The error of that speed assumption is estimated at the step's end against the
  cubic (Hermite) speed from both ends' accelerations; a current error δi decays
  with L/R and moves the joint by at most δq̇ = i_r·k_m·δi·h/(J·i_r²) (the rotor
  alone accelerated), which is held to the same tolerance as q̇. (Before this
  estimate the error went unseen: 7e-4 m on the cylindrical arm's LQR-driven reach,
  now 1e-9 m.)
* the step never falls below ``dt`` (but to land on a sample instant): where the
  tolerance would ask for less (the sign of dry friction switching while a joint
  sticks), steps of ``dt`` are taken and counted;
* the kept samples (times k·dt, every ``every`` steps, as RK4) inside a step are
  interpolated: cubic Hermite (from the stage derivatives; the exact current formula
  with ``exact``, the speed linear up to the interpolated one).

The right-hand side is :func:`manipcad.sim.loop._rates` (drives of
:mod:`manipcad.drives.dc`, then the articulated-body algorithm), the one place both
integrators evaluate it. Elastic gears and backlash (the generic drive states of
:mod:`manipcad.drives.coupling`) are integrated by the pair with q, q̇ (``exact=False``;
their contact and motor-shaft events located as the friction's); with ``exact`` only the
rigid drives' currents have a formula, so ``simulate`` refuses elastic gears there.
"""

from __future__ import annotations

import math
from collections import namedtuple

import numba as nb
import numpy as np

from manipcad.analysis.realtime import components_one  # noqa: F401  (loaded with _signals)
from manipcad.drives.dc import armature_current_phis, armature_current_poly, phis
from manipcad.drives.params import KIND_RIGID, P_J, P_KIND, P_KM, P_L, P_R, P_RATIO
from manipcad.sim.borrow import borrowed, callee, keep
from manipcad.sim.events import (
    bracket_next,
    bracket_start,
    crossing,
    edge_due,
    event_values,
    release_edge,
    switch,
    values_at,
)
from manipcad.sim.loop import (
    _rates,
    _torques,
    check_state,
    sample_due,
    scratch,
    settle,
    write_record,
)

#: an explicit embedded Runge–Kutta pair with the last stage at the new solution
#: (first same as last): a (S, S), b (S,) the propagated weights, e (S,) = b − b̂ the
#: error weights, c (S,) the nodes, p the lower order (the step control's exponent
#: is 1/(p+1))
Tableau = namedtuple("Tableau", "a b e c p")


def _tableau(a_rows, b, bhat, c, p) -> Tableau:
    S = len(c)
    a = np.zeros((S, S))
    for i, row in enumerate(a_rows, start=1):
        a[i, :len(row)] = row
    b = np.array(b, dtype=float)
    return Tableau(a, b, b - np.array(bhat, dtype=float), np.array(c, dtype=float), int(p))


#: Dormand & Prince (1980), RK5(4)7FM
DP54 = _tableau(
    [[1 / 5],
     [3 / 40, 9 / 40],
     [44 / 45, -56 / 15, 32 / 9],
     [19372 / 6561, -25360 / 2187, 64448 / 6561, -212 / 729],
     [9017 / 3168, -355 / 33, 46732 / 5247, 49 / 176, -5103 / 18656],
     [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84]],
    [35 / 384, 0.0, 500 / 1113, 125 / 192, -2187 / 6784, 11 / 84, 0.0],
    [5179 / 57600, 0.0, 7571 / 16695, 393 / 640, -92097 / 339200, 187 / 2100, 1 / 40],
    [0.0, 1 / 5, 3 / 10, 4 / 5, 8 / 9, 1.0, 1.0], 4)

#: Bogacki & Shampine (1989), RK3(2)
BS32 = _tableau(
    [[1 / 2], [0.0, 3 / 4], [2 / 9, 1 / 3, 4 / 9]],
    [2 / 9, 1 / 3, 4 / 9, 0.0],
    [7 / 24, 1 / 4, 1 / 3, 1 / 8],
    [0.0, 1 / 2, 3 / 4, 1.0], 2)

#: the pairs by name (``simulate(..., integrator="adaptive")`` uses "dp54")
TABLEAUS = {"dp54": DP54, "bs32": BS32}

#: the adaptive integrator's counters, carried between chunks (float64 array): proposed
#: step (s, 0 before the first), accepted steps, rejected steps, right-hand sides,
#: steps accepted at the floor dt above the tolerance
STATS = 5


@callee
def _currents(plant, x, xs, U, t, n, ph, a0, a1, rtol, atol):
    """The rigid drives' currents t s after x (U held), exactly
    (:func:`armature_current_phis`, :func:`armature_current_poly`), for a motor speed
    polynomial in time over [0, t]; one loop over the drives for both uses:

    * ``a0`` empty: the speed linear from x's to xs's; the currents written into xs.
      Returns (0.0, 0).
    * ``a0``, ``a1`` the joint accelerations at both ends (rad/s², m/s²): the error of the
      currents xs holds (the linear speed's) over a whole step of t s. The cubic
      (Hermite) speed of both ends' speeds and accelerations is the better one, and the
      two currents' distance δi (A) estimates the linear speed's error. A current error
      decays with L/R and moves the joint by its torque: over the step at most
      δq̇ = i_r·k_m·δi·t / (J·i_r²) (rad/s, m/s; the rotor alone accelerated), scaled
      by atol + rtol·|q̇| (with no rotor inertia δi itself, by atol + rtol·|i|). Returns
      (Σ of the squared scaled errors, count of currents).

    ``ph``: (n, 5) φ_0..φ_4 of each drive at -R·t/L (see :func:`_phi_table`), or empty
    (then computed here; linear speed only).
    """
    err = 0.0
    cnt = 0
    if not plant.use_drives or t <= 0.0:
        return err, cnt
    m = 2 * n
    cubic = a0.shape[0] > 0
    for j in range(n):
        p = plant.dtable[j]
        if int(p[P_KIND]) != KIND_RIGID:
            continue
        o = m + plant.off[j]
        r = p[P_RATIO]
        w0 = r * x[n + j]
        dw = r * xs[n + j] - w0
        if not cubic:
            if ph.shape[0]:
                xs[o] = armature_current_phis(x[o], U[j], w0, dw / t, 0.0, 0.0, t, p, ph[j, 0],
                                              ph[j, 1], ph[j, 2], ph[j, 3], ph[j, 4])
            else:
                xs[o] = armature_current_poly(x[o], U[j], w0, dw / t, 0.0, 0.0, t, p)
            continue
        d0 = r * a0[j]
        d1 = r * a1[j]
        w2 = (3.0 * dw - (2.0 * d0 + d1) * t) / (t * t)
        w3 = ((d0 + d1) * t - 2.0 * dw) / (t * t * t)
        ic = armature_current_phis(x[o], U[j], w0, d0, w2, w3, t, p, ph[j, 0],
                                   ph[j, 1], ph[j, 2], ph[j, 3], ph[j, 4])
        i = xs[o]
        Jr = p[P_J] * abs(r)
        if Jr > 0.0:
            dqd = p[P_KM] * abs(ic - i) * t / Jr
            err += (dqd / (atol + rtol * max(abs(x[n + j]), abs(xs[n + j])))) ** 2
        else:   # no rotor inertia: the current's own error, A
            err += ((ic - i) / (atol + rtol * max(abs(x[o]), abs(i)))) ** 2
        cnt += 1
    return err, cnt


@callee
def _phi_table(plant, c, h, n, ph):
    """ph[st, j] = φ_0..φ_4 (:func:`manipcad.drives.dc.phis`) at -R·c[st]·h/L of the
    rigid drives (the exact currents of a step of h s, stage by stage)."""
    if not plant.use_drives:
        return
    for st in range(c.shape[0]):
        for j in range(n):
            p = plant.dtable[j]
            if int(p[P_KIND]) == KIND_RIGID:
                ph[st, j, 0], ph[st, j, 1], ph[st, j, 2], ph[st, j, 3], ph[st, j, 4] = \
                    phis(-c[st] * h * p[P_R] / p[P_L])


@callee
def _stages(plant, x, xs, U, dist, n, scr, Ks, tab, h, exact, ph, st0):
    """The stages st0 .. S-1 of a step of h s of the pair ``tab`` from x into Ks (Ks[0]
    given when st0 is 1), the last at the new solution xs; with ``exact`` the rigid
    drives' currents by the exact formula (``ph``: the φ table of h). The one stepping
    code of the error-controlled integrator (its steps and the steps of θ·h that locate
    an event inside one)."""
    q, qd, qdd, xd, dxd, tau, sig, H, fext, awork, comp = scr
    S = tab.c.shape[0]
    nx = x.shape[0]
    me = 2 * n if exact else nx
    for st in range(st0, S):
        if st == 0:
            for j in range(nx):
                xs[j] = x[j]
        else:
            for j in range(me):
                acc = 0.0
                for l in range(st):
                    acc += tab.a[st, l] * Ks[l, j]
                xs[j] = x[j] + h * acc
            if exact:
                _currents(plant, x, xs, U, tab.c[st] * h, n, ph[st], Ks[0, n:n], Ks[0, n:n],
                          0.0, 0.0)
        _rates(xs, U, dist, n, plant, q, qd, xd, dxd, tau, qdd, Ks, st, fext, awork)


@nb.njit(cache=True, no_cfunc_wrapper=True)  # no C-ABI entry: nothing uses one
def run_adaptive(plant, ctrl, ref, rec, work, k0, K, dt, every, last, stop_at_limits,
                 stride, hold, tab, rtol, atol, stats, exact):
    """Integrate from step k0 to k0+K (times k·dt, s) with error control; see the module.

    Args:
        plant, ctrl, rec, work: as :func:`manipcad.sim.loop.run` (``work.wait`` counts
            steps of dt to each regulator's next sample).
        ref: reference and disturbance rows at the steps k0, k0+stride, ... (every
            regulator period is a multiple of ``stride``).
        k0, K: first step and number of steps of dt; dt: s; every: keep every
            ``every``-th step; last: the run ends at k0+K (recorded if due).
        stop_at_limits: stop when a joint leaves its limits.
        stride: steps between reference rows; hold: most steps one held interval may
            span (1 when the disturbance changes every step).
        tab: a :class:`Tableau`; rtol (-), atol (rad, m, rad/s, m/s): the tolerance.
        stats: (STATS,) carried counters (see :data:`STATS`).
        exact: advance the rigid drives' currents by the exact formula (see the module).

    Returns:
        (status, step, joint) as :func:`manipcad.sim.loop.run`.

    The step never falls below ``dt`` (but to land on a sample instant): where the
    tolerance asks for less (a joint sticking in dry friction makes q̈ switch sign
    step after step, a discontinuity no step resolves), the step of ``dt`` is taken
    and counted in ``stats[4]``, so the run is never slower than the pair at ``dt``.
    """
    n = plant.rtable.shape[0]
    nx = work.x.shape[0]
    S = tab.c.shape[0]
    own = (np.empty((S, nx)), np.empty(nx), np.empty(nx), np.empty((1, nx)),
           np.zeros((S, n, 5)), np.empty((0, 5)), scratch(n, nx))
    # every array counts no reference inside the integration (:func:`borrowed`: the
    # caller holds the arguments, ``own`` is kept to each return): handed to the
    # functions called at every sample and step, they would count each, at every call.
    # All in this one function: numba optimizes a caller's module again with every callee
    # linked in, and a wrapper around the integration cost 6.6 s more of compile
    plant, ctrl, ref, rec, work, tab, stats, bare = borrowed(
        (plant, ctrl, ref, rec, work, tab, stats, own))
    Ks, xs, xr, Kd, ph, noph, scr = bare
    q, qd, qdd, xd, dxd, tau, sig, H, fext, awork, comp = scr
    x = work.x
    m = 2 * n
    U = work.U
    wait = work.wait
    R = ctrl.kind.shape[0]
    hph = -1.0
    expo = -1.0 / (tab.p + 1.0)
    hmin = dt * (1.0 + 1e-9)
    kend = k0 + K
    k = k0
    # q̈ at the state the last step ended on does not depend on U when every joint's
    # torque comes from a current state (and the disturbance is constant): reuse it,
    # unless a payload was picked up at the sample instant in between
    reuse = exact and plant.use_drives and hold > 1
    for j in range(n):
        if int(plant.dtable[j, P_KIND]) != KIND_RIGID:
            reuse = False
    have = False
    h = stats[0]
    # the stages from the second: an int64, not the literal 1 (numba compiles a callee
    # once for each literal int it is given: _stages, with the right-hand side, twice)
    ONE = np.intp(1)
    while True:
        kr = (k - k0) // stride
        dist = ref.dist[kr]
        # sample the regulators due at step k, as RK4 does (and pick up a payload due)
        picked = plant.pick.done[0]
        sample_due(plant, ctrl, x, U, k, kr, dt, ref, sig, H, comp, wait)
        if plant.pick.done[0] != picked:
            have = False  # the plant changed here: the carried q̈ is the old plant's
        if work.rec[0] * every == k:
            _torques(x, U, dist, n, plant, q, qd, xd, dxd, tau, Kd, 0)
            write_record(plant, rec, work.rec[0], k * dt, x, U, tau)
            work.rec[0] += 1
        if k >= kend:
            keep(own)
            return 0, k, -1
        # the held interval: up to the next sample, the chunk's end or the hold limit
        L = min(kend - k, hold)
        for r in range(R):
            L = min(L, wait[r])
        for r in range(R):
            wait[r] -= L
        T = L * dt
        t0 = k * dt
        if h <= 0.0:
            h = min(T, 1e-4)
        # the first stage (the rates at x) unless carried over: in the first step's
        # stage loop, so that the right-hand side is written (inlined) once
        st0 = 1 if reuse and have else 0
        have = True
        hyb = plant.ev.on
        if hyb and st0 == 0:
            # stick-slip friction, gear losses: the rates at x with consistent modes, and
            # the event values there (manipcad.sim.events); a carried first stage is
            # consistent already (the margins, as q̈, do not depend on U then)
            settle(plant, x, U, dist, n, scr, Ks, t0)
            event_values(plant, x, n, plant.ev.e0)
            stats[3] += 1
            st0 = 1
        s = 0.0
        while s < T:
            hs = h
            final = s + h >= T * (1.0 - 1e-12)
            if final:
                hs = T - s
            me = m if exact else nx
            if exact and hs != hph:
                _phi_table(plant, tab.c, hs, n, ph)
                hph = hs
            _stages(plant, x, xs, U, dist, n, scr, Ks, tab, hs, exact, ph, st0)
            stats[3] += S - st0
            st0 = 1
            # xs is now the new solution (last stage = b weights); the error of q, q̇
            err = 0.0
            for j in range(me):
                e = 0.0
                for l in range(S):
                    e += tab.e[l] * Ks[l, j]
                sc = atol + rtol * max(abs(x[j]), abs(xs[j]))
                err += (hs * e / sc) ** 2
            cnt = me
            if exact:
                # and of the currents: the linear speed (propagated) against the cubic
                ce, cc = _currents(plant, x, xs, U, hs, n, ph[S - 1], Ks[0, n:m],
                                   Ks[S - 1, n:m], rtol, atol)
                err += ce
                cnt += cc
            err = math.sqrt(err / cnt)
            if not math.isfinite(err):
                err = 1e10
            if err > 1.0 and hs > hmin:
                stats[2] += 1
                h = max(hmin, hs * max(0.2, 0.9 * err ** expo))
                continue
            stats[1] += 1
            if err > 1.0:
                stats[4] += 1
            event = False
            hfull = hs
            if hyb:
                ev = plant.ev
                values_at(plant, xs, n, ev.e1)
                if edge_due(ev, n, ev.e0, ev.e1) and release_edge(plant, x, n, ev.e0, ev.e1,
                                                                  t0 + s):
                    # a stuck joint on its band's edge at the step's start breaks away
                    # there: the step again from x
                    stats[1] -= 1
                    settle(plant, x, U, dist, n, scr, Ks, t0 + s)
                    stats[3] += 1
                    event_values(plant, x, n, ev.e0)
                    continue
                fhi = crossing(ev.e0, ev.e1)
                if fhi < 0.0:
                    # an event inside the step: the step cut at the first crossing (the
                    # Illinois method on the fraction θ of the step, each try a step of
                    # θ·hs with the same pair)
                    event = True
                    il = ev.il
                    th = bracket_start(il, fhi)
                    while th > 0.0:
                        if exact:
                            _phi_table(plant, tab.c, th * hs, n, ph)
                        _stages(plant, x, xs, U, dist, n, scr, Ks, tab, th * hs, exact, ph, ONE)
                        stats[3] += S - 1
                        event_values(plant, xs, n, ev.e1)
                        th = bracket_next(il, crossing(ev.e0, ev.e1))
                    ev.count[1] += int(il[5])
                    if il[4] == 0.0:
                        if exact:
                            _phi_table(plant, tab.c, il[2] * hs, n, ph)
                        _stages(plant, x, xs, U, dist, n, scr, Ks, tab, il[2] * hs, exact, ph,
                                ONE)
                        stats[3] += S - 1
                        event_values(plant, xs, n, ev.e1)
                    hfull = hs
                    hs = il[2] * hs
                    hph = hs if exact else hph
                    final = False
            # kept samples strictly inside this step: interpolate
            while True:
                kk = work.rec[0] * every
                tk = (kk - k) * dt
                if kk >= k + L or tk >= s + hs:
                    break
                th = (tk - s) / hs
                h00 = (1.0 + 2.0 * th) * (1.0 - th) ** 2
                h10 = th * (1.0 - th) ** 2
                h01 = th * th * (3.0 - 2.0 * th)
                h11 = th * th * (th - 1.0)
                for j in range(me):
                    xr[j] = (h00 * x[j] + h01 * xs[j]
                             + hs * (h10 * Ks[0, j] + h11 * Ks[S - 1, j]))
                if exact:
                    for j in range(m, nx):
                        xr[j] = x[j]
                    _currents(plant, x, xr, U, th * hs, n, noph, Ks[0, n:n], Ks[0, n:n],
                              0.0, 0.0)
                _torques(xr, U, dist, n, plant, q, qd, xd, dxd, tau, Kd, 0)
                write_record(plant, rec, work.rec[0], kk * dt, xr, U, tau)
                work.rec[0] += 1
            for j in range(nx):
                x[j] = xs[j]
                Ks[0, j] = Ks[S - 1, j]
            s = T if final else s + hs
            fac = 5.0 if err == 0.0 else min(5.0, max(0.2, 0.9 * err ** expo))
            # a step cut short to end on the sample instant keeps the longer proposal (cut
            # at an event: the proposal of the whole step)
            h = max(h, hs * fac, hmin) if final else max(hfull * fac, hmin)
            if hyb:
                ev = plant.ev
                if event:
                    switch(plant, x, n, ev.e0, ev.e1, t0 + s)
                    settle(plant, x, U, dist, n, scr, Ks, t0 + s)
                    stats[3] += 1
                    event_values(plant, x, n, ev.e0)
                else:
                    for j in range(ev.e0.shape[0]):
                        ev.e0[j] = ev.e1[j]
            kt = k + int(round(s / dt))
            status, joint = check_state(plant, work, x, Ks[0], t0 + s, stop_at_limits)
            if status:
                stats[0] = h
                keep(own)
                return status, kt, joint
        k += L
        stats[0] = h
        if k == kend and not last:
            keep(own)
            return 0, k, -1
