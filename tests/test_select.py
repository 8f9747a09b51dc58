"""Drive selection from the catalogue (manipcad.sizing.select, `manipcad select`).

Optimality is checked by brute force with `size`'s own code path
(:func:`required_drive` on the robot with the candidate put in), independent of
the vectorized evaluation the selection uses.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from typer.testing import CliRunner

import manipcad
import manipcad.sizing.select as S
from manipcad.sizing.limits import JOINT_LIMITS
from manipcad.sizing.requirements import required_drive
from manipcad.trajectories import cosine

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
DT = 4e-3


def _traj(n: int, scale: float = 1.0):
    amp = scale * np.array([0.6, 0.5, 0.4, 0.8, 0.6, 0.8][:n])
    return cosine(amp, [3.0, 2.5, 3.5, 4.0, 4.5, 5.0][:n], 2.0)


def _use(monkeypatch, motors: set[str]):
    """Select from the catalogue's candidates of these motors only; returns their parts."""
    table = S.candidate_table(False).take(np.isin(S.candidate_table(False).motor,
                                                  sorted(motors)))
    monkeypatch.setattr(S, "TABLE_SOURCE", lambda prismatic=False, ws=None: table)
    return [table.part(i) for i in range(len(table))]


@pytest.fixture
def small_catalogue(monkeypatch):
    """Two maxon brushless motors of the MGDB (MM_614949: 24 V, 0.36 kg; MM_402687: 48 V,
    0.14 kg), each direct and with every gear the catalogue pairs with it."""
    return _use(monkeypatch, {"MM_614949", "MM_402687"})


def test_arrays_are_the_library_drives():
    """The candidate arrays hold the numbers of the Drive the parts library composes
    for each pair (manipcad.catalog.drive_fields), and rating_table's ratings."""
    from manipcad.sizing.limits import rating_table

    t = S.candidate_table(False)
    rng = np.random.default_rng(1)
    rows = np.concatenate([rng.choice(len(t), 150, replace=False),
                           np.flatnonzero(t.gear_type == "harmonic")[:25],
                           np.flatnonzero(t.gear_type == "direct")[:25]])
    for i in rows:
        d = t.drive_of(i)
        rated, geared = rating_table((d,))
        assert geared[0] == t.geared[i]
        for k, v in rated.items():
            assert t.rated[k][i] == pytest.approx(v[0], rel=1e-12, nan_ok=True), (t.label(i), k)
        for k in ("J", "ratio", "k_v", "R", "L", "k_m", "k_w", "efficiency"):
            assert getattr(t.arrays, k)[i, 0] == pytest.approx(float(getattr(d, k)), rel=1e-12,
                                                             nan_ok=True), (t.label(i), k)
        assert (t.arrays.M_f[0][i, 0], t.arrays.M_f[1][i, 0]) == d.M_f
    assert len(S.candidate_table(True)) >= 1 and not (S.candidate_table(True).gear == "").any()


def _feasible_by_size(robot, j, drive, masses, trajs, payloads, need):
    """Brute force: joint j with ``drive`` passes size's checks with the margin on
    every case (``masses``: the other drives' masses, joint -> kg)."""
    drives = list(robot.drives)
    drives[j] = drive
    arm = S.with_drive_masses(robot, masses).replace(drives=tuple(drives))
    for tr in trajs:
        for p in payloads:
            req = required_drive(arm, tr, dt=DT, payload=p)
            for name, c in req.checks.items():
                st, m = c.status[j], c.margin[j]
                if st == "n/a" or name in JOINT_LIMITS:   # the trajectory's limits, not
                    continue                               # the drive's (PUMA q3 0.8 rad)
                if st != "pass" or m < need:
                    return False
    return True


