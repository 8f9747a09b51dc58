"""Measurement: ``manipcad warmup``'s steps on 2 workers, on an empty kernel cache, as timed.

Usage::

    python benchmarks/prewarm_wall.py [--workers 2]

Starts ``--workers`` processes that run :func:`manipcad.sim.warm.share` ``(w, W)`` at
once, as ``manipcad warmup`` and the pytest-xdist workers of the README's test command
do (each
takes the steps of each phase of ``PHASES`` from its own starting point, a file lock
per step in the kernel cache folder, then waits for the others' steps of that phase),
all on one new empty cache (``XDG_CACHE_HOME``). Prints when each worker starts and ends
each step (s after the start, wall) with the step's CPU time and the functions numba
compiled (not loaded from the cache) in it: those called from Python and, in brackets,
their direct callees (a core step that names a callee compiled it again: phase 1 should
have cached it), and the whole prewarm's wall time.
``benchmarks/compile_times.py`` gives each step's compile CPU one after another; this
gives what the workers' sharing makes of them (a step compiles the callees it shares
with another again unless that one has cached them by then).
"""

from __future__ import annotations

import argparse
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]

WORKER = r'''
import sys, time
t0, w, W = float(sys.argv[1]), int(sys.argv[2]), int(sys.argv[3])
from manipcad.sim import warm
from numba.core import event

compiled = []  # the functions numba compiles (not loads) in a step: called from Python,
# and (in brackets) their direct callees


class Compiles(event.Listener):
    depth = 0

    def on_start(self, ev):
        name = ev.data["dispatcher"].py_func.__qualname__
        if self.depth <= 1:
            compiled.append(name if self.depth == 0 else f"({name})")
        self.depth += 1

    def on_end(self, ev):
        self.depth -= 1


event.register("numba:compile", Compiles())


def timed(name, step):
    def run():
        c = time.process_time()
        del compiled[:]
        print(f"  worker {w} {name:16s} start {time.perf_counter() - t0:6.1f} s", flush=True)
        step()
        print(f"  worker {w} {name:16s} end   {time.perf_counter() - t0:6.1f} s   "
              f"CPU {time.process_time() - c:5.1f} s   compiled: "
              f"{', '.join(dict.fromkeys(compiled)) or '-'}", flush=True)
    return run

for name, (what, step) in list(warm.STEPS.items()):
    warm.STEPS[name] = (what, timed(name, step))
for line in warm.share(w, W):
    print(f"  worker {w} FAILED {line}", flush=True)
print(f"  worker {w} done       {time.perf_counter() - t0:6.1f} s   "
      f"CPU {time.process_time():5.1f} s (with the imports)", flush=True)
'''


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--workers", type=int, default=2)
    args = ap.parse_args()
    env = dict(os.environ, XDG_CACHE_HOME=tempfile.mkdtemp(prefix="manipcad-prewarm-"),
               MANIPCAD_SHIPPED_KERNELS="0")  # compile, not unpack the shipped kernels
    env.pop("NUMBA_CACHE_DIR", None)
    load = os.getloadavg()[0]
    t0 = time.perf_counter()
    procs = [subprocess.Popen([sys.executable, "-c", WORKER, str(t0), str(w),
                               str(args.workers)], cwd=ROOT, env=env)
             for w in range(args.workers)]
    for p in procs:
        p.wait()
    print(f"prewarm on {args.workers} workers: {time.perf_counter() - t0:.1f} s wall "
          f"(load average {load:.2f} at the start, {os.getloadavg()[0]:.2f} at the end)")
    if any(p.returncode for p in procs):
        sys.exit("a worker failed")


if __name__ == "__main__":
    main()
