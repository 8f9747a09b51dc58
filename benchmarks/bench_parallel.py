"""Benchmark: the claims maps' quick grid on 1 and on 2 Dask workers (speed-up, time per cell).

Usage::

    python benchmarks/bench_parallel.py [--grid quick|full] [--workers N]
                                        [--arm light|industrial|heavy] [--cli]
                                        [--rounds R]

Headline: ``manipcad.study.claims.run_claims`` end to end (sizing of the rows,
cluster start, the cells, claims.json/png/html written), on an arm (default
light) into fresh folders (no cache), first serially (``workers=1``, in this
process), then on a local Dask cluster of N worker processes (default 2: its
start and the workers' warm-up are inside the time), after one warm-up cell
that compiles (or loads) the kernels in this process, as a session that has
already run something has them. Each cell is cached whole, but its 14
closed-loop runs are the units of work, handed out longest first (in
guided batches, single runs at the end); the time-scaled cells of a row are
computed once (the cells counted are the computed ones).

Also printed: the sum of the runs' times in the serial run, the ideal
schedule of those runs on N and on 64 workers (longest first onto the first
free worker), and the projection for a 64-worker cluster (that schedule plus
what the N-worker run spent beyond its own ideal schedule: cluster start,
sizing, writing the files).

``--rounds R`` repeats the whole measurement in R fresh processes (each: the
warm-up cell, the serial run, the N-worker run, which imports distributed and
starts its cluster as a user's command does) and reports each time's minimum
over the rounds; on a shared machine another session's load only slows a run.

``--cli`` also times the user's command in fresh processes (``python -m
manipcad study claims --grid G --arm A --workers 1|N --out DIR``, each
from interpreter start to exit: imports, python-control, the kernels loaded
from their cache, the files written), after one untimed run that fills the
kernel cache.
"""

from __future__ import annotations

import argparse
import heapq
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import manipcad
from manipcad.study import claims as claims_mod
from manipcad.study.claims import claims_cell, own_load_ratio, run_claims


def schedule(times: list[float], workers: int) -> float:
    """The makespan of ``times`` handed out longest first to the first free of ``workers``."""
    free = [0.0] * workers
    for t in sorted(times, reverse=True):
        heapq.heappush(free, heapq.heappop(free) + t)
    return max(free)


def _cli(grid: str, arm: str, workers: int, out: Path) -> float:
    cmd = [sys.executable, "-m", "manipcad", "study", "claims", "--grid", grid, "--arm",
           arm, "--workers", str(workers), "--out", str(out)]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", default="quick", choices=sorted(claims_mod.GRIDS))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--arm", default="light", choices=sorted(claims_mod.ARMS))
    ap.add_argument("--cli", action="store_true", help="also time the CLI in fresh processes")
    ap.add_argument("--rounds", type=int, default=1, help="this many rounds, each in a fresh "
                    "process (the N-worker run imports distributed as a user's does); the "
                    "minimum of each time is reported (a shared machine's load only slows "
                    "a run down)")
    ap.add_argument("--emit", help=argparse.SUPPRESS)  # one round's figures as JSON, to a file
    args = ap.parse_args()
    if args.rounds > 1:
        return _rounds(args)
    arm = manipcad.load_robot("cylindrical")
    claims_cell(speed_scale=1.0, load_ratio=own_load_ratio(arm), arm=arm, dt=1e-4)  # compile
    run_times: list[float] = []
    plain_run = claims_mod.claims_run

    def timed_run(**kw):  # the serial run's runs, timed one by one (in this process)
        t0 = time.perf_counter()
        out = plain_run(**kw)
        run_times.append(time.perf_counter() - t0)
        return out

    times, docs = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for w in (1, args.workers):
            claims_mod.claims_run = timed_run if w == 1 else plain_run
            t0 = time.perf_counter()
            docs[w] = run_claims(Path(tmp) / f"w{w}", arm=args.arm, grid=args.grid, workers=w,
                                 progress=False)
            times[w] = time.perf_counter() - t0
        claims_mod.claims_run = plain_run
        cli = {}
        if args.cli:
            _cli(args.grid, args.arm, 1, Path(tmp) / "cli-warm")
            for w in (1, args.workers):
                cli[w] = _cli(args.grid, args.arm, w, Path(tmp) / f"cli{w}")
    same = docs[1]["claims"] == docs[args.workers]["claims"]
    cells = docs[1]["settings"]["cells_computed"]
    grid_cells = len(docs[1]["grid"]["speed_scale"]) * len(docs[1]["grid"]["load_ratio"])
    if args.emit:
        Path(args.emit).write_text(json.dumps({
            "times": {str(w): t for w, t in times.items()}, "run_times": run_times,
            "same": same, "cells": cells, "grid_cells": grid_cells, "cli": {
                str(w): t for w, t in cli.items()}}))
        return
    _print(args, times, run_times, same, cells, grid_cells, cli)


