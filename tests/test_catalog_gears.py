"""The Harmonic Drive CSG catalog entries (sizes 14-32, docs/robot-files.md "Catalog
parts"), the gear-rating validator, and what an unknown gear efficiency does to a sizing:
it is never taken as η = 1 (a false pass), and a motor that fails even at the lower
bound of its torque fails."""

from __future__ import annotations

import dataclasses
import math

import numpy as np
import pytest
import yaml

import manipcad
from manipcad.catalog.efficiency import strain_wave_assumption
from manipcad.catalog.files import PARTS
from manipcad.errors import InputError
from manipcad.model.robot import Drive
from manipcad.model.yaml_robot import CONSTANTS, compose_gears, load_gear
from manipcad.sizing import required_drive
from manipcad.trajectories import cosine, quintic
from manipcad.trajectories.base import Trajectory

RPM = CONSTANTS["rpm"]
#: the CSG rating-table rows entered: size -> ratios (the table has no CSG-14-120/160,
#: no CSG-17-160)
CSG = {14: (50, 80, 100), 17: (50, 80, 100, 120), 20: (50, 80, 100, 120, 160),
       25: (50, 80, 100, 120, 160), 32: (50, 80, 100, 120, 160)}
#: size -> (max input speed grease rpm, moment of inertia kg·m²), per the table
SIZE = {14: (8500, 0.033e-4), 17: (7300, 0.079e-4), 20: (6500, 0.193e-4),
        25: (5600, 0.413e-4), 32: (4800, 1.690e-4)}


@pytest.mark.parametrize("size, ratio", [(s, r) for s, rs in CSG.items() for r in rs])
def test_csg_entry_loads_ordered_and_sourced(size, ratio):
    g = load_gear(f"harmonic_csg{size}_{ratio}")
    assert g.type == "harmonic" and g.ratio == ratio and g.direction == -1
    assert g.max_continuous_torque <= g.max_average_torque <= g.max_intermittent_torque \
        <= g.max_momentary_torque
    assert g.max_input_speed == pytest.approx(SIZE[size][0] * RPM, rel=1e-15)
    assert g.max_average_input_speed == pytest.approx(3500 * RPM, rel=1e-15)
    assert g.rated_input_speed == pytest.approx(2000 * RPM, rel=1e-15)
    assert g.J == pytest.approx(SIZE[size][1], rel=1e-12)
    # what the transcription does not give stays unknown, and the source says so; the
    # efficiency is the library's stated strain-wave assumption, marked as such
    assert g.stiffness is None and g.mass is None
    assert g.efficiency == strain_wave_assumption()[0] and g.efficiency_basis == "assumed"
    assert "HFUC-20-80" in g.assumed["efficiency"]
    assert f"size {size}, ratio {ratio}" in " ".join(g.source.split())
    assert "transcription" in g.source and "efficiency" in g.source


@pytest.mark.parametrize("name, ratings", [
    ("harmonic_csf17_50", (16, 34, 70)), ("harmonic_csf25_50", (39, 98, 186)),
    ("harmonic_csf17_100", (24, 54, 108))])
def test_csf_units_from_the_product_pages(name, ratings):
    """The CSF entries sourced from (a transcription of) Harmonic Drive's product pages:
    rated / repeated peak / momentary torque as printed; what the pages do not give (the
    average-torque limit, and for the new two the maximum input speed and efficiency)
    is unknown, not guessed."""
    g = load_gear(name)
    assert (g.max_continuous_torque, g.max_intermittent_torque, g.max_momentary_torque) \
        == ratings
    assert g.max_average_torque is None
    assert g.max_average_input_speed == pytest.approx(3500 * RPM, rel=1e-15)
    if name != "harmonic_csf17_100":
        assert g.max_input_speed is None and g.stiffness is None
        assert g.efficiency_basis == "assumed"
    else:
        assert "NOT CONFIRMED" in g.source      # its efficiency and max speed


def test_csg_25_100_cross_check():
    """The row two further independent public notes confirm: 87 / 204 / 369 N·m."""
    g = load_gear("harmonic_csg25_100")
    assert (g.max_continuous_torque, g.max_intermittent_torque, g.max_momentary_torque) \
        == (87, 204, 369)


