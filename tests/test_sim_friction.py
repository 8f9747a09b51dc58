"""Stick-slip friction and gear losses in the simulated plant (manipcad.sim.events).

Checked against independent implementations: one joint with Coulomb friction, an
armature current and a sampled PD, integrated by SciPy's ``solve_ivp`` with events
(rtol 1e-12), its stick and break-away instants and positions; the energy balance
of a run with gear losses; the sizing's currents on the same motion.
"""

from __future__ import annotations

import math

import numpy as np
import pytest
from scipy.integrate import solve_ivp

from manipcad.control import pid
from manipcad.errors import ManipcadError, ManipcadWarning
from manipcad.model.robot import Drive, Robot
from manipcad.sim import simulate

# one revolute joint about the vertical (no gravity torque): link inertia, drive with L
I_LINK = 0.05           # kg·m²
RATIO = 10.0
DRIVE = Drive(J=1e-4, ratio=RATIO, R=1.0, L=1e-3, k_m=0.1, k_w=0.1, k_u=1.0,
              M_f=(0.02, 0.03))
KP, KD, PERIOD = 40.0, 0.4, 1e-3           # V/rad, V·s/rad, s


def one_joint(drive: Drive = DRIVE) -> Robot:
    return Robot.from_arrays(
        "one", ["revolute"], [-1], np.eye(3)[None], np.zeros((1, 3)), [1.0],
        np.zeros((1, 3)), np.diag([0.01, 0.01, I_LINK])[None], drives=[drive])


class Sine:
    """The reference q*(t) = a·sin(w·t), rad, of one joint (``.sample`` as a trajectory)."""

    def __init__(self, a: float, w: float) -> None:
        self.a, self.w = a, w

    def at(self, t: float) -> tuple[float, float]:
        return self.a * math.sin(self.w * t), self.a * self.w * math.cos(self.w * t)

    def sample(self, t):
        t = np.asarray(t, dtype=float)[:, None]
        return (self.a * np.sin(self.w * t), self.a * self.w * np.cos(self.w * t),
                -self.a * self.w**2 * np.sin(self.w * t))


def oracle(q0: float, qd0: float, t_end: float, drive: Drive = DRIVE, ki: float = 0.0,
           ref: Sine | None = None, hi: float = math.inf):
    """The joint under the sampled PD (U = kp·(q* − q) + kd·(q̇* − q̇) held over each
    period, q* = 0 or ``ref`` at the sample; with ``ki`` the PID, + ki·Σ(q* − q)·T as
    :func:`manipcad.control.pid.pid_update`) by solve_ivp (rtol 1e-12) with events: q̇ = 0
    while slipping (the kinetic friction M_f against the motion), the holding torque at
    the static friction M_s while stuck; with ``hi`` a hard stop there (rad): reached, the
    joint is put on it at rest (mode 2) and held while its torque pushes into it or the
    static friction holds it. Returns the switches [(t, mode, q)]."""
    inertia = I_LINK + drive.J * RATIO**2
    kp_, kn_ = RATIO * drive.M_f[0], RATIO * drive.M_f[1]
    fp, fn = RATIO * drive.static_friction[0], RATIO * drive.static_friction[1]
    km, kw, R, L = drive.k_m, drive.k_w, drive.R, drive.L
    x = np.array([q0, qd0, 0.0])
    mode = float(np.sign(qd0))
    switches = []
    t = 0.0
    k = 0
    integ = 0.0

    def held(tau, mode):
        return -fn <= tau and (mode == 2.0 or tau <= fp)

    while t < t_end - 1e-12:
        qs, qds = (0.0, 0.0) if ref is None else ref.at(k * PERIOD)
        integ += (qs - x[0]) * PERIOD
        U = KP * (qs - x[0]) + KD * (qds - x[1]) + ki * integ
        t1 = min((k + 1) * PERIOD, t_end)
        for _ in range(20):
            if t >= t1 - 1e-15:
                break

            def rhs(_t, y, mode=mode, U=U):
                tau = RATIO * km * y[2]
                di = (U - R * y[2] - kw * RATIO * y[1]) / L
                if mode in (0.0, 2.0):
                    return [0.0, 0.0, di]
                return [y[1], (tau - (kp_ if mode > 0 else -kn_)) / inertia, di]

            def stop(_t, y, mode=mode):
                return mode * y[1] if mode in (1.0, -1.0) else 1.0
            stop.terminal = True
            stop.direction = -1.0

            def breakaway(_t, y, mode=mode):
                tau = RATIO * km * y[2]
                if mode == 0.0:
                    return min(fp - tau, tau + fn)
                return tau + fn if mode == 2.0 else 1.0
            breakaway.terminal = True
            breakaway.direction = -1.0

            def contact(_t, y, mode=mode):
                return hi - y[0] if mode == 1.0 and hi < math.inf else 1.0
            contact.terminal = True
            contact.direction = -1.0

            sol = solve_ivp(rhs, (t, t1), x, method="DOP853", rtol=1e-12, atol=1e-14,
                            events=(stop, breakaway, contact))
            assert sol.status >= 0
            x = sol.y[:, -1].copy()
            t = sol.t[-1]
            if sol.status == 1:          # an event: switch the mode
                tau = RATIO * km * x[2]
                if mode in (1.0, -1.0):  # it stops or reaches the stop; turned back at
                    x[1] = 0.0           # once if not held
                    if len(sol.t_events[2]):
                        x[0] = hi
                        mode = 2.0
                    else:
                        mode = 0.0
                    switches.append((t, mode, x[0]))
                    if not held(tau, mode):
                        mode = float(np.sign(tau))
                        switches.append((t, mode, x[0]))
                else:
                    mode = 1.0 if mode == 0.0 and tau > fp - 1e-12 else -1.0
                    switches.append((t, mode, x[0]))
        # a sample: a held joint whose drive now exceeds the band breaks away there
        if mode in (0.0, 2.0):
            tau = RATIO * km * x[2]
            if not held(tau, mode):
                mode = float(np.sign(tau))
                switches.append((t, mode, x[0]))
        k += 1
    return switches


