"""Bad input, kills and concurrent runs found by a new user and a fault campaign: each
case gives one clear error (or a correct result), never a traceback, a silent wrong
answer, a lost file or a write where none may happen.

Grouped by harm: data lost or written where it must not be, security, silent wrong
answers, tracebacks and wrong messages, what a new user tripped over.
"""

from __future__ import annotations

import json
import os
import re
import stat
from pathlib import Path

import numpy as np
import pytest
import yaml

from manipcad.errors import InputError, ManipcadError

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"


def cli(*args, env=None):
    """Run the CLI in-process: (result, stdout + stderr)."""
    from typer.testing import CliRunner

    from manipcad.cli import app

    res = CliRunner().invoke(app, [str(a) for a in args], env={"COLUMNS": "300", **(env or {})})
    return res, res.output + (res.stderr or "")


def fails_cleanly(res, out: str, *words: str) -> None:
    """Exit status 2, one error line naming ``words``, no traceback."""
    assert res.exit_code == 2, out
    assert "Traceback" not in out, out
    for w in words:
        assert w in out, out


def move(tmp_path: Path, duration: float = 0.05) -> Path:
    """A short quintic move of the PUMA's wrist (a trajectory file)."""
    pose = [0.0, 0.5, -0.5, 0.0, 0.3, 0.0]
    end = list(pose)
    end[3] = 0.05
    p = tmp_path / "move.yaml"
    p.write_text(yaml.safe_dump({"type": "quintic", "q_start": pose, "q_end": end,
                                 "duration": duration}))
    return p


# --------------------------------------------------------------------------- data lost

def test_simulate_force_replaces_only_a_result_folder(tmp_path):
    """--force replaces a folder that holds a manipcad result, never another folder."""
    traj = move(tmp_path)
    thesis = tmp_path / "thesis"
    thesis.mkdir()
    (thesis / "thesis.tex").write_text("\\documentclass{book}\n")
    res, out = cli("simulate", "puma560", "--trajectory", traj, "--regulator",
                   EXAMPLES / "pid_puma.yaml", "--out", thesis, "--t-end", "0.02", "--force")
    fails_cleanly(res, out, "thesis", "not a manipcad result")
    assert (thesis / "thesis.tex").read_text() == "\\documentclass{book}\n"
    # a result folder is replaced
    r1 = tmp_path / "r1"
    args = ("simulate", "puma560", "--trajectory", traj, "--regulator",
            EXAMPLES / "pid_puma.yaml", "--out", r1, "--t-end", "0.02")
    res, out = cli(*args)
    assert res.exit_code == 0, out
    res, out = cli(*args, "--force")
    assert res.exit_code == 0, out
    assert (r1 / "metrics.json").is_file()


def test_save_result_api_refuses_a_user_folder(tmp_path):
    from manipcad.store import check_out_dir

    (tmp_path / "notes.txt").write_text("mine")
    with pytest.raises(InputError, match="not a manipcad result"):
        check_out_dir(tmp_path, force=True)


@pytest.fixture
def fifo(tmp_path) -> Path:
    p = tmp_path / "pipe"
    os.mkfifo(p)
    return p


def _still_fifo(p: Path) -> bool:
    return stat.S_ISFIFO(os.lstat(p).st_mode)


def test_writer_refuses_non_regular_targets(tmp_path, fifo):
    from manipcad.fileio import atomic_write_text, writable_target

    for target in (fifo, Path("/dev/null")):
        with pytest.raises(InputError, match="not a regular file"):
            atomic_write_text(target, "x")
    assert _still_fifo(fifo)
    link = tmp_path / "to_null"
    link.symlink_to("/dev/null")
    with pytest.raises(InputError, match="character device"):
        writable_target(link)
    assert link.is_symlink()
    atomic_write_text(tmp_path / "plain.txt", "ok")  # a regular file still works
    assert (tmp_path / "plain.txt").read_text() == "ok"


def test_cli_and_api_refuse_a_fifo_target(tmp_path, fifo):
    import manipcad
    from manipcad.trajectories import load_trajectory, save_trajectory

    res, out = cli("synthesize", "cylindrical", "--method", "pid", "--all", "--out", fifo,
                   "--force")
    fails_cleanly(res, out, "FIFO")
    assert _still_fifo(fifo)
    traj = move(tmp_path)
    res, out = cli("size", "puma560", "--trajectory", traj, "--plot", fifo)
    fails_cleanly(res, out, "FIFO")
    assert _still_fifo(fifo)
    with pytest.raises(InputError, match="FIFO"):
        save_trajectory(load_trajectory(traj), fifo)
    with pytest.raises(InputError, match="FIFO"):
        manipcad.save_robot(manipcad.load_robot("cylindrical"), fifo)
    assert _still_fifo(fifo)
    folder = tmp_path / "code"
    folder.mkdir()
    os.mkfifo(folder / "cyl.c")
    res, out = cli("codegen", "cylindrical", "--lang", "c", "--out", folder, "--prefix", "cyl")
    fails_cleanly(res, out, "FIFO")
    assert _still_fifo(folder / "cyl.c") and not (folder / "cyl.h").exists()


def _dead_pid() -> int:
    import subprocess
    import sys

    p = subprocess.Popen([sys.executable, "-c", "pass"])
    p.wait()
    return p.pid


