"""The Fig. 3 study harness (manipcad.study.run_fig3, `manipcad study fig3`).

Short horizons (0.2 s of laws (2), 0.15 s steps): the test checks the harness
(files, keys, that every number is a metric of a run it made, skips, atomic
writing, CLI), not the paper's claims, which need the full 1.6 s run.
"""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

import manipcad
from manipcad.control import realization_complexity
from manipcad.errors import InputError
from manipcad.sim import simulate
from manipcad.study import fig3 as fig3_mod
from manipcad.study import run_fig3

T_END, STEP_T_END, DT = 0.2, 0.15, 1e-4
TRACK = [v.label for v in fig3_mod.TRACKING]
STEP = [v.label for v in fig3_mod.STEPS]


@pytest.fixture(scope="module")
def study(tmp_path_factory):
    out = tmp_path_factory.mktemp("fig3") / "out"
    return run_fig3(out, dt=DT, t_end=T_END, step_t_end=STEP_T_END, progress=False)


def test_writes_three_files_with_required_keys(study):
    out = study.out_dir
    assert sorted(p.name for p in out.iterdir()) == ["fig3.json", "fig3.png", "report.html"]
    assert (out / "fig3.png").read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"
    data = json.loads((out / "fig3.json").read_text(encoding="utf-8"))
    assert data == study.data
    for key in ("max_error", "rms_error", "rise_time", "overshoot", "complexity", "arm",
                "skipped", "claims", "settings", "units"):
        assert key in data, key
    assert data["units"]["max_error"] == "rad" and data["units"]["rise_time"] == "s"
    assert data["settings"]["t_end"] == T_END and data["settings"]["dt"] == DT
    # every method either ran or is listed as skipped with a reason
    for lab in TRACK:
        assert (lab in data["max_error"]) != (lab in data["skipped"]), lab
    for lab in STEP:
        assert (lab in data["rise_time"]) != (lab in data["skipped"]), lab
    # each tracking run judged against every rating of the turn drive (docs/checks.md)
    for lab in data["max_error"]:
        c = data["checks"][lab]
        assert c["verdict"] in ("pass", "fail", "unknown") and "saturation" in c["checks"]
        assert (c["verdict"] == "fail") == bool(c["failed"])
    # on the Fig. 2 arm every method runs: a study where everything was skipped must fail
    assert not data["skipped"], data["skipped"]
    for lab, why in data["skipped"].items():
        assert isinstance(why, str) and len(why) > 10, lab
    # no temporary directory left next to the output
    assert [p.name for p in out.parent.iterdir()] == ["out"]


def test_json_values_are_the_runs_metrics(study):
    data = study.data
    assert set(study.tracking) == set(data["max_error"]) == set(data["rms_error"])
    for lab, res in study.tracking.items():
        m = res.metrics["turn"]
        assert data["max_error"][lab] == m["max_error"]
        assert data["rms_error"][lab] == m["rms_error"]
        assert m["max_error"] == float(np.abs(res.error[:, 0]).max())
        assert res.t[-1] == pytest.approx(T_END)
        for j in ("reach", "lift"):
            assert data["other_joints"][lab][j]["max_error"] == res.metrics[j]["max_error"]
    for lab, cases in study.steps.items():
        assert set(cases) == {"min_load", "max_load"}
        for case, res in cases.items():
            for key in ("rise_time", "overshoot", "settling_time"):
                v = res.metrics["turn"][key]
                assert data[key][lab][case] == (v if math.isfinite(v) else None)
            # the reach was held where the case says
            q3 = fig3_mod.STEP_CASES[case]
            assert res.q[0, 2] == q3 and res.q_ref[-1, 0] == pytest.approx(0.1)


def test_a_run_reproduces_independently(study):
    """Re-simulating one method from its parts gives the JSON's number exactly."""
    data = study.data
    lab = next(iter(data["max_error"]))
    v = {x.label: x for x in fig3_mod.TRACKING}[lab]
    arm = manipcad.load_robot("cylindrical")
    period = fig3_mod.control_period(DT)
    from manipcad.control import synthesize

    reg = synthesize(arm, "turn", v.method, period=period, **v.options)
    assert data["complexity"][lab] == json.loads(json.dumps(realization_complexity(reg)))
    traj = manipcad.trajectories.cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], 1.6)
    res = simulate(arm, t_end=T_END, dt=DT, trajectory=traj,
                   regulators=[reg, *fig3_mod.support_regulators(arm, period)])
    assert res.metrics["turn"]["max_error"] == data["max_error"][lab]


