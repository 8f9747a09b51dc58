"""Benchmark: the claims maps' quick grid on 1 and on 2 Dask workers (speed-up, time per cell).

Usage::

    python benchmarks/bench_parallel.py [--grid quick|full] [--workers N]
                                        [--arm light|industrial|heavy] [--cli]
                                        [--rounds R] [--cluster local|standing|both]

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

``--cluster standing`` measures the same run against a cluster the user already
runs (``run_claims(..., scheduler=ADDRESS)``, as ``manipcad study claims --scheduler
ADDRESS``): before anything is timed, another process (this script with a hidden
option, standing for ``dask scheduler`` + ``dask worker``) starts a LocalCluster of N
worker processes of one thread each (spawned, the scheduler in that process, with
the Dask settings of the study's own cluster, ``executor.LOCAL_CONFIG``), then warms every
worker with the same warm-up cell this process computes (and the study's
``warm_worker``), and serves; this process then times its serial run and the run
against the standing cluster. The timed run starts from a fresh output folder (no cell
cache: every cell is computed, the counts are checked) and includes all the study does
once the cluster exists: ``import distributed``, connecting, the study's warm-up call
on the workers, the rows' sizing, the cells, the panels, claims.json/png/html. Its
results must equal the serial run's (the whole claims.json but its time stamp).
``--cluster both`` measures both modes, each in its own fresh process per round (its own
serial run), one after the other.

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
import logging
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import manipcad
from manipcad.parallel.executor import LOCAL_CONFIG
from manipcad.study import claims as claims_mod
from manipcad.study.claims import claims_cell, own_load_ratio, run_claims


def schedule(times: list[float], workers: int) -> float:
    """The makespan of ``times`` handed out longest first to the first free of ``workers``."""
    free = [0.0] * workers
    for t in sorted(times, reverse=True):
        heapq.heappush(free, heapq.heappop(free) + t)
    return max(free)


def _cli(grid: str, arm: str, workers: int, out: Path, scheduler: str | None = None) -> float:
    cmd = [sys.executable, "-m", "manipcad", "study", "claims", "--grid", grid, "--arm",
           arm, "--out", str(out)]
    cmd += ["--workers", str(workers)] if scheduler is None else ["--scheduler", scheduler]
    t0 = time.perf_counter()
    subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    return time.perf_counter() - t0


WARM_CELL = {"speed_scale": 1.0, "dt": 1e-4}  # the warm-up cell (own load ratio, light arm)


def _warm_cell() -> None:
    """The warm-up cell: compiles (or loads) the kernels a claims cell uses, here."""
    arm = manipcad.load_robot("cylindrical")
    claims_cell(load_ratio=own_load_ratio(arm), arm=arm, **WARM_CELL)


def _serve_cluster(workers: int, grid: str, arm: str) -> None:
    """Stand for a cluster the user runs (``dask scheduler`` + ``dask worker --nthreads
    1``): a LocalCluster of ``workers`` spawned processes of one thread each (numba's
    too: ``NUMBA_NUM_THREADS=1``), warmed by the warm-up cell on every worker, then one
    throwaway study (the same arm and grid, into a folder deleted at once) as a
    user's earlier command would have; its address printed, then served until stdin
    closes."""
    import dask
    from distributed import Client, LocalCluster

    with dask.config.set(LOCAL_CONFIG):
        cluster = LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                               dashboard_address=":0", memory_limit=0,
                               silence_logs=logging.ERROR)
    with Client(cluster, set_as_default=False) as client:
        client.wait_for_workers(workers)
        client.run(_warm_cell)
    with tempfile.TemporaryDirectory() as tmp:
        run_claims(Path(tmp) / "throwaway", arm=arm, grid=grid,
                   scheduler=cluster.scheduler_address, progress=False)
    print(cluster.scheduler_address, flush=True)
    sys.stdin.read()  # until the benchmark closes it
    cluster.close()


class _Standing:
    """The standing cluster: another process of this script (``--serve-cluster N``)."""

    def __init__(self, workers: int, grid: str, arm: str) -> None:
        # NUMBA_NUM_THREADS from the start (numba refuses a change once its threads run)
        self.proc = subprocess.Popen([sys.executable, __file__, "--serve-cluster",
                                      str(workers), "--grid", grid, "--arm", arm],
                                     env={**os.environ, "NUMBA_NUM_THREADS": "1"},
                                     stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, text=True)
        self._address: str | None = None

    def address(self) -> str:
        """The scheduler's address (waits until every worker is warm)."""
        if self._address is None:
            line = self.proc.stdout.readline().strip()
            if "://" not in line:
                raise RuntimeError(f"the standing cluster did not start ({line!r})")
            self._address = line
        return self._address

    def close(self) -> None:
        self.proc.stdin.close()
        try:
            self.proc.wait(timeout=30)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()