def test_rating_order_validator_names_the_field(tmp_path):
    """A transcription that swapped two columns (rated above the repeated peak) fails
    with the field named; so does an average input speed above the maximum."""
    base = yaml.safe_load(open(PARTS.joinpath("gears", "harmonic_csg20_100.yaml"),
                               encoding="utf-8"))
    bad = dict(base, max_continuous_torque=120)
    p = tmp_path / "swapped.yaml"
    p.write_text(yaml.safe_dump(bad), encoding="utf-8")
    with pytest.raises(InputError) as exc:
        load_gear(str(p))
    assert exc.value.field in ("max_average_torque", "max_intermittent_torque")
    assert "order" in str(exc.value)
    slow = dict(base, max_average_input_speed="9000*rpm")
    p = tmp_path / "speed.yaml"
    p.write_text(yaml.safe_dump(slow), encoding="utf-8")
    with pytest.raises(InputError) as exc:
        load_gear(str(p))
    assert exc.value.field == "max_input_speed"
    p = tmp_path / "neg.yaml"
    p.write_text(yaml.safe_dump(dict(base, max_momentary_torque=-1)), encoding="utf-8")
    with pytest.raises(InputError) as exc:
        load_gear(str(p))
    assert exc.value.field == "max_momentary_torque"


def _unknown_eta_gear(tmp_path):
    """The CSG-20-100 file with ``efficiency: unknown`` (no assumption), as a path."""
    base = yaml.safe_load(open(PARTS.joinpath("gears", "harmonic_csg20_100.yaml"),
                               encoding="utf-8"))
    p = tmp_path / "csg20_100_unknown.yaml"
    p.write_text(yaml.safe_dump(dict(base, efficiency="unknown")), encoding="utf-8")
    return str(p)


def test_unknown_efficiency_composes_to_nan_and_round_trips(tmp_path):
    unknown = _unknown_eta_gear(tmp_path)
    f, _ = compose_gears([load_gear(unknown)])
    assert math.isnan(f["efficiency"]) and "assumed" not in f
    assert (f["gear_rated_torque"], f["gear_peak_torque"]) == (52.0, 107.0)
    assert f["gear_max_input_speed"] == pytest.approx(6500 * RPM, rel=1e-15)
    # a chain: the rating of a gear before one of unknown efficiency is unknown too
    f, _ = compose_gears([load_gear("wittenstein_tp004mf_10"), load_gear(unknown)])
    assert math.isnan(f["efficiency"]) and "gear_rated_torque" not in f
    assert "gear_max_input_speed" in f                      # speeds need no efficiency
    doc = {"name": "one", "joints": [{
        "name": "j1", "type": "revolute", "dh": {"a": 0, "alpha": 0, "d": 0, "theta": 0},
        "link": {"mass": 1.0, "com": [0.1, 0, 0], "inertia": {"ixx": 0.01, "iyy": 0.01,
                                                               "izz": 0.01}},
        "drive": {"motor": "maxon_ec90flat_244879", "gear": unknown}}]}
    p = tmp_path / "one.yaml"
    p.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    arm = manipcad.load_robot(p)
    assert math.isnan(arm.drives[0].efficiency)
    saved = manipcad.save_robot(arm, tmp_path / "saved.yaml")
    assert "efficiency: unknown" in saved.read_text(encoding="utf-8")
    assert math.isnan(manipcad.load_robot(saved).drives[0].efficiency)
    # a designer who has the efficiency from his own data states it in the drive
    doc["joints"][0]["drive"]["efficiency"] = 0.7
    p.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    assert manipcad.load_robot(p).drives[0].efficiency == 0.7


def _one_joint(efficiency: float, rated_torque: float):
    """One horizontal-axis joint, 2 kg at 0.3 m, through a CSG-20-100's ratings (SI)."""
    f, _ = compose_gears([load_gear("harmonic_csg20_100")])
    d = Drive(J=1e-4, ratio=100.0, R=1.0, L=1e-3, k_m=0.1, k_w=0.1, u_max=48.0,
              rated_torque=rated_torque, peak_torque=10 * rated_torque, max_speed=600.0,
              efficiency=efficiency, gear="harmonic_csg20_100",
              gear_rated_torque=f["gear_rated_torque"], gear_peak_torque=f["gear_peak_torque"],
              gear_max_input_speed=f["gear_max_input_speed"])
    R_x = np.array([[1.0, 0, 0], [0, 0, -1.0], [0, 1.0, 0]])   # joint axis horizontal
    return manipcad.Robot.from_arrays("one", ["revolute"], [-1], R_x[None], np.zeros((1, 3)),
                                      [2.0], [[0.3, 0.0, 0.0]], np.eye(3)[None] * 0.01,
                                      drives=[d])


