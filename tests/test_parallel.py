"""The sweep executor: serial and Dask runs agree, the cache computes only new cells."""

from __future__ import annotations

import os
import signal

import numpy as np
import pytest

import manipcad
from manipcad.errors import InputError, ManipcadError
from manipcad.parallel import Pool, TaskFailed, run_tasks, task_key
from manipcad.parallel.executor import check_workers
from manipcad.sizing import ratio_sweep
from manipcad.trajectories import cosine

FIG3 = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], duration=1.6)


def _square(x, offset=0.0):
    return x * x + offset


def _fails(x):
    if x == 2:
        raise ValueError("two is bad")
    return x


def _bad_input(x):
    raise InputError("cell", "x", f"refused {x}")


def _cube_part(x, k):
    return (x + k) ** 3


def _split_cells():
    """A Split cutting task {"x"} into parts k = 0..x (one unit of work each)."""
    from manipcad.parallel import Split

    return Split(plan=lambda task, common: (task["x"], [{"x": task["x"] + common["offset"],
                                                         "k": k} for k in range(task["x"] + 1)]),
                 run=_cube_part, combine=lambda x, parts: (x, sum(parts)))


def _cells(x, offset):  # what the split computes, whole
    return x, sum((x + offset + k) ** 3 for k in range(x + 1))


def test_serial_results_in_order_with_common_arguments():
    r = run_tasks(_square, [{"x": k} for k in range(7)], common={"offset": 0.5}, workers=1,
                  chunk=3, progress=False)
    assert list(r) == [k * k + 0.5 for k in range(7)]
    assert r.computed == 7 and r.cached == 0


def test_cache_computes_only_new_cells(tmp_path):
    calls = []

    def spy(tasks, offset):
        calls.extend(t["x"] for t in tasks)
        return [_square(t["x"], offset) for t in tasks]

    spy.__module__, spy.__qualname__ = __name__, "spy"
    first = run_tasks(spy, [{"x": k} for k in range(4)], common={"offset": 1.0}, workers=1,
                      cache_dir=tmp_path, batched=True, progress=False)
    assert calls == [0, 1, 2, 3] and first.computed == 4
    again = run_tasks(spy, [{"x": k} for k in range(4)], common={"offset": 1.0}, workers=1,
                      cache_dir=tmp_path, batched=True, progress=False)
    assert calls == [0, 1, 2, 3] and again.cached == 4 and list(again) == list(first)
    wider = run_tasks(spy, [{"x": k} for k in range(6)], common={"offset": 1.0}, workers=1,
                      cache_dir=tmp_path, batched=True, progress=False)
    assert calls == [0, 1, 2, 3, 4, 5] and wider.computed == 2 and wider.cached == 4
    assert list(wider) == [k * k + 1.0 for k in range(6)]
    # other common arguments: other keys, everything recomputed
    other = run_tasks(spy, [{"x": 1}], common={"offset": 2.0}, workers=1, cache_dir=tmp_path,
                      batched=True, progress=False)
    assert list(other) == [3.0] and other.computed == 1
    # a damaged cache file is recomputed, not trusted
    key = task_key(spy, {"x": 5}, {"offset": 1.0})
    (tmp_path / key[:2] / f"{key}.pkl").write_bytes(b"garbage")
    fixed = run_tasks(spy, [{"x": 5}], common={"offset": 1.0}, workers=1, cache_dir=tmp_path,
                      batched=True, progress=False)
    assert list(fixed) == [26.0] and fixed.computed == 1


def test_task_key_canonical():
    a = {"q": np.arange(3.0), "name": "x", "opts": {"b": 1, "a": 2}}
    b = {"opts": {"a": 2, "b": 1}, "name": "x", "q": np.arange(3.0)}
    assert task_key(_square, a) == task_key(_square, b)
    assert task_key(_square, a) != task_key(_square, {**a, "q": np.arange(3)})  # dtype counts
    assert task_key(_square, a) != task_key(_fails, a)
    assert task_key(_square, a, version="2") != task_key(_square, a)
    robot = manipcad.load_robot("cylindrical")
    heavier = robot.with_payload(1.0)
    assert task_key(_square, {"r": robot}) == task_key(_square, {"r": manipcad.load_robot(
        "cylindrical")})
    assert task_key(_square, {"r": robot}) != task_key(_square, {"r": heavier})


