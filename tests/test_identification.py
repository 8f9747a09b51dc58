"""Payload identification (paper 4.1) against torques made by Pinocchio.

The measured torques come from an independent implementation: a Pinocchio
model of the robot with the payload appended to the last joint as its own
body, ``pin.rnea`` (with the rotor inertias as Pinocchio's armature), plus the
drives' friction written out here from the drive parameters. manipcad only sees
the unloaded robot and those torques. Robots: the catalog PUMA 560 and
Stanford arm (exported with ``to_pinocchio``) and the UR5 of example-robot-data
(Pinocchio's own URDF parser, our URDF loader). Payload masses 0.7 and 3 kg at
three positions; motion (cosine laws) and short stops; noise-free and with
Gaussian torque noise of 0.5 % of each drive's torque RMS.
"""

from __future__ import annotations

import json
import re
import warnings
from importlib.metadata import PackageNotFoundError, distribution
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from typer.testing import CliRunner
from urdf_pinref import StateMap, body_rotations

import manipcad
from manipcad.cli import app
from manipcad.dynamics.identification import (
    identify_payload,
    load_torque_data,
    payload_regressor,
)
from manipcad.errors import InputError, ManipcadWarning
from manipcad.model.robot import Robot
from manipcad.model.to_pinocchio import to_pinocchio
from manipcad.trajectories import cosine

ROOT = Path(__file__).resolve().parents[1]
NOISE = 0.005  # of each drive's torque RMS
COMS = {"origin": (0.0, 0.0, 0.0), "offset": (0.05, -0.03, 0.12), "side": (-0.1, 0.08, 0.02)}
MASSES = (0.7, 3.0)


# ------------------------------------------------------------------ robots and references


def through_lossy_gears(loaded: Robot, q, qd, qdd) -> np.ndarray:
    """The drives' torques at the joints (N·m or N) of ``loaded`` along (q, q̇, q̈): the rigid
    load P through each gear of efficiency η (f = 1/η when P·q̇ >= 0, motoring; η when the
    load drives the motor back), plus the drive terms before the gear (rotor inertia,
    viscous and dry friction)."""
    P = manipcad.inverse_dynamics(loaded, q, qd, qdd, drives=False)
    drive = manipcad.inverse_dynamics(loaded, q, qd, qdd) - P
    eta = np.array([1.0 if d is None or not np.isfinite(d.efficiency) else d.efficiency
                    for d in loaded.drives])
    return drive + np.where(P * qd >= 0, 1 / eta, eta) * P


def ur5_path() -> Path:
    try:  # example-robot-data 6 ships data only, under the cmeel prefix
        d = Path(distribution("example-robot-data").locate_file(
            "cmeel.prefix/share/example-robot-data/robots"))
    except PackageNotFoundError:
        d = None
    if d is None or not d.is_dir():
        try:  # older releases have a Python module with the path
            from example_robot_data.path import EXAMPLE_ROBOT_DATA_MODEL_DIR  # type: ignore

            d = Path(EXAMPLE_ROBOT_DATA_MODEL_DIR)
        except ImportError:
            pytest.fail("example-robot-data (a test dependency) is not installed")
    return d / "ur_description" / "urdf" / "ur5_robot.urdf"


class PinRef:
    """Pinocchio torques of a robot carrying a point mass on its last link."""

    def __init__(self, name: str):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ManipcadWarning)
            if name == "ur5":
                path = ur5_path()
                self.robot = manipcad.load_robot(path)
                self.model = pin.buildModelFromUrdf(str(path))
                self.offset = np.zeros(self.robot.n)  # the URDF's own joint zero
            else:
                self.robot = manipcad.load_robot(name)
                self.model, _ = to_pinocchio(self.robot, armature=True)
                self.offset = self.robot.offset  # exported models take q + offset
        self.smap = StateMap(self.robot, self.model)
        last = self.smap.jid[-1]
        # our last body frame and Pinocchio's joint frame share the origin and differ
        # by a fixed rotation when the URDF axis is not z (found from the kinematics)
        q0 = np.zeros(self.robot.n)
        data = self.model.createData()
        pin.forwardKinematics(self.model, data, self.smap.q(q0 + self.offset))
        self.R_rel = data.oMi[last].rotation.T @ body_rotations(self.robot, q0)[-1]
        self.last = last

    def torques(self, mass: float, com, q, qd, qdd) -> np.ndarray:
        model = self.model.copy()
        c = self.R_rel @ np.asarray(com, float)
        model.appendBodyToJoint(self.last, pin.Inertia(mass, c, np.zeros((3, 3))),
                                pin.SE3.Identity())
        data = model.createData()
        tau = np.array([
            self.smap.back(pin.rnea(model, data, self.smap.q(q[k] + self.offset),
                                    self.smap.v(qd[k]),
                                    self.smap.v(qdd[k])))
            for k in range(q.shape[0])])
        for i, d in enumerate(self.robot.drives):  # drive friction, joint-referred
            if d is not None:
                v = qd[:, i]
                dry = np.where(v > 0, d.M_f[0], np.where(v < 0, -d.M_f[1], 0.0))
                tau[:, i] += d.k_v * d.ratio**2 * v + abs(d.ratio) * dry
        return tau


