"""Timeline of one claims-maps run: where the wall time of ``run_claims`` goes, per process.

Usage::

    python benchmarks/claims_timeline.py [--grid quick|full] [--workers N] [--arm A]
                                         [--rounds R] [--no-serial] [--verbose]

Runs ``manipcad.study.claims.run_claims`` into fresh folders (after one warm-up cell that
loads the kernels in this process, as ``bench_parallel.py`` does), serially and then on N
workers (``--no-serial``: only on N workers, whose forked processes then load the
kernels this one has not), and logs, with the wall clock and the process's CPU time:

- in this process: the pool's start (import distributed, the cluster forked), the
  client ready (the workers warmed), every ``run_tasks`` and ``_run_dask`` call (the
  rows' sizing, the cells, the figure's panels), every cell's planning, the files;
- on the workers (forked after the patches, so they run the logging wrappers):
  the warm-up, each row's sizing, each closed-loop run, each group of panels.

Prints per run the CPU time of this process and of the workers (as they exit), the
N-worker run's wall time cut into phases by the workers' tasks (cluster start, sizing,
runs, panels, the tail) with the share of each phase the workers were busy, and per
worker its busy time and the gaps between its tasks; ``--verbose`` also every event of
this process. Only on an idle machine do the wall times mean what they say.
"""

from __future__ import annotations

import argparse
import functools
import json
import os
import resource
import tempfile
import time
from collections import defaultdict
from pathlib import Path

import manipcad
from manipcad.parallel import executor
from manipcad.report import claims as report_mod
from manipcad.study import claims as claims_mod

LOG = Path(tempfile.mkdtemp(prefix="claims-timeline-")) / "events.jsonl"
T0 = [0.0]


def _emit(name: str, t0: float, t1: float, c0: float, c1: float, **extra) -> None:
    line = json.dumps({"pid": os.getpid(), "name": name, "t0": t0, "t1": t1,
                       "cpu": c1 - c0, **extra}) + "\n"
    fd = os.open(LOG, os.O_WRONLY | os.O_APPEND | os.O_CREAT, 0o644)
    try:
        os.write(fd, line.encode())
    finally:
        os.close(fd)


def _logged(name: str, fn, label=None):
    @functools.wraps(fn)
    def wrapper(*a, **kw):
        t0, c0 = time.time(), time.process_time()
        try:
            return fn(*a, **kw)
        finally:
            extra = {"label": label(a, kw)} if label else {}
            _emit(name, t0, time.time(), c0, time.process_time(), **extra)
    return wrapper


def _patch() -> None:
    claims_mod.claims_run = _logged("run", claims_mod.claims_run,
                                    lambda a, kw: kw.get("label"))
    claims_mod.size_row = _logged("size_row", claims_mod.size_row)
    claims_mod.cell_plan = _logged("cell_plan", claims_mod.cell_plan)
    claims_mod.warm_worker = _logged("warm_worker", claims_mod.warm_worker)
    claims_mod._write = _logged("write files", claims_mod._write)
    report_mod.draw_panels = _logged("draw_panels", report_mod.draw_panels)
    report_mod.save_bands = _logged("save_bands", report_mod.save_bands)
    report_mod.claims_html = _logged("claims_html", report_mod.claims_html)
    import manipcad.parallel as par

    par.run_tasks = _logged("run_tasks", executor.run_tasks,
                            lambda a, kw: getattr(a[0], "__name__", "?"))
    par.Pool = executor.Pool
    executor.Pool.__init__ = _logged("Pool start (fork)", executor.Pool.__init__)
    executor.Pool.client = _logged("Pool.client (wait)", executor.Pool.client)
    executor._run_dask = _logged("_run_dask", executor._run_dask,
                                 lambda a, kw: f"{getattr(a[1], '__name__', '?')}, "
                                 f"{len(a[5])} tasks")


def _phases(t_call: float, wall: float, ev: list[dict], n: int) -> None:
    """The N-worker run's wall time cut into phases by the workers' tasks, with the share
    of each phase the workers spent in tasks."""
    kinds = ("warm_worker", "run", "draw_panels")
    span = {k: (min(e["t0"] for e in ev if e["name"] == k) - t_call,
                max(e["t1"] for e in ev if e["name"] == k) - t_call)
            for k in kinds if any(e["name"] == k for e in ev)}
    names = {"warm_worker": "warm-up (client.run)",
             "run": "the closed-loop runs", "draw_panels": "claims.png's panels"}
    between = {"warm_worker": "cluster start (import distributed, fork, workers up)",
               "run": "the rows sized, planning, the first runs out",
               "draw_panels": "cells combined, claims.json, the panels out"}
    if "warm_worker" not in span:  # forked workers: no warm-up task
        between["run"] = "cluster start, planning, the first runs out"
    at = 0.0
    print(f"  {'phase':<56} {'from':>6} {'to':>6} {'s':>6}  workers busy")
    for k in kinds:
        if k not in span:
            continue
        a, b = span[k]
        if a > at:
            print(f"  {between[k]:<56} {at:6.2f} {a:6.2f} {a - at:6.2f}")
        busy = sum(min(e["t1"] - t_call, b) - max(e["t0"] - t_call, a) for e in ev
                   if e["name"] in kinds and e["t1"] - t_call > a and e["t0"] - t_call < b)
        print(f"  {names[k]:<56} {a:6.2f} {b:6.2f} {b - a:6.2f}  "
              f"{100 * busy / (n * max(b - a, 1e-9)):5.1f} %")
        at = b
    print(f"  {'PNG written, report.html, cluster closed':<56} {at:6.2f} {wall:6.2f} "
          f"{wall - at:6.2f}")


