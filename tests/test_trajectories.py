"""Trajectories: closed forms, analytic derivatives, IK paths, gripper speed, YAML files."""

from __future__ import annotations

import os
from pathlib import Path

import numpy as np
import pytest
import yaml
from conftest import PUMA_MDH, mdh_robot

from manipcad.errors import InputError
from manipcad.kinematics import KinematicsError, jacobian, tool_pose
from manipcad.model.robot import Robot
from manipcad.trajectories import (
    Trajectory,
    circle,
    cosine,
    gripper_speed,
    line,
    load_trajectory,
    quintic,
    save_trajectory,
    spline,
    trapezoidal,
)
from manipcad.trajectories import io as traj_io

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"

PUMA = mdh_robot(PUMA_MDH, tool_p=(0.0, 0.0, 0.1), name="puma_mdh")
PUMA_Q0 = np.array([0.1, -0.6, 0.4, 0.2, 0.7, -0.3])
# the paper's Fig. 2 arm: turn q1 about the vertical (rad), lift q2 (m), radial reach q3 (m)
CYL = mdh_robot([
    ("R", 0.0, 0.0, 0.40, 0.0),
    ("P", 0.0, 0.0, 0.20, 0.0),
    ("P", 0.0, -np.pi / 2, 0.0, 0.0),
], name="cylindrical")
# a 3R arm (vertical turn, shoulder, elbow) with a 1 m reach
ARM3R = mdh_robot([
    ("R", 0.0, 0.0, 0.4, 0.0),
    ("R", 0.0, -np.pi / 2, 0.0, 0.0),
    ("R", 0.5, 0.0, 0.0, 0.0),
], tool_p=(0.5, 0.0, 0.0), name="arm3r")


def numeric_derivatives(traj: Trajectory, t: np.ndarray, h: float = 1e-5):
    """Central differences of q and qd at times t (s)."""
    qp, qdp, _ = traj.sample(t + h)
    qm, qdm, _ = traj.sample(t - h)
    return (qp - qm) / (2 * h), (qdp - qdm) / (2 * h)


def assert_derivatives(traj: Trajectory, t: np.ndarray, rtol: float = 1e-7):
    q, qd, qdd = traj.sample(t)
    qd_num, qdd_num = numeric_derivatives(traj, t)
    np.testing.assert_allclose(qd, qd_num, atol=rtol * max(1.0, np.abs(qd).max()))
    np.testing.assert_allclose(qdd, qdd_num, atol=rtol * max(1.0, np.abs(qdd).max()))


# ------------------------------------------------------------------ cosine law
def test_cosine_is_the_closed_form_exactly():
    A = np.array([0.5, 0.0, 0.25])
    w = np.array([4.0, 0.0, 16.0])
    traj = cosine(A, w, duration=1.6)
    t = np.linspace(0.0, 1.6, 321)
    q, qd, qdd = traj.sample(t)
    wt = t[:, None] * w
    np.testing.assert_array_equal(q, 0.0 + A * (1.0 - np.cos(wt)))
    np.testing.assert_array_equal(qd, A * w * np.sin(wt))
    np.testing.assert_array_equal(qdd, A * w * w * np.cos(wt))
    # the paper's laws (2) written out
    np.testing.assert_allclose(q[:, 0], 0.5 * (1 - np.cos(4 * t)), rtol=0, atol=1e-16)
    np.testing.assert_allclose(q[:, 2], 0.25 * (1 - np.cos(16 * t)), rtol=0, atol=1e-16)
    assert not q[:, 1].any() and not qd[:, 1].any()
    # the reach moves 0.5 m at up to 4 m/s, as DESIGN.md reads the paper
    assert traj.sample(np.pi / 16)[0][2] == pytest.approx(0.5, rel=1e-15)
    assert traj.sample(np.pi / 32)[1][2] == pytest.approx(4.0, rel=1e-15)


def test_cosine_derivatives_and_defaults():
    traj = cosine([0.3, -0.2], [2.0, 5.0], q0=[0.1, 0.2])
    assert traj.duration == pytest.approx(np.pi)  # one period of the slowest joint
    assert_derivatives(traj, np.linspace(0.01, np.pi - 0.01, 57))
    np.testing.assert_allclose(traj.sample(traj.duration)[0], [0.1, 0.2 - 0.2 * (1 - np.cos(
        5 * np.pi))], atol=1e-15)
    assert cosine([0.0], [0.0]).duration == 0.0
    assert cosine(0.1, [1.0, 2.0, 4.0]).n == 3


