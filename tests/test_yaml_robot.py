"""YAML robot loader: catalog robots, mapping of both DH conventions, drives, bad input.

Independent references: the Robotics Toolbox for Python (rtb.models.DH.Puma560,
rtb.models.DH.Stanford and hand-built modified-DH robots: forward kinematics,
parameters and RNE), and closed-form frame algebra written here in the tests.
"""

from __future__ import annotations

import copy
import math
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml

import manipcad
from manipcad.errors import InertiaWarning, InputError, ManipcadWarning, ModelError
from manipcad.model import dh
from manipcad.model.load import catalog_names, load_robot
from manipcad.model.robot import Robot, inertia_notes
from manipcad.model.yaml_robot import (
    CONSTANTS,
    evaluate,
    load_gear,
    load_motor,
    load_yaml_robot,
    rpy_to_matrix,
)

ROOT = Path(__file__).resolve().parents[1]
CATALOG = ROOT / "src" / "manipcad" / "model" / "catalog"
PARTS = ROOT / "src" / "manipcad" / "catalog" / "data" / "parts"

# --------------------------------------------------------------------------- helpers


def write(tmp_path: Path, doc: dict | str, name: str = "robot.yaml") -> Path:
    """Write a robot file (a dict is dumped as YAML, a str written as is)."""
    path = tmp_path / name
    path.write_text(doc if isinstance(doc, str) else yaml.safe_dump(doc, sort_keys=False))
    return path


def base_doc() -> dict:
    """A valid two-joint (RP) robot in modified DH with drives."""
    return {
        "name": "test arm",
        "convention": "modified",
        "joints": [
            {"name": "j1", "type": "revolute",
             "dh": {"a": 0.0, "alpha": 0.0, "d": 0.2, "theta": 0.0},
             "limits": [-3.0, 3.0],
             "link": {"mass": 2.0, "com": [0.1, 0.0, 0.05],
                      "inertia": {"ixx": 0.01, "iyy": 0.02, "izz": 0.02}},
             "drive": {"J": 1e-5, "ratio": 50, "k_v": 1e-5, "M_f": [0.01, -0.02]}},
            {"name": "j2", "type": "prismatic",
             "dh": {"a": 0.3, "alpha": "-pi/2", "d": 0.1, "theta": 0.0},
             "link": {"mass": 1.0, "com": [0.0, 0.0, -0.1],
                      "inertia": {"ixx": 0.005, "iyy": 0.005, "izz": 0.001}}},
        ],
    }


def expect_error(tmp_path: Path, doc: dict | str, field: str, *reason: str) -> InputError:
    """Loading ``doc`` raises an InputError naming the file, ``field`` and the reason words."""
    path = write(tmp_path, doc)
    with pytest.raises(InputError) as info:
        load_yaml_robot(path)
    err = info.value
    msg = str(err)
    assert str(path) in msg, msg
    assert err.source == str(path)
    assert err.field == field, msg
    if field:
        assert f": {field}: " in msg, msg
    for word in reason:
        assert word.lower() in msg.lower(), msg
    assert msg.count("\n") == 0  # one line
    return err


def fk(robot: Robot, q: np.ndarray) -> np.ndarray:
    """Tool pose (4x4) by composing the placements and joint motions (reference)."""
    T = [np.eye(4)] * robot.n
    for i in range(robot.n):
        A = np.eye(4)
        A[:3, :3], A[:3, 3] = robot.placement_R[i], robot.placement_p[i]
        M = np.eye(4)
        x = q[i] + robot.offset[i]
        if robot.joint_types[i] == "revolute":
            M[:3, :3] = dh.rot_z(x)
        else:
            M[2, 3] = x
        P = np.eye(4) if robot.parent[i] < 0 else T[robot.parent[i]]
        T[i] = P @ A @ M
    tool = np.eye(4)
    tool[:3, :3], tool[:3, 3] = robot.tool_R, robot.tool_p
    return T[-1] @ tool


def load_quiet(name: str) -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return load_robot(name)


def has_dynamics() -> bool:
    try:
        import manipcad.dynamics as d
    except ImportError:
        return False
    return callable(getattr(d, "inverse_dynamics", None)) and callable(
        getattr(d, "mass_matrix", None))


needs_dynamics = pytest.mark.skipif(not has_dynamics(), reason="manipcad.dynamics not available")


def rel(a, b) -> float:
    a, b = np.asarray(a, float), np.asarray(b, float)
    return float(np.abs(a - b).max() / max(np.abs(b).max(), 1.0))


# --------------------------------------------------------------------------- catalog


@pytest.mark.parametrize("name", catalog_names("robots"))
def test_every_catalog_robot_loads(name):
    robot = load_quiet(name)
    assert robot.n >= 3
    assert robot.source, "every catalog robot cites its source"
    assert all(d is not None for d in robot.drives)
    assert np.all(robot.mass >= 0)
    text = (CATALOG / "robots" / f"{name}.yaml").read_text()
    assert "source:" in text


def test_catalog_has_the_required_robots():
    assert {"puma560", "cylindrical", "scara", "stanford"} <= set(catalog_names("robots"))


@pytest.mark.parametrize("name", catalog_names("motors"))
def test_every_catalog_motor_loads_with_source(name):
    m = load_motor(name)
    assert len(m.source) > 40
    assert m.J > 0 and m.R > 0 and m.L > 0 and m.k_m > 0
    # SI torque and back-EMF constants agree (within data-sheet rounding)
    assert m.k_w == pytest.approx(m.k_m, rel=0.02)
    # stall current ~ U/R and stall torque ~ k_m·I_stall (data-sheet consistency)
    if m.stall_current and m.rated_voltage:
        assert m.stall_current == pytest.approx(m.rated_voltage / m.R, rel=0.05)
        assert m.peak_torque == pytest.approx(m.k_m * m.stall_current, rel=0.05)
    if m.no_load_speed and m.rated_voltage:
        assert m.no_load_speed == pytest.approx(m.rated_voltage / m.k_w, rel=0.05)


