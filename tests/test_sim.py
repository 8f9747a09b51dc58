"""Closed-loop simulator and regulator files.

Checked against independent implementations: the passive rigid body against
Pinocchio's ABA integrated by SciPy's DOP853; one drive against the closed
form of its linear model (python-control ``forced_response``); the energy
balance of the drive; PID hold under gravity; divergence; bad regulator files.
"""

from __future__ import annotations

import math
import warnings
from pathlib import Path

import control as ct
import numpy as np
import pytest
from conftest import random_tree
from scipy.integrate import simpson, solve_ivp

import manipcad
from manipcad.control import pid
from manipcad.control.files import load_regulators, regulators_from_dict
from manipcad.errors import InputError, ManipcadError, ManipcadWarning
from manipcad.model.robot import Drive, Robot
from manipcad.sim import SimulationDiverged, simulate

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def puma() -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return manipcad.load_robot("puma560")


# ------------------------------------------------------------ passive motion
def pinocchio_passive(robot: Robot, q0, qd0, t_eval):
    """Zero-torque motion by Pinocchio's ABA and SciPy's DOP853 (rtol = atol = 1e-12)."""
    pin = pytest.importorskip("pinocchio")
    from manipcad.model.to_pinocchio import to_pinocchio

    model, order = to_pinocchio(robot)
    data = model.createData()
    n = robot.n
    inv = np.argsort(order)  # our joint j is Pinocchio's joint inv[j]
    off = robot.offset[order]
    zero = np.zeros(n)

    def rhs(_t, x):
        qp, vp = x[:n], x[n:]
        return np.concatenate([vp, pin.aba(model, data, qp + off, vp, zero)])

    x0 = np.concatenate([np.asarray(q0)[order], np.asarray(qd0)[order]])
    sol = solve_ivp(rhs, (0.0, t_eval[-1]), x0, method="DOP853", t_eval=t_eval,
                    rtol=1e-12, atol=1e-12)
    assert sol.success, sol.message
    return sol.y[:n].T[:, inv], sol.y[n:].T[:, inv]


@pytest.mark.parametrize("seed", [0, 2, 4])
def test_passive_random_chain_matches_pinocchio(seed):
    robot = random_tree(seed, n=3 + seed, chain=True)
    rng = np.random.default_rng(100 + seed)
    q0 = rng.normal(size=robot.n) * 0.5
    qd0 = rng.normal(size=robot.n) * 0.5
    res = simulate(robot, t_end=0.5, dt=1e-4, q0=q0, qd0=qd0, drives=False,
                   joint_limits="ignore")
    q_ref, qd_ref = pinocchio_passive(robot, q0, qd0, res.t)
    assert res.q.shape == (5001, robot.n)
    # measured: 4e-14 .. 3.2e-12 rad
    assert np.abs(res.q - q_ref).max() < 1e-9
    assert np.abs(res.qd - qd_ref).max() < 1e-8
    assert np.abs(res.q[-1] - q0).max() > 1e-2  # it did move


def test_passive_random_tree_matches_pinocchio():
    robot = random_tree(5, n=7, chain=False)
    q0 = np.linspace(-0.5, 0.5, robot.n)
    res = simulate(robot, t_end=0.5, dt=1e-4, q0=q0, qd0=np.zeros(robot.n), drives=False,
                   joint_limits="ignore")
    q_ref, _ = pinocchio_passive(robot, q0, np.zeros(robot.n), res.t)
    assert np.abs(res.q - q_ref).max() < 1e-9


def test_passive_puma_without_drives_matches_pinocchio():
    robot = puma()
    q0 = np.array([0.1, 0.6, -0.4, 0.2, 0.5, -0.3])
    qd0 = np.array([0.3, 0.0, 0.2, -0.5, 0.1, 0.4])
    res = simulate(robot, t_end=0.5, dt=1e-4, q0=q0, qd0=qd0, drives=False,
                   joint_limits="ignore")
    q_ref, _ = pinocchio_passive(robot, q0, qd0, res.t)
    assert np.abs(res.q - q_ref).max() < 1e-9   # measured 2.5e-12 rad
    assert np.abs(res.q[-1] - q0).max() > 0.1  # it fell under gravity
    assert np.all(res.u == 0) and np.all(np.isnan(res.current))


