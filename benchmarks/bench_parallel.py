"""Benchmark: the claims maps' quick grid on 1 and on 2 Dask workers (speed-up, time per cell).

Usage::

    python benchmarks/bench_parallel.py [--grid quick|full] [--workers N]
                                        [--arm light|industrial|heavy]

Runs ``manipcad.study.claims.run_claims`` on an arm (default light) into fresh
folders (no cache), first serially (``workers=1``, in this process), then on a
local Dask cluster of N worker processes (default 2; its start-up, the
workers' imports and their loading of the compiled kernels are included: the
study starts the cluster in a background thread while it sizes the rows, and
each worker loads the kernels at start), after one warm-up cell that compiles
the kernels. The grid's cells that time scaling makes equal are computed once,
so the cells counted are the computed ones. Prints the wall times, the
speed-up and the time per cell, and a projection for a 64-worker cluster (one
round of the longest cell plus the measured fixed cost).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import manipcad
from manipcad.study import claims as claims_mod
from manipcad.study.claims import claims_cell, own_load_ratio, run_claims


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", default="quick", choices=sorted(claims_mod.GRIDS))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--arm", default="light", choices=sorted(claims_mod.ARMS))
    args = ap.parse_args()
    arm = manipcad.load_robot("cylindrical")
    claims_cell(speed_scale=1.0, load_ratio=own_load_ratio(arm), arm=arm, dt=1e-4)  # compile
    times, docs = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for w in (1, args.workers):
            t0 = time.perf_counter()
            docs[w] = run_claims(Path(tmp) / f"w{w}", arm=args.arm, grid=args.grid, workers=w,
                                 progress=False)
            times[w] = time.perf_counter() - t0
    same = docs[1]["claims"] == docs[args.workers]["claims"]
    cells = docs[1]["settings"]["cells_computed"]
    grid_cells = len(docs[1]["grid"]["speed_scale"]) * len(docs[1]["grid"]["load_ratio"])
    per_cell = times[1] / cells
    fixed = max(times[args.workers] - per_cell * cells / args.workers, 0.0)
    longest = max(1.0 / s for row in docs[1]["speed_scale_run"] for s in row if s)
    print(f"arm {args.arm}, grid {args.grid}: {grid_cells} cells, {cells} computed (the "
          f"time-scaled ones of a row are one)")
    print(f"workers=1: {times[1]:.1f} s ({per_cell:.2f} s per computed cell)")
    print(f"workers={args.workers}: {times[args.workers]:.1f} s; speed-up "
          f"{times[1] / times[args.workers]:.2f}x (fixed cost about {fixed:.1f} s); "
          f"results identical: {same}")
    # one round: the longest cell, about per_cell scaled by its duration over the mean's
    unique = {(i, s) for i, row in enumerate(docs[1]["speed_scale_run"]) for s in row if s}
    mean = sum(1.0 / s for _, s in unique) / len(unique)
    one = per_cell * longest / mean
    print(f"projection, 64 workers: one round of the longest cell (~{one:.1f} s) + "
          f"{fixed:.1f} s fixed = {one + fixed:.1f} s")


if __name__ == "__main__":
    main()