@pytest.mark.parametrize("name", catalog_names("motors"))
def test_every_catalog_motor_ratings_are_plausible(name):
    """The ratings a sizing reads (rated and peak torque, max speed, rated voltage and
    current): positive where given, rated below peak, the rated torque within 10 % of
    k_m x rated current (maxon's nominal current carries the no-load current; Beckhoff's
    rated torque is K_T x I_n), a no-load speed under the max speed, and electrical and
    mechanical time constants of a servo motor (SI: s)."""
    m = load_motor(name)
    for key in ("rated_torque", "peak_torque", "max_speed", "rated_voltage", "rated_current",
                "no_load_speed", "mass"):
        value = getattr(m, key)
        assert value is None or value > 0, key
    if m.rated_torque is not None and m.peak_torque is not None:
        assert m.rated_torque < m.peak_torque
    if m.rated_torque is not None and m.rated_current is not None:
        assert m.k_m * m.rated_current == pytest.approx(m.rated_torque, rel=0.10)
    if m.max_speed is not None and m.no_load_speed is not None:
        assert m.no_load_speed < m.max_speed
    assert 1e-5 < m.L / m.R < 1e-2                        # electrical time constant, s
    assert 1e-4 < m.J * m.R / (m.k_m * m.k_w) < 0.1       # mechanical time constant, s


@pytest.mark.parametrize("name, K_T, K_E, peak", [
    ("beckhoff_am8112_0f21", 0.080, 5, 1.360), ("beckhoff_am8113_0f21", 0.108, 7, None),
    ("beckhoff_am8122_0fh1", 0.200, 13, 4.060)])
def test_beckhoff_servo_dc_equivalent(name, K_T, K_E, peak):
    """A sinusoidally commutated servomotor as the DC drive of paper section 3.1
    (catalog file headers): power-invariant in line-to-line quantities, so k_m = k_w =
    K_T·sqrt(2/3) (K_T per A rms), R and L phase to phase, the 48 V DC bus as the voltage
    (sqrt(2) x 33.9 V rms line to line). The type plate's EMF constant (rms line to line,
    an integer in mV/rpm) agrees with k_w within its rounding and Beckhoff's +/-10 %
    tolerance, so the conversion is checked against an independent datum."""
    m = load_motor(name)
    RPM = CONSTANTS["rpm"]
    assert m.k_m == pytest.approx(K_T * (2.0 / 3.0) ** 0.5, rel=1e-12)
    assert m.k_w == m.k_m
    emf = 2.0 ** 0.5 * K_E * 1e-3 / RPM                   # V·s/rad, line-to-line amplitude
    assert abs(emf - m.k_w) <= 2.0 ** 0.5 * 0.5e-3 / RPM + 0.10 * m.k_w
    assert m.rated_voltage == pytest.approx(48.0, rel=2e-3)
    # equivalent current sqrt(3/2)·I_rms: the rated torque is K_T x I_n in either unit
    assert m.rated_torque == pytest.approx(K_T * m.rated_current / 1.5 ** 0.5, rel=1e-12)
    assert m.peak_torque == peak                          # unknown stays unknown (None)
    assert m.max_speed == pytest.approx(10000 * RPM, rel=1e-15)
    text = " ".join(m.source.split())
    assert "ecmccfg" in text and "phase to phase" in text and "not from a Beckhoff" in text


def test_beckhoff_ratings_reach_the_sizing(tmp_path):
    """One horizontal-axis joint (1 kg at 0.1 m) through a CSG-20-100, swung by a cosine
    move: the AM8122's catalog ratings become the drive's (0.80 N·m rated, 4.06 N·m peak,
    10000 rpm, the 48 V bus as the voltage limit), so its speed check is decided
    ("pass" against 10000 rpm) where the EC 90 flat's, whose source gives no maximum
    speed, is "unknown". The torque and voltage checks stay "unknown" while the CSG
    efficiency is unknown, and are decided ("pass") once the drive states one."""
    from manipcad.sizing import required_drive
    from manipcad.trajectories import cosine

    RPM = CONSTANTS["rpm"]

    def robot(motor: str, **drive) -> Robot:
        doc = {"name": "one", "joints": [{
            "name": "j1", "type": "revolute",
            "dh": {"a": 0, "alpha": "pi/2", "d": 0, "theta": 0},
            "link": {"mass": 1.0, "com": [0.1, 0, 0],
                     "inertia": {"ixx": 0.01, "iyy": 0.01, "izz": 0.01}},
            "drive": {"motor": motor, "gear": "harmonic_csg20_100", **drive}}]}
        return load_yaml_robot(write(tmp_path, doc, f"{motor}.yaml"))

    traj = cosine([0.5], [2.0], 2.0)
    arm = robot("beckhoff_am8122_0fh1")
    d = arm.drives[0]
    assert (d.rated_torque, d.peak_torque, d.u_max) == (0.80, 4.06, 48.0)
    assert d.max_speed == pytest.approx(10000 * RPM, rel=1e-15)
    req = required_drive(arm, traj)
    assert req.checks["speed"].status == ("pass",)
    assert req.checks["speed"].limit[0] == pytest.approx(10000 * RPM, rel=1e-15)
    for k in ("continuous", "peak", "voltage"):   # on the CSG's assumed efficiency
        assert req.checks[k].status == ("pass",), k
    assert arm.drives[0].assumed[0][0] == "efficiency"
    req = required_drive(robot("beckhoff_am8122_0fh1", efficiency="unknown"), traj)
    for k in ("continuous", "peak", "voltage"):
        assert req.checks[k].status == ("unknown",), k
    assert required_drive(robot("maxon_ec90flat_244879"), traj).checks["speed"].status \
        == ("unknown",)
    known = required_drive(robot("beckhoff_am8122_0fh1", efficiency=0.7), traj)
    for k in ("continuous", "peak", "speed", "voltage"):
        assert known.checks[k].status == ("pass",), k
    assert known.checks["continuous"].limit[0] == 0.80


def test_at_least_four_motors_and_three_gears():
    assert len(catalog_names("motors")) >= 4
    assert len(catalog_names("gears")) >= 3