def test_workspace_write_removes_leftovers_of_killed_writers(tmp_path):
    """What a SIGKILL of 'simulate --ws --force' or 'ws add FOLDER' leaves (the staging
    folder, the store's folder nested in it, a half-copied file) is removed by the next
    write; a live writer's are kept."""
    from manipcad.workspace import Workspace

    ws = Workspace.init(tmp_path / "ws")
    dead, live = _dead_pid(), os.getpid()
    results = ws.root / "results"
    stale = [results / f".r1.partial-{dead}-ab12cd", results / f"..r1.partial-{dead}-ab12cd"
             f".partial-{dead}-ef34gh", results / f".r2.old-{dead}-x1y2z3"]
    for p in stale:
        p.mkdir()
        (p / "metrics.json").write_text("{}")
    half = ws.root / "trajectories" / f".m.partial-{dead}-q1w2e3"
    half.write_text("type: quin")
    mine = results / f".r3.partial-{live}-zz99zz"
    mine.mkdir()
    ws.add(move(tmp_path))
    assert not half.exists()
    import manipcad
    from manipcad.sim import simulate

    arm = manipcad.load_robot("cylindrical")
    res = simulate(arm, t_end=0.01, dt=1e-3, drives=False, q0=[0.0, 0.3, 0.2])
    ws.store_result(res, name="r9", robot=arm, plot=False)
    assert not any(p.exists() for p in stale) and mine.is_dir()
    assert (results / "r9" / "metrics.json").is_file()


def test_claims_cleans_leftovers_and_a_failed_run_leaves_no_folder(tmp_path, monkeypatch):
    from manipcad.study import claims
    from manipcad.study.claims import run_claims

    def unreachable(*_a, **_k):
        raise InputError("--scheduler", "", "cannot reach tcp://192.0.2.1:8786")

    monkeypatch.setattr(claims, "Pool", unreachable)  # the study's own name for the pool
    out = tmp_path / "claims"
    with pytest.raises(InputError, match="cannot reach"):
        run_claims(out, workers=2, progress=False)
    assert not out.exists()  # made by the failed run, holding no cached cell: removed
    out.mkdir()
    (out / "notes.txt").write_text("mine")
    killed = out / f".claims.partial-{_dead_pid()}-a1b2c3"
    killed.mkdir()
    (killed / "claims.json").write_text("{")
    with pytest.raises(InputError, match="cannot reach"):
        run_claims(out, workers=2, progress=False)
    assert not killed.exists()
    assert (out / "notes.txt").read_text() == "mine"  # a folder it did not make stays


# --------------------------------------------------------------------------- security

EVIL = ('x""";import os;os.system(chr(116));"""'  # would end the numba module's docstring
        ' */ int pwned = 1; /* \\\n@PREFIX@ {x}')    # would end the C comment


def _strip_c_comments(src: str) -> str:

    return re.sub(r"/\*.*?\*/", " ", src, flags=re.S)


def test_robot_name_cannot_inject_code(tmp_path):
    """A robot's name (a URDF's <robot name>) reaches the generated numba module's
    docstring and the C comments as inert text: the module's code holds no statement of
    it, the C (compiled) no symbol of it."""
    import ast
    import shutil
    import subprocess

    import manipcad
    from manipcad.codegen import generate
    from manipcad.control.c_code import regulators_c

    arm = manipcad.load_robot("cylindrical")
    evil = arm.replace(name=EVIL, joint_names=("turn", "lift */ int pwned2; /*", "reach"))
    gen = generate(evil, cache_dir=tmp_path / "cache", attach=False)
    assert gen.generated, gen.reason
    tree = ast.parse(gen.python_source())
    assert ast.get_docstring(tree).startswith("Customized dynamics of 'x___;import os")
    code = ast.unparse(ast.Module(body=tree.body[1:], type_ignores=[]))
    assert "system" not in code and "chr(116)" not in code
    hdr, src = gen.c_code("evil")
    reg = manipcad.synthesize(evil, "turn", "pid")
    rh, rc = regulators_c([reg], evil, "evil", source='r */ int pwned3; /*.yaml')
    for text in (hdr, src, rh, rc):
        assert "pwned" not in _strip_c_comments(text)
    (tmp_path / "evil.h").write_text(hdr)
    (tmp_path / "evil.c").write_text(src)
    (tmp_path / "evil_regulators.h").write_text(rh)
    (tmp_path / "evil_regulators.c").write_text(rc)
    cc = shutil.which("cc") or shutil.which("gcc")
    assert cc, "no C compiler"
    for name in ("evil", "evil_regulators"):
        obj = tmp_path / f"{name}.o"
        subprocess.run([cc, "-std=c99", "-c", str(tmp_path / f"{name}.c"), "-o", str(obj)],
                       check=True, cwd=tmp_path, timeout=120)
        syms = subprocess.run(["nm", str(obj)], capture_output=True, text=True).stdout
        assert "pwned" not in syms
    with pytest.raises(ManipcadError, match="C identifier"):
        regulators_c([reg], evil, "x; int y")


def _bundle(tmp_path):
    import manipcad
    from manipcad.sim import simulate
    from manipcad.workspace import Workspace

    ws = Workspace.init(tmp_path / "ws")
    traj = ws.add(move(tmp_path))
    arm = manipcad.load_robot("cylindrical")
    res = simulate(arm, t_end=0.01, dt=1e-3, drives=False, q0=[0.0, 0.3, 0.2])
    ws.store_result(res, name="r1", robot=arm, trajectory=traj.name, plot=False)
    return ws.export("r1", tmp_path / "share")