def test_bad_arguments_named():
    with pytest.raises(InputError, match="workers"):
        run_tasks(_square, [{"x": 1}], workers=0, progress=False)
    with pytest.raises(InputError, match="not both"):
        run_tasks(_square, [{"x": 1}], workers=2, scheduler="tcp://127.0.0.1:1", progress=False)
    with pytest.raises(InputError, match="scheduler"):
        run_tasks(_square, [{"x": 1}], scheduler="localhost", progress=False)
    with pytest.raises(InputError, match=r"tasks\[1\]"):
        run_tasks(_square, [{"x": 1}, 3], workers=1, progress=False)


def test_failures_name_the_task():
    with pytest.raises(TaskFailed, match=r"task 2 .*two is bad") as info:
        run_tasks(_fails, [{"x": k} for k in range(4)], workers=1, progress=False)
    assert info.value.index == 2
    with pytest.raises(InputError, match="refused 1"):  # manipcad errors pass unchanged
        run_tasks(_bad_input, [{"x": 1}], workers=1, progress=False)


@pytest.mark.slow
def test_ratio_sweep_serial_equals_two_workers(tmp_path):
    """The grid cells on a 2-worker LocalCluster give bit-identical results to the serial run,
    and a rerun from the cache computes nothing."""
    arm = manipcad.load_robot("cylindrical")
    grid = np.geomspace(5.0, 400.0, 40)
    serial = ratio_sweep(arm, FIG3, "turn", ratios=grid)
    dist = ratio_sweep(arm, FIG3, "turn", ratios=grid, workers=2, cache_dir=tmp_path)
    for name in ("rms_motor_torque", "peak_motor_torque", "peak_motor_speed", "peak_current",
                 "rms_current", "peak_voltage", "feasible"):
        np.testing.assert_array_equal(getattr(serial, name), getattr(dist, name), err_msg=name)
    for name in serial.margins:
        np.testing.assert_array_equal(serial.margins[name], dist.margins[name])
    assert serial.intervals == dist.intervals
    assert serial.best_ratio == dist.best_ratio
    assert serial.feasible.any() and not serial.feasible.all()  # the comparison has content
    files = sorted(tmp_path.rglob("*.pkl"))
    assert len(files) == grid.size
    cached = ratio_sweep(arm, FIG3, "turn", ratios=grid, workers=1, cache_dir=tmp_path)
    np.testing.assert_array_equal(cached.rms_motor_torque, serial.rms_motor_torque)
    assert sorted(tmp_path.rglob("*.pkl")) == files


def test_ratio_sweep_cache_serial_matches_plain(tmp_path):
    arm = manipcad.load_robot("cylindrical")
    grid = np.geomspace(5.0, 400.0, 12)
    plain = ratio_sweep(arm, FIG3, "turn", ratios=grid)
    cached = ratio_sweep(arm, FIG3, "turn", ratios=grid, cache_dir=tmp_path)
    np.testing.assert_array_equal(plain.peak_current, cached.peak_current)
    wider = ratio_sweep(arm, FIG3, "turn", ratios=np.concatenate([grid, [600.0, 800.0]]),
                        cache_dir=tmp_path)
    assert len(list(tmp_path.rglob("*.pkl"))) == grid.size + 2
    np.testing.assert_array_equal(wider.peak_current[:grid.size], plain.peak_current)


def test_scheduler_unreachable_is_an_input_error(monkeypatch):
    from manipcad.parallel import executor

    monkeypatch.setattr(executor, "CONNECT_TIMEOUT", 1.0)
    with pytest.raises((InputError, ManipcadError), match="cannot connect"):
        run_tasks(_square, [{"x": 1}], scheduler="tcp://127.0.0.1:9", progress=False)