@pytest.mark.parametrize("name", catalog_names("gears"))
def test_every_catalog_gear_loads_with_source(name):
    g = load_gear(name)
    assert len(g.source) > 40
    assert g.ratio > 0 and g.J >= 0
    assert g.efficiency is None or 0 < g.efficiency <= 1


def test_examples_two_link_loads():
    robot = load_yaml_robot(ROOT / "examples" / "two_link.yaml")
    assert robot.n == 2
    d0, d1 = robot.drives
    assert d0.name == "maxon_re40_148867" and d0.gear == "maxon_gp42c_43"
    assert d0.k_u == 2.0 and d0.u_max == 24.0
    assert d1.ratio == 50 and d1.M_f == (2.0e-3, 2.5e-3)


# --------------------------------------------------------------------------- PUMA / Stanford vs RTB


def test_puma560_matches_rtb_joint_for_joint():
    rtb = pytest.importorskip("roboticstoolbox")
    ref = rtb.models.DH.Puma560()
    robot = load_quiet("puma560")
    assert robot.n == ref.n == 6
    for i, L in enumerate(ref.links):
        assert robot.joint_types[i] == "revolute"
        assert robot.mass[i] == pytest.approx(L.m, abs=1e-12)
        # link data: RTB gives them in the distal frame i; ours are in the body frame
        Rd, pd = dh.rot_x(L.alpha), np.array([L.a, 0.0, 0.0])
        np.testing.assert_allclose(robot.com[i], Rd @ np.asarray(L.r) + pd, atol=1e-12)
        np.testing.assert_allclose(robot.inertia[i], Rd @ L.I @ Rd.T, atol=1e-12)
        np.testing.assert_allclose(robot.limits[i], L.qlim, rtol=1e-12)
        d = robot.drives[i]
        assert d.J == pytest.approx(L.Jm, rel=1e-9)
        assert d.ratio == pytest.approx(L.G, rel=1e-9)
        assert d.k_v == pytest.approx(L.B, rel=1e-9)
        assert d.M_f[0] == pytest.approx(abs(L.Tc[0]), rel=1e-9)
        assert d.M_f[1] == pytest.approx(abs(L.Tc[1]), rel=1e-9)
        assert d.has_electrics
    rng = np.random.default_rng(1)
    for q in [ref.qz, ref.qn, ref.qr, *rng.uniform(-3, 3, (5, 6))]:
        np.testing.assert_allclose(fk(robot, q), ref.fkine(q).A, atol=1e-12)


@needs_dynamics
def test_puma560_dynamics_match_rtb_rne():
    rtb = pytest.importorskip("roboticstoolbox")
    import manipcad.dynamics as dyn

    ref = rtb.models.DH.Puma560()
    robot = load_quiet("puma560")
    rng = np.random.default_rng(2)
    for _ in range(5):
        q, qd, qdd = rng.normal(size=(3, 6))
        assert rel(dyn.inverse_dynamics(robot, q, qd, qdd), ref.rne(q, qd, qdd)) < 1e-9
        assert rel(dyn.mass_matrix(robot, q), ref.inertia(q)) < 1e-9


def test_stanford_matches_rtb_joint_for_joint():
    rtb = pytest.importorskip("roboticstoolbox")
    ref = rtb.models.DH.Stanford()
    robot = load_quiet("stanford")
    assert robot.joint_types == ("revolute", "revolute", "prismatic",
                                 "revolute", "revolute", "revolute")
    for i, L in enumerate(ref.links):
        Rd, pd = dh.rot_x(L.alpha), np.array([L.a, 0.0, 0.0])
        assert robot.mass[i] == pytest.approx(L.m, abs=1e-12)
        np.testing.assert_allclose(robot.com[i], Rd @ np.asarray(L.r) + pd, atol=1e-12)
        np.testing.assert_allclose(robot.inertia[i], Rd @ L.I @ Rd.T, atol=1e-12)
        np.testing.assert_allclose(robot.limits[i], L.qlim, rtol=1e-12)
        assert robot.drives[i].J == pytest.approx(L.Jm, rel=1e-12)
        assert robot.drives[i].ratio == L.G == 1
    rng = np.random.default_rng(3)
    for q in rng.uniform(-1, 1, (5, 6)) + np.array([0, 0, 0.8, 0, 0, 0]):
        np.testing.assert_allclose(fk(robot, q), ref.fkine(q).A, atol=1e-12)


def test_cylindrical_geometry():
    """Turn about the base z axis, lift along z, reach radially along base x at q1 = 0."""
    robot = load_quiet("cylindrical")
    assert robot.joint_types == ("revolute", "prismatic", "prismatic")
    np.testing.assert_allclose(robot.limits[2], [0.0, 0.5])
    np.testing.assert_allclose(fk(robot, np.zeros(3))[:3, 3], [0.8, 0, 0.3], atol=1e-12)
    np.testing.assert_allclose(fk(robot, np.array([np.pi / 2, 0, 0]))[:3, 3], [0, 0.8, 0.3],
                               atol=1e-12)
    np.testing.assert_allclose(fk(robot, np.array([0, 0.6, 0.5]))[:3, 3], [1.3, 0, 0.9],
                               atol=1e-12)
    assert all(d.has_electrics and d.name for d in robot.drives)
    d1 = robot.drives[0]
    # J = J_motor + J_gear on the motor shaft, ratio from the gear (CSF reverses)
    assert d1.J == pytest.approx(137e-7 + 0.079e-4, rel=1e-12)   # RE 40 + CSF-17-100
    assert d1.ratio == -100
    # reach: RE 65 directly on a 20-tooth AT5 pulley (2π/0.1 m), pulley + 2 idlers on the shaft
    d3 = robot.drives[2]
    assert d3.ratio == pytest.approx(2 * np.pi / 0.1, rel=1e-12)
    assert d3.J == pytest.approx(1340e-7 + 3 * 0.5 * 2700 * np.pi * 0.016**4 * 0.016, rel=1e-12)


# --------------------------------------------------------------------------- mapping


