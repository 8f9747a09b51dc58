"""Drive sizing: required torques against the Robotics Toolbox, energy, ratio sweep, CLI."""

from __future__ import annotations

import json
import math
import warnings

import numpy as np
import pytest
from typer.testing import CliRunner

import manipcad
from manipcad.errors import InputError, ManipcadWarning, ModelError
from manipcad.model.robot import Drive
from manipcad.sizing import ratio_sweep, required_drive, torque_speed_plot
from manipcad.sizing.motion import sample_motion
from manipcad.sizing.motor import coulomb_direction, motor_series
from manipcad.trajectories import cosine, quintic, save_trajectory, spline

FIG3 = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], duration=1.6)


def _load(name: str) -> manipcad.Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return manipcad.load_robot(name)


def _rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.abs(a - b).max() / np.abs(b).max())


@pytest.fixture(scope="module")
def puma():
    return _load("puma560")


@pytest.fixture(scope="module")
def cyl():
    return _load("cylindrical")


PUMA_MOVES = [
    quintic([0, 0, 0, 0, 0, 0], [1.0, -0.8, 0.7, 1.2, -1.0, 1.5], 1.2),
    cosine([0.6, 0.4, -0.5, 0.8, 0.7, -0.9], [3.0, 4.0, 5.0, 6.0, 7.0, 8.0], 2.0,
           q0=[0.1, -0.3, 0.2, 0.0, 0.4, -0.2]),
    spline([0.0, 0.4, 1.0, 1.5], [[0, 0, 0, 0, 0, 0], [0.5, 0.2, -0.3, 1.0, 0.5, 0.3],
                                   [0.8, -0.4, 0.6, -0.5, 1.0, 0.9],
                                   [0.2, 0.1, 0.0, 0.3, 0.0, 0.0]]),
]


# --------------------------------------------------------------- against the Toolbox
@pytest.mark.parametrize("traj", PUMA_MOVES, ids=["quintic", "cosine", "spline"])
def test_puma_torques_equal_rtb_rne(puma, traj):
    """Joint torques along a trajectory = RTB Puma560.rne, which adds Jm·G²·q̈ and friction."""
    rtb = pytest.importorskip("roboticstoolbox")
    p = rtb.models.DH.Puma560()
    req = required_drive(puma, traj, t_end=traj.duration + 0.2)
    q, qd, qdd = traj.sample(req.t)                     # independent sampling
    ref = p.rne(q, qd, qdd)
    assert req.tau.shape == ref.shape == (req.t.size, 6)
    assert _rel(req.tau, ref) < 1e-9
    assert _rel(req.peak_torque, np.abs(ref).max(axis=0)) < 1e-9
    rms = np.sqrt(np.trapezoid(ref**2, req.t, axis=0) / req.t_end)
    assert _rel(req.rms_torque, rms) < 1e-9
    # the toolbox's rne really holds the drive terms: without them it differs
    bare = p.nofriction(coulomb=True, viscous=True).rne(q, qd, qdd)
    assert _rel(bare, ref) > 1e-3
    # motor side: T_m = P / G, ω_m = G·q̇
    G = np.array([link.G for link in p.links])
    assert _rel(req.motor_torque, ref / G) < 1e-9
    assert _rel(req.peak_motor_torque, np.abs(ref / G).max(axis=0)) < 1e-9
    assert _rel(req.peak_motor_speed, np.abs(qd * G).max(axis=0)) < 1e-12
    assert _rel(req.current, ref / G / 0.228 * np.r_[1, 1, 1, 0, 0, 0]
                + ref / G / 0.075 * np.r_[0, 0, 0, 1, 1, 1]) < 1e-9


def test_puma_unknown_ratings(puma):
    """PUMA motors have no ratings in the catalog: torque and speed checks are "unknown";
    the voltage check uses the amplifier limit u_max = 40 V."""
    req = required_drive(puma, PUMA_MOVES[0])
    for name in ("continuous", "peak", "speed"):
        assert req.checks[name].status == ("unknown",) * 6
        assert np.all(np.isnan(req.checks[name].margin))
    v = req.checks["voltage"]
    assert np.all(v.limit == 40.0)
    assert np.allclose(v.margin, 1 - req.peak_voltage / 40.0)
    assert set(req.status) <= {"unknown", "fail"}
    assert not req.ok