def test_fig3_example_file():
    traj = load_trajectory(EXAMPLES / "fig3_laws.yaml")
    ref = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], duration=1.6)
    assert traj.duration == 1.6 and traj.n == 3
    t = np.linspace(0.0, 2.0, 201)
    for a, b in zip(traj.sample(t), ref.sample(t), strict=True):
        np.testing.assert_array_equal(a, b)


# ------------------------------------------------------- hold after the duration
@pytest.mark.parametrize("make", [
    lambda: cosine([0.5, 0.25], [4.0, 16.0], duration=1.6),
    lambda: quintic([0.0, 1.0], [1.0, -1.0], 2.0),
    lambda: trapezoidal([0.0, 1.0], [1.0, -1.0], v_max=1.0, a_max=2.0),
    lambda: spline([0.0, 0.5, 1.2], [[0.0, 1.0], [0.5, 0.0], [1.0, -1.0]]),
])
def test_hold_after_duration(make):
    traj = make()
    T = traj.duration
    q_end = traj.sample(T)[0]
    q, qd, qdd = traj.sample(np.array([T + 1e-9, T + 1.0, 10 * T + 5]))
    np.testing.assert_array_equal(q, np.tile(q_end, (3, 1)))
    assert not qd.any() and not qdd.any()
    # a scalar time gives joint vectors
    qs, qds, qdds = traj.sample(0.3 * T)
    assert qs.shape == qds.shape == qdds.shape == (traj.n,)
    with pytest.raises(InputError, match="t"):
        traj.sample(-0.1)
    with pytest.raises(InputError):
        traj.sample(np.array([0.0, np.nan]))


# ------------------------------------------------------------- point to point
def test_quintic_matches_toolbox_jtraj():
    rtb = pytest.importorskip("roboticstoolbox")
    qs, qe, T = np.array([0.1, -0.4, 0.3]), np.array([1.0, 0.6, -0.2]), 2.5
    t = np.linspace(0.0, T, 101)
    q, qd, qdd = quintic(qs, qe, T).sample(t)
    ref = rtb.jtraj(qs, qe, t)
    np.testing.assert_allclose(q, ref.q, atol=1e-13)
    np.testing.assert_allclose(qd, ref.qd, atol=1e-13)
    np.testing.assert_allclose(qdd, ref.qdd, atol=1e-12)
    for k in (0, -1):
        assert not qd[k].any() and np.abs(qdd[k]).max() < 1e-15
    np.testing.assert_array_equal(q[-1], qe)


def test_quintic_derivatives():
    traj = quintic([0.0, 2.0], [1.0, -1.0], 1.3)
    assert_derivatives(traj, np.linspace(1e-3, 1.3 - 1e-3, 41))
    D = np.array([1.0, -3.0])
    assert np.abs(traj.sample(0.65)[1] - 1.875 * D / 1.3).max() < 1e-14


def test_trapezoidal_limits_and_synchronisation():
    qs, qe = np.array([0.0, 1.0, 0.5]), np.array([2.0, 0.0, 0.5])
    vmax, amax = np.array([1.0, 0.4, 1.0]), np.array([2.0, 3.0, 1.0])
    traj = trapezoidal(qs, qe, v_max=vmax, a_max=amax)
    assert not traj.triangular
    # joint 0 limits: V = min(1/2, 0.4/1) = 0.4 /s, A = min(2/2, 3/1) = 1 /s²
    assert traj.t_accel == pytest.approx(0.4) and traj.duration == pytest.approx(0.4 + 2.5)
    t = np.linspace(0.0, traj.duration, 2001)
    q, qd, qdd = traj.sample(t)
    assert np.all(np.abs(qd) <= vmax + 1e-12) and np.all(np.abs(qdd) <= amax + 1e-12)
    assert np.abs(qd[:, 1]).max() == pytest.approx(0.4)  # the limiting joint reaches v_max
    np.testing.assert_allclose(q[-1], qe, atol=1e-14)
    assert not qd[[0, -1]].any()
    # synchronised: every joint is at the same fraction of its move
    frac = (q - qs)[:, :2] / (qe - qs)[:2]
    np.testing.assert_allclose(frac[:, 0], frac[:, 1], atol=1e-14)
    assert not (q[:, 2] - 0.5).any()
    # derivatives inside each phase
    ta, T = traj.t_accel, traj.duration
    for a, b in ((1e-3, ta - 1e-3), (ta + 1e-3, T - ta - 1e-3), (T - ta + 1e-3, T - 1e-3)):
        assert_derivatives(traj, np.linspace(a, b, 15))