def test_modified_dh_mapping_closed_form(tmp_path):
    """Revolute: placement Rx(α)Tx(a)Tz(d), offset θ; prismatic: Rx(α)Tx(a)Rz(θ), offset d."""
    robot = load_yaml_robot(write(tmp_path, base_doc()))
    np.testing.assert_allclose(robot.placement_R[0], np.eye(3), atol=1e-15)
    np.testing.assert_allclose(robot.placement_p[0], [0, 0, 0.2])
    assert robot.offset[0] == 0.0
    np.testing.assert_allclose(robot.placement_R[1], dh.rot_x(-np.pi / 2), atol=1e-15)
    np.testing.assert_allclose(robot.placement_p[1], [0.3, 0, 0])
    assert robot.offset[1] == pytest.approx(0.1)
    np.testing.assert_allclose(robot.com[0], [0.1, 0, 0.05])  # proximal frame: unchanged
    assert robot.parent.tolist() == [-1, 0]
    np.testing.assert_allclose(robot.limits[0], [-3, 3])
    assert np.isinf(robot.limits[1]).all()


def test_modified_dh_against_rtb_mdh(tmp_path):
    """A modified-DH file gives RTB's MDH robot's kinematics and (with dynamics) RNE."""
    rtb = pytest.importorskip("roboticstoolbox")
    rows = [  # type, a, alpha, d, theta, m, r, (Ixx, Iyy, Izz)
        ("revolute", 0.0, 0.0, 0.3, 0.2, 3.0, [0.1, 0.02, -0.05], (0.02, 0.03, 0.025)),
        ("prismatic", 0.25, -np.pi / 2, 0.15, 0.4, 2.0, [0.0, 0.05, -0.1], (0.01, 0.012, 0.004)),
        ("revolute", 0.1, np.pi / 3, 0.05, -0.3, 1.0, [0.05, 0.0, 0.02], (0.003, 0.004, 0.005)),
    ]
    links, joints = [], []
    for k, (t, a, al, d, th, m, r, I) in enumerate(rows):
        cls = rtb.RevoluteMDH if t == "revolute" else rtb.PrismaticMDH
        fixed = {"d": d, "offset": th} if t == "revolute" else {"theta": th, "offset": d}
        links.append(cls(a=a, alpha=al, m=m, r=r, I=[*I, 0, 0, 0], **fixed))
        joints.append({"name": f"j{k}", "type": t,
                       "dh": {"a": a, "alpha": al, "d": d, "theta": th},
                       "link": {"mass": m, "com": r,
                                "inertia": {"ixx": I[0], "iyy": I[1], "izz": I[2]}}})
    ref = rtb.DHRobot(links)
    robot = load_yaml_robot(write(tmp_path, {"name": "mdh", "joints": joints}))
    rng = np.random.default_rng(4)
    for q in rng.uniform(-1, 1, (5, 3)):
        np.testing.assert_allclose(fk(robot, q), ref.fkine(q).A, atol=1e-12)
    if has_dynamics():
        import manipcad.dynamics as dyn

        for _ in range(3):
            q, qd, qdd = rng.normal(size=(3, 3))
            assert rel(dyn.inverse_dynamics(robot, q, qd, qdd), ref.rne(q, qd, qdd)) < 1e-9


def _arm_in_both_conventions() -> tuple[dict, dict]:
    """The same RPR arm written in standard and in modified DH.

    Standard rows (a_i, alpha_i, d_i, theta_i) with link data given in the distal
    frames; the modified description shifts (a, alpha) one row down and gives
    the link data in the proximal (body) frames, computed here by the inverse
    transform of the distal frame (R_d^T (r - p_d), R_d^T I R_d), the opposite
    direction to the loader's.
    """
    rows = [  # type, a, alpha, d, theta
        ("revolute", 0.1, np.pi / 2, 0.4, 0.3),
        ("prismatic", 0.05, -np.pi / 2, 0.2, 0.5),
        ("revolute", 0.3, np.pi / 4, 0.1, -0.2),
    ]
    rng = np.random.default_rng(5)
    std_joints, mod_joints = [], []
    prev_a, prev_alpha = 0.0, 0.0
    for k, (t, a, al, d, th) in enumerate(rows):
        m = float(rng.uniform(1, 3))
        c_body = rng.normal(size=3) * 0.1
        box = rng.uniform(0.05, 0.4, 3)  # a solid box's principal moments, rotated
        Q = np.linalg.qr(rng.normal(size=(3, 3)))[0]
        I_body = Q @ np.diag(m * ((box**2).sum() - box**2) / 12) @ Q.T
        Rd, pd = dh.rot_x(al), np.array([a, 0.0, 0.0])
        c_dist = Rd.T @ (c_body - pd)
        I_dist = Rd.T @ I_body @ Rd

        def inertia(I):
            return {"ixx": float(I[0, 0]), "iyy": float(I[1, 1]), "izz": float(I[2, 2]),
                    "ixy": float(I[0, 1]), "ixz": float(I[0, 2]), "iyz": float(I[1, 2])}

        drive = {"J": 1e-5 * (k + 1), "ratio": 30.0 * (k + 1), "k_v": 1e-4, "M_f": 0.01}
        std_joints.append({"name": f"j{k}", "type": t,
                           "dh": {"a": a, "alpha": float(al), "d": d, "theta": th},
                           "link": {"mass": m, "com": c_dist.tolist(),
                                    "inertia": inertia(I_dist)}, "drive": drive})
        mod_joints.append({"name": f"j{k}", "type": t,
                           "dh": {"a": prev_a, "alpha": float(prev_alpha), "d": d, "theta": th},
                           "link": {"mass": m, "com": c_body.tolist(),
                                    "inertia": inertia(I_body)}, "drive": drive})
        prev_a, prev_alpha = a, al
    a3, al3 = rows[-1][1], rows[-1][2]
    tool = {"xyz": [0.0, 0.02, 0.05], "rpy": [0.1, 0.2, 0.3]}
    # modified: the last row's distal part Tx(a)Rx(alpha) composed with the tool
    Rt = dh.rot_x(al3) @ rpy_to_matrix(*tool["rpy"])
    pt = np.array([a3, 0, 0]) + dh.rot_x(al3) @ np.array(tool["xyz"])
    rpy_mod = _matrix_to_rpy(Rt)
    std = {"name": "arm", "convention": "standard", "gravity": [0.3, -0.2, -9.81],
           "tool": tool, "joints": std_joints}
    mod = {"name": "arm", "convention": "modified", "gravity": [0.3, -0.2, -9.81],
           "tool": {"xyz": pt.tolist(), "rpy": rpy_mod}, "joints": mod_joints}
    return std, mod


