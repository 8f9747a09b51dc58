"""ChildCall: one call in a forked child process, its value or its error brought back."""

from __future__ import annotations

import os
import pickle
import time

import pytest

from manipcad.errors import InputError, ManipcadError, ModelError
from manipcad.parallel import child, executor
from manipcad.parallel.child import ChildCall
from manipcad.parallel.executor import TaskFailed

FORK = executor.start_method() == "fork"


def _pid_and(x):
    return os.getpid(), x * 2


def _refuse(source):
    raise InputError(source, "joints[1].drive.R", "must be > 0 Ω")


def _die(code):
    os._exit(code)


def _sleep(s):
    time.sleep(s)
    return s


def _unpicklable():
    return lambda: None


@pytest.mark.skipif(not FORK, reason="the forked path exists where fork does (Linux)")
def test_value_computed_in_another_process():
    with ChildCall(_pid_and, 21) as call:
        pid, value = call.result()
        assert call.result() == (pid, value)  # asked again: the same value, no new child
    assert value == 42
    assert pid != os.getpid()


@pytest.mark.skipif(not FORK, reason="the forked path exists where fork does (Linux)")
def test_error_raised_here_with_its_fields():
    with ChildCall(_refuse, "arm.yaml") as call:
        with pytest.raises(InputError) as err:
            call.result()
    assert err.value.source == "arm.yaml"
    assert err.value.field == "joints[1].drive.R"
    assert str(err.value) == "arm.yaml: joints[1].drive.R: must be > 0 Ω"
    cause = err.value.__cause__  # the child's traceback, naming where it was raised
    assert isinstance(cause, child.ChildTraceback)
    assert "in _refuse" in str(cause) and "InputError: arm.yaml" in str(cause)


@pytest.mark.skipif(not FORK, reason="the forked path exists where fork does (Linux)")
def test_child_without_result_is_named():
    with ChildCall(_die, 3) as call:
        with pytest.raises(ManipcadError, match=r"_die in a child process: it ended "
                           r"without a result \(exit code 3\)"):
            call.result()


@pytest.mark.skipif(not FORK, reason="the forked path exists where fork does (Linux)")
def test_unpicklable_result_is_named():
    with ChildCall(_unpicklable) as call:
        with pytest.raises(ManipcadError, match="could not be sent back"):
            call.result()


@pytest.mark.skipif(not FORK, reason="the forked path exists where fork does (Linux)")
def test_close_stops_a_running_child():
    call = ChildCall(_sleep, 60.0)
    proc = call._proc
    t0 = time.perf_counter()
    call.close()
    assert time.perf_counter() - t0 < child.CLOSE_TIMEOUT
    assert proc.exitcode is not None and proc.exitcode != 0  # terminated, not finished
    with pytest.raises(ManipcadError, match="ended without a result"):
        call.result()


def test_without_fork_runs_here_when_asked(monkeypatch):
    monkeypatch.setattr(child, "start_method", lambda: "spawn")
    calls = []

    def fn(x):
        calls.append(x)
        return os.getpid(), x

    call = ChildCall(fn, 5)
    assert calls == []  # nothing yet
    assert call.result() == (os.getpid(), 5)
    assert call.result() == (os.getpid(), 5) and calls == [5]  # computed once
    with pytest.raises(InputError):
        ChildCall(_refuse, "x.yaml").result()


@pytest.mark.parametrize("exc", [
    InputError("arm.yaml", "joints[0]", "no drive"), ModelError("not physical", "R"),
    TaskFailed("task 3 failed", 3, {"x": 1}), ManipcadError("plain")])
def test_manipcad_errors_pickle_whole(exc):
    back = pickle.loads(pickle.dumps(exc))
    assert type(back) is type(exc)
    assert str(back) == str(exc) and back.args == exc.args
    assert vars(back) == vars(exc)
