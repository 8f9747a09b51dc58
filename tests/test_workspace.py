"""The workspace: add/list/show/rm/check/reindex/export, the --where filter (no SQL
injection), names that cannot escape, concurrent writer processes, killed writers,
the CLI (exit status 2 with one line for bad input, --json, --version, completion)."""

from __future__ import annotations

import json
import os
import random
import signal
import sqlite3
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
import yaml
from typer.testing import CliRunner

from manipcad.catalog.files import PARTS
from manipcad.cli import app
from manipcad.errors import InputError, ManipcadWarning
from manipcad.model.load import CATALOG
from manipcad.sim.simulate import SimulationResult
from manipcad.workspace import Workspace, parse_where, resolve_input

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
SRC = ROOT / "src"
runner = CliRunner()


def catalog(kind: str, name: str) -> Path:
    return Path(str((CATALOG if kind == "robots" else PARTS) / kind / f"{name}.yaml"))


def fake_result(scale: float, n: int = 3, k: int = 50) -> SimulationResult:
    """A result with errors of size ``scale`` rad and torques 10·scale N·m."""
    t = np.linspace(0.0, 0.049, k)
    ref = np.outer(np.sin(t * 20), np.arange(1, n + 1))
    q = ref - scale * np.cos(t * 20)[:, None]
    tau = 10 * scale * np.ones((k, n))
    return SimulationResult(
        t=t, q=q, qd=np.ones((k, n)), q_ref=ref, qd_ref=np.zeros((k, n)), u=np.zeros((k, n)),
        current=np.full((k, n), 2 * scale), tau=tau, joint_names=("turn", "lift", "reach")[:n],
        robot="fake", settings={"dt": 1e-3, "drives": True},
        metrics={j: {"max_error": float(np.abs(ref - q)[:, i].max()),
                     "rms_error": float(np.sqrt(np.mean((ref - q)[:, i] ** 2)))}
                 for i, j in enumerate(("turn", "lift", "reach")[:n])})


@pytest.fixture
def ws(tmp_path) -> Workspace:
    w = Workspace.init(tmp_path / "ws")
    yield w
    w.close()


def traj_file(tmp_path: Path, name: str = "move", n: int = 3, dur: float = 0.05) -> Path:
    p = tmp_path / f"{name}.yaml"
    p.write_text(yaml.safe_dump({"type": "quintic", "q_start": [0.0] * n,
                                 "q_end": [0.05] * n, "duration": dur}))
    return p


# ------------------------------------------------------------------ basics


def test_init_layout_and_default_root(tmp_path, monkeypatch):
    w = Workspace.init(tmp_path / "w")
    assert sorted(p.name for p in w.root.iterdir()) == sorted(
        [".meta", "gears", "index.sqlite", "manipcad-workspace.yaml", "motors", "regulators",
         "results", "robots", "studies", "trajectories"] + [
         p.name for p in w.root.iterdir() if p.name.startswith("index.sqlite-")])
    mode = sqlite3.connect(w.root / "index.sqlite").execute("PRAGMA journal_mode").fetchone()
    assert mode[0] == "wal"
    monkeypatch.setenv("MANIPCAD_WORKSPACE", str(w.root))
    assert Workspace().root == w.root
    monkeypatch.delenv("MANIPCAD_WORKSPACE")
    monkeypatch.chdir(tmp_path)
    with pytest.raises(InputError, match="not a manipcad workspace.*ws init"):
        Workspace()
    (tmp_path / "full").mkdir()
    (tmp_path / "full" / "x").write_text("")
    with pytest.raises(InputError, match="not empty and is not a workspace"):
        Workspace.init(tmp_path / "full")