def _matrix_to_rpy(R: np.ndarray) -> list[float]:
    pitch = math.asin(-R[2, 0])
    return [math.atan2(R[2, 1], R[2, 2]), pitch, math.atan2(R[1, 0], R[0, 0])]


def test_standard_and_modified_same_kinematics(tmp_path):
    std, mod = _arm_in_both_conventions()
    rs = load_yaml_robot(write(tmp_path, std, "std.yaml"))
    rm = load_yaml_robot(write(tmp_path, mod, "mod.yaml"))
    rng = np.random.default_rng(6)
    for q in rng.uniform(-1, 1, (5, 3)):
        np.testing.assert_allclose(fk(rs, q), fk(rm, q), atol=1e-12)
    np.testing.assert_allclose(rs.com, rm.com, atol=1e-12)
    np.testing.assert_allclose(rs.inertia, rm.inertia, atol=1e-12)


@needs_dynamics
def test_standard_and_modified_same_dynamics(tmp_path):
    import manipcad.dynamics as dyn

    std, mod = _arm_in_both_conventions()
    rs = load_yaml_robot(write(tmp_path, std, "std.yaml"))
    rm = load_yaml_robot(write(tmp_path, mod, "mod.yaml"))
    rng = np.random.default_rng(7)
    q, qd, qdd = rng.normal(size=(3, 20, 3))
    for drives in (True, False):
        a = dyn.inverse_dynamics(rs, q, qd, qdd, drives=drives)
        b = dyn.inverse_dynamics(rm, q, qd, qdd, drives=drives)
        assert rel(a, b) < 1e-9
        assert rel(dyn.mass_matrix(rs, q, drives=drives),
                   dyn.mass_matrix(rm, q, drives=drives)) < 1e-9


def test_standard_dh_placements_closed_form(tmp_path):
    """Standard DH: joint i's placement is the parent's Tx(a)Rx(alpha) then Tz(d) / Rz(theta)."""
    doc = {"name": "s", "convention": "standard", "joints": [
        {"name": "a", "type": "revolute", "dh": {"a": 0.1, "alpha": 0.5, "d": 0.2, "theta": 0.3},
         "link": {"mass": 1, "com": [0.01, 0.02, 0.03]}},
        {"name": "b", "type": "prismatic", "dh": {"a": 0.4, "alpha": -0.7, "d": 0.6,
                                                  "theta": 0.8},
         "link": {"mass": 1}},
        {"name": "c", "type": "revolute", "parent": "a", "dh": {"a": 0.0, "alpha": 0.0,
                                                                "d": 0.9, "theta": 0.0},
         "link": {"mass": 1}},
    ]}
    robot = load_yaml_robot(write(tmp_path, doc))
    # first joint on the base: identity then Tz(d); offset theta
    np.testing.assert_allclose(robot.placement_R[0], np.eye(3))
    np.testing.assert_allclose(robot.placement_p[0], [0, 0, 0.2])
    assert robot.offset[0] == pytest.approx(0.3)
    # prismatic child: Tx(0.1)Rx(0.5) · Rz(0.8); offset d
    np.testing.assert_allclose(robot.placement_R[1], dh.rot_x(0.5) @ dh.rot_z(0.8), atol=1e-15)
    np.testing.assert_allclose(robot.placement_p[1], [0.1, 0, 0])
    assert robot.offset[1] == pytest.approx(0.6)
    # tree: c hangs on a, so its placement starts from a's distal part
    assert robot.parent.tolist() == [-1, 0, 0]
    np.testing.assert_allclose(robot.placement_R[2], dh.rot_x(0.5), atol=1e-15)
    np.testing.assert_allclose(robot.placement_p[2], [0.1, 0, 0] + dh.rot_x(0.5) @ [0, 0, 0.9])
    # link data carried from the distal frame into the body frame
    np.testing.assert_allclose(robot.com[0], dh.rot_x(0.5) @ [0.01, 0.02, 0.03] + [0.1, 0, 0])
    # tool: the last row's distal part
    np.testing.assert_allclose(robot.tool_R, np.eye(3))
    np.testing.assert_allclose(robot.tool_p, [0, 0, 0])


def test_parents_default_to_previous_and_base(tmp_path):
    doc = base_doc()
    doc["joints"].append({"name": "j3", "type": "revolute", "parent": "base",
                          "link": {"mass": 0.5}})
    doc["joints"].append({"name": "j4", "type": "revolute", "parent": "j1",
                          "link": {"mass": 0.5}})
    robot = load_yaml_robot(write(tmp_path, doc))
    assert robot.parent.tolist() == [-1, 0, -1, 0]
    assert robot.joint_names == ("j1", "j2", "j3", "j4")


def test_expressions_and_constants():
    assert evaluate("26.45*inch") == 26.45 * 0.0254
    assert evaluate("-160*deg") == -160 * (math.pi / 180)
    assert evaluate("-pi/2") == -math.pi / 2
    assert evaluate("137*gcm2") == pytest.approx(137e-7)
    assert evaluate("1/(158*rpm)") == pytest.approx(60 / (2 * math.pi * 158))
    assert evaluate("2*pi/(10*mm)") == pytest.approx(628.3185307)
    assert evaluate("(12 + 38)*inch") == pytest.approx(1.27)
    assert set(CONSTANTS) == {"pi", "deg", "rpm", "inch", "mm", "gcm2"}
    for bad in ("__import__('os')", "foo", "1/0", "2**1000", "[1]", "pi pi", "1 if 1 else 2"):
        with pytest.raises(ValueError):
            evaluate(bad)


