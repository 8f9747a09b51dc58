"""The results store: compact storage, atomic swaps (exchange and versioned link),
clean-up of dead writers' leftovers, clear errors on damaged files, and writers
killed at random moments by real signals."""

from __future__ import annotations

import faulthandler
import json
import os
import random
import signal
import subprocess
import sys
import time
import zipfile
from pathlib import Path

import numpy as np
import pytest
from killing import wait_dead

from manipcad import folders
from manipcad.errors import InputError
from manipcad.folders import SaveInterrupted, clean_stale, leftovers
from manipcad.sim.simulate import SimulationResult
from manipcad.store.results import every_for, load_result, save_result, write_csv


def fake_result(run_id: int, k: int = 2000, n: int = 3) -> SimulationResult:
    """A result whose every array and its robot name carry ``run_id`` (to detect mixes)."""
    full = np.full((k, n), float(run_id))
    return SimulationResult(t=np.linspace(0.0, 1.0, k), q=full, qd=full, q_ref=full,
                            qd_ref=full, u=full, current=full, tau=full,
                            joint_names=tuple(f"j{i}" for i in range(n)),
                            robot=f"run-{run_id}", settings={"dt": 1e-3, "drives": True},
                            metrics={f"j{i}": {"max_error": 0.0} for i in range(n)})


def assert_whole(out: Path) -> int:
    """The result in ``out`` loads and is one run throughout; returns its id."""
    res, doc = load_result(out)
    run_id = int(doc["robot"].split("-")[1])
    for name in ("q", "qd", "q_ref", "qd_ref", "u", "current", "tau"):
        assert np.all(getattr(res, name) == run_id), f"{name} mixes runs"
    return run_id


def dead_pid() -> int:
    proc = subprocess.Popen([sys.executable, "-c", "pass"])
    proc.wait()
    return proc.pid


# ------------------------------------------------------------------ storage


def test_compressed_npz_without_csv_round_trip(tmp_path):
    res = fake_result(3, k=5000, n=9)
    res.q = np.sin(np.linspace(0, 10, 5000))[:, None] * np.arange(1, 10)
    out = save_result(res, tmp_path / "r", csv=False, plot=False)
    assert sorted(os.listdir(out)) == ["inputs", "metrics.json", "timeseries.npz"]
    with zipfile.ZipFile(out / "timeseries.npz") as z:
        assert all(i.compress_type == zipfile.ZIP_DEFLATED for i in z.infolist())
        raw = sum(i.file_size for i in z.infolist())
        packed = sum(i.compress_size for i in z.infolist())
    assert packed < 0.5 * raw  # 7 constant arrays compress to nothing, q (sin) less
    back, _ = load_result(out)
    assert back.q.dtype == np.float64 and np.array_equal(back.q, res.q)  # full precision
    csv = write_csv(back, tmp_path / "r.csv", joint_types=["revolute"] * 9)
    header = csv.read_text().splitlines()[0].split(",")
    assert header[:3] == ["t [s]", "j0.q [rad]", "j0.qd [rad/s]"] and len(header) == 1 + 9 * 8
    data = np.loadtxt(csv, delimiter=",", skiprows=1)
    assert np.allclose(data[:, 1 + 8 * 4], res.q[:, 4], rtol=1e-9)


def test_every_for():
    assert every_for(1e-4, [1e-3]) == 10
    assert every_for(1e-4, [1e-3, 4e-4]) == 2
    assert every_for(1e-3, [1e-3]) == 1
    assert every_for(1e-4, []) == 1


# ------------------------------------------------------------------ swaps


def test_exchange_swaps_two_folders(tmp_path):
    if not sys.platform.startswith("linux"):
        pytest.skip("renameat2 is Linux's")
    a, b = tmp_path / "a", tmp_path / "b"
    a.mkdir()
    b.mkdir()
    (a / "x").write_text("a")
    (b / "x").write_text("b")
    assert folders.exchange(a, b) is True
    assert (a / "x").read_text() == "b" and (b / "x").read_text() == "a"


def test_force_replaces_by_exchange(tmp_path):
    if not folders.exchange_supported(tmp_path):
        pytest.skip("file system without RENAME_EXCHANGE")
    out = tmp_path / "r"
    save_result(fake_result(1), out, plot=False, csv=False)
    inode = out.stat().st_ino
    with pytest.raises(InputError, match="not empty"):
        save_result(fake_result(2), out, plot=False, csv=False)
    save_result(fake_result(2), out, plot=False, csv=False, force=True)
    assert assert_whole(out) == 2 and out.stat().st_ino != inode and not out.is_symlink()
    assert leftovers(tmp_path) == []


def test_versioned_link_fallback(tmp_path, monkeypatch):
    monkeypatch.setattr(folders, "exchange", lambda a, b: False)
    monkeypatch.setattr(folders, "exchange_supported", lambda folder: False)
    out = tmp_path / "r"
    save_result(fake_result(1), out, plot=False, csv=False)
    assert out.is_symlink() and not os.path.isabs(os.readlink(out))
    first = out.resolve()
    save_result(fake_result(2), out, plot=False, csv=False, force=True)
    assert out.is_symlink() and out.resolve() != first and not first.exists()
    assert assert_whole(out) == 2
    assert [p.name for p in tmp_path.iterdir() if not p.name.startswith(".r.v-")] == ["r"]
    with pytest.raises(InputError, match="not empty"):
        save_result(fake_result(3), out, plot=False, csv=False)