@pytest.mark.parametrize("objective", ["mass", "rotor_inertia"])
def test_no_single_swap_improves(small_catalogue, objective):
    """Every chosen drive is feasible by size's checks, and every candidate with a
    smaller objective on that joint fails them (the others kept): the optimum."""
    arm = manipcad.load_robot("puma560").without_drives()
    trajs = [_traj(6), _traj(6, 0.5)]
    sel = S.select_drives(arm, trajs, payload_range=(0.0, 1.0), joints=[0, 1, 2],
                          objective=objective, margin=1.2, dt=DT)
    need = 1.0 - 1.0 / 1.2
    masses = {c.index: c.chosen.part.mass for c in sel.joints}
    checked = 0
    for c in sel.joints:
        assert c.chosen.feasible and c.feasible >= 1 and c.considered == len(small_catalogue)
        assert _feasible_by_size(arm, c.index, c.chosen.part.drive, masses, trajs, (0.0, 1.0),
                                 need)
        value = c.chosen.objective
        for p in small_catalogue:
            obj = (p.mass if objective == "mass" else p.drive.J * p.drive.ratio ** 2)
            if not obj < value or not math.isfinite(p.mass):   # no mass: cannot load the arm
                continue
            checked += 1
            assert not _feasible_by_size(arm, c.index, p.drive, masses, trajs, (0.0, 1.0),
                                         need), (c.joint, p.label)
        # the report lists the lighter ones as rejected with a reason
        assert all(r.reason and not r.feasible and r.objective <= value for r in c.rejected)
        assert all(a.feasible and a.objective >= value for a in c.alternatives)
    assert checked > 0


def test_vectorized_requirements_equal_size(small_catalogue):
    """The per-candidate worst-case requirements are size's numbers (required_drive
    with the candidate put in), for candidates evaluated on the motor model."""
    arm = manipcad.load_robot("puma560").without_drives()
    trajs = [_traj(6)]
    motions = [S.sample_motion(arm, trajs[0], dt=DT, payload=0.5)]
    table = S.candidate_table(False)
    idx = np.arange(len(table))
    ev = S._evaluate_joint(table, idx, motions, 1, 0.0, False, "mass")
    done = np.flatnonzero(ev.evaluated)
    assert ev.bounded.any() and (~ev.bounded[done]).any()
    for k in np.concatenate([done[~ev.bounded[done]][:5], done[ev.bounded[done]][:5]]):
        drives = list(arm.drives)
        drives[1] = table.part(k).drive
        req = required_drive(arm.replace(drives=tuple(drives)), trajs[0], dt=DT, payload=0.5)
        for name, c in ev.checks.items():
            want = req.checks[name]
            assert c.status[k] == want.status[1] or (
                c.status[k] == "unknown" and want.status[1] in ("unknown", "fail")), name
            if math.isfinite(want.required[1]) and not (
                    name in ("continuous", "peak", "voltage")
                    and math.isnan(table.part(k).drive.efficiency)):   # size: a bound there
                if ev.bounded[k] and name in ("continuous", "peak", "voltage"):
                    # ruled out on part of the samples: a lower bound that already fails
                    assert c.required[k] <= want.required[1] * (1 + 1e-12), name
                else:
                    assert c.required[k] == pytest.approx(want.required[1], rel=1e-9), name
        if ev.bounded[k]:       # ruled out by a bound: size fails it too
            assert any(req.checks[n].status[1] == "fail" for n in ("continuous", "peak",
                                                                   "voltage"))


