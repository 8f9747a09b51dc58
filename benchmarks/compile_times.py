"""Measurement: numba compile time of the simulator's variants on a cold kernel cache.

Usage::

    python benchmarks/compile_times.py [--json out.json]

Runs each step of ``manipcad warmup`` (:data:`manipcad.sim.warm.STEPS`: the functions
the simulator's cores call — the stick-slip events' steps, the regulators and the payload
estimator, the plant's side —, the batched inverse dynamics, the RK4 loop and the
error-controlled loop themselves — each one specialization, with or without the online
payload estimator —, the batched forward dynamics) one after another in this process,
with the kernel cache pointed at a new empty folder (``XDG_CACHE_HOME``), and prints
each step's CPU time (``time.process_time``, less sensitive to other load than the wall
time, also printed).
A step reuses what earlier steps compiled (callees with the same signature), so the
figures depend on the order, which is :data:`~manipcad.sim.warm.STEPS`'.

This is the compile a user's first simulation needs on a fresh install where the shipped
kernels do not fit (``MANIPCAD_SHIPPED_KERNELS=0`` here), on one core
(docs/performance.md, "Compile and first run").
It measures, it does not compare: there is no peer for numba's compile of our code.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import tempfile
import time
from pathlib import Path


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--json", type=Path, help="write the figures here")
    args = ap.parse_args()
    if "manipcad" in sys.modules:
        sys.exit("run this as a script: the kernel cache must be set before manipcad loads")
    os.environ.pop("NUMBA_CACHE_DIR", None)
    os.environ["XDG_CACHE_HOME"] = tempfile.mkdtemp(prefix="manipcad-compile-")
    os.environ["MANIPCAD_SHIPPED_KERNELS"] = "0"  # compile, not unpack the shipped kernels
    from manipcad.sim.warm import STEPS  # after the cache is set: manipcad configures it

    out = {}
    for name, (_, step) in STEPS.items():
        c0, w0 = time.process_time(), time.perf_counter()
        step()
        out[name] = {"cpu_s": time.process_time() - c0, "wall_s": time.perf_counter() - w0}
        print(f"{name:20s} CPU {out[name]['cpu_s']:6.1f} s   wall {out[name]['wall_s']:6.1f} s",
              flush=True)
    total = sum(v["cpu_s"] for v in out.values())
    print(f"{'total':20s} CPU {total:6.1f} s   (load average at the end: "
          f"{os.getloadavg()[0]:.2f})")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2) + "\n")


if __name__ == "__main__":
    main()
