"""Benchmark: convergence and speed of the simulator with stick-slip dry friction.

Usage::

    python benchmarks/bench_friction.py [--rounds R] [--ref-dt 5e-6]

The job: the catalog PUMA 560 with its six DC drives (armature inductance, dry
friction |i_r|·M_f of 25, 14 and 7 N·m on the first three joints), the PID of
``examples/pid_puma.yaml`` (1 kHz, integral action), a quintic move from
``Q_START`` to ``Q_END`` in 1.5 s, then the hold to t = 2 s. The joints stop, stick
and creep under the integral in stick-slip steps (:mod:`manipcad.sim.events`).

Printed:

* fixed-step RK4 at dt = 1e-4, 5e-5, 2.5e-5 s against RK4 at ``--ref-dt`` (the
  reference): max |Δq| over the kept samples (every 1 ms, every joint), the ratio of
  successive errors (4th order: 16), the stick-slip switches located;
* the error-controlled integrator ``adaptive-exact`` (Dormand–Prince 5(4), exact
  armature currents, rtol 1e-6, atol 1e-8, grid dt 1e-4) with the robot's generated
  kernels (:func:`manipcad.codegen.generate`) and with the general ones: max |Δq|
  against the reference and the real-time factor (simulated s per wall s, minimum
  wall time over ``--rounds`` after a warm-up run), and the same from the process's
  CPU time (``RTF cpu``: what an idle core gives; on a loaded machine the wall time
  also counts the time the process waits for a core), and the load average.

Targets: RK4 at 1e-4 within 1e-7 rad of the reference and halving dt cutting the
error at least 4×; the adaptive integrator within 1e-6 rad at RTF >= 100 (generated
kernels).
"""

from __future__ import annotations

import argparse
import os
import time
import warnings
from pathlib import Path

import numpy as np
from _puma_job import Q_END, Q_START

import manipcad
from manipcad.codegen import generate
from manipcad.control.files import load_regulators
from manipcad.sim import simulate
from manipcad.trajectories import quintic

ROOT = Path(__file__).resolve().parents[1]
T_MOVE, T_END, KEEP = 1.5, 2.0, 1e-3


def job(robot, dt: float, integrator: str = "rk4", use_generated: bool = False):
    """The run, its wall time and its process CPU time, s."""
    regs = load_regulators(ROOT / "examples" / "pid_puma.yaml", robot, dt=dt)
    c0, t0 = time.process_time(), time.perf_counter()
    res = simulate(robot, t_end=T_END, dt=dt, trajectory=quintic(Q_START, Q_END, T_MOVE),
                   regulators=regs, integrator=integrator, use_generated=use_generated,
                   every=int(round(KEEP / dt)))
    return res, time.perf_counter() - t0, time.process_time() - c0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--ref-dt", type=float, default=5e-6)
    args = ap.parse_args()
    warnings.simplefilter("ignore")
    robot = manipcad.load_robot("puma560")
    ref, wall, _ = job(robot, args.ref_dt)
    print(f"reference: RK4 dt {args.ref_dt:g} s, {wall:.1f} s wall, "
          f"{len(ref.events)} stick-slip switches")

    def err(res) -> float:
        return float(np.abs(res.q - ref.q).max())

    print("\nfixed-step RK4 against the reference")
    print(f"{'dt s':>9} {'max |dq| rad':>13} {'ratio':>7} {'switches':>9}")
    last = None
    for dt in (1e-4, 5e-5, 2.5e-5):
        res, _, _ = job(robot, dt)
        e = err(res)
        ratio = "" if last is None else f"{last / e:7.1f}"
        print(f"{dt:9.2g} {e:13.3g} {ratio:>7} {len(res.events):9d}")
        last = e

    generate(robot)
    print("\nadaptive-exact (rtol 1e-6, atol 1e-8, grid dt 1e-4)")
    print(f"{'kernels':>10} {'max |dq| rad':>13} {'RTF':>7} {'RTF cpu':>8} {'steps':>7} "
          f"{'at dt':>6}")
    for gen in (True, False):
        job(robot, 1e-4, "adaptive-exact", gen)      # warm-up (compile)
        walls, cpus = [], []
        for _ in range(args.rounds):
            res, w, c = job(robot, 1e-4, "adaptive-exact", gen)
            walls.append(w)
            cpus.append(c)
        s = res.settings
        print(f"{'generated' if gen else 'general':>10} {err(res):13.3g} "
              f"{T_END / min(walls):7.1f} {T_END / min(cpus):8.1f} {s['steps']:7d} "
              f"{s['steps_at_dt_above_tolerance']:6d}")
    print(f"load average (1, 5, 15 min): {', '.join(f'{x:.1f}' for x in os.getloadavg())} "
          f"on {os.cpu_count()} cores")


if __name__ == "__main__":
    main()
