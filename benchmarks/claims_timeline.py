"""Timeline of one claims-maps run: where the wall time of ``run_claims`` goes, per process.

Usage::

    python benchmarks/claims_timeline.py [--grid quick|full] [--workers N] [--arm A]
                                         [--rounds R]

Runs ``manipcad.study.claims.run_claims`` into fresh folders (after one warm-up cell that
loads the kernels in this process, as ``bench_parallel.py`` does), serially and on N
workers, and logs, with the wall clock (s after the call) and the process's CPU time:

- in this process: the pool's start (the cluster forked), the client ready (the
  workers warmed), every ``run_tasks`` call (the rows' sizing, the cells, the figure's
  panels), every cell's planning, the files (claims.json, the PNG, report.html);
- on the workers (forked after the patches, so they run the logging wrappers):
  the warm-up, each row's sizing, each closed-loop run, each group of panels.

Prints per round a table of phases (start, end, CPU) and per worker its busy time and
idle gaps; the workers' tasks are logged to a file (O_APPEND, one line each).
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
    report_mod.save_panels = _logged("save_panels", report_mod.save_panels)
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


def _report(t_call: float, wall: float, main_pid: int) -> None:
    ev = [json.loads(s) for s in LOG.read_text().splitlines()]
    LOG.unlink()
    ev = [e for e in ev if e["t1"] >= t_call]
    by_pid = defaultdict(list)
    for e in ev:
        by_pid[e["pid"]].append(e)
    print(f"  end to end {wall:.2f} s")
    for pid in sorted(by_pid, key=lambda p: (p != main_pid, p)):
        es = sorted(by_pid[pid], key=lambda e: e["t0"])
        who = "main" if pid == main_pid else f"worker {pid}"
        if pid == main_pid:
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
    ap.add_argument("--serial", action="store_true", help="also time the serial run")
    args = ap.parse_args()
    arm = manipcad.load_robot("cylindrical")
    claims_mod.claims_cell(speed_scale=1.0, load_ratio=claims_mod.own_load_ratio(arm),
                           arm=arm, dt=1e-4)
    _patch()
    print(f"load average {os.getloadavg()}")
    with tempfile.TemporaryDirectory() as tmp:
        for r in range(args.rounds):
            for w in ((1, args.workers) if args.serial else (args.workers,)):
                print(f"round {r}, workers={w}:")
                t_call, c_call, k_call = time.time(), time.process_time(), _children()
                claims_mod.run_claims(Path(tmp) / f"r{r}w{w}", arm=args.arm, grid=args.grid,
                                      workers=w, progress=False)
                wall = time.time() - t_call
                main_cpu, kids = time.process_time() - c_call, _children() - k_call
                print(f"  CPU: this process {main_cpu:.2f} s, the workers (ended) {kids:.2f} s, "
                      f"sum {main_cpu + kids:.2f} s")
                _report(t_call, wall, os.getpid())
    print(f"load average {os.getloadavg()}")


if __name__ == "__main__":
    main()