def test_no_electrics_gives_nan_and_unknown():
    """The Stanford arm's drives have J and ratio only: currents and voltages are nan."""
    arm = _load("stanford")
    # the prismatic joint 3 within its limits [0.3048, 1.27] m
    traj = quintic([0.0, 0.0, 0.5, 0.0, 0.0, 0.0], [0.5, 0.4, 0.6, 0.3, 0.2, 0.1], 1.0)
    req = required_drive(arm, traj, t_end=1.0)
    assert np.all(np.isfinite(req.peak_motor_torque))
    assert np.all(np.isnan(req.peak_current)) and np.all(np.isnan(req.peak_voltage))
    assert np.all(np.isnan(req.mean_elec_power))
    assert req.status == ("unknown",) * 6
    # and a joint without any drive: motor side nan, joint side known
    bare = arm.replace(drives=(None,) + arm.drives[1:])
    r2 = required_drive(bare, traj)
    assert math.isnan(r2.peak_motor_torque[0]) and math.isfinite(r2.peak_torque[0])
    assert r2.status[0] == "unknown"
    d = r2.to_dict()
    assert d["joints"][0]["motor"] is None and d["joints"][0]["peak_current"] is None


# ------------------------------------------------------------------------ physics
def test_energy_losses(cyl, puma):
    """Mean electrical power >= mean mechanical power for every driven joint (copper loss)."""
    for robot, traj in ((cyl, FIG3), (puma, PUMA_MOVES[1])):
        req = required_drive(robot, traj)
        for j in range(robot.n):
            if np.any(req.qd[:, j] != 0):
                assert req.mean_elec_power[j] >= req.mean_mech_power[j], robot.name
        # p_e - p_m = R·i² + L·i·di/dt + (k_w - k_m)·ω_m·i + gear loss, sample by sample;
        # the gear loss P_rigid·q̇·(f - 1) (f = 1/η motoring, η braking) is never negative
        m = sample_motion(robot, traj)
        for j, d in enumerate(robot.drives):
            s = motor_series(d, d.ratio, m.tau[:, j], m.qd[:, j], m.qdd[:, j],
                             m.dtau_rigid[:, j], m.jerk[:, j], m.tau_rigid[:, j])
            gear_loss = (s.torque - m.tau[:, j] / d.ratio) * s.speed
            assert gear_loss.min() >= -1e-12 * np.abs(gear_loss).max()
            if d.efficiency < 1 and np.any(m.qd[:, j] != 0):
                assert gear_loss.max() > 0
            loss = d.R * s.current**2 + d.L * s.current * s.current_rate \
                + (d.k_w - d.k_m) * s.speed * s.current + gear_loss
            assert np.allclose(req.elec_power[:, j] - req.mech_power[:, j], loss,
                               rtol=1e-9, atol=1e-9 * np.abs(req.elec_power[:, j]).max())


def test_mech_power_is_motor_shaft_power(cyl):
    """With lossless gears P·q̇ = T_m·ω_m; with the catalog efficiencies the motor gives more."""
    ideal = cyl.replace(drives=tuple(d.replace(efficiency=1.0) for d in cyl.drives))
    req = required_drive(ideal, FIG3)
    shaft = req.motor_torque * req.motor_speed
    assert np.allclose(req.mech_power, shaft, rtol=1e-12, atol=1e-9)
    lossy = required_drive(cyl, FIG3)
    assert any(d.efficiency < 1 for d in cyl.drives)
    assert np.all(lossy.mean_elec_power > req.mean_elec_power - 1e-12)
    shaft = lossy.motor_torque * lossy.motor_speed
    assert np.all(shaft - lossy.mech_power >= -1e-9)


def test_current_rate_matches_finite_differences(puma):
    """di/dt (limited derivative at t ± h) = a fine central difference of the smooth current."""
    traj = PUMA_MOVES[1]
    m = sample_motion(puma, traj, dt=1e-4)
    for j, d in enumerate(puma.drives):
        s = motor_series(d, d.ratio, m.tau[:, j], m.qd[:, j], m.qdd[:, j],
                         m.dtau_rigid[:, j], m.jerk[:, j])
        smooth = (m.tau[:, j] - abs(d.ratio) * coulomb_direction(d, m.qd[:, j])) / d.ratio / d.k_m
        fd = np.gradient(smooth, m.t, edge_order=2)
        assert np.abs(fd - s.current_rate)[2:-2].max() < 1e-5 * np.abs(s.current_rate).max()