def test_rk4_converges_with_fourth_order():
    """Halving the step divides the error at t = 0.4 s by ~16 (measured 15.3, 15.6, 15.8
    from dt = 8 ms to 1 ms on the falling PUMA), against DOP853 at rtol 1e-12."""
    robot = puma()
    q0 = np.array([0.1, 0.6, -0.4, 0.2, 0.5, -0.3])
    qd0 = np.array([0.3, 0.0, 0.2, -0.5, 0.1, 0.4])
    q_ref, _ = pinocchio_passive(robot, q0, qd0, np.linspace(0.0, 0.4, 5))
    err = [np.abs(simulate(robot, t_end=0.4, dt=dt, q0=q0, qd0=qd0, drives=False,
                   joint_limits="ignore").q[-1]
                  - q_ref[-1]).max() for dt in (8e-3, 4e-3, 2e-3, 1e-3)]
    orders = np.log2(np.array(err[:-1]) / np.array(err[1:]))
    assert np.all((orders > 3.8) & (orders < 4.2)), (err, orders)


# ------------------------------------------------------- one drive, open loop
class ConstantSpeedRef:
    """A reference with q̇_ref = v (so a PID with only kff = 1 outputs U = v)."""

    def __init__(self, v: float) -> None:
        self.v, self.n, self.duration = v, 1, math.inf

    def sample(self, t):
        t = np.asarray(t, dtype=float)
        ones = np.ones((len(t), 1))
        return self.v * t[:, None], self.v * ones, 0.0 * ones


def one_drive_robot(M_f: float = 0.0) -> Robot:
    """A turntable: vertical revolute joint, gravity along the axis (no gravity torque)."""
    drive = Drive(J=3.0e-5, ratio=50.0, k_v=2.0e-5, M_f=M_f, R=1.2, L=6.0e-4, k_m=0.06,
                  k_w=0.06, k_u=2.0)
    return Robot.from_arrays(
        "turntable", ["revolute"], [-1], np.eye(3)[None], np.zeros((1, 3)), [4.0],
        np.zeros((1, 3)), np.diag([0.05, 0.05, 0.08])[None], drives=[drive],
        gravity=(0.0, 0.0, -9.81))


def run_step(robot: Robot, U0: float, load: float, t_end: float = 0.08, dt: float = 1e-5):
    reg = pid(0, kp=0.0, kff=1.0, period=dt)
    return simulate(robot, t_end=t_end, dt=dt, trajectory=ConstantSpeedRef(U0),
                    regulators=[reg], q0=[0.0], disturbance=np.array([load]))


