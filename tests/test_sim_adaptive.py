"""The adaptive integrator (manipcad.sim.adaptive) against fixed-step RK4 at dt 1e-5.

RK4 at dt = 1e-5 s is the reference (RK4 at 1e-4 agrees with it to 3e-11 rad on the
PUMA job without dry friction). Dry (sign) friction is left out of the PUMA job: a joint
sticking in it makes q̈ switch sign at every step, a discontinuity no integrator
resolves (RK4 at 1e-4 and at 1e-5 differ by 9e-6 rad there), so no tolerance is
meaningful.
"""

from __future__ import annotations

import warnings

import numpy as np
import pytest
from scipy.integrate import solve_ivp

import manipcad
from manipcad.control import pid
from manipcad.drives.dc import (
    armature_current_poly,
    armature_current_rate,
    phis,
)
from manipcad.drives.params import pack_drive
from manipcad.errors import ManipcadError, ManipcadWarning
from manipcad.model.robot import Drive
from manipcad.sim import simulate
from manipcad.sim.adaptive import TABLEAUS
from manipcad.trajectories import quintic

KP = np.array([-930.0, 950.0, -580.0, 320.0, 340.0, 320.0])
KD = np.array([-27.0, 9.0, -4.5, 8.3, 9.5, 8.3])
KFF = np.array([-14.28, 24.58, -12.25, 5.70, 5.39, 5.75])
Q_START = np.array([0.0, 0.5, -0.5, 0.0, 0.3, 0.0])
Q_END = np.array([0.8, 0.2, -0.1, 0.5, -0.3, 1.0])
T_END = 0.15


@pytest.fixture(scope="module")
def puma():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        arm = manipcad.load_robot("puma560")
    return arm.replace(drives=tuple(d.replace(M_f=0.0) for d in arm.drives))


def pd_regs(period=1e-3):
    """The PD of examples/pid_puma.yaml (integral left out), sampled at 1 kHz."""
    return [pid(j, kp=KP[j], kd=KD[j], kff=KFF[j], u_limit=40.0, period=period)
            for j in range(6)]


def sample_instants(res, tol=1e-12):
    """Times (s) at which some regulator output changed between kept samples."""
    changed = np.abs(np.diff(res.u, axis=0)).max(axis=1) > tol
    return res.t[1:][changed]


def test_armature_current_with_linear_speed_is_the_exact_solution():
    """Against solve_ivp (DOP853, rtol 1e-12) of L·di/dt + R·i + k_w·ω(t) = u_a with ω
    linear (the adaptive integrator's stages), from a step much shorter than L/R to ten
    L/R, and in saturation."""
    p = pack_drive(Drive(ratio=50.0, R=1.6, L=5e-4, k_m=0.26, k_w=0.26, k_u=2.0, u_max=40.0))
    for i0, U, w0, w1, t in [(0.5, 3.0, 10.0, 14.0, 1e-6), (0.5, 3.0, 10.0, 14.0, 2e-4),
                             (-2.0, -1.0, 5.0, -30.0, 3e-3), (1.0, 30.0, 0.0, 50.0, 1e-3)]:
        def rate(s, y, U=U, w0=w0, w1=w1, t=t):
            return [armature_current_rate(y[0], U, w0 + (w1 - w0) * s / t, p)]

        sol = solve_ivp(rate,
                        (0.0, t), [i0], method="DOP853", rtol=1e-12, atol=1e-14)
        exact = sol.y[0, -1]
        got = armature_current_poly(i0, U, w0, (w1 - w0) / t, 0.0, 0.0, t, p)
        assert got == pytest.approx(exact, rel=1e-9, abs=1e-12), (i0, U, w0, w1, t)
    assert armature_current_poly(0.7, 3.0, 1.0, 1e3, 0.0, 0.0, 0.0, p) == 0.7


