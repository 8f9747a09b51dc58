"""URDF loader: structure, agreement with Pinocchio on example-robot-data arms, bad input.

Two independent checks of each loaded robot against Pinocchio's own URDF parser
(``pin.buildModelFromUrdf`` on the same file):

1. Loader only: our :class:`Robot` is rebuilt as a Pinocchio model (one RZ/PZ
   joint per joint, our placements and inertias) and its inverse dynamics, mass
   matrix and forward dynamics are compared with the URDF-built model's. This
   checks the loader's kinematics and inertias without our dynamics code.
2. Our dynamics (``manipcad.dynamics``, drives=False) against Pinocchio's RNEA,
   CRBA and ABA on the URDF-built model, with gravity and external forces,
   single states and batches.

Tolerance and state mapping: see urdf_pinref.py.
"""

from __future__ import annotations

import warnings
import xml.etree.ElementTree as ET
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from urdf_pinref import (
    StateMap,
    body_rotations,
    close,
    dynamics,
    pin_from_robot,
    pin_reference,
    random_state,
)

from manipcad.errors import InputError, ManipcadWarning
from manipcad.model.urdf import align_z, load_urdf, robot_from_urdf_string, rpy_matrix

# ------------------------------------------------------------------ helpers


def erd_robots_dir() -> Path:
    """The ``robots`` folder of the installed example-robot-data (v4 to v6)."""
    try:  # v6 ships data only, under the cmeel prefix
        d = Path(distribution("example-robot-data").locate_file(
            "cmeel.prefix/share/example-robot-data/robots"))
        if d.is_dir():
            return d
    except PackageNotFoundError:
        pass
    try:  # older releases have a Python module with the path
        from example_robot_data.path import EXAMPLE_ROBOT_DATA_MODEL_DIR  # type: ignore

        return Path(EXAMPLE_ROBOT_DATA_MODEL_DIR)
    except ImportError:
        pytest.fail("example-robot-data (a test dependency) is not installed")


# (URDF path under robots/, what it exercises)
ERD_URDFS = {
    "ur5": "ur_description/urdf/ur5_robot.urdf",  # y axes, fixed joints
    "panda": "panda_description/urdf/panda.urdf",  # tree: two prismatic fingers, mimic
    "talos_left_arm": "talos_data/robots/talos_left_arm.urdf",  # x/y axes, gripper mimics
    "kinova": "kinova_description/robots/kinova.urdf",  # continuous joints
    "double_pendulum": "double_pendulum_description/urdf/double_pendulum.urdf",  # x axes
    "double_pendulum_continuous":
        "double_pendulum_description/urdf/double_pendulum_continuous.urdf",
    "z1": "z1_description/urdf/z1.urdf",
    "so100": "so_arm_description/urdf/so100.urdf",  # mixed axes
    "xarm7": "xarm_description/urdf/xarm7.urdf",
    "allegro": "allegro_hand_description/urdf/allegro_left_hand.urdf",  # '+1 0 0', '0 0 -1'
    "baxter": "baxter_description/urdf/baxter.urdf",  # large tree, prismatic grippers
}


@pytest.fixture(scope="module", params=sorted(ERD_URDFS))
def erd(request):
    """(name, path, our robot, Pinocchio model) for one example-robot-data URDF."""
    path = erd_robots_dir() / ERD_URDFS[request.param]
    with warnings.catch_warnings():  # allegro's finger tips break the triangle inequality
        warnings.simplefilter("ignore", ManipcadWarning)
        robot = load_urdf(path)
    return request.param, path, robot, pin.buildModelFromUrdf(str(path))


# ------------------------------------------------ example-robot-data robots


