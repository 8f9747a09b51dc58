"""The PUMA PD job on the fixed-step RK4 path, with and without dry friction, for a before/after.

The closed loop of benchmarks/bench_simulator.py (PUMA 560 of the catalog with its six
DC drives, PD + back-EMF feed-forward on every joint sampled every step, a 1 s quintic
move, RK4 at dt 1e-4 s), in four cases: the catalog's drives (dry friction: the hybrid
plant, :mod:`manipcad.sim.events`) and the same drives with M_f = 0 (no events), each
with the robot's generated kernels and with the general ones.

Runs whatever manipcad is first on PYTHONPATH, so two versions can be alternated in
separate processes::

    git worktree add --detach /tmp/before <commit>
    for i in 1 2 3; do
        PYTHONPATH=/tmp/before/src python benchmarks/rk4_job.py before
        PYTHONPATH=src python benchmarks/rk4_job.py after
    done

Prints per case the process's CPU time per simulated second (the least of ``--rounds``
runs after a warm-up; what a core of its own gives, steadier than the wall time on a
shared machine), the wall time of that run, and a digest of every result array (q, q̇,
U, currents, torques): the same digest before and after is the same run bit for bit.
Then the load average.
"""

from __future__ import annotations

import argparse
import hashlib
import os
import time
import warnings

import numpy as np
from _puma_job import DT, Q_END, Q_START, pd_regulators

import manipcad
from manipcad.codegen import generate
from manipcad.sim import simulate
from manipcad.trajectories import quintic

T_END = 1.0


def digest(res) -> str:
    """The first 12 hex digits of the SHA-1 of every result array's bytes."""
    h = hashlib.sha1()
    for a in (res.q, res.qd, res.u, res.current, res.tau):
        h.update(np.ascontiguousarray(a).tobytes())
    return h.hexdigest()[:12]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("label", nargs="?", default="")
    ap.add_argument("--rounds", type=int, default=5)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    robot = manipcad.load_robot("puma560")
    smooth = robot.replace(drives=tuple(d.replace(M_f=0.0) for d in robot.drives))
    for arm in (robot, smooth):
        generate(arm)
    traj = quintic(Q_START, Q_END, 1.0)

    def regs():
        return pd_regulators()

    cases = {"dry friction, generated": (robot, True),
             "dry friction, general": (robot, False),
             "no friction, generated": (smooth, True),
             "no friction, general": (smooth, False)}
    for name, (arm, use) in cases.items():
        simulate(arm, t_end=0.01, dt=DT, trajectory=traj, regulators=regs(),
                 use_generated=use)  # warm-up (compiles on an empty cache)
        best = (np.inf, np.inf)
        for _ in range(args.rounds):
            c, t = time.process_time(), time.perf_counter()
            res = simulate(arm, t_end=T_END, dt=DT, trajectory=traj, regulators=regs(),
                           use_generated=use)
            best = min(best, (time.process_time() - c, time.perf_counter() - t))
        print(f"{args.label} {name:24s} CPU {best[0] / T_END:.4f} s per simulated s "
              f"(wall {best[1] / T_END:.4f})  digest {digest(res)}", flush=True)
    print(f"load average {os.getloadavg()[0]:.1f}")


if __name__ == "__main__":
    main()