def _rounds(args) -> None:
    """``args.rounds`` rounds in fresh processes; the minimum of each time printed."""
    got = []
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            out = Path(tmp) / f"round{r}.json"
            cmd = [sys.executable, __file__, "--grid", args.grid, "--workers",
                   str(args.workers), "--arm", args.arm, "--emit", str(out)]
            subprocess.run(cmd + (["--cli"] if args.cli else []), check=True)
            got.append(json.loads(out.read_text()))
    w = str(args.workers)
    print(f"{args.rounds} rounds, each in a fresh process (serial, then {args.workers} "
          f"workers): workers=1 " + ", ".join(f"{g['times']['1']:.2f}" for g in got)
          + f" s; workers={w} " + ", ".join(f"{g['times'][w]:.2f}" for g in got) + " s; "
          "speed-up per round " + ", ".join(f"{g['times']['1'] / g['times'][w]:.2f}x"
                                             for g in got))
    best = min(got, key=lambda g: g["times"]["1"])  # its runs' times: the fastest serial run
    times = {int(k): min(g["times"][k] for g in got) for k in ("1", w)}
    cli = {int(k): min(g["cli"][k] for g in got) for k in got[0]["cli"]}
    _print(args, times, best["run_times"], all(g["same"] for g in got), best["cells"],
           best["grid_cells"], cli, label="min of the rounds: ")


def _print(args, times, run_times, same, cells, grid_cells, cli, label="") -> None:
    busy = sum(run_times)
    ideal = schedule(run_times, args.workers)
    over = times[args.workers] - ideal
    print(f"arm {args.arm}, grid {args.grid}: {grid_cells} cells, {cells} computed (the "
          f"time-scaled ones of a row are one), {len(run_times)} closed-loop runs")
    print(f"{label}workers=1: {times[1]:.1f} s end to end ({times[1] / cells:.2f} s per computed "
          f"cell; the runs {busy:.1f} s, the rest {times[1] - busy:.1f} s)")
    print(f"workers={args.workers}: {times[args.workers]:.1f} s end to end; speed-up "
          f"{times[1] / times[args.workers]:.2f}x; results identical: {same}")
    print(f"  the runs' ideal schedule on {args.workers} workers {ideal:.1f} s (longest run "
          f"{max(run_times):.2f} s); beyond it {over:.1f} s (cluster start, sizing, files)")
    one = schedule(run_times, 64)
    print(f"projection, 64 workers: the runs' schedule {one:.2f} s + {over:.1f} s = "
          f"{one + over:.1f} s (a 64-worker cluster's start is assumed no longer)")
    if cli:
        print(f"CLI, fresh processes (manipcad study claims --grid {args.grid} --arm "
              f"{args.arm}): --workers 1 {cli[1]:.1f} s, --workers {args.workers} "
              f"{cli[args.workers]:.1f} s; speed-up {cli[1] / cli[args.workers]:.2f}x")


if __name__ == "__main__":
    main()