def test_tool_in_modified_dh(tmp_path):
    doc = base_doc()
    doc["tool"] = {"xyz": [0.1, 0.2, 0.3], "rpy": [0.0, 0.0, "pi/2"]}
    robot = load_yaml_robot(write(tmp_path, doc))
    np.testing.assert_allclose(robot.tool_p, [0.1, 0.2, 0.3])
    np.testing.assert_allclose(robot.tool_R, dh.rot_z(np.pi / 2), atol=1e-15)


# --------------------------------------------------------------------------- drives


def test_drive_from_motor_and_gear(tmp_path):
    doc = base_doc()
    doc["joints"][0]["drive"] = {"motor": "maxon_re40_148877", "gear": "harmonic_csf17_100"}
    robot = load_yaml_robot(write(tmp_path, doc))
    d = robot.drives[0]
    m, g = load_motor("maxon_re40_148877"), load_gear("harmonic_csf17_100")
    assert d.J == pytest.approx(m.J + g.J, rel=1e-12)
    assert d.ratio == -100.0
    assert (d.R, d.L, d.k_m, d.k_w) == (m.R, m.L, m.k_m, m.k_w)
    assert d.M_f == m.M_f and d.k_v == m.k_v
    assert d.u_max == m.rated_voltage == 48
    assert d.rated_torque == m.rated_torque and d.max_speed == m.max_speed
    assert d.name == "maxon_re40_148877" and d.gear == "harmonic_csf17_100"


def test_drive_gear_chain_and_overrides(tmp_path):
    doc = base_doc()
    doc["joints"][1]["drive"] = {"motor": "maxon_re40_148877",
                                 "gear": ["maxon_gp42c_4_3", "ballscrew_d16_p10_l800"],
                                 "u_max": 30, "k_u": 2.5}
    doc["joints"][0]["drive"] = {"motor": "maxon_re25_118743", "ratio": 20, "J": "12*gcm2"}
    robot = load_yaml_robot(write(tmp_path, doc))
    d = robot.drives[1]
    m = load_motor("maxon_re40_148877")
    g1, g2 = load_gear("maxon_gp42c_4_3"), load_gear("ballscrew_d16_p10_l800")
    assert d.J == pytest.approx(m.J + g1.J + g2.J / 4.3**2, rel=1e-12)
    assert d.ratio == pytest.approx(4.3 * 2 * math.pi / 0.010, rel=1e-12)
    assert d.u_max == 30 and d.k_u == 2.5
    d0 = robot.drives[0]
    assert d0.ratio == 20 and d0.J == pytest.approx(12e-7)
    assert d0.k_m == load_motor("maxon_re25_118743").k_m


def test_explicit_drive_defaults_and_friction_pair(tmp_path):
    robot = load_yaml_robot(write(tmp_path, base_doc()))
    d = robot.drives[0]
    assert d.J == 1e-5 and d.ratio == 50
    assert d.M_f == (0.01, 0.02)  # negative-motion value given signed, stored as magnitude
    assert not d.has_electrics and d.k_u == 1.0 and math.isinf(d.u_max)
    assert robot.drives[1] is None


def test_motor_by_path_relative_to_robot_file(tmp_path):
    (tmp_path / "my_motor.yaml").write_text(
        (PARTS / "motors" / "maxon_re25_118743.yaml").read_text())
    doc = base_doc()
    doc["joints"][0]["drive"] = {"motor": "my_motor.yaml", "ratio": 10}
    robot = load_yaml_robot(write(tmp_path, doc))
    assert robot.drives[0].k_m == pytest.approx(23.4e-3)


# ------------------------------------------------------------- warnings / valid edge cases


def test_puma_inertias_are_noted_once_not_warned_at_every_load():
    """The PUMA 560's published link 1 and 3 tensors break the triangle inequality; the
    catalog file notes it, so loading is silent, and inertia_notes names both links."""
    with warnings.catch_warnings():
        warnings.simplefilter("error", ManipcadWarning)
        robot = load_yaml_robot(CATALOG / "robots" / "puma560.yaml")
    assert robot.mass[0] == 0 and robot.inertia[0, 2, 2] == pytest.approx(0.35)
    notes = inertia_notes(robot)
    assert [n.split(" ")[0] for n in notes] == ["joints[0].link.inertia", "joints[2].link.inertia"]
    assert all("triangle inequality" in n for n in notes)


def test_a_note_silences_only_its_own_tensor(tmp_path):
    doc = base_doc()
    doc["joints"][0]["link"]["inertia"] = {"ixx": 0.0, "iyy": 0.1, "izz": 0.0,
                                           "note": "published as is"}
    doc["joints"][1]["link"]["inertia"] = {"ixx": 0.0, "iyy": 0.1, "izz": 0.0}
    path = write(tmp_path, doc)
    with pytest.warns(InertiaWarning) as rec:
        robot = load_yaml_robot(path)
    assert ["joints[1].link.inertia" in str(w.message) for w in rec] == [True]
    assert len(inertia_notes(robot)) == 2


def test_triangle_inequality_warning_names_file_and_field(tmp_path):
    doc = base_doc()
    doc["joints"][1]["link"]["inertia"] = {"ixx": 0.0, "iyy": 0.1, "izz": 0.0}
    path = write(tmp_path, doc)
    with pytest.warns(ManipcadWarning) as rec:
        load_yaml_robot(path)
    msg = str(rec[0].message)
    assert str(path) in msg and "joints[1].link.inertia" in msg


def test_zero_mass_link_with_inertia_is_valid(tmp_path):
    doc = base_doc()
    doc["joints"][0]["link"] = {"mass": 0, "inertia": {"ixx": 0.2, "iyy": 0.2, "izz": 0.35}}
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # no warning either: this tensor is a rigid body's
        robot = load_yaml_robot(write(tmp_path, doc))
    assert robot.mass[0] == 0 and robot.inertia[0, 2, 2] == 0.35


# --------------------------------------------------------------------------- bad input