def test_existing_cluster_by_address():
    """scheduler="tcp://HOST:PORT": the tasks run on a cluster started separately, with the
    same results as the serial run."""
    from distributed import LocalCluster

    tasks = [{"x": float(k)} for k in range(6)]
    serial = run_tasks(_square, tasks, common={"offset": 0.25}, workers=1, progress=False)
    with LocalCluster(n_workers=1, threads_per_worker=2, processes=False,
                      dashboard_address=None) as cluster:
        remote = run_tasks(_square, tasks, common={"offset": 0.25},
                           scheduler=cluster.scheduler_address, chunk=2, progress=False)
    assert list(remote) == list(serial) and remote.computed == 6


def test_pool_started_ahead_longest_first(dask_scheduler, monkeypatch, tmp_path):
    """A Pool (the client started in a background thread, a warm-up run on every worker)
    gives the serial results in task order, whatever order the costs hand the tasks out;
    so do tasks split into parts."""
    tasks = [{"base": 2, "exp": k} for k in range(8)]
    serial = run_tasks(pow, tasks, workers=1, progress=False)
    with Pool(scheduler=dask_scheduler, warm=abs) as pool:  # abs(): fails, ignored
        r = run_tasks(pow, tasks, pool=pool, cost=lambda t: -t["exp"], chunk=3,
                      progress=False)
        with pytest.raises(InputError, match="pool"):
            run_tasks(pow, tasks, pool=pool, workers=2, progress=False)
    assert list(r) == list(serial) == [2 ** k for k in range(8)]
    # a split task: its parts are the units of work (longest first), its result cached whole
    tasks = [{"x": k} for k in range(5)]
    want = [_cells(k, 0.5) for k in range(5)]
    cache = tmp_path / "split"
    with Pool(scheduler=dask_scheduler) as pool:
        r = run_tasks(_cells, tasks[:3], common={"offset": 0.5}, pool=pool, split=_split_cells(),
                      cost=lambda part: part["k"], cache_dir=cache, progress=False)
    assert list(r) == want[:3] and len(list(cache.rglob("*.pkl"))) == 3
    r = run_tasks(_cells, tasks, common={"offset": 0.5}, workers=1, split=_split_cells(),
                  cache_dir=cache, progress=False)
    assert list(r) == want and (r.computed, r.cached) == (2, 3)
    # the same keys as the whole function's: a cache written without the split serves it
    plain = run_tasks(_cells, tasks, common={"offset": 0.5}, workers=1, cache_dir=cache,
                      progress=False)
    assert list(plain) == want and plain.computed == 0
    with pytest.raises(InputError, match="split"):
        run_tasks(_cells, tasks, common={"offset": 0.5}, workers=1, split=_split_cells(),
                  chunk=2, progress=False)
    # tasks joined into guided batches (equal costs): a failure names its own task,
    # not the first of its batch; and a pool released early closes while the caller goes on
    from manipcad.parallel.executor import guided

    assert guided([[k] for k in range(30)], [1.0] * 30, 2)[0] == [0, 1, 2, 3, 4]
    with Pool(scheduler=dask_scheduler) as pool:
        with pytest.raises(TaskFailed, match=r"task 2 .*two is bad") as info:
            run_tasks(_fails, [{"x": k} for k in range(30)], pool=pool, cost=lambda t: 1.0,
                      progress=False)
        assert info.value.index == 2
        r = run_tasks(_square, [{"x": k} for k in range(30)], pool=pool, cost=lambda t: 1.0,
                      progress=False)
        client = pool.client()
        pool.release()
    assert list(r) == [k * k for k in range(30)] and client.status == "closed"
    from manipcad.parallel import executor

    monkeypatch.setattr(executor, "CONNECT_TIMEOUT", 0.5)
    with pytest.raises(InputError, match="cannot connect"), \
            Pool(scheduler="tcp://127.0.0.1:9") as p:
        p.client()


