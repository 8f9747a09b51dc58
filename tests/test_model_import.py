"""Models in from other libraries and out as URDF: inverse dynamics and mass matrix
equal the source library's own (Robotics Toolbox rne/inertia, Pinocchio rnea/crba,
MuJoCo mj_inverse/mj_fullM) to 1e-9 relative; Robot.to_urdf round trips to 1e-12.

Two limits of the Robotics Toolbox's ``rne`` (installed version) found on the way and
worked around here, not in manipcad: it ignores a joint's ``flip`` (its forward
kinematics honours it) and the transform of a static link between two joints, and
it assumes a serial chain (a branched tree such as the Panda's fingers differs from
Pinocchio by 0.15 N·m). For those cases the reference is an equivalent robot rtb
handles (flip undone by q -> -q, static transform folded into the next link) or
Pinocchio reading the same URDF.
"""

from __future__ import annotations

import re
import warnings
from pathlib import Path

import numpy as np
import pytest
from test_random_trees import random_urdf
from test_urdf import erd_robots_dir

import manipcad
from manipcad.dynamics.api import inverse_dynamics, mass_matrix
from manipcad.errors import InputError, ManipcadWarning
from manipcad.kinematics.forward import forward_kinematics
from manipcad.model.to_urdf import robot_to_urdf

rtb = pytest.importorskip("roboticstoolbox")
pin = pytest.importorskip("pinocchio")
mujoco = pytest.importorskip("mujoco")

RTOL = 1e-9


def rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.abs(a - b).max() / max(1.0, np.abs(b).max()))


def states(n: int, seed: int, count: int = 4):
    rng = np.random.default_rng(seed)
    return [rng.uniform(-1.2, 1.2, (3, n)) for _ in range(count)]


def bare_urdf(rel_path: str) -> str:
    """An example-robot-data URDF without meshes (visual/collision)."""
    text = (erd_robots_dir() / rel_path).read_text()
    return re.sub(r"<visual>.*?</visual>|<collision>.*?</collision>", "", text, flags=re.S)


def quiet_load(source):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return manipcad.load_robot(source)


# ------------------------------------------------------------------ Robotics Toolbox


def _mdh_robot():
    rng = np.random.default_rng(3)
    links = []
    for i in range(4):
        kw = dict(a=rng.uniform(0, 0.5), alpha=rng.uniform(-2, 2), m=rng.uniform(1, 5),
                  r=rng.uniform(-0.2, 0.2, 3), I=np.diag(rng.uniform(0.01, 0.1, 3)),
                  Jm=1e-4 * (i + 1), G=[-50, 80, 30, 100][i], B=1e-3, Tc=[0.1, -0.05],
                  offset=0.2)
        if i == 2:
            links.append(rtb.PrismaticMDH(theta=0.3, **kw))
        else:
            links.append(rtb.RevoluteMDH(d=rng.uniform(0, 0.3), **kw))
    return rtb.DHRobot(links, name="mdh4")


RTB_ROBOTS = {
    "puma560": lambda: rtb.models.DH.Puma560(),  # standard DH, motors with negative G
    "stanford": lambda: rtb.models.DH.Stanford(),  # a prismatic joint
    "mdh4": _mdh_robot,  # modified DH, prismatic, offsets, motors (Jm, G, B, Tc)
}


@pytest.mark.parametrize("name", sorted(RTB_ROBOTS))
def test_rtb_dh_robots_match_rne_and_inertia(name):
    r = RTB_ROBOTS[name]()
    robot = manipcad.load_robot(r)
    assert robot.n == r.n and robot.has_drives == any(L.Jm or L.B for L in r.links)
    for q, qd, qdd in states(r.n, 1):
        assert rel(inverse_dynamics(robot, q, qd, qdd), r.rne(q, qd, qdd)) < RTOL
        assert rel(mass_matrix(robot, q), r.inertia(q)) < RTOL
        assert rel(forward_kinematics(robot, q)[-1] @ _tool(robot), r.fkine(q).A) < RTOL


def _tool(robot) -> np.ndarray:
    T = np.eye(4)
    T[:3, :3], T[:3, 3] = robot.tool_R, robot.tool_p
    return T


def test_rtb_motor_terms_map_to_drives():
    r = RTB_ROBOTS["puma560"]()
    robot = manipcad.load_robot(r)
    d = robot.drives[0]
    assert (d.J, d.ratio, d.k_v) == (r.links[0].Jm, r.links[0].G, r.links[0].B)
    assert d.M_f == (abs(r.links[0].Tc[0]), abs(r.links[0].Tc[1]))