def test_arm_parameters_and_claims(study):
    data = study.data
    arm = manipcad.load_robot("cylindrical")
    joints = data["arm"]["joints"]
    assert [j["name"] for j in joints] == list(arm.joint_names)
    for j, jt in enumerate(joints):
        assert jt["mass"] == arm.mass[j]
        assert jt["drive"]["ratio"] == arm.drives[j].ratio and jt["drive"]["J"] == arm.drives[j].J
    load = data["arm"]["turn_load"]
    H = [manipcad.mass_matrix(arm, np.array([0.0, 0.0, q3]), drives=False)[0, 0]
         for q3 in (0.0, 0.5)]
    assert load["H_11_min"] == H[0] and load["H_11_max"] == H[1]
    assert {c["id"] for c in data["claims"]} == {"ace_tf_vs_none", "ace_de_vs_ace_tf",
                                                  "asvs_vs_vss", "lqr_gs_vs_lqr"}
    for c in data["claims"]:
        assert c["verdict"] in ("holds", "holds (larger gain than claimed)", "partly",
                                "does not hold", "not measured")
    c = {c["id"]: c for c in data["claims"]}["lqr_gs_vs_lqr"]
    if c["ratio"] is not None:
        assert c["ratio"] == data["max_error"]["lqr"] / data["max_error"]["lqr_gs"]


def test_report_is_self_contained(study):
    html = (study.out_dir / "report.html").read_text(encoding="utf-8")
    assert html.startswith("<!DOCTYPE html>")
    assert html.count('src="data:image/png;base64,') == 1
    assert "http://" not in html and "https://" not in html and "<script" not in html
    for c in study.data["claims"]:
        assert c["section"] in html
    for lab in study.data["max_error"]:
        assert f"<td>{lab}</td>" in html
    assert "maxon_re65_353297" in html        # the arm's parameters are stated


def test_skipped_methods_are_recorded(tmp_path, monkeypatch):
    """A method whose synthesis raises is skipped with the reason; nothing is made up."""
    from manipcad.study import fig3 as synthesis  # the study's own name for synthesize

    real = synthesis.synthesize

    def fake(robot, joint, method, **kw):
        if method == "lqr_gs":
            raise NotImplementedError("gain tables not written yet")
        if method == "asvs":
            raise manipcad.ManipcadError("spec unreachable")
        return real(robot, joint, method, **kw)

    monkeypatch.setattr(synthesis, "synthesize", fake)
    res = run_fig3(tmp_path / "o", dt=DT, t_end=0.05, step_t_end=0.05, progress=False,
                   methods=["lqr", "lqr_gs", "vss", "asvs"])
    d = res.data
    assert "NotImplementedError: gain tables not written yet" in d["skipped"]["lqr_gs"]
    assert "ManipcadError: spec unreachable" in d["skipped"]["asvs"]
    assert "lqr_gs" not in d["max_error"] and "asvs" not in d["rise_time"]
    assert set(d["max_error"]) == {"lqr"} and set(d["rise_time"]) == {"vss"}
    claims = {c["id"]: c for c in d["claims"]}
    assert claims["lqr_gs_vs_lqr"]["verdict"] == "not measured"
    assert claims["asvs_vs_vss"]["verdict"] == "not measured"
    assert "gain tables not written yet" in (tmp_path / "o" / "report.html").read_text()


def test_rewrites_existing_directory_keeping_other_files(tmp_path):
    out = tmp_path / "o"
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    (out / "fig3.json").write_text("old")
    run_fig3(out, dt=DT, t_end=0.02, progress=False, methods=["none"])
    assert (out / "notes.txt").read_text() == "mine"
    assert json.loads((out / "fig3.json").read_text())["settings"]["t_end"] == 0.02
    assert sorted(p.name for p in tmp_path.iterdir()) == ["o"]


@pytest.mark.parametrize("kwargs, match", [
    ({"dt": 0.0}, "dt"), ({"dt": 1.0}, "dt"), ({"methods": ["wobble"]}, "unknown study"),
    ({"t_end": -1.0}, "t_end"), ({"step": 0.0}, "step"),
])
def test_bad_arguments(tmp_path, kwargs, match):
    with pytest.raises(InputError, match=match):
        run_fig3(tmp_path / "o", progress=False, **kwargs)
    with pytest.raises(InputError, match="does not exist"):
        run_fig3(tmp_path / "no" / "o", progress=False)
    assert list(tmp_path.iterdir()) == []


def test_cli(tmp_path):
    from manipcad.cli import app

    runner = CliRunner()
    res = runner.invoke(app, ["study", "fig3", "--out", str(tmp_path / "o"), "--t-end", "0.02",
                              "--methods", "none,vss", "--no-progress"])
    assert res.exit_code == 0, res.output
    assert "max |ε|" in res.stdout and "wrote" in res.stdout
    assert sorted(p.name for p in (tmp_path / "o").iterdir()) == [
        "fig3.json", "fig3.png", "report.html"]
    for bad in (["--dt", "0"], ["--methods", "nope"]):
        res = runner.invoke(app, ["study", "fig3", "--out", str(tmp_path / "p"), *bad])
        assert res.exit_code == 2 and "Traceback" not in res.output
        assert not (tmp_path / "p").exists()