def test_unknown_efficiency_is_not_a_pass():
    """Holding the arm horizontal needs m·g·c/(i_r·η) = 0.0589/η N·m. Against a 0.1 N·m
    rating the old sizing (η taken as 1) said "pass"; with η unknown it cannot know
    (η = 0.5 would need 0.118): "unknown". Against 0.05 N·m even the lower bound 0.0589
    fails: "fail", unknown η or not. The gear checks, which do not depend on η, are
    made with the CSG data (52 N·m rated against 0.59 N·m: pass)."""
    hold = quintic([0.0], [0.0], 1.0)
    need = 2.0 * 9.81 * 0.3 / 100.0
    req = required_drive(_one_joint(math.nan, 0.1), hold, t_end=1.0)
    assert req.checks["continuous"].status == ("unknown",)
    assert math.isnan(req.checks["continuous"].margin[0])
    assert req.checks["continuous"].required[0] == pytest.approx(need, rel=1e-9)  # at η = 1
    assert req.checks["voltage"].status == ("unknown",)
    assert req.checks["speed"].status == ("pass",)
    for k in ("gear_continuous", "gear_peak", "gear_speed"):
        assert req.checks[k].status == ("pass",)
    assert req.checks["gear_continuous"].limit[0] == 52.0
    assert req.status == ("unknown",)
    # the same with a known efficiency is decided
    known = required_drive(_one_joint(0.7, 0.1), hold, t_end=1.0)
    assert known.checks["continuous"].status == ("pass",)
    assert known.checks["continuous"].required[0] == pytest.approx(need / 0.7, rel=1e-9)
    # a motor too weak even for the lossless bound fails, efficiency unknown or not
    weak = required_drive(_one_joint(math.nan, 0.05), hold, t_end=1.0)
    assert weak.checks["continuous"].status == ("fail",) and weak.status == ("fail",)
    assert weak.checks["continuous"].required[0] == pytest.approx(need, rel=1e-9)


def test_lower_bound_is_a_bound():
    """Swinging (motoring and braking, acceleration against gravity): for every η in
    (0, 1] the RMS and peak motor torque stay at or above the bound used for η unknown,
    so a "fail" from the bound is a fail for the true gear."""
    traj = cosine([0.8], [3.0], 2.0)
    bound = required_drive(_one_joint(math.nan, 1e-3), traj)
    assert bound.checks["continuous"].status == ("fail",)
    rms_lb, peak_lb = (bound.checks[k].required[0] for k in ("continuous", "peak"))
    for eta in (1.0, 0.9, 0.6, 0.3, 0.05):
        r = required_drive(_one_joint(eta, 1e-3), traj)
        assert r.rms_motor_torque[0] >= rms_lb * (1 - 1e-12)
        assert r.peak_motor_torque[0] >= peak_lb * (1 - 1e-12)


def test_cli_size_says_why_unknown(tmp_path):
    """`manipcad size` on a drive through a CSG gear stated ``efficiency: unknown``: exit 1
    (unknown), and it names the unknown gear efficiency as the reason; --allow-unknown
    exits 0."""
    from typer.testing import CliRunner

    from manipcad.cli import app
    from manipcad.trajectories import save_trajectory

    doc = {"name": "one", "joints": [{
        "name": "j1", "type": "revolute", "dh": {"a": 0, "alpha": "pi/2", "d": 0, "theta": 0},
        "link": {"mass": 1.0, "com": [0.1, 0, 0], "inertia": {"ixx": 0.01, "iyy": 0.01,
                                                               "izz": 0.01}},
        "drive": {"motor": "maxon_ec45flat_411812", "gear": "harmonic_csg14_100",
                  "efficiency": "unknown"}}]}
    robot = tmp_path / "one.yaml"
    robot.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    traj = tmp_path / "t.yaml"
    save_trajectory(cosine([0.5], [2.0], 2.0), traj)
    runner = CliRunner()
    res = runner.invoke(app, ["size", str(robot), "-t", str(traj)], env={"COLUMNS": "200"})
    assert res.exit_code == 1, res.output
    assert "gear efficiency unknown" in res.stdout and "not taken as 1" in res.stdout
    res = runner.invoke(app, ["size", str(robot), "-t", str(traj), "--allow-unknown"])
    assert res.exit_code == 0, res.output