def test_one_joint_closed_form():
    """One joint about the vertical: T_m, i and u_a (with L·di/dt) equal their closed forms."""
    d = Drive(J=1e-4, ratio=50.0, k_v=1e-4, M_f=(0.02, 0.03), R=1.5, L=1e-3, k_m=0.05,
              k_w=0.051, k_u=2.0, u_max=48.0)
    H = 0.01 + 2.0 * 0.3**2              # Izz + m·c², kg·m²; gravity along the axis: no load
    arm = manipcad.Robot.from_arrays("one", ["revolute"], [-1], np.eye(3)[None],
                                     np.zeros((1, 3)), [2.0], [[0.3, 0.0, 0.0]],
                                     np.eye(3)[None] * 0.01, drives=[d])
    traj = quintic([0.0], [2.0], 1.0)
    req = required_drive(arm, traj, t_end=1.0)
    s = req.t
    qd = 2.0 * (30 * s**2 - 60 * s**3 + 30 * s**4)
    qdd = 2.0 * (60 * s - 180 * s**2 + 120 * s**3)
    jerk = 2.0 * (60 - 360 * s + 360 * s**2)
    r = d.ratio
    fric = np.where(qd > 0, d.M_f[0], np.where(qd < 0, -d.M_f[1], 0.0))
    T = H * qdd / r + d.J * r * qdd + d.k_v * r * qd + fric
    assert np.allclose(req.motor_torque[:, 0], T, rtol=1e-12, atol=1e-12)
    i = T / d.k_m
    di = (H * jerk / r + d.J * r * jerk + d.k_v * r * qdd) / d.k_m
    u = d.R * i + d.L * di + d.k_w * r * qd
    assert np.allclose(req.current[:, 0], i, rtol=1e-12, atol=1e-12)
    # the jerk steps from 120 rad/s³ to 0 at the end of the move (t = 1 s, then the hold):
    # on that sample the limited derivative takes the smaller side, 0
    assert _rel(req.voltage[:-1, 0], u[:-1]) < 1e-6
    assert math.isclose(req.voltage[-1, 0], d.R * i[-1] + d.k_w * r * qd[-1], abs_tol=1e-12)
    assert math.isclose(req.peak_input_voltage[0], np.abs(u).max() / 2.0, rel_tol=1e-6)
    assert math.isclose(req.rms_current[0], math.sqrt(np.trapezoid(i**2, s)), rel_tol=1e-12)


def test_payload(cyl):
    base = required_drive(cyl, FIG3)
    heavy = required_drive(cyl, FIG3, payload=2.0)
    assert heavy.payload_mass == 2.0
    assert np.all(heavy.rms_torque[[0, 2]] > base.rms_torque[[0, 2]])
    with_com = required_drive(cyl, FIG3, payload={"mass": 2.0, "com": [0.0, 0.0, 0.1]})
    ref = required_drive(cyl.with_payload(2.0, (0.0, 0.0, 0.1)), FIG3)
    assert _rel(with_com.tau, ref.tau) < 1e-12
    for bad in (-1.0, {"mass": 1.0, "colour": "red"}, {"com": [0, 0, 0]}, "heavy"):
        with pytest.raises((InputError, ModelError)):
            required_drive(cyl, FIG3, payload=bad)


def test_bad_arguments(cyl):
    with pytest.raises(InputError, match="has 6 joints"):
        required_drive(cyl, PUMA_MOVES[0])
    with pytest.raises(InputError, match="dt"):
        required_drive(cyl, FIG3, dt=0.0)
    with pytest.raises(InputError, match="t_end"):
        required_drive(cyl, FIG3, t_end=-1.0)


def test_margins_and_status(cyl):
    req = required_drive(cyl, FIG3)
    c = req.checks["continuous"]
    assert np.allclose(c.required, req.rms_motor_torque)
    rated = np.array([0.187, 0.187, 0.8])   # N·m: RE 40, RE 40, RE 65 (the arm's motors)
    assert np.allclose(c.limit, rated)
    assert np.allclose(c.margin, 1 - req.rms_motor_torque / rated)
    for name, check in req.checks.items():
        if name == "position":       # judged by the room left, not by a ratio
            continue
        for j in range(3):
            unrated = ("n/a" if name in ("gear_average_speed", "velocity", "effort")
                       else "unknown")   # an optional rating, or no limit given
            expect = (unrated if math.isnan(check.margin[j])
                      else "pass" if check.margin[j] >= 0 else "fail")
            assert check.status[j] == expect, name
    # the belt and the ball screw give no peak rating: that check cannot be made
    assert req.checks["gear_peak"].status[1:] == ("unknown", "unknown")
    for j in range(3):
        states = {ch.status[j] for ch in req.checks.values()}
        assert req.status[j] == ("fail" if "fail" in states else
                                 "unknown" if "unknown" in states else "pass")