def test_structure_matches_pinocchio(erd):
    name, path, robot, model = erd
    assert robot.n == model.nv
    assert robot.name == ET.parse(path).getroot().get("name")
    assert set(robot.joint_names) == set(model.names[1:])
    assert robot.mass.sum() == pytest.approx(pin.computeTotalMass(model), rel=1e-12)
    # parents precede children and the tree is Pinocchio's
    for i, j in enumerate(robot.parent):
        assert j < i
        pj = model.parents[model.getJointId(robot.joint_names[i])]
        assert (robot.joint_names[j] if j >= 0 else "universe") == model.names[pj]
    # limits (continuous: unlimited)
    for i, jn in enumerate(robot.joint_names):
        jid = model.getJointId(jn)
        if model.joints[jid].nq == 1:
            iq = model.joints[jid].idx_q
            assert robot.limits[i, 0] == pytest.approx(model.lowerPositionLimit[iq])
            assert robot.limits[i, 1] == pytest.approx(model.upperPositionLimit[iq])
        else:
            assert tuple(robot.limits[i]) == (-np.inf, np.inf)


def test_kinematics_match_pinocchio(erd):
    """Body-frame origins equal Pinocchio's joint origins, and our local z is the URDF axis."""
    name, path, robot, model = erd
    rng = np.random.default_rng(1)
    smap = StateMap(robot, model)
    data = model.createData()
    for _ in range(3):
        q = rng.uniform(-1.5, 1.5, robot.n)
        pin.computeJointJacobians(model, data, smap.q(q))
        R = body_rotations(robot, q)
        p = np.zeros((robot.n, 3))
        for i in range(robot.n):
            Ri, pi = robot.placement_R[i], robot.placement_p[i]
            if robot.joint_types[i] == "prismatic":
                pi_moved = pi + Ri[:, 2] * q[i]
            else:
                pi_moved = pi
            par = robot.parent[i]
            p[i] = pi_moved if par < 0 else R[par] @ pi_moved + p[par]
            jid = smap.jid[i]
            close(p[i], data.oMi[jid].translation, 1e-12)
            R_rel = data.oMi[jid].rotation.T @ R[i]
            close(R_rel @ R_rel.T, np.eye(3), 1e-12)
            # Pinocchio's joint axis in its joint frame is our local z
            close(R_rel[:, 2], _pin_axis(model, data, jid), 1e-12)


def _pin_axis(model: pin.Model, data: pin.Data, jid: int) -> np.ndarray:
    """Unit axis of a one-dof Pinocchio joint in its own frame (after
    ``computeJointJacobians``): the angular part of its local motion subspace, or
    the linear part for a prismatic joint."""
    S = pin.getJointJacobian(model, data, jid, pin.LOCAL)[:, model.joints[jid].idx_v]
    return S[3:] if np.linalg.norm(S[3:]) > 0.5 else S[:3]


def test_loader_alone_matches_pinocchio(erd):
    """Our robot rebuilt in Pinocchio gives Pinocchio's URDF dynamics (no manipcad dynamics)."""
    name, path, robot, model = erd
    mine = pin_from_robot(robot)
    rng = np.random.default_rng(2)
    for _ in range(3):
        q, qd, qdd, tau = random_state(robot, rng)
        ref = pin_reference(robot, model, q, qd, qdd, tau)
        got = pin_reference(robot, mine, q, qd, qdd, tau)
        for a, b in zip(got, ref, strict=True):
            close(a, b)


def _check_dynamics(erd, seed: int, draws: int, *, gravity=None, f_ext_sd: float = 0.0,
                    mass_matrix: bool = False) -> None:
    """Our inverse and forward (ABA, CRBA) dynamics against Pinocchio at random states.

    ``gravity`` is passed to both when given; ``f_ext_sd`` > 0 draws external
    forces N(0, sd) per state (after the state); ``mass_matrix`` also compares H.
    """
    dyn = dynamics()
    name, path, robot, model = erd
    rng = np.random.default_rng(seed)
    for _ in range(draws):
        q, qd, qdd, tau = random_state(robot, rng)
        kw = {} if gravity is None else {"gravity": gravity}
        if f_ext_sd:
            kw["f_ext"] = rng.normal(0.0, f_ext_sd, (robot.n, 6))
        tau_ref, H_ref, qdd_ref = pin_reference(robot, model, q, qd, qdd, tau, **kw)
        close(dyn.inverse_dynamics(robot, q, qd, qdd, drives=False, **kw), tau_ref)
        if mass_matrix:
            close(dyn.mass_matrix(robot, q, drives=False), H_ref)
        for method in ("aba", "crba"):
            close(dyn.forward_dynamics(robot, q, qd, tau, method=method, drives=False, **kw),
                  qdd_ref)


