"""manipcad.store.plan: the one set of checks `manipcad simulate` and the web application's
Simulation page make before a run (each error names its source and reason)."""

from __future__ import annotations

from pathlib import Path

import pytest

import manipcad
from manipcad.errors import InputError
from manipcad.store.plan import check_numbers, plan_run
from manipcad.trajectories import load_trajectory

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


@pytest.fixture(scope="module")
def arm():
    return manipcad.load_robot("cylindrical")


@pytest.fixture(scope="module")
def traj(arm):
    return load_trajectory(EXAMPLES / "fig3_laws.yaml", robot=arm)


def pid_file(arm, tmp_path, name, joints, period=1e-3):
    regs = [manipcad.synthesize(arm, j, "pid", period=period) for j in joints]
    path = tmp_path / name
    manipcad.save_regulators(regs, path, robot=arm)
    return path


def test_plan_sets_end_time_stride_and_regulators(arm, traj, tmp_path):
    a = pid_file(arm, tmp_path, "a.yaml", ["turn"], period=1e-3)
    b = pid_file(arm, tmp_path, "b.yaml", ["lift", "reach"], period=5e-4)
    plan = plan_run(arm, traj, [a, b], dt=1e-4)
    assert plan.t_end == pytest.approx(float(traj.duration))
    assert plan.every == 5                       # one sample per shortest period
    assert [tuple(r.joints) for r in plan.regulators] == [(0,), (1,), (2,)]
    assert plan_run(arm, traj, [a], dt=1e-4, t_end=0.2, every=3).every == 3


@pytest.mark.parametrize("kw, where, reason", [
    ({"dt": 0.0}, "dt", "must be > 0 s"),
    ({"dt": float("nan")}, "dt", "must be > 0 s"),
    ({"dt": 1e-4, "t_end": -1.0}, "t_end", "must be > 0 s"),
    ({"dt": 1e-4, "every": 0}, "every", "must be >= 1"),
    ({"dt": 0.5, "t_end": 0.1}, "dt", "longer than the run"),
])
def test_bad_numbers_name_the_number(arm, traj, kw, where, reason):
    with pytest.raises(InputError, match=reason) as exc:
        plan_run(arm, traj, **kw)
    assert exc.value.source == where


def test_option_names_are_used_when_given(arm, traj):
    with pytest.raises(InputError, match=r"^--dt: must be > 0 s"):
        check_numbers(-1.0, names={"dt": "--dt", "t_end": "--t-end", "every": "--every"})


def test_a_joint_with_two_regulators_names_both_files(arm, traj, tmp_path):
    a = pid_file(arm, tmp_path, "a.yaml", ["turn", "lift"])
    b = pid_file(arm, tmp_path, "b.yaml", ["lift"])
    with pytest.raises(InputError, match=r"joint 'lift' already has a regulator in .*a\.yaml"):
        plan_run(arm, traj, [a, b], dt=1e-4)


def test_trajectory_of_another_joint_count(traj):
    puma = manipcad.load_robot("puma560")
    with pytest.raises(InputError, match="has 3 joints, robot .* has 6") as exc:
        plan_run(puma, traj, dt=1e-4, trajectory_source="fig3_laws.yaml")
    assert exc.value.source == "fig3_laws.yaml"


def test_drives_asked_of_a_robot_without_them(arm, traj):
    bare = arm.replace(drives=[None] * arm.n)
    assert not bare.has_drives
    with pytest.raises(InputError, match="the robot has no drives; use drives=False"):
        plan_run(bare, traj, dt=1e-4)
    assert plan_run(bare, traj, dt=1e-4, drives=False).regulators == []