def test_ctrl_c_after_install_says_saved_and_next_save_cleans(tmp_path, monkeypatch):
    out = tmp_path / "r"
    save_result(fake_result(1), out, plot=False, csv=False)

    def interrupted(path):
        raise KeyboardInterrupt

    monkeypatch.setattr(folders, "_remove", interrupted)
    with pytest.raises(SaveInterrupted, match="was written whole"):
        save_result(fake_result(2), out, plot=False, csv=False, force=True)
    monkeypatch.undo()
    assert assert_whole(out) == 2
    # the old copy is this (live) process's: kept until its writer is gone
    assert [tag for _, tag, _ in leftovers(tmp_path)] in (["partial"], ["old"], ["v"])


def test_clean_stale_removes_dead_writers_and_restores_half_swap(tmp_path):
    pid = dead_pid()
    (tmp_path / f".r.partial-{pid}-abc").mkdir()
    (tmp_path / f".r.partial-{pid}-abc" / "timeseries.npz").write_bytes(b"x" * 100)
    (tmp_path / ".r.partial-oldstyle").mkdir()  # an earlier manipcad's name: no pid
    live = tmp_path / f".r.partial-{os.getpid()}-def"
    live.mkdir()
    # a kill between the two renames: r missing, its data in .old-
    save_result(fake_result(7), tmp_path / "s", plot=False, csv=False)
    os.rename(tmp_path / "s", tmp_path / f".s.old-{pid}-ghi")
    done = clean_stale(tmp_path)
    assert sorted(done) == sorted([f"removed .r.partial-{pid}-abc", "removed .r.partial-oldstyle",
                                   f"restored s from .s.old-{pid}-ghi"])
    assert live.exists() and assert_whole(tmp_path / "s") == 7
    assert [p.name for p, _, _ in leftovers(tmp_path)] == [live.name]


# ------------------------------------------------------------------ damaged files


@pytest.fixture
def saved(tmp_path) -> Path:
    return save_result(fake_result(1), tmp_path / "r", plot=False, csv=False)


def test_load_truncated_npz_names_file(saved):
    npz = saved / "timeseries.npz"
    npz.write_bytes(npz.read_bytes()[: npz.stat().st_size // 2])
    with pytest.raises(InputError, match=r"timeseries\.npz: (truncated|corrupt)") as exc:
        load_result(saved)
    assert str(npz) in str(exc.value)


def test_load_missing_array_names_it(saved):
    npz = saved / "timeseries.npz"
    with np.load(npz) as d:
        arrays = {k: d[k] for k in d.files if k != "tau"}
    np.savez_compressed(npz, **arrays)
    with pytest.raises(InputError, match=r"timeseries\.npz: tau: array missing"):
        load_result(saved)


def test_load_wrong_shape_and_bad_json(saved):
    npz = saved / "timeseries.npz"
    with np.load(npz) as d:
        arrays = {k: d[k] for k in d.files}
    arrays["q"] = arrays["q"][:-1]
    np.savez_compressed(npz, **arrays)
    with pytest.raises(InputError, match=r"q: has shape \(1999, 3\), expected \(2000, 3\)"):
        load_result(saved)
    (saved / "metrics.json").write_text("{not json")
    with pytest.raises(InputError, match=r"metrics\.json: cannot read"):
        load_result(saved)
    with pytest.raises(InputError, match="no such result folder"):
        load_result(saved.parent / "nothing")


# ------------------------------------------------------------------ real kills


def _writer_loop(out: Path, first_id: int, fd: int) -> None:
    """The child: save runs first_id, first_id + 1, ... forever, reporting each on fd."""
    run_id = first_id
    while True:
        save_result(fake_result(run_id, k=3000, n=4), out, plot=False, csv=False, force=True)
        os.write(fd, f"{run_id}\n".encode())
        run_id += 1


_STOP = {signal.SIGINT, signal.SIGTERM}


def _reap(pid: int, stacks: Path, timeout: float = 20.0) -> None:
    """Wait for the killed child; one that outlives ``timeout`` s (not counting disk
    waits, where no signal is taken: see tests/killing.py) fails, it does not hang, and
    the failure shows where the child was (its threads' Python stacks, written by
    faulthandler on SIGUSR1 into ``stacks``, at C level even if Python code cannot run)."""
    reason = wait_dead(pid, lambda: os.waitpid(pid, os.WNOHANG) != (0, 0), timeout)
    if reason is not None:
        os.kill(pid, signal.SIGUSR1)
        time.sleep(1.0)
        os.kill(pid, signal.SIGKILL)
        os.waitpid(pid, 0)
        where = stacks.read_text() if stacks.exists() else "(no stack written)"
        pytest.fail(f"the writer {pid} {reason}; its stacks:\n{where}")


def test_reap_fails_a_writer_that_ignores_its_signal():
    """The kill tests' wait can say "fail": a child that ignores SIGTERM is reported
    with its signal masks once it has spent the allowed time awake."""
    child = subprocess.Popen([sys.executable, "-c", "import signal, sys, time; "
                              "signal.signal(signal.SIGTERM, signal.SIG_IGN); "
                              "print(flush=True); time.sleep(60)"], stdout=subprocess.PIPE)
    try:
        child.stdout.readline()  # its handler is set
        child.send_signal(signal.SIGTERM)
        reason = wait_dead(child.pid, lambda: child.poll() is not None, 0.5)
        assert reason is not None and "survived its signal" in reason
        assert "SigIgn" in reason and "State" in reason
    finally:
        child.kill()
        child.wait()


def test_a_writer_that_outlives_its_signal_fails_with_its_stack(tmp_path):
    """_reap says fail, with where the child was, for a child that ignores SIGINT and
    spins (the case it exists for)."""
    signal.pthread_sigmask(signal.SIG_BLOCK, _STOP)
    pid = os.fork()
    if pid == 0:
        try:
            faulthandler.register(signal.SIGUSR1, all_threads=True,
                                  file=open(tmp_path / f"stacks-{os.getpid()}", "w"))
            signal.signal(signal.SIGINT, signal.SIG_IGN)
            signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOP)
            while True:
                pass
        finally:
            os._exit(0)
    signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOP)
    os.kill(pid, signal.SIGINT)
    with pytest.raises(pytest.fail.Exception, match=r"(?s)survived its signal.*its stacks:.*"
                       r"test_a_writer_that_outlives_its_signal_fails_with_its_stack"):
        _reap(pid, tmp_path / f"stacks-{pid}", timeout=0.5)