def test_bundle_import_checks_the_manifest_hash(tmp_path):
    import json

    from manipcad.workspace import Workspace

    out = _bundle(tmp_path)
    other = Workspace.init(tmp_path / "other")
    (out / "trajectories" / "move.yaml").write_text(
        (out / "trajectories" / "move.yaml").read_text().replace("0.05", "5.0"))
    with pytest.raises(InputError, match="changed since the bundle was exported"):
        other.add(out)
    assert other.list() == []  # nothing imported
    res, msg = cli("ws", "add", out, "--ws", other.root)
    fails_cleanly(res, msg, "move.yaml", "SHA-256")
    # a changed result file too; an unchanged bundle imports
    out2 = _bundle(tmp_path / "b")
    doc = json.loads((out2 / "results" / "r1" / "metrics.json").read_text())
    doc["metrics"]["turn"]["max_error"] = 0.0
    (out2 / "results" / "r1" / "metrics.json").write_text(json.dumps(doc))
    with pytest.raises(InputError, match="r1: changed since"):
        other.add(out2)
    out3 = _bundle(tmp_path / "c")
    assert sorted(i.ref for i in other.add(out3)) == ["results/r1", "trajectories/move"]


def test_a_path_too_long_to_follow_is_refused(tmp_path, monkeypatch):
    """A circle of many turns is refused by the work budget, naming the file, instead of
    taking minutes (1500 rad) or hours (1e6 rad)."""
    import manipcad
    import manipcad.trajectories.cartesian as cart
    from manipcad.trajectories import load_trajectory

    arm = manipcad.load_robot("cylindrical")
    q0 = np.array([0.0, 0.3, 0.3])
    k, c = cart.resolve_point(arm, -1, None)
    R, x = cart.frames(arm, q0[None])
    tip = x[0, k] + R[0, k] @ c
    p = tmp_path / "circle.yaml"
    p.write_text(yaml.safe_dump({
        "type": "circle", "robot": "cylindrical", "center": (tip - [0.02, 0, 0]).tolist(),
        "radius": 0.02, "normal": [0, 0, 1], "angle": 1.0e6, "duration": 2.0,
        "q0": q0.tolist()}))
    monkeypatch.setattr(cart, "MAX_RATE_EVALUATIONS", 2000)  # the same rule, sooner
    with pytest.raises(InputError, match="too long to follow") as err:
        load_trajectory(p)
    assert err.value.source == str(p)


def test_upload_is_validated_off_the_event_loop(tmp_path, monkeypatch):
    """While an upload is validated the server keeps answering (a tick task runs); an
    upload the browser refuses (over the size cap) says so."""
    import asyncio
    import time

    from nicegui import ui
    from test_ui import _open, _simulate_user

    from manipcad.ui import logic

    real = logic.add_upload

    def slow(*a, **k):
        time.sleep(1.0)  # a long validation, holding its thread
        return real(*a, **k)

    monkeypatch.setattr(logic, "add_upload", slow)
    ticks: list[float] = []
    text = move(tmp_path).read_bytes()

    async def script(user):
        await _open(user, "/trajectories")
        (up,) = user.find(kind=ui.upload).elements

        async def tick():
            while True:
                ticks.append(time.monotonic())
                await asyncio.sleep(0.05)

        ticker = asyncio.create_task(tick())
        await up.handle_uploads([ui.upload.SmallFileUpload("move.yaml", "text/yaml", text)])
        await user.should_see("added trajectories/move", retries=60)
        ticker.cancel()
        gaps = np.diff(ticks)
        assert len(ticks) > 10 and gaps.max() < 0.5, gaps.max()
        for handler in up._event_listeners.values():
            if handler.type == "rejected":
                handler.handler()
        await user.should_see("refused: larger than")

    _simulate_user(tmp_path / "ws", script)


# --------------------------------------------------------------------------- silent wrong

def _ident_csv(tmp_path, *, header=None, huge=False) -> Path:
    """Noise-free torques of the PUMA carrying 1.5 kg (manipcad's own inverse dynamics)."""
    import manipcad

    arm = manipcad.load_robot("puma560")
    t = np.linspace(0, 2, 200)
    k = np.arange(1, 7)
    q, qd, qdd = (0.3 * np.sin(np.outer(t, k)), 0.3 * np.cos(np.outer(t, k)) * k,
                  -0.3 * np.sin(np.outer(t, k)) * k**2)
    tau = manipcad.inverse_dynamics(arm.with_payload(1.5, [0, 0, 0.08]), q, qd, qdd)
    if huge:
        tau[5, 1] = 1e308
    cols = header or (["t"] + [f"{s}{i}" for s in ("q", "qd", "qdd", "tau") for i in k])
    p = tmp_path / "m.csv"
    np.savetxt(p, np.column_stack([t, q, qd, qdd, tau]), delimiter=",", header=",".join(cols),
               comments="")
    return p


