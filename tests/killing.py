"""Waiting for a process the tests have just sent a signal to.

A process inside an uninterruptible kernel wait (``State: D``, most often an
``fsync`` on a busy disk) takes no signal, not even SIGKILL, until the wait ends;
on a shared CI disk such a wait was seen to last 20 s. So the time a killed
writer is allowed counts only the moments it could have acted on the signal
(any state but D); a writer that stays runnable or sleeping interruptibly past
``timeout`` still fails the test, with its signal masks, so the check can say
"fail" for the case it exists for: a writer that ignores or outlives its signal.
"""

from __future__ import annotations

import time
from collections.abc import Callable

#: the longest wall time spent waiting in all, disk waits included (s)
HARD_LIMIT = 300.0


def signal_state(pid: int) -> str:
    """The process's state and signal masks from /proc (hexadecimal; bit k-1 is
    signal k; SigPnd is the thread's pending set, ShdPnd the whole process's)."""
    try:
        with open(f"/proc/{pid}/status") as f:
            return ", ".join(line.strip() for line in f
                             if line.startswith(("State", "Sig", "ShdPnd")))
    except OSError:
        return "no /proc status"


def in_disk_wait(pid: int) -> bool:
    """True while ``pid`` is in an uninterruptible wait (State D)."""
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] == "D"
    except (OSError, IndexError):
        return False


def wait_dead(pid: int, exited: Callable[[], bool], timeout: float) -> str | None:
    """Poll ``exited()`` until it is true. Returns None once the process is gone, or
    the reason it is not: it spent ``timeout`` s outside disk waits (or
    :data:`HARD_LIMIT` s in all) still alive."""
    start = last = time.monotonic()
    awake = 0.0
    while not exited():
        now = time.monotonic()
        if not in_disk_wait(pid):
            awake += now - last
        last = now
        if awake > timeout or now - start > HARD_LIMIT:
            return (f"survived its signal for {now - start:.1f} s, {awake:.1f} s of it "
                    f"outside disk waits ({signal_state(pid)})")
        time.sleep(0.01)
    return None