class _Spin(Trajectory):
    """One joint turning at a constant speed w (rad/s) from q = 0 for T s (SI)."""

    def __init__(self, w: float, T: float) -> None:
        self.w, self.T = w, T

    @property
    def n(self) -> int:
        return 1

    @property
    def duration(self) -> float:
        return self.T

    def _evaluate(self, t):
        t = np.asarray(t, dtype=float)
        return (self.w * t)[:, None], np.full((t.size, 1), self.w), np.zeros((t.size, 1))

    def to_dict(self):
        return {"kind": "spin", "w": self.w, "T": self.T}


def _spin_joint(mass: float, **ratings):
    """The horizontal joint of :func:`_one_joint` with a given mass (kg) and gear ratings."""
    arm = _one_joint(0.7, 10.0)
    d = dataclasses.replace(arm.drives[0], **ratings)
    return dataclasses.replace(arm, drives=(d,), mass=np.array([mass]))


def test_csg_average_ratings_reach_the_drive():
    f, _ = compose_gears([load_gear("harmonic_csg20_100")])
    assert f["gear_average_torque"] == 64.0
    assert f["gear_average_input_speed"] == pytest.approx(3500 * 2 * math.pi / 60, rel=1e-12)
    f, _ = compose_gears([load_gear("harmonic_csf20_100")])   # not in its source: unknown
    assert "gear_average_torque" not in f and "gear_average_input_speed" not in f


@pytest.mark.parametrize("mass, rated, average, status, limit", [
    (30.0, 52.0, 64.0, "fail", 64.0),        # T_av 66.3 N·m over the 64 N·m average limit
    (25.0, 52.0, 64.0, "pass", 64.0),        # T_av 55.3: over the rated torque, under the limit
    (25.0, 52.0, math.nan, "unknown", math.nan),   # no average limit: over the rated bound
    (10.0, 52.0, math.nan, "pass", 52.0),    # T_av 22.1 under the rated torque: a known pass
])
def test_average_torque_check(mass, rated, average, status, limit):
    """A full turn at constant speed: P_rigid = m·g·c·cos q, so the speed-weighted cubic
    mean is m·g·c·(∫|cos|³/π)^(1/3) = m·g·c·(4/(3π))^(1/3) (closed form)."""
    w, T = 2.0, math.pi / 2.0    # rad/s, s: q from 0 to π
    arm = _spin_joint(mass, gear_rated_torque=rated, gear_average_torque=average)
    req = required_drive(arm, _Spin(w, T), t_end=T, dt=1e-4)
    expect = mass * 9.81 * 0.3 * (4.0 / (3.0 * math.pi)) ** (1.0 / 3.0)
    c = req.checks["gear_average"]
    assert c.required[0] == pytest.approx(expect, rel=1e-6)
    assert c.status == (status,)
    assert c.limit[0] == pytest.approx(limit, nan_ok=True)


@pytest.mark.parametrize("rpm, average, status", [
    (4000.0, 3500 * math.pi / 30, "fail"),    # 4000 rpm input mean over 3500 rpm
    (3000.0, 3500 * math.pi / 30, "pass"),
    (4000.0, math.nan, "n/a"),                # no average rating, under the 6500 rpm max
    (7000.0, math.nan, "fail"),               # 7000 rpm mean: over the max input speed itself
])
def test_average_input_speed_check(rpm, average, status):
    w = rpm * math.pi / 30.0 / 100.0          # joint speed, rad/s, through the 100:1 gear
    arm = _spin_joint(1.0, gear_average_input_speed=average)
    req = required_drive(arm, _Spin(w, 0.1), t_end=0.1, dt=1e-3)
    c = req.checks["gear_average_speed"]
    assert c.required[0] == pytest.approx(100.0 * w, rel=1e-9)     # |i_r·q̇|, constant
    assert c.status == (status,)


def test_average_torque_formula_reproduces_a_worked_example():
    """A published selection example (honpine.com, "How to Selection Harmonic Reduction
    Gear?"): T = 150, 82, 130, 0 N·m for 0.2, 3, 0.3, 0.2 s at 10, 20, 10, 0 rpm gives
    T_av = 89 N·m. Piecewise-constant samples (a 1e-9 s step between segments)."""
    from manipcad.sizing.stats import weighted_cubic_mean
    segs = [(150.0, 0.2, 10.0), (82.0, 3.0, 20.0), (130.0, 0.3, 10.0), (0.0, 0.2, 0.0)]
    t, x, w, t0 = [], [], [], 0.0
    for T, dt, n in segs:
        t += [t0 + 1e-9, t0 + dt]
        x += [T, T]
        w += [n, n]
        t0 += dt
    t[0] = 0.0
    got = float(weighted_cubic_mean(np.array(x), np.array(w), np.array(t)))
    assert round(got) == 89
