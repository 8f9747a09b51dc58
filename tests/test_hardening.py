"""Bad-input reproducers: each bad input must give the project's own error (or a
correct result), never a traceback, a silent wrong answer or a runaway resource.

Grouped by kind: reading files, values, API inputs, the CLI's guard, saves. Each
case failed before its fix.
"""

from __future__ import annotations

import os
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

from manipcad.errors import InputError, ManipcadError, ManipcadWarning
from manipcad.fileio import MAX_DEPTH, MAX_NODES, parse_yaml, read_yaml
from manipcad.model.load import load_robot
from manipcad.trajectories import load_trajectory

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
TWO_LINK = (EXAMPLES / "two_link.yaml").read_text()


def laughs(levels: int = 9) -> str:
    """The 'billion laughs' alias bomb: 9**levels values from a few lines."""
    out = ["l0: &l0 [lol, lol, lol, lol, lol, lol, lol, lol, lol]"]
    for k in range(1, levels):
        out.append(f"l{k}: &l{k} [" + ", ".join([f"*l{k - 1}"] * 9) + "]")
    return "\n".join(out) + "\n"


def write(tmp_path: Path, text: str, name: str = "f.yaml") -> Path:
    p = tmp_path / name
    p.write_text(text)
    return p


# --------------------------------------------------------------------------- reading files

BOMBS = {
    "laughs": laughs(),
    "laughs_as_gain": "type: pid\nkp: &a [1, 1, 1, 1, 1, 1, 1, 1, 1, 1]\n"
                      + "".join(f"k{i}: &{chr(98 + i)} [" + ", ".join(
                          [f"*{chr(97 + i)}"] * 10) + "]\n" for i in range(7)),
    "deep_flow": "name: x\njoints: " + "[" * 20000 + "]" * 20000 + "\n",
    "deep_block": "name: x\n" + "".join(" " * i + f"k{i}:\n" for i in range(5000)) + " " * 5000
                  + "v: 1\n",
    "recursive_alias": "name: &a [x, *a]\n",
    "deep_by_alias": "a: &a " + "[" * 60 + "1" + "]" * 60 + "\nb: " + "[" * 60 + "*a"
                     + "]" * 60 + "\n",
}


@pytest.mark.parametrize("kind", BOMBS)
@pytest.mark.parametrize("loader", ["robot", "trajectory", "yaml"])
def test_yaml_bombs_refused(tmp_path, kind, loader):
    p = write(tmp_path, BOMBS[kind])
    load = {"robot": load_robot, "trajectory": load_trajectory, "yaml": read_yaml}[loader]
    # the behaviour, not a library's wording: one InputError naming the file, saying the
    # text was refused (the YAML scanner or this reader's prescan may be first to see it)
    with pytest.raises(InputError, match=r"refused") as err:
        load(str(p))
    assert err.value.source == str(p)
    assert any(w in str(err.value) for w in ("values", "deeper", "recursive", "nest"))


@pytest.mark.slow
def test_limits_are_generous_enough_for_real_files():
    assert parse_yaml("a: " + "[" * (MAX_DEPTH - 1) + "1" + "]" * (MAX_DEPTH - 1), "x")
    rows = (MAX_NODES - 10) // 7
    text = "points:\n" + "".join("- [0, 1, 2, 3, 4, 5]\n" for _ in range(rows))
    assert len(parse_yaml(text, "x")["points"]) == rows


@pytest.mark.parametrize("expr", ["1+" * 50000 + "1", "-" * 100000 + "1",
                                  "(" * 5000 + "1" + ")" * 5000],
                         ids=["50k_terms", "100k_minus", "5k_parens"])
def test_huge_expression_refused(tmp_path, expr):
    text = TWO_LINK.replace("mass: 0.8", f"mass: '{expr}'")
    with pytest.raises(InputError, match="joints\\[1\\].link.mass.*(too long|characters)"):
        load_robot(str(write(tmp_path, text)))


def test_duplicate_key_refused_in_trajectory(tmp_path):
    p = write(tmp_path, "type: cosine\namplitude: [0.5]\nomega: [4.0]\namplitude: [9.0]\n")
    with pytest.raises(InputError, match="line 4.*duplicate key 'amplitude'"):
        load_trajectory(p)


