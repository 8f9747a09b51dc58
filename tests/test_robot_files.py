"""Robot files: URDF + drives (locks, payload on a named link, tool), the tree form
Robot.save writes, and the DH drive fields backlash and elasticity.

The URDF + drives robots are checked against Pinocchio's own URDF parser on the
same files (example-robot-data's UR5 and Panda): the payload is added to the
Pinocchio model in the link's URDF frame (``model.frames[...].placement``),
the Panda's fingers are locked with ``pin.buildReducedModel``, and the tool
frame is Pinocchio's frame placement composed with the file's xyz/rpy.
"""

from __future__ import annotations

import dataclasses
import math
import shutil
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from test_urdf import ERD_URDFS, erd_robots_dir
from urdf_pinref import StateMap, close

import manipcad
from manipcad.drives.params import KIND_ELASTIC, P_GAP, P_KIND, P_KS, pack_drives
from manipcad.errors import InputError, ModelError
from manipcad.kinematics import tool_pose
from manipcad.model.tree_file import save_robot
from manipcad.model.yaml_robot import rpy_to_matrix


@pytest.fixture(scope="module")
def urdf_dir(tmp_path_factory) -> Path:
    d = tmp_path_factory.mktemp("urdf")
    for key in ("ur5", "panda"):
        shutil.copy(erd_robots_dir() / ERD_URDFS[key], d)
    return d


def write(folder: Path, name: str, text: str) -> Path:
    p = folder / name
    p.write_text(text)
    return p


UR5 = """
name: ur5-drives
urdf: ur5_robot.urdf
drives:
  shoulder_pan_joint: {motor: maxon_re65_353297, gear: harmonic_csf20_100}
  shoulder_lift_joint: {motor: maxon_re65_353297, gear: harmonic_csf20_100,
                        elasticity: [3.0e4, 5.0], backlash: 2.0e-4}
  wrist_3_joint: {motor: maxon_re40_148877, gear: harmonic_csf17_100, k_u: 5}
payload: {link: wrist_3_link, mass: 2.0, com: [0.01, -0.02, 0.05],
          inertia: {ixx: 0.003, iyy: 0.004, izz: 0.002, ixy: 0.0005}}
tool: {link: tool0, xyz: [0.0, 0.02, 0.1], rpy: [0.1, -0.2, 0.3]}
"""

PANDA = """
urdf: panda.urdf
lock: {panda_finger_joint1: 0.02, panda_finger_joint2: 0.03}
drives:
  panda_joint1: {motor: maxon_re40_148877, gear: harmonic_csf17_100}
payload: {link: panda_hand, mass: 1.5, com: [0.0, 0.01, 0.08]}
tool: {link: panda_hand_tcp}
"""


def pin_with_payload(model: pin.Model, link: str, mass, com, inertia) -> pin.Model:
    """Pinocchio model with a payload given in a link's URDF frame."""
    model = model.copy()
    f = model.frames[model.getFrameId(link)]
    model.inertias[f.parentJoint] += f.placement.act(pin.Inertia(mass, np.array(com), inertia))
    return model


def check_dynamics(robot, model: pin.Model, seed: int = 0) -> None:
    smap = StateMap(robot, model)
    data = model.createData()
    rng = np.random.default_rng(seed)
    for _ in range(3):
        q, qd, qdd = rng.uniform(-1.5, 1.5, (3, robot.n))
        tau = manipcad.inverse_dynamics(robot, q, qd, qdd, drives=False)
        ref = pin.rnea(model, data, smap.q(q), smap.v(qd), smap.v(qdd))
        close(tau, smap.back(ref))


def test_ur5_file_matches_pinocchio_with_payload_and_tool(urdf_dir):
    robot = manipcad.load_robot(write(urdf_dir, "ur5.yaml", UR5))
    assert robot.name == "ur5-drives" and robot.n == 6
    names = [d.name if d else None for d in robot.drives]
    assert names == ["maxon_re65_353297", "maxon_re65_353297", None, None, None,
                     "maxon_re40_148877"]
    d1 = robot.drives[1]
    assert (d1.stiffness, d1.damping, d1.backlash) == (3.0e4, 5.0, 2.0e-4)
    assert robot.drives[5].k_u == 5.0
    assert d1.gear_rated_torque == 40.0 and d1.efficiency == 0.75

    model = pin.buildModelFromUrdf(str(urdf_dir / "ur5_robot.urdf"))
    I = np.array([[0.003, 0.0005, 0], [0.0005, 0.004, 0], [0, 0, 0.002]])
    check_dynamics(robot, pin_with_payload(model, "wrist_3_link", 2.0, [0.01, -0.02, 0.05], I))
    # and the robot without the payload differs (the payload is really there)
    bare = manipcad.load_robot(urdf_dir / "ur5_robot.urdf")
    q = np.full(6, 0.3)
    assert abs(manipcad.inverse_dynamics(robot, q, 0 * q, 0 * q, drives=False)
               - manipcad.inverse_dynamics(bare, q, 0 * q, 0 * q, drives=False)).max() > 1.0

    data = model.createData()
    smap = StateMap(robot, model)
    T_extra = pin.SE3(rpy_to_matrix(0.1, -0.2, 0.3), np.array([0.0, 0.02, 0.1]))
    for q in np.random.default_rng(1).uniform(-2, 2, (3, 6)):
        pin.framesForwardKinematics(model, data, smap.q(q))
        ref = data.oMf[model.getFrameId("tool0")] * T_extra
        close(tool_pose(robot, q), ref.homogeneous, rtol=1e-12)


