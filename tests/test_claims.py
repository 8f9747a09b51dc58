"""The claims maps (study claims): load-ratio arms, the Fig. 3 cell, files, cache, CLI."""

from __future__ import annotations

import json
import math

import numpy as np
import pytest
from typer.testing import CliRunner

import manipcad
from manipcad.cli import app
from manipcad.errors import InputError
from manipcad.study import claims as claims_mod
from manipcad.study.claims import arm_with_load_ratio, own_load_ratio, run_claims


@pytest.fixture(scope="module")
def arm():
    return manipcad.load_robot("cylindrical")


def test_load_ratio_arms(arm):
    own = own_load_ratio(arm)
    same, info = arm_with_load_ratio(arm, own)
    assert same is arm and info["payload_kg"] == 0.0 and info["reached"]
    for rho in (1.6, 2.2, 5.0):
        new, info = arm_with_load_ratio(arm, rho)
        d = new.drives[new.joint_index("turn")]
        lo, hi = claims_mod.turn_load_range(new, info["stroke_m"])  # measured on the new arm
        got = (d.J * d.ratio**2 + hi) / (d.J * d.ratio**2 + lo)
        assert got == pytest.approx(rho, rel=1e-9) and info["reached"]
        assert math.copysign(1, d.ratio) == math.copysign(1, arm.drives[0].ratio)
        assert 0 <= info["payload_kg"] <= claims_mod.MAX_PAYLOAD
    # 5: the payload alone is not enough, the reach stroke is moved in and lengthened
    assert info["payload_kg"] == claims_mod.MAX_PAYLOAD and 0.5 < info["stroke_m"] < 1.0
    assert new.limits[new.joint_index("reach"), 1] >= info["stroke_m"]
    assert not info["over_rated"]
    # 10: the rated 2 kg and the stroke at its end give H_max/H_min = 7.56 (the rotor can
    # only lower ρ): a payload above the rated one (3.65 kg), the laws slowed to what the
    # sizing passes
    new, info = arm_with_load_ratio(arm, 10.0)
    assert info["reached"] and info["over_rated"] and info["stroke_m"] == claims_mod.STROKE_MAX
    assert claims_mod.MAX_PAYLOAD < info["payload_kg"] < claims_mod.OVERLOAD_MAX * 2.0
    d = new.drives[new.joint_index("turn")]
    lo, hi = claims_mod.turn_load_range(new, info["stroke_m"])
    assert (d.J * d.ratio**2 + hi) / (d.J * d.ratio**2 + lo) == pytest.approx(10.0, rel=1e-9)
    s_run, fails = claims_mod.feasible_speed_scale(new, 1.0, info["stroke_m"])
    assert fails and 0.2 < s_run < 1.0  # sized feasible, time-scaled (0.342)
    # without the over-rated payload the arm at the levers' ends, the ratio it gets, said
    new, info = arm_with_load_ratio(arm, 10.0, max_payload=2.0 / claims_mod.OVERLOAD_MAX)
    assert not info["reached"] and 5.0 < info["load_ratio"] < 10.0
    with pytest.raises(InputError, match="load_ratio"):
        arm_with_load_ratio(arm, 0.5)
    with pytest.raises(InputError, match="max_payload"):
        arm_with_load_ratio(arm, 2.0, max_payload=-1.0)


def test_presets_sized_and_time_scaled():
    """The industrial and heavy presets: catalog parts only, heavier than the light arm as
    the issue asks, reach a load ratio of 10 (heavy), and laws (2) time-scaled to what the
    sizing module passes."""
    light = manipcad.load_robot("cylindrical")
    for name, extra, payload in (("industrial", 3.0, 2.0), ("heavy", 5.0, 5.0)):
        robot_name, max_payload = claims_mod.ARMS[name]
        assert max_payload == payload
        r = manipcad.load_robot(robot_name)
        k = r.joint_index("reach")
        assert r.mass[k] - light.mass[k] == pytest.approx(extra, abs=0.5)
        assert abs(r.drives[0].gear_rated_torque) > abs(light.drives[0].gear_rated_torque)
        loaded = r.with_payload(payload, np.asarray(r.tool_p), link="reach")
        assert claims_mod.sizing_failures(loaded, 1.0)  # full speed: over the limits
        s_run, fails = claims_mod.feasible_speed_scale(loaded, 1.0)
        assert fails and s_run is not None and 0.1 < s_run < 1.0
        assert claims_mod.sizing_failures(loaded, s_run) == []
        assert claims_mod.sizing_failures(loaded, 1.05 * s_run)  # the largest, to 1 %
    heavy = manipcad.load_robot(claims_mod.ARMS["heavy"][0])
    assert abs(heavy.drives[k].ratio) > 4 * abs(light.drives[k].ratio)  # extra reduction
    new, info = arm_with_load_ratio(heavy, 10.0, max_payload=5.0)
    assert info["reached"] and info["load_ratio"] == pytest.approx(10.0, rel=1e-9)


