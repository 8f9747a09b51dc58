"""The claims maps (study claims): load-ratio arms, the Fig. 3 cell, files, cache, CLI."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

import manipcad
from manipcad.cli import app
from manipcad.errors import InputError, ManipcadError
from manipcad.study import claims as claims_mod
from manipcad.study.claims import arm_with_load_ratio, own_load_ratio, run_claims
from manipcad.study.fig3 import turn_inertia


@pytest.fixture(scope="module")
def arm():
    return manipcad.load_robot("cylindrical")


def test_load_ratio_arms(arm):
    own = own_load_ratio(arm)
    same, info = arm_with_load_ratio(arm, own)
    assert same is arm and info["payload_kg"] == 0.0
    for rho in (1.6, 1.9, 2.2):
        new, info = arm_with_load_ratio(arm, rho)
        d = new.drives[new.joint_index("turn")]
        H = turn_inertia(new)  # measured on the new arm, not taken from info
        got = (d.J * d.ratio**2 + H["max_load"]) / (d.J * d.ratio**2 + H["min_load"])
        assert got == pytest.approx(rho, rel=1e-9)
        assert math.copysign(1, d.ratio) == math.copysign(1, arm.drives[0].ratio)
        assert 0 <= info["payload_kg"] <= claims_mod.MAX_PAYLOAD
    with pytest.raises(ManipcadError, match="needs more than"):
        arm_with_load_ratio(arm, 10.0)
    with pytest.raises(InputError, match="load_ratio"):
        arm_with_load_ratio(arm, 0.5)


@pytest.mark.slow
def test_fig3_cell_files_and_cache(tmp_path, monkeypatch, arm):
    """The cell at speed scale 1 on the light arm is the Fig. 3 experiment: the same
    figures as `study fig3` (to 1e-6: the cells run the general kernels, study fig3 may
    run the robot's generated ones, which agree to about 1e-8); the files have issue 13's
    layout; a rerun computes nothing."""
    from manipcad.study import run_fig3

    monkeypatch.setitem(claims_mod.GRIDS, "quick", {"speed_scale": [1.0], "load_ratio": [None]})
    # one q3 stroke (2π/16 s) and a short step keep the test short; both studies read the
    # same laws (2), so the comparison is unchanged
    from manipcad.study import fig3 as fig3_mod

    monkeypatch.setitem(fig3_mod.LAWS, "duration", 0.4)
    monkeypatch.setattr(claims_mod, "STEP_T_END", 0.15)
    doc = run_claims(tmp_path / "c", workers=1, progress=False)
    for name in ("claims.json", "claims.png", "report.html"):
        assert (tmp_path / "c" / name).is_file()
    on_disk = json.loads((tmp_path / "c" / "claims.json").read_text())
    assert set(on_disk) >= {"arm", "grid", "claims", "saturation", "peak_gripper_speed",
                            "diverged"}
    for c in on_disk["claims"].values():
        assert set(c) >= {"paper", "threshold", "ratio", "holds", "where_it_holds"}
        assert np.shape(c["ratio"]) == (1, 1)
    fig3 = run_fig3(tmp_path / "f", methods=["none_sce", "ace_tf", "ace_de", "lqr", "lqr_gs",
                                             "vss", "asvs"], progress=False,
                    step_t_end=0.15).data
    mx = doc["max_error"][0][0]
    for ours, theirs in (("none_sce", "none_sce"), ("ace_tf_observable", "ace_tf"),
                         ("ace_de", "ace_de"), ("lqr", "lqr"), ("lqr_gs", "lqr_gs")):
        assert mx[ours] == pytest.approx(fig3["max_error"][theirs], rel=1e-6), ours
    rt = doc["rise_time"][0][0]
    assert rt["vss"] == pytest.approx(fig3["rise_time"]["vss"]["min_load"], rel=1e-6)
    assert rt["asvs"] == pytest.approx(fig3["rise_time"]["asvs"]["min_load"], rel=1e-6)
    slide = doc["claims"]["asvs_sliding_rate"]["ratio"][0][0]
    assert slide > 1.0  # the adaptive slope decays faster once sliding (1.25 at this cell)
    assert doc["claims"]["lqr_gs"]["ratio"][0][0] == pytest.approx(
        fig3["max_error"]["lqr"] / fig3["max_error"]["lqr_gs"], rel=1e-6)
    again = run_claims(tmp_path / "c", workers=1, progress=False)
    assert again["settings"]["cells_cached"] == 1 and again["settings"]["cells_computed"] == 0
    assert again["claims"] == doc["claims"]


def test_cli_bad_options(tmp_path):
    runner = CliRunner()
    r = runner.invoke(app, ["study", "claims", "--grid", "huge", "--out", str(tmp_path / "x")])
    assert r.exit_code == 2 and "--grid" in r.output and "Traceback" not in r.output
    r = runner.invoke(app, ["study", "claims", "--arm", "heavy", "--out", str(tmp_path / "x")])
    assert r.exit_code == 2 and "not built" in r.output