def test_fixed_point_of_drive_masses(small_catalogue):
    """Distal drive masses load the proximal joints: the result is a fixed point —
    each joint re-selected alone with the others' masses on the arm keeps its choice —
    and the robot carries each drive's mass on the link before its joint."""
    arm = manipcad.load_robot("puma560").without_drives()
    trajs = [_traj(6)]
    sel = S.select_drives(arm, trajs, payload=1.0, joints=[0, 1, 2, 3], margin=1.0, dt=DT)
    assert sel.iterations >= 2 and sel.history[-1] == sel.history[-2] and sel.verified
    masses = {c.index: c.chosen.part.mass for c in sel.joints}
    added = sel.robot.mass - arm.mass
    for c in sel.joints:
        body = int(arm.parent[c.index])
        expect = sum(m for k, m in masses.items() if int(arm.parent[k]) == body)
        if body >= 0:
            assert added[body] == pytest.approx(expect, abs=1e-12)
            assert c.mount_link == arm.link_names[body]
    assert added[3] == pytest.approx(0.0, abs=1e-12)   # joint 4's link carries no drive
    for c in sel.joints:
        others = {k: m for k, m in masses.items() if k != c.index}
        alone = S.select_drives(S.with_drive_masses(arm, others), trajs, payload=1.0,
                                joints=[c.index], margin=1.0, dt=DT)
        assert alone.joints[0].chosen.part == c.chosen.part
    # without the drive masses the proximal joints would see a lighter arm
    light = S._evaluate_joint(S.candidate_table(False), np.arange(len(S.candidate_table(False))),
                              [S.sample_motion(arm, trajs[0], dt=DT, payload=1.0)], 1, 0.0,
                              False, "mass")
    heavy = S._evaluate_joint(S.candidate_table(False), np.arange(len(S.candidate_table(False))),
                              [S.sample_motion(S.with_drive_masses(arm, others), trajs[0],
                                               dt=DT, payload=1.0)], 1, 0.0, False, "mass")
    assert heavy.checks["gear_continuous"].required[0] > light.checks[
        "gear_continuous"].required[0]


def test_base_mount_loads_nothing():
    arm = manipcad.load_robot("puma560").without_drives()
    same = S.with_drive_masses(arm, {2: 3.0}, {2: "base"})
    assert (same.mass == arm.mass).all()
    with pytest.raises(manipcad.errors.InputError, match="mount"):
        S.with_drive_masses(arm, {2: 3.0}, {2: "after"})


def test_infeasible_names_joint_candidate_and_check(monkeypatch, tmp_path):
    """No feasible drive: NoFeasibleDrive naming the joint, the closest candidate and
    the check it fails; the CLI exits 1 with that message and writes nothing."""
    _use(monkeypatch, {"maxon_ec45flat_411812"})
    arm = manipcad.load_robot("puma560").without_drives()
    with pytest.raises(S.NoFeasibleDrive) as err:
        S.select_drives(arm, [_traj(6)], payload=2.0, joints=[1], dt=DT)
    e = err.value
    assert e.joint == arm.joint_names[1] and e.closest is not None and e.check
    c = e.closest["checks"][e.check]
    assert c["status"] in ("fail", "unknown") or c["margin"] < 1 - 1 / S.DEFAULT_MARGIN
    assert e.joint in str(e) and e.closest["label"] in str(e) and e.check in str(e)
    traj = tmp_path / "t.yaml"
    from manipcad.trajectories import save_trajectory
    save_trajectory(_traj(6), traj)
    robot = tmp_path / "arm.yaml"
    manipcad.save_robot(arm, robot)
    out = tmp_path / "out.yaml"
    from manipcad.cli import app
    res = CliRunner().invoke(app, ["select", str(robot), "-t", str(traj), "--payload", "2",
                                   "--joints", "2", "--dt", str(DT), "--out", str(out)])
    assert res.exit_code == 1, res.output
    assert e.joint in res.output and e.closest["label"] in res.output and e.check in res.output
    assert not out.exists()


def test_bad_arguments():
    arm = manipcad.load_robot("puma560").without_drives()
    Err = manipcad.errors.InputError
    with pytest.raises(Err, match="objective"):
        S.select_drives(arm, [_traj(6)], objective="cost")
    with pytest.raises(Err, match="margin"):
        S.select_drives(arm, [_traj(6)], margin=0.9)
    with pytest.raises(Err, match="makers"):
        S.select_drives(arm, [_traj(6)], makers=["nobody"])
    with pytest.raises(Err, match="not both"):
        S.select_drives(arm, [_traj(6)], payload=1.0, payload_range=(0, 1))


