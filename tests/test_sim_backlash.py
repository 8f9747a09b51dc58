"""Elastic gears with backlash in the simulated plant: the gap's contact, the motor
shaft's stick-slip friction and the joint's hard stops as located events
(manipcad.sim.events), checked against SciPy's ``solve_ivp`` with events (DOP853, rtol
1e-12) on one joint under a sampled PD.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from manipcad.control import pid
from manipcad.drives.params import Transmission
from manipcad.errors import ManipcadWarning
from manipcad.model.robot import Drive, Robot
from manipcad.sim import simulate
from manipcad.trajectories import cosine

I_LINK, RATIO = 0.05, 10.0                    # kg·m², -
K_S, D_S, GAP = 2000.0, 0.5, 2e-3             # N·m/rad, N·m·s/rad, rad (joint side)
KP, KD, PERIOD = 40.0, 0.4, 1e-3              # V/rad, V·s/rad, s
A, W = 0.05, 10 * math.pi                     # the reference A·(1 − cos W·t), rad, rad/s
DRIVE = Drive(J=1e-4, ratio=RATIO, R=1.0, L=1e-3, k_m=0.1, k_w=0.1, k_u=1.0,
              M_f=(0.02, 0.03), M_s=(0.03, 0.04))


def one_joint(drive: Drive = DRIVE, limits=None) -> Robot:
    return Robot.from_arrays(
        "one", ["revolute"], [-1], np.eye(3)[None], np.zeros((1, 3)), [1.0],
        np.zeros((1, 3)), np.diag([0.01, 0.01, I_LINK])[None], drives=[drive],
        limits=limits)


def run(dt, t_end, drive=DRIVE, hi=None, **kw):
    robot = one_joint(drive, None if hi is None else np.array([[-1.0, hi]]))
    return simulate(robot, t_end=t_end, dt=dt, trajectory=cosine(A, W, 0.4),
                    regulators=[pid(0, kp=KP, kd=KD, period=PERIOD)],
                    transmissions=[Transmission(K_S, D_S, GAP)],
                    every=max(1, int(round(PERIOD / dt))),
                    **({"joint_limits": "hard-stop"} if hi is not None else {}), **kw)


def oracle(t_end: float, drive: Drive = DRIVE, hi: float = math.inf):
    """The joint, its gear and motor under the sampled PD (U = kp·(q* − q) + kd·(q̇* − q̇)
    held over each period) by solve_ivp with terminal events, written from the model's
    equations: τ_s = k_s·(δ − c·b) + d_s·δ̇ with the contact mode c (0 in the gap),
    J·ω̇_m = k_m·i − k_v·ω_m − M_f(s) − τ_s/i_r with the shaft's mode s (0 stuck: ω_m = 0,
    held while −M_s⁻ ≤ k_m·i − τ_s/i_r ≤ M_s⁺), I·q̈ = τ_s, L·di/dt = U − R·i − k_w·ω_m;
    with ``hi`` a hard stop (the joint put on it at rest, held while τ_s pushes into it:
    it leaves when the contact opens or pulls).

    Returns (switches [(t, code)] with the simulator's codes: 10 + c, 20 + s, 2 on the
    stop, -1 off it; and the state at each sample instant, (K, 5): q, q̇, θ_m, ω_m, i).
    """
    J, km, kw, R, L = drive.J, drive.k_m, drive.k_w, drive.R, drive.L
    mfp, mfn = drive.M_f
    msp, msn = drive.static_friction
    y = np.zeros(5)
    c, s, on, edge = 0.0, 0.0, False, False
    out, switches = [y.copy()], []
    t, k = 0.0, 0

    def torque(y, c):
        d, dd = y[2] / RATIO - y[0], y[3] / RATIO - y[1]
        return 0.0 if c == 0.0 else K_S * (d - c * GAP) + D_S * dd

    def shaft(y, c):
        return km * y[4] - torque(y, c) / RATIO

    def contact_value(y, c):
        d, dd = y[2] / RATIO - y[0], y[3] / RATIO - y[1]
        up = (K_S * (d - GAP) + D_S * dd) / K_S
        lo = (K_S * (d + GAP) + D_S * dd) / K_S
        return up if c > 0 else -lo if c < 0 else min(max(GAP - d, -up), max(d + GAP, lo))

    def check_shaft(y, s):
        T = shaft(y, c)
        if s == 0.0 and not (-msn <= T <= msp):
            s = 1.0 if T > msp else -1.0
            switches.append((t, 20.0 + s))
        return s

    s = check_shaft(y, s)
    while t < t_end - 1e-12:
        tk = k * PERIOD
        U = KP * (A * (1 - math.cos(W * tk)) - y[0]) + KD * (A * W * math.sin(W * tk) - y[1])
        t1 = min((k + 1) * PERIOD, t_end)
        for _ in range(30):
            if t >= t1 - 1e-15:
                break

            def rhs(_t, y, c=c, s=s, on=on, U=U):
                tau = torque(y, c)
                di = (U - R * y[4] - kw * y[3]) / L
                if s == 0.0:
                    dth, dw = 0.0, 0.0
                else:
                    f = mfp if s > 0 else -mfn
                    dth, dw = y[3], (km * y[4] - drive.k_v * y[3] - f - tau / RATIO) / J
                dq, dqd = (0.0, 0.0) if on else (y[1], tau / I_LINK)
                return [dq, dqd, dth, dw, di]

            def ev_contact(_t, y, c=c):
                return contact_value(y, c)

            def ev_shaft(_t, y, c=c, s=s):
                T = shaft(y, c)
                return s * y[3] if s != 0.0 else min(msp - T, T + msn)

            def ev_stop(_t, y, on=on, edge=edge):
                # on the stop (or left on it unloaded) it goes with the gear's contact
                return 1.0 if on or edge else hi - y[0]

            for e in (ev_contact, ev_shaft, ev_stop):
                e.terminal, e.direction = True, -1.0
            sol = solve_ivp(rhs, (t, t1), y, method="DOP853", rtol=1e-12, atol=1e-14,
                            events=(ev_contact, ev_shaft, ev_stop))
            assert sol.status >= 0
            y, t = sol.y[:, -1].copy(), sol.t[-1]
            if sol.status != 1:
                continue
            if len(sol.t_events[0]):
                if c != 0.0 and on:     # the gear stops pushing: the joint leaves,
                    on, edge = False, True  # at rest on the stop, unloaded
                    switches.append((t, -1.0))
                c = (1.0 if y[2] / RATIO - y[0] > 0 else -1.0) if c == 0.0 else 0.0
                switches.append((t, 10.0 + c))
                if edge and c != 0.0:   # pushed into the stop again, or pulled off it
                    edge = False
                    if c > 0.0:
                        on = True
                        switches.append((t, 2.0))
            if len(sol.t_events[1]):
                if s == 0.0:
                    s = 1.0 if shaft(y, c) > 0 else -1.0
                    switches.append((t, 20.0 + s))
                else:
                    s, y[3] = 0.0, 0.0
                    switches.append((t, 20.0))
                    s = check_shaft(y, s)
            if len(sol.t_events[2]):
                on, y[0], y[1] = True, hi, 0.0
                switches.append((t, 2.0))
            if on and torque(y, c) < 0.0:     # the contact closed on the pulling flank
                on = False
                switches.append((t, -1.0))
        k += 1
        out.append(y.copy())
    return switches, np.array(out)


def _agree(res, want, tol_t):
    got = res.events
    assert got.shape[0] == len(want), (got, want)
    for (t, code), (tg, jg, cg) in zip(want, got, strict=True):
        assert cg == code and jg == 0, (got, want)
        assert abs(tg - t) < tol_t, (tg, t, code)


T_END = 0.25


@pytest.fixture(scope="module")
def want():
    return oracle(T_END)


#: the integrators checked: RK4 at dt 2e-5 s, Dormand–Prince 5(4) at rtol 1e-10 on a 1e-4 s
#: grid; measured against the oracle (switch instants s, q rad, q̇ rad/s, i A):
#: RK4 1.6e-12, 1.4e-13, 2.5e-11, 2.2e-10; adaptive 3.8e-12, 5.0e-13, 3.4e-11, 3.2e-10
RUNS = {"rk4": dict(dt=2e-5), "adaptive": dict(dt=1e-4, integrator="adaptive", rtol=1e-10,
                                               atol=1e-12)}


@pytest.mark.parametrize("integrator", ["rk4", "adaptive"])
def test_backlash_and_shaft_stick_slip_against_solve_ivp(want, integrator):
    """The gap's contact (closing, opening) and the motor shaft's stick and break-away
    (M_s > M_f) at solve_ivp's instants: within 1e-10 s, the joint at every sample within
    5e-12 rad, its speed within 1e-10 rad/s and the armature current within 1e-9 A (the
    figures reached: :data:`RUNS`)."""
    switches, states = want
    codes = [c for _, c in switches]
    assert {11.0, 9.0, 10.0, 20.0, 21.0, 19.0} <= set(codes)
    res = run(t_end=T_END, **RUNS[integrator])
    _agree(res, switches, 1e-10)
    assert np.abs(res.q[:, 0] - states[:, 0]).max() < 5e-12
    assert np.abs(res.qd[:, 0] - states[:, 1]).max() < 1e-10
    assert np.abs(res.current[:, 0] - states[:, 4]).max() < 1e-9


def test_rk4_converges_at_fourth_order_through_the_gap(want):
    """RK4 at dt 2e-4 and 1e-4 s against the oracle at the samples: halving dt cuts the
    joint's error more than 10x (measured 1.43e-9 and 8.7e-11 rad, 16.4x; with the gap's
    kinks and the shaft's sign friction integrated across, the error was 5.9e-5 and
    5.6e-5 rad)."""
    _, states = want
    err = [np.abs(run(dt, T_END).q[:, 0] - states[:, 0]).max() for dt in (2e-4, 1e-4)]
    assert err[0] / err[1] > 10.0, err
    assert err[1] < 2e-10, err


@pytest.mark.parametrize("integrator", ["rk4", "adaptive"])
def test_hard_stop_on_an_elastic_gear_against_solve_ivp(integrator):
    """joint_limits="hard-stop" with an elastic gear: the joint reaches its stop (put on it
    at rest) and stays there while the motor keeps winding the spring (the gear's torque
    rising from its value at the impact), its shaft sticking and slipping under the PD; it
    leaves when the gear stops pushing. Against solve_ivp with events: the instants within
    1e-10 s (measured 6.7e-12 s RK4, 4.2e-12 s adaptive), the joint within 5e-12 rad
    (7.8e-14, 5.0e-13) and never beyond its stop."""
    hi, t_end = 0.03, 0.2
    switches, states = oracle(t_end, hi=hi)
    codes = [c for _, c in switches]
    assert 2.0 in codes and -1.0 in codes and codes.count(20.0) >= 3
    with pytest.warns(ManipcadWarning, match="reference leaves the joint limits"):
        res = run(t_end=t_end, hi=hi, **RUNS[integrator])
    _agree(res, switches, 1e-10)
    assert np.abs(res.q[:, 0] - states[:, 0]).max() < 5e-12
    assert res.q.max() <= hi
    t_on, t_off = switches[codes.index(2.0)][0], switches[codes.index(-1.0)][0]
    on = (res.t > t_on) & (res.t < t_off)
    assert np.all(res.q[on, 0] == hi) and np.all(res.qd[on, 0] == 0.0)
    # the spring wound up while held: its torque rises well above the impact's
    at_impact = res.tau[np.searchsorted(res.t, t_on), 0]
    assert res.tau[on, 0].max() > 2.0 + at_impact