def test_add_recognizes_kinds_and_validates(ws, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        assert ws.add(catalog("robots", "cylindrical")).ref == "robots/cylindrical"
    assert ws.add(catalog("motors", "maxon_re40_148877"), name="my-motor").ref == \
        "motors/my-motor"
    assert ws.add(catalog("gears", "harmonic_csf17_100")).kind == "gears"
    assert ws.add(traj_file(tmp_path)).kind == "trajectories"
    assert ws.add(EXAMPLES / "pid_cylindrical.yaml").kind == "regulators"
    assert [i.ref for i in ws.list("motor")] == ["motors/my-motor"]
    # validated by the same loader, same message
    bad = tmp_path / "bad_motor.yaml"
    bad.write_text(catalog("motors", "maxon_re40_148877").read_text().replace("R:", "R_x:"))
    with pytest.raises(InputError, match="bad_motor.yaml"):
        ws.add(bad, kind="motor")
    # a name taken is refused unless --force
    with pytest.raises(InputError, match="name taken"):
        ws.add(traj_file(tmp_path))
    item = ws.add(traj_file(tmp_path, dur=0.1), name="move", force=True)
    assert ws.get("move").hash == item.hash
    # a regulator checked against a robot when one is named
    bad_reg = tmp_path / "reg.yaml"
    bad_reg.write_text("type: pid\nperiod: 0.001\nkp: [1, 2]\njoints: [turn, nope]\n")
    with pytest.raises(InputError, match="nope"):
        ws.add(bad_reg, robot="cylindrical")
    unknown = tmp_path / "what.yaml"
    unknown.write_text("colour: blue\n")
    with pytest.raises(InputError, match="cannot tell the kind"):
        ws.add(unknown)


def test_names_cannot_escape(ws, tmp_path):
    src = traj_file(tmp_path)
    for name in ("../evil", "/abs", "a/b", ".hidden", "", "x" * 101, "a..b"):
        with pytest.raises(InputError):
            ws.add(src, name=name)
    assert ws.list() == [] and not (tmp_path / "evil.yaml").exists()
    with pytest.raises(InputError):
        ws.store_result(fake_result(1e-3), name="../../r")
    # a link planted in the workspace that leads outside is reported and never followed
    outside = tmp_path / "secret.yaml"
    outside.write_text("type: quintic\nq_start: [0]\nq_end: [1]\nduration: 1\n")
    os.symlink(outside, ws.root / "trajectories" / "planted.yaml")
    assert [(p.problem, p.name) for p in ws.check()] == [("outside", "planted")]
    assert ws.reindex()["errors"] == {"trajectories/planted": "points outside the workspace"}
    assert ws.find("trajectory", "planted") is None
    # a folder holding a link to the outside is refused
    folder = tmp_path / "study"
    folder.mkdir()
    os.symlink(outside, folder / "link.yaml")
    with pytest.raises(InputError, match="outside the folder"):
        ws.add(folder, kind="study")
    # a bundle whose manifest names a path outside it
    bundle = tmp_path / "bundle"
    bundle.mkdir()
    (bundle / "manipcad-bundle.json").write_text(json.dumps(
        {"items": [{"kind": "trajectories", "name": "x", "path": "../secret.yaml"}]}))
    with pytest.raises(InputError, match="outside the bundle"):
        ws.add(bundle)


# ------------------------------------------------------------------ results, where


@pytest.fixture
def results_ws(ws, tmp_path):
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        ws.add(catalog("robots", "cylindrical"), name="cyl")
    ws.add(traj_file(tmp_path))
    for name, scale in (("small", 1e-4), ("medium", 5e-3), ("large", 0.2)):
        ws.store_result(fake_result(scale), name=name, robot="cyl", trajectory="move",
                        run={"t_end": 0.05, "dt": 1e-3}, plot=False)
    return ws


def test_where_filters_results(results_ws):
    ws = results_ws
    names = lambda w: [i.name for i in ws.list(where=w)]  # noqa: E731
    assert names("max_error<1e-3") == ["small"]
    assert names("max_error<1e-2") == ["medium", "small"]
    assert names("max_error>=1e-2 and status=ok") == ["large"]
    assert names("peak_torque[lift]<=0.05 and peak_torque[lift]>0.002") == ["medium"]
    assert names("status!=ok") == []
    # key metrics indexed: per joint and the largest over the joints
    m = ws.get("small").metrics
    assert m["peak_torque"] == pytest.approx(1e-3) and m["turn.peak_current"] == pytest.approx(2e-4)
    assert m["peak_power"] == pytest.approx(1e-3) and m["samples"] == 50


@pytest.mark.parametrize("text", [
    "max_error<1; DROP TABLE items", "max_error<1 or 1=1", "nosuch<1", "max_error<abc",
    "max_error<nan", "status<ok", "max_error", "max_error<1 and", "1=1"])
def test_where_refuses_anything_else(results_ws, text):
    with pytest.raises(InputError, match="--where"):
        results_ws.list(where=text)
    assert len(results_ws.list()) == 5  # the table is intact


def test_where_joint_text_is_a_parameter(results_ws):
    with pytest.raises(InputError, match="no stored result has a joint \"x' OR '1'='1\""):
        results_ws.list(where="max_error[x' OR '1'='1]<1")  # a name, never SQL
    assert parse_where("max_error[x' OR '1'='1]<1")[0].joint == "x' OR '1'='1"
    assert len(results_ws.list()) == 5


def test_provenance_rm_cascade_check_reindex(results_ws):
    ws = results_ws
    prov = ws.get("small").provenance
    assert prov["inputs"]["robot"]["name"] == "cyl"
    assert prov["inputs"]["trajectory"]["name"] == "move"
    assert len(prov["settings_hash"]) == 64
    with pytest.raises(InputError, match="stored results depend on it: large, medium, small"):
        ws.rm("cyl")
    # hand edits, missing files and unindexed files are reported
    assert ws.check() == []
    traj = ws.path("move")
    old = ws.get("move").hash
    traj.write_text(traj.read_text() + "# edited\n")
    (ws.root / "results" / "small" / "timeseries.npz").unlink()
    (ws.root / "gears" / "extra.yaml").write_bytes(catalog("gears", "harmonic_csf17_100")
                                                  .read_bytes())
    found = {(p.problem, p.name): p.detail for p in ws.check()}
    assert set(found) == {("changed", "move"), ("changed", "small"), ("unindexed", "extra")}
    assert old[:16] in found[("changed", "move")]
    done = ws.reindex()
    assert done["items"] == 5 and list(done["errors"]) == ["results/small"]
    # the broken result stays on disk, unindexed, and is reported as such
    assert [(p.problem, p.name) for p in ws.check()] == [("unindexed", "small")]
    removed = ws.rm("move", cascade=True)
    assert sorted(i.ref for i in removed) == ["results/large", "results/medium",
                                                "trajectories/move"]
    assert not (ws.root / "results" / "large").exists()


def test_export_bundle_and_add_elsewhere(results_ws, tmp_path):
    out = results_ws.export("medium", tmp_path / "share")
    manifest = json.loads((out / "manipcad-bundle.json").read_text())
    assert sorted(e["name"] for e in manifest["items"]) == ["cyl", "medium", "move"]
    header = (out / "results" / "medium" / "timeseries.csv").read_text().splitlines()[0]
    assert header.startswith("t [s],turn.q [rad]")
    other = Workspace.init(tmp_path / "other")
    added = other.add(out)
    assert sorted(i.ref for i in added) == ["results/medium", "robots/cyl", "trajectories/move"]
    assert other.get("medium").provenance["inputs"]["robot"]["name"] == "cyl"
    assert other.get("medium").metrics["max_error"] == results_ws.get("medium").metrics[
        "max_error"]
    assert other.add(out) == []  # identical items are not added twice
    assert other.check() == []


def test_resolve_input(results_ws, tmp_path, monkeypatch):
    ws = results_ws
    assert resolve_input("robot", "cyl", ws) == str(ws.resolve("robot", "cyl"))
    assert resolve_input("robot", "puma560", ws) == "puma560"
    assert resolve_input("trajectory", str(traj_file(tmp_path, "t2")), ws).endswith("t2.yaml")
    monkeypatch.setenv("MANIPCAD_WORKSPACE", str(ws.root))
    assert resolve_input("trajectory", "move").endswith("trajectories/move.yaml")
    with pytest.raises(InputError, match="no such item"):
        ws.resolve("robot", "nothing")


# ------------------------------------------------------------------ real processes

WRITER = r"""
import sys, yaml
from pathlib import Path
from manipcad.errors import InputError
from manipcad.workspace import Workspace
ws = Workspace(sys.argv[1]); tag = sys.argv[2]; folder = Path(sys.argv[3])
for k in range(int(sys.argv[4])):
    p = folder / f"{tag}-{k}.yaml"
    p.write_text(yaml.safe_dump({"type": "quintic", "q_start": [0.0], "q_end": [k + 1.0],
                                 "duration": 1.0}))
    ws.add(p)
p = folder / f"{tag}-shared.yaml"   # then both race for one name
p.write_text(yaml.safe_dump({"type": "quintic", "q_start": [0.0], "q_end": [len(tag) + 0.5],
                             "duration": 2.0 if tag == "a" else 3.0}))
try:
    ws.add(p, name="shared")
    print("added")
except InputError as exc:
    print("refused:", exc)
"""


@pytest.mark.slow
def test_two_writer_processes_lose_nothing(ws, tmp_path):
    """Two real processes add 15 items each at the same time: 30 rows, no partial file;
    then both add an item of one name: one wins, the other is told the name is taken."""
    env = {**os.environ, "PYTHONPATH": str(SRC)}
    procs = [subprocess.Popen([sys.executable, "-c", WRITER, str(ws.root), tag, str(tmp_path),
                               "15"], env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                              text=True) for tag in ("a", "b")]
    outs = [p.communicate(timeout=180) for p in procs]
    assert [p.returncode for p in procs] == [0, 0], [o[1][-800:] for o in outs]
    names = sorted(i.name for i in ws.list("trajectories"))
    assert names == sorted([f"{t}-{k}" for t in "ab" for k in range(15)] + ["shared"])
    said = sorted(o[0].strip() for o in outs)
    assert said[0] == "added" and said[1].startswith("refused:") and "name taken" in said[1]
    winner = "a" if outs[0][0].strip() == "added" else "b"
    assert ws.get("shared").hash == __import__("hashlib").sha256(
        (tmp_path / f"{winner}-shared.yaml").read_bytes()).hexdigest()
    assert ws.check() == []
    assert [p.name for p in (ws.root / "trajectories").iterdir()
            if p.name.startswith(".")] == []


def test_killed_writers_leave_a_consistent_workspace(ws, tmp_path):
    """Writers killed by SIGKILL at random moments while storing results: at worst an
    unindexed item or a leftover, and after reindex ``check`` is clean."""
    rng = random.Random(5)
    for round_ in range(6):
        pid = os.fork()
        if pid == 0:
            try:
                w = Workspace(ws.root)
                for k in range(1000):
                    w.store_result(fake_result(1e-3 * (k + 1), k=400), name=f"r{round_}-{k}",
                                   run={"t_end": 0.05, "dt": 1e-3}, plot=False)
            finally:
                os._exit(0)
        time.sleep(rng.uniform(0.05, 0.4))
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        for p in ws.check():
            assert p.problem in ("unindexed", "leftover"), p
    ws.reindex()
    assert ws.check() == []
    for item in ws.list("results"):  # every indexed result loads whole
        from manipcad.store import load_result

        load_result(ws.path(item))
    assert [p.name for p in (ws.root / "results").iterdir() if p.name.startswith(".")] == []


# ------------------------------------------------------------------ CLI


def cli(*args: str):
    return runner.invoke(app, [*map(str, args)], env={"COLUMNS": "200"})


def test_cli_tour(tmp_path):
    w = tmp_path / "w"
    assert cli("ws", "init", w).exit_code == 0
    r = cli("ws", "add", catalog("motors", "maxon_re25_118743"), "--name", "m1", "--ws", w)
    assert r.exit_code == 0 and "added motors/m1" in r.output
    r = cli("ws", "add", tmp_path / "none.yaml", "--ws", w)
    assert r.exit_code == 2 and "no such file" in r.output and "Traceback" not in r.output
    r = cli("ws", "list", "--ws", w, "--json")
    assert r.exit_code == 0 and json.loads(r.stdout)[0]["name"] == "m1"
    r = cli("ws", "list", "--where", "max_error<1; drop table items", "--ws", w)
    assert r.exit_code == 2 and "--where" in r.output
    r = cli("ws", "show", "m1", "--ws", w, "--json")
    assert json.loads(r.stdout)["kind"] == "motors"
    assert cli("ws", "check", "--ws", w).exit_code == 0
    Path(json.loads(r.stdout)["file"]).write_text("k_m: 1\nR: 1\n")
    r = cli("ws", "check", "--ws", w, "--json")
    assert r.exit_code == 1 and json.loads(r.stdout)[0]["problem"] == "changed"
    r = cli("ws", "rm", "m1", "--ws", w)
    assert r.exit_code == 0 and cli("ws", "list", "--ws", w, "--json").stdout.strip() == "[]"
    r = cli("ws", "list", "--ws", tmp_path / "nope")
    assert r.exit_code == 2 and "not a manipcad workspace" in r.output


COMPLETE = "from manipcad.cli import app; app(prog_name='manipcad')"


@pytest.mark.slow
def test_cli_version_and_completion(tmp_path):
    r = cli("--version")
    assert r.exit_code == 0 and r.stdout.strip() == "manipcad 0.1.0"
    env = {**os.environ, "PYTHONPATH": str(SRC), "_MANIPCAD_COMPLETE": "complete_bash",
           "COMP_WORDS": "manipcad ws re", "COMP_CWORD": "2"}
    out = subprocess.run([sys.executable, "-c", COMPLETE], env=env, capture_output=True,
                         text=True, timeout=60)
    assert set(out.stdout.split()) == {"reindex", "rerun"}, out.stderr[-500:]
    w = Workspace.init(tmp_path / "w")
    w.add(catalog("motors", "maxon_re25_118743"), name="motor-a")
    env.update(COMP_WORDS=f"manipcad ws show --ws {w.root} mo", COMP_CWORD="5")
    out = subprocess.run([sys.executable, "-c", COMPLETE], env=env, capture_output=True,
                         text=True, timeout=60)
    assert out.stdout.split() == ["motor-a"], out.stderr[-500:]


# ------------------------------------------------------------------ real runs


def test_robot_file_referencing_files_is_stored_self_contained(ws):
    """A URDF + drives file names its URDF by a relative path: the workspace keeps the
    robot in the tree form Robot.save writes, which loads back identical."""
    src = EXAMPLES / "ur5" / "ur5.yaml"
    item = ws.add(src, name="ur5")
    stored = ws.path(item)
    assert stored.suffix == ".yaml" and "tree form" in item.source
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        a, b = manipcad_load(src), manipcad_load(stored)
    assert np.array_equal(a.table, b.table) and a.drives == b.drives


def manipcad_load(path):
    import manipcad

    return manipcad.load_robot(path)


def test_store_result_then_rerun_is_identical_and_compare_plots(ws, tmp_path):
    import manipcad
    from manipcad.control import load_regulators
    from manipcad.sim import simulate
    from manipcad.trajectories import load_trajectory
    from manipcad.workspace.runs import compare, rerun

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        ws.add(catalog("robots", "cylindrical"), name="cyl")
    ws.add(traj_file(tmp_path, "move", dur=0.03))
    ws.add(EXAMPLES / "pid_cylindrical.yaml", name="pid", robot="cyl")
    arm = manipcad.load_robot(ws.resolve("robot", "cyl"))
    traj = load_trajectory(ws.resolve("trajectory", "move"), robot=arm)
    regs = load_regulators(ws.resolve("regulator", "pid"), arm, dt=1e-4)
    run = {"t_end": 0.03, "dt": 1e-4, "every": 10, "drives": True, "payload": None}
    res = simulate(arm, t_end=0.03, dt=1e-4, trajectory=traj, regulators=regs,
                   every=10)
    item = ws.store_result(res, name="r1", robot=arm, trajectory="move", regulators=["pid"],
                           run=run)
    assert item.provenance["inputs"]["trajectory"]["name"] == "move"
    assert item.provenance["inputs"]["regulator"]["name"] == "pid"
    assert item.metrics["samples"] == len(res.t) == 31
    r = rerun(ws, "r1")
    assert r.identical and set(r.max_abs_diff.values()) == {0.0}
    assert r.metrics and all(a == b for a, b in r.metrics.values())
    # a changed stored input makes the re-run differ, and says so
    reg = ws.path("r1") / "inputs" / "regulator.yaml"
    reg.write_text(reg.read_text().replace("period: 0.001", "period: 0.0005"))
    assert not rerun(ws, "r1").identical
    rows, fig = compare(ws, ["r1", "r1"])
    assert rows[0]["max_error"] == item.metrics["max_error"] and len(fig.axes) == 3 * 3


def test_catalog_listed_beside_the_users(ws):
    ws.add(catalog("motors", "maxon_re25_118743"), name="mine")
    items = ws.library("motor")
    origins = {(i.name, i.source.split(" ")[0]) for i in items}
    assert ("mine", ws.get("mine").source.split(" ")[0]) in origins
    assert ("maxon_re25_118743", "catalog") in origins
    assert {i.kind for i in ws.library()} >= {"robots", "motors", "gears"}
    assert ws.library("trajectory") == []
    r = cli("ws", "list", "gear", "--catalog", "--json", "--ws", ws.root)
    assert r.exit_code == 0 and all(d["source"] == "catalog (read-only)"
                                    for d in json.loads(r.stdout))


def test_jupyter_html(results_ws):
    import manipcad
    from manipcad.store import load_result
    from manipcad.workspace import result_html, results_dataframe

    html = results_ws.list()._repr_html_()
    assert html.count("<tr>") == 1 + 5 and "medium" in html
    assert "cyl" in results_ws._repr_html_()
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        arm = manipcad.load_robot("cylindrical")
    assert arm._repr_html_().count("<tr>") == 1 + arm.n
    res, doc = load_result(results_ws.path("small"))
    assert "turn" in result_html(res, doc["joint_types"])
    df = results_dataframe(res, doc["joint_types"])
    assert df.shape == (50, 3 * 8) and "lift.tau [N]" in df.columns
    assert np.array_equal(df["reach.q [m]"].to_numpy(), res.q[:, 2])


def test_unreadable_index_is_rebuilt_from_the_files(results_ws):
    root = results_ws.root
    before = sorted(i.ref for i in results_ws.list())
    results_ws.close()
    for suffix in ("-wal", "-shm"):
        (root / f"index.sqlite{suffix}").unlink(missing_ok=True)
    (root / "index.sqlite").write_bytes(b"this is not a database" * 100)
    with pytest.raises(InputError, match="not a usable index.*reindex"):
        Workspace(root)
    r = cli("ws", "reindex", "--ws", root)
    assert r.exit_code == 0, r.output
    w = Workspace(root)
    assert sorted(i.ref for i in w.list()) == before and w.check() == []
    assert w.get("small").metrics["max_error"] == pytest.approx(1e-4)
    assert any(p.name.startswith("index.sqlite.unreadable-") for p in root.iterdir())


def test_where_fuzz_never_reaches_sql_as_text(results_ws):
    """Any filter text either parses (and runs as bound parameters) or is an InputError;
    the index is never changed by a listing."""
    from hypothesis import HealthCheck, given, settings
    from hypothesis import strategies as st

    alphabet = st.sampled_from(list("max_error[]<>=!; '\"-+.e0123456789 andORDROPTABLE*()/\\"))
    before = sorted(i.ref for i in results_ws.list())

    @settings(max_examples=120, deadline=None, derandomize=True,
              suppress_health_check=[HealthCheck.function_scoped_fixture])
    @given(st.text(alphabet, max_size=40))
    def check(text):
        try:
            results_ws.list(where=text)
        except InputError as exc:
            assert "--where" in str(exc)

    check()
    assert sorted(i.ref for i in results_ws.list()) == before