@pytest.mark.parametrize("which", ["ur5", "panda"])
def test_examples_select_then_size_passes(which, tmp_path):
    """`select` on the bare example arm (URDF + payload, no drives) writes a robot
    file that loads and that `size` passes (exit 0), at both payload ends."""
    from manipcad.cli import app
    runner = CliRunner()
    out = tmp_path / f"{which}.yaml"
    pick = EXAMPLES / which / "pick.yaml"
    res = runner.invoke(app, ["select", str(EXAMPLES / which / f"{which}_bare.yaml"), "-t",
                              str(pick), "--payload-range", "0,0.5", "--out", str(out),
                              "--dt", "2e-3", "--json"])
    assert res.exit_code == 0, res.output
    doc = json.loads(res.output)
    assert doc["ok"] and doc["verified"] and doc["iterations"] >= 2
    assert len(doc["joints"]) == manipcad.load_robot(out).n
    for payload in ("0", "0.5"):
        res = runner.invoke(app, ["size", str(out), "-t", str(pick), "--payload", payload])
        assert res.exit_code == 0, res.output


def test_ui_logic_selects_and_saves(tmp_path):
    """The web application's call: the workspace trajectory in, the robot with the chosen
    drives saved as a workspace robot, the report rows out."""
    from manipcad.trajectories import save_trajectory
    from manipcad.ui import logic

    w = logic.open_workspace(tmp_path / "ws")
    arm = manipcad.load_robot("puma560").without_drives()
    save_trajectory(_traj(6, 0.5), tmp_path / "move.yaml")
    w.add(tmp_path / "move.yaml", kind="trajectories", name="move")
    sel, item = logic.select_drives_for(w, arm, "move", payload_range=(0.0, 0.5),
                                        makers="maxon", gear_types="harmonic, direct",
                                        name="puma-sel")
    assert item.ref == "robots/puma-sel" and sel.verified
    saved = logic.load_robot_ref(w, item.ref)[0]
    assert [d.name for d in saved.drives] == [c.chosen.part.motor for c in sel.joints]
    rows = logic.selection_rows(sel)
    assert [r["joint"] for r in rows] == list(arm.joint_names)
    assert all(r["chosen"] == c.chosen.label for r, c in zip(rows, sel.joints, strict=True))
    alts = logic.alternative_rows(sel)
    assert {a["kind"] for a in alts} <= {"alternative", "rejected"} and alts
    assert all(c.chosen.part.maker == "maxon" and c.chosen.part.gear_type in
               ("harmonic", "direct") for c in sel.joints)


def test_drives_page_selects_automatically(tmp_path):
    """The Drives page's "select automatically": the form's filters, the report tables,
    the saved robot made the current one; a bad payload range names the field."""
    from nicegui import ui
    from test_ui import _error, _field, _open, _simulate_user

    from manipcad.ui import pages

    async def script(user):
        await _open(user, "/trajectories")
        user.find(kind=ui.input, content="duration").clear().type("2")
        user.find("Save to workspace").click()
        await user.should_see("saved trajectories/move")
        await _open(user, "/drives")
        _field(user, ui.input, "payload range LO, HI [kg]").value = "1"
        user.find("Select the drives automatically").click()
        assert "payload range" in await _error(user)
        _field(user, ui.input, "payload range LO, HI [kg]").value = "0, 0.5"
        _field(user, ui.input, "makers (e.g. maxon, faulhaber)").value = "maxon"
        _field(user, ui.input, "gear types (e.g. planetary, harmonic, direct)").value = \
            "harmonic, direct"
        user.find("Select the drives automatically").click()
        await user.should_see("saved robots/puma560-selected", retries=600)
        with user:
            assert pages.state()["robot"] == "robots/puma560-selected"
        (table,) = user.find(marker="select-table").elements
        assert len(table.rows) == 6 and all(r["candidates"] for r in table.rows)

    _simulate_user(tmp_path / "ws", script)