def test_yaml_syntax_error_names_line(tmp_path):
    err = expect_error(tmp_path, "name: arm\njoints:\n  - name: a\n    type: [revolute\n", "",
                       "YAML syntax error", "line")
    assert "line 4" in err.reason or "line 5" in err.reason


def test_yaml_tab_indentation_error(tmp_path):
    expect_error(tmp_path, "name: arm\njoints:\n\t- name: a\n", "", "YAML syntax error", "line")


def test_duplicate_yaml_key(tmp_path):
    expect_error(tmp_path, "name: a\nname: b\njoints: []\n", "", "duplicate key 'name'", "line 2")


def test_empty_file_and_non_mapping(tmp_path):
    expect_error(tmp_path, "", "", "expected a mapping")
    expect_error(tmp_path, "- 1\n- 2\n", "", "expected a mapping")


def test_missing_file(tmp_path):
    with pytest.raises(InputError, match="no such file"):
        load_yaml_robot(tmp_path / "nope.yaml")
    with pytest.raises(InputError, match="no such file"):
        load_robot(tmp_path / "nope.yaml")


@pytest.mark.parametrize("where, key, field", [
    ((), "nmae", "nmae"),
    (("joints", 0), "axis", "joints[0].axis"),
    (("joints", 0, "dh"), "alfa", "joints[0].dh.alfa"),
    (("joints", 1, "link"), "inertial", "joints[1].link.inertial"),
    (("joints", 0, "link", "inertia"), "izx", "joints[0].link.inertia.izx"),
    (("joints", 0, "drive"), "gain", "joints[0].drive.gain"),
])
def test_unknown_keys(tmp_path, where, key, field):
    doc = base_doc()
    node = doc
    for k in where:
        node = node[k]
    node[key] = 1
    err = expect_error(tmp_path, doc, field, "unknown key", repr(key))
    assert "allowed keys" in err.reason


@pytest.mark.parametrize("path, value, field, words", [
    (("joints", 0, "link", "mass"), "heavy", "joints[0].link.mass",
     ["expected a number, got 'heavy'"]),
    (("joints", 0, "link", "mass"), [1, 2], "joints[0].link.mass", ["expected a number"]),
    (("joints", 0, "link", "com"), [1, 2], "joints[0].link.com", ["list of 3 numbers"]),
    (("joints", 0, "link", "com"), [1, 2, "x"], "joints[0].link.com", ["item 2"]),
    (("joints", 1, "dh", "alpha"), True, "joints[1].dh.alpha", ["expected a number"]),
    (("joints", 1, "dh"), [1, 2, 3, 4], "joints[1].dh", ["expected a mapping"]),
    (("joints",), {"a": 1}, "joints", ["expected a list"]),
    (("name",), 5, "name", ["expected text"]),
    (("gravity",), [0, -9.81], "gravity", ["list of 3 numbers"]),
    (("convention",), "craig", "convention", ["unknown value 'craig'", "modified"]),
    (("joints", 0, "limits"), [1.0], "joints[0].limits", ["[lower, upper]"]),
    (("joints", 0, "drive", "M_f"), [1, 2, 3], "joints[0].drive.M_f", ["[positive, negative]"]),
    (("joints", 0, "drive", "gear"), 5, "joints[0].drive.gear", ["catalog name"]),
    (("joints", 1, "dh", "theta"), "pi/0", "joints[1].dh.theta", ["division by zero"]),
    (("joints", 1, "dh", "theta"), "__import__('os')", "joints[1].dh.theta",
     ["expected a number", "only numbers"]),
    (("joints", 1, "dh", "theta"), "tau", "joints[1].dh.theta", ["unknown name 'tau'"]),
])
def test_wrong_types(tmp_path, path, value, field, words):
    doc = base_doc()
    node = doc
    for k in path[:-1]:
        node = node[k]
    node[path[-1]] = value
    expect_error(tmp_path, doc, field, *words)


@pytest.mark.parametrize("path, field", [
    (("name",), "name"),
    (("joints",), "joints"),
    (("joints", 0, "type"), "joints[0].type"),
    (("joints", 0, "name"), "joints[0].name"),
    (("joints", 1, "link"), "joints[1].link"),
    (("joints", 1, "link", "mass"), "joints[1].link.mass"),
])
def test_missing_fields(tmp_path, path, field):
    doc = base_doc()
    node = doc
    for k in path[:-1]:
        node = node[k]
    del node[path[-1]]
    expect_error(tmp_path, doc, field, "required field is missing")


def test_reason_names_the_joint_and_counts_more_problems(tmp_path):
    doc = base_doc()
    doc["joints"][1]["link"]["mass"] = "x"
    doc["joints"][1]["dh"]["alfa"] = 1
    err = expect_error(tmp_path, doc, "joints[1].dh.alfa", "(joint 'j2')", "1 more problem")
    assert err.reason.count("more") == 1


def test_negative_mass(tmp_path):
    doc = base_doc()
    doc["joints"][1]["link"]["mass"] = -1.5
    expect_error(tmp_path, doc, "joints[1].link.mass", "mass must be >= 0 kg", "-1.5")


def test_inertia_not_positive_semidefinite(tmp_path):
    doc = base_doc()
    doc["joints"][0]["link"]["inertia"] = {"ixx": 1, "iyy": 1, "izz": 1, "ixy": 2}
    expect_error(tmp_path, doc, "joints[0].link.inertia", "not positive semi-definite")
    doc["joints"][0]["link"]["inertia"] = {"ixx": -0.1, "iyy": 1, "izz": 1}
    expect_error(tmp_path, doc, "joints[0].link.inertia", "not positive semi-definite")


def test_unknown_joint_type(tmp_path):
    doc = base_doc()
    doc["joints"][1]["type"] = "helical"
    expect_error(tmp_path, doc, "joints[1].type", "unknown value 'helical'", "revolute",
                 "prismatic")


def test_unknown_parent(tmp_path):
    doc = base_doc()
    doc["joints"][1]["parent"] = "j9"
    expect_error(tmp_path, doc, "joints[1].parent", "unknown parent 'j9'", "'base'", "'j1'")