def test_identify_never_reports_nan(tmp_path, monkeypatch):
    # noise-free torques with --estimate-com: the drives' weights stay finite (their
    # estimated noise floored relative to their torques) and the fit is exact (a point
    # mass's torques are affine in its mass and first moment)
    res, out = cli("identify", "puma560", "--data", _ident_csv(tmp_path), "--estimate-com",
                   "--json")
    assert res.exit_code == 0, out
    doc = json.loads(out[out.index("{"):])
    assert doc["mass_kg"] == pytest.approx(1.5, rel=1e-9) and "nan" not in out
    np.testing.assert_allclose(doc["com_m"], [0.0, 0.0, 0.08], atol=1e-9)
    # an estimate that is not a number is refused with its likely cause, never printed:
    # by check_estimate, and by the command (exit 2, no traceback)
    import dataclasses

    import manipcad
    import manipcad.cli.identify as cli_identify
    from manipcad.dynamics.identification import (
        check_estimate,
        identify_payload,
        load_torque_data,
    )

    arm = manipcad.load_robot("puma560")
    d = load_torque_data(_ident_csv(tmp_path), arm)
    est = identify_payload(arm, d.q, d.qd, d.qdd, d.tau, com=[0, 0, 0.08])
    assert check_estimate(est, "m.csv") is est
    with pytest.raises(ManipcadError, match="m.csv: the data determine no payload mass"):
        check_estimate(dataclasses.replace(est, mass=float("nan")), "m.csv")
    real = cli_identify.identify_payload
    monkeypatch.setattr(cli_identify, "identify_payload", lambda *a, **k: dataclasses.replace(
        real(*a, **k), mass=float("nan")))
    res, out = cli("identify", "puma560", "--data", _ident_csv(tmp_path))
    fails_cleanly(res, out, "m.csv", "determine no payload mass")
    assert "nan ±" not in out
    monkeypatch.undo()
    res, out = cli("identify", "puma560", "--data", _ident_csv(tmp_path, huge=True))
    fails_cleanly(res, out, "line 7, column tau2", "too large")


@pytest.mark.parametrize("label", ["tau2 [deg]", "tau2 [lbf·in]", "tau2 [kN·m]"])
def test_identify_refuses_non_si_unit_labels(tmp_path, label):
    import manipcad
    from manipcad.dynamics.identification import load_torque_data

    k = range(1, 7)
    cols = ["t [s]"] + [f"{s}{i} [{u}]" for s, u in (("q", "rad"), ("qd", "rad/s"),
                                                     ("qdd", "rad/s²"), ("tau", "N·m"))
                        for i in k]
    good = _ident_csv(tmp_path, header=cols)
    arm = manipcad.load_robot("puma560")
    assert load_torque_data(good, arm).tau.shape == (200, 6)  # SI labels are read
    bad = _ident_csv(tmp_path, header=[label if c == "tau2 [N·m]" else c for c in cols])
    with pytest.raises(InputError, match="not the SI unit"):
        load_torque_data(bad, arm)


def test_size_refuses_a_dt_that_undersamples(tmp_path):
    traj = tmp_path / "m.yaml"
    traj.write_text("type: quintic\nq_start: [0, 0.5, -0.5, 0, 0.3, 0]\n"
                    "q_end: [1, 0.5, -0.5, 0, 0.3, 0]\nduration: 0.3\n")
    res, out = cli("size", "puma560", "--trajectory", traj, "--dt", "10")
    fails_cleanly(res, out, "--dt", "1 step over the 0.3 s motion", "0.006")
    res, out = cli("size", "puma560", "--trajectory", traj, "--dt", "0.006", "--json")
    assert res.exit_code in (0, 1) and "error" not in out, out


def test_size_says_a_trajectory_leaves_the_joint_limits(tmp_path):
    """A move of the waist to 4 rad (limits ±2.79 rad): the position check
    (sizing.limits.check_joint_limits, the one the run checks use) fails, exit 1, and the
    summary names the joint, the check, the value and the limit."""
    traj = tmp_path / "far.yaml"
    traj.write_text("type: quintic\nq_start: [0, 0.5, -0.5, 0, 0.3, 0]\n"
                    "q_end: [4, 0.5, -0.5, 0, 0.3, 0]\nduration: 8.0\n")
    res, out = cli("size", "puma560", "--trajectory", traj, "--allow-unknown")
    assert res.exit_code == 1, out
    assert "over a limit: waist: position 4 vs 2.793 rad" in out, out
    res, out = cli("size", "puma560", "--trajectory", traj, "--json")
    import json

    doc = json.loads(out[out.index("{"):])
    assert doc["joints"][0]["checks"]["position"]["status"] == "fail"


def test_api_simulate_refuses_another_robots_regulators():
    """Regulators made for a two-link arm are not run on the PUMA's waist and shoulder."""
    import manipcad
    from manipcad.control.files import load_regulators
    from manipcad.sim import simulate

    two = manipcad.load_robot(str(EXAMPLES / "two_link.yaml"))
    regs = [manipcad.synthesize(two, j, "pid") for j in two.joint_names]
    puma = manipcad.load_robot("puma560")
    with pytest.raises(ManipcadError, match="was made for joint 'shoulder'.*'waist'"):
        simulate(puma, t_end=0.01, dt=1e-4, regulators=regs)
    own = load_regulators(str(EXAMPLES / "pid_puma.yaml"), puma)
    assert simulate(puma, t_end=0.002, dt=1e-4, regulators=own).t[-1] > 0