@pytest.mark.parametrize("with_gravity", [False, True])
def test_dynamics_match_pinocchio(erd, with_gravity):
    """manipcad.dynamics (drives=False) against Pinocchio's RNEA, CRBA and ABA."""
    g = np.array([0.3, -1.2, -9.81]) if with_gravity else np.zeros(3)
    _check_dynamics(erd, 3, 3, gravity=g, mass_matrix=True)


def test_dynamics_with_external_forces_match_pinocchio(erd):
    _check_dynamics(erd, 4, 2, f_ext_sd=5.0)


def test_batched_dynamics_match_pinocchio(erd):
    dyn = dynamics()
    name, path, robot, model = erd
    rng = np.random.default_rng(5)
    N = 4
    q, qd, qdd, tau = random_state(robot, rng, batch=N)
    f_ext = rng.normal(0.0, 5.0, (N, robot.n, 6))
    tau_b = dyn.inverse_dynamics(robot, q, qd, qdd, f_ext=f_ext, drives=False)
    H_b = dyn.mass_matrix(robot, q, drives=False)
    fd_b = dyn.forward_dynamics(robot, q, qd, tau, f_ext=f_ext, drives=False)
    assert tau_b.shape == (N, robot.n) and H_b.shape == (N, robot.n, robot.n)
    assert fd_b.shape == (N, robot.n)
    for k in range(N):
        tau_ref, H_ref, qdd_ref = pin_reference(robot, model, q[k], qd[k], qdd[k], tau[k],
                                                f_ext=f_ext[k])
        close(tau_b[k], tau_ref)
        close(H_b[k], H_ref)
        close(fd_b[k], qdd_ref)


def test_load_robot_reads_urdf():
    from manipcad import load_robot

    path = erd_robots_dir() / ERD_URDFS["ur5"]
    robot = load_robot(path)
    assert robot.n == 6 and robot.source == str(path)
    assert robot.name == "ur5"


# ------------------------------------------------------ structure, by hand


def urdf(body: str, name: str = "r") -> str:
    return f'<robot name="{name}">{body}</robot>'


def link(name: str, mass: float | str | None = 1.0, xyz: str = "0 0 0", rpy: str = "0 0 0",
         inertia: str = 'ixx="0.1" ixy="0" ixz="0" iyy="0.2" iyz="0" izz="0.3"') -> str:
    if mass is None:
        return f'<link name="{name}"/>'
    return (f'<link name="{name}"><inertial><origin xyz="{xyz}" rpy="{rpy}"/>'
            f'<mass value="{mass}"/><inertia {inertia}/></inertial></link>')


def joint(name: str, parent: str, child: str, kind: str = "revolute", xyz: str = "0 0 0",
          rpy: str = "0 0 0", axis: str | None = "0 0 1", extra: str = "") -> str:
    ax = "" if axis is None else f'<axis xyz="{axis}"/>'
    return (f'<joint name="{name}" type="{kind}"><parent link="{parent}"/>'
            f'<child link="{child}"/><origin xyz="{xyz}" rpy="{rpy}"/>{ax}{extra}</joint>')


def test_rpy_is_fixed_axis_roll_pitch_yaw():
    r, p, y = 0.3, -0.7, 1.9
    Rx = np.array([[1, 0, 0], [0, np.cos(r), -np.sin(r)], [0, np.sin(r), np.cos(r)]])
    Ry = np.array([[np.cos(p), 0, np.sin(p)], [0, 1, 0], [-np.sin(p), 0, np.cos(p)]])
    Rz = np.array([[np.cos(y), -np.sin(y), 0], [np.sin(y), np.cos(y), 0], [0, 0, 1]])
    close(rpy_matrix(np.array([r, p, y])), Rz @ Ry @ Rx, 1e-15)
    close(rpy_matrix(np.array([r, p, y])), pin.rpy.rpyToMatrix(r, p, y), 1e-15)