def test_armature_current_poly_is_the_exact_solution():
    """The same with the motor speed a cubic in time (the adaptive integrator's error
    estimate), across |λ·t| from 2e-3 (the φ series) to 30 (the recurrence)."""
    p = pack_drive(Drive(ratio=50.0, R=1.6, L=5e-4, k_m=0.26, k_w=0.26, k_u=2.0, u_max=40.0))
    for i0, U, w0, w1, w2, w3, t in [(0.5, 3.0, 10.0, 4e3, -2e6, 3e9, 1e-6),
                                     (0.5, 3.0, 10.0, 4e3, -2e6, 3e9, 6e-4),
                                     (-2.0, 30.0, 5.0, -3e4, 1e7, -1e10, 1e-3),
                                     (1.0, -3.0, 0.0, 1e2, 5e4, 2e6, 1e-2)]:
        def rate(s, y, U=U, w=(w0, w1, w2, w3)):
            return [armature_current_rate(y[0], U, w[0] + s * (w[1] + s * (w[2] + s * w[3])), p)]

        sol = solve_ivp(rate, (0.0, t), [i0], method="DOP853", rtol=1e-12, atol=1e-14)
        got = armature_current_poly(i0, U, w0, w1, w2, w3, t, p)
        assert got == pytest.approx(sol.y[0, -1], rel=1e-9, abs=1e-11), (i0, U, t)
    # φ_k by its definition where that is not cancelling, and φ_k(0) = 1/k!
    for z in (-30.0, -3.0, -1.0 - 1e-12, -0.999, -0.3, 0.5):
        e = np.exp(z)
        want = [e, (e - 1) / z, (e - 1 - z) / z ** 2, (e - 1 - z - z * z / 2) / z ** 3]
        for k in range(4):
            assert phis(z)[k] == pytest.approx(want[k], rel=1e-8 if abs(z) < 1 else 1e-12)
    # either side of the switch from the series to the recurrence (|z| = 1)
    for k in range(5):
        assert phis(-1.0 + 1e-9)[k] == pytest.approx(phis(-1.0 - 1e-9)[k], rel=1e-8)
    assert phis(0.0) == (1.0, 1.0, 0.5, 1 / 6, 1 / 24)


@pytest.mark.parametrize("integrator", ["adaptive", "adaptive-exact", "adaptive-bs32",
                                        "adaptive-exact-bs32"])
def test_puma_pd_matches_rk4_at_1e_5(puma, integrator):
    """PUMA 560, 6 drives with L, PD at 1 kHz: adaptive (rtol 1e-6, atol 1e-8, grid
    1e-4 s) within 1e-6 rad of RK4 at dt 1e-5 at every kept sample (1 kHz), the
    regulators sampled at the same instants. "adaptive-exact" in fewer right-hand sides
    (RK4 at 1e-4: 40 per ms; measured 14.4, every error controlled, the currents'
    included; "adaptive", bounded by the currents' stability and transients, takes 48
    over this start)."""
    traj = quintic(Q_START, Q_END, 1.0)
    ref = simulate(puma, t_end=T_END, dt=1e-5, trajectory=traj, regulators=pd_regs(),
                   every=10)
    ada = simulate(puma, t_end=T_END, dt=1e-4, trajectory=traj, regulators=pd_regs(),
                   integrator=integrator, rtol=1e-6, atol=1e-8)
    assert ada.t.shape == ref.t.shape
    np.testing.assert_allclose(ada.t, ref.t, atol=1e-15, rtol=0)
    dq = np.abs(ada.q - ref.q).max()
    assert dq <= 1e-6, dq
    assert dq > 0.0  # not the same integrator by accident
    assert np.abs(ada.current - ref.current).max() < 1e-3  # A (currents ~ 1-10 A)
    # the same sample instants: U changes exactly at the multiples of 1 ms in both
    si_ref, si_ada = sample_instants(ref), sample_instants(ada)
    assert len(si_ada) > 0.9 * T_END / 1e-3
    np.testing.assert_allclose(si_ada, si_ref, rtol=0, atol=1e-12)
    assert np.allclose(np.round(si_ada / 1e-3), si_ada / 1e-3, atol=1e-9)
    # the held outputs themselves agree (V)
    assert np.abs(ada.u - ref.u).max() < 1e-3
    s = ada.settings
    assert s["integrator"] == integrator and s["rtol"] == 1e-6
    per_ms = s["rhs_evaluations"] / (T_END / 1e-3)
    if integrator == "adaptive-exact":
        assert per_ms < 20, per_ms


