"""The PUMA PD job on the fixed-step RK4 path (dt 1e-4, PD every step), for a before/after.

Runs whatever manipcad is first on PYTHONPATH, so two versions can be alternated in
separate processes (docs/performance.md, "Closed-loop simulator")::

    git worktree add /tmp/before d1c455b        # the commit before the regulator registry
    for i in 1 2 3; do
        PYTHONPATH=/tmp/before/src python benchmarks/rk4_job.py before
        PYTHONPATH=src python benchmarks/rk4_job.py after
    done

Prints the median and best real-time factor (simulated s per wall s) of 5 runs of 1 s
after a warm-up, and the first two joints' final position (the same closed loop).
"""

from __future__ import annotations

import statistics
import sys
import time
import warnings

import numpy as np

import manipcad
from manipcad.sim import simulate
from manipcad.trajectories import quintic

try:
    from manipcad.control import pid
except ImportError:  # before the regulator registry
    from manipcad.sim.regulators import pid

KP = np.array([-930.0, 950.0, -580.0, 320.0, 340.0, 320.0])
KD = np.array([-27.0, 9.0, -4.5, 8.3, 9.5, 8.3])
KFF = np.array([-14.28, 24.58, -12.25, 5.70, 5.39, 5.75])
Q_START = np.array([0.0, 0.5, -0.5, 0.0, 0.3, 0.0])
Q_END = np.array([0.8, 0.2, -0.1, 0.5, -0.3, 1.0])


def main() -> None:
    warnings.simplefilter("ignore")
    robot = manipcad.load_robot("puma560")
    traj = quintic(Q_START, Q_END, 1.0)

    def regs():
        return [pid(j, kp=KP[j], kd=KD[j], kff=KFF[j], u_limit=40.0, period=1e-4)
                for j in range(6)]

    simulate(robot, t_end=0.01, dt=1e-4, trajectory=traj, regulators=regs())  # warm-up
    walls = []
    for _ in range(5):
        t0 = time.perf_counter()
        res = simulate(robot, t_end=1.0, dt=1e-4, trajectory=traj, regulators=regs())
        walls.append(time.perf_counter() - t0)
    label = sys.argv[1] if len(sys.argv) > 1 else ""
    print(f"{label} RTF median {1 / statistics.median(walls):.1f} best {1 / min(walls):.1f} "
          f"q_end {res.q[-1][:2]}")


if __name__ == "__main__":
    main()