def test_trapezoidal_triangular():
    traj = trapezoidal([0.0], [0.5], v_max=10.0, a_max=2.0)
    assert traj.triangular
    assert traj.duration == pytest.approx(2 * np.sqrt(0.5 / 2.0))
    q, qd, _ = traj.sample(np.linspace(0, traj.duration, 1001))
    assert np.abs(qd).max() == pytest.approx(np.sqrt(0.5 * 2.0), rel=1e-6)
    assert trapezoidal([1.0, 2.0], [1.0, 2.0], v_max=1.0, a_max=1.0).duration == 0.0


# ------------------------------------------------------------------- spline
def test_spline_via_points_and_continuity():
    times = np.array([0.0, 0.4, 1.0, 1.5, 2.2])
    pts = np.array([[0.0, 0.1], [0.5, -0.3], [0.2, 0.4], [0.9, 0.0], [1.0, 0.2]])
    traj = spline(times, pts)
    q, qd, qdd = traj.sample(times)
    np.testing.assert_allclose(q, pts, atol=1e-14)
    assert np.abs(qd[[0, -1]]).max() < 1e-14
    eps = 1e-9
    for tk in times[1:-1]:  # C2 at the interior knots
        _, qd_k, qdd_k = traj.sample(np.array([tk - eps, tk + eps]))
        np.testing.assert_allclose(qd_k[0], qd_k[1], atol=1e-6)
        np.testing.assert_allclose(qdd_k[0], qdd_k[1], atol=1e-6)
    inner = np.concatenate([np.linspace(a + 1e-3, b - 1e-3, 9)
                            for a, b in zip(times[:-1], times[1:], strict=True)])
    assert_derivatives(traj, inner)


def test_spline_holds_before_first_time():
    traj = spline([0.5, 1.0], [[1.0], [2.0]])
    q, qd, qdd = traj.sample(np.array([0.0, 0.25]))
    assert q.tolist() == [[1.0], [1.0]] and not qd.any() and not qdd.any()


# ------------------------------------------------------ gripper paths through IK
def assert_on_path(traj, t, tol=1e-9):
    q, qd, qdd = traj.sample(t)
    x, xd, xdd = traj.path(t)
    pos = tool_pose(traj.robot, q)[:, :3, 3]
    assert np.linalg.norm(pos - x, axis=1).max() < tol
    J = jacobian(traj.robot, q)
    np.testing.assert_allclose(np.einsum("kij,kj->ki", J[:, :3], qd), xd, atol=1e-10)
    return q, qd, qdd, J


def test_line_ik_reaches_points_cylindrical():
    p0 = tool_pose(CYL, np.array([0.2, 0.1, 0.3]))[:3, 3]
    p1 = p0 + np.array([-0.2, 0.25, 0.1])
    traj = line(CYL, p0, p1, 1.2, q0=[0.0, 0.0, 0.2])
    t = np.linspace(0.0, 1.2, 121)
    assert_on_path(traj, t)
    assert_derivatives(traj, t[1:-1])
    np.testing.assert_allclose(traj.sample(1.2)[0], traj.sample(5.0)[0])


