"""``manipcad simulate`` and the results store: files written, --json, --force,
divergence and interruption leave nothing partial and lose nothing saved."""

from __future__ import annotations

import json
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from manipcad import folders
from manipcad.cli import app
from manipcad.errors import InputError
from manipcad.store import load_result, save_result

runner = CliRunner()
ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
POSE = [0.0, 0.5, -0.5, 0.0, 0.3, 0.0]


def run(*args: str):
    return runner.invoke(app, ["simulate", *map(str, args)], env={"COLUMNS": "200"})


def both(res) -> str:
    return res.output + (res.stderr or "")


@pytest.fixture
def traj(tmp_path) -> Path:
    """A 0.05 s quintic move of the PUMA's wrist from a pose held under gravity."""
    p = tmp_path / "move.yaml"
    end = list(POSE)
    end[3] = 0.05
    p.write_text(yaml.safe_dump({"type": "quintic", "q_start": POSE, "q_end": end,
                                 "duration": 0.05}))
    return p


def leftovers(folder: Path) -> list[str]:
    """Hidden temporary folders of the store left in a folder."""
    return [p.name for p in folder.iterdir() if ".partial-" in p.name or ".old-" in p.name]


def test_simulate_writes_everything(tmp_path, traj):
    out = tmp_path / "runs" / "r1"
    res = run("puma560", "--trajectory", traj, "--regulator", EXAMPLES / "pid_puma.yaml",
              "--out", out, "--t-end", "0.06", "--csv")
    assert res.exit_code == 0, both(res)
    assert "closed-loop metrics" in res.output and "shoulder" in res.output
    assert sorted(os.listdir(out)) == ["errors.png", "inputs", "metrics.json",
                                       "timeseries.csv", "timeseries.npz"]
    assert leftovers(out.parent) == []
    # inputs: byte copies of the files used (the robot from the catalog)
    inputs = out / "inputs"
    assert sorted(os.listdir(inputs)) == ["regulator.yaml", "robot.yaml", "trajectory.yaml"]
    assert (inputs / "trajectory.yaml").read_bytes() == traj.read_bytes()
    assert ((inputs / "regulator.yaml").read_bytes()
            == (EXAMPLES / "pid_puma.yaml").read_bytes())
    assert "PUMA 560" in (inputs / "robot.yaml").read_text()
    # time series with units in the header
    with open(out / "timeseries.csv", encoding="utf-8") as fh:
        header = fh.readline().strip().split(",")
    assert header[0] == "t [s]" and len(header) == 1 + 6 * 8
    for col in ("shoulder.q [rad]", "shoulder.q_ref [rad]", "shoulder.error [rad]",
                "shoulder.u [V]", "shoulder.current [A]", "shoulder.tau [N·m]"):
        assert col in header
    data = np.loadtxt(out / "timeseries.csv", delimiter=",", skiprows=1)
    assert data.shape == (61, 49)   # one sample per regulator period (1 ms) by default
    assert data[-1, 0] == pytest.approx(0.06)
    # metrics
    doc = json.loads((out / "metrics.json").read_text())
    assert doc["status"] == "ok" and doc["robot"] == "PUMA 560"
    assert doc["settings"]["dt"] == 1e-4 and doc["run"]["t_end"] == 0.06
    assert set(doc["metrics"]) == set(doc["joints"])
    assert doc["units"]["shoulder"]["max_error"] == "rad"
    assert doc["units"]["shoulder"]["effort_rms"] == "V"
    assert doc["metrics"]["wrist_roll"]["max_error"] > 0
    # the plot
    assert (out / "errors.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    # the round trip of the store
    back, doc2 = load_result(out)
    assert np.allclose(back.q[:, 1], data[:, 1 + 8 + 0])
    assert doc2["metrics"] == doc["metrics"]


def test_simulate_json(tmp_path, traj):
    out = tmp_path / "r"
    res = run("puma560", "-t", traj, "-r", EXAMPLES / "pid_puma.yaml", "-o", out, "--json")
    assert res.exit_code == 0, both(res)
    doc = json.loads(res.stdout)
    assert doc["status"] == "ok" and doc["out"] == str(out)
    assert doc["t_final"] == pytest.approx(0.05)
    m = doc["metrics"]["wrist_roll"]
    for key in ("max_error", "rms_error", "effort_rms", "energy", "overshoot", "rise_time",
                "settling_time"):
        assert key in m
    saved = json.loads((out / "metrics.json").read_text())
    assert saved["metrics"] == doc["metrics"]


def test_no_drives_payload_every(tmp_path, traj):
    out = tmp_path / "r"
    reg = tmp_path / "torque.yaml"
    # torques now (N·m per rad): the bare wrist links are light (H_66 = 4e-5 kg·m²)
    reg.write_text("type: pid\nperiod: 0.0001\nkp: [2000, 4000, 2000, 5, 5, 0.5]\n"
                   "kd: [100, 200, 80, 0.1, 0.05, 0.003]\n")
    res = run("puma560", "-t", traj, "-r", reg, "-o", out, "--no-drives", "--payload", "2.5",
              "--every", "10", "--json", "--csv")
    assert res.exit_code == 0, both(res)
    doc = json.loads(res.stdout)
    assert doc["units"]["shoulder"]["effort_rms"] == "N·m"
    assert doc["run"]["payload"] == 2.5 and doc["settings"]["drives"] is False
    with open(out / "timeseries.csv", encoding="utf-8") as fh:
        header = fh.readline()
    assert "shoulder.u [N·m]" in header
    assert np.loadtxt(out / "timeseries.csv", delimiter=",", skiprows=1).shape[0] == 51


def test_refuses_non_empty_folder_unless_force(tmp_path, traj):
    out = tmp_path / "r"
    out.mkdir()
    (out / "keep.txt").write_text("earlier work")
    args = ("puma560", "-t", traj, "-r", EXAMPLES / "pid_puma.yaml", "-o", out)
    res = run(*args)
    assert res.exit_code == 2
    assert "not empty" in both(res) and "--force" in both(res)
    assert os.listdir(out) == ["keep.txt"]
    res = run(*args, "--force")  # not a result folder: --force does not replace it
    assert res.exit_code == 2 and "not a manipcad result" in both(res)
    assert os.listdir(out) == ["keep.txt"]
    (out / "keep.txt").unlink()
    assert run(*args).exit_code == 0
    (out / "keep.txt").write_text("earlier work")  # a result folder (metrics.json) is
    res = run(*args, "--force")
    assert res.exit_code == 0, both(res)
    assert "keep.txt" not in os.listdir(out) and (out / "metrics.json").is_file()
    assert leftovers(tmp_path) == []


def test_empty_existing_folder_is_used(tmp_path, traj):
    out = tmp_path / "r"
    out.mkdir()
    res = run("puma560", "-t", traj, "-r", EXAMPLES / "pid_puma.yaml", "-o", out)
    assert res.exit_code == 0, both(res)
    # CSV on request (--csv, or 'ws export'); the arrays are in the npz, one sample per
    # regulator period (examples/pid_puma.yaml: 1 ms)
    assert (out / "timeseries.npz").is_file() and not (out / "timeseries.csv").exists()
    doc = json.loads((out / "metrics.json").read_text())
    assert doc["run"]["every"] == 10


DIVERGENT = "type: pid\nperiod: 0.001\nkp: -1.0e6\nkd: -1.0e4\njoints: [elbow]\n"


def test_divergent_run_exits_2_and_keeps_folder(tmp_path, traj):
    out = tmp_path / "r"
    out.mkdir()
    (out / "keep.txt").write_text("earlier work")
    (out / "metrics.json").write_text("{}")  # an earlier result: --force may replace it
    reg = tmp_path / "bad_gains.yaml"
    reg.write_text(DIVERGENT)
    res = run("puma560", "-t", traj, "-r", reg, "-o", out, "--no-drives", "--t-end", "2",
              "--force")
    assert res.exit_code == 2
    msg = both(res)
    assert "diverged at t = " in msg and "joint '" in msg and "nothing was written" in msg
    assert "Traceback" not in msg
    assert sorted(os.listdir(out)) == ["keep.txt", "metrics.json"]
    assert leftovers(tmp_path) == []


def test_divergent_run_partial_result_on_request(tmp_path, traj):
    out = tmp_path / "r"
    reg = tmp_path / "bad_gains.yaml"
    reg.write_text(DIVERGENT)
    res = run("puma560", "-t", traj, "-r", reg, "-o", out, "--no-drives", "--t-end", "2",
              "--save-diverged")
    assert res.exit_code == 2
    assert "partial result" in both(res)
    doc = json.loads((out / "metrics.json").read_text())
    assert doc["status"] == "diverged" and "diverged at t = " in doc["message"]
    assert doc["t_final"] < 2.0
    assert (out / "errors.png").is_file()


def test_bad_regulator_file_one_line(tmp_path, traj):
    reg = tmp_path / "reg.yaml"
    reg.write_text("type: pid\nperiod: 0.001\nkp: [1, 2, 3]\n")
    out = tmp_path / "r"
    res = run("puma560", "-t", traj, "-r", reg, "-o", out)
    assert res.exit_code == 2
    msg = res.stderr
    assert f"{reg}: kp: has 3 entries" in msg
    assert len([ln for ln in msg.splitlines() if ln.strip()]) == 1, msg
    assert not out.exists()


def test_period_not_multiple_of_dt(tmp_path, traj):
    res = run("puma560", "-t", traj, "-r", EXAMPLES / "pid_puma.yaml", "-o", tmp_path / "r",
              "--dt", "3e-4")
    assert res.exit_code == 2
    assert "period: 0.001 s is not a multiple of the simulation step" in both(res)


def test_bad_arguments(tmp_path, traj):
    out = tmp_path / "r"
    for args, words in [
        (("--dt", "0"), "--dt: must be > 0"),
        (("--t-end", "-1"), "--t-end: must be > 0"),
        (("--payload", "-2"), "--payload: must be >= 0"),
        (("--every", "0"), "--every: must be >= 1"),
        (("--joint-limits", "bounce"), "must be one of warn, stop, ignore, hard-stop"),
    ]:
        res = run("puma560", "-t", traj, "-o", out, *args)
        assert res.exit_code == 2, both(res)
        assert words in both(res)
    res = run("puma560", "-t", tmp_path / "nope.yaml", "-o", out)
    assert res.exit_code == 2 and "no such file" in both(res)
    bad = tmp_path / "three.yaml"
    bad.write_text("type: quintic\nq_start: [0, 0, 0]\nq_end: [1, 1, 1]\nduration: 1\n")
    res = run("puma560", "-t", bad, "-o", out)
    assert res.exit_code == 2 and "has 3 joints" in both(res)
    assert not out.exists()


def test_interrupted_run_leaves_nothing(tmp_path, traj, monkeypatch):
    """Ctrl-C while the results are written: no DIR, no temporary folder; an old DIR stays."""
    import manipcad.store.results as results

    def interrupt(*_a, **_k):
        raise KeyboardInterrupt

    monkeypatch.setattr(results, "plot_errors", interrupt)  # the store's own name for it
    out = tmp_path / "r"
    args = ("puma560", "-t", traj, "-r", EXAMPLES / "pid_puma.yaml", "-o", out)
    res = run(*args)
    assert res.exit_code == 130
    assert "interrupted" in both(res)
    assert not out.exists() and leftovers(tmp_path) == []
    out.mkdir()
    (out / "keep.txt").write_text("earlier work")
    (out / "metrics.json").write_text("{}")  # an earlier result: --force may replace it
    res = run(*args, "--force")
    assert res.exit_code == 130
    assert sorted(os.listdir(out)) == ["keep.txt", "metrics.json"]
    assert leftovers(tmp_path) == []


def test_interrupted_simulation_leaves_nothing(tmp_path, traj, monkeypatch):
    import importlib

    def interrupt(*_a, **_k):
        raise KeyboardInterrupt

    # the run description's call of simulate
    monkeypatch.setattr(importlib.import_module("manipcad.store.run"), "simulate", interrupt)
    out = tmp_path / "r"
    res = run("puma560", "-t", traj, "-r", EXAMPLES / "pid_puma.yaml", "-o", out)
    assert res.exit_code == 130 and not out.exists()


# ------------------------------------------------------------------- the store
@pytest.fixture(scope="module")
def small_result():
    import warnings

    import manipcad
    from manipcad.errors import ManipcadWarning
    from manipcad.sim import simulate

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        arm = manipcad.load_robot("cylindrical")
    return arm, simulate(arm, t_end=0.02, dt=1e-3, drives=False, q0=[0.0, 0.3, 0.2])


def test_store_failed_swap_restores_old_folder(tmp_path, small_result, monkeypatch):
    """If renaming the new folder in fails after the old one moved aside, the old comes back."""
    arm, res = small_result
    out = tmp_path / "r"
    out.mkdir()
    (out / "keep.txt").write_text("earlier work")
    (out / "metrics.json").write_text("{}")  # an earlier result: force may replace it
    real_rename = os.rename

    def flaky(src, dst):
        if ".partial-" in str(src):
            raise KeyboardInterrupt
        return real_rename(src, dst)

    monkeypatch.setattr(folders.os, "rename", flaky)
    monkeypatch.setattr(folders, "exchange", lambda a, b: False)  # the two-rename fallback
    with pytest.raises(KeyboardInterrupt):
        save_result(res, out, joint_types=arm.joint_types, force=True)
    assert sorted(os.listdir(out)) == ["keep.txt", "metrics.json"]
    assert leftovers(tmp_path) == []


def test_store_inputs_and_units(tmp_path, small_result):
    arm, res = small_result
    src = tmp_path / "a.yaml"
    src.write_text("x: 1\n")
    from manipcad.trajectories import quintic

    out = save_result(res, tmp_path / "r", joint_types=arm.joint_types, inputs={
        "robot": src, "trajectory": quintic([0, 0, 0], [1, 1, 1], 1.0),
        "regulator": [src, src], "notes": {"why": "test"}}, plot=False)
    names = sorted(os.listdir(out / "inputs"))
    assert names == ["notes.yaml", "regulator-1.yaml", "regulator-2.yaml", "robot.yaml",
                     "trajectory.yaml"]
    assert yaml.safe_load((out / "inputs" / "trajectory.yaml").read_text())["type"] == "quintic"
    header = (out / "timeseries.csv").read_text().splitlines()[0]
    assert "lift.q [m]" in header and "lift.tau [N]" in header and "turn.q [rad]" in header
    assert "lift.u [N]" in header  # no drives: the output is a force
    assert not (out / "errors.png").exists()
    with pytest.raises(InputError, match="not empty"):
        save_result(res, out)
    with pytest.raises(InputError, match="not a readable file"):
        save_result(res, tmp_path / "r2", inputs={"robot": tmp_path / "missing.yaml"})
    assert not (tmp_path / "r2").exists() and leftovers(tmp_path) == []
    (tmp_path / "file").write_text("")
    with pytest.raises(InputError, match="not a folder"):
        save_result(res, tmp_path / "file")


def test_subprocess_divergence_one_line_on_stderr(tmp_path, traj):
    reg = tmp_path / "bad_gains.yaml"
    reg.write_text(DIVERGENT)
    proc = subprocess.run(
        [sys.executable, "-m", "manipcad", "simulate", "puma560", "-t", str(traj), "-r",
         str(reg), "-o", str(tmp_path / "r"), "--no-drives", "--t-end", "2"],
        capture_output=True, text=True, timeout=600)
    assert proc.returncode == 2, proc.stderr
    assert "Traceback" not in proc.stderr + proc.stdout
    lines = [ln for ln in proc.stderr.splitlines() if ln.strip()
             and not ln.startswith("warning:") and "triangle" not in ln]
    assert any("diverged at t = " in ln for ln in lines), proc.stderr
    assert not (tmp_path / "r").exists()


def test_hard_stops_from_the_command_line(tmp_path, traj):
    """--joint-limits hard-stop runs the limits as mechanical stops (docs/simulation.md)."""
    out = tmp_path / "r"
    res = run("puma560", "-t", traj, "-r", EXAMPLES / "pid_puma.yaml", "-o", out,
              "--joint-limits", "hard-stop", "--json")
    assert res.exit_code == 0, both(res)
    assert json.loads(res.stdout)["settings"]["joint_limits"] == "hard-stop"
    res = run("puma560", "-t", traj, "-r", EXAMPLES / "pid_puma.yaml", "-o", out, "--force",
              "--json")
    assert res.exit_code == 0 and "joint_limits" not in json.loads(res.stdout)["settings"]