def test_ws_where_refuses_unknown_joint_and_status(tmp_path):
    import manipcad
    from manipcad.sim import simulate
    from manipcad.workspace import Workspace

    ws = Workspace.init(tmp_path / "ws")
    arm = manipcad.load_robot("cylindrical")
    res = simulate(arm, t_end=0.01, dt=1e-3, drives=False, q0=[0.0, 0.3, 0.2])
    ws.store_result(res, name="r1", robot=arm, plot=False)
    assert [i.name for i in ws.list(where="max_error[lift]>=0 and status=ok")] == ["r1"]
    with pytest.raises(InputError, match="no stored result has a joint 'elbow'.*lift"):
        ws.list(where="max_error[elbow]<1")
    with pytest.raises(InputError, match="status 'okay'.*diverged, ok"):
        ws.list(where="status=okay")
    res, out = cli("ws", "list", "--where", "max_error[lfit]<1", "--ws", ws.root)
    fails_cleanly(res, out, "lfit")


def test_yaml_base60_and_octal_are_not_numbers(tmp_path):
    """YAML 1.1 read 'ratio: 1:30' as 90 and '010' as 8: now text, which the number field
    refuses naming it."""
    from manipcad.fileio import parse_yaml
    from manipcad.model.load import load_robot

    assert parse_yaml("a: 1:30\nb: 010\nc: 190:20:30.15\nd: 0x1f\ne: 1_000\n", "x") == {
        "a": "1:30", "b": "010", "c": "190:20:30.15", "d": 31, "e": 1000}
    text = (EXAMPLES / "two_link.yaml").read_text()
    p = tmp_path / "arm.yaml"
    p.write_text(text.replace("ratio: 50 ", "ratio: 1:30"))
    with pytest.raises(InputError, match="ratio") as err:
        load_robot(str(p))
    assert "1:30" in str(err.value) and err.value.source == str(p)


def test_names_that_look_like_numbers_read_back(tmp_path):
    import manipcad
    from manipcad.control.files import load_regulators, save_regulators
    from manipcad.fileio import dump_yaml, parse_yaml

    data = {"names": ["1e0", "1e3", "1:30", "010", ".5", "yes", "x"]}
    assert parse_yaml(dump_yaml(data), "x") == data
    arm = manipcad.load_robot("cylindrical").replace(joint_names=("1e0", "1e3", "reach"))
    manipcad.save_robot(arm, tmp_path / "arm.yaml")
    back = manipcad.load_robot(str(tmp_path / "arm.yaml"))
    assert back.joint_names == ("1e0", "1e3", "reach")
    regs = [manipcad.synthesize(back, j, "pid") for j in ("1e0", "1e3")]
    save_regulators(regs, tmp_path / "regs.yaml")
    again = load_regulators(str(tmp_path / "regs.yaml"), back)
    assert [r.joint_names for r in again] == [("1e0",), ("1e3",)]


def test_selection_file_quotes_names_that_look_like_numbers(tmp_path):
    """select's robot file was written with yaml.safe_dump: joints named 1e0, 1e3 came
    back as numbers. Every YAML writer goes through fileio.dump_yaml."""
    from types import SimpleNamespace

    import manipcad
    from manipcad.sizing.select import save_selection

    arm = manipcad.load_robot("cylindrical").replace(joint_names=("1e0", "1e3", "010"))
    sel = SimpleNamespace(objective="mass", margin=1.2, payloads=[2.0], joints=[], robot=arm)
    back = manipcad.load_robot(str(save_selection(sel, tmp_path / "sel.yaml")))
    assert back.joint_names == ("1e0", "1e3", "010")
    src = ROOT / "src" / "manipcad"
    writers = [str(p.relative_to(src)) for p in src.rglob("*.py")
               if p.name != "fileio.py" and re.search(r"yaml\.(safe_)?dump\(", p.read_text())]
    assert writers == [], writers


# --------------------------------------------------------------------------- tracebacks

def _two_link(tmp_path, old: str, new: str, name: str = "arm.yaml") -> Path:
    p = tmp_path / name
    text = (EXAMPLES / "two_link.yaml").read_text()
    assert old in text
    p.write_text(text.replace(old, new))
    return p


@pytest.mark.parametrize("old,new,field", [
    ("ratio: 50 ", "ratio: 1e200", "joints[1].drive.ratio"),
    ("gear: maxon_gp42c_43", "gear: [" + ", ".join(["maxon_gp42c_43"] * 100) + "]",
     "joints[0].drive.gear"),
    ("k_m: 0.0538 ", "k_m: 0 ", "joints[1].drive.k_m"),
    ("k_u: 2.0 ", "k_u: 0 ", "joints[0].drive.k_u"),
], ids=["ratio_1e200", "100_gears", "k_m_0", "k_u_0"])
def test_drive_values_that_overflow_or_cannot_act(tmp_path, old, new, field):
    p = _two_link(tmp_path, old, new)
    res, out = cli("robots", "show", p)
    fails_cleanly(res, out, str(p), field)
    assert "unexpected" not in out


def test_motor_file_refuses_zero_resistance(tmp_path):
    from manipcad.catalog.library import load_motor

    src = Path(__file__).resolve().parents[1] / "src/manipcad/catalog/data/parts/motors"
    text = (src / "maxon_re40_148867.yaml").read_text()
    p = tmp_path / "m.yaml"
    p.write_text(text.replace("\nR: 0.299 ", "\nR: 0 "))
    with pytest.raises(InputError, match="R: must be > 0"):
        load_motor(str(p))