def test_rtb_erobot_from_urdf_matches(tmp_path):
    path = tmp_path / "ur5.urdf"
    path.write_text(bare_urdf("ur_description/urdf/ur5_robot.urdf"))
    r = rtb.Robot.URDF(str(path))
    robot = manipcad.load_robot(r)
    for q, qd, qdd in states(6, 2):
        assert rel(inverse_dynamics(robot, q, qd, qdd), r.rne(q, qd, qdd)) < RTOL
        assert rel(mass_matrix(robot, q), r.inertia(q)) < RTOL


def test_rtb_ets_static_link_and_flip():
    """A static link with mass between two joints, and a flipped joint: compared with
    equivalent robots rtb's rne handles (see the module docstring)."""
    ET = rtb.ET

    def build(flip: bool, fold: bool):
        l0 = rtb.Link(ET.tz(0.3) * ET.Rz(), name="l0", m=2.0, r=[0.1, 0, 0.05],
                      I=np.diag([0.02, 0.03, 0.04]))
        l1 = rtb.Link(ET.ty(0.1) * ET.Rx(0.4) * ET.Ry(flip=flip), name="l1", parent=l0,
                      m=3.0, r=[0, 0.1, 0.2], I=[[0.05, 0.001, 0], [0.001, 0.04, 0], [0, 0, 0.03]])
        tail = dict(name="l2", m=1.5, r=[0, 0, 0.1], I=np.diag([0.01, 0.02, 0.01]), Jm=2e-4,
                    G=30, B=1e-3)
        if fold:  # the static link's mass moved into l1 by hand is not needed: it is 0 there
            l2 = rtb.Link(ET.tx(0.2) * ET.Rz(0.3) * ET.tz(0.1) * ET.tx(), parent=l1, **tail)
            return rtb.Robot([l0, l1, l2], name="folded")
        lf = rtb.Link(ET.tx(0.2) * ET.Rz(0.3), name="fixed", parent=l1, m=0.0)
        l2 = rtb.Link(ET.tz(0.1) * ET.tx(), parent=lf, **tail)
        return rtb.Robot([l0, l1, lf, l2], name="sandwiched")

    ours = manipcad.load_robot(build(flip=False, fold=False))
    ref = build(flip=False, fold=True)
    flipped = manipcad.load_robot(build(flip=True, fold=False))
    sign = np.array([1.0, -1.0, 1.0])
    for q, qd, qdd in states(3, 4):
        assert rel(inverse_dynamics(ours, q, qd, qdd), ref.rne(q, qd, qdd)) < RTOL
        assert rel(mass_matrix(ours, q), ref.inertia(q)) < RTOL
        # flipping a joint is q -> -q for it: tau_i -> -tau_i
        assert rel(inverse_dynamics(flipped, q, qd, qdd),
                   sign * ref.rne(sign * q, sign * qd, sign * qdd)) < RTOL


def test_rtb_trailing_static_link_with_mass():
    """A massive static link after the last joint (a tool flange), which rtb's rne
    carries with that joint: its mass joins the last link."""
    ET = rtb.ET
    l0 = rtb.Link(ET.tz(0.3) * ET.Rz(), name="l0", m=2.0, r=[0.1, 0, 0.05],
                  I=np.diag([0.02, 0.03, 0.04]))
    l1 = rtb.Link(ET.ty(0.1) * ET.Ry(), name="l1", parent=l0, m=1.0, r=[0, 0.1, 0.2],
                  I=np.diag([0.01, 0.02, 0.015]))
    flange = rtb.Link(ET.tx(0.2) * ET.Rz(0.3), name="flange", parent=l1, m=1.2,
                      r=[0.05, 0.02, 0.0], I=[[0.01, 0.001, 0], [0.001, 0.02, 0], [0, 0, 0.01]])
    r = rtb.Robot([l0, l1, flange], name="flanged")
    robot = manipcad.load_robot(r)
    assert robot.mass.tolist() == pytest.approx([2.0, 2.2])
    for q, qd, qdd in states(2, 12):
        assert rel(inverse_dynamics(robot, q, qd, qdd), r.rne(q, qd, qdd)) < RTOL
        assert rel(mass_matrix(robot, q), r.inertia(q)) < RTOL


# ------------------------------------------------------------------ Pinocchio


PIN_URDFS = ["ur_description/urdf/ur5_robot.urdf", "panda_description/urdf/panda.urdf",
             "kinova_description/robots/kinova.urdf"]


def _pin_check(robot, model, seed: int, *, q_map=None):
    data = model.createData()
    for q, qd, qdd in states(robot.n, seed):
        qp = q if q_map is None else q_map(q)
        tau = pin.rnea(model, data, qp, qd, qdd)
        M = pin.crba(model, data, qp)
        M = np.triu(M) + np.triu(M, 1).T
        assert rel(inverse_dynamics(robot, q, qd, qdd), tau) < RTOL
        assert rel(mass_matrix(robot, q), M) < RTOL