@pytest.fixture(scope="module", params=["puma560", "stanford", "ur5"])
def ref(request) -> PinRef:
    return PinRef(request.param)


def motion(robot: Robot, N: int, seed: int = 0):
    """Cosine laws on all joints, N samples over 3 s (rad, m; rad/s, m/s; ...)."""
    rng = np.random.default_rng(seed)
    amp = np.where(np.array(robot.joint_types) == "revolute", rng.uniform(0.4, 1.0, robot.n),
                   rng.uniform(0.05, 0.15, robot.n)) * rng.choice([-1, 1], robot.n)
    traj = cosine(amp, rng.uniform(1.5, 5.0, robot.n), duration=3.0)
    return traj.sample(np.linspace(0.0, 3.0, N))


def stops(robot: Robot, N: int, seed: int = 1):
    rng = np.random.default_rng(seed)
    q = rng.uniform(-1.5, 1.5, (N, robot.n))
    prism = np.array(robot.joint_types) == "prismatic"
    q[:, prism] = rng.uniform(0.0, 0.3, (N, int(prism.sum())))
    z = np.zeros_like(q)
    return q, z, z


def noisy(tau: np.ndarray, seed: int) -> np.ndarray:
    rng = np.random.default_rng(seed)
    return tau + rng.normal(size=tau.shape) * NOISE * np.sqrt(np.mean(tau**2, axis=0))


def test_reference_matches_our_loaded_model(ref):
    """The references agree with our own loaded robot (so both sides model the same arm)."""
    q, qd, qdd = motion(ref.robot, 20)
    com = COMS["offset"]
    tau = ref.torques(1.5, com, q, qd, qdd)
    ours = manipcad.inverse_dynamics(ref.robot.with_payload(1.5, com), q, qd, qdd)
    assert np.abs(tau - ours).max() <= 1e-9 * max(1.0, np.abs(tau).max())


# ------------------------------------------------------------------ recovery


@pytest.mark.parametrize("mass", MASSES)
@pytest.mark.parametrize("where", sorted(COMS))
def test_dynamic_noise_free_within_1_percent(ref, mass, where):
    q, qd, qdd = motion(ref.robot, 300)
    tau = ref.torques(mass, COMS[where], q, qd, qdd)
    est = identify_payload(ref.robot, q, qd, qdd, tau, com=COMS[where])
    assert est.method == "motion"
    assert abs(est.mass - mass) <= 0.01 * mass
    assert abs(est.mass - mass) <= 1e-8 * mass  # in fact to round-off
    assert est.residual < 1e-8


@pytest.mark.parametrize("mass", MASSES)
@pytest.mark.parametrize("where", sorted(COMS))
def test_dynamic_noisy_within_2_percent(ref, mass, where):
    q, qd, qdd = motion(ref.robot, 2000, seed=2)
    tau = noisy(ref.torques(mass, COMS[where], q, qd, qdd), seed=3)
    est = identify_payload(ref.robot, q, qd, qdd, tau, com=COMS[where])
    assert abs(est.mass - mass) <= 0.02 * mass
    assert abs(est.mass - mass) <= 5 * est.std  # the standard deviation is honest
    assert est.weighting == "noise"


