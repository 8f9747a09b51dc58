"""Forward kinematics, Jacobians and inverse kinematics against independent implementations.

References: the Robotics Toolbox for Python (DHRobot built from the same
modified-DH tables), Pinocchio (a model built joint by joint from the same tree,
and the UR5 URDF of example-robot-data when the URDF loader is present), and
finite differences.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from conftest import PUMA_MDH, mdh_robot

from manipcad.errors import InputError, ManipcadError
from manipcad.kinematics import (
    KinematicsError,
    forward_kinematics,
    inverse_kinematics,
    jacobian,
    jacobian_dot,
    point_position,
    tool_pose,
)
from manipcad.model.dh import rot_x, rot_z
from manipcad.model.robot import Robot

rtb = pytest.importorskip("roboticstoolbox")
pin = pytest.importorskip("pinocchio")
SE3 = pytest.importorskip("spatialmath").SE3

TOL = 1e-12

# modified DH rows: (type, a_{i-1} m, alpha_{i-1} rad, d_i m, theta_i rad); the
# joint variable adds to theta (revolute) or d (prismatic); PUMA_MDH is in conftest.py
# the cylindrical arm of the paper's Fig. 2: turn about the vertical, lift, radial reach
CYL_MDH = [
    ("R", 0.0, 0.0, 0.40, 0.0),
    ("P", 0.0, 0.0, 0.20, 0.0),
    ("P", 0.05, -np.pi / 2, 0.30, 0.0),
]
# a mixed chain with offsets on every joint
MIXED_MDH = [
    ("R", 0.1, 0.3, 0.2, 0.4),
    ("P", 0.2, -1.1, 0.1, 0.7),
    ("R", 0.3, 0.5, -0.2, -0.3),
    ("R", 0.0, 1.4, 0.15, 1.0),
    ("P", 0.12, -0.6, 0.05, 0.2),
]
TOOL = SE3.Rx(0.3) * SE3.Ry(-0.2) * SE3(0.01, 0.02, 0.11)


def rtb_robot(rows, tool=None):
    links = []
    for kind, a, alpha, d, theta in rows:
        if kind == "R":
            links.append(rtb.RevoluteMDH(a=a, alpha=alpha, d=d, offset=theta))
        else:
            links.append(rtb.PrismaticMDH(a=a, alpha=alpha, theta=theta, offset=d))
    return rtb.DHRobot(links, tool=tool if tool is not None else SE3())


TABLES = {"puma": PUMA_MDH, "cylindrical": CYL_MDH, "mixed": MIXED_MDH}


@pytest.fixture(params=sorted(TABLES))
def pair(request):
    rows = TABLES[request.param]
    return mdh_robot(rows, TOOL.A), rtb_robot(rows, TOOL)


def random_q(n: int, count: int, seed: int = 0) -> np.ndarray:
    return np.random.default_rng(seed).uniform(-1.5, 1.5, (count, n))


# ------------------------------------------------------------- vs the Toolbox
def test_forward_kinematics_matches_rtb(pair):
    robot, ref = pair
    for q in random_q(robot.n, 20):
        T = forward_kinematics(robot, q)
        all_ref = ref.fkine_all(q)
        for i in range(robot.n):
            np.testing.assert_allclose(T[i], all_ref[i + 1].A, atol=TOL, rtol=0)
        np.testing.assert_allclose(tool_pose(robot, q), ref.fkine(q).A, atol=TOL, rtol=0)


def test_jacobian_matches_rtb(pair):
    robot, ref = pair
    for q in random_q(robot.n, 20, seed=1):
        np.testing.assert_allclose(jacobian(robot, q), ref.jacob0(q), atol=TOL, rtol=0)
        np.testing.assert_allclose(jacobian(robot, q, frame="local"), ref.jacobe(q),
                                   atol=TOL, rtol=0)


def test_batch_matches_single(pair):
    robot, _ = pair
    Q = random_q(robot.n, 7, seed=2)
    Qd = random_q(robot.n, 7, seed=3)
    T = forward_kinematics(robot, Q)
    assert T.shape == (7, robot.n, 4, 4)
    assert tool_pose(robot, Q).shape == (7, 4, 4)
    J = jacobian(robot, Q)
    assert J.shape == (7, 6, robot.n)
    Jd = jacobian_dot(robot, Q, Qd)
    for k in range(7):
        np.testing.assert_array_equal(T[k], forward_kinematics(robot, Q[k]))
        np.testing.assert_allclose(J[k], jacobian(robot, Q[k]), atol=1e-15)
        np.testing.assert_allclose(Jd[k], jacobian_dot(robot, Q[k], Qd[k]), atol=1e-15)


# ---------------------------------------------------------- finite differences
def test_jacobian_matches_finite_differences(pair):
    robot, _ = pair
    h = 1e-6
    c = np.array([0.03, -0.02, 0.05])
    for q in random_q(robot.n, 5, seed=4):
        for link in range(robot.n):
            J = jacobian(robot, q, link=link, point=c)
            R0 = forward_kinematics(robot, q)[link, :3, :3]
            for j in range(robot.n):
                dq = np.zeros(robot.n)
                dq[j] = h
                dx = (point_position(robot, q + dq, link, c)
                      - point_position(robot, q - dq, link, c)) / (2 * h)
                np.testing.assert_allclose(J[:3, j], dx, atol=1e-8)
                dR = (forward_kinematics(robot, q + dq)[link, :3, :3]
                      - forward_kinematics(robot, q - dq)[link, :3, :3]) / (2 * h)
                W = dR @ R0.T
                np.testing.assert_allclose(J[3:, j], [W[2, 1], W[0, 2], W[1, 0]], atol=1e-8)
                if j > link:  # serial chain: later joints do not move this link
                    assert not J[:, j].any()


def test_jacobian_dot_matches_finite_differences(pair):
    robot, _ = pair
    h = 1e-6
    for q, qd in zip(random_q(robot.n, 5, seed=5), random_q(robot.n, 5, seed=6), strict=True):
        for link in (-1, robot.n // 2):
            Jd = jacobian_dot(robot, q, qd, link=link)
            fd = (jacobian(robot, q + h * qd, link=link)
                  - jacobian(robot, q - h * qd, link=link)) / (2 * h)
            np.testing.assert_allclose(Jd, fd, atol=1e-8)


# ------------------------------------------------------------------ vs Pinocchio
def pinocchio_model(robot: Robot, points: dict[str, tuple[int, np.ndarray]]):
    """The same tree built joint by joint in Pinocchio, with a frame per point."""
    model = pin.Model()
    ids = []
    for i in range(robot.n):
        parent = 0 if robot.parent[i] < 0 else ids[robot.parent[i]]
        jm = pin.JointModelRZ() if robot.joint_types[i] == "revolute" else pin.JointModelPZ()
        M = pin.SE3(robot.placement_R[i], robot.placement_p[i])
        jid = model.addJoint(parent, jm, M, robot.joint_names[i])
        model.appendBodyToJoint(jid, pin.Inertia.Random(), pin.SE3.Identity())
        ids.append(jid)
    for name, (link, c) in points.items():
        model.addFrame(pin.Frame(name, ids[link], 0, pin.SE3(np.eye(3), c), pin.FrameType.OP_FRAME))
    return model, ids


def tree_robot(seed: int = 0) -> Robot:
    """A branched tree: two arms on a revolute trunk, one branching again."""
    rng = np.random.default_rng(seed)
    parent = [-1, 0, 1, 2, 0, 4, 4, 6]
    types = ["revolute", "prismatic", "revolute", "revolute", "revolute", "prismatic",
             "revolute", "revolute"]
    n = len(parent)
    Rs = [rot_z(a) @ rot_x(b) @ rot_z(c) for a, b, c in rng.uniform(-np.pi, np.pi, (n, 3))]
    return Robot.from_arrays(
        "tree", types, parent, np.array(Rs), rng.uniform(-0.3, 0.3, (n, 3)), np.ones(n),
        np.zeros((n, 3)), np.tile(np.eye(3) * 0.01, (n, 1, 1)),
        offset=rng.uniform(-0.5, 0.5, n), tool_R=rot_x(0.4), tool_p=[0.0, 0.05, 0.1])


def test_tree_matches_pinocchio():
    robot = tree_robot()
    rng = np.random.default_rng(7)
    points = {f"p{i}": (i, rng.uniform(-0.2, 0.2, 3)) for i in range(robot.n)}
    points["tool"] = (robot.n - 1, robot.tool_p)
    model, ids = pinocchio_model(robot, points)
    data = model.createData()
    for q in random_q(robot.n, 10, seed=8):
        qd = rng.normal(size=robot.n)
        qp = q + robot.offset  # Pinocchio has no joint offsets
        pin.forwardKinematics(model, data, qp, qd)
        pin.computeJointJacobians(model, data, qp)
        pin.computeJointJacobiansTimeVariation(model, data, qp, qd)
        pin.updateFramePlacements(model, data)
        T = forward_kinematics(robot, q)
        for i in range(robot.n):
            np.testing.assert_allclose(T[i], data.oMi[ids[i]].homogeneous, atol=TOL, rtol=0)
        for name, (link, c) in points.items():
            fid = model.getFrameId(name)
            J_ref = pin.getFrameJacobian(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            J = jacobian(robot, q, link=link, point=c)
            np.testing.assert_allclose(J, J_ref, atol=TOL, rtol=0)
            # only ancestors contribute
            chain = set()
            j = link
            while j >= 0:
                chain.add(j)
                j = robot.parent[j]
            for j in set(range(robot.n)) - chain:
                assert not J[:, j].any()
            # J'·qd is the classical acceleration bias of the point (qdd = 0)
            Jd = jacobian_dot(robot, q, qd, link=link, point=c)
            pin.forwardKinematics(model, data, qp, qd, np.zeros(robot.n))
            a_ref = pin.getFrameClassicalAcceleration(model, data, fid, pin.LOCAL_WORLD_ALIGNED)
            np.testing.assert_allclose(Jd @ qd, np.r_[a_ref.linear, a_ref.angular],
                                       atol=1e-11, rtol=0)
        np.testing.assert_allclose(tool_pose(robot, q)[:3, 3],
                                   data.oMf[model.getFrameId("tool")].translation, atol=TOL)


def _ur5_urdf() -> Path | None:
    base = Path(pin.__file__).resolve().parents[4] / "share" / "example-robot-data"
    path = base / "robots" / "ur_description" / "urdf" / "ur5_robot.urdf"
    return path if path.is_file() else None


def test_ur5_urdf_matches_pinocchio():
    urdf_mod = pytest.importorskip("manipcad.model.urdf")
    path = _ur5_urdf()
    if path is None:
        pytest.skip("example-robot-data UR5 URDF not found")
    robot = urdf_mod.load_urdf(path)
    model = pin.buildModelFromUrdf(str(path))
    data = model.createData()
    assert robot.n == model.nq
    for q in random_q(robot.n, 10, seed=9):
        pin.forwardKinematics(model, data, q)
        pin.computeJointJacobians(model, data, q)
        T = forward_kinematics(robot, q)
        for i in range(robot.n):
            jid = i + 1
            # the joint origins do not depend on how the loader aligns the axis with z
            np.testing.assert_allclose(T[i, :3, 3], data.oMi[jid].translation, atol=TOL)
        # the Jacobian of the last joint's origin
        J_ref = pin.getJointJacobian(model, data, robot.n, pin.LOCAL_WORLD_ALIGNED)
        np.testing.assert_allclose(jacobian(robot, q, point=np.zeros(3)), J_ref, atol=TOL)


# ------------------------------------------------------------ inverse kinematics
def test_ik_reaches_positions(pair):
    robot, _ = pair
    rng = np.random.default_rng(10)
    for q_true in random_q(robot.n, 10, seed=11):
        x = tool_pose(robot, q_true)[:3, 3]
        q0 = q_true + rng.uniform(-0.3, 0.3, robot.n)
        q = inverse_kinematics(robot, x, q0)
        assert np.linalg.norm(tool_pose(robot, q)[:3, 3] - x) < 1e-12


def test_ik_reaches_poses():
    robot = mdh_robot(PUMA_MDH, TOOL.A)
    rng = np.random.default_rng(12)
    for q_true in random_q(robot.n, 10, seed=13):
        T = tool_pose(robot, q_true)
        q = inverse_kinematics(robot, T, q_true + rng.uniform(-0.2, 0.2, robot.n))
        Tq = tool_pose(robot, q)
        assert np.linalg.norm(Tq[:3, 3] - T[:3, 3]) < 1e-12
        assert np.abs(Tq[:3, :3] - T[:3, :3]).max() < 1e-11


def test_ik_point_on_inner_link():
    robot = tree_robot()
    q_true = random_q(robot.n, 1, seed=14)[0]
    c = np.array([0.1, 0.0, -0.05])
    x = point_position(robot, q_true, link=3, point=c)
    q = inverse_kinematics(robot, x, q_true + 0.2, link=3, point=c)
    assert np.linalg.norm(point_position(robot, q, link=3, point=c) - x) < 1e-12


def test_ik_out_of_reach_raises():
    robot = mdh_robot(PUMA_MDH)
    with pytest.raises(KinematicsError, match="out of reach") as info:
        inverse_kinematics(robot, [3.0, 0.0, 0.5], np.full(6, 0.2))
    err = info.value
    assert isinstance(err, ManipcadError)
    assert err.position_error > 1.0 and err.q.shape == (6,)


def test_ik_respects_joint_limits():
    rows = CYL_MDH
    base = mdh_robot(rows)
    robot = base.replace(limits=np.array([[-np.pi, np.pi], [0.0, 0.5], [0.0, 0.4]]))
    q_true = np.array([0.3, 0.2, 0.3])
    q = inverse_kinematics(robot, tool_pose(robot, q_true)[:3, 3], np.array([0.0, 0.1, 0.1]))
    np.testing.assert_allclose(q, q_true, atol=1e-10)
    # a radius that needs q3 = 0.6 m > 0.4 m
    x = tool_pose(base, np.array([0.3, 0.2, 0.6]))[:3, 3]
    with pytest.raises(KinematicsError, match="limits"):
        inverse_kinematics(robot, x, np.array([0.0, 0.1, 0.1]))
    assert np.linalg.norm(tool_pose(base, inverse_kinematics(
        base, x, np.array([0.0, 0.1, 0.1])))[:3, 3] - x) < 1e-12


@pytest.mark.parametrize("kwargs, field", [
    ({"q": np.zeros(5)}, "q"),
    ({"q": np.full(6, np.nan)}, "q"),
    ({"frame": "body"}, "frame"),
    ({"point": [1.0, 2.0]}, "point"),
])
def test_bad_input_raises(kwargs, field):
    robot = mdh_robot(PUMA_MDH)
    args = {"q": np.zeros(6)} | kwargs
    with pytest.raises(InputError) as info:
        jacobian(robot, **args)
    assert info.value.source == field


def test_ik_bad_targets():
    robot = mdh_robot(PUMA_MDH)
    with pytest.raises(InputError, match="target"):
        inverse_kinematics(robot, [1.0, 2.0], np.zeros(6))
    with pytest.raises(InputError, match="q0"):
        inverse_kinematics(robot, [0.5, 0.0, 0.2], np.zeros(4))
    with pytest.raises(InputError, match="orientation"):
        inverse_kinematics(robot, [0.5, 0.0, 0.2], np.zeros(6), position_only=False)