def test_one_drive_step_matches_linear_model():
    robot = one_drive_robot()
    d = robot.drives[0]
    U0, load = 12.0, -0.8  # V; N·m at the joint, opposing the motion
    res = run_step(robot, U0, load)
    assert np.allclose(res.u[:, 0], U0)

    G, I = d.ratio, 0.08 + d.J * d.ratio**2
    # x = (q, q̇, i); inputs (U, load torque)
    A = np.array([[0.0, 1.0, 0.0],
                  [0.0, -d.k_v * G**2 / I, G * d.k_m / I],
                  [0.0, -d.k_w * G / d.L, -d.R / d.L]])
    B = np.array([[0.0, 0.0], [0.0, 1.0 / I], [d.k_u / d.L, 0.0]])
    sys = ct.ss(A, B, np.eye(3), np.zeros((3, 2)))
    inputs = np.vstack([np.full(len(res.t), U0), np.full(len(res.t), load)])
    lin = ct.forced_response(sys, T=res.t, U=inputs, X0=np.zeros(3))
    q_lin, qd_lin, i_lin = lin.outputs

    def rel(a, b):
        return np.abs(a - b).max() / np.abs(b).max()

    assert qd_lin[-1] > 0.5 * qd_lin.max() > 0  # well into the step
    assert rel(res.qd[:, 0], qd_lin) < 1e-6
    assert rel(res.q[:, 0], q_lin) < 1e-6
    assert rel(res.current[:, 0], i_lin) < 1e-6
    assert rel(res.tau[:, 0], G * d.k_m * i_lin + load) < 1e-6
    # the final speed approaches the static one: (k_u U G k_m / R + load) / (b_emf + k_v G²)
    b = G**2 * d.k_m * d.k_w / d.R + d.k_v * G**2
    w_inf = (d.k_u * U0 * G * d.k_m / d.R + load) / b
    assert abs(res.qd[-1, 0] - w_inf) < 0.05 * w_inf


def test_one_drive_energy_balance():
    """∫u_a·i = ∫R·i² + ½L·i² + ½I·ω² + ∫(k_v·i_r²·ω² + |i_r|·M_f·|ω|) - ∫load·ω."""
    robot = one_drive_robot(M_f=0.01)
    d = robot.drives[0]
    U0, load = 12.0, 0.3  # the load helps the motion: ω > 0 throughout, no stick
    res = run_step(robot, U0, load, t_end=0.05)
    t, w, i = res.t, res.qd[:, 0], res.current[:, 0]
    assert np.all(w[1:] > 0)
    G, I = d.ratio, 0.08 + d.J * d.ratio**2
    e_in = simpson(d.k_u * res.u[:, 0] * i, x=t)
    e_r = simpson(d.R * i**2, x=t)
    e_l = 0.5 * d.L * i[-1] ** 2
    e_kin = 0.5 * I * w[-1] ** 2
    e_fric = simpson(d.k_v * G**2 * w**2 + abs(G) * d.M_f[0] * np.abs(w), x=t)
    e_load = -simpson(load * w, x=t)
    assert e_in > 0 and e_kin > 0.05 * e_in
    assert abs(e_in - (e_r + e_l + e_kin + e_fric + e_load)) < 1e-6 * e_in
    # the simulator's own energy metric is the same electrical input, trapezoidal
    assert res.metrics["q1"]["energy"] == pytest.approx(e_in, rel=1e-6)


# ------------------------------------------------------------ PID closed loop
def puma_without_dry_friction() -> Robot:
    """The PUMA with M_f = 0: dry friction would make an integral regulator stick-slip."""
    r = puma()
    return r.replace(drives=tuple(d.replace(M_f=0.0) for d in r.drives))


def test_pid_holds_puma_pose_under_gravity():
    robot = puma_without_dry_friction()
    q0 = np.array([0.2, 0.6, -0.5, 0.1, 0.4, 0.0])
    with warnings.catch_warnings():
        warnings.simplefilter("error", ManipcadWarning)  # the example's signs are right
        regs = load_regulators(EXAMPLES / "pid_puma.yaml", robot, dt=1e-4)
    assert len(regs) == 6
    res = simulate(robot, t_end=1.5, dt=1e-4, regulators=regs, q0=q0)
    e = np.abs(res.error)
    early = e[(res.t > 0.05) & (res.t < 0.1)].max(axis=0)
    late = e[res.t > 1.4].max(axis=0)
    assert e[:, 1].max() > 1e-4  # gravity did pull the shoulder off the pose
    assert np.all(late < 1e-5), late  # the integral removed the steady-state error
    assert late[1] < 0.01 * early[1]
    assert np.isfinite(res.current).all()
    m = res.metrics["shoulder"]
    assert m["max_error"] == pytest.approx(e[:, 1].max())
    assert m["energy"] > 0 and m["effort_rms"] > 0

    # without the integral the gravity error stays
    pd = [pid(r.joint, kp=r.params[0], kd=r.params[2], kff=r.params[4], period=r.period,
              u_limit=40.0) for r in regs]
    res_pd = simulate(robot, t_end=1.5, dt=1e-4, regulators=pd, q0=q0)
    assert np.abs(res_pd.error[-1, 1]) > 100 * late[1]
    assert np.abs(res_pd.error[-1, 1]) > 1e-4