@pytest.mark.parametrize("qd0, integrator, tol", [
    (3.0, "rk4", 1e-9), (-2.5, "rk4", 1e-9), (3.0, "adaptive", 1e-9),
    # the exact-current pair's own error on this joint is 2e-8 rad at rtol 1e-10 even
    # without friction (its current error is estimated through the joint speed)
    (-2.5, "adaptive-exact", 1e-6)])
def test_stick_slip_against_solve_ivp(qd0, integrator, tol):
    """Stick, turn-back and break-away instants within 1e-9 s of solve_ivp's, the
    positions held within 1e-9 rad, with either integrator."""
    t_end = 0.4
    want = oracle(0.0, qd0, t_end)
    adaptive = integrator != "rk4"
    res = simulate(one_joint(), t_end=t_end, dt=2e-5 if not adaptive else 1e-4,
                   q0=[0.0], qd0=[qd0], regulators=[pid(0, kp=KP, kd=KD, period=PERIOD)],
                   every=50 if not adaptive else 10, integrator=integrator,
                   **({"rtol": 1e-10, "atol": 1e-12} if adaptive else {}))
    assert len(want) >= 3 and any(m == 0.0 for _, m, _ in want)
    _agree(res, want, t_end, tol)


def _agree(res, want, t_end, tol):
    """The run's switches (joint 0) at the oracle's instants within ``tol`` s, the same
    modes, and the positions held while stuck within ``tol`` rad (q̇ = 0 exactly)."""
    got = res.events
    assert got.shape[0] == len(want), (got, want)
    for (t, m, _q), (tg, jg, mg) in zip(want, got, strict=True):
        assert mg == m and jg == 0
        assert abs(tg - t) < tol, (tg, t)
    # the positions where it stuck: the recorded q holds them until the next switch
    checked = 0
    for a, (t, m, q) in enumerate(want):
        if m not in (0.0, 2.0):
            continue
        t_next = want[a + 1][0] if a + 1 < len(want) else t_end
        held = (res.t > t + 1e-9) & (res.t < t_next - 1e-9)
        if t_next == t:         # turned back at once
            continue
        checked += 1
        assert np.abs(res.q[held, 0] - q).max() < tol, (t, q)
        assert np.all(res.qd[held, 0] == 0.0)
    assert checked >= 1


def test_static_friction_above_kinetic_against_solve_ivp():
    """M_s > M_f: a stopped joint holds until the drive's torque exceeds the static
    friction, then slides with the kinetic one. A PID (the integral winds up while the
    joint is stuck) against solve_ivp with events: the switches within 1e-9 s, the held
    positions within 1e-9 rad; where M_s = M_f turns the joint back at once, M_s holds it
    and breaks away later."""
    t_end, ki = 0.4, 400.0
    drive = DRIVE.replace(M_s=(0.035, 0.045))
    want = oracle(0.0, 3.0, t_end, drive, ki)
    plain = oracle(0.0, 3.0, t_end, DRIVE, ki)
    # the last stop: turned back at once with M_f, held for some 30 ms with M_s
    assert plain[-1][0] == plain[-2][0] and want[-1][0] - want[-2][0] > 0.02, (want, plain)
    res = simulate(one_joint(drive), t_end=t_end, dt=2e-5, q0=[0.0], qd0=[3.0],
                   regulators=[pid(0, kp=KP, ki=ki, kd=KD, period=PERIOD)],
                   every=50)
    _agree(res, want, t_end, 1e-9)