@pytest.mark.skipif(not hasattr(__import__("os"), "register_at_fork"), reason="no fork")
def test_forked_workers_inherit_frozen_objects():
    """The default LocalCluster forks its workers with the objects alive then frozen
    (gc.freeze: their collector leaves the inherited objects, and their pages, alone);
    this process unfreezes them once the workers have forked (when the Pool returns)."""
    import gc

    assert gc.get_freeze_count() == 0
    with Pool(workers=1) as pool:  # returns once the worker has forked, unfrozen here
        assert gc.get_freeze_count() == 0
        frozen = pool.client().run(gc.get_freeze_count)
        assert gc.get_freeze_count() == 0 and pool.ready()
    assert len(frozen) == 1 and min(frozen.values()) > 10000


def test_guided_batches():
    """Guided batches: consecutive units in their order, every unit once, each batch within
    1/(GUIDED·slots) of the work left unless a single unit, the last ones single units."""
    from manipcad.parallel.executor import GUIDED, guided

    rng = np.random.default_rng(5)
    for slots in (1, 2, 8):
        costs = sorted(rng.uniform(0.05, 3.0, 98), reverse=True)
        units = [[2 * k, 2 * k + 1] for k in range(98)]  # chunks of two tasks each
        batches = guided(units, costs, slots)
        assert [i for b in batches for i in b] == list(range(196))
        left, at = sum(costs), 0
        for b in batches:
            n = len(b) // 2
            c = sum(costs[at:at + n])
            assert n == 1 or c <= left / (GUIDED * slots) + 1e-12
            left, at = left - c, at + n
        assert len(batches[-1]) == 2 and len(batches) < 98
    assert guided([], [], 2) == []


def _threads_usable():
    from manipcad.dynamics import _inputs

    return _inputs._threads_usable[0]


@pytest.mark.skipif(not hasattr(__import__("os"), "register_at_fork"), reason="no fork here")
def test_forked_process_runs_batches_serially():
    """The default LocalCluster forks its workers (start_method); a forked process never
    enters numba's thread pool, which is not fork-safe (its threads stay in the parent)."""
    import multiprocessing

    from manipcad.parallel.executor import start_method

    assert start_method() in ("fork", "spawn")
    assert _threads_usable()
    with multiprocessing.get_context("fork").Pool(1) as p:
        assert p.apply(_threads_usable) is False


_LOCK_SCRIPT = """
import logging, os, sys, threading, time
from manipcad.parallel import run_tasks

def where(x):
    logging.getLogger("manipcad.test").warning("worker log line")
    return os.readlink("/proc/self/fd/2")

if __name__ == "__main__":
    # the root logger writes into a pipe a thread drains. At each fork the draining pauses
    # and a thread blocks inside a write to that handler's stream: the stream's buffer lock
    # is held at the fork (as when the cluster's event loop logs at that instant); after
    # the fork, in this process, the draining resumes and the write ends.
    r, w = os.pipe()
    handler = logging.StreamHandler(open(w, "w", buffering=1))
    root = logging.getLogger()
    root.addHandler(handler)
    root.setLevel(logging.INFO)
    drain = threading.Event()
    drain.set()

    def drainer():
        while True:
            drain.wait()
            os.read(r, 1 << 16)

    def hold():
        drain.clear()
        time.sleep(0.1)                     # the drainer is waiting
        threading.Thread(target=lambda: handler.stream.write("x" * (1 << 18)),
                         daemon=True).start()
        time.sleep(0.2)                     # the writer blocks, holding the lock

    threading.Thread(target=drainer, daemon=True).start()
    os.register_at_fork(before=hold, after_in_parent=drain.set)
    print(run_tasks(where, [{"x": 1}, {"x": 2}], workers=2, progress=False)[0], flush=True)
    os._exit(0)
"""


