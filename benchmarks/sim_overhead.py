"""The Python side of one :func:`manipcad.simulate` call: argument checks, packing the
plant and the control, the result's assembly and the limit checks, around the compiled
core.

Usage::

    python benchmarks/sim_overhead.py [--runs 40]

Jobs (after warm-up runs that load the compiled kernels): the catalog PUMA 560 with its
drives and the PID of ``examples/pid_puma.yaml`` (1 kHz) along a quintic move of all six
joints, RK4 at dt = 1e-4 s, for 0.2 s and 1 s; the catalog cylindrical arm with its PID
(``examples/pid_cylindrical.yaml``) along ``examples/fig3_laws.yaml`` for 10 steps, where
nearly all is the Python side.

Printed per job: the smallest whole-call wall time over ``--runs`` runs and the smallest
time outside the compiled core (the whole call less the calls of
``manipcad.sim.integrate.run``, timed inside the same call), in ms, and the load
average. On a loaded machine run two versions side by side (same load) and compare the
minima.
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

import numpy as np
from _core_calls import core_calls

import manipcad
from manipcad.control.files import load_regulators
from manipcad.errors import ManipcadWarning
from manipcad.sim import simulate
from manipcad.trajectories import load_trajectory, quintic

ROOT = Path(__file__).resolve().parents[1]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--runs", type=int, default=40)
    args = ap.parse_args()
    warnings.simplefilter("ignore", ManipcadWarning)
    puma = manipcad.load_robot("puma560")
    puma_regs = load_regulators(ROOT / "examples" / "pid_puma.yaml", puma)
    move = quintic(np.zeros(6), np.full(6, 0.3), 1.0)
    arm = manipcad.load_robot("cylindrical")
    laws = load_trajectory(ROOT / "examples" / "fig3_laws.yaml", robot=arm)
    arm_regs = load_regulators(ROOT / "examples" / "pid_cylindrical.yaml", arm)
    jobs = {"PUMA PID 0.2 s": (puma, move, puma_regs, 0.2),
            "PUMA PID 1 s": (puma, move, puma_regs, 1.0),
            "cylindrical PID 10 steps": (arm, laws, arm_regs, 1e-3)}
    with core_calls() as spent:
        for name, (robot, traj, regs, t_end) in jobs.items():
            best_total = best_outside = np.inf
            for i in range(args.runs + 3):
                spent.clear()
                t0 = time.perf_counter()
                simulate(robot, t_end=t_end, dt=1e-4, trajectory=traj, regulators=regs)
                total = time.perf_counter() - t0
                if i >= 3:                   # the first runs load the kernels
                    best_total = min(best_total, total)
                    best_outside = min(best_outside, total - sum(spent))
            print(f"{name:25s} whole call min {best_total * 1e3:8.3f} ms, outside the core "
                  f"min {best_outside * 1e3:6.3f} ms ({args.runs} runs); load "
                  f"{os.getloadavg()[0]:.2f}")


if __name__ == "__main__":
    main()