@pytest.mark.parametrize("path", PIN_URDFS)
def test_pinocchio_models_match_rnea_and_crba(path, tmp_path):
    f = tmp_path / "r.urdf"
    f.write_text(bare_urdf(path))
    model = pin.buildModelFromUrdf(str(f))
    robot = manipcad.load_robot(model)
    assert robot.n == model.nv
    _pin_check(robot, model, 5, q_map=_pin_q(model))


def test_pinocchio_continuous_unaligned_armature(tmp_path):
    """Continuous joints (cos, sin in Pinocchio's q), an unaligned axis and armature."""
    text = random_urdf(7).replace('type="revolute"', 'type="continuous"', 2)
    f = tmp_path / "tree.urdf"
    f.write_text(text)
    model = pin.buildModelFromUrdf(str(f))
    model.armature = np.linspace(0.01, 0.05, model.nv)
    robot = manipcad.load_robot(model)
    kinds = {model.joints[i].shortname() for i in range(1, model.njoints)}
    assert {"JointModelRevoluteUnboundedUnaligned", "JointModelPrismaticUnaligned"} <= kinds
    assert robot.drives[0].J == pytest.approx(0.01)

    _pin_check(robot, model, 6, q_map=_pin_q(model))


def test_pinocchio_refuses_other_joints():
    model = pin.Model()
    model.addJoint(0, pin.JointModelSpherical(), pin.SE3.Identity(), "ball")
    with pytest.raises(InputError, match="'ball'.*3 degrees of freedom"):
        manipcad.load_robot(model)


# ------------------------------------------------------------------ MuJoCo (MJCF)


def mj_reference(model, q, qd, qdd):
    """MuJoCo's inverse dynamics (constraints off; frictionloss as dry friction
    frictionloss·sign(q̇), which MuJoCo solves as a constraint) and mass matrix."""
    model.opt.disableflags |= int(mujoco.mjtDisableBit.mjDSBL_CONSTRAINT)
    data = mujoco.MjData(model)
    data.qpos[:], data.qvel[:], data.qacc[:] = q, qd, qdd
    mujoco.mj_inverse(model, data)
    M = np.zeros((model.nv, model.nv))
    mujoco.mj_fullM(model, data, M)
    return data.qfrc_inverse + model.dof_frictionloss * np.sign(qd), M


def _mj_check(path: Path, seed: int) -> None:
    robot = quiet_load(path)
    model = mujoco.MjModel.from_xml_path(str(path))
    assert robot.n == model.nv
    for q, qd, qdd in states(robot.n, seed):
        tau, M = mj_reference(model, q, qd, qdd)
        assert rel(inverse_dynamics(robot, q, qd, qdd), tau) < RTOL
        assert rel(mass_matrix(robot, q), M) < RTOL


MJ_URDFS = ["ur_description/urdf/ur5_robot.urdf", "panda_description/urdf/panda.urdf",
            "kinova_description/robots/kinova.urdf", "z1_description/urdf/z1.urdf"]


@pytest.mark.parametrize("path", MJ_URDFS)
def test_mjcf_written_by_mujoco_from_erd_urdf(path, tmp_path):
    """MuJoCo compiles the URDF and writes MJCF (mj_saveLastXML); manipcad reads that
    MJCF through mujoco's parser; dynamics equal mj_inverse / mj_fullM."""
    model = mujoco.MjModel.from_xml_string(bare_urdf(path))
    out = tmp_path / "robot.xml"
    mujoco.mj_saveLastXML(str(out), model)
    assert "<mujoco" in out.read_text()[:200]
    _mj_check(out, 8)


HANDMADE = """
<mujoco model="handmade">
  <compiler angle="degree"/>
  <option gravity="0.3 -0.2 -9.7"/>
  <worldbody>
    <body name="base" pos="0 0 0.1">
      <geom type="box" size="0.1 0.1 0.05" mass="5"/>
      <body name="b1" pos="0 0 0.2" quat="0.9 0.1 0.2 0.3">
        <inertial pos="0.05 0.01 0.1" quat="0.8 0.3 0.1 0.5" mass="2" diaginertia="0.03 0.02 0.01"/>
        <joint name="j1" type="hinge" axis="0.3 0.5 1" pos="0.02 0 0.01" ref="20"
               armature="0.01" damping="0.2"/>
        <body name="weld" pos="0.1 0 0.05" euler="10 20 30">
          <inertial pos="0.02 0 0" mass="0.7" diaginertia="0.002 0.003 0.004"/>
          <body name="b2" pos="0 0.2 0">
            <inertial pos="0 0.1 0" mass="1.5" fullinertia="0.03 0.03 0.02 0.001 0 0.002"/>
            <joint name="slide" type="slide" axis="1 1 0" range="-0.2 0.3" ref="0.05"/>
            <body name="b3" pos="0.1 0 0">
              <inertial pos="0.03 0 0.02" mass="0.8" diaginertia="0.004 0.004 0.002"/>
              <joint name="j3" type="hinge" axis="0 -1 0" frictionloss="0.3"/>
            </body>
          </body>
        </body>
      </body>
    </body>
  </worldbody>
</mujoco>
"""