# ------------------------------------------------------------------------ ratio sweep
def test_sweep_reproduces_required_drive(cyl):
    """The sweep at the drive's own ratio gives required_drive's numbers."""
    req = required_drive(cyl, FIG3)
    for j in (0, 2):
        r0 = abs(cyl.drives[j].ratio)
        sw = ratio_sweep(cyl, FIG3, j, ratios=[r0 / 2, r0, 2 * r0])
        assert math.isclose(sw.rms_motor_torque[1], req.rms_motor_torque[j], rel_tol=1e-9)
        assert math.isclose(sw.peak_motor_torque[1], req.peak_motor_torque[j], rel_tol=1e-9)
        assert math.isclose(sw.peak_current[1], req.peak_current[j], rel_tol=1e-9)
        assert math.isclose(sw.peak_voltage[1], req.peak_voltage[j], rel_tol=1e-9)
        assert math.isclose(sw.peak_motor_speed[1], req.peak_motor_speed[j], rel_tol=1e-12)


@pytest.mark.parametrize("criterion", ["rms_torque", "peak_current"])
def test_sweep_best_inside_feasible_range(cyl, criterion):
    sw = ratio_sweep(cyl, FIG3, "turn", criterion=criterion)
    assert sw.feasible.any()
    assert sw.ratio_min <= sw.best_ratio <= sw.ratio_max
    assert any(a <= sw.best_ratio <= b for a, b in sw.intervals)
    key = "rms_motor_torque" if criterion == "rms_torque" else "peak_current"
    # no feasible grid ratio does better than the reported best
    assert sw.best_value <= np.min(getattr(sw, key)[sw.feasible]) * (1 + 1e-12)
    # the refined range edges: the tightest margin is ~0 there
    for edge in (sw.ratio_min, sw.ratio_max):
        one = ratio_sweep(cyl, FIG3, "turn", ratios=[edge, edge * (1 + 1e-9)])
        tight = min(one.margins[k][0] for k in one.limits_used)
        assert -1e-6 < tight < 1e-6 or edge in (sw.ratios[0], sw.ratios[-1])


def test_sweep_inertia_matching_optimum():
    """No friction, rigid load: least RMS motor torque at i_r⁴ = mean(P²)/(J²·mean(q̈²))."""
    J = 3e-5
    d = Drive(J=J, ratio=100.0, R=1.0, L=1e-3, k_m=0.06, k_w=0.06, rated_torque=10.0)
    arm = manipcad.Robot.from_arrays("one", ["revolute"], [-1], np.eye(3)[None],
                                     np.zeros((1, 3)), [5.0], [[0.4, 0.0, 0.0]],
                                     np.eye(3)[None] * 0.05, drives=[d], gravity=(0, -9.81, 0))
    traj = cosine([1.0], [6.0], 2 * np.pi / 6.0)
    sw = ratio_sweep(arm, traj, 0, ratios=np.geomspace(10, 10000, 301))
    m = sample_motion(arm, traj)
    t = m.t
    P2 = np.trapezoid(m.tau_rigid[:, 0] ** 2, t)
    A2 = np.trapezoid(m.qdd[:, 0] ** 2, t)
    r_star = (P2 / (J**2 * A2)) ** 0.25
    assert math.isclose(sw.best_ratio, r_star, rel_tol=1e-5)
    assert math.isclose(sw.optimum_ratio, r_star, rel_tol=1e-5)


def test_sweep_errors(cyl):
    with pytest.raises(ModelError, match="no known"):
        ratio_sweep(_load("stanford"), PUMA_MOVES[0], 0)    # no rating, no electrics
    with pytest.raises(InputError):
        ratio_sweep(cyl, FIG3, 0, ratios=[-1.0, 2.0])
    with pytest.raises(InputError):
        ratio_sweep(cyl, FIG3, 0, criterion="cheapest")
    with pytest.raises(ModelError):
        ratio_sweep(cyl.replace(drives=(None,) + cyl.drives[1:]), FIG3, 0)