def _report(t_call: float, wall: float, main_pid: int, verbose: bool) -> None:
    ev = [json.loads(s) for s in LOG.read_text().splitlines()]
    LOG.unlink()
    ev = [e for e in ev if e["t1"] >= t_call]
    by_pid = defaultdict(list)
    for e in ev:
        by_pid[e["pid"]].append(e)
    print(f"  end to end {wall:.2f} s")
    # the workers ran the cells' runs; another child (the rows' sizing) only size_row
    workers = [p for p in by_pid if p != main_pid
               and any(e["name"] != "size_row" for e in by_pid[p])]
    if workers:
        _phases(t_call, wall, [e for p in workers for e in by_pid[p]], len(workers))
    for pid in sorted(by_pid, key=lambda p: (p != main_pid, p)):
        es = sorted(by_pid[pid], key=lambda e: e["t0"])
        who = ("main" if pid == main_pid else f"worker {pid}" if pid in workers
               else f"child {pid}")
        if pid == main_pid and verbose:
            for e in es:
                if e["name"] in ("run", "size_row", "draw_panels") or \
                        e.get("label") == "gain_cell":  # the serial run's tasks; lqr_gs tables
                    continue
                lab = f" [{e['label']}]" if e.get("label") else ""
                print(f"  {who:>13}: {e['t0'] - t_call:6.2f} -> {e['t1'] - t_call:6.2f} s "
                      f"({e['t1'] - e['t0']:5.2f} wall, {e['cpu']:5.2f} cpu) {e['name']}{lab}")
        agg = defaultdict(lambda: [0, 0.0, 0.0])
        for e in es:
            a = agg[e["name"]]
            a[0] += 1
            a[1] += e["t1"] - e["t0"]
            a[2] += e["cpu"]
        tasks = [e for e in es if e["name"] in ("run", "size_row", "draw_panels", "warm_worker")]
        if tasks:
            busy = sum(e["t1"] - e["t0"] for e in tasks)
            first, last = min(e["t0"] for e in tasks), max(e["t1"] for e in tasks)
            gaps = sum(max(0.0, b["t0"] - a["t1"]) for a, b in zip(tasks, tasks[1:], strict=False))
            print(f"  {who:>13}: tasks from {first - t_call:.2f} to {last - t_call:.2f} s, "
                  f"busy {busy:.2f} s, gaps between tasks {gaps:.2f} s; " + ", ".join(
                      f"{k} {n}x {w:.2f} s ({c:.2f} cpu)" for k, (n, w, c) in agg.items()
                      if k in ("run", "size_row", "draw_panels", "warm_worker")))


def _children() -> float:
    """CPU time of this process's ended (waited-for) child processes, s."""
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--grid", default="quick", choices=sorted(claims_mod.GRIDS))
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--arm", default="light", choices=sorted(claims_mod.ARMS))
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--no-serial", action="store_true", help="no serial run first (the "
                    "workers then load the kernels the main process has not)")
    ap.add_argument("--verbose", action="store_true", help="every event of this process")
    args = ap.parse_args()
    arm = manipcad.load_robot("cylindrical")
    claims_mod.claims_cell(speed_scale=1.0, load_ratio=claims_mod.own_load_ratio(arm),
                           arm=arm, dt=1e-4)
    _patch()
    print(f"load average {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for w in ((args.workers,) if args.no_serial else (1, args.workers)):
                print(f"round {r}, workers={w}:")
                t_call, c_call, k_call = time.time(), time.process_time(), _children()
                claims_mod.run_claims(Path(tmp) / f"r{r}w{w}", arm=args.arm, grid=args.grid,
                                      workers=w, progress=False)
                wall = time.time() - t_call
                main_cpu, kids = time.process_time() - c_call, _children() - k_call
                print(f"  CPU: this process {main_cpu:.2f} s, its children (ended) {kids:.2f} s, "
                      f"sum {main_cpu + kids:.2f} s")
                _report(t_call, wall, os.getpid(), args.verbose)
    print(f"load average {os.getloadavg()}")


if __name__ == "__main__":
    main()