@pytest.mark.parametrize("orientation", ["free", "fixed"])
@pytest.mark.parametrize("profile", ["quintic", "cubic", "linear"])
def test_line_ik_puma(orientation, profile):
    p0 = tool_pose(PUMA, PUMA_Q0)[:3, 3]
    p1 = p0 + np.array([-0.1, -0.15, -0.1])
    traj = line(PUMA, p0, p1, 1.0, q0=PUMA_Q0, profile=profile, orientation=orientation)
    t = np.linspace(0.0, 1.0, 101)
    q, qd, qdd, J = assert_on_path(traj, t)
    if orientation == "fixed":
        R0 = tool_pose(PUMA, PUMA_Q0)[:3, :3]
        assert np.abs(tool_pose(PUMA, q)[:, :3, :3] - R0).max() < 1e-10
        assert np.abs(np.einsum("kij,kj->ki", J[:, 3:], qd)).max() < 1e-10
    # the redundant (free orientation) case checks the null-space term of qdd too
    assert_derivatives(traj, t[1:-1], rtol=1e-6)
    speed = gripper_speed(PUMA, traj, t)
    _, xd, _ = traj.path(t)
    np.testing.assert_allclose(speed, np.linalg.norm(xd, axis=1), atol=1e-10)


def test_circle_ik():
    center = tool_pose(PUMA, PUMA_Q0)[:3, 3] + [0.0, 0.05, 0.0]
    traj = circle(PUMA, center, 0.08, [1.0, 1.0, 0.0], 2.0, q0=PUMA_Q0)
    t = np.linspace(0.0, 2.0, 161)
    q, *_ = assert_on_path(traj, t)
    x = tool_pose(PUMA, q)[:, :3, 3]
    nrm = np.array([1.0, 1.0, 0.0]) / np.sqrt(2)
    np.testing.assert_allclose(np.linalg.norm(x - center, axis=1), 0.08, atol=1e-9)
    np.testing.assert_allclose((x - center) @ nrm, 0.0, atol=1e-9)
    np.testing.assert_allclose(x[0], x[-1], atol=1e-9)  # a full turn
    assert_derivatives(traj, t[1:-1], rtol=1e-6)
    # turns about the normal by the right-hand rule
    _, xd, _ = traj.path(np.array([1.0]))
    assert np.cross(x[80] - center, xd[0]) @ nrm > 0


def test_path_errors():
    far = tool_pose(CYL, np.array([0.0, 0.0, 0.3]))[:3, 3]
    with pytest.raises(InputError, match="profile"):
        line(CYL, far, far + 0.1, 1.0, q0=[0, 0, 0.3], profile="bang")
    with pytest.raises(InputError, match="at least 6"):
        line(CYL, far, far + 0.1, 1.0, q0=[0, 0, 0.3], orientation="fixed")
    with pytest.raises(InputError, match="radius"):
        circle(CYL, far, -0.1, [0, 0, 1], 1.0, q0=[0, 0, 0.3])
    # out of the reach of a 3R arm: it stretches into its boundary singularity
    q0 = np.array([0.2, 0.5, -0.9])
    p0 = tool_pose(ARM3R, q0)[:3, 3]
    with pytest.raises(KinematicsError, match="singularity|cannot be followed"):
        line(ARM3R, p0, p0 + [1.5, 0.0, 0.0], 1.0, q0=q0)
    limited = CYL.replace(limits=np.array([[-3.0, 3.0], [-1.0, 1.0], [0.0, 0.35]]))
    with pytest.raises(KinematicsError, match="limits"):
        line(limited, far, far + [0.2, 0.0, 0.0], 1.0, q0=[0, 0, 0.3])


def test_gripper_speed_cylindrical_fig3():
    traj = load_trajectory(EXAMPLES / "fig3_laws.yaml")
    t = np.linspace(0.0, 1.6, 161)
    q, qd, _ = traj.sample(t)
    # tool at radius r = q3 (here the reach axis meets the vertical): v² = (r q1')² + q3'²
    ref = np.hypot(q[:, 2] * qd[:, 0], qd[:, 2])
    np.testing.assert_allclose(gripper_speed(CYL, traj, t), ref, atol=1e-13)
    assert gripper_speed(CYL, traj, 2.0) == 0.0
    with pytest.raises(InputError, match="joints"):
        gripper_speed(PUMA, traj, t)


def _catalog_robot(name: str) -> Robot:
    from manipcad.model.load import catalog_names, load_robot

    if name not in catalog_names():
        pytest.skip(f"catalog robot {name!r} not available")
    return load_robot(name)