def test_duplicate_key_refused_in_every_reader(tmp_path):
    # read_yaml's old unique_keys=False (regulator and requirement files) is ignored
    p = write(tmp_path, "type: pid\nkp: 1\nkp: 2\n")
    with pytest.raises(InputError, match="duplicate key 'kp'"):
        read_yaml(p, unique_keys=False)


@pytest.mark.parametrize("text,value", [("1e-1", 0.1), ("1.0e12", 1e12), ("2.5E+3", 2500.0),
                                        ("1e5", 1e5), ("-.5", -0.5), ("0.5", 0.5)])
def test_one_float_rule(tmp_path, text, value):
    p = write(tmp_path, f"type: quintic\nq_start: [0]\nq_end: [{text}]\nduration: 2\n")
    assert load_trajectory(p).q_end[0] == value
    robot = TWO_LINK.replace("mass: 0.8", f"mass: {text.lstrip('-')}")
    assert load_robot(str(write(tmp_path, robot, "r.yaml"))).mass[1] == abs(value)


def test_directory_fifo_empty_name(tmp_path):
    d = tmp_path / "d.yaml"
    d.mkdir()
    for load in (load_robot, load_trajectory, read_yaml):
        with pytest.raises(InputError, match="is a directory"):
            load(str(d))
    with pytest.raises(InputError, match="empty file name"):
        load_robot("")
    with pytest.raises(InputError, match="empty file name"):
        load_trajectory("")
    fifo = tmp_path / "pipe.yaml"
    os.mkfifo(fifo)
    for load in (load_robot, load_trajectory, read_yaml):
        with pytest.raises(InputError, match="is a FIFO"):
            load(str(fifo))


def test_urdf_directory_and_fifo(tmp_path):
    d = tmp_path / "d.urdf"
    d.mkdir()
    with pytest.raises(InputError, match="is a directory"):
        load_robot(str(d))
    fifo = tmp_path / "p.urdf"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="is a FIFO"):
        load_robot(str(fifo))


@pytest.mark.parametrize("text,match", [
    ("d: 2020-02-30\n", "bad value"),              # ValueError from the date constructor
    ("x: " + "1" * 5000 + "\n", "bad value"),     # int of more than 4300 digits
    ("? [a, b]\n: 1\n", "key must be text"),      # unhashable key: TypeError
    ("a: 1\n---\nb: 2\n", "single document"),
], ids=["bad_date", "huge_int", "list_key", "two_documents"])
def test_yaml_constructor_errors(tmp_path, text, match):
    with pytest.raises(InputError, match=match):
        read_yaml(write(tmp_path, text))


def test_csv_directory_fifo(tmp_path):
    from manipcad.dynamics.identification import load_torque_data

    robot = load_robot("puma560")
    fifo = tmp_path / "t.csv"
    os.mkfifo(fifo)
    with pytest.raises(InputError, match="is a FIFO"):
        load_torque_data(fifo, robot)


@pytest.mark.parametrize("text,match", [
    ("type: spline\ntimes: [0, 1, 2]\npoints: [[1.0e308], [0], [1]]\n", "cannot be built"),
    ("type: cosine\namplitude: [1e300]\nomega: [1e10]\nduration: 1\n", "not finite"),
    ("type: trapezoidal\nq_start: [0]\nq_end: [1e308]\nv_max: 1e-308\na_max: 1\n",
     "cannot be built|finite"),  # a ZeroDivisionError inside the law, before
], ids=["spline_1e308", "cosine_overflow", "trapezoidal_endless"])
def test_trajectory_values_that_overflow(tmp_path, text, match):
    with pytest.raises(InputError, match=match) as err:
        load_trajectory(write(tmp_path, text))
    assert err.value.source.endswith("f.yaml")


