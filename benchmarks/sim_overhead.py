"""The Python side of one :func:`manipcad.simulate` call: argument checks, packing the
plant and the control, the result's assembly and the limit checks, around a compiled core
that has almost nothing to do.

Usage::

    python benchmarks/sim_overhead.py [--calls 2000] [--rounds 5]

Runs whatever manipcad is first on PYTHONPATH, so two versions can be alternated in
separate processes at the same load. The jobs (after a warm-up that loads the compiled
kernels):

* ``tiny``: the catalog cylindrical arm, its PID (``examples/pid_cylindrical.yaml``,
  1 kHz) along ``examples/fig3_laws.yaml`` for 10 RK4 steps of 1e-4 s: nearly all of it
  is the Python side;
* ``job``: the same for 0.1 s (1,000 steps), a short job of a sweep.

Printed per job: the minimum and the median wall time per call over ``--rounds`` rounds
of ``--calls`` calls (``job``: a tenth of them), the minimum CPU time per call (what an
idle core gives; on a loaded machine the wall time also counts the waits for a core), in
µs, and the load average.
"""

from __future__ import annotations

import argparse
import os
import statistics
import time
import warnings
from pathlib import Path

import manipcad
from manipcad.control.files import load_regulators
from manipcad.errors import ManipcadWarning
from manipcad.sim import simulate
from manipcad.trajectories import load_trajectory

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--calls", type=int, default=2000)
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    warnings.simplefilter("ignore", ManipcadWarning)
    arm = manipcad.load_robot("cylindrical")
    laws = load_trajectory(ROOT / "examples" / "fig3_laws.yaml", robot=arm)
    regs = load_regulators(ROOT / "examples" / "pid_cylindrical.yaml", arm)
    jobs = {"tiny": (1e-3, args.calls), "job": (0.1, max(1, args.calls // 10))}
    for name, (t_end, calls) in jobs.items():
        def once(t_end=t_end):
            return simulate(arm, t_end=t_end, dt=1e-4, trajectory=laws, regulators=regs)
        for _ in range(20):
            once()
        per, cpu = [], []
        for _ in range(args.rounds):
            t0, c0 = time.perf_counter(), time.process_time()
            for _ in range(calls):
                once()
            per.append((time.perf_counter() - t0) / calls * 1e6)
            cpu.append((time.process_time() - c0) / calls * 1e6)
        print(f"{name:5s} ({int(round(t_end / 1e-4))} steps): wall min {min(per):8.1f} us, "
              f"median {statistics.median(per):8.1f} us; CPU min {min(cpu):8.1f} us per call "
              f"({args.rounds} rounds of {calls}); load {os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
