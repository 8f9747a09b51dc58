"""Benchmark: the workspace index with many results (one run).

Usage::

    python benchmarks/workspace_index.py [--results 200]

Stores N small results (50 samples, 6 joints, no plot) with
``Workspace.store_result`` into a new workspace, then times ``list()`` of all
items and a ``--where`` filter on the largest error and one joint's peak
torque (wall clock, ``time.perf_counter``). Checks the filter's count
against the closed form of the data (result i has max error 1e-3·(i+1) rad
and torque i N·m).
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--results", type=int, default=200)
    args = ap.parse_args()

    from manipcad.sim.simulate import SimulationResult
    from manipcad.workspace import Workspace

    with tempfile.TemporaryDirectory() as d:
        ws = Workspace.init(Path(d) / "ws")
        k, n = 50, 6
        z = np.zeros((k, n))
        names = tuple(f"j{j}" for j in range(n))
        t0 = time.perf_counter()
        for i in range(args.results):
            r = SimulationResult(
                t=np.linspace(0.0, 1.0, k), q=z, qd=z, q_ref=z + 1e-3 * (i + 1), qd_ref=z,
                u=z, current=z, tau=z + i, joint_names=names, settings={"dt": 1e-3},
                metrics={j: {"max_error": 1e-3 * (i + 1)} for j in names})
            ws.store_result(r, name=f"r{i}", plot=False, run={"t_end": 1.0, "dt": 1e-3})
        t1 = time.perf_counter()
        items = ws.list()
        t2 = time.perf_counter()
        sel = ws.list(where="max_error<0.05 and peak_torque[j3]>=10")
        t3 = time.perf_counter()
        expected = len([i for i in range(args.results) if i + 1 < 50 and i >= 10])
        assert len(items) == args.results and len(sel) == expected, (len(sel), expected)
        ws.close()
    print(f"results stored             {args.results}")
    print(f"store_result, per result   {(t1 - t0) / args.results * 1e3:.1f} ms")
    print(f"list() of all              {(t2 - t1) * 1e3:.1f} ms")
    print(f"list(where=...)            {(t3 - t2) * 1e3:.1f} ms ({len(sel)} items)")


if __name__ == "__main__":
    main()