def test_asvs_switching_matches_rk4_at_1e_5():
    """The cylindrical arm: ASVS (a switching law) on the turn, PID on the lift, LQR on
    the reach, all at 1 kHz, a 0.1 rad step: both adaptive integrators within 1e-6 of
    RK4 at 1e-5, the switching law sampled at the same instants with the same signs.
    "adaptive-exact" once advanced the currents with the motor speed taken linear over
    each stage and did not see that error: 7e-4 m on the LQR-driven reach; its error
    estimate now holds the currents' (1e-9 m measured)."""
    arm = manipcad.load_robot("cylindrical")
    # without dry friction: a joint sticking in it has no converged solution (RK4 at
    # 1e-4 and 1e-5 differ by 1.3e-3 m on the reach here)
    arm = arm.replace(drives=tuple(d.replace(M_f=0.0) for d in arm.drives))
    regs = lambda: [manipcad.synthesize(arm, "turn", "asvs", period=1e-3),  # noqa: E731
                    manipcad.synthesize(arm, "lift", "pid", period=1e-3),
                    manipcad.synthesize(arm, "reach", "lqr", period=1e-3)]

    class Step:
        def sample(self, t):
            z = np.zeros((len(t), 3))
            return np.tile([0.1, 0.0, 0.25], (len(t), 1)), z, z.copy()

    kw = dict(t_end=0.08, trajectory=Step(), q0=[0.0, 0.0, 0.25])
    ref = simulate(arm, dt=1e-5, regulators=regs(), every=10, **kw)
    for integrator, rtol in (("adaptive", 1e-6), ("adaptive-exact", 1e-7)):
        ada = simulate(arm, dt=1e-4, regulators=regs(), integrator=integrator, rtol=rtol,
                       **kw)
        dq = np.abs(ada.q - ref.q).max(axis=0)
        assert dq.max() <= 1e-6, (integrator, dq)
        assert dq[2] <= 1e-7, (integrator, dq)   # the reach (m)
        np.testing.assert_allclose(sample_instants(ada), sample_instants(ref), rtol=0,
                                   atol=1e-12)
        # the relay's sign at every sample is the same
        assert np.array_equal(np.sign(np.round(ada.u[:, 0], 6)), np.sign(np.round(ref.u[:, 0], 6)))


def test_record_times_and_interpolation_match_rk4(puma):
    """Kept samples every 1e-4 s (inside the adaptive steps: interpolated) at RK4's times
    and within 1e-6 rad of RK4 at 1e-5; U held between the 1 kHz samples."""
    traj = quintic(Q_START, Q_END, 1.0)
    ref = simulate(puma, t_end=0.03, dt=1e-5, trajectory=traj, regulators=pd_regs(),
                   every=10)
    ada = simulate(puma, t_end=0.03, dt=1e-4, trajectory=traj, regulators=pd_regs(),
                   integrator="adaptive")
    assert ada.q.shape == (301, 6)
    np.testing.assert_allclose(ada.t, ref.t, atol=1e-15, rtol=0)
    assert np.abs(ada.q - ref.q).max() <= 1e-6
    assert np.abs(ada.qd - ref.qd).max() <= 1e-4


@pytest.mark.parametrize("kw, what", [
    (dict(integrator="euler"), "integrator"),
    (dict(integrator="adaptive", rtol=0.0), "rtol"),
    (dict(integrator="adaptive", rtol=float("nan")), "rtol"),
    (dict(integrator="adaptive", atol=-1e-9), "atol"),
    (dict(integrator="adaptive", atol=float("inf")), "atol"),
    (dict(integrator="adaptive", rtol="tight"), "rtol"),
    (dict(rtol=1e-6), "rtol"),
])
def test_bad_integrator_options(kw, what):
    arm = manipcad.load_robot("cylindrical")
    with pytest.raises(ManipcadError, match=what):
        simulate(arm, t_end=0.01, dt=1e-3, drives=False, **kw)


def test_adaptive_exact_refuses_elastic_gears():
    from manipcad.drives.params import Transmission

    arm = manipcad.load_robot("cylindrical")
    tr = [Transmission(stiffness=5e3, damping=1.0), None, None]
    with pytest.raises(ManipcadError, match="rigid drives' currents exactly.*'adaptive'"):
        simulate(arm, t_end=0.01, dt=1e-4, transmissions=tr, integrator="adaptive-exact")


def test_cli_integrator_options(tmp_path):
    from typer.testing import CliRunner

    from manipcad.cli import app

    traj = tmp_path / "move.yaml"
    traj.write_text("type: quintic\nq_start: [0, 0, 0.1]\nq_end: [0.05, 0, 0.1]\n"
                    "duration: 0.02\n")
    runner = CliRunner()
    base = ["simulate", "cylindrical", "-t", str(traj), "--no-drives"]
    res = runner.invoke(app, [*base, "-o", str(tmp_path / "a"), "--integrator", "adaptive",
                              "--rtol", "1e-7", "--json"])
    assert res.exit_code == 0, res.output
    res = runner.invoke(app, [*base, "-o", str(tmp_path / "b"), "--integrator", "rk5"])
    assert res.exit_code == 2
    assert "integrator" in res.output and "Traceback" not in res.output
    assert not (tmp_path / "b").exists()