@pytest.mark.filterwarnings("ignore::UserWarning")
def test_fig3_on_catalog_cylindrical_arm(tmp_path):
    robot = _catalog_robot("cylindrical")
    traj = load_trajectory(EXAMPLES / "fig3_laws.yaml")
    t = np.linspace(0.0, 1.6, 161)
    q, qd, _ = traj.sample(t)
    x = tool_pose(robot, q)[:, :3, 3]
    # turn about the vertical, lift vertical, reach radial: v² = (r q1')² + q3'²
    ref = np.hypot(np.hypot(x[:, 0], x[:, 1]) * qd[:, 0], qd[:, 2])
    np.testing.assert_allclose(gripper_speed(robot, traj, t), ref, atol=1e-12)
    # a straight line of the gripper inside the arm's strokes, saved by catalog name
    p0 = tool_pose(robot, np.array([0.3, 0.2, 0.2]))[:3, 3]
    p1 = tool_pose(robot, np.array([0.8, 0.4, 0.35]))[:3, 3]
    path = line(robot, p0, p1, 1.0, q0=[0.0, 0.3, 0.25])
    assert_on_path(path, np.linspace(0.0, 1.0, 51))
    save_trajectory(path, tmp_path / "line.yaml")
    assert yaml.safe_load((tmp_path / "line.yaml").read_text())["robot"] == "cylindrical"
    back = load_trajectory(tmp_path / "line.yaml")
    np.testing.assert_allclose(back.sample(0.5)[0], path.sample(0.5)[0], atol=1e-12)


# ------------------------------------------------------------------ YAML files
def joint_laws():
    return [
        cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], duration=1.6, q0=[0.1, 0.2, 0.3]),
        quintic([0.1, -0.2], [1.0 / 3.0, 2.0], 1.7),
        trapezoidal([0.0, 1.0], [np.pi, 0.5], v_max=[1.0, 0.3], a_max=2.0),
        spline([0.0, 0.3, 1.1], [[0.0, 1e-17], [0.25, 0.5], [1.0, -0.1]]),
    ]


@pytest.mark.parametrize("traj", joint_laws(), ids=lambda tr: tr.kind)
def test_yaml_round_trip(tmp_path, traj):
    path = tmp_path / f"{traj.kind}.yaml"
    save_trajectory(traj, path)
    back = load_trajectory(path)
    assert type(back) is type(traj) and back.to_dict() == traj.to_dict()
    t = np.linspace(0.0, traj.duration * 1.2, 50)
    for a, b in zip(back.sample(t), traj.sample(t), strict=True):
        np.testing.assert_array_equal(a, b)
    assert yaml.safe_load(path.read_text())["type"] == traj.kind


def test_yaml_round_trip_paths(tmp_path):
    p0 = tool_pose(PUMA, PUMA_Q0)[:3, 3]
    for traj in (line(PUMA, p0, p0 + [0.1, 0.0, -0.1], 0.8, q0=PUMA_Q0, orientation="fixed"),
                 circle(PUMA, p0 + [0.0, 0.0, 0.05], 0.05, [0, 0, 1], 1.5, q0=PUMA_Q0,
                        angle=np.pi, profile="cubic")):
        path = tmp_path / f"{traj.kind}.yaml"
        save_trajectory(traj, path)
        data = yaml.safe_load(path.read_text())
        assert data["robot"] == "puma_mdh"
        back = load_trajectory(path, robot=PUMA)
        assert back.to_dict() == traj.to_dict()
        t = np.linspace(0.0, traj.duration, 21)
        for a, b in zip(back.sample(t), traj.sample(t), strict=True):
            np.testing.assert_allclose(a, b, atol=1e-9)
        # without a robot to resolve it, the file's robot name must load
        with pytest.raises(InputError) as info:
            load_trajectory(path)
        assert info.value.field == "robot" and info.value.source == str(path)


