"""Benchmark: the real-time moment components H_ii, h_i, Q_i against a 1 ms control period.

Usage::

    python benchmarks/bench_components.py [--quick] [--json out.json] [--rounds R]

The adaptive regulators of paper section 3 read, every control period, the
current H_ii, h_i and Q_i of their drive (paper 4.1). For each built-in robot
(``manipcad.catalog_names()``) this times, per sample (state):

* ``torque_components`` single: a Python loop of one-state calls of
  :func:`manipcad.torque_components` (the whole split of P_i, five dynamics calls);
* ``moment_components`` single: a Python loop of one-state calls of
  :func:`manipcad.analysis.moment_components` (H_ii, h_i, Q_i only, one compiled call);
* kernel in a compiled loop: :func:`manipcad.analysis.realtime.components_one`
  called from a numba loop with preallocated scratch, as a compiled regulator or
  the simulator would call it (no Python in the loop);
* batched: one call of each public function on N = 10,000 states, divided by N.

Wall clock (``time.perf_counter``); the cases are interleaved round by round so
that the noise of a shared machine hits them alike; the table shows the
minimum over the rounds and, in brackets, the median, in µs per sample, and
the minimum as a share of a 1 ms control period.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import statistics
import sys
import time
import warnings

import numba
import numpy as np

import manipcad
from manipcad.analysis.realtime import components_one, moment_components, scratch

N_BATCH = 10_000
PERIOD = 1e-3  # s, the control period


@numba.njit(cache=False, nogil=True)
def _kernel_loop(table, g, Q, QD, reps, zero, rwork, cwork, tmp, H):
    """Call components_one on the rows of Q, QD, ``reps`` times over (compiled caller)."""
    n = table.shape[0]
    Hii = np.empty(n)
    h = np.empty(n)
    Qg = np.empty(n)
    acc = 0.0
    for _ in range(reps):
        for k in range(Q.shape[0]):
            components_one(table, g, Q[k], QD[k], zero, rwork, cwork, tmp, H, Hii, h, Qg)
            acc += Hii[0] + h[0] + Qg[0]
    return acc


def bench_robot(robot, rounds: int, n_single: int, n_batch: int) -> dict:
    rng = np.random.default_rng(0)
    n = robot.n
    Q, QD, QDD = rng.uniform(-1, 1, (3, n_batch, n))
    singles = [(Q[k].copy(), QD[k].copy(), QDD[k].copy()) for k in range(n_single)]
    work = scratch(n)
    # warm up (compile)
    manipcad.torque_components(robot, *singles[0])
    moment_components(robot, singles[0][0], singles[0][1])
    manipcad.torque_components(robot, Q[:10], QD[:10], QDD[:10])
    moment_components(robot, Q[:10], QD[:10])
    _kernel_loop(robot.table, robot.gravity, Q[:2], QD[:2], 1, *work)

    def tc_single():
        t = time.perf_counter()
        for q, qd, qdd in singles:
            manipcad.torque_components(robot, q, qd, qdd)
        return (time.perf_counter() - t) / n_single

    def mc_single():
        t = time.perf_counter()
        for q, qd, _ in singles:
            moment_components(robot, q, qd)
        return (time.perf_counter() - t) / n_single

    def kernel():
        reps = 10
        t = time.perf_counter()
        _kernel_loop(robot.table, robot.gravity, Q[:n_single], QD[:n_single], reps, *work)
        return (time.perf_counter() - t) / (n_single * reps)

    def tc_batch():
        t = time.perf_counter()
        manipcad.torque_components(robot, Q, QD, QDD)
        return (time.perf_counter() - t) / n_batch

    def mc_batch():
        t = time.perf_counter()
        moment_components(robot, Q, QD)
        return (time.perf_counter() - t) / n_batch

    cases = {"torque_components, single": tc_single, "moment_components, single": mc_single,
             "components_one in a compiled loop": kernel,
             "torque_components, batch": tc_batch, "moment_components, batch": mc_batch}
    times: dict[str, list[float]] = {k: [] for k in cases}
    for _ in range(rounds):
        for name, f in cases.items():
            times[name].append(f())
    return {name: {"min_us": min(v) * 1e6, "median_us": statistics.median(v) * 1e6,
                   "share_of_1ms": min(v) / PERIOD} for name, v in times.items()}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--quick", action="store_true", help="fewer states and rounds")
    ap.add_argument("--rounds", type=int, default=None, help="rounds per case (default 7)")
    ap.add_argument("--json", default=None, help="write the results to this JSON file")
    args = ap.parse_args(argv)
    rounds = args.rounds or (3 if args.quick else 7)
    n_single = 200 if args.quick else 2000
    n_batch = 2000 if args.quick else N_BATCH
    results = {}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", manipcad.ManipcadWarning)
        robots = {name: manipcad.load_robot(name) for name in manipcad.catalog_names()}
    for name, robot in robots.items():
        results[name] = {"n": robot.n, **bench_robot(robot, rounds, n_single, n_batch)}

    cases = [k for k in next(iter(results.values())) if k != "n"]
    print(f"H_ii, h_i, Q_i per sample, µs: min (median) over {rounds} rounds; "
          f"% of a 1 ms control period")
    print(f"{'robot':12s} {'n':>2s}  " + "  ".join(f"{c:>34s}" for c in cases))
    for name, r in results.items():
        cells = [f"{r[c]['min_us']:8.2f} ({r[c]['median_us']:7.2f}) "
                 f"{100 * r[c]['share_of_1ms']:6.2f} %" for c in cases]
        print(f"{name:12s} {r['n']:2d}  " + "  ".join(f"{c:>34s}" for c in cells))
    env = {"python": sys.version.split()[0], "numpy": np.__version__,
           "numba": numba.__version__, "manipcad": manipcad.__version__,
           "machine": platform.machine(), "processor": platform.processor(),
           "cpus": os.cpu_count(), "numba_threads": numba.config.NUMBA_NUM_THREADS,
           "batch": n_batch, "singles": n_single, "rounds": rounds}
    print("environment:", ", ".join(f"{k} {v}" for k, v in env.items()))
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump({"environment": env, "results": results}, f, indent=2)
    return 0


if __name__ == "__main__":
    sys.exit(main())