def test_divergence_limits_and_progress_as_rk4(puma):
    """Divergence named with time and joint, joints beyond their limits warned or
    stopped at (about) the same time as RK4, progress reported up to 1."""
    from manipcad.sim import JointLimitExceeded, SimulationDiverged

    regs = [pid("elbow", kp=-1e6, kd=-1e4, period=1e-3)]  # absurd negative gains
    with pytest.raises(SimulationDiverged, match=r"diverged at t = .* joint '") as info:
        simulate(puma, t_end=2.0, dt=1e-4, regulators=regs, drives=False,
                 q0=[0.0, 0.5, -0.5, 0.0, 0.0, 0.0], integrator="adaptive")
    assert 0 < len(info.value.result.t) < 2001
    assert np.isfinite(info.value.result.q).all()

    traj = quintic(Q_START, Q_END, 1.0)
    narrow = puma.replace(limits=np.array([[-0.1, 0.1]] + [[-3.0, 3.0]] * 5))
    kw = dict(t_end=0.5, dt=1e-4, trajectory=traj, regulators=pd_regs(), every=10)
    with pytest.raises(JointLimitExceeded, match=r"'waist' left its limits") as rk4:
        simulate(narrow, joint_limits="stop", **kw)
    done = []
    with pytest.raises(JointLimitExceeded, match=r"'waist' left its limits") as ada:
        simulate(narrow, joint_limits="stop", integrator="adaptive-exact",
                 progress=done.append, **kw)
    t_rk4 = float(str(rk4.value).split("t = ")[1].split(" s")[0])
    t_ada = float(str(ada.value).split("t = ")[1].split(" s")[0])
    assert abs(t_ada - t_rk4) <= 1e-3  # within one step of the adaptive one (<= 1 ms)
    with pytest.warns(ManipcadWarning, match="'waist' by up to"):
        res = simulate(narrow, integrator="adaptive-exact", progress=done.append, **kw)
    assert res.metrics["waist"]["limit_excess"] > 0.0
    assert done and done[-1] == 1.0


