"""Benchmark: what the online payload estimator costs inside the simulated closed loop.

Usage::

    python benchmarks/bench_pickup.py [--rounds R] [--t-end T]

The pickup study's job (the Fig. 2 arm, laws (2), ``ace_de`` on the turn, the lift and
reach PIDs, a 0.1 kg payload gripped at a third of the run, dt = period = 0.1 ms) run
with ``model_payload="true"`` (no estimator: the peer) and ``"online"`` (the estimator
at every regulator period, feeding the model), interleaved round by round. Prints the
wall time of each (minimum over the rounds, median in brackets), their ratio, the
real-time factor (simulated s per wall s) and the estimator's added cost per period
(µs), with its counted operations per period.
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
from manipcad.control.design import inertia_range
from manipcad.control.estimator import PayloadEstimator
from manipcad.errors import ManipcadWarning
from manipcad.study.fig3 import LAWS, support_regulators
from manipcad.trajectories import cosine

DT = 1e-4
MASS = 0.1


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--rounds", type=int, default=5)
    ap.add_argument("--t-end", type=float, default=1.6)
    args = ap.parse_args()
    arm = manipcad.load_robot("cylindrical")
    com = list(arm.tool_p)
    lr = (inertia_range(arm, 0)[0], inertia_range(arm.with_payload(MASS, com), 0)[1])
    regs = [manipcad.synthesize(arm, "turn", "ace_de", period=DT, load_range=lr),
            *support_regulators(arm, DT)]
    traj = cosine(list(LAWS["amplitude"]), list(LAWS["omega"]), max(LAWS["duration"],
                                                                   args.t_end))
    est = PayloadEstimator(arm, period=DT, com=com, forgetting=0.998, current_noise=0.02)
    pick = {"mass": MASS, "t": args.t_end / 3, "com": com}

    def run(mode):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ManipcadWarning)
            t0 = time.perf_counter()
            manipcad.simulate(arm, t_end=args.t_end, dt=DT, trajectory=traj, regulators=regs,
                              pickup=pick, estimator=est if mode == "online" else None,
                              model_payload=mode)
            return time.perf_counter() - t0

    for mode in ("true", "online"):  # compile
        run(mode)
    times = {"true": [], "online": []}
    for _ in range(args.rounds):
        for mode in times:
            times[mode].append(run(mode))
    print(f"python {platform.python_version()}, numpy {np.__version__}, numba {nb.__version__}; "
          f"{args.rounds} rounds, t_end {args.t_end:g} s, dt = period {DT:g} s")
    best = {m: min(v) for m, v in times.items()}
    for mode, v in times.items():
        print(f"  {mode:7s} {best[mode]:.4f} s ({statistics.median(v):.4f}), "
              f"RTF {args.t_end / best[mode]:.1f}")
    periods = round(args.t_end / DT)
    cx = est.realization_complexity()
    print(f"  online / true: {best['online'] / best['true']:.3f}; the estimator adds "
          f"{1e6 * (best['online'] - best['true']) / periods:.3f} µs per period "
          f"({cx['mul']} mul + {cx['add']} add counted)")


if __name__ == "__main__":
    main()