def test_pid_step_metrics():
    """A step of the reference: overshoot, rise and settling times are reported."""
    robot = puma_without_dry_friction()
    regs = load_regulators(EXAMPLES / "pid_puma.yaml", robot, dt=1e-4)

    class Step:
        n, duration = 6, 0.0

        def sample(self, t):
            q = np.tile([0.0, 0.5, -0.5, 0.0, 0.0, 0.0], (len(t), 1))
            q[:, 3] = 0.1  # a 0.1 rad step on the wrist roll
            return q, np.zeros_like(q), np.zeros_like(q)

    res = simulate(robot, t_end=0.6, dt=1e-4, trajectory=Step(), regulators=regs,
                   q0=[0.0, 0.5, -0.5, 0.0, 0.0, 0.0])
    m = res.metrics["wrist_roll"]
    assert 0.0 < m["rise_time"] < 0.2
    assert m["rise_time"] < m["settling_time"] < 0.6
    assert 0.0 <= m["overshoot"] < 0.3
    assert abs(res.q[-1, 3] - 0.1) < 2e-3


def test_metrics_computed_when_first_read_are_the_runs():
    """``simulate`` leaves the metrics to their first reading: they are then those of
    :func:`joint_metrics` on the result (with the drives' energy), with the limit
    excess of a joint that left its limits; a result pickled before reading them, or
    copied by ``dataclasses.replace``, gives the same; assigning replaces them."""
    import dataclasses
    import pickle

    from manipcad.drives.params import pack_drives
    from manipcad.sim.metrics import joint_metrics
    from manipcad.trajectories import quintic

    robot = puma_without_dry_friction()
    regs = load_regulators(EXAMPLES / "pid_puma.yaml", robot, dt=1e-4)
    narrow = robot.replace(limits=np.array([[-0.05, 0.05]] + [[-3.0, 3.0]] * 5))
    traj = quintic(np.zeros(6), [0.1, 0.2, 0.0, 0.0, 0.0, 0.0], 0.1)
    with pytest.warns(ManipcadWarning, match="'waist' by up to"):
        res = simulate(narrow, t_end=0.1, dt=1e-4, trajectory=traj, regulators=regs)
    copy = pickle.loads(pickle.dumps(res))
    replaced = dataclasses.replace(res, joint_types=res.joint_types)
    want = joint_metrics(res, drives=True, dtable=pack_drives(robot.drives))
    m = res.metrics
    assert set(m) == set(robot.joint_names)
    assert m["waist"]["limit_excess"] > 0.0
    assert "limit_excess" not in m["shoulder"]
    for nm in robot.joint_names:
        assert {k: v for k, v in m[nm].items() if k != "limit_excess"} == \
            pytest.approx(want[nm], nan_ok=True)
        assert copy.metrics[nm] == pytest.approx(m[nm], nan_ok=True)
        assert replaced.metrics[nm] == pytest.approx(m[nm], nan_ok=True)
    assert m["shoulder"]["energy"] > 0.0  # the drives' electrical energy, J
    assert res.metrics is m  # computed once
    res.metrics = {"waist": {}}
    assert res.metrics == {"waist": {}}


