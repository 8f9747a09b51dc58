"""Resource budgets: estimate the steps and memory of a run before allocating, refuse with numbers.

A fixed-step run of ``t_end`` seconds at step ``dt`` takes ``K = t_end/dt``
steps; arrays proportional to K (the reference, the recorded samples) must fit
in memory. :func:`check_steps` computes K and the bytes such a run needs and
raises :class:`~manipcad.errors.InputError` naming the argument, with the
numbers, when they are not finite, not positive, or do not fit, instead of
letting numpy raise a MemoryError (or run for hours) later.

The memory budget is half of the memory the system reports as available
(``MemAvailable`` in /proc/meminfo; the physical memory elsewhere), or
:data:`MEMORY_BUDGET` bytes when that is set (tests, batch machines).
"""

from __future__ import annotations

import math
import os
import time

from manipcad.errors import InputError

#: fixed memory budget in bytes (None: half of the available memory, read per call or
#: reused briefly for a small run: :data:`REUSE_SECONDS`)
MEMORY_BUDGET: int | None = None
#: the most steps one run may take, whatever the memory (about an hour of work)
MAX_STEPS = 1_000_000_000


def available_memory() -> int:
    """Bytes of memory available to a new allocation (MemAvailable on Linux)."""
    try:
        with open("/proc/meminfo", encoding="ascii") as fh:
            for line in fh:
                if line.startswith("MemAvailable:"):
                    return int(line.split()[1]) * 1024
    except (OSError, ValueError, IndexError):
        pass
    try:
        return os.sysconf("SC_PHYS_PAGES") * os.sysconf("SC_PAGE_SIZE")
    except (ValueError, OSError, AttributeError):  # pragma: no cover - exotic systems
        return 8 * 2**30


def memory_budget() -> int:
    """The bytes a run may allocate: :data:`MEMORY_BUDGET`, or half the available memory."""
    return MEMORY_BUDGET if MEMORY_BUDGET is not None else available_memory() // 2


#: a reading of the available memory younger than this (s) serves a run that needs at
#: most :data:`REUSE_SHARE` of the budget it gave, without reading /proc/meminfo again
#: (0.01-0.09 ms a read: a tenth of a 1 s simulation's own Python work)
REUSE_SECONDS = 1.0
REUSE_SHARE = 1 / 16
_last_budget = [0, -math.inf]  # [bytes, time.monotonic() of the reading]


def _budget_for(need: float) -> int:
    """:func:`memory_budget` for a run that needs ``need`` bytes: a recent reading when the
    need is a small share of it (the check cannot fail unless the memory available fell
    sixteen-fold within the second), else a new one."""
    if MEMORY_BUDGET is not None:
        return MEMORY_BUDGET
    budget, when = _last_budget
    now = time.monotonic()
    if need <= REUSE_SHARE * budget and now - when < REUSE_SECONDS:
        return budget
    budget = memory_budget()
    _last_budget[:] = [budget, now]
    return budget


def human_bytes(b: float) -> str:
    """A byte count in words: ``human_bytes(3.2e9) == '3.2 GB'`` (decimal units)."""
    for unit in ("B", "kB", "MB", "GB", "TB", "PB"):
        if abs(b) < 1000 or unit == "PB":
            return f"{b:.3g} {unit}"
        b /= 1000
    return f"{b:.3g} PB"  # pragma: no cover


def check_steps(t_end: float, dt: float, *, floats_per_step: float,
                floats_per_kept: float = 0.0, every: int = 1, runs: int = 1,
                t_end_name: str = "t_end", dt_name: str = "dt") -> int:
    """Steps of a fixed-step run, checked against :data:`MAX_STEPS` and the memory budget.

    Args:
        t_end: duration, s (finite, > 0).
        dt: step, s (finite, > 0, <= t_end).
        floats_per_step: float64 values held per step whatever is kept (time
            grid, reference, disturbance: e.g. ``1 + 8·n``).
        floats_per_kept: float64 values per kept (recorded) sample.
        every: one sample kept every ``every`` steps (>= 1).
        runs: how many such runs are held in memory at once.
        t_end_name, dt_name: how errors name the two arguments (``--t-end``).

    Returns:
        K = round(t_end/dt), the number of steps.

    Raises:
        InputError: naming the argument, with the numbers: not finite or not
            positive, dt > t_end, more than MAX_STEPS steps, or more memory than
            the budget ("t_end/dt = 1e+16 steps need about 2.5 EB ... available").

    Example:
        >>> check_steps(1.6, 1e-4, floats_per_step=25)
        16000
        >>> check_steps(1e12, 1e-4, floats_per_step=25)  # doctest: +ELLIPSIS
        Traceback (most recent call last):
        ...
        manipcad.errors.InputError: t_end: t_end/dt = 1e+16 steps, more than the limit ...
    """
    for name, v in ((t_end_name, t_end), (dt_name, dt)):
        if not (isinstance(v, int | float) and math.isfinite(v) and v > 0):
            raise InputError(name, "", f"must be a finite number of seconds > 0, got {v!r}")
    if dt > t_end:
        raise InputError(dt_name, "", f"must be <= {t_end_name} = {t_end:g} s, got {dt:g}")
    ratio = t_end / dt
    hint = f"use a larger {dt_name} or a shorter {t_end_name}"
    if not math.isfinite(ratio) or ratio > MAX_STEPS:
        raise InputError(t_end_name, "", f"{t_end_name}/{dt_name} = {ratio:.3g} steps, more "
                         f"than the limit of {MAX_STEPS:.0e}; {hint}")
    K = int(round(ratio))
    need = 8.0 * runs * (floats_per_step * (K + 1) + floats_per_kept * (K // max(every, 1) + 1))
    budget = _budget_for(need)
    if need > budget:
        raise InputError(t_end_name, "", f"{t_end_name}/{dt_name} = {K:.3g} steps need about "
                         f"{human_bytes(need)} of memory, more than the "
                         f"{human_bytes(budget)} available to this run; {hint}")
    return K


__all__ = ["check_steps", "available_memory", "memory_budget", "human_bytes", "MAX_STEPS",
           "MEMORY_BUDGET"]