@pytest.mark.parametrize("mass", MASSES)
@pytest.mark.parametrize("where", sorted(COMS))
def test_static_at_stops(ref, mass, where):
    q, qd, qdd = stops(ref.robot, 60)
    tau = ref.torques(mass, COMS[where], q, qd, qdd)
    est = identify_payload(ref.robot, q, None, None, tau, com=COMS[where])
    assert est.method == "stops"
    assert abs(est.mass - mass) <= 1e-8 * mass
    # zero velocity and acceleration given as arrays: the same, static method
    assert identify_payload(ref.robot, q, qd, qdd, tau, com=COMS[where]).method == "stops"
    est = identify_payload(ref.robot, q, None, None, noisy(tau, seed=4), com=COMS[where])
    assert abs(est.mass - mass) <= 0.02 * mass
    assert abs(est.mass - mass) <= 5 * est.std


def test_static_leaves_out_joints_gravity_does_not_load():
    """At rest the PUMA's vertical waist axis and, for a payload on the flange axis, the
    wrist see no payload torque: left out by default, an error when named."""
    r = PinRef("puma560")
    q, _, _ = stops(r.robot, 30)
    tau = r.torques(2.0, (0, 0, 0.1), q, 0 * q, 0 * q)
    est = identify_payload(r.robot, q, None, None, tau, com=(0, 0, 0.1))
    assert "waist" not in est.joint_names and "flange" not in est.joint_names
    assert {"shoulder", "elbow"} <= set(est.joint_names)
    with pytest.raises(InputError, match=r"joints\[1\].*no excitation.*'waist'"):
        identify_payload(r.robot, q, None, None, tau, com=(0, 0, 0.1), joints=["elbow", 0])


def test_one_drive_and_named_drives():
    """The paper's 'from one drive only', and drives chosen by name or index."""
    r = PinRef("puma560")
    q, qd, qdd = motion(r.robot, 400)
    tau = noisy(r.torques(1.2, COMS["offset"], q, qd, qdd), seed=5)
    one = identify_payload(r.robot, q, qd, qdd, tau, com=COMS["offset"], joints="elbow")
    assert one.joints == (2,) and one.weighting == "equal"
    assert abs(one.mass - 1.2) <= 0.02 * 1.2
    two = identify_payload(r.robot, q, qd, qdd, tau, com=COMS["offset"], joints=[1, "elbow"])
    assert two.joint_names == ("shoulder", "elbow")
    full = identify_payload(r.robot, q, qd, qdd, tau, com=COMS["offset"])
    # per-drive estimates are the single-drive fits
    k = full.joints.index(2)
    assert full.per_joint_mass[k] == pytest.approx(one.mass, rel=1e-12)
    assert full.per_joint_std[k] == pytest.approx(one.std, rel=1e-9)
    assert full.std < one.std  # several drives: more exact


def test_reported_std_matches_the_spread():
    """Over 300 noise draws the estimates spread as the reported std says (within 15 %)."""
    r = PinRef("puma560")
    q, qd, qdd = motion(r.robot, 200)
    clean = r.torques(2.0, COMS["side"], q, qd, qdd)
    est = [identify_payload(r.robot, q, qd, qdd, noisy(clean, seed=100 + s), com=COMS["side"])
           for s in range(300)]
    masses = np.array([e.mass for e in est])
    assert abs(masses.mean() - 2.0) < 3 * masses.std() / np.sqrt(len(masses))
    assert np.mean([e.std for e in est]) == pytest.approx(masses.std(), rel=0.15)


def test_regressor_is_the_payload_difference():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        for name in manipcad.catalog_names():
            robot = manipcad.load_robot(name)
            q, qd, qdd = motion(robot, 50)
            com = (0.02, 0.03, -0.04)
            g = payload_regressor(robot, q, qd, qdd, com=com)
            diff = (manipcad.inverse_dynamics(robot.with_payload(1.0, com), q, qd, qdd)
                    - manipcad.inverse_dynamics(robot, q, qd, qdd))
            assert np.abs(g - diff).max() <= 1e-10 * max(1.0, np.abs(diff).max())
            # affine in the mass: 2.7 kg adds exactly 2.7 g (of the load the gear passes)
            tau = through_lossy_gears(robot.with_payload(2.7, com), q, qd, qdd)
            assert identify_payload(robot, q, qd, qdd, tau, com=com).mass == pytest.approx(
                2.7, rel=1e-10)