URDF = """<robot name="g"><link name="base"/><link name="f1"/><link name="f2"/>
<joint name="j1" type="prismatic"><parent link="base"/><child link="f1"/>
  <limit lower="0" upper="0.04"/></joint>
<joint name="j2" type="prismatic"><parent link="base"/><child link="f2"/>
  <limit lower="0" upper="0.04"/><mimic joint="LEADER" multiplier="1" offset="0"/></joint>
</robot>"""


def test_urdf_key_naming_a_folder_fifo_or_device_says_what_it_is(tmp_path):
    from manipcad.model.load import load_robot

    os.mkfifo(tmp_path / "pipe.urdf")
    (tmp_path / "folder.urdf").mkdir()
    for target, what in (("folder.urdf", "is a directory"), ("pipe.urdf", "is a FIFO"),
                         ("/dev/zero", "is a character device")):
        p = tmp_path / "arm.yaml"
        p.write_text(f"name: arm\nurdf: {target}\ndrives: {{}}\n")
        with pytest.raises(InputError, match=what) as err:
            load_robot(str(p))
        assert err.value.field == "urdf" and "no such file" not in str(err.value)


def test_urdf_mimic_of_a_missing_joint_refused():
    from manipcad.model.urdf import robot_from_urdf_string

    with pytest.raises(InputError, match="mimics joint 'nope', which the file does not have"):
        robot_from_urdf_string(URDF.replace("LEADER", "nope"))
    with pytest.warns(Warning, match="'j2' mimics 'j1'"):
        assert robot_from_urdf_string(URDF.replace("LEADER", "j1")).n == 2


def test_divergence_names_the_drive_whose_inductance_the_step_cannot_resolve(tmp_path):
    """A tiny L on the elbow blew up the elbow's current, and the speed check caught the
    shoulder first: the message names the elbow's drive, L/R and a step that works."""
    import manipcad
    from manipcad.sim import simulate
    from manipcad.sim.simulate import SimulationDiverged

    arm = manipcad.load_robot(str(_two_link(tmp_path, "L: 0.51e-3 ", "L: 1e-9 ")))
    with pytest.raises(SimulationDiverged) as err:
        simulate(arm, t_end=0.01, dt=1e-4)
    msg = str(err.value)
    assert msg.index("joint 'elbow''s drive") < msg.index("'shoulder'"), msg
    assert "L/R = 1e-09 H / 2.45 Ω = 4.08e-10 s" in msg and "dt <= 4.1e-10 s" in msg
    assert "L: 0 for joint 'elbow'" in msg
    # the step the message gives runs that mode stably (a 20-step run)
    assert np.isfinite(simulate(arm, t_end=8e-9, dt=4e-10).current).all()


@pytest.mark.parametrize("address,words", [
    ("http://x", ["tcp://HOST:PORT or HOST:PORT", "'http://x'"]),
    ("x", ["tcp://HOST:PORT or HOST:PORT"]),
    ("tcp://127.0.0.1:99999", ["tcp://HOST:PORT"]),
    ("tcp://127.0.0.1:1", ["cannot connect to tcp://127.0.0.1:1", "connection refused"]),
    ("tcp://x.invalid:8786", ["unknown host 'x.invalid'"]),
])
def test_scheduler_address_checked_up_front(tmp_path, address, words):
    """--scheduler http://x waited 20 s, then an unexpected ValueError and a traceback of
    the failed client's close; now the form is checked, then a short connect."""
    import time

    t0 = time.monotonic()
    res, out = cli("study", "claims", "--scheduler", address, "--out", tmp_path / "c")
    fails_cleanly(res, out, "--scheduler", *words)
    assert "unexpected" not in out and not (tmp_path / "c").exists()
    assert time.monotonic() - t0 < 10.0


def test_scheduler_that_is_not_dask_refused():
    """A server that answers with something else (here garbage bytes) is not handed to a
    Dask client (which read it as a frame of exabytes)."""
    import socket
    import threading

    from manipcad.parallel import Pool

    srv = socket.create_server(("127.0.0.1", 0))
    port = srv.getsockname()[1]

    def answer():
        for _ in range(2):  # the plain connect, then the identity request
            conn, _ = srv.accept()
            conn.sendall(b"\xff" * 64)
            conn.close()

    threading.Thread(target=answer, daemon=True).start()
    try:
        with pytest.raises(InputError, match=f"127.0.0.1:{port}: no Dask scheduler answered"):
            Pool(scheduler=f"127.0.0.1:{port}")
    finally:
        srv.close()


