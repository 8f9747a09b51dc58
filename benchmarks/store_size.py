"""Benchmark: disk size of a stored simulation result, the old format against the new.

Usage::

    python benchmarks/store_size.py [--t-end 3] [--json out.json]

One closed-loop run of the catalog PUMA 560 (6 joints, DC drives) under the
example PID regulators (examples/pid_puma.yaml, sampled at 1 kHz), RK4 step
dt = 1e-4 s, along a quintic move of every joint; then the result is stored:

* old: what ``manipcad simulate`` wrote before (every step; an uncompressed
  npz and a CSV of the same arrays), emulated with ``np.savez`` + ``write_csv``;
* new, every step: ``save_result(..., csv=False)``, float64 compressed npz;
* new, at the regulator period: the same run recorded every
  ``every_for(dt, periods)`` steps (here 10), as ``--record-every``
  or the default of a workspace run would.

Sizes are bytes of the folders' files (metrics.json, inputs and errors.png
included); the per-joint-second figure divides the time-series files by the
joints and the simulated seconds.
"""

from __future__ import annotations

import argparse
import json
import tempfile
import warnings
from pathlib import Path

import numpy as np


def folder_size(path: Path) -> int:
    return sum(p.stat().st_size for p in path.rglob("*") if p.is_file())


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--t-end", type=float, default=3.0, help="simulated time, s")
    ap.add_argument("--json", type=Path, default=None)
    args = ap.parse_args()

    import manipcad
    from manipcad.control import load_regulators
    from manipcad.errors import ManipcadWarning
    from manipcad.sim import simulate
    from manipcad.store.results import every_for, result_arrays, save_result, write_csv
    from manipcad.trajectories import quintic

    root = Path(__file__).resolve().parents[1]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        arm = manipcad.load_robot("puma560")
    dt = 1e-4
    regs = load_regulators(root / "examples" / "pid_puma.yaml", arm, dt=dt)
    q0 = np.array([0.0, 0.5, -0.5, 0.0, 0.3, 0.0])
    traj = quintic(q0, q0 + 0.3, args.t_end)
    every = every_for(dt, [r.period for r in regs])
    out: dict[str, float] = {"t_end_s": args.t_end, "dt_s": dt, "joints": arm.n,
                             "every": every}
    with tempfile.TemporaryDirectory() as d:
        tmp = Path(d)
        full = simulate(arm, t_end=args.t_end, dt=dt, trajectory=traj, regulators=regs)
        kept = simulate(arm, t_end=args.t_end, dt=dt, trajectory=traj, regulators=regs,
                        every=every)
        old = tmp / "old"
        save_result(full, old, joint_types=arm.joint_types, csv=False)
        (old / "timeseries.npz").unlink()
        np.savez(old / "timeseries.npz", joint_names=np.array(arm.joint_names),
                 **result_arrays(full))
        write_csv(full, old / "timeseries.csv", joint_types=arm.joint_types)
        new_all = save_result(full, tmp / "new_all", joint_types=arm.joint_types, csv=False)
        new_kept = save_result(kept, tmp / "new_kept", joint_types=arm.joint_types, csv=False)
        for key, folder in (("old", old), ("new_every_step", new_all),
                            ("new_regulator_period", new_kept)):
            out[f"{key}_bytes"] = folder_size(folder)
            series = sum((folder / f).stat().st_size for f in ("timeseries.npz",
                                                               "timeseries.csv")
                         if (folder / f).exists())
            out[f"{key}_series_bytes_per_joint_second"] = series / arm.n / args.t_end
        out["samples_every_step"] = len(full.t)
        out["samples_regulator_period"] = len(kept.t)
        same = np.array_equal(full.q[::every], kept.q)
        out["kept_samples_equal_every_step_run"] = bool(same)
    for k, v in out.items():
        print(f"{k:48s} {v:,.6g}" if isinstance(v, float) else f"{k:48s} {v}")
    if args.json:
        args.json.write_text(json.dumps(out, indent=2))


if __name__ == "__main__":
    main()