@pytest.mark.parametrize("axis", [(0, 0, 1), (0, 0, -1), (1, 0, 0), (0, -1, 0),
                                  (0.3, -0.4, 0.866), (1e-9, 0, -1)])
def test_align_z_is_a_rotation_onto_the_axis(axis):
    a = np.asarray(axis, float) / np.linalg.norm(axis)
    R = align_z(a)
    close(R @ R.T, np.eye(3), 1e-14)
    assert np.linalg.det(R) == pytest.approx(1.0)
    close(R[:, 2], a, 1e-14)


def test_chain_fields_names_limits():
    text = urdf(
        link("base") + link("l1") + link("l2") + link("l3")
        + joint("j1", "base", "l1", extra='<limit lower="-1" upper="2" effort="1" velocity="1"/>')
        + joint("j2", "l1", "l2", kind="continuous",
                extra='<limit lower="-1" upper="1" effort="1" velocity="1"/>')
        + joint("j3", "l2", "l3", kind="prismatic", axis="1 0 0",
                extra='<limit lower="0" upper="0.5" effort="1" velocity="1"/>'),
        name="arm")
    r = robot_from_urdf_string(text)
    assert r.name == "arm" and r.source == "<string>"
    assert r.joint_names == ("j1", "j2", "j3")
    assert r.link_names == ("l1", "l2", "l3")
    assert r.joint_types == ("revolute", "revolute", "prismatic")
    assert list(r.parent) == [-1, 0, 1]
    np.testing.assert_array_equal(r.limits, [[-1, 2], [-np.inf, np.inf], [0, 0.5]])
    np.testing.assert_array_equal(r.tool_R, np.eye(3))
    np.testing.assert_array_equal(r.tool_p, np.zeros(3))
    assert not r.has_drives
    # axis x: local z is rotated onto x; the link inertia follows
    Ra = align_z(np.array([1.0, 0, 0]))
    close(r.placement_R[2], Ra, 1e-15)
    close(r.inertia[2], Ra.T @ np.diag([0.1, 0.2, 0.3]) @ Ra, 1e-15)


def test_missing_limit_sides_and_axis_default():
    text = urdf(link("base") + link("l1")
                + joint("j1", "base", "l1", axis=None, extra='<limit upper="1.5"/>'))
    r = robot_from_urdf_string(text)
    np.testing.assert_array_equal(r.limits, [[-np.inf, 1.5]])
    close(r.placement_R[0][:, 2], [1.0, 0.0, 0.0], 1e-15)  # URDF default axis (1, 0, 0)


def test_axis_is_normalised():
    text = urdf(link("base") + link("l1") + joint("j1", "base", "l1", axis="0 0 +3"))
    close(robot_from_urdf_string(text).placement_R[0], np.eye(3), 1e-15)


