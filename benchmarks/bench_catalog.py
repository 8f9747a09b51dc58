"""Benchmark: the parts library's index (docs/catalog.md), build against cached lookups.

Usage::

    python benchmarks/bench_catalog.py [--rounds R] [--json out.json]

What is timed (``time.perf_counter``, wall clock, each case in a fresh process so
that no in-memory cache helps):

* build: the tables from the data files (``manipcad.catalog.library.build``: every
  MGDB CSV, the YAML data files, the part files, the compatibility tables);
* first lookup, cache cold: ``motors()`` with an empty cache folder (builds and
  writes the pickle);
* first lookup, cache warm: ``motors()`` in a new process with the pickle present;
* filter: ``motors(where="k_t > 0.1 and mass < 1")`` after the first lookup;
* pairs: ``compatible_pairs()`` over the whole library (tables + adapter rule).

The table shows the minimum over rounds and (in brackets) the median, seconds.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

CASE = r"""
import time, json, sys
t0 = time.perf_counter()
import manipcad.catalog as c
from manipcad.catalog import library
t1 = time.perf_counter()
out = {}
if sys.argv[1] == "build":
    t = time.perf_counter(); library.build(); out["build"] = time.perf_counter() - t
else:
    t = time.perf_counter(); c.motors(); out["first"] = time.perf_counter() - t
    t = time.perf_counter(); c.motors(where="k_t > 0.1 and mass < 1")
    out["filter"] = time.perf_counter() - t
    t = time.perf_counter(); c.compatible_pairs(); out["pairs"] = time.perf_counter() - t
print(json.dumps(out))
"""


def run(case: str, cache: str) -> dict[str, float]:
    env = dict(os.environ, XDG_CACHE_HOME=cache)
    res = subprocess.run([sys.executable, "-c", CASE, case], env=env, check=True,
                         capture_output=True, text=True)
    return json.loads(res.stdout.strip().splitlines()[-1])


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--rounds", type=int, default=3)
    ap.add_argument("--json", default=None)
    args = ap.parse_args()
    times: dict[str, list[float]] = {}
    for _ in range(args.rounds):
        with tempfile.TemporaryDirectory() as cache:
            times.setdefault("build", []).append(run("build", cache)["build"])
            cold = run("lookup", cache)
            times.setdefault("first lookup, cache cold", []).append(cold["first"])
            warm = run("lookup", cache)
            times.setdefault("first lookup, cache warm", []).append(warm["first"])
            times.setdefault("filter (where)", []).append(warm["filter"])
            times.setdefault("compatible_pairs()", []).append(warm["pairs"])
    print(f"{'case':<28} {'min s':>8} {'(median)':>10}")
    for k, v in times.items():
        print(f"{k:<28} {min(v):>8.3f} ({statistics.median(v):.3f})")
    if args.json:
        with open(args.json, "w", encoding="utf-8") as f:
            json.dump(times, f, indent=1)


if __name__ == "__main__":
    main()