def test_panda_locked_fingers_payload_on_fixed_link(urdf_dir):
    robot = manipcad.load_robot(write(urdf_dir, "panda.yaml", PANDA))
    assert robot.n == 7 and "panda_finger_joint1" not in robot.joint_names
    full = pin.buildModelFromUrdf(str(urdf_dir / "panda.urdf"))
    q0 = pin.neutral(full)
    for name, v in (("panda_finger_joint1", 0.02), ("panda_finger_joint2", 0.03)):
        q0[full.joints[full.getJointId(name)].idx_q] = v
    locked = [full.getJointId("panda_finger_joint1"), full.getJointId("panda_finger_joint2")]
    model = pin.buildReducedModel(full, locked, q0)
    check_dynamics(robot, pin_with_payload(model, "panda_hand", 1.5, [0.0, 0.01, 0.08],
                                           np.zeros((3, 3))))
    data = model.createData()
    smap = StateMap(robot, model)
    q = np.linspace(-1, 1, 7)
    pin.framesForwardKinematics(model, data, smap.q(q))
    close(tool_pose(robot, q), data.oMf[model.getFrameId("panda_hand_tcp")].homogeneous,
          rtol=1e-12)
    # the identification helper's entry: a named link's body and frame
    body, R, p = robot.link_frame("panda_hand")
    assert body == 6 and robot.link_index("panda_hand") == 6
    f = model.frames[model.getFrameId("panda_hand")].placement
    # our body frame and Pinocchio's joint frame share the origin (urdf_pinref)
    close(p, f.translation, rtol=1e-12)


def assert_same_robot(a, b) -> None:
    assert a.name == b.name and a.joint_names == b.joint_names
    assert a.joint_types == b.joint_types and a.link_names == b.link_names
    for key in ("parent", "placement_R", "placement_p", "offset", "mass", "com", "inertia",
                "gravity", "limits", "tool_R", "tool_p", "table"):
        np.testing.assert_array_equal(getattr(a, key), getattr(b, key), err_msg=key)
    assert len(a.drives) == len(b.drives)
    for da, db in zip(a.drives, b.drives, strict=True):
        assert (da is None) == (db is None)
        if da is not None:
            np.testing.assert_equal(dataclasses.asdict(da), dataclasses.asdict(db))
    assert [f[:2] for f in a.frames] == [f[:2] for f in b.frames]
    for fa, fb in zip(a.frames, b.frames, strict=True):
        np.testing.assert_array_equal(fa[2], fb[2])
        np.testing.assert_array_equal(fa[3], fb[3])


@pytest.mark.filterwarnings("ignore::manipcad.errors.ManipcadWarning")
@pytest.mark.parametrize("which", ["ur5", "panda", "puma560", "cylindrical"])
def test_save_loads_back_identical(urdf_dir, tmp_path, which):
    if which in ("ur5", "panda"):
        robot = manipcad.load_robot(write(urdf_dir, f"{which}.yaml",
                                          UR5 if which == "ur5" else PANDA))
    else:
        robot = manipcad.load_robot(which)
    path = save_robot(robot, tmp_path / "saved.yaml")
    back = manipcad.load_robot(path)
    assert_same_robot(robot, back)
    # saved again: the same text (a fixed point)
    assert save_robot(back, tmp_path / "again.yaml").read_text() == path.read_text()


#: a one-joint DH robot file up to its first drive line
ONE_JOINT = """
name: one
joints:
  - name: a
    type: revolute
    link: {mass: 1.0, com: [0.1, 0, 0], inertia: {ixx: 0.01, iyy: 0.01, izz: 0.01}}
"""