def test_fixed_joint_merges_child_into_parent_body():
    text = urdf(
        link("base", mass=7.0) + link("b2", mass=3.0)  # base and its fixed child: dropped
        + link("l1", mass=2.0, xyz="0.1 0 0")
        + link("tool", mass=1.0, xyz="0 0.2 0", rpy="0 0 1.5707963267948966")
        + link("l2", mass=1.0)
        + joint("f0", "base", "b2", kind="fixed", xyz="0 0 0.5")
        + joint("j1", "b2", "l1", xyz="0 0 0.25")
        + joint("f1", "l1", "tool", kind="fixed", xyz="0.5 0 0", rpy="0 0 1.5707963267948966")
        + joint("j2", "tool", "l2", xyz="0 0 0.1"))
    r = robot_from_urdf_string(text)
    assert r.joint_names == ("j1", "j2") and list(r.parent) == [-1, 0]
    close(r.placement_p[0], [0, 0, 0.75], 1e-15)
    # j2 placed through the fixed transform f1
    close(r.placement_p[1], [0.5, 0, 0.1], 1e-15)
    close(r.placement_R[1], rpy_matrix(np.array([0, 0, np.pi / 2])), 1e-15)
    # mass and centre of l1 + tool: tool's centre is at f1 · (0, 0.2, 0) = (0.3, 0, 0)
    assert r.mass[0] == pytest.approx(3.0)
    close(r.com[0], [(2 * 0.1 + 1 * 0.3) / 3, 0, 0], 1e-15)
    # inertia: tool's axes turned by pi (two quarter turns) -> same diagonal; parallel axes
    d1, d2 = 0.1 - r.com[0][0], 0.3 - r.com[0][0]
    expect = 2 * np.diag([0.1, 0.2, 0.3]) + np.diag([0, 2 * d1**2 + d2**2, 2 * d1**2 + d2**2])
    close(r.inertia[0], expect, 1e-14)


def test_child_listed_before_parent_is_reordered():
    text = urdf(
        link("base") + link("a") + link("b") + link("c") + link("d")
        + joint("jb", "a", "b") + joint("jc", "base", "c") + joint("jd", "b", "d")
        + joint("ja", "base", "a"))
    r = robot_from_urdf_string(text)
    # smallest topological order: jc (base), then ja (base), then jb, jd
    assert r.joint_names == ("jc", "ja", "jb", "jd")
    assert list(r.parent) == [-1, -1, 1, 2]
    assert r.link_names == ("c", "a", "b", "d")


def test_parents_first_file_keeps_its_order():
    text = urdf(
        link("base") + link("a") + link("b") + link("c")
        + joint("ja", "base", "a") + joint("jc", "base", "c") + joint("jb", "a", "b"))
    r = robot_from_urdf_string(text)
    assert r.joint_names == ("ja", "jc", "jb") and list(r.parent) == [-1, -1, 0]


def test_mimic_joint_is_independent_with_a_warning():
    text = urdf(
        link("base") + link("f1") + link("f2")
        + joint("j1", "base", "f1", kind="prismatic")
        + joint("j2", "base", "f2", kind="prismatic", axis="0 -1 0",
                extra='<mimic joint="j1" multiplier="1" offset="0"/>'))
    with pytest.warns(ManipcadWarning, match="'j2' mimics 'j1'"):
        r = robot_from_urdf_string(text)
    assert r.n == 2 and r.joint_types == ("prismatic", "prismatic")


def test_inertial_rpy_rotates_inertia():
    text = urdf(link("base") + link("l1", mass=2.0, xyz="0.1 0.2 0.3", rpy="0.4 -0.2 1.1")
                + joint("j1", "base", "l1"))
    r = robot_from_urdf_string(text)
    R = rpy_matrix(np.array([0.4, -0.2, 1.1]))
    close(r.inertia[0], R @ np.diag([0.1, 0.2, 0.3]) @ R.T, 1e-15)
    close(r.com[0], [0.1, 0.2, 0.3], 1e-15)


def test_transmission_and_gazebo_joint_tags_are_ignored():
    text = urdf(link("base") + link("l1") + joint("j1", "base", "l1")
                + '<transmission name="t"><joint name="j1"/></transmission>'
                + '<gazebo reference="l1"><joint name="x"/></gazebo>')
    assert robot_from_urdf_string(text).n == 1


# ----------------------------------------------------------------- bad input


GOOD_LINKS = link("base") + link("l1") + link("l2")
J1 = joint("j1", "base", "l1")
J2 = joint("elbow", "l1", "l2")


