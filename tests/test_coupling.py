"""Coupling analysis (paper section 2) and the real-time moment components (paper 4.1)."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pinocchio as pin
import pytest
from scipy.spatial.transform import Rotation
from typer.testing import CliRunner

import manipcad
from manipcad.analysis import coupling_analysis, moment_components
from manipcad.analysis.realtime import components_one, scratch
from manipcad.cli import app
from manipcad.errors import InputError, ManipcadWarning
from manipcad.model.robot import Robot
from manipcad.model.to_pinocchio import to_pinocchio
from manipcad.trajectories import cosine, quintic

ROOT = Path(__file__).resolve().parents[1]
FIG3 = ROOT / "examples" / "fig3_laws.yaml"
G = 9.81


def load(name: str) -> Robot:
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        return manipcad.load_robot(name)


def rot(axis: str, deg: float) -> np.ndarray:
    return Rotation.from_euler(axis, deg, degrees=True).as_matrix()


def chain(name, types, world_R, masses, coms, inertia=0.01) -> Robot:
    """A chain whose joint frames have the given world orientations (all origins at 0)."""
    n = len(types)
    rel = [world_R[0]] + [world_R[i - 1].T @ world_R[i] for i in range(1, n)]
    return Robot.from_arrays(name, types, list(range(-1, n - 1)), np.array(rel),
                             np.zeros((n, 3)), masses, np.array(coms, float),
                             np.array([np.eye(3) * inertia] * n))


# ------------------------------------------------------------------ the paper's Fig. 2/3 case


@pytest.fixture(scope="module")
def fig3():
    arm = load("cylindrical")
    return arm, coupling_analysis(arm, FIG3)


def test_fig3_turning_joint_strongly_coupled(fig3):
    """Laws (2) on the cylindrical arm: the turning drive q1 sees its inertia change
    by more than half with the reach q3 and a Coriolis torque of the order of its own
    inertial one: the general form of P_1, as the paper's Fig. 2/3 study assumes.
    (The arm's figures: 0.47-0.77 kg·m², Coriolis/inertial peaks 4.4/4.7 N·m, for
    the 0.4 kg carbon reach arm of the catalog file.)"""
    arm, rep = fig3
    turn = rep["turn"]
    assert turn.classification == "full" and rep.overall == "full"
    assert turn.H_ratio > 1.5
    # H_11 ranges over the reach's stroke: min at q3 = 0, max at q3 = 0.5 m (Pinocchio CRBA)
    model, order = to_pinocchio(arm)
    data = model.createData()
    H11 = []
    for q3 in (0.0, 0.5):
        q = np.array([0.0, 0.0, q3])
        H11.append(pin.crba(model, data, (q + arm.offset)[order])[0, 0])
    assert turn.H_min == pytest.approx(H11[0], rel=1e-9)
    assert turn.H_max == pytest.approx(H11[1], rel=1e-5)  # sampled at 1 ms, near q3 = 0.5
    assert turn.velocity_ratio > 0.5  # 2·m·r·ṙ·q̇1 of the order of H_11·q̈1
    assert turn.coupling_ratio == 0.0  # the reach axis passes through the turning axis
    assert turn.gravity_peak == 0.0
    assert any("general form" in r for r in turn.reasons)


def test_fig3_lift_and_reach(fig3):
    arm, rep = fig3
    lift, reach = rep["lift"], rep["reach"]
    # the lift is held; its only load is the weight of carriage and arm, a constant
    # that a counterweight (or a constant-force spring) takes off entirely
    assert not lift.moving and lift.inertial_peak == 0.0
    assert lift.gravity_constant == pytest.approx((15 + 0.4) * G, rel=1e-12)
    assert lift.gravity_after_spring == 0.0 and lift.gravity_after_balancer == 0.0
    assert lift.classification == "decoupled"
    # the reach: constant inertia 0.4 kg, centrifugal force a few % of m·q̈3
    assert reach.H_min == pytest.approx(0.4) and reach.H_max == pytest.approx(0.4)
    assert 0.0 < reach.velocity_ratio < 0.05
    assert reach.classification == "decoupled"


def test_figures_are_those_of_torque_components():
    """Peaks, RMS and ratios are computed from torque_components along the samples."""
    puma = load("puma560")
    traj = quintic(np.zeros(6), [1.0, -0.8, 1.2, 0.5, -0.7, 1.0], 1.5)
    rep = coupling_analysis(puma, traj, dt=0.01)
    t = np.arange(151) * 0.01
    assert rep.samples == 151
    parts = manipcad.torque_components(puma, *traj.sample(t))
    for i, j in enumerate(rep.joints):
        assert j.inertial_peak == pytest.approx(np.abs(parts.inertial[:, i]).max())
        assert j.coupling_rms == pytest.approx(np.sqrt(np.mean(parts.coupling[:, i] ** 2)))
        assert j.velocity_peak == pytest.approx(np.abs(parts.velocity[:, i]).max())
        assert j.gravity_peak == pytest.approx(np.abs(parts.gravity[:, i]).max())
        assert j.velocity_ratio == pytest.approx(j.velocity_peak / j.inertial_peak)
        assert j.H_min == pytest.approx(parts.H_ii[:, i].min())
        # the best constant-torque spring is the mean; what is left, the varying part
        Q = parts.gravity[:, i]
        assert j.gravity_constant == pytest.approx(Q.mean())
        assert j.gravity_after_spring == pytest.approx(np.abs(Q - Q.mean()).max(), abs=1e-9)
        assert j.gravity_after_balancer <= j.gravity_after_spring + 1e-12
    # rotor=True adds J·i_r² to the own inertia (the PUMA's big gears make it larger)
    rot_rep = coupling_analysis(puma, traj, dt=0.01, rotor=True)
    for j, jr in zip(rep.joints, rot_rep.joints, strict=True):
        assert jr.H_min == pytest.approx(j.H_min + j.rotor_inertia)
        assert jr.inertial_peak >= j.inertial_peak
        assert jr.coupling_ratio <= j.coupling_ratio + 1e-12


# ------------------------------------------------------------------ counterweights and springs


def test_counterweight_removes_gravity_that_depends_on_the_joint_only():
    """A pendulum: Q = m·g·l·cos q, a function of q alone. A constant spring leaves its
    variation; the ideal counterweight (balancer) takes it all off -> decoupled."""
    m, l = 2.0, 0.3
    pend = chain("pendulum", ["revolute"], [rot("x", 90)], [m], [[l, 0, 0]])
    rep = coupling_analysis(pend, cosine([1.2], [3.0], duration=2.0))
    j = rep[0]
    assert j.gravity_peak == pytest.approx(m * G * l, rel=1e-3)
    assert j.gravity_after_spring > 0.5 * m * G * l
    assert j.gravity_after_balancer == 0.0
    c0, c1, c2 = j.balancer  # c0 + c1 cos q + c2 sin q: a counterweight of moment m·l
    assert abs(c0) < 1e-9 and np.hypot(c1, c2) == pytest.approx(m * G * l, rel=1e-12)
    assert j.classification == "decoupled"
    assert j.velocity_ratio == 0.0 and j.coupling_ratio == 0.0


def test_puma_shoulder_balanced_only_while_the_elbow_holds():
    """Q_2 of the PUMA depends on q2 and q3: with the elbow held, a balancer on the
    shoulder removes it all; with the elbow moving, part of it is left."""
    puma = load("puma560")
    only_q2 = coupling_analysis(puma, cosine([0, 0.8, 0, 0, 0, 0], [0, 3, 0, 0, 0, 0],
                                             duration=2.0))
    sh = only_q2["shoulder"]
    assert sh.gravity_after_balancer <= 1e-9 * sh.gravity_peak
    assert sh.gravity_after_spring > 0.1 * sh.gravity_peak
    assert sh.classification == "decoupled"
    # the held elbow is loaded by gravity that depends on q2: not decoupled
    el = only_q2["elbow"]
    assert not el.moving and el.gravity_after_balancer > 0 and el.classification == "full"
    both = coupling_analysis(puma, cosine([0, 0.8, 0.9, 0, 0, 0], [0, 3, 4, 0, 0, 0],
                                          duration=2.0))
    assert both["shoulder"].gravity_after_balancer > 0.1 * both["shoulder"].gravity_peak
    assert both["shoulder"].classification == "full"


def test_gantry_is_decoupled():
    """A Cartesian (gantry) robot: constant diagonal inertia, no velocity terms, constant
    weight on the vertical axis: every joint decoupled (mechanically decoupled scheme)."""
    gantry = chain("gantry", ["prismatic"] * 3, [rot("y", 90), rot("x", -90), np.eye(3)],
                   [30.0, 12.0, 5.0], [[0, 0, 0.1], [0.05, 0, 0], [0, 0.02, -0.2]])
    rep = coupling_analysis(gantry, cosine([0.4, 0.3, 0.2], [2.0, 3.0, 4.0], duration=3.0))
    assert rep.classes == ("decoupled",) * 3
    z = rep[2]
    assert z.gravity_constant == pytest.approx(5.0 * G)
    assert z.gravity_after_spring == 0.0 and z.H_ratio == pytest.approx(1.0)


def test_skewed_axes_couple_through_inertia_only():
    """Two horizontal prismatic axes 45° apart: H_12 = m_2 cos 45° couples them, with no
    velocity or gravity constituents: class inertial."""
    skew = chain("skew", ["prismatic"] * 2, [rot("y", 90), rot("z", 45) @ rot("y", 90)],
                 [2.0, 3.0], [[0, 0, 0], [0, 0, 0]])
    rep = coupling_analysis(skew, cosine([0.3, 0.3], [3.0, 3.0], duration=2.0))
    assert rep.classes == ("inertial", "inertial")
    assert rep[0].coupling_ratio == pytest.approx(3.0 * np.cos(np.pi / 4) / 5.0, rel=1e-9)
    assert rep[0].velocity_ratio == 0.0 and rep[0].gravity_peak == 0.0


def test_threshold_moves_the_boundary(fig3):
    arm, rep = fig3
    r = rep["reach"].velocity_ratio
    strict = coupling_analysis(arm, FIG3, threshold=r * 0.9)
    assert strict["reach"].classification == "full"


# ------------------------------------------------------------------ bad input


def test_bad_input():
    arm = load("cylindrical")
    with pytest.raises(InputError, match="moves 6 joints, the robot 'cylindrical arm"):
        coupling_analysis(arm, cosine([0.1] * 6, [1.0] * 6))
    with pytest.raises(InputError, match="dt: must be a finite number > 0"):
        coupling_analysis(arm, FIG3, dt=0)
    with pytest.raises(InputError, match="threshold: must be a fraction"):
        coupling_analysis(arm, FIG3, threshold=1.5)
    with pytest.raises(InputError, match="zero duration"):
        coupling_analysis(arm, cosine([0.1] * 3, [1.0] * 3, duration=0.0))
    with pytest.raises(InputError, match="no such file"):
        coupling_analysis(arm, ROOT / "examples" / "nothing.yaml")
    with pytest.raises(InputError, match="expected a Trajectory"):
        coupling_analysis(arm, 3)


runner = CliRunner()


def run(*args: str):
    return runner.invoke(app, ["coupling", *args], env={"COLUMNS": "220"})


def test_cli_table_and_json():
    res = run("cylindrical", "--trajectory", str(FIG3))
    assert res.exit_code == 0, res.output
    for word in ("turn (R)", "full", "lift (P)", "decoupled", "overall: full", "after balancer"):
        assert word in res.output, res.output
    res = run("cylindrical", "--trajectory", str(FIG3), "--json")
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    assert doc["overall"] == "full"
    assert [j["classification"] for j in doc["joints"]] == ["full", "decoupled", "decoupled"]
    assert doc["joints"][0]["H_ratio"] > 1.5 and doc["joints"][1]["velocity_ratio"] == 0.0


def test_cli_bad_input_exits_2(tmp_path):
    bad = tmp_path / "bad.yaml"
    bad.write_text("type: cosine\namplitude: [0.1, 0.2]\nomega: [1.0]\n")
    for args, message in [
        (["cylindrical", "--trajectory", str(tmp_path / "none.yaml")], "no such file"),
        (["puma560", "--trajectory", str(FIG3)], "moves 3 joints"),
        (["cylindrical", "--trajectory", str(FIG3), "--dt", "-1"], "dt: must be"),
        (["nosuchrobot", "--trajectory", str(FIG3)], "not a file and not a catalog robot"),
        (["cylindrical", "--trajectory", str(bad)], str(bad)),
    ]:
        res = run(*args)
        assert res.exit_code == 2, (args, res.output)
        assert message in res.output, res.output
        assert "Traceback" not in res.output


# ------------------------------------------------------------------ real-time components


@pytest.mark.parametrize("name", ["cylindrical", "puma560", "scara", "stanford"])
def test_moment_components_against_pinocchio(name):
    robot = load(name)
    model, order = to_pinocchio(robot)
    data = model.createData()
    rng = np.random.default_rng(7)
    q, qd = rng.uniform(-1, 1, (2, 20, robot.n))
    mc = moment_components(robot, q, qd)
    for k in range(20):
        pq = (q[k] + robot.offset)[order]
        H = pin.crba(model, data, pq)
        Qg = pin.computeGeneralizedGravity(model, data, pq)
        h = pin.rnea(model, data, pq, qd[k][order], np.zeros(robot.n)) - Qg
        for ours, ref in ((mc.H_ii[k], np.diag(H)), (mc.velocity[k], h), (mc.gravity[k], Qg)):
            assert np.abs(ours[order] - ref).max() <= 1e-10 * max(1.0, np.abs(ref).max())
    # one state, and the compiled kernel called directly with its scratch
    one = moment_components(robot, q[3], qd[3])
    assert one.H_ii.shape == (robot.n,)
    np.testing.assert_allclose(one.gravity, mc.gravity[3], rtol=0, atol=1e-12)
    out = [np.empty(robot.n) for _ in range(3)]
    zero, rwork, cwork, tmp, H = scratch(robot.n)
    components_one(robot.table, robot.gravity, q[3], qd[3], zero, rwork, cwork, tmp, H, *out)
    np.testing.assert_allclose(out[1], mc.velocity[3], rtol=0, atol=1e-12)


def test_moment_components_equal_torque_components():
    robot = load("stanford")
    traj = quintic(np.zeros(6), np.ones(6) * 0.5, 1.0)
    q, qd, qdd = traj.sample(np.linspace(0, 1, 30))
    mc = moment_components(robot, q, qd)
    tc = manipcad.torque_components(robot, q, qd, qdd)
    np.testing.assert_allclose(mc.H_ii, tc.H_ii, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(mc.velocity, tc.velocity, rtol=1e-12, atol=1e-12)
    np.testing.assert_allclose(mc.gravity, tc.gravity, rtol=1e-12, atol=1e-12)
    with pytest.raises(manipcad.ManipcadError, match="qd must have n = 6 columns"):
        moment_components(robot, q, qd[:, :5])