def test_mjcf_handmade_features(tmp_path):
    """Degrees, ref (offset), unaligned axes, joint pos, a welded body with mass,
    a slide joint with limits, armature, damping and frictionloss, custom gravity."""
    f = tmp_path / "handmade.xml"
    f.write_text(HANDMADE)
    robot = manipcad.load_robot(f)
    assert robot.joint_types == ("revolute", "prismatic", "revolute")
    assert robot.limits[1].tolist() == pytest.approx([-0.2, 0.3])
    assert robot.offset[0] == pytest.approx(-np.deg2rad(20)) and robot.offset[1] == -0.05
    assert robot.gravity.tolist() == [0.3, -0.2, -9.7]
    _mj_check(f, 9)
    # the same from text
    assert manipcad.load_robot(HANDMADE).n == 3


def test_mjcf_refuses_free_and_ball_joints(tmp_path):
    f = tmp_path / "free.xml"
    f.write_text('<mujoco><worldbody><body name="b"><freejoint name="fj"/>'
                 '<geom size="0.1" mass="1"/></body></worldbody></mujoco>')
    with pytest.raises(InputError, match="free.xml: joint 'fj': free and ball joints"):
        manipcad.load_robot(f)
    bad = tmp_path / "bad.xml"
    bad.write_text("<mujoco><worldbody><body><joint type='hinge'/></body></mujoco>")
    with pytest.raises(InputError, match="bad.xml: MuJoCo cannot read it"):
        manipcad.load_robot(bad)


# ------------------------------------------------------------------ URDF text, errors


def test_urdf_string_and_unsupported_objects():
    text = bare_urdf("ur_description/urdf/ur5_robot.urdf")
    a = manipcad.load_robot(text)
    b = manipcad.load_robot(erd_robots_dir() / "ur_description/urdf/ur5_robot.urdf")
    assert np.array_equal(a.table, b.table)
    with pytest.raises(InputError, match="got a dict; expected a catalog name"):
        manipcad.load_robot({"joints": []})


# ------------------------------------------------------------------ out: URDF


def _same_rigid_body(a, b, seed: int, tol: float = 1e-12) -> None:
    for q, qd, qdd in states(a.n, seed):
        assert rel(inverse_dynamics(b, q, qd, qdd, drives=False),
                   inverse_dynamics(a, q, qd, qdd, drives=False)) < tol
        assert rel(mass_matrix(b, q, drives=False), mass_matrix(a, q, drives=False)) < tol
        assert rel(forward_kinematics(b, q), forward_kinematics(a, q)) < tol


@pytest.mark.parametrize("name", ["puma560", "stanford", "scara", "cylindrical"])
def test_to_urdf_round_trip_catalog(name, tmp_path):
    robot = quiet_load(name)
    text = robot_to_urdf(robot, tmp_path / f"{name}.urdf")
    assert (tmp_path / f"{name}.urdf").read_text() == text
    back = quiet_load(text)
    assert back.joint_names == robot.joint_names and back.joint_types == robot.joint_types
    assert np.array_equal(back.limits, robot.limits)
    _same_rigid_body(robot, back, 10)
    # Pinocchio reads our URDF as well: same dynamics
    f = tmp_path / "p.urdf"
    f.write_text(text)
    model = pin.buildModelFromUrdf(str(f))
    _pin_check(robot.without_drives(), model, 11, q_map=_pin_q(model))


def _pin_q(model):
    def q_map(q):
        out = []
        for i in range(1, model.njoints):
            v = q[model.joints[i].idx_v]
            out += [np.cos(v), np.sin(v)] if model.joints[i].nq == 2 else [v]
        return np.array(out)
    return q_map


@pytest.mark.parametrize("seed", [1, 2, 3])
def test_to_urdf_round_trip_random_trees(seed):
    robot = quiet_load(random_urdf(seed))
    back = quiet_load(robot_to_urdf(robot))
    _same_rigid_body(robot, back, seed)
    assert np.array_equal(back.parent, robot.parent)