def bad(text: str, *fragments: str, tmp_path: Path | None = None) -> InputError:
    """Load ``text`` from a file (so the message must name it) and check the message."""
    assert tmp_path is not None
    path = tmp_path / "bad_robot.urdf"
    path.write_text(text)
    with pytest.raises(InputError) as info:
        load_urdf(path)
    msg = str(info.value)
    assert msg.startswith(str(path)), msg
    for f in fragments:
        assert f in msg, f"{f!r} not in {msg!r}"
    return info.value


@pytest.mark.parametrize("text, fragments", [
    ("<robot name='r'><link name='a'></robot>", ["malformed XML", "line 1"]),
    ("", ["malformed XML"]),
    ("<model name='r'/>", ["root element is <model>", "expected <robot>"]),
    (urdf(""), ["no <link> elements"]),
    (urdf(GOOD_LINKS + J1 + joint("elbow", "l1", "ghost")),
     ["joint 'elbow'.child", "link 'ghost' does not exist"]),
    (urdf(GOOD_LINKS + J1 + joint("elbow", "nowhere", "l2")),
     ["joint 'elbow'.parent", "link 'nowhere' does not exist"]),
    (urdf(GOOD_LINKS + J1 + '<joint name="elbow" type="revolute"><child link="l2"/></joint>'),
     ["joint 'elbow'.parent", "missing"]),
    (urdf(GOOD_LINKS + J1), ["2 root links", "'base'", "'l2'"]),
    (urdf(GOOD_LINKS + J1 + J2 + joint("again", "base", "l2")),
     ["joint 'again'.child", "link 'l2' already has the parent joint 'elbow'", "loop"]),
    (urdf(GOOD_LINKS + link("l3") + J1 + joint("elbow", "l2", "l3") + joint("back", "l3", "l2")),
     ["cycle", "'l2'", "'l3'"]),
    (urdf(link("a") + link("b") + joint("ab", "a", "b") + joint("ba", "b", "a")),
     ["no root link", "cycle"]),
    (urdf(GOOD_LINKS + J1 + joint("elbow", "l2", "l2")),
     ["joint 'elbow'", "same link 'l2'", "loop"]),
    (urdf(GOOD_LINKS + J1 + joint("elbow", "l1", "l2", kind="floating")),
     ["joint 'elbow'.type", "'floating' is unsupported", "revolute, continuous, prismatic, fixed"]),
    (urdf(GOOD_LINKS + J1 + joint("elbow", "l1", "l2", kind="planar")),
     ["joint 'elbow'.type", "'planar' is unsupported"]),
    (urdf(GOOD_LINKS + J1 + joint("elbow", "l1", "l2", kind="ball")),
     ["joint 'elbow'.type", "unknown joint type 'ball'"]),
    (urdf(GOOD_LINKS + J1 + J2.replace(' type="revolute"', "")),
     ["joint 'elbow'.type", "missing"]),
    (urdf(GOOD_LINKS + J1 + joint("elbow", "l1", "l2", axis="0 1")),
     ["joint 'elbow'.axis", "expected 3 numbers", "'0 1'"]),
    (urdf(GOOD_LINKS + J1 + joint("elbow", "l1", "l2", axis="0 0 0")),
     ["joint 'elbow'.axis", "non-zero"]),
    (urdf(GOOD_LINKS + J1 + joint("elbow", "l1", "l2", axis="0 y 1")),
     ["joint 'elbow'.axis", "not a number"]),
    (urdf(GOOD_LINKS + J1 + joint("elbow", "l1", "l2", xyz="0 0 nan")),
     ["joint 'elbow'.origin.xyz", "finite"]),
    (urdf(GOOD_LINKS + J1 + joint("elbow", "l1", "l2", rpy="0 0 inf")),
     ["joint 'elbow'.origin.rpy", "finite"]),
    (urdf(GOOD_LINKS + J1 + joint("elbow", "l1", "l2",
                                  extra='<limit lower="low" upper="1"/>')),
     ["joint 'elbow'.limit.lower", "not a number: 'low'"]),
    (urdf(GOOD_LINKS + J1 + joint("elbow", "l1", "l2", extra='<limit lower="1" upper="-1"/>')),
     ["joint 'elbow'.limit", "lower 1.0 > upper -1.0"]),
    (urdf(link("base") + link("l1", mass=-2) + link("l2") + J1 + J2),
     ["link 'l1'.inertial.mass.value", "must be >= 0 kg", "-2"]),
    (urdf(link("base") + link("l1", mass="heavy") + link("l2") + J1 + J2),
     ["link 'l1'.inertial.mass.value", "not a number: 'heavy'"]),
    (urdf(link("base") + link("l1", inertia='ixx="1" ixy="0" ixz="0" iyy="1" iyz="0"')
          + link("l2") + J1 + J2),
     ["link 'l1'.inertial.inertia.izz", "missing"]),
    (urdf(link("base") + link("l1", inertia='ixx="1" ixy="2" ixz="0" iyy="1" iyz="0" izz="1"')
          + link("l2") + J1 + J2),
     ["link 'l1'.inertial.inertia", "not positive semi-definite"]),
    (urdf(link("base") + '<link name="l1"><inertial><mass value="1"/></inertial></link>'
          + link("l2") + J1 + J2),
     ["link 'l1'.inertial.inertia", "missing"]),
    (urdf(link("base") + '<link name="l1"><inertial><inertia ixx="1" ixy="0" ixz="0" '
          'iyy="1" iyz="0" izz="1"/></inertial></link>' + link("l2") + J1 + J2),
     ["link 'l1'.inertial.mass", "missing"]),
    (urdf(link("base") + link("l1", xyz="1 2") + link("l2") + J1 + J2),
     ["link 'l1'.inertial.origin.xyz", "expected 3 numbers"]),
    (urdf(GOOD_LINKS + link("l1") + J1 + J2), ["link 'l1'", "defined twice"]),
    (urdf(GOOD_LINKS + J1 + J2 + joint("j1", "l2", "l1")), ["joint 'j1'", "defined twice"]),
    (urdf(GOOD_LINKS + '<joint type="revolute"/>'), ["joint #1", "no name"]),
    (urdf(link("base") + link("l1") + joint("f", "base", "l1", kind="fixed")),
     ["no movable joint"]),
])
def test_bad_urdf(text, fragments, tmp_path):
    bad(text, *fragments, tmp_path=tmp_path)