def test_parent_after_child(tmp_path):
    doc = base_doc()
    doc["joints"][0]["parent"] = "j2"
    expect_error(tmp_path, doc, "joints[0].parent", "must be listed before", "parents first")
    doc["joints"][0]["parent"] = "j1"
    expect_error(tmp_path, doc, "joints[0].parent", "must be listed before")


def test_duplicate_and_reserved_joint_names(tmp_path):
    doc = base_doc()
    doc["joints"][1]["name"] = "j1"
    expect_error(tmp_path, doc, "joints[1].name", "duplicate joint name 'j1'")
    doc["joints"][1]["name"] = "base"
    expect_error(tmp_path, doc, "joints[1].name", "reserved")


def test_unknown_motor_and_gear(tmp_path):
    doc = base_doc()
    doc["joints"][0]["drive"] = {"motor": "maxon_re99"}
    err = expect_error(tmp_path, doc, "joints[0].drive.motor", "unknown motor 'maxon_re99'",
                       "maxon_re40_148877")
    assert err.reason.count("unknown motor") == 1
    doc["joints"][0]["drive"] = {"motor": "maxon_re40_148877", "gear": "gp_nope"}
    expect_error(tmp_path, doc, "joints[0].drive.gear", "unknown gear 'gp_nope'",
                 "harmonic_csf20_100")
    doc["joints"][0]["drive"] = {"motor": "maxon_re40_148877",
                                 "gear": ["maxon_gp42c_4_3", "gp_nope"]}
    expect_error(tmp_path, doc, "joints[0].drive.gear[1]", "unknown gear 'gp_nope'")


def test_explicit_drive_needs_J_and_ratio(tmp_path):
    doc = base_doc()
    doc["joints"][0]["drive"] = {"ratio": 10}
    expect_error(tmp_path, doc, "joints[0].drive.J", "required field is missing", "motor")
    doc["joints"][0]["drive"] = {"J": 1e-5}
    expect_error(tmp_path, doc, "joints[0].drive.ratio", "required field is missing")


def test_nonphysical_drive_values(tmp_path):
    doc = base_doc()
    doc["joints"][0]["drive"]["R"] = -1
    expect_error(tmp_path, doc, "joints[0].drive.R", "must be >= 0")
    doc = base_doc()
    doc["joints"][0]["drive"]["ratio"] = 0
    expect_error(tmp_path, doc, "joints[0].drive.ratio", "non-zero")


def test_limits_in_wrong_order(tmp_path):
    doc = base_doc()
    doc["joints"][0]["limits"] = [1.0, -1.0]
    expect_error(tmp_path, doc, "joints[0].limits", "lower limit 1.0 is above upper limit -1.0")


def test_bad_motor_file_is_named(tmp_path):
    (tmp_path / "bad_motor.yaml").write_text("J: 1e-5\nR: 1\nL: 1e-3\nk_m: 0.05\n")
    doc = base_doc()
    doc["joints"][0]["drive"] = {"motor": "bad_motor.yaml", "ratio": 10}
    path = write(tmp_path, doc)
    with pytest.raises(InputError) as info:
        load_yaml_robot(path)
    assert info.value.source.endswith("bad_motor.yaml")
    assert info.value.field in ("source", "k_w")
    assert "required field is missing" in str(info.value)


def test_model_error_becomes_input_error(tmp_path, monkeypatch):
    def boom(*args, **kwargs):
        raise ModelError("something inconsistent")

    monkeypatch.setattr(Robot, "from_arrays", boom)
    path = write(tmp_path, base_doc())
    with pytest.raises(InputError) as info:
        load_yaml_robot(path)
    assert str(path) in str(info.value) and "something inconsistent" in str(info.value)


def test_input_error_is_never_mutating_the_document(tmp_path):
    """Loading twice gives equal robots (no hidden state from the caches)."""
    doc = base_doc()
    path = write(tmp_path, copy.deepcopy(doc))
    a, b = load_yaml_robot(path), load_yaml_robot(path)
    np.testing.assert_array_equal(a.table, b.table)


def test_static_friction_read_saved_and_checked(tmp_path):
    """A drive's M_s (static friction) is read, written back by save_robot, packed for the
    simulator (joint side |i_r|·M_s); absent it equals M_f and the robot's hash is the one
    of a drive without the field; below M_f it is refused naming the field."""
    from manipcad.model.hashing import robot_hash
    from manipcad.model.tree_file import save_robot
    from manipcad.sim.closed_loop import _events, packed_drives
    from manipcad.sim.events import FS_NEG, FS_POS

    plain = load_yaml_robot(write(tmp_path, base_doc()))
    assert plain.drives[0].static_friction == plain.drives[0].M_f == (0.01, 0.02)
    doc = base_doc()
    doc["joints"][0]["drive"].update(M_s=[0.015, 0.02], R=1.0, L=1e-3, k_m=0.1, k_w=0.1)
    robot = load_yaml_robot(write(tmp_path, doc, "ms.yaml"))
    assert robot.drives[0].M_s == (0.015, 0.02)
    again = manipcad.load_robot(save_robot(robot, tmp_path / "saved.yaml"))
    assert again.drives[0].M_s == (0.015, 0.02)
    assert robot_hash(again) == robot_hash(robot)
    equal = base_doc()
    equal["joints"][0]["drive"]["M_s"] = [0.01, 0.02]
    assert robot_hash(load_yaml_robot(write(tmp_path, equal, "eq.yaml"))) == robot_hash(plain)
    doc["joints"][0]["drive"]["M_s"] = [0.01, 0.02]
    assert robot_hash(robot) != robot_hash(load_yaml_robot(write(tmp_path, doc, "ms2.yaml")))
    dtable, _, rtable = packed_drives(robot, True, None, 3)
    fric = _events(robot, dtable, rtable, True, np.zeros(2), 4).fric
    assert fric[0, FS_POS] == pytest.approx(50 * 0.015) and fric[0, FS_NEG] == pytest.approx(1.0)
    bad = base_doc()
    bad["joints"][0]["drive"]["M_s"] = 0.015
    expect_error(tmp_path, bad, "joints[0].drive.M_s", ">= M_f")