@pytest.mark.parametrize("integrator", ["rk4", "adaptive"])
def test_hard_stop_against_solve_ivp(integrator):
    """joint_limits="hard-stop": the joint (dry friction, PD on a sine beyond the stop)
    reaches its upper stop, is put on it at rest (inelastic) and held while its drive
    pushes into it, and leaves when the drive pulls away beyond the static friction: the
    instants within 1e-9 s of solve_ivp with events, the position on the stop to rounding,
    never beyond it."""
    t_end, hi = 0.3, 0.06
    ref = Sine(0.1, 2 * math.pi / 0.4)
    want = oracle(0.0, 0.0, t_end, ref=ref, hi=hi)
    assert [m for _, m, _ in want] == [1.0, 2.0, -1.0]
    robot = one_joint().replace(limits=np.array([[-1.0, hi]]))
    adaptive = integrator != "rk4"
    with pytest.warns(ManipcadWarning, match="reference leaves the joint limits"):
        res = simulate(robot, t_end=t_end, dt=1e-4 if adaptive else 2e-5, trajectory=ref,
                       regulators=[pid(0, kp=KP, kd=KD, period=PERIOD)],
                       joint_limits="hard-stop", every=10 if adaptive else 50,
                       integrator=integrator,
                       **({"rtol": 1e-10, "atol": 1e-12} if adaptive else {}))
    _agree(res, want, t_end, 1e-9)
    assert res.q.max() <= hi + 1e-15
    on = (res.t > want[1][0]) & (res.t < want[2][0])
    # held on the stop: pushed into it, then pulled away but less than the friction holds
    assert np.abs(res.q[on, 0] - hi).max() <= 1e-15
    assert res.tau[on, 0].max() > 1.0 and -RATIO * DRIVE.M_f[1] < res.tau[on, 0].min() < 0
    with pytest.raises(ManipcadError, match="beyond its stops"):
        simulate(robot, t_end=0.01, q0=[0.07], joint_limits="hard-stop")


def test_hard_stop_impact_keeps_the_momentum_of_the_free_joint():
    """A passive planar two-link arm turning about vertical axes (no torque on joint 1): the
    elbow hits its stop and the impact's impulse acts through the coupled inertia, so the
    momentum conjugate to joint 1, (H·q̇)_1, is the same before, across and after the
    impact (setting the elbow's speed to 0 alone would change it by H_12·q̇_2); the elbow
    never passes its stop."""
    import manipcad

    arm = Robot.from_arrays(
        "planar", ["revolute", "revolute"], [-1, 0], np.stack([np.eye(3)] * 2),
        np.array([[0.0, 0.0, 0.0], [0.4, 0.0, 0.0]]), [3.0, 2.0],
        np.array([[0.2, 0.0, 0.0], [0.15, 0.0, 0.0]]),
        np.stack([np.diag([0.01, 0.04, 0.04]), np.diag([0.005, 0.02, 0.02])]),
        limits=np.array([[-math.pi, math.pi], [-0.5, 0.3]]))
    res = simulate(arm, t_end=0.5, dt=1e-4, q0=[0.0, 0.0], qd0=[1.0, 2.0], drives=False,
                   joint_limits="hard-stop", every=10)
    assert res.events[:, 1:].tolist()[0] == [1.0, 2.0]     # the elbow reaches its stop
    assert res.q[:, 1].max() <= 0.3
    H = manipcad.mass_matrix(arm, res.q, drives=False)
    p1 = np.einsum("kj,kj->k", H[:, 0, :], res.qd)
    assert np.abs(p1 - p1[0]).max() < 1e-9 * abs(p1[0]), np.abs(p1 - p1[0]).max()


# ------------------------------------------------------------ gear losses
def rot_x(a):
    c, s = math.cos(a), math.sin(a)
    return np.array([[1.0, 0.0, 0.0], [0.0, c, -s], [0.0, s, c]])


def lossy_arm(eta=(0.7, 0.85), M_f=((0.01, 0.012), (0.004, 0.005))) -> Robot:
    """Two links in a vertical plane (gravity loads both joints), drives with inductance,
    dry friction and gears of efficiency ``eta``."""
    drives = [Drive(J=1e-4, ratio=r, k_v=1e-5, M_f=mf, R=1.0, L=1e-3, k_m=0.1, k_w=0.1,
                    k_u=1.0, efficiency=e) for r, mf, e in zip((50.0, 30.0), M_f, eta,
                                                                strict=True)]
    return Robot.from_arrays(
        "arm2", ["revolute", "revolute"], [-1, 0], np.stack([rot_x(math.pi / 2), np.eye(3)]),
        np.array([[0.0, 0.0, 0.0], [0.4, 0.0, 0.0]]), [3.0, 2.0],
        np.array([[0.2, 0.0, 0.0], [0.15, 0.0, 0.0]]),
        np.stack([np.diag([0.01, 0.04, 0.04]), np.diag([0.005, 0.02, 0.02])]), drives=drives)


