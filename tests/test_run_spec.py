"""The run description (manipcad.store.run): stored and read back as data, executed the
same whoever runs it, and a stored result's description re-runs it bit for bit."""

from __future__ import annotations

import json
import warnings
from pathlib import Path

import numpy as np
import pytest

from manipcad.errors import InputError, ManipcadWarning
from manipcad.store.results import load_result
from manipcad.store.run import RunSpec, execute, prepare, stored_spec, to_folder

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
LAWS = str(EXAMPLES / "fig3_laws.yaml")
PID = str(EXAMPLES / "pid_cylindrical.yaml")
ARRAYS = ("t", "q", "qd", "q_ref", "qd_ref", "u", "current", "tau")


def spec(**kw) -> RunSpec:
    return RunSpec("cylindrical", LAWS, (PID,), t_end=0.02, **kw)


def test_to_dict_from_dict_round_trip_and_refusals():
    s = spec(payload={"mass": 1.5, "com": [0.0, 0.0, 0.1]}, integrator="adaptive", rtol=1e-7,
             joint_limits="hard-stop", accuracy=1e-3, max_chatter=80.0)
    d = json.loads(json.dumps(s.to_dict()))          # as metrics.json holds it
    assert d["checks"] == {"accuracy": 1e-3, "max_saturation": 0.02, "max_chatter": 80.0}
    assert RunSpec.from_dict(d) == s
    # what execute adds to a stored description is skipped on reading
    assert RunSpec.from_dict({**d, "robot_notes": ["x"], "wall_time_s": 1.0,
                              "checks": {**d["checks"], "verdict": "pass"}}) == s
    with pytest.raises(InputError, match=r"m.json: run.speed: unknown run setting"):
        RunSpec.from_dict({**d, "speed": 2}, "m.json")
    with pytest.raises(InputError, match=r"run.every: 'ten' is not a valid value"):
        RunSpec.from_dict({**d, "every": "ten"})
    with pytest.raises(InputError, match=r"run.robot: missing"):
        RunSpec.from_dict({"dt": 1e-4})


def test_prepare_settles_the_numbers_and_needs_t_end_without_trajectory():
    p = prepare(RunSpec("cylindrical", LAWS, (PID,)))
    assert p.spec.t_end == pytest.approx(1.6) and p.spec.every == 10  # 1 ms PID, dt 1e-4
    with pytest.raises(InputError, match="t_end: needed: there is no trajectory"):
        prepare(RunSpec("cylindrical", None, (PID,)))
    held = prepare(RunSpec("cylindrical", None, (PID,), t_end=0.01))
    assert held.trajectory is None and held.spec.every == 10


def test_stored_result_reruns_from_its_description(tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        done = execute(spec(), to_folder(tmp_path / "r"))
        stored, doc = load_result(tmp_path / "r")
        # the stored description is the settled one, run on the result's own inputs
        assert RunSpec.from_dict(doc["run"]) == done.prepared.spec
        again = stored_spec(tmp_path / "r", doc)
        assert again.robot.endswith("inputs/robot.yaml") and again.every == 10
        new = execute(again).result
    assert all(np.array_equal(getattr(stored, k), getattr(new, k)) for k in ARRAYS)
    assert doc["run"]["checks"]["verdict"] == done.checks.verdict
    assert doc["checks"] == done.result.checks


def test_an_earlier_results_settings_fill_what_its_run_lacks(tmp_path):
    inputs = tmp_path / "inputs"
    inputs.mkdir()
    for src, name in ((LAWS, "trajectory.yaml"), (PID, "regulator.yaml")):
        (inputs / name).write_text(Path(src).read_text())
    (inputs / "robot.yaml").write_text("placeholder")      # not loaded here
    doc = {"settings": {"dt": 1e-4, "t_end": 0.05, "integrator": "adaptive", "rtol": 1e-6,
                        "atol": 1e-8, "order": 3, "generated": False,
                        "joint_limits": "hard-stop", "regulators": {"turn": "pid ..."}},
           "run": {"t_end": 0.03, "dt": 1e-4, "drives": True, "payload": None}}
    s = stored_spec(tmp_path, doc)
    assert (s.t_end, s.every, s.integrator, s.rtol, s.use_generated, s.joint_limits) == \
        (0.03, 1, "adaptive", 1e-6, False, "hard-stop")
    assert s.regulators == (str(inputs / "regulator.yaml"),)
    with pytest.raises(InputError, match="run.dt: missing; cannot re-run"):
        stored_spec(tmp_path, {"run": {"t_end": 0.03}})