@pytest.mark.parametrize("call,words", [
    ("inverse_dynamics('puma560', z, z, z)", ["inverse_dynamics: robot", "got str 'puma560'",
                                             "manipcad.load_robot('puma560')"]),
    ("inverse_dynamics(None, z, z, z)", ["inverse_dynamics: robot", "got NoneType"]),
    ("mass_matrix('puma560', z)", ["mass_matrix: robot"]),
    ("forward_dynamics(None, z, z, z)", ["forward_dynamics: robot"]),
    ("simulate('puma560', t_end=0.001, dt=1e-4)", ["simulate: robot"]),
    ("simulate(puma, t_end=0.001, dt=1e-4, payload=(1.0, [0, 0, 0]))",
     ["payload", "a mass in kg or a mapping", "got tuple"]),
    ("simulate(puma, t_end=0.001, dt=1e-4, disturbance='5')",
     ["simulate: disturbance", "(6,) array", "got str '5'"]),
    ("simulate(puma, t_end=0.001, dt=1e-4, disturbance={'waist': 1.0})",
     ["simulate: disturbance", "got dict"]),
    ("puma.with_payload((1.0, 0.1))", ["payload mass must be a number (kg)"]),
    ("puma.with_payload(1.0, com='abc')", ["payload com must be 3 numbers"]),
    ("puma.with_payload(1.0, inertia=[1, 2])", ["payload inertia must be a (3, 3) tensor"]),
], ids=lambda v: v if isinstance(v, str) else "")
def test_api_names_the_argument_and_what_it_takes(call, words):
    """The Python API raised AttributeError, TypeError or ValueError from deep inside."""
    import manipcad

    puma = manipcad.load_robot("puma560")
    env = {"puma": puma, "z": np.zeros(6), **{k: getattr(manipcad, k) for k in (
        "inverse_dynamics", "mass_matrix", "forward_dynamics", "simulate")}}
    with pytest.raises(ManipcadError) as err:
        eval(call, env)
    for w in words:
        assert w in str(err.value), str(err.value)


@pytest.mark.parametrize("period", ["1.0e+6", "1.0e+300"])
def test_regulator_period_longer_than_the_run_named(tmp_path, period):
    """A huge period was reported as 'record_every = 10000000000 keeps one sample...'
    (CLI) and ran with a regulator that never acted (API, --every 1)."""

    import manipcad
    from manipcad.control.files import load_regulators

    text = (EXAMPLES / "pid_puma.yaml").read_text()
    regs = tmp_path / "slow.yaml"
    regs.write_text(re.sub(r"(?m)^period: \S+", f"period: {period}", text))
    for extra in ((), ("--every", "1")):
        res, out = cli("simulate", "puma560", "--trajectory", move(tmp_path), "--regulator",
                       regs, "--out", tmp_path / "r", *extra)
        fails_cleanly(res, out, "slow.yaml: period", f"period {float(period):g} s of joint "
                      "'waist' is longer than the run (0.05 s)")
        assert "keeps one sample" not in out
    puma = manipcad.load_robot("puma560")
    with pytest.raises(ManipcadError, match="period .* of joint 'waist' is longer than the run"):
        manipcad.simulate(puma, t_end=0.01, dt=1e-4, regulators=load_regulators(str(regs), puma))


def test_tables_print_law_and_names_literally_and_uncut_into_a_pipe(tmp_path):
    """rich read table cells as markup: the ace_de law lost its bracketed term and a joint
    named '[red]sh:fire:[/]' lost its brackets; output to a pipe was laid out for 80
    columns (or the terminal on another stream) and cut."""
    from typer.testing import CliRunner

    from manipcad.cli import app

    def piped(*args):  # stdout is not a terminal and COLUMNS is not set
        res = CliRunner().invoke(app, [str(a) for a in args], env={"COLUMNS": None})
        assert res.exit_code == 0, res.output
        return res.output

    out = piped("synthesize", "puma560", "--method", "ace_de", "--joint", "waist",
                "--out", tmp_path / "g")
    law = "+ [k_w/k_u·(1−ρ) + (R(h*+k_v)+L·ḣ*)/(k_m k_u)]·i_r·q̇ + R/(k_m k_u)·m_f +"
    assert law in out, out
    arm = _two_link(tmp_path, "name: shoulder", "name: '[red]sh:fire:[/]'")
    out = piped("robots", "show", arm)
    assert "│ [red]sh:fire:[/] │" in out and "🔥" not in out, out
    out = piped("catalog", "list", "--kind", "gear", "--makers", "maxon")
    assert "…" not in out and max(map(len, out.splitlines())) > 150


def test_echoed_user_text_keeps_emoji_codes(tmp_path):
    res, out = cli("size", "puma560", "--trajectory", tmp_path / ":fire:0:100:10.yaml")
    fails_cleanly(res, out, ":fire:0:100:10.yaml")
    assert "🔥" not in out and "💯" not in out


# --------------------------------------------------------------------------- new user

def test_synthesize_ws_prints_a_command_that_runs(tmp_path):
    import shlex

    from manipcad.workspace import Workspace

    ws = Workspace.init(tmp_path / "ws")
    ws.add(move(tmp_path))
    res, out = cli("synthesize", "puma560", "--method", "pid", "--all", "--out", "g",
                   "--ws", ws.root)
    assert res.exit_code == 0, out
    cmd = re.search(r"run it: manipcad (simulate .*?)\)\s*$", out, re.S)[1]
    args = shlex.split(cmd.replace("\n", " ").replace("TRAJECTORY.yaml", "move"))
    assert "--ws" in args
    res, out = cli(*args, "--t-end", "0.002", "--out", "r1")
    assert res.exit_code == 0, out