def test_drive_mounts_from_the_robot_file(tmp_path, monkeypatch):
    """A robot file's drive_mounts override the convention: a drive mounted on the base
    loads no link; the selected robot's file keeps the mounts and loads back; an unknown
    joint is refused naming the field."""
    _use(monkeypatch, {"MM_614949", "MM_402687"})
    text = (EXAMPLES / "ur5" / "ur5_bare.yaml").read_text()
    text = text.replace("urdf: ur5_robot.urdf", f"urdf: {EXAMPLES / 'ur5' / 'ur5_robot.urdf'}")
    path = tmp_path / "ur5_mounts.yaml"
    path.write_text(text + "drive_mounts: {wrist_2_joint: base}\n")
    arm = manipcad.load_robot(path)
    assert arm.drive_mounts == (("wrist_2_joint", "base"),)
    pick = manipcad.load_trajectory(EXAMPLES / "ur5" / "pick.yaml", robot=arm)
    sel = S.select_drives(arm, [pick], joints=["wrist_2_joint", "wrist_3_joint"], dt=DT,
                          margin=1.0)
    added = sel.robot.mass - arm.mass
    w2, w3 = arm.joint_index("wrist_2_joint"), arm.joint_index("wrist_3_joint")
    assert added[int(arm.parent[w2])] == pytest.approx(0.0, abs=1e-12)          # on the base
    assert added[int(arm.parent[w3])] == pytest.approx(sel.joints[1].chosen.part.mass)
    assert sel.joints[0].mount == "base" and sel.joints[0].mount_link == ""
    out = S.save_selection(sel, tmp_path / "sel.yaml")
    again = manipcad.load_robot(out)
    assert again.drive_mounts == arm.drive_mounts
    assert np.array_equal(again.mass, sel.robot.mass)
    path.write_text(text + "drive_mounts: {no_such_joint: base}\n")
    with pytest.raises(manipcad.errors.InputError, match="drive_mounts.no_such_joint"):
        manipcad.load_robot(path)


def test_power_objective_and_complete_counts(small_catalogue):
    """objective power: the winner has the least mean electrical power among the feasible
    candidates (every one evaluated); count_all gives the same choice as the search in
    objective order, with complete counts (nothing skipped)."""
    arm = manipcad.load_robot("puma560").without_drives()
    trajs = [_traj(6, 0.5)]
    sel = S.select_drives(arm, trajs, joints=[2], objective="power", margin=1.0, dt=DT)
    c = sel.joints[0]
    assert c.skipped == 0 and c.chosen.objective > 0
    ev = S._evaluate_joint(S.candidate_table(False), np.arange(len(small_catalogue)),
                           [S.sample_motion(S.with_drive_masses(arm, {}), trajs[0], dt=DT,
                                            payload=0.0)], 2, 0.0, False, "power")
    assert c.feasible == int(ev.ok.sum())
    assert c.chosen.objective == pytest.approx(float(np.min(ev.objective[ev.ok])), rel=1e-12)
    lazy = S.select_drives(arm, trajs, joints=[2], margin=1.0, dt=DT)
    full = S.select_drives(arm, trajs, joints=[2], margin=1.0, dt=DT, count_all=True)
    assert lazy.joints[0].chosen.part == full.joints[0].chosen.part
    assert [a.label for a in lazy.joints[0].alternatives] == [
        a.label for a in full.joints[0].alternatives]
    assert full.joints[0].skipped == 0 and full.joints[0].feasible >= lazy.joints[0].feasible


def test_candidate_table_follows_a_replaced_source(monkeypatch):
    """Each new table source gets its own table, also when the one before it was freed:
    keyed by ``id(source)``, a freed source's address was reused by the next (198 stale
    tables in 200 swaps), so a test selecting from one motor could be handed the previous
    test's candidates (test_infeasible_names_joint_candidate_and_check, order-dependent)."""
    monkeypatch.setattr(S, "_TABLES", {})
    original = S.TABLE_SOURCE
    monkeypatch.setattr(S, "TABLE_SOURCE", original)  # restored after the test

    def source_of(marker):
        return lambda prismatic=False, ws=None: marker

    for _ in range(50):  # assigned directly: nothing else keeps a replaced source alive
        marker = object()
        S.TABLE_SOURCE = source_of(marker)
        assert S.candidate_table(False) is marker
        S.TABLE_SOURCE = original