def test_reference_of_the_result_is_the_trajectory_at_the_kept_times():
    """q_ref and q̇_ref are the trajectory sampled at the kept times, whether the loop's own
    rows serve (one chunk, every step kept) or they are sampled again (every 3rd step
    kept; a run cut short by divergence)."""
    from manipcad.trajectories import quintic

    robot = puma_without_dry_friction()
    regs = load_regulators(EXAMPLES / "pid_puma.yaml", robot, dt=1e-4)
    traj = quintic(np.zeros(6), [0.1, 0.2, 0.0, 0.0, 0.0, 0.0], 0.1)
    for every in (1, 3):
        res = simulate(robot, t_end=0.05, dt=1e-4, trajectory=traj, regulators=regs,
                       every=every)
        q, qd, _ = traj.sample(res.t)
        assert len(res.t) == 500 // every + 1
        assert np.array_equal(res.q_ref, q) and np.array_equal(res.qd_ref, qd)
    bad = [pid("elbow", kp=-1e6, kd=-1e4, period=1e-3)]  # absurd negative gains
    with pytest.raises(SimulationDiverged) as err:
        simulate(puma(), t_end=2.0, dt=1e-4, trajectory=traj, regulators=bad, drives=False)
    part = err.value.result
    assert 0 < len(part.t) < 20001
    assert np.array_equal(part.q_ref, traj.sample(part.t)[0])


def test_reference_beyond_the_limits_warns_with_joint_excess_and_time():
    """A reference that leaves a joint's limits is named with how far and when first;
    one that touches a limit within the rounding tolerance (a millionth of the range) is
    not."""
    from manipcad.trajectories import quintic

    robot = puma_without_dry_friction()
    regs = load_regulators(EXAMPLES / "pid_puma.yaml", robot, dt=1e-4)
    lim = np.array([[-3.0, 3.0]] * 6)
    lim[1] = [-1.0, 0.15]   # the shoulder's reference ends 0.05 rad beyond
    lim[0] = [-1.0, 0.1 - 1e-7]  # the waist's ends 1e-7 rad beyond: within the tolerance
    arm = robot.replace(limits=lim)
    traj = quintic(np.zeros(6), [0.1, 0.2, 0.0, 0.0, 0.0, 0.0], 0.05)
    with pytest.warns(ManipcadWarning, match="the reference leaves the joint limits") as rec:
        simulate(arm, t_end=0.06, dt=1e-4, trajectory=traj, regulators=regs)
    msg = next(str(w.message) for w in rec if "the reference leaves" in str(w.message))
    assert "'shoulder' by up to 0.05 rad" in msg and "'waist'" not in msg
    t_first = float(msg.split("first at t = ")[1].split(" s")[0])
    q = traj.sample(np.arange(601) * 1e-4)[0][:, 1]
    assert t_first == pytest.approx(np.argmax(q - 0.15 > 1e-6 * 1.15) * 1e-4)


# ------------------------------------------------------------------ divergence
def test_divergent_simulation_names_time_and_joint():
    robot = puma()
    regs = [pid("elbow", kp=-1e6, kd=-1e4, period=1e-3)]  # absurd negative gains
    with pytest.raises(SimulationDiverged) as info:
        simulate(robot, t_end=2.0, dt=1e-4, regulators=regs, drives=False,
                 q0=[0.0, 0.5, -0.5, 0.0, 0.0, 0.0])
    exc = info.value
    msg = str(exc)
    assert "diverged at t = " in msg and "joint '" in msg
    part = exc.result
    assert 0 < len(part.t) < 20001
    t_div = float(msg.split("t = ")[1].split(" s")[0])
    assert t_div == pytest.approx(part.t[-1], abs=1e-3)
    assert np.isfinite(part.q).all()
    assert isinstance(exc, ManipcadError)