def test_ws_add_of_a_folder_holding_a_bundle_says_how_to_take_it(tmp_path):
    """``ws export r --to share`` writes share/r/; ``ws add share`` used to file share as a
    study. It is refused naming the bundle and the command that takes it, which works;
    ``--kind study`` still files the folder as a study."""
    from manipcad.workspace import Workspace

    src = Workspace.init(tmp_path / "a")
    src.add(EXAMPLES / "two_link.yaml", name="arm2")
    src.export("arm2", tmp_path / "share")
    ws = Workspace.init(tmp_path / "b")
    res, out = cli("ws", "add", tmp_path / "share", "--ws", ws.root)
    fails_cleanly(res, out, "not a study", f"manipcad ws add {tmp_path / 'share' / 'arm2'}")
    assert ws.list() == []
    res, out = cli("ws", "add", tmp_path / "share" / "arm2", "--ws", ws.root)
    assert res.exit_code == 0, out
    assert [i.ref for i in ws.list()] == ["robots/arm2"]
    res, out = cli("ws", "add", tmp_path / "share", "--kind", "study", "--ws", ws.root)
    assert res.exit_code == 0 and ws.find("studies", "share") is not None, out


def test_workspace_doc_says_which_commands_take_ws():
    """docs/workspace.md names the commands that take --ws, each of which does, and no
    longer says --ws is still to come."""

    text = (ROOT / "docs" / "workspace.md").read_text()
    assert not re.search(r"still to wire|until `?simulate", text, re.I)
    named = re.search(r"`--ws DIR` is taken by (.*?): their", text, re.S)[1]
    commands = re.findall(r"`([a-z0-9 ]+)`", named)
    assert {"simulate", "synthesize", "robots show", "study fig3"} <= set(commands), commands
    for command in commands:
        res, out = cli(*command.split(), "--help")
        assert res.exit_code == 0 and "--ws" in out, (command, out)


def test_result_inputs_name_files_that_exist(tmp_path):
    """metrics.json's inputs of `simulate --out` and `simulate --ws` name files that exist
    after the run (the robot as it ran used to be named by a deleted temporary file)."""
    import json

    from manipcad.workspace import Workspace

    ws = Workspace.init(tmp_path / "ws")
    traj = move(tmp_path)
    for where in (("--out", tmp_path / "r1"), ("--ws", ws.root, "--out", "r2")):
        res, out = cli("simulate", "puma560", "-t", traj, "--t-end", "0.002", *where)
        assert res.exit_code == 0, out
    for folder in (tmp_path / "r1", ws.root / "results" / "r2"):
        doc = json.loads((folder / "metrics.json").read_text())
        robot = doc["inputs"]["robot"]
        assert robot.startswith("inputs/robot.yaml") and "PUMA 560" in robot, robot
        assert (folder / "inputs" / "robot.yaml").is_file()
        assert Path(doc["inputs"]["trajectory"]).is_file()


def test_robots_show_takes_ws(tmp_path):
    from manipcad.workspace import Workspace

    ws = Workspace.init(tmp_path / "ws")
    ws.add(EXAMPLES / "two_link.yaml", name="arm2")
    res, out = cli("robots", "show", "arm2", "--ws", ws.root, "--json")
    assert res.exit_code == 0, out
    assert '"shoulder"' in out


def test_recommend_footer_says_the_order_it_shows(monkeypatch):
    """The --verify footer said "ranked by score" while the list is ordered by the verdict
    of every check, then cost: the footer prints the list's own order."""
    import manipcad.cli.recommend as command  # the command's own name for recommend: run
    from manipcad.expert.engine import RULES_ORDER, VERIFIED_ORDER

    real = command.run
    seen = []

    def verified(*args, verify=False, **kw):  # the rules' list, marked as _verify marks it
        recs = real(*args, **kw)
        seen.append(recs.order)
        recs.verified, recs.order = True, VERIFIED_ORDER
        return recs

    res, out = cli("recommend", EXAMPLES / "requirements_fig3.yaml")
    assert res.exit_code == 0, out
    assert RULES_ORDER in " ".join(out.split())
    monkeypatch.setattr(command, "run", verified)
    res, out = cli("recommend", EXAMPLES / "requirements_fig3.yaml")
    flat = " ".join(out.split())
    assert seen == [RULES_ORDER] and VERIFIED_ORDER in flat and "ranked by score" not in flat


def test_claims_arm_file_must_be_the_cylindrical_arm(tmp_path):
    """study claims --arm FILE said only 'turn: the claims study needs joints turn, lift,
    reach': now what arm it takes, the joints the file has, and before any work."""
    res, out = cli("study", "claims", "--arm", EXAMPLES / "two_link.yaml", "--workers", "1",
                   "--out", tmp_path / "c")
    fails_cleanly(res, out, "two_link.yaml: joints", "exactly the joints turn (revolute",
                  "this arm has shoulder (revolute), elbow (revolute) (no turn, lift, reach)",
                  "--arm light, industrial or heavy")
    assert not (tmp_path / "c").exists()
    text = (ROOT / "src/manipcad/model/catalog/robots/cylindrical.yaml").read_text()
    p = tmp_path / "cyl.yaml"
    p.write_text(text.replace("type: prismatic", "type: revolute", 1))
    res, out = cli("study", "robustness", "--arm", p, "--workers", "1", "--out", tmp_path / "r")
    fails_cleanly(res, out, "cyl.yaml: lift", "joint 'lift' is revolute")


def test_simulate_summary_says_every_n_steps(tmp_path):
    res, out = cli("simulate", "puma560", "--trajectory", move(tmp_path), "--regulator",
                   EXAMPLES / "pid_puma.yaml", "--out", tmp_path / "r", "--t-end", "0.02")
    assert res.exit_code == 0, out
    assert "one sample every 10 steps" in out and "10. step" not in out
