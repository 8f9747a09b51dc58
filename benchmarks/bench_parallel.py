"""Benchmark: the claims maps' quick grid on 1 and on 2 Dask workers (speed-up, time per cell).

Usage::

    python benchmarks/bench_parallel.py [--grid quick|full] [--workers N]

Runs ``manipcad.study.claims.run_claims`` on the light arm into fresh folders
(no cache), first serially (``workers=1``, in this process), then on a local
Dask cluster of N worker processes (default 2; its start-up and the workers'
loading of the compiled kernels are included), after one warm-up cell that
compiles the kernels. Prints the wall times, the speed-up and the time per
cell, and a projection for a 64-worker cluster (cells / 64 rounds of the
per-cell time plus the measured fixed cost).
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
    args = ap.parse_args()
    arm = manipcad.load_robot("cylindrical")
    claims_cell(speed_scale=1.0, load_ratio=own_load_ratio(arm), arm=arm, dt=1e-4)  # compile
    cells = len(claims_mod.GRIDS[args.grid]["speed_scale"]) * len(
        claims_mod.GRIDS[args.grid]["load_ratio"])
    times = {}
    with tempfile.TemporaryDirectory() as tmp:
        for w in (1, args.workers):
            t0 = time.perf_counter()
            run_claims(Path(tmp) / f"w{w}", grid=args.grid, workers=w, progress=False)
            times[w] = time.perf_counter() - t0
    per_cell = times[1] / cells
    fixed = max(times[args.workers] - per_cell * cells / args.workers, 0.0)
    print(f"grid {args.grid}: {cells} cells")
    print(f"workers=1: {times[1]:.1f} s ({per_cell:.2f} s per cell)")
    print(f"workers={args.workers}: {times[args.workers]:.1f} s; speed-up "
          f"{times[1] / times[args.workers]:.2f}x (fixed cost about {fixed:.1f} s)")
    rounds = -(-cells // 64)
    print(f"projection, 64 workers: {rounds} round(s) of {per_cell:.2f} s + {fixed:.1f} s fixed "
          f"= {rounds * per_cell + fixed:.1f} s (the full grid: "
          f"{-(-49 // 64) * per_cell + fixed:.1f} s)")


if __name__ == "__main__":
    main()