def _arm_run(robot, t_end=0.6, dt=2e-5, integrator="rk4", amplitude=(0.6, -0.8)):
    from manipcad.trajectories import cosine

    traj = cosine(list(amplitude), [2 * math.pi / t_end, 2 * math.pi / t_end], t_end)
    regs = [pid(0, kp=400.0, ki=2000.0, kd=8.0, kff=5.0, period=1e-3),
            pid(1, kp=300.0, ki=1500.0, kd=5.0, kff=3.0, period=1e-3)]
    return simulate(robot, t_end=t_end, dt=dt, trajectory=traj, regulators=regs,
                    integrator=integrator), traj


def test_energy_balance_with_gear_losses():
    """∫u_a·i = ∫R·i² + Δ½L·i² + Δ(kinetic + potential) + ∫(k_v·ω² + M_f·|ω|) + ∫gear
    loss, the gear loss (f − 1)·P·q̇ with the sizing's factor f of the rigid-body torque
    P (inverse dynamics of the simulated motion)."""
    from scipy.integrate import simpson

    import manipcad
    from manipcad.sizing.motor import efficiency_factor

    robot = lossy_arm()
    res, _ = _arm_run(robot)
    t, q, qd = res.t, res.q, res.qd
    qdd = np.gradient(qd, t, axis=0, edge_order=2)
    P = manipcad.inverse_dynamics(robot, q, qd, qdd, drives=False)
    grav = manipcad.inverse_dynamics(robot, q, 0 * q, 0 * q, drives=False)
    Hd = manipcad.mass_matrix(robot, q, drives=True)
    kin = 0.5 * np.einsum("ki,kij,kj->k", qd, Hd, qd)
    e_in = e_r = e_l = e_fric = e_gear = 0.0
    motoring = braking = 0
    for j, d in enumerate(robot.drives):
        i, w = res.current[:, j], qd[:, j]
        # U is held over each step (the record keeps it at the step's start): exactly
        e_in += np.sum(d.k_u * res.u[:-1, j] * 0.5 * (i[1:] + i[:-1]) * np.diff(t))
        e_r += simpson(d.R * i**2, x=t)
        e_l += 0.5 * d.L * (i[-1] ** 2 - i[0] ** 2)
        mf = np.where(w > 0, d.M_f[0], d.M_f[1])
        e_fric += simpson(d.k_v * d.ratio**2 * w**2 + abs(d.ratio) * mf * np.abs(w),
                          x=t)
        f = efficiency_factor(d, P[:, j], w)
        e_gear += simpson((f - 1.0) * P[:, j] * w, x=t)
        moving = np.abs(w) > 1e-3
        motoring += int(np.sum(moving & (P[:, j] * w > 0)))
        braking += int(np.sum(moving & (P[:, j] * w < 0)))
    e_pot = simpson(np.sum(grav * qd, axis=1), x=t)
    e_kin = kin[-1] - kin[0]
    assert motoring > 1000 and braking > 1000          # the gears work both ways
    assert e_gear > 0.1 * e_in                         # the losses are not negligible
    residual = e_in - (e_r + e_l + e_kin + e_pot + e_fric + e_gear)
    assert abs(residual) < 1e-6 * e_in, (residual, e_in, e_gear)


def test_simulated_currents_agree_with_the_sizing():
    """The same motion sized and simulated: RMS currents within 2 % (the regulator tracks
    within 2e-2 rad), with the gears' losses on both sides; the losses move both by
    more than that (joint 1: η = 0.7). (The peaks differ where the joint sticks at a
    reversal and the integral breaks it away, which the sizing does not model.)"""
    from manipcad.sizing import required_drive

    rms = {}
    for eta in ((0.7, 0.85), (1.0, 1.0)):
        robot = lossy_arm(eta=eta)
        res, traj = _arm_run(robot, t_end=1.2, dt=5e-5, amplitude=(0.3, -0.4))
        req = required_drive(robot, traj, t_end=1.2, dt=1e-4)
        rms[eta] = np.sqrt(np.mean(res.current**2, axis=0))
        assert np.abs(res.q - res.q_ref).max() < 2e-2
        assert np.allclose(rms[eta], req.rms_current, rtol=0.02), (eta, rms[eta],
                                                                    req.rms_current)
    assert rms[(0.7, 0.85)][0] > 1.1 * rms[(1.0, 1.0)][0]