def test_urdf_mimic_warns(tmp_path):
    from manipcad.model.urdf import robot_from_urdf_string

    text = """<robot name="g"><link name="base"/><link name="f1"/><link name="f2"/>
    <joint name="j1" type="prismatic"><parent link="base"/><child link="f1"/>
      <limit lower="0" upper="0.04"/></joint>
    <joint name="j2" type="prismatic"><parent link="base"/><child link="f2"/>
      <limit lower="0" upper="0.04"/><mimic joint="j1" multiplier="1" offset="0"/></joint>
    </robot>"""
    with pytest.warns(ManipcadWarning, match="'j2' mimics 'j1'.*INDEPENDENT"):
        r = robot_from_urdf_string(text)
    assert r.n == 2
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        assert robot_from_urdf_string(text, lock={"j2": 0.0}).n == 1


# --------------------------------------------------------------------------- values

def _puma_arrays():
    r = load_robot("puma560")
    return r, dict(name="p", joint_types=r.joint_types, parent=r.parent,
                   placement_R=r.placement_R, placement_p=r.placement_p, mass=r.mass,
                   com=r.com, inertia=r.inertia)


@pytest.mark.parametrize("field,index,value,match", [
    ("com", (2, 0), np.nan, "com.*finite"),
    ("placement_p", (1, 2), np.inf, "placement.*finite"),
    ("inertia", (3, 0, 0), np.nan, "inertia.*finite"),
    ("mass", (0,), np.inf, "mass"),
])
def test_from_arrays_refuses_non_finite(field, index, value, match):
    from manipcad.model.robot import Robot

    _, kw = _puma_arrays()
    a = np.array(kw[field], dtype=float)
    a[index] = value
    kw[field] = a
    with pytest.raises(ManipcadError, match=match):
        Robot.from_arrays(**kw)


@pytest.mark.parametrize("kw,match", [
    (dict(gravity=(0, 0, np.inf)), "gravity.*finite"),
    (dict(offset=[0, np.nan, 0, 0, 0, 0]), "offset.*finite"),
    (dict(tool_p=(np.inf, 0, 0)), "tool.*finite"),
    (dict(limits=np.tile([np.nan, 1.0], (6, 1))), "limits"),
])
def test_from_arrays_refuses_non_finite_extras(kw, match):
    from manipcad.model.robot import Robot

    _, base = _puma_arrays()
    with pytest.raises(ManipcadError, match=match):
        Robot.from_arrays(**base, **kw)


@pytest.mark.parametrize("kw,match", [
    (dict(J=np.nan), "J.*finite"), (dict(ratio=np.inf), "ratio.*finite"),
    (dict(k_v=np.nan), "k_v"), (dict(M_f=(np.nan, 0.0)), "M_f"),
    (dict(R=0.0), "R.*> 0"), (dict(k_m=np.inf), "k_m"), (dict(L=np.inf), "L"),
    (dict(u_max=np.nan), "u_max"), (dict(k_u=np.nan), "k_u"),
])
def test_drive_refuses_non_physical(kw, match):
    from manipcad.model.robot import Drive

    with pytest.raises(ManipcadError, match=match):
        Drive(**kw)


def test_with_payload_refuses_non_finite():
    r = load_robot("puma560")
    with pytest.raises(ManipcadError, match="payload com.*finite"):
        r.with_payload(1.0, com=(np.nan, 0, 0))
    with pytest.raises(ManipcadError, match="payload inertia"):
        r.with_payload(1.0, inertia=np.full((3, 3), np.inf))
    with pytest.raises(ManipcadError, match="payload inertia"):
        r.with_payload(1.0, inertia=-np.eye(3))