def test_drives_false_for_rigid_body_torques():
    r = PinRef("puma560")
    q, qd, qdd = motion(r.robot, 100)
    rigid = manipcad.inverse_dynamics(r.robot.with_payload(0.9), q, qd, qdd, drives=False)
    assert identify_payload(r.robot, q, qd, qdd, rigid, drives=False).mass == pytest.approx(0.9)
    with pytest.warns(ManipcadWarning, match="disagree"):  # friction not in tau: flagged
        wrong = identify_payload(r.robot, q, qd, qdd, rigid, drives=True)
    assert abs(wrong.mass - 0.9) > 0.05 and wrong.residual > 1.0 and wrong.flagged


# ------------------------------------------------------------------ bad input


@pytest.fixture(scope="module")
def puma():
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return manipcad.load_robot("puma560")


def test_shapes_and_values(puma):
    q, qd, qdd = motion(puma, 10)
    tau = manipcad.inverse_dynamics(puma.with_payload(1.0), q, qd, qdd)
    with pytest.raises(InputError, match=r"tau: must have shape \(n,\) or \(N, n\) with n = 6"):
        identify_payload(puma, q, qd, qdd, tau[:, :5])
    with pytest.raises(InputError, match="qd: has 9 samples, q has 10"):
        identify_payload(puma, q, qd[:9], qdd, tau)
    bad = tau.copy()
    bad[3, 2] = np.nan
    with pytest.raises(InputError, match=r"tau\[3, 2\]: is not a finite number"):
        identify_payload(puma, q, qd, qdd, bad)
    with pytest.raises(InputError, match="com: expected three finite numbers"):
        identify_payload(puma, q, qd, qdd, tau, com=(0, 0))
    with pytest.raises(InputError, match=r"joints\[1\]: .*named twice"):
        identify_payload(puma, q, qd, qdd, tau, joints=["elbow", 2])
    with pytest.raises(InputError, match=r"joints\[0\]: no joint named 'knee'"):
        identify_payload(puma, q, qd, qdd, tau, joints=["knee"])
    with pytest.raises(InputError, match="joints: empty list"):
        identify_payload(puma, q, qd, qdd, tau, joints=[])
    # one state works too (one equation per drive; a moving one: at q̇ = 0 the sign of
    # the dry friction is unknown and the motion method leaves the drive out)
    assert np.all(np.abs(qd[5]) > 0.05)
    est = identify_payload(puma, q[5], qd[5], qdd[5], tau[5])
    assert est.samples == 1 and est.mass == pytest.approx(1.0)


def test_no_excitation_at_all():
    """A turntable (vertical axis) at rest: gravity exerts no torque on it."""
    table = Robot.from_arrays("turntable", ["revolute"], [-1], np.eye(3)[None], np.zeros((1, 3)),
                              [5.0], [[0.1, 0.0, 0.05]], np.eye(3)[None] * 0.1)
    q = np.linspace(-1, 1, 10)[:, None]
    tau = np.zeros_like(q)
    with pytest.raises(InputError, match="no excitation.*exerts no torque on any drive"):
        identify_payload(table, q, None, None, tau, com=(0.3, 0, 0))
    # in motion it is excited: accelerations and a payload off the axis
    qdd = np.ones_like(q)
    tau = manipcad.inverse_dynamics(table.with_payload(0.4, (0.3, 0, 0)), q, 0 * q, qdd)
    assert identify_payload(table, q, 0 * q, qdd, tau, com=(0.3, 0, 0)).mass == pytest.approx(0.4)


def test_negative_mass_is_reported_not_clipped(puma):
    q, qd, qdd = motion(puma, 50)
    tau = manipcad.inverse_dynamics(puma, q, qd, qdd) - 0.5 * payload_regressor(puma, q, qd, qdd)
    with pytest.warns(ManipcadWarning, match="negative: -0.5"):
        est = identify_payload(puma, q, qd, qdd, tau)
    assert est.mass == pytest.approx(-0.5)


# ------------------------------------------------------------------ CSV files and CLI

runner = CliRunner()


def run(*args: str):
    return runner.invoke(app, ["identify", *args], env={"COLUMNS": "200"})