# ------------------------------------------------------------------------ plot and CLI
def test_torque_speed_plot(cyl, tmp_path):
    req = required_drive(cyl, FIG3)
    out = torque_speed_plot(req, tmp_path / "ts.png")
    assert out.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    assert [p.name for p in tmp_path.iterdir()] == ["ts.png"]      # no temporary left
    with pytest.raises(InputError, match="does not exist"):
        torque_speed_plot(req, tmp_path / "nope" / "ts.png")
    with pytest.raises(InputError, match="format"):
        torque_speed_plot(req, tmp_path / "ts.xyz")


@pytest.fixture(scope="module")
def runner():
    return CliRunner()


def _app():
    from manipcad.cli import app
    return app


def test_cli_json_parses(runner, tmp_path):
    traj = tmp_path / "fig3.yaml"
    save_trajectory(FIG3, traj)
    res = runner.invoke(_app(), ["size", "cylindrical", "--trajectory", str(traj), "--json",
                                 "--plot", str(tmp_path / "p.png"), "--allow-unknown"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert [j["name"] for j in data["joints"]] == ["turn", "lift", "reach"]
    assert data["joints"][0]["units"]["peak_torque"] == "N·m"
    assert data["joints"][2]["units"]["peak_torque"] == "N"
    assert set(data["joints"][0]["checks"]) == {"continuous", "peak", "speed", "voltage",
                                                "gear_continuous", "gear_peak", "gear_speed",
                                                "gear_average", "gear_average_speed",
                                                "position", "velocity", "effort"}
    req = required_drive(_load("cylindrical"), FIG3)
    assert math.isclose(data["joints"][2]["peak_current"], req.peak_current[2], rel_tol=1e-12)
    assert (tmp_path / "p.png").is_file()


def test_cli_table(runner, tmp_path):
    traj = tmp_path / "fig3.yaml"
    save_trajectory(FIG3, traj)
    res = runner.invoke(_app(), ["size", "cylindrical", "-t", str(traj), "--payload", "1.5"])
    assert res.exit_code == 1, res.output            # a check fails: the answer is no
    for word in ("peak motor torque", "turn", "reach (P)", "maxon_re40_148877", "fail", "N·m"):
        assert word in res.stdout


@pytest.mark.parametrize("content, expect", [
    ("type: cosine\namplitude: [1, 2\n", "YAML syntax"),
    ("type: wobble\n", "unknown trajectory type"),
    ("type: cosine\namplitude: [0.1, 0.2]\nomega: [1.0, 2.0]\n", "has 2 joints"),
    (None, "no such file"),
])
def test_cli_bad_trajectory_exits_2(runner, tmp_path, content, expect):
    path = tmp_path / "t.yaml"
    if content is not None:
        path.write_text(content)
    res = runner.invoke(_app(), ["size", "cylindrical", "--trajectory", str(path)])
    assert res.exit_code == 2
    assert "Traceback" not in res.output
    assert expect in res.stderr
    assert len(res.stderr.strip().splitlines()) == 1


def test_cli_bad_options_exit_2(runner, tmp_path):
    traj = tmp_path / "fig3.yaml"
    save_trajectory(FIG3, traj)
    for extra in (["--dt", "0"], ["--payload", "-2"]):
        res = runner.invoke(_app(), ["size", "cylindrical", "-t", str(traj), *extra])
        assert res.exit_code == 2 and "Traceback" not in res.output
    res = runner.invoke(_app(), ["size", "no_such_robot", "-t", str(traj)])
    assert res.exit_code == 2 and "Traceback" not in res.output


def test_cli_unknown_exits_1_unless_allowed(runner, tmp_path):
    """The cylindrical arm passes every check that can be made on FIG3, but its belt and
    ball screw give no peak rating: exit 1, and 0 with --allow-unknown."""
    traj = tmp_path / "fig3.yaml"
    save_trajectory(FIG3, traj)
    req = required_drive(_load("cylindrical"), FIG3)
    assert "fail" not in req.status and "unknown" in req.status
    res = runner.invoke(_app(), ["size", "cylindrical", "-t", str(traj)])
    assert res.exit_code == 1 and "--allow-unknown" in res.stdout, res.output
    res = runner.invoke(_app(), ["size", "cylindrical", "-t", str(traj), "--allow-unknown"])
    assert res.exit_code == 0, res.output


# ------------------------------------------------------------------------ gear checks
def _ur5_with_csf20(tmp_path):
    """example-robot-data's UR5 with a CSF-20-100 on the shoulder lift and a motor strong
    enough that only the gear can fail (explicit ratings, SI units)."""
    import shutil

    from test_urdf import ERD_URDFS, erd_robots_dir

    shutil.copy(erd_robots_dir() / ERD_URDFS["ur5"], tmp_path)
    path = tmp_path / "ur5.yaml"
    path.write_text(
        "urdf: ur5_robot.urdf\n"
        "drives:\n"
        "  shoulder_lift_joint: {gear: harmonic_csf20_100, J: 1.0e-4, R: 0.2, L: 1.0e-4,\n"
        "    k_m: 0.1, k_w: 0.1, u_max: 48, rated_torque: 3.0, peak_torque: 10.0,\n"
        "    max_speed: 600}\n"
        "payload: {link: wrist_3_link, mass: 3.0}\n")
    return path


def test_gear_rated_torque_false_pass_is_caught(tmp_path):
    """The issue's false pass: a CSF-20 (40 N·m rated) carrying about 77 N·m RMS passed,
    because only the motor was checked. Now the gear check fails and so does the joint."""
    arm = manipcad.load_robot(_ur5_with_csf20(tmp_path))
    traj = cosine([0, 0.3, 0, 0, 0, 0], [0, 2.0, 0, 0, 0, 0], 3.0)
    req = required_drive(arm, traj)
    j = 1
    assert all(req.checks[k].status[j] == "pass" for k in ("continuous", "peak", "speed",
                                                            "voltage"))
    g = req.checks["gear_continuous"]
    assert g.limit[j] == 40.0 and g.required[j] > 70.0
    assert math.isclose(g.required[j], req.rms_gear_torque[j], rel_tol=1e-15)
    assert g.status[j] == "fail" and req.status[j] == "fail"
    assert req.checks["gear_peak"].status[j] == "pass"          # 82 N·m repeated peak
    # joints without a drive cannot be checked: unknown, never pass
    assert req.status[0] == "unknown"


def test_cli_gear_fail_exits_1(runner, tmp_path):
    traj = tmp_path / "t.yaml"
    save_trajectory(cosine([0, 0.3, 0, 0, 0, 0], [0, 2.0, 0, 0, 0, 0], 3.0), traj)
    res = runner.invoke(_app(), ["size", str(_ur5_with_csf20(tmp_path)), "-t", str(traj),
                                 "--allow-unknown"])
    assert res.exit_code == 1, res.output
    assert "gear_continuous" in res.stdout and "over a limit: shoulder_lift_joint" in res.stdout


def test_efficiency_closed_form():
    """One horizontal-axis joint (mass m at c, gear i_r, efficiency η). Holding the arm
    horizontal: T_m = m·g·c/(i_r·η) exactly. Swinging: against the same arm with η = 1,
    T_m(η) - T_m(1) = P_rigid·(1/η - 1)/i_r while the motor lifts (P_rigid·q̇ >= 0) and
    P_rigid·(η - 1)/i_r while the arm comes down driving the gear back."""
    eta, ratio, m, c, g = 0.7, 100.0, 2.0, 0.3, 9.81
    d = Drive(J=1e-4, ratio=ratio, R=1.0, L=1e-3, k_m=0.1, k_w=0.1, efficiency=eta)
    R_x = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])   # joint axis horizontal
    arm = manipcad.Robot.from_arrays("one", ["revolute"], [-1], R_x[None], np.zeros((1, 3)),
                                     [m], [[c, 0.0, 0.0]], np.eye(3)[None] * 0.01, drives=[d])
    hold = required_drive(arm, quintic([0.0], [0.0], 1.0), t_end=1.0)
    assert np.allclose(np.abs(hold.motor_torque[:, 0]), m * g * c / (ratio * eta), rtol=1e-12)
    traj = cosine([0.6], [3.0], 2.0)
    lossy = required_drive(arm, traj)
    ideal = required_drive(arm.replace(drives=(d.replace(efficiency=1.0),)), traj)
    P = ideal.tau[:, 0] - d.J * ratio**2 * ideal.qdd[:, 0]      # P_rigid (k_v = M_f = 0)
    lifting = P * ideal.qd[:, 0] >= 0
    assert lifting.any() and (~lifting).any()
    extra = lossy.motor_torque[:, 0] - ideal.motor_torque[:, 0]
    expect = np.where(lifting, P * (1 / eta - 1), P * (eta - 1)) / ratio
    assert np.allclose(extra, expect, rtol=1e-9, atol=1e-12)