def test_cell_plan_reuses_the_rows_arm(arm):
    """A cell planned with its row's arm as size_row returned it (pickled, as from a
    worker) has the same runs, arm and all, as one that computes the arm again."""
    import pickle

    from manipcad.parallel import task_key

    row = pickle.loads(pickle.dumps(claims_mod.size_row(
        arm=arm, load_ratio=5.0, max_payload=2.0, speed_scales=[0.5, 1.0])))
    assert row["arm"] == arm_with_load_ratio(arm, 5.0, max_payload=2.0)[1]
    kw = {"speed_scale": 0.5, "load_ratio": 5.0, "arm": arm, "dt": 1e-4, "max_payload": 2.0}
    again = claims_mod.cell_plan(**kw)
    reused = claims_mod.cell_plan(**kw, row=(row["robot"], row["arm"]))
    assert task_key(pow, {"plan": reused}) == task_key(pow, {"plan": again})
    other = claims_mod.cell_plan(**{**kw, "load_ratio": 2.5})
    assert task_key(pow, {"plan": other}) != task_key(pow, {"plan": again})


@pytest.mark.slow
def test_fig3_cell_files_and_cache(tmp_path, monkeypatch, arm, dask_scheduler):
    """The cell at speed scale 1 on the light arm is the Fig. 3 experiment: the same
    figures as `study fig3` (to 1e-6: the cells run the general kernels, study fig3 may
    run the robot's generated ones, which agree to about 1e-8); the files have the
    study's layout; a rerun computes nothing; on a 2-worker cluster (the cell's runs spread over
    the workers, the rows sized and the figure's panels drawn there) the results and the
    figure are identical."""
    from manipcad.study import run_fig3

    monkeypatch.setitem(claims_mod.GRIDS, "quick", {"speed_scale": [1.0], "load_ratio": [None]})
    # one q3 stroke (2π/16 s) and a short step keep the test short; both studies read the
    # same laws (2), so the comparison is unchanged
    from manipcad.study import fig3 as fig3_mod

    monkeypatch.setitem(fig3_mod.LAWS, "duration", 0.4)
    monkeypatch.setattr(claims_mod, "STEP_T_END", 0.15)
    shown = []  # the progress callable: fractions of the cells done, up to 1
    doc = run_claims(tmp_path / "c", workers=1, progress=shown.append)
    assert shown and shown == sorted(shown) and shown[-1] == 1.0
    for name in ("claims.json", "claims.png", "report.html"):
        assert (tmp_path / "c" / name).is_file()
    on_disk = json.loads((tmp_path / "c" / "claims.json").read_text())
    assert set(on_disk) >= {"arm", "grid", "claims", "saturation", "peak_gripper_speed",
                            "diverged"}
    # every claim the issue lists, with its paper words, threshold, ratio, verdict, sentence
    assert set(on_disk["claims"]) == {
        "ace_tf_observable", "ace_tf_controllable", "law3", "law3_no_friction", "asvs_rise",
        "asvs_sliding_rate", "asvs_overshoot", "vss_light_overshoot", "lqr_gs",
        "lqr_gs_gains_only", "lqr_gs_feedforward", "lqr_equal_information"}
    for c in on_disk["claims"].values():
        assert set(c) >= {"paper", "threshold", "ratio", "holds", "where_it_holds"}
        assert c["paper"] and isinstance(c["threshold"], float)
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
    eq = doc["claims"]["lqr_equal_information"]["ratio"][0][0]
    assert eq == pytest.approx(mx["lqr_equal_information"] / mx["lqr_gs"], rel=1e-12)
    assert doc["speed_scale_run"] == [[1.0]] and doc["time_scaled"] == [[False]]
    shown.clear()
    dist = run_claims(tmp_path / "d", scheduler=dask_scheduler, progress=shown.append)
    assert shown and shown == sorted(shown) and shown[-1] == 1.0
    assert dist["settings"]["cells_computed"] == 1
    for key in ("claims", "max_error", "rise_time", "sliding_rate", "saturation", "arm"):
        assert dist[key] == doc[key], key
    # the figure's panels drawn in two groups on the workers: the same pixels as drawn whole
    from PIL import Image

    serial_png = np.asarray(Image.open(tmp_path / "c" / "claims.png"))
    dist_png = np.asarray(Image.open(tmp_path / "d" / "claims.png"))
    assert serial_png.shape == dist_png.shape and np.array_equal(serial_png, dist_png)
    assert (serial_png[..., :3] < 128).any()  # not a blank canvas
    again = run_claims(tmp_path / "c", workers=1, progress=False)
    assert again["settings"]["cells_cached"] == 1 and again["settings"]["cells_computed"] == 0
    assert again["claims"] == doc["claims"]