def test_dh_file_backlash_and_elasticity(tmp_path):
    text = ONE_JOINT + """\
    drive: {motor: maxon_re40_148877, gear: harmonic_csf17_100, elasticity: [2.0e4, 3.0],
            backlash: 1.0e-4}
  - name: b
    type: revolute
    link: {mass: 1.0, com: [0.1, 0, 0], inertia: {ixx: 0.01, iyy: 0.01, izz: 0.01}}
    drive: {motor: maxon_re40_148877, gear: harmonic_csf17_100}
"""
    robot = manipcad.load_robot(write(tmp_path, "one.yaml", text))
    table = pack_drives(robot.drives)
    assert int(table[0, P_KIND]) == KIND_ELASTIC
    assert (table[0, P_KS], table[0, P_GAP]) == (2.0e4, 1.0e-4)
    assert int(table[1, P_KIND]) != KIND_ELASTIC and not robot.drives[1].elastic


@pytest.mark.parametrize("body,field,words", [
    ("drives: {nope: {motor: maxon_re40_148877}}", "drives.nope", "no movable joint"),
    ("lock: {nope: 0.0}", "lock.nope", "no joint"),
    ("lock: {shoulder_pan_joint: 9.0}", "lock.shoulder_pan_joint", "within"),
    ("lock: {shoulder_pan_joint: 0.0}\ndrives: {shoulder_pan_joint: {motor: maxon_re40_148877}}",
     "drives.shoulder_pan_joint", "locked"),
    ("tool: {link: forearm_link}", "tool.link", "last joint"),
    ("payload: {link: nope, mass: 1.0}", "payload.link", "no link"),
    ("payload: {link: tool0, mass: -1.0}", "payload.mass", ">= 0"),
    ("drives: {elbow_joint: {motor: maxon_re40_148877, backlash: 0.001}}",
     "drives.elbow_joint.backlash", "contact stiffness"),
    ("drives: {elbow_joint: {motor: nope}}", "drives.elbow_joint.motor", "unknown motor"),
    ("gravity: [0, 0]", "gravity", "3 numbers"),
])
def test_urdf_robot_file_errors(urdf_dir, body, field, words):
    path = write(urdf_dir, "bad.yaml", "urdf: ur5_robot.urdf\n" + body + "\n")
    with pytest.raises(InputError) as err:
        manipcad.load_robot(path)
    assert err.value.source == str(path) and err.value.field == field
    assert words in err.value.reason


def test_missing_urdf_named(tmp_path):
    path = write(tmp_path, "r.yaml", "urdf: nothere.urdf\n")
    with pytest.raises(InputError, match="urdf: no such file"):
        manipcad.load_robot(path)


@pytest.mark.filterwarnings("ignore::manipcad.errors.ManipcadWarning")
def test_link_frame_errors_name_links():
    puma = manipcad.load_robot("puma560")
    with pytest.raises(ModelError, match="no link named 'x'; links are"):
        puma.link_frame("x")
    with pytest.raises(ModelError, match="1..6"):
        puma.link_frame(0)


# ------------------------------------------------------------------ CLI and examples
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_cli_robots_show_and_save(tmp_path):
    import json

    from typer.testing import CliRunner

    from manipcad.cli import app

    runner = CliRunner()
    res = runner.invoke(app, ["robots", "show", str(EXAMPLES / "panda" / "panda.yaml"), "--json"])
    assert res.exit_code == 0, res.output
    data = json.loads(res.stdout)
    assert [j["number"] for j in data["joints"]] == list(range(1, 8))
    assert data["joints"][6]["link"] == "panda_link7"
    assert "panda_hand_tcp" in [f["name"] for f in data["links"]]
    assert data["joints"][0]["drive"]["gear_rated_torque"] == 52.0     # CSG-20-100
    out = tmp_path / "panda_saved.yaml"
    res = runner.invoke(app, ["robots", "save", str(EXAMPLES / "panda" / "panda.yaml"), str(out)])
    assert res.exit_code == 0, res.output
    assert_same_robot(manipcad.load_robot(EXAMPLES / "panda" / "panda.yaml"),
                      manipcad.load_robot(out))
    res = runner.invoke(app, ["robots", "show", str(tmp_path / "nope.yaml")])
    assert res.exit_code == 2 and "Traceback" not in res.output


@pytest.mark.parametrize("which", ["ur5", "panda"])
def test_examples_load_and_size(which):
    """The worked examples load from their own folder (no absolute path) and every check
    passes on their trajectory, on printed data and one stated assumption: the CSG
    gears' efficiency (their catalogue prints none; the library's strain-wave
    assumption, recorded in each drive's ``assumed``). With the efficiency unknown
    instead (``size --strict``) the motor torque and voltage checks are unknown: they
    pass at η = 1, a lossless gear."""
    from manipcad.sizing import required_drive
    from manipcad.trajectories import load_trajectory

    robot = manipcad.load_robot(EXAMPLES / which / f"{which}.yaml")
    assert all(d is not None and d.has_electrics for d in robot.drives)
    req = required_drive(robot, load_trajectory(EXAMPLES / which / "pick.yaml", robot=robot))
    assert set(req.status) == {"pass"}
    assert all(d.gear.startswith("harmonic_csg") and dict(d.assumed).keys() == {"efficiency"}
               for d in robot.drives)
    strict = robot.replace(drives=tuple(d.replace(efficiency=math.nan, assumed=())
                                        for d in robot.drives))
    req = required_drive(strict, load_trajectory(EXAMPLES / which / "pick.yaml", robot=robot))
    unknown = {(name, j) for name, c in req.checks.items() for j, s in enumerate(c.status)
               if s == "unknown"}
    assert unknown == {(k, j) for k in ("continuous", "peak", "voltage") for j in range(robot.n)}
    for k in ("continuous", "peak", "voltage"):          # at η = 1 (a lossless gear)
        c = req.checks[k]
        assert (c.required < c.limit).all()
    for k in ("gear_continuous", "gear_peak", "gear_speed"):
        assert set(req.checks[k].status) == {"pass"}