BAD_FILES = [
    ("type: cosine\namplitude: [0.5, 0\n", "", "YAML syntax"),
    ("- 1\n- 2\n", "", "mapping"),
    ("", "", "empty"),
    ("amplitude: [1.0]\nomega: [1.0]\n", "type", "missing"),
    ("type: wobble\n", "type", "unknown trajectory type 'wobble'"),
    ("type: cosine\namplitude: [0.5]\nomega: [4.0]\nspeed: 3\n", "speed", "unknown field"),
    ("type: cosine\namplitude: [0.5, 0.1, 0.2]\nomega: [4.0, 1.0]\n", "omega", "3"),
    ("type: cosine\namplitude: [0.5, x]\nomega: [4.0, 1.0]\n", "amplitude[1]", "number"),
    ("type: cosine\namplitude: [0.5, .inf]\nomega: [4.0, 1.0]\n", "amplitude[1]", "finite"),
    ("type: cosine\namplitude: [0.5]\nomega: [-4.0]\n", "omega[0]", ">= 0"),
    ("type: cosine\namplitude: [0.5]\nomega: [4.0]\nduration: -1.0\n", "duration", ">= 0"),
    ("type: quintic\nq_start: [0.0, 1.0]\nq_end: [1.0]\nduration: 1.0\n", "q_end", "2"),
    ("type: quintic\nq_start: [0.0]\nq_end: [1.0]\nduration: 0\n", "duration", "> 0"),
    ("type: quintic\nq_start: [0.0]\nduration: 1.0\n", "q_end", "missing"),
    ("type: quintic\nq_start: [0.0]\nq_end: '1.0'\nduration: 1.0\n", "q_end", "list"),
    ("type: trapezoidal\nq_start: [0.0]\nq_end: [1.0]\nv_max: [-1.0]\na_max: 1.0\n",
     "v_max[0]", "> 0"),
    ("type: spline\ntimes: [0.0, 1.0, 0.5]\npoints: [[0.0], [1.0], [2.0]]\n",
     "times[2]", "strictly increasing"),
    ("type: spline\ntimes: [0.0, 1.0]\npoints: [[0.0, 1.0], [1.0]]\n", "points[1]", "2"),
    ("type: spline\ntimes: [0.0, 1.0, 2.0]\npoints: [[0.0], [1.0]]\n", "points", "3 times"),
    ("type: spline\ntimes: [-1.0, 1.0]\npoints: [[0.0], [1.0]]\n", "times[0]", ">= 0"),
    ("type: line\np_start: [0.3, 0, 0.6]\np_end: [0.1, 0, 0.6]\nduration: 1.0\n"
     "q0: [0, 0, 0.3]\nprofile: bang\n", "profile", "quintic"),
    ("type: line\nrobot: no_such_robot_xyz\np_start: [0.3, 0, 0.6]\np_end: [0.1, 0, 0.6]\n"
     "duration: 1.0\nq0: [0, 0, 0.3]\n", "robot", "no_such_robot_xyz"),
    ("type: circle\ncenter: [0.3, 0, 0.6]\nradius: 0.1\nnormal: [0, 0, 0]\nduration: 1.0\n"
     "q0: [0, 0, 0.3]\n", "normal", "zero"),
]


@pytest.mark.parametrize("text, field, reason", BAD_FILES)
def test_bad_files_name_file_and_field(tmp_path, text, field, reason):
    path = tmp_path / "bad.yaml"
    path.write_text(text)
    override = CYL if "type: line" in text and "robot:" not in text or "circle" in text else None
    with pytest.raises(InputError) as info:
        load_trajectory(path, robot=override)
    err = info.value
    assert err.source == str(path)
    assert err.field == field
    assert reason in err.reason
    assert str(path) in str(err)


def test_unreachable_path_file(tmp_path):
    path = tmp_path / "far.yaml"
    path.write_text("type: line\np_start: [3.0, 0, 0.6]\np_end: [0.1, 0, 0.6]\n"
                    "duration: 1.0\nq0: [0, 0, 0.3]\n")
    with pytest.raises(InputError, match="cannot be followed") as info:
        load_trajectory(path, robot=ARM3R)
    assert info.value.source == str(path)


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_trajectory(tmp_path / "nope.yaml")


# --------------------------------------------------------------- atomic saves
def _old_file(tmp_path) -> tuple[Path, bytes]:
    path = tmp_path / "keep.yaml"
    save_trajectory(quintic([0.0], [1.0], 1.0), path)
    return path, path.read_bytes()


def _leftovers(tmp_path) -> list[str]:
    return sorted(p.name for p in tmp_path.iterdir() if p.name != "keep.yaml")