def test_equal_information_lqr_is_the_fixed_lqr(arm):
    """lqr_equal_information: lqr_gs on one table point at the middle of the H_11 range has
    the fixed lqr's gains, and reads the measured H_11, c_1, Q_1 as lqr_gs does."""
    from manipcad.control import synthesize
    from manipcad.control.design import inertia_range

    lo, hi = inertia_range(arm, 0)
    mid = 0.5 * (lo + hi)
    fixed = synthesize(arm, "turn", "lqr")
    eq = synthesize(arm, "turn", "lqr_gs", load_range=(mid, mid))
    gs = synthesize(arm, "turn", "lqr_gs")
    assert fixed.design["H_nominal"] == mid
    np.testing.assert_allclose(eq.design["table"].gains[0, 0], fixed.design["gains"],
                               rtol=1e-12)
    assert set(eq.needs) == set(gs.needs) and {"H_ii", "c_i", "Q_i"} <= set(eq.needs)
    assert claims_mod.RATIOS["lqr_equal_information"] == ("lqr_equal_information", "lqr_gs")


def test_cli_bad_options(tmp_path):
    runner = CliRunner()
    r = runner.invoke(app, ["study", "claims", "--grid", "huge", "--out", str(tmp_path / "x")])
    assert r.exit_code == 2 and "--grid" in r.output and "Traceback" not in r.output
    r = runner.invoke(app, ["study", "claims", "--arm", str(tmp_path / "nope.yaml"), "--out",
                            str(tmp_path / "x")])
    assert r.exit_code == 2 and "nope.yaml" in r.output and "Traceback" not in r.output


def test_warm_worker_freezes_what_it_leaves_alive():
    """A worker's warm-up leaves the imported modules and loaded kernels frozen, so that
    the study's tasks do not scan them in every full collection (a spawned worker of a
    cluster the user runs has nothing frozen from a parent)."""
    import gc

    gc.unfreeze()
    assert gc.get_freeze_count() == 0
    try:
        claims_mod.warm_worker()
        # the modules alone (numpy, numba, matplotlib, manipcad) are far above this
        assert gc.get_freeze_count() > 50_000
    finally:
        gc.unfreeze()


def test_figure_bands_joined_into_one_png(tmp_path):
    """claims.png from groups of panels encoded apart (each group's rows on its worker):
    the pixels of the figure drawn whole, whether the groups' rows are disjoint (bands
    joined, white rows between) or overlap (their minimum encoded); the file says its dpi."""
    from PIL import Image

    from manipcad.report.claims import save_bands
    from manipcad.report.png import encode_rows

    rng = np.random.default_rng(3)
    whole = np.full((40, 7, 4), 255, np.uint8)
    whole[3:15] = rng.integers(0, 256, (12, 7, 4))
    whole[21:37] = rng.integers(0, 256, (16, 7, 4))

    def part(first, stop):  # a group that drew rows first:stop of the figure
        img = np.full_like(whole, 255)
        img[first:stop] = whole[first:stop]
        return {"shape": img.shape, "span": (first, stop),
                "band": encode_rows(img, first, stop), "image": img[first:stop]}

    empty = {"shape": whole.shape, "span": (0, 0), "band": None, "image": whole[:0]}
    for parts in ([part(3, 37)], [part(21, 37), part(3, 15)], [part(3, 15), empty,
                                                                part(21, 37)],
                  [part(3, 25), part(21, 37)]):  # the last two overlap (rows 21-24)
        path = save_bands(parts, tmp_path / "f.png", dpi=100)
        with Image.open(path) as im:
            assert np.array_equal(np.asarray(im), whole)
            assert im.info["dpi"] == pytest.approx((100, 100), abs=1e-3)
    with pytest.raises(ValueError, match="row 0"):
        from manipcad.report.png import write_png

        write_png(tmp_path / "g.png", [encode_rows(whole, 1)])