@pytest.mark.parametrize("old,new,field", [
    ("dh: {a: 0.3, alpha: 0, d: 0, theta: 0}", "dh: {a: .inf, alpha: 0, d: 0, theta: 0}",
     "joints[1].dh.a"),
    ("dh: {a: 0.3, alpha: 0, d: 0, theta: 0}", "dh: {a: 1e400, alpha: 0, d: 0, theta: 0}",
     "joints[1].dh.a"),
    ("gravity: [0, 0, -9.81]", "gravity: [0, 0, -.inf]", "gravity"),
    ("R: 2.45 ", "R: 0 ", "joints[1].drive.R"),
    ("com: [0.125, 0, 0]", "com: [1e400, 0, 0]", "joints[1].link.com"),
    ("mass: 0.8", "mass: " + "9" * 400, "joints[1].link.mass"),
], ids=["dh_inf", "dh_1e400", "gravity_inf", "R_zero", "com_1e400", "mass_400_digits"])
def test_robot_file_non_physical_values(tmp_path, old, new, field):
    assert old in TWO_LINK
    p = write(tmp_path, TWO_LINK.replace(old, new))
    with pytest.raises(InputError) as err:
        load_robot(str(p))
    assert err.value.source == str(p) and err.value.field == field, str(err.value)
    if "drive" in field:
        assert "elbow" in str(err.value)


def _zero_mass_robot():
    from manipcad.model.robot import Robot

    n = 2
    return Robot.from_arrays("massless", ["revolute"] * n, [-1, 0], np.tile(np.eye(3), (n, 1, 1)),
                             np.zeros((n, 3)), np.zeros(n), np.zeros((n, 3)),
                             np.zeros((n, 3, 3)))


@pytest.mark.parametrize("method", ["aba", "crba"])
@pytest.mark.parametrize("batch", [False, True])
def test_zero_mass_detected_alike(method, batch):
    import manipcad

    r = _zero_mass_robot()
    z = np.zeros((3, 2)) if batch else np.zeros(2)
    with pytest.raises(ManipcadError, match="not positive definite at state 0.*moves no mass"):
        manipcad.forward_dynamics(r, z, z, z, method=method)
    with pytest.raises(ManipcadError, match="not positive definite"):
        manipcad.forward_dynamics(r, [0.0, 0.0], [0.0, 0.0], [0.0, 0.0], method=method)


def test_simulate_refuses_a_start_where_a_joint_moves_no_mass():
    """simulate's initial check (dynamics.api.moves_mass: H from the inverse dynamics and
    numpy's Cholesky) refuses what the forward dynamics refuses, naming the state; a robot
    whose joints all move mass passes."""
    import manipcad
    from manipcad.dynamics.api import moves_mass

    r = _zero_mass_robot()
    assert not moves_mass(r, np.zeros(2), drives=False)
    with pytest.raises(ManipcadError, match="cannot simulate 'massless' from its initial "
                       "state: the mass matrix is not positive definite at state 0"):
        manipcad.simulate(r, t_end=1e-3, dt=1e-3, drives=False)
    arm = manipcad.load_robot("cylindrical")
    assert moves_mass(arm, np.full(arm.n, 0.1), drives=False)
    assert moves_mass(arm, np.full(arm.n, 0.1), drives=True)


# --------------------------------------------------------------------------- API inputs

@pytest.mark.parametrize("call,arg", [
    (lambda m, r, z: m.inverse_dynamics(r, ["a"] * 6, z, z), "q"),
    (lambda m, r, z: m.inverse_dynamics(r, z, [None] * 6, z), "qd"),
    (lambda m, r, z: m.inverse_dynamics(r, z, z, z + 1j), "qdd"),
    (lambda m, r, z: m.forward_dynamics(r, z, z, ["x"] * 6), "tau"),
    (lambda m, r, z: m.mass_matrix(r, [[0.0] * 6, [0.0] * 5]), "q"),
    (lambda m, r, z: m.inverse_dynamics(r, z, z, z, gravity=["a", 0, 0]), "gravity"),
    (lambda m, r, z: m.inverse_dynamics(r, z, z, z, f_ext="nope"), "f_ext"),
], ids=["text_q", "none_qd", "complex_qdd", "text_tau", "ragged_q", "text_gravity",
        "text_fext"])
def test_api_inputs_name_the_argument(call, arg):
    import manipcad

    r = load_robot("puma560")
    with pytest.raises(ManipcadError, match=f"^{arg} must be real numbers"):
        call(manipcad, r, np.zeros(6))


# --------------------------------------------------------------------------- the CLI's guard

def _cli(*args, env=None):
    from typer.testing import CliRunner

    from manipcad.cli import app

    res = CliRunner().invoke(app, [str(a) for a in args], env={"COLUMNS": "300", **(env or {})})
    return res, res.output + (res.stderr or "")