def write_csv(path: Path, robot: Robot, q, tau, qd=None, qdd=None, names=False) -> Path:
    n = robot.n

    def col(kind, i):
        return f"{kind}_{robot.joint_names[i]}" if names else f"{kind}{i + 1}"

    cols, arrays = [], []
    for kind, a in (("q", q), ("qd", qd), ("qdd", qdd), ("tau", tau)):
        if a is not None:
            cols += [col(kind, i) for i in range(n)]
            arrays.append(a)
    data = np.column_stack(arrays)
    lines = ["# test data", ",".join(cols)]
    lines += [",".join(repr(float(x)) for x in row) for row in data]
    path.write_text("\n".join(lines) + "\n")
    return path


def test_csv_names_and_static_columns(tmp_path, puma):
    q, _, _ = stops(puma, 25)
    tau = manipcad.inverse_dynamics(puma.with_payload(1.7, (0, 0, 0.05)), q, 0 * q, 0 * q)
    path = write_csv(tmp_path / "stops.csv", puma, q, tau, names=True)
    d = load_torque_data(path, puma)
    assert d.qd is None and d.qdd is None and d.q.shape == (25, 6)
    res = run("puma560", "--data", str(path), "--com", "0,0,0.05", "--json")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    assert doc["method"] == "stops" and doc["mass_kg"] == pytest.approx(1.7)
    res = run("puma560", "--data", str(path), "--com", "0,0,0.05", "--joints", "2,elbow")
    assert res.exit_code == 0, res.output
    assert "static" in res.output and "1.7" in res.output


def test_cli_example_file():
    """The shipped example (Pinocchio torques, 0.5 % noise): 2.5 kg within 2 %."""
    res = run("puma560", "--data", str(ROOT / "examples" / "identify_puma.csv"),
              "--com", "0,0,0.08", "--json")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    assert doc["method"] == "motion"
    assert abs(doc["mass_kg"] - 2.5) <= 0.02 * 2.5
    res = run("puma560", "--data", str(ROOT / "examples" / "identify_puma.csv"),
              "--com", "0,0,0.08")
    assert res.exit_code == 0 and "payload mass m_r = 2.5" in res.output


HEADER = ",".join([f"{k}{i}" for k in ("q", "qd", "qdd", "tau") for i in range(1, 7)])
ROW = ",".join(["0.1"] * 24)
BAD_QD2 = ",".join(["0.1"] * 7 + ["abc"] + ["0.1"] * 16)  # the 8th column is qd2


@pytest.mark.parametrize("text, message", [
    ("", "empty file"),
    ("# only a comment\n", "empty file"),
    (HEADER + "\n", "no data lines after the header"),
    (HEADER + "\n" + ROW + "\n" + BAD_QD2 + "\n",
     "line 3, column qd2: 'abc' is not a number"),
    (HEADER + "\n" + ROW + ",0.1\n", "line 2: 25 fields, the header has 24"),
    (HEADER + "\n" + ROW.replace("0.1", "nan", 1) + "\n",
     "line 2, column q1: 'nan' is not a finite"),
    (HEADER.replace("tau3", "torque3") + "\n" + ROW + "\n",
     "line 1, column 21: unknown column 'torque3'"),
    (HEADER.replace("qd4", "q4") + "\n" + ROW + "\n", "column 'q4' repeats column 'q4'"),
    (HEADER.replace(",tau6", "") + "\n" + ROW[:-4] + "\n", "missing column\\(s\\) tau6"),
    (HEADER.replace(",qd6", "") + "\n" + ROW[:-4] + "\n", "missing column\\(s\\) qd6"),
])
def test_bad_csv_exits_2_naming_file_line_column(tmp_path, text, message):
    path = tmp_path / "bad.csv"
    path.write_text(text)
    res = run("puma560", "--data", str(path))
    assert res.exit_code == 2, res.output
    assert str(path) in res.output
    assert re.search(message, res.output), res.output
    assert "Traceback" not in res.output