def test_inertia_breaking_triangle_inequality_loads_with_warning():
    text = urdf(link("base") + link("l1", inertia='ixx="0.1" ixy="0" ixz="0" iyy="0.1" '
                                                  'iyz="0" izz="0.5"') + J1)
    with pytest.warns(ManipcadWarning, match=r"<string>: link 'l1'\.inertial\.inertia: .*"
                      "triangle inequality"):
        r = robot_from_urdf_string(text)
    assert r.inertia[0][2, 2] == pytest.approx(0.5)


def test_allegro_warns_for_its_finger_tips():
    path = erd_robots_dir() / ERD_URDFS["allegro"]
    with pytest.warns(ManipcadWarning) as record:
        load_urdf(path)
    messages = [str(w.message) for w in record]
    assert any("link 'link_15.0'.inertial.inertia" in m for m in messages), messages


def test_missing_file_names_the_file(tmp_path):
    path = tmp_path / "nope.urdf"
    with pytest.raises(InputError, match="nope.urdf: no such file"):
        load_urdf(path)


def test_string_source_names_the_source():
    with pytest.raises(InputError, match=r"^mytext: joint 'j'\.type: unknown joint type 'x'"):
        robot_from_urdf_string(urdf(link("a") + link("b") + joint("j", "a", "b", kind="x")),
                               source="mytext")


def test_load_robot_bad_urdf_is_input_error(tmp_path):
    from manipcad import load_robot

    path = tmp_path / "loop.urdf"
    path.write_text(urdf(GOOD_LINKS + J1 + J2 + joint("again", "base", "l2")))
    with pytest.raises(InputError, match="loop.urdf: joint 'again'.child"):
        load_robot(path)