# ------------------------------------------------------------ regulator files
def write(tmp_path, text: str, name: str = "reg.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


GOOD = """\
type: pid
period: 1e-3
kp: [-930, 950, -580, 320, 340, 320]
kd: 5
"""


def test_regulator_file_scalar_and_lists(tmp_path):
    robot = puma()
    regs = load_regulators(write(tmp_path, GOOD), robot, dt=1e-4)
    assert [r.joints[0] for r in regs] == list(range(6))
    assert regs[1].params[0] == 950 and regs[4].params[2] == 5
    assert math.isinf(regs[0].params[3])  # no u_limit: none
    assert regs[0].period == 1e-3


def test_regulator_file_groups_and_joint_names(tmp_path):
    robot = puma()
    text = """\
regulators:
  - {type: pid, joints: [shoulder], period: 0.001, kp: 900, ki: 100, u_limit: 30}
  - {type: pid, joints: [elbow, 0], period: 0.0005, kp: [-500, -800], kd: [-3, -20]}
"""
    regs = load_regulators(write(tmp_path, text), robot, dt=1e-4)
    by_joint = {r.joints[0]: r for r in regs}
    assert sorted(by_joint) == [0, 1, 2]
    assert by_joint[1].params[1] == 100 and by_joint[1].params[3] == 30
    assert by_joint[0].params[0] == -800 and by_joint[0].period == 5e-4
    assert by_joint[2].params[2] == -3


def test_example_files_load():
    with warnings.catch_warnings():
        warnings.simplefilter("error", ManipcadWarning)
        assert len(load_regulators(EXAMPLES / "pid_puma.yaml", puma(), dt=1e-4)) == 6
        cyl = manipcad.load_robot("cylindrical")
        regs = load_regulators(EXAMPLES / "pid_cylindrical.yaml", cyl, dt=1e-4)
    assert sorted(r.joints[0] for r in regs) == [0, 1, 2]


BAD = [
    ("type: pid\nkp: [1, 2\n", "", "YAML syntax error"),
    ("", "", "empty file"),
    ("- 1\n- 2\n", "", "expected a mapping"),
    ("period: 0.001\nkp: 1\n", "type", "missing"),
    ("type: lqr\nperiod: 0.001\n", "type", "unknown regulator type 'lqr'"),
    ("type: pid\nperiod: 0.001\nkp: 1\nkq: 2\n", "kq", "unknown field"),
    ("type: pid\nperiod: 0.001\n", "kp", "missing"),
    ("type: pid\nperiod: 0.001\nkp: [1, 2, 3]\n", "kp", "has 3 entries"),
    ("type: pid\nperiod: 0.001\nkp: [1, 2]\njoints: [waist, elbo]\n", "joints[1]",
     "no joint 'elbo'"),
    ("type: pid\nperiod: 0.001\nkp: 1\njoints: [waist, 0]\n", "joints[1]", "listed twice"),
    ("type: pid\nperiod: 0\nkp: 1\n", "period", "must be > 0"),
    ("type: pid\nperiod: -0.001\nkp: 1\n", "period", "must be > 0"),
    ("type: pid\nperiod: .nan\nkp: 1\n", "period", "must be > 0"),
    ("type: pid\nperiod: 0.001\nkp: [1, 2, x, 4, 5, 6]\n", "kp[2]", "valid number"),
    ("type: pid\nperiod: 0.001\nkp: [1, 2, .inf, 4, 5, 6]\n", "kp[2]", "must be finite"),
    ("type: pid\nperiod: 0.001\nkp: 1\nu_limit: 0\n", "u_limit", "must be > 0"),
    ("type: pid\nperiod: 0.001\nkp: true\n", "kp", "valid"),
    ("regulators: []\n", "regulators", "non-empty list"),
    ("regulators:\n  - {type: pid, period: 0.001, kp: 1, joints: [waist]}\n"
     "  - {type: pid, period: 0.001, kp: 1, kd: [1, 2], joints: [elbow]}\n",
     "regulators[1].kd", "has 2 entries"),
    ("regulators:\n  - {type: pid, period: 0.001, kp: 1, joints: [waist]}\n"
     "  - {type: pid, period: 0.001, kp: 1, joints: [elbow, waist]}\n",
     "regulators[1].joints", "already has a regulator"),
    ("regulators:\n  - {type: pid, period: 0.001, kp: 1}\nperiod: 1\n", "period",
     "unknown field beside"),
]


@pytest.mark.parametrize(("text", "field", "reason"), BAD)
def test_bad_regulator_files(tmp_path, text, field, reason):
    path = write(tmp_path, text)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        with pytest.raises(InputError) as info:
            load_regulators(path, puma())
    err = info.value
    assert err.source == str(path)
    assert err.field == field, str(err)
    assert reason in err.reason, str(err)
    assert str(path) in str(err)


def test_missing_regulator_file(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_regulators(tmp_path / "nope.yaml", puma())


def test_period_not_a_multiple_of_dt(tmp_path):
    path = write(tmp_path, "type: pid\nperiod: 0.001\nkp: 1\n")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        with pytest.raises(InputError) as info:
            load_regulators(path, puma(), dt=3e-4)
        assert info.value.field == "period" and "not a multiple" in info.value.reason
        regs = load_regulators(path, puma())
    with pytest.raises(ManipcadError, match="not a multiple of dt"):
        simulate(puma(), t_end=0.01, dt=3e-4, regulators=regs)


def test_positive_feedback_sign_warns(tmp_path):
    robot = puma()
    path = write(tmp_path, "type: pid\nperiod: 0.001\nkp: 100\njoints: [waist]\n")
    with pytest.warns(ManipcadWarning, match="positive feedback"):
        load_regulators(path, robot)
    with warnings.catch_warnings():
        warnings.simplefilter("error", ManipcadWarning)
        load_regulators(path, robot, drives=False)  # torque output: kp > 0 is right
    with pytest.warns(ManipcadWarning, match="without a drive"):
        regulators_from_dict({"type": "pid", "period": 1e-3, "kp": -1.0,
                              "joints": ["shoulder"]}, robot, drives=False)


def _slider():
    """A passive finger: a prismatic joint along -z under gravity, limits [0, 0.04] m."""
    return Robot.from_arrays("finger", ["prismatic"], [-1], [np.eye(3)], [np.zeros(3)],
                             [0.1], [np.zeros(3)], [np.eye(3) * 1e-5],
                             gravity=(0.0, 0.0, 9.81), limits=[[0.0, 0.04]],
                             joint_names=["finger_joint"])


def test_joint_beyond_its_limits_is_never_silent():
    """A passive finger slides past its 0.04 m limit: warned (with how far and when), or
    the run stops there naming the joint and the time."""
    from manipcad.sim import JointLimitExceeded

    with pytest.warns(ManipcadWarning, match="'finger_joint' by up to .* m .first at t = 0.09"):
        res = simulate(_slider(), t_end=0.5, dt=1e-3, q0=[0.0], drives=False)
    assert res.q[-1, 0] > 1.0 and res.metrics["finger_joint"]["limit_excess"] > 1.0
    with pytest.raises(JointLimitExceeded, match=r"'finger_joint' left its limits \[0, 0.04\] "
                       r"m at t = 0.09"):
        simulate(_slider(), t_end=0.5, dt=1e-3, q0=[0.0], drives=False, joint_limits="stop")
    import warnings as w

    with w.catch_warnings():
        w.simplefilter("error")
        simulate(_slider(), t_end=0.5, dt=1e-3, q0=[0.0], drives=False, joint_limits="ignore")


def test_old_record_stride_keyword_is_refused_by_its_new_name():
    arm = manipcad.load_robot("cylindrical")
    with pytest.raises(ManipcadError, match="'record_every' is now called 'every'"):
        simulate(arm, t_end=0.01, dt=1e-3, drives=False, record_every=2)
    with pytest.raises(TypeError, match="unexpected keyword argument 'recrd'"):
        simulate(arm, t_end=0.01, dt=1e-3, drives=False, recrd=2)
    assert simulate(arm, t_end=0.01, dt=1e-3, drives=False, every=2).t.shape == (6,)
