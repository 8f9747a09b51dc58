"""Benchmark: drive selection for a 7-joint arm against the whole catalogue.

Usage::

    python benchmarks/bench_select.py [--rounds R] [--dt S] [--margin M]

The Panda of examples/panda (URDF + 0.5 kg payload, no drives) against every
compatible (motor, gear) pair and direct drive of the parts library, on two
trajectories (examples/panda/pick.yaml and a faster cycle through other poses,
quintic moves of 1.0 s), at both ends of the payload range 0..1 kg, the fixed
point of the drive masses and the verification by ``size``'s checks
included: :func:`manipcad.sizing.select.select_drives` as ``manipcad select``
runs it. Wall clock per round (the catalogue's tables and the kernels are
loaded and compiled by a first, untimed round), minimum and median over the
rounds, and the CPU time of the process (all its threads: on a busy machine
the wall clock measures the other jobs too), with the candidates considered
and the sweeps.
"""

from __future__ import annotations

import argparse
import os
import platform
import statistics
import time
from pathlib import Path

import numpy as np

import manipcad
from manipcad.sizing.select import select_drives
from manipcad.trajectories.io import trajectory_from_dict

ROOT = Path(__file__).resolve().parent.parent
PANDA = ROOT / "examples" / "panda"


def trajectories(arm):
    """The example's pick cycle and a faster cycle through other poses (rad, s)."""
    pick = manipcad.load_trajectory(PANDA / "pick.yaml", robot=arm)
    fast = trajectory_from_dict({
        "type": "waypoints", "profile": "quintic", "move_time": 1.0, "dwell": 0.3,
        "points": [[0.3, -0.6, 0.2, -2.0, 0.3, 1.9, 0.4],
                   [-0.4, 0.2, -0.3, -1.6, -0.5, 2.3, 1.4],
                   [0.5, -0.2, 0.4, -2.4, 0.2, 1.7, -0.2]]}, "fast cycle", robot=arm)
    return [pick, fast]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--dt", type=float, default=1e-3, help="sampling step, s")
    ap.add_argument("--margin", type=float, default=1.1)
    args = ap.parse_args()
    arm = manipcad.load_robot(PANDA / "panda_bare.yaml")
    trajs = trajectories(arm)
    print(f"python {platform.python_version()}, numpy {np.__version__}, "
          f"{os.cpu_count()} cores; Panda (7 joints), 2 trajectories "
          f"({', '.join(f'{t.duration:g} s' for t in trajs)}), payloads 0 and 1 kg, "
          f"dt = {args.dt:g} s, margin {args.margin:g}")
    t0 = time.perf_counter()
    sel = select_drives(arm, trajs, payload_range=(0.0, 1.0), margin=args.margin, dt=args.dt)
    print(f"first round (tables loaded, kernels compiled): {time.perf_counter() - t0:.2f} s")
    times, cpu = [], []
    for _ in range(args.rounds):
        t0, c0 = time.perf_counter(), time.process_time()
        sel = select_drives(arm, trajs, payload_range=(0.0, 1.0), margin=args.margin,
                            dt=args.dt)
        times.append(time.perf_counter() - t0)
        cpu.append(time.process_time() - c0)
    considered = sum(c.considered for c in sel.joints)
    feasible = sum(c.feasible for c in sel.joints)
    print(f"candidates: {considered} over the 7 joints ({considered // 7} per joint on "
          f"average), {feasible} feasible; {sel.iterations} sweeps; verified {sel.verified}")
    for c in sel.joints:
        print(f"  {c.joint}: {c.chosen.label}, {c.chosen.part.mass:.3g} kg, binding "
              f"{c.chosen.binding} {c.chosen.binding_margin:+.0%}")
    print(f"select_drives: wall min {min(times):.2f} s, median {statistics.median(times):.2f} s; "
          f"CPU (all threads) min {min(cpu):.2f} s, over {len(times)} rounds; load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