@pytest.mark.parametrize("mode", ["exchange", "versioned"])
def test_killed_writers_leave_old_or_new_never_neither(tmp_path, mode, monkeypatch):
    """Fork real writer processes and kill each at a random moment (SIGKILL, SIGTERM,
    SIGINT); after each kill the result is one whole run, at least as new as the last
    reported save, and the next save leaves no leftovers."""
    if mode == "versioned":
        monkeypatch.setattr(folders, "_EXCHANGE_OFF", True)
        monkeypatch.setattr(folders, "exchange_supported", lambda folder: False)
    elif not folders.exchange_supported(tmp_path):
        pytest.skip("file system without RENAME_EXCHANGE")
    rng = random.Random(11)
    out = tmp_path / "r"
    save_result(fake_result(0, k=3000, n=4), out, plot=False, csv=False)
    next_id = 1
    kills = mid_save = 0
    for sig in (signal.SIGKILL, signal.SIGTERM, signal.SIGINT) * 4:
        r, w = os.pipe()
        # the signals stay blocked until the child has its own handlers: a signal sent
        # before that would meet the handlers this process inherited (a library's
        # SIGTERM handler that only sets a flag), and the writer would never stop
        signal.pthread_sigmask(signal.SIG_BLOCK, _STOP)
        pid = os.fork()
        if pid == 0:  # the writer
            try:
                os.close(r)
                faulthandler.register(signal.SIGUSR1, all_threads=True,
                                      file=open(tmp_path / f"stacks-{os.getpid()}", "w"))
                signal.signal(signal.SIGTERM, signal.SIG_DFL)
                signal.signal(signal.SIGINT, signal.default_int_handler)
                signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOP)
                _writer_loop(out, next_id, w)
            finally:
                os._exit(0)
        signal.pthread_sigmask(signal.SIG_UNBLOCK, _STOP)
        os.close(w)
        time.sleep(rng.uniform(0.0, 0.15))
        os.kill(pid, sig)
        _reap(pid, tmp_path / f"stacks-{pid}")
        with os.fdopen(r) as fh:
            reported = [int(x) for x in fh.read().split()]
        kills += 1
        live = out.resolve().name if out.is_symlink() else None
        mid_save += any(p.name != live for p, _, _ in leftovers(tmp_path, "r"))
        got = assert_whole(out)
        assert got >= (reported[-1] if reported else 0)
        assert got <= next_id + len(reported)  # nothing from the future
        next_id += len(reported) + 1
    assert kills == 12
    # the kills did land inside saves (a dead writer's leftover), not only between them
    assert mid_save >= 2, f"only {mid_save} of {kills} kills hit a save in progress"
    clean_stale(tmp_path)
    names = [p.name for p, _, _ in leftovers(tmp_path)]
    if mode == "versioned":  # only the version the link points to remains
        assert names == [out.resolve().name]
    else:
        assert names == []
    save_result(fake_result(99, k=10, n=4), out, plot=False, csv=False, force=True)
    assert assert_whole(out) == 99
    assert [p.name for p in tmp_path.iterdir() if p.name in ("r",) or ".r." in p.name
            and not (out.is_symlink() and p.name == out.resolve().name)] == ["r"]


def test_metrics_json_is_one_document(saved):
    doc = json.loads((saved / "metrics.json").read_text())
    assert doc["robot"] == "run-1" and doc["samples"] == 2000