@pytest.mark.parametrize("exc,words", [
    (OSError(30, "Read-only file system", "/ro/out"), ["/ro/out", "Read-only file system"]),
    (OSError(28, "No space left on device", "/full/out/fig3.png"),
     ["/full/out/fig3.png", "No space left"]),
    (MemoryError("Unable to allocate 74.5 GiB for an array with shape (10000000001,)"),
     ["out of memory", "74.5 GiB"]),
    (ValueError("Maximum allowed size exceeded"), ["unexpected ValueError", "Maximum allowed"]),
    (OverflowError("cannot convert float infinity to integer"), ["unexpected OverflowError"]),
], ids=["read_only", "disk_full", "memory", "value", "overflow"])
def test_cli_edge_catches_everything(monkeypatch, tmp_path, exc, words):
    import manipcad.study

    def boom(*a, **k):
        raise exc

    monkeypatch.setattr(manipcad.study, "run_fig3", boom)
    res, out = _cli("study", "fig3", "--out", tmp_path / "o", "--t-end", "0.1", "--no-progress")
    assert res.exit_code == 2, out
    assert "Traceback" not in out and res.exception is None or isinstance(res.exception,
                                                                          SystemExit)
    for w in words:
        assert w in out, out


@pytest.mark.parametrize("args,words", [
    (["--t-end", "1e6"], ["--t-end", "1e+10 steps", "more than the limit"]),
    (["--dt", "1e-300"], ["--t-end", "steps", "limit"]),
    (["--t-end", "1e12"], ["--t-end", "steps"]),
    (["--t-end", "2000", "--dt", "1e-4"], ["2e+07 steps need about", "GB", "available"]),
], ids=["t_end_1e6", "dt_1e-300", "t_end_1e12", "memory"])
def test_study_refuses_before_allocating(monkeypatch, tmp_path, args, words):
    import manipcad.budget
    import manipcad.study

    monkeypatch.setattr(manipcad.budget, "MEMORY_BUDGET", 2 * 10**9)
    monkeypatch.setattr(manipcad.study, "run_fig3",
                        lambda *a, **k: pytest.fail("ran instead of refusing"))
    res, out = _cli("study", "fig3", "--out", tmp_path / "o", "--no-progress", *args)
    assert res.exit_code == 2, out
    for w in words:
        assert w in out, out
    assert not (tmp_path / "o").exists()


@pytest.mark.slow
def test_cli_no_traceback_in_a_real_process(tmp_path):
    import subprocess
    import sys

    traj = write(tmp_path, "type: cosine\namplitude: [0.5, 0, 0.25]\nomega: [4, 0, 16]\n"
                 "duration: 1.6\n", "t.yaml")
    for args in (["simulate", "cylindrical", "--trajectory", str(traj), "--dt", "1e-300",
                  "--out", str(tmp_path / "r")],
                 ["size", "cylindrical", "--trajectory", str(tmp_path)],
                 ["study", "fig3", "--out", str(tmp_path / "s"), "--t-end", "1e12"]):
        p = subprocess.run([sys.executable, "-m", "manipcad", *args], capture_output=True,
                           text=True, timeout=120, env={**os.environ, "COLUMNS": "300"})
        assert p.returncode == 2, (args, p.stdout, p.stderr)
        last = p.stderr.strip().splitlines()[-1]  # after "compiling kernels ..." notes
        assert "Traceback" not in p.stderr and last.startswith("error:"), p.stderr


# --------------------------------------------------------------------------- saves

def test_write_folder_whole_or_not_at_all(tmp_path):
    from manipcad.folders import write_folder

    out = tmp_path / "study"
    with write_folder(out) as tmp:
        (tmp / "fig3.json").write_text("old")
        (tmp / "fig3.png").write_text("old")
    with pytest.raises(RuntimeError), write_folder(out) as tmp:
        (tmp / "fig3.json").write_text("new")
        raise RuntimeError("plot failed")
    assert {p.name: p.read_text() for p in out.iterdir()} == {"fig3.json": "old",
                                                             "fig3.png": "old"}
    with write_folder(out) as tmp:
        (tmp / "fig3.json").write_text("new")
    assert [p.name for p in out.iterdir()] == ["fig3.json"]
    assert sorted(p.name for p in tmp_path.iterdir()) == ["study"]  # nothing left behind