def _same(a: dict, b: dict) -> bool:
    """Two claims.json documents equal but for their time stamp."""
    return {k: v for k, v in a.items() if k != "created"} == {
        k: v for k, v in b.items() if k != "created"}


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
    ap.add_argument("--cluster", default="local", choices=("local", "standing", "both"),
                    help="local: the study starts its own LocalCluster inside the timed "
                    "run (default); standing: a cluster started and warmed beforehand by "
                    "another process, given by address (--scheduler); both: each mode in "
                    "its own process, one after the other")
    ap.add_argument("--emit", help=argparse.SUPPRESS)  # one round's figures as JSON, to a file
    ap.add_argument("--serve-cluster", type=int, help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.serve_cluster:
        return _serve_cluster(args.serve_cluster, args.grid, args.arm)
    if args.rounds > 1 or args.cluster == "both":
        return _rounds(args)
    standing = _Standing(args.workers, args.grid, args.arm) if args.cluster == "standing" else None
    try:
        got = _measure(args, standing)
    finally:
        if standing is not None:
            standing.close()
    if args.emit:
        Path(args.emit).write_text(json.dumps(got))
        return
    _print(args, args.cluster, {int(k): t for k, t in got["times"].items()}, got["run_times"],
           got["same"], got["cells"], got["grid_cells"],
           {int(k): t for k, t in got["cli"].items()})


def _measure(args, standing: _Standing | None) -> dict:
    """One round in this process: the warm-up cell, the serial run, the N-worker run (on
    a LocalCluster the study starts, or on ``standing``)."""
    _warm_cell()  # compile (or load) the kernels here, as a session that has run something
    address = standing.address() if standing is not None else None  # warm, serving
    run_times: list[float] = []
    plain_run = claims_mod.claims_run

    def timed_run(**kw):  # the serial run's runs, timed one by one (in this process)
        t0 = time.perf_counter()
        out = plain_run(**kw)
        run_times.append(time.perf_counter() - t0)
        return out

    w = args.workers
    times, docs = {}, {}
    with tempfile.TemporaryDirectory() as tmp:
        for n in (1, w):
            claims_mod.claims_run = timed_run if n == 1 else plain_run
            kw = {"workers": n} if n == 1 or address is None else {"scheduler": address}
            t0 = time.perf_counter()
            docs[n] = run_claims(Path(tmp) / f"w{n}", arm=args.arm, grid=args.grid,
                                 progress=False, **kw)
            times[n] = time.perf_counter() - t0
        claims_mod.claims_run = plain_run
        cli = {}
        if args.cli:
            _cli(args.grid, args.arm, 1, Path(tmp) / "cli-warm")
            for n in (1, w):
                cli[n] = _cli(args.grid, args.arm, n, Path(tmp) / f"cli{n}",
                              None if n == 1 else address)
    for n in (1, w):  # every cell computed, none from a cache
        s = docs[n]["settings"]
        if s["cells_cached"]:
            raise RuntimeError(f"workers={n}: {s['cells_cached']} cells from a cache")
    if docs[w]["settings"]["cells_computed"] != docs[1]["settings"]["cells_computed"]:
        raise RuntimeError("the two runs computed different numbers of cells")
    grid = docs[1]["grid"]
    return {"times": {str(n): t for n, t in times.items()}, "run_times": run_times,
            "same": _same(docs[1], docs[w]), "cells": docs[1]["settings"]["cells_computed"],
            "grid_cells": len(grid["speed_scale"]) * len(grid["load_ratio"]),
            "cli": {str(n): t for n, t in cli.items()}}


def _rounds(args) -> None:
    """``args.rounds`` rounds in fresh processes (per mode); the minimum of each time printed."""
    modes = ("local", "standing") if args.cluster == "both" else (args.cluster,)
    got: dict[str, list] = {m: [] for m in modes}
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for m in modes:
                out = Path(tmp) / f"round{r}-{m}.json"
                cmd = [sys.executable, __file__, "--grid", args.grid, "--workers",
                       str(args.workers), "--arm", args.arm, "--cluster", m, "--emit",
                       str(out)]
                subprocess.run(cmd + (["--cli"] if args.cli else []), check=True)
                got[m].append(json.loads(out.read_text()))
    w = str(args.workers)
    for m in modes:
        g_m = got[m]
        print(f"[{m}] {args.rounds} rounds, each in a fresh process (serial, then "
              f"{args.workers} workers, {WHERE[m]}): workers=1 "
              + ", ".join(f"{g['times']['1']:.2f}" for g in g_m) + f" s; workers={w} "
              + ", ".join(f"{g['times'][w]:.2f}" for g in g_m) + " s; speed-up per round "
              + ", ".join(f"{g['times']['1'] / g['times'][w]:.2f}x" for g in g_m))
        best = min(g_m, key=lambda g: g["times"]["1"])  # its runs' times: the fastest serial
        times = {int(k): min(g["times"][k] for g in g_m) for k in ("1", w)}
        cli = {int(k): min(g["cli"][k] for g in g_m) for k in g_m[0]["cli"]}
        _print(args, m, times, best["run_times"], all(g["same"] for g in g_m),
               best["cells"], best["grid_cells"], cli, label="min of the rounds: ")


WHERE = {"local": "the study's own LocalCluster started inside the timed run",
         "standing": "a standing cluster started and warmed beforehand, --scheduler"}
BEYOND = {"local": "cluster start, sizing, files", "standing": "connecting, sizing, files"}


def _print(args, mode, times, run_times, same, cells, grid_cells, cli, label="") -> None:
    busy = sum(run_times)
    ideal = schedule(run_times, args.workers)
    over = times[args.workers] - ideal
    print(f"arm {args.arm}, grid {args.grid}: {grid_cells} cells, {cells} computed (the "
          f"time-scaled ones of a row are one), {len(run_times)} closed-loop runs")
    print(f"{label}workers=1: {times[1]:.2f} s end to end ({times[1] / cells:.2f} s per "
          f"computed cell; the runs {busy:.1f} s, the rest {times[1] - busy:.1f} s)")
    print(f"workers={args.workers} ({WHERE[mode]}): {times[args.workers]:.2f} s end to end; "
          f"speed-up {times[1] / times[args.workers]:.2f}x; results identical: {same}")
    print(f"  the runs' ideal schedule on {args.workers} workers {ideal:.1f} s (longest run "
          f"{max(run_times):.2f} s); beyond it {over:.1f} s ({BEYOND[mode]})")
    one = schedule(run_times, 64)
    print(f"projection, 64 workers: the runs' schedule {one:.2f} s + {over:.1f} s = "
          f"{one + over:.1f} s (a 64-worker cluster's start is assumed no longer)")
    if cli:
        how = f"--workers {args.workers}" if mode == "local" else "--scheduler ADDRESS"
        print(f"CLI, fresh processes (manipcad study claims --grid {args.grid} --arm "
              f"{args.arm}): --workers 1 {cli[1]:.1f} s, {how} "
              f"{cli[args.workers]:.1f} s; speed-up {cli[1] / cli[args.workers]:.2f}x")


if __name__ == "__main__":
    main()
