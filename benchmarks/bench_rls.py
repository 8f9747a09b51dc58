"""Benchmark: the online payload estimator's cost per control period.

Usage::

    python benchmarks/bench_rls.py [--quick] [--rounds R]

For each robot, times per period (µs) the compiled loop of
:func:`manipcad.dynamics.rls.payload_rls_step` (two RNEA passes, the update;
``OnlinePayloadEstimator.run`` on N states) against its peer, one compiled
RNEA pass per state in the same kind of loop (the inverse dynamics the step
is made of), and as a share of a 1 ms control period. Wall clock, the cases
interleaved round by round, minimum over the rounds (median in brackets).
"""

from __future__ import annotations

import argparse
import platform
import statistics
import time
import warnings

import numba as nb
import numpy as np

import manipcad
from manipcad.dynamics.rls import OnlinePayloadEstimator
from manipcad.dynamics.rnea import RNEA_WORK, rnea_one
from manipcad.errors import ManipcadWarning
from manipcad.trajectories import cosine


@nb.njit(cache=True)
def _rnea_loop(table, g, Q, QD, QDD, out):
    n = Q.shape[1]
    fext = np.zeros((n, 6))
    work = np.empty((n, RNEA_WORK))
    tau = np.empty(n)
    for t in range(Q.shape[0]):
        rnea_one(table, g, Q[t], QD[t], QDD[t], fext, False, True, work, tau)
        out[t] = tau[0]


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--quick", action="store_true", help="fewer states and rounds")
    ap.add_argument("--rounds", type=int, default=None)
    args = ap.parse_args()
    N = 2_000 if args.quick else 20_000
    rounds = args.rounds or (3 if args.quick else 7)
    print(f"python {platform.python_version()}, numpy {np.__version__}, numba {nb.__version__}; "
          f"N = {N} periods, {rounds} rounds")
    print("| robot | n | RLS step, µs/period | RNEA peer, µs/period | ratio | share of 1 ms |")
    print("|---|---|---|---|---|---|")
    for name in ("cylindrical", "puma560", "stanford"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ManipcadWarning)
            robot = manipcad.load_robot(name)
        n = robot.n
        t = np.linspace(0.0, 3.0, N)
        q, qd, qdd = cosine(np.full(n, 0.3), np.linspace(2.0, 4.0, n), 3.0).sample(t)
        tau = manipcad.inverse_dynamics(robot.with_payload(1.0), q, qd, qdd)
        est = OnlinePayloadEstimator(robot, forgetting=0.999)
        out = np.empty(N)
        est.run(q[:10], qd[:10], qdd[:10], tau[:10])  # compile
        _rnea_loop(robot.table, robot.gravity, q[:10], qd[:10], qdd[:10], out)
        a, b = [], []
        for _ in range(rounds):
            t0 = time.perf_counter()
            est.run(q, qd, qdd, tau)
            a.append((time.perf_counter() - t0) / N * 1e6)
            t0 = time.perf_counter()
            _rnea_loop(robot.table, robot.gravity, q, qd, qdd, out)
            b.append((time.perf_counter() - t0) / N * 1e6)
        print(f"| {name} | {n} | {min(a):.3f} ({statistics.median(a):.3f}) | "
              f"{min(b):.3f} ({statistics.median(b):.3f}) | {min(a) / min(b):.2f} | "
              f"{min(a) / 1e3 * 100:.3f} % |")


if __name__ == "__main__":
    main()
