"""Time the simulator's compiled core inside whole :func:`manipcad.simulate` calls.

Example (from a script in benchmarks/)::

    from _core_calls import core_calls
    with core_calls() as spent:
        manipcad.simulate(...)
    outside = whole_call - sum(spent)
"""

from __future__ import annotations

import contextlib
import importlib
import time
from collections.abc import Iterator


@contextlib.contextmanager
def core_calls() -> Iterator[list[float]]:
    """While inside, each call of the compiled core (``run`` of
    :mod:`manipcad.sim.integrate`, the module that calls it) appends its wall time, s,
    to the list yielded; the core is put back on leaving."""
    integrate = importlib.import_module("manipcad.sim.integrate")
    core = integrate.run
    spent: list[float] = []

    def timed(*args):
        t0 = time.perf_counter()
        out = core(*args)
        spent.append(time.perf_counter() - t0)
        return out

    integrate.run = timed
    try:
        yield spent
    finally:
        integrate.run = core