@pytest.mark.parametrize("which, mass", [("ur5", 1.0), ("panda", 0.5)])
def test_unloaded_examples_match_their_arm(which, mass):
    """`identify` models the arm without its payload (README there): the *_unloaded file
    has the same drives and joints, and carries exactly the payload mass less."""
    arm = manipcad.load_robot(EXAMPLES / which / f"{which}.yaml")
    bare = manipcad.load_robot(EXAMPLES / which / f"{which}_unloaded.yaml")
    assert arm.drives == bare.drives and arm.joint_names == bare.joint_names
    assert arm.mass.sum() - bare.mass.sum() == pytest.approx(mass, abs=1e-12)


def test_payload_on_unknown_link_names_links_and_joints(urdf_dir):
    ur5 = manipcad.load_robot(urdf_dir / "ur5_robot.urdf")
    with pytest.raises(ModelError, match="no link or joint named 'tol0'.*links are .*tool0.*"
                                         "joints are .*wrist_3_joint"):
        ur5.with_payload(1.0, link="tol0")
    # a link name puts the centre of mass in that link's URDF frame, a joint name in the
    # body frame; the UR5's wrist_3 axis is URDF y, so the two frames differ
    body, R, p = ur5.link_frame("wrist_3_link")
    c = np.array([0.0, 0.0, 0.1])
    assert body == 5 and not np.allclose(R @ c + p, c)
    by_link = ur5.with_payload(1.0, c, link="wrist_3_link")
    by_joint = ur5.with_payload(1.0, R @ c + p, link="wrist_3_joint")
    np.testing.assert_allclose(by_link.com[5], by_joint.com[5], rtol=0, atol=1e-15)
    np.testing.assert_allclose(by_link.com[5] * by_link.mass[5] - ur5.com[5] * ur5.mass[5],
                               R @ c + p, atol=1e-12)


def test_gear_chain_composition_closed_forms():
    """compose_gears against hand sums for a TP004 (i = 10) into a CSF-20 (i = 100)."""
    from manipcad.model.yaml_robot import compose_gears, load_gear

    tp, csf = load_gear("wittenstein_tp004mf_10"), load_gear("harmonic_csf20_100")
    f, k = compose_gears([tp, csf])
    assert f["ratio"] == -1000.0
    assert f["J"] == tp.J + csf.J / 10.0**2
    assert f["efficiency"] == 0.97 * 0.75
    # output limits referred to the joint: tp's 27 N·m through the CSF (x 100 x 0.75), CSF's 40
    assert f["gear_rated_torque"] == min(27.0 * 100 * 0.75, 40.0)
    assert f["gear_peak_torque"] == min(42.0 * 100 * 0.75, 82.0)
    # input-speed limits referred to the motor: tp's own, the CSF's times 10
    assert f["gear_max_input_speed"] == min(tp.max_input_speed, csf.max_input_speed * 10)
    assert k is None                                   # the CSF file gives no stiffness
    f2, k2 = compose_gears([tp, load_gear("wittenstein_tp050ma_110")])
    k_tp, k_big = tp.stiffness, load_gear("wittenstein_tp050ma_110").stiffness
    assert np.isclose(k2, 1.0 / (1.0 / (k_tp * 110.0**2) + 1.0 / k_big), rtol=1e-14)
    assert np.isclose(k_tp, 8 * 60 * 180 / np.pi, rtol=1e-14)   # 8 N·m/arcmin


def test_backlash_alone_takes_the_gear_stiffness(tmp_path):
    text = ONE_JOINT + """\
    drive: {motor: maxon_ec45flat_411812, gear: wittenstein_tp004mf_10, backlash: 5.0e-4}
"""
    d = manipcad.load_robot(write(tmp_path, "b.yaml", text)).drives[0]
    assert d.backlash == 5.0e-4 and d.elastic
    assert np.isclose(d.stiffness, 8 * 60 / (np.pi / 180), rtol=1e-14)