def test_dry_friction_sticking_needs_no_steps_of_dt():
    """A joint sticking in dry friction is a located event and a smooth stuck motion
    (manipcad.sim.events): no step is forced down to dt above the tolerance (with the
    sign(q̇) friction integrated across its zero there were), and the stops are logged."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        arm = manipcad.load_robot("puma560")
    traj = quintic(Q_START, Q_END, 1.0)
    res = simulate(arm, t_end=0.2, dt=1e-4, trajectory=traj, regulators=pd_regs(),
                   integrator="adaptive-exact", every=10)
    s = res.settings
    assert s["steps"] <= 0.2 / 1e-4 + 200  # + the steps that land on a sample
    assert s["steps_at_dt_above_tolerance"] == 0
    assert res.events is not None and len(res.events) > 0


@pytest.mark.parametrize("name", sorted(TABLEAUS))
def test_pairs_satisfy_their_order_conditions(name):
    """Each pair's propagated weights b satisfy the order conditions up to order p + 1,
    its embedded weights b̂ = b − e up to order p and not p + 1 (the error estimate is of
    order p + 1 in the step), c holds the row sums of a, and the last stage is the new
    solution (first same as last: its row of a is b, its node 1)."""
    tab = TABLEAUS[name]
    a, b, c, p = tab.a, tab.b, tab.c, tab.p
    bhat = b - tab.e
    np.testing.assert_allclose(a.sum(axis=1), c, atol=1e-15)
    np.testing.assert_allclose(a[-1], b, atol=0)
    assert c[-1] == 1.0

    def conditions(w, order):
        """The residuals of the Butcher order conditions of orders 1..order (up to 5)."""
        ac = a @ c
        res = [w.sum() - 1, w @ c - 1 / 2, w @ c**2 - 1 / 3, w @ ac - 1 / 6,
               w @ c**3 - 1 / 4, w @ (c * ac) - 1 / 8, w @ (a @ c**2) - 1 / 12,
               w @ (a @ ac) - 1 / 24, w @ c**4 - 1 / 5, w @ (c**2 * ac) - 1 / 10,
               w @ (c * (a @ c**2)) - 1 / 15, w @ (c * (a @ ac)) - 1 / 30,
               w @ ac**2 - 1 / 20, w @ (a @ c**3) - 1 / 20, w @ (a @ (c * ac)) - 1 / 40,
               w @ (a @ (a @ c**2)) - 1 / 60, w @ (a @ (a @ ac)) - 1 / 120]
        return np.array(res[:{1: 1, 2: 2, 3: 4, 4: 8, 5: 17}[order]])

    assert np.abs(conditions(b, p + 1)).max() < 1e-14
    assert np.abs(conditions(bhat, p)).max() < 1e-14
    assert np.abs(conditions(bhat, p + 1)).max() > 1e-4


@pytest.fixture(scope="module")
def ur5():
    from pathlib import Path

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return manipcad.load_robot(str(Path(__file__).resolve().parents[1] / "examples"
                                       / "ur5" / "ur5_robot.urdf"))


UR5_Q0 = np.array([0.0, -1.57, 0.0, -1.57, 0.0, 0.0])
UR5_Q1 = np.array([0.5, -1.2, 0.6, -1.2, 0.4, 0.3])
UR5_KP = np.array([400.0, 400.0, 300.0, 50.0, 50.0, 20.0])      # N·m/rad


class _Hold:
    """The reference: hold UR5_Q1."""

    def sample(self, t):
        z = np.zeros((len(t), 6))
        return np.tile(UR5_Q1, (len(t), 1)), z, z.copy()


@pytest.mark.parametrize("integrator", ["adaptive", "adaptive-bs32"])
def test_rigid_ur5_pd_at_1khz_matches_rk4_at_1e_5(ur5, integrator):
    """The rigid UR5 PD job of benchmarks/bench_simulator.py --part ur5 (torque PD at 1
    kHz, no drives): both pairs within 1e-7 rad of RK4 at dt 1e-5 at every 1 ms sample,
    one step per sample period (the period bounds the steps, not the tolerance): 1 + 6
    right-hand sides per period with Dormand–Prince, 1 + 3 with Bogacki–Shampine."""
    def run(**kw):
        regs = [pid(j, kp=UR5_KP[j], kd=UR5_KP[j] / 10, period=1e-3) for j in range(6)]
        return simulate(ur5, t_end=0.2, trajectory=_Hold(), q0=UR5_Q0, regulators=regs,
                        drives=False, joint_limits="ignore", **kw)

    ref = run(dt=1e-5, every=100)
    ada = run(dt=1e-4, every=10, integrator=integrator)
    np.testing.assert_allclose(ada.t, ref.t, atol=1e-15, rtol=0)
    dq = np.abs(ada.q - ref.q).max()
    assert 0.0 < dq <= 1e-7, dq
    np.testing.assert_allclose(sample_instants(ada), sample_instants(ref), rtol=0,
                               atol=1e-12)
    s = ada.settings
    # (the first period in 2-3 steps: the first step is 1e-4 s, growing at most 5x a step)
    assert s["steps"] <= 203 and s["rejected"] == 0, s
    per_period = {"adaptive": 7, "adaptive-bs32": 4}[integrator]
    assert s["rhs_evaluations"] <= 200 * per_period + 3 * (per_period - 1), s


@pytest.mark.parametrize("integrator, order", [("adaptive", 5), ("adaptive-bs32", 3)])
def test_pairs_converge_with_the_tolerance_at_their_order(puma, integrator, order):
    """The passive PUMA (no regulator: the steps set by the tolerance alone) falling
    for 1 s: the error at the end against RK4 at dt 1e-5 falls in proportion to the
    tolerance, and the steps grow as tol^(-1/order), the step control's exponent and the
    order of its estimate (Dormand–Prince: a 4th-order estimate of a 5th-order step;
    Bogacki–Shampine: 2nd of 3rd). Measured: DP54 90, 218, 544 steps and BS32 1007, 4684,
    21755 at tol 1e-7, 1e-9, 1e-11; errors 8.8 and 13.7 times the tolerance."""
    kw = dict(t_end=1.0, drives=False, q0=[0.0, 0.5, -0.5, 0.0, 0.3, 0.0],
              joint_limits="ignore", every=100000)
    ref = simulate(puma, dt=1e-5, **kw)
    errors, steps = [], []
    tols = (1e-7, 1e-9, 1e-11)
    for tol in tols:
        res = simulate(puma, dt=1e-5, integrator=integrator, rtol=tol, atol=tol, **kw)
        assert res.t[-1] == 1.0
        errors.append(np.abs(res.q[-1] - ref.q[-1]).max())
        steps.append(res.settings["steps"])
    for tol, err in zip(tols, errors, strict=True):
        assert tol < err < 30 * tol, (tols, errors)
    assert errors[0] / errors[1] > 50 and errors[1] / errors[2] > 50, errors
    # 100x tighter: 100^(1/order) times the steps (DP54 2.51, BS32 4.64)
    growth = [steps[1] / steps[0], steps[2] / steps[1]]
    want = 100 ** (1 / order)
    assert all(0.8 * want <= g <= 1.25 * want for g in growth), (growth, want, steps)