_PIPE_SCRIPT = """
import os, sys
from manipcad.parallel import run_tasks

def chatty(x):
    # a worker that logs more than a pipe's 64 KiB buffer, then says where its stderr goes
    os.write(2, b"worker log line\\n" * 20000)
    return os.readlink("/proc/self/fd/2")

if __name__ == "__main__":
    print(run_tasks(chatty, [{"x": 1}], workers=2, progress=False)[0])
"""


def _run_script(script, text: str, *, drain: bool, why: str) -> tuple[bytes, bytes]:
    """Run ``text`` as the file ``script`` in a session of its own, its stdout and stderr
    pipes drained while it runs (``drain``) or read only once it has ended; fail with
    ``why`` (the script and its workers killed) after 120 s, or on a non-zero exit."""
    import subprocess
    import sys

    script.write_text(text)
    proc = subprocess.Popen([sys.executable, str(script)], stdout=subprocess.PIPE,
                            stderr=subprocess.PIPE, start_new_session=True)
    try:
        if drain:
            out, err = proc.communicate(timeout=120)
        else:
            proc.wait(timeout=120)
            out, err = proc.communicate()
    except subprocess.TimeoutExpired:
        os.killpg(proc.pid, signal.SIGKILL)     # the script and its stuck workers
        proc.communicate()
        pytest.fail(why)
    assert proc.returncode == 0, err.decode()[-2000:]
    return out, err


def test_forked_workers_never_block_on_an_undrained_pipe(tmp_path):
    """A forked worker inherits the caller's stderr; when that is a pipe nobody reads until
    the caller ends (pytest-xdist's, ``subprocess.run(capture_output=True)``), a worker's
    log past the pipe buffer blocked it for good. The workers leave such pipes; a worker's
    stderr is /dev/null there and the sweep finishes."""
    # stdout is read only once the process ends: nothing drains its pipes before
    out, err = _run_script(tmp_path / "chatty.py", _PIPE_SCRIPT, drain=False,
                           why="the sweep blocked: a worker is stuck writing to the "
                               "inherited pipe")
    assert out.decode().strip().splitlines()[-1] == os.devnull
    assert b"worker log line" not in err


@pytest.mark.skipif(not hasattr(__import__("os"), "register_at_fork"), reason="no fork here")
def test_forked_workers_never_wait_on_a_lock_held_at_the_fork(tmp_path):
    """A thread of the caller blocked inside a logging handler's write holds that stream's
    buffer lock; a worker forked then inherited the lock held, and its first log line
    (Dask's "Start worker at") waited on it for ever: the cluster never started. The
    forked workers get new stream objects (a pipe's: /dev/null) and the sweep finishes."""
    out, _ = _run_script(tmp_path / "locked.py", _LOCK_SCRIPT, drain=True,
                         why="the cluster never started: a forked worker waits on a lock "
                             "held at the fork")
    assert out.decode().strip().splitlines()[-1] == os.devnull


def test_a_scheduler_is_probed_once_per_command(dask_scheduler, monkeypatch):
    """A command checks --scheduler before any work (check_workers), then its Pool checks
    the arguments and starts the client: the scheduler is asked once, not three times;
    one that has not answered is asked again (a refused port still fails each time)."""
    from manipcad.parallel import executor

    executor._ANSWERED.clear()
    calls = []
    connect = executor.socket.create_connection

    def counted(address, *args, **kwargs):
        calls.append(address)
        return connect(address, *args, **kwargs)

    monkeypatch.setattr(executor.socket, "create_connection", counted)
    check_workers(None, dask_scheduler)
    with Pool(scheduler=dask_scheduler) as pool:
        assert run_tasks(pow, [{"base": 3, "exp": 2}], pool=pool, progress=False) == [9]
    assert len(calls) == 1, calls
    for _ in range(2):
        with pytest.raises(InputError, match="refused"):
            check_workers(None, "tcp://127.0.0.1:9")
    assert len(calls) == 3, calls