def test_write_folder_refusals(tmp_path):
    from manipcad.folders import write_folder

    f = write(tmp_path, "x", "file")
    with pytest.raises(InputError, match="not a folder"), write_folder(f):
        pass
    with pytest.raises(InputError, match="does not exist"), write_folder(tmp_path / "a" / "b"):
        pass


def test_write_folder_two_rename_fallback_and_restore(tmp_path, monkeypatch):
    import manipcad.folders as fio

    out = tmp_path / "res"
    with fio.write_folder(out) as tmp:
        (tmp / "a").write_text("1")
    monkeypatch.setattr(fio, "exchange", lambda a, b: False)
    with fio.write_folder(out) as tmp:
        (tmp / "a").write_text("2")
    assert (out / "a").read_text() == "2"
    # a writer killed between the two renames: OUT missing, its old copy beside it
    dead = 2**22 + 12345
    while fio._alive(dead):
        dead += 1
    old = tmp_path / f".res.old-{dead}-abcd1234"
    os.rename(out, old)
    (tmp_path / f".res.partial-{dead}-zz").mkdir()
    assert sorted(fio.clean_stale(tmp_path, "res")) == [
        f"removed .res.partial-{dead}-zz", f"restored res from .res.old-{dead}-abcd1234"]
    assert (out / "a").read_text() == "2"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["res"]


def _writer(out: Path, ready, when: float) -> None:  # runs in a forked child
    import signal
    import time

    from manipcad.folders import write_folder

    # the stops of a process started from a shell, whatever this child inherited: one was
    # seen (py-spy, /proc status) writing on 30 s after its SIGINT with SIGINT and SIGQUIT
    # ignored (SigIgn 0x1001006), taken over at the fork from the xdist worker (which
    # ignores neither between tests; C's system() in another thread would do it)
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, signal.SIG_DFL)

    for k in range(100000):
        with write_folder(out) as tmp:
            for name in ("fig3.json", "fig3.png", "report.html"):
                (tmp / name).write_text(str(k % 10) * 200000)
            if k == 0:
                ready.set()
            time.sleep(when)


@pytest.mark.parametrize("sig", ["SIGKILL", "SIGTERM", "SIGINT"])
def test_kill_during_folder_write(tmp_path, sig):
    """Writers replacing a 3-file folder in a loop, killed at random moments: the folder
    is always whole (3 files of one writing), and the next run leaves nothing behind."""
    import multiprocessing
    import random
    import signal

    from manipcad.folders import write_folder

    def whole(tag: str) -> None:
        with write_folder(out) as tmp:
            for name in ("fig3.json", "fig3.png", "report.html"):
                (tmp / name).write_text(tag * 200000)

    out = tmp_path / "s"
    whole("o")
    ctx = multiprocessing.get_context("fork")
    rng = random.Random(sig)
    for _ in range(8):
        ready = ctx.Event()
        p = ctx.Process(target=_writer, args=(out, ready, 0.001))
        p.start()
        assert ready.wait(30)
        ready.clear()
        time.sleep(rng.uniform(0.0, 0.03))
        os.kill(p.pid, getattr(signal, sig))
        from killing import wait_dead

        reason = wait_dead(p.pid, lambda p=p: p.join(0.01) or p.exitcode is not None, 30.0)
        if reason is not None:
            p.kill()
            p.join()
            pytest.fail(f"the writer {reason} ({sig})")
        files = sorted(out.iterdir())
        assert [f.name for f in files] == ["fig3.json", "fig3.png", "report.html"]
        texts = {f.read_text() for f in files}
        assert len(texts) == 1 and len(texts.pop()) == 200000  # complete and never a mix
        whole("o")  # the next run cleans what the dead writer left
        assert sorted(p.name for p in tmp_path.iterdir()) == ["s"]
