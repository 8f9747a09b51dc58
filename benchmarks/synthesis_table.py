"""The table of docs/synthesis.md: every method on the Fig. 2 arm's turning drive under laws (2).

Usage: ``python benchmarks/synthesis_table.py`` (about a minute). The turn is driven by
the method (period 0.1 ms), the lift by a PID and the reach by an LQR, along
q1 = 0.5(1 − cos 4t), q3 = 0.25(1 − cos 16t) for 1.6 s at dt = 0.1 ms; max and RMS of
the turn's error (rad), the largest |U| (V), and the realization complexity counted
from each law's code (numbers stored, operations per period, signals).
"""

from __future__ import annotations

import numpy as np

import manipcad
from manipcad.control import realization_complexity
from manipcad.trajectories import cosine

CASES = [
    ("none (P at the largest load)", "none", {}),
    ("none_sce, no feed-forward (the PD alone)", "none_sce", {"feedforward": False}),
    ("none_sce (the SCE alone, no corrector)", "none_sce", {}),
    ("pid", "pid", {}),
    ("ace_tf, no feed-forward", "ace_tf", {"feedforward": False}),
    ("ace_de, no feed-forward", "ace_de", {"feedforward": False}),
    ("ace_tf (observable)", "ace_tf", {}),
    ("ace_tf, controllable", "ace_tf", {"realization": "controllable"}),
    ("ace_de", "ace_de", {}),
    ("asvs", "asvs", {}),
    ("vss", "vss", {}),
    ("lqr", "lqr", {}),
    ("lqr_gs", "lqr_gs", {}),
    ("lqr_gs, load_torque=False", "lqr_gs", {"load_torque": False}),
    ("computed_torque", "computed_torque", {}),
]


def main() -> None:
    dt = 1e-4
    arm = manipcad.load_robot("cylindrical")
    others = [manipcad.synthesize(arm, "lift", "pid", period=dt),
              manipcad.synthesize(arm, "reach", "lqr", period=dt)]
    traj = cosine([0.5, 0.0, 0.25], [4.0, 0.0, 16.0], duration=1.6)
    print("| method | max | RMS | max U, V | numbers stored | ops/period | signals |")
    print("|---|---|---|---|---|---|---|")
    for label, method, opts in CASES:
        reg = manipcad.synthesize(arm, "turn", method, period=dt, **opts)
        res = manipcad.simulate(arm, t_end=1.6, dt=dt, trajectory=traj,
                                regulators=[reg, *others])
        e = res.error[:, 0]
        c = realization_complexity(reg)
        print(f"| {label} | {np.abs(e).max():.3g} | {np.sqrt(np.mean(e * e)):.3g} | "
              f"{np.abs(res.u[:, 0]).max():.3g} | {c['gains_stored']} | "
              f"{c['ops_per_period']} | {len(c['signals'])} |")


if __name__ == "__main__":
    main()