def test_cli_bad_arguments(tmp_path, puma):
    q, qd, qdd = motion(puma, 10)
    tau = manipcad.inverse_dynamics(puma, q, qd, qdd)
    path = write_csv(tmp_path / "ok.csv", puma, q, tau, qd, qdd)
    for args, message in [
        (["puma560", "--data", str(tmp_path / "none.csv")], "none.csv: no such file"),
        (["nosuchrobot", "--data", str(path)], "not a file and not a catalog robot"),
        (["puma560", "--data", str(path), "--com", "0,0"], "--com: expected three numbers"),
        (["puma560", "--data", str(path), "--joints", "knee"], "'knee' is neither a joint"),
        (["puma560", "--data", str(path), "--joints", "7"], "neither a joint name"),
        (["puma560", "--data", str(path), "--link", "2,3"], "--link: name one link"),
        (["puma560", "--data", str(path), "--link", "hand"], "--link: no link named 'hand'"),
    ]:
        res = run(*args)
        assert res.exit_code == 2, (args, res.output)
        assert message in res.output, res.output
        assert "Traceback" not in res.output


# ------------------------------------------------------------------ gear losses


def test_lossy_gears_at_stops_and_in_motion_closed_form():
    """The Fig. 2 arm's gears lose power (η 0.75 / 0.81 / 0.95). The drive's torque at the
    joint, written out here: moving, τ = f·P + J·i_r²·q̈ + k_v·i_r²·q̇ + F·sign(q̇) with the
    rigid load P and f = 1/η when P·q̇ >= 0 (motoring), η otherwise (braking); at rest after
    an approach from direction d, the torque it came to rest with: τ = f_d·P + d·F (the
    lift: P/η + F after going up, η·P − F after coming down). Both methods recover the mass
    exactly, and so does every drive alone; a model without the losses is far off at stops
    (the midpoint of the lift's two sides is (1/η + η)/2·P, not P)."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        arm = manipcad.load_robot("cylindrical")
    from manipcad.model.robot import COL_FCP
    from manipcad.trajectories import waypoints

    eta = np.array([d.efficiency for d in arm.drives])
    assert np.all(eta < 1)
    lift = [0.30, 0.45, 0.35, 0.50, 0.32, 0.48, 0.38, 0.52, 0.33, 0.47, 0.40]
    rng = np.random.default_rng(3)
    pts = np.column_stack([rng.uniform(-1, 1, len(lift)), lift,
                           rng.uniform(0.1, 0.4, len(lift))])
    traj = waypoints(pts, move_time=0.5, dwell=0.4)
    t = np.arange(0.0, traj.duration, 2e-3)
    q, qd, qdd = traj.sample(t)
    com = (0.0, 0.0, 0.05)
    P = manipcad.inverse_dynamics(arm.with_payload(1.0, com), q, qd, qdd, drives=False)
    F = np.asarray(arm.table)[:, COL_FCP]  # symmetric dry friction here, joint side, N·m or N
    tau = through_lossy_gears(arm.with_payload(1.0, com), q, qd, qdd)
    # at rest: the torque the drive came to rest with, after its last motion's direction
    moving = np.abs(qd) > 1e-9
    last = np.zeros_like(qd)
    for k in range(1, len(t)):
        last[k] = np.where(moving[k], np.sign(qd[k]), last[k - 1])
    f_d = np.where(P * last >= 0, 1 / eta, eta)
    tau = np.where(moving, tau, f_d * P + last * F)

    for method in ("stops", "motion"):
        kw = dict(method=method, com=com, t=t)
        est = identify_payload(arm, q, qd, None if method == "stops" else qdd, tau, **kw)
        assert est.mass == pytest.approx(1.0, rel=1e-9), method
        used = np.isfinite(est.per_joint_mass)
        np.testing.assert_allclose(est.per_joint_mass[used], 1.0, rtol=1e-9)
        if method == "stops":
            assert est.joint_names == ("lift",) and len(est.stops) == len(lift) - 1
            assert est.held_friction[0] == pytest.approx({1: F[1], -1: -F[1]}, rel=1e-9)
            model = identify_payload(arm, q, qd, None, tau, friction="model", **kw)
            assert model.mass == pytest.approx(1.0, rel=1e-9)
    # the same data read with lossless gears: the lift's two sides do not average to P
    lossless = arm.replace(drives=tuple(d.replace(efficiency=1.0) for d in arm.drives))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        wrong = identify_payload(lossless, q, qd, None, tau, method="stops", com=com, t=t)
    assert wrong.mass > 1.2