def test_failed_save_keeps_old_file(tmp_path, monkeypatch):
    path, old = _old_file(tmp_path)

    def broken_replace(src, dst):
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(traj_io.os, "replace", broken_replace)
    with pytest.raises(InputError, match="No space left") as info:
        save_trajectory(cosine([0.5], [4.0], 1.6), path)
    assert info.value.source == str(path)
    assert path.read_bytes() == old and _leftovers(tmp_path) == []


def test_interrupted_save_keeps_old_file(tmp_path, monkeypatch):
    path, old = _old_file(tmp_path)

    def interrupt(fd):
        raise KeyboardInterrupt

    monkeypatch.setattr(traj_io.os, "fsync", interrupt)
    with pytest.raises(KeyboardInterrupt):
        save_trajectory(cosine([0.5], [4.0], 1.6), path)
    assert path.read_bytes() == old and _leftovers(tmp_path) == []
    assert load_trajectory(path).to_dict()["type"] == "quintic"


def test_unserialisable_trajectory_keeps_old_file(tmp_path):
    path, old = _old_file(tmp_path)

    class Broken(Trajectory):
        n = 1
        duration = 1.0

        def _evaluate(self, t):  # pragma: no cover - never sampled
            raise AssertionError

        def to_dict(self):
            raise RuntimeError("cannot describe")

    with pytest.raises(RuntimeError):
        save_trajectory(Broken(), path)
    assert path.read_bytes() == old and _leftovers(tmp_path) == []


def test_save_into_missing_folder(tmp_path):
    with pytest.raises(InputError, match="does not exist"):
        save_trajectory(quintic([0.0], [1.0], 1.0), tmp_path / "nope" / "a.yaml")


def test_save_keeps_permissions(tmp_path):
    path, _ = _old_file(tmp_path)
    os.chmod(path, 0o600)
    save_trajectory(cosine([0.5], [4.0], 1.6), path)
    assert (path.stat().st_mode & 0o777) == 0o600


# ------------------------------------------------------------ argument checks
@pytest.mark.parametrize("call, field", [
    (lambda: cosine([0.5, 0.2, 0.1], [1.0, 2.0]), "omega"),
    (lambda: cosine([0.5], [1.0], q0=[0.0, 1.0]), "q0"),
    (lambda: quintic([0.0], [1.0], -2.0), "duration"),
    (lambda: quintic([], [], 1.0), "q_start"),
    (lambda: trapezoidal([0.0], [1.0], v_max=0.0, a_max=1.0), "v_max[0]"),
    (lambda: trapezoidal([0.0], [1.0], v_max=1.0, a_max=[1.0, 2.0]), "a_max"),
    (lambda: spline([0.0], [[1.0]]), "times"),
    (lambda: spline([0.0, 0.0], [[1.0], [2.0]]), "times[1]"),
])
def test_constructor_errors_name_the_field(call, field):
    with pytest.raises(InputError) as info:
        call()
    assert info.value.field == field


def test_point_to_point_rows_compiled_are_the_broadcast_numbers():
    """A long sample (>= 64 times, compiled rows) equals numpy's broadcast of the same
    formula bit for bit: q = q_start + s·D, q̇ = ṡ·D, q̈ = s̈·D (quintic and trapezoid)."""
    from manipcad.trajectories import quintic, trapezoidal

    rng = np.random.default_rng(5)
    for traj in (quintic(rng.uniform(-2, 2, 7), rng.uniform(-2, 2, 7), 0.8),
                 trapezoidal(rng.uniform(-2, 2, 3), rng.uniform(-2, 2, 3), v_max=2.0,
                             a_max=5.0)):
        t = np.sort(rng.uniform(0.0, 1.2 * traj.duration, 500))
        q, qd, qdd = traj.sample(t)
        s, sd, sdd = traj._profile(np.minimum(t, traj.duration))
        D = traj.q_end - traj.q_start
        held = t > traj.duration
        want = (traj.q_start + s[:, None] * D, sd[:, None] * D, sdd[:, None] * D)
        want[1][held] = 0.0
        want[2][held] = 0.0
        for got, w in zip((q, qd, qdd), want, strict=True):
            assert got.shape == (500, traj.n) and got.flags.c_contiguous
            assert np.array_equal(got, w)
        short = traj.sample(t[:10])
        assert all(np.array_equal(a, b[:10]) for a, b in zip(short, (q, qd, qdd), strict=True))
