"""Benchmark: ``manipcad design`` on a 6-joint arm, on 1 and on N Dask workers.

Usage::

    python benchmarks/bench_design.py [--workers N] [--rounds R] [--samples S]
                                      [--payloads LO,HI] [--methods M]

The case: the UR5 example without its payload (``examples/ur5/ur5_unloaded.yaml``), its
4.2 s pick cycle, accuracy 1e-3 rad on every joint, payloads 0, 0.5 and 1 kg, ±5 %
uncertainty with 5 samples, the rules' first 4 methods: 3 × 5 × 4 = 60 verification
runs, then the chosen design's 15 runs again with their time series, stored. Each
round is a fresh process: one untimed warm-up (the kernels loaded from their cache, as
a session that has run something has them), then ``run_design`` into a fresh folder
(no cache) with ``workers=1`` (serial, in the process), then with ``workers=N`` (a
local Dask cluster, its start inside the time). Printed per round and as the minimum
over the rounds (another session's load on a shared machine only slows a run): the
whole call's wall time, the sweep's (the verification runs: ``stage_wall_s["sweep"]``
of design.json) and the speed-ups; and whether both designs are the same (methods and
worst-case errors).
"""

from __future__ import annotations

import argparse
import json
import subprocess
import sys
import tempfile
import time
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
CASE = {"requirements": str(ROOT / "examples/ur5/requirements.yaml"),
        "robot": str(ROOT / "examples/ur5/ur5_unloaded.yaml"),
        "trajectories": [str(ROOT / "examples/ur5/pick.yaml")]}


def one_round(workers: int, samples: int, payloads: tuple[float, float], methods: int) -> dict:
    """One round in this process: warm-up, then 1 worker, then ``workers``."""
    import warnings

    from manipcad.design import run_design
    from manipcad.errors import ManipcadWarning

    warnings.simplefilter("ignore", ManipcadWarning)
    kw = dict(payload_range=payloads, uncertainty=0.05, samples=samples, max_methods=methods)
    with tempfile.TemporaryDirectory() as tmp:
        # warm-up: the kernels, python-control, the rules (not timed)
        run_design(CASE["requirements"], CASE["robot"], CASE["trajectories"],
                   out=Path(tmp) / "warm", workers=1, payload_range=(0.0, 0.0),
                   max_methods=1, store_runs=False)
        out = {}
        for w in (1, workers):
            t0 = time.perf_counter()
            doc = run_design(CASE["requirements"], CASE["robot"], CASE["trajectories"],
                             out=Path(tmp) / f"w{w}", workers=w, **kw)
            wall = time.perf_counter() - t0
            out[w] = {"wall": wall, "sweep": doc["executor"]["stage_wall_s"].get("sweep"),
                      "runs": doc["executor"]["runs_computed"], "methods": doc["methods"],
                      "worst": doc["worst_case_error"]}
    return out


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--workers", type=int, default=2)
    ap.add_argument("--rounds", type=int, default=1)
    ap.add_argument("--samples", type=int, default=5)
    ap.add_argument("--payloads", default="0,1")
    ap.add_argument("--methods", type=int, default=4)
    ap.add_argument("--_child", action="store_true", help=argparse.SUPPRESS)
    a = ap.parse_args()
    lo, hi = (float(x) for x in a.payloads.split(","))
    if a._child:
        print(json.dumps(one_round(a.workers, a.samples, (lo, hi), a.methods)))
        return
    rounds = []
    for r in range(a.rounds):
        p = subprocess.run([sys.executable, __file__, "--_child", "--workers", str(a.workers),
                            "--samples", str(a.samples), "--payloads", a.payloads,
                            "--methods", str(a.methods)], capture_output=True, text=True,
                           check=True)
        res = {int(k): v for k, v in json.loads(p.stdout.strip().splitlines()[-1]).items()}
        rounds.append(res)
        one, many = res[1], res[a.workers]
        same = one["methods"] == many["methods"] and one["worst"] == many["worst"]
        print(f"round {r + 1}: {one['runs']} runs; 1 worker {one['wall']:.1f} s (sweep "
              f"{one['sweep']:.1f} s), {a.workers} workers {many['wall']:.1f} s (sweep "
              f"{many['sweep']:.1f} s): whole {one['wall'] / many['wall']:.2f}x, sweep "
              f"{one['sweep'] / many['sweep']:.2f}x; same design: {same}", flush=True)
    best = {w: {k: min(r[w][k] for r in rounds) for k in ("wall", "sweep")}
            for w in (1, a.workers)}
    print(f"min over {a.rounds} round(s): 1 worker {best[1]['wall']:.1f} s (sweep "
          f"{best[1]['sweep']:.1f} s); {a.workers} workers {best[a.workers]['wall']:.1f} s "
          f"(sweep {best[a.workers]['sweep']:.1f} s); speed-up whole "
          f"{best[1]['wall'] / best[a.workers]['wall']:.2f}x, sweep "
          f"{best[1]['sweep'] / best[a.workers]['sweep']:.2f}x")
    print(f"methods: {rounds[-1][1]['methods']}")


if __name__ == "__main__":
    main()
