"""Regulators that model the gear's losses against the same laws assuming none (η = 1).

Usage: ``python benchmarks/gear_losses.py [fig3|puma|ur5 ...] [METHOD ...]`` (default all
three cases and every method below; about 6 minutes; a METHOD is a label of
:data:`METHOD_CASES`, e.g. ``"ace_tf controllable"``). Each method is synthesized as it
is (its law models the gear efficiency η of the drive, as the simulated plant applies
it) and run again with its stored η set to 1 (the same law with no gear losses; the
design-time uses of η, ace_tf's T_1 and lqr_gs's table range, stay), on:

- ``fig3``: the Fig. 2 arm on its own gears (η 0.75 / 0.81 / 0.95), the turn by the method,
  the lift and the reach by ``pid`` (as ``recommend --verify``), laws (2) for 1.6 s, dt and
  period 0.1 ms, accuracy 1e-4 rad (the Fig. 3 case of docs/synthesis.md);
- ``puma``: the PUMA 560 with its drives (their efficiency is 1: the two runs must agree),
  every joint by the method, examples/waypoints_puma.yaml for 2 s, dt 0.1 ms, period 1 ms;
- ``ur5``: the UR5 example (CSG gears, η = 0.725 assumed), every joint by the method,
  examples/ur5/pick.yaml for 2 s, dt 0.1 ms, period 1 ms.

Prints per method and η: the largest |e| over the joints the method drives (rad), its RMS,
and the run checks' verdict over those joints with the failing checks (docs/checks.md).
"""

from __future__ import annotations

import dataclasses
import sys
import warnings

import numpy as np

import manipcad
from manipcad.control import METHODS
from manipcad.errors import ManipcadError
from manipcad.sim.checks import run_checks

#: (label, method, synthesis options)
METHOD_CASES = [("ace_de", "ace_de", {}), ("ace_tf", "ace_tf", {}),
                ("ace_tf controllable", "ace_tf", {"realization": "controllable"}),
                ("asvs", "asvs", {}), ("lqr_gs", "lqr_gs", {}),
                ("computed_torque", "computed_torque", {}),
                ("computed_torque_full", "computed_torque_full", {})]


def without_losses(reg):
    """The same regulator with its stored gear efficiency(ies) set to 1."""
    m = METHODS[reg.method]
    p = np.array(reg.params, dtype=float)
    if "gear_efficiency" in m.fields:
        p[m.fields["gear_efficiency"]] = 1.0
    if "gear_efficiency" in m.joint_fields:
        i0 = m.joint_fields["gear_efficiency"]
        p[i0:i0 + len(reg.joints)] = 1.0
    return dataclasses.replace(reg, params=p)


def row(label, robot, res, joints, accuracy):
    names = [robot.joint_names[j] for j in joints]
    e = res.error[:, joints]
    checks = run_checks(res, robot, accuracy={n: accuracy for n in names})
    fails = [f"{j}: {k} {c.value:.3g} of {c.limit:.3g} {c.unit}"
             for j, k, c in checks.failures() if j in names]
    verdict = ("fail" if fails else
               "unknown" if any(j in names for j, _, _ in checks.failures("unknown")) else "pass")
    print(f"| {label} | {np.abs(e).max():.3g} | {np.sqrt(np.mean(e * e)):.3g} | {verdict} | "
          f"{'; '.join(fails) or '-'} |", flush=True)


def fig3(cases):
    dt = 1e-4
    arm = manipcad.load_robot("cylindrical")
    laws = manipcad.load_trajectory("examples/fig3_laws.yaml", robot=arm)
    others = [manipcad.synthesize(arm, j, "pid", period=dt) for j in ("lift", "reach")]
    print("\nFig. 3 case, Fig. 2 arm on its gears (turn: η = 0.75)")
    print("| method, law's η | max abs(e), rad | RMS, rad | checks (turn) | failing |")
    print("|---|---|---|---|---|")
    for name, m, opts in cases:
        reg = (manipcad.synthesize(arm, "all", m, period=dt) if METHODS[m].spans
               else manipcad.synthesize(arm, "turn", m, period=dt, **opts))
        for label, r in ((f"{name}, η as the drive", reg),
                         (f"{name}, η = 1", without_losses(reg))):
            regs = [r] if METHODS[m].spans else [r, *others]
            res = manipcad.simulate(arm, t_end=laws.duration, dt=dt, trajectory=laws,
                                    regulators=regs)
            row(label, arm, res, [0], 1e-4)


def whole_arm(title, robot, traj, t_end, accuracy, cases):
    dt, period = 1e-4, 1e-3
    print(f"\n{title}")
    print("| method, law's η | max abs(e), rad | RMS, rad | checks (all joints) | failing |")
    print("|---|---|---|---|---|")
    for name, m, opts in cases:
        regs = ([manipcad.synthesize(robot, "all", m, period=period)] if METHODS[m].spans
                else [manipcad.synthesize(robot, j, m, period=period, **opts)
                      for j in range(robot.n)])
        for label, rs in ((f"{name}, η as the drive", regs),
                          (f"{name}, η = 1", [without_losses(r) for r in regs])):
            try:
                res = manipcad.simulate(robot, t_end=t_end, dt=dt, trajectory=traj,
                                        regulators=rs)
            except ManipcadError as exc:
                print(f"| {label} | - | - | - | {exc} |")
                continue
            row(label, robot, res, list(range(robot.n)), accuracy)


def main() -> None:
    warnings.simplefilter("ignore")
    args = sys.argv[1:]
    which = [a for a in args if a in ("fig3", "puma", "ur5")] or ["fig3", "puma", "ur5"]
    cases = [c for c in METHOD_CASES if c[0] in args] or METHOD_CASES
    if "fig3" in which:
        fig3(cases)
    if "puma" in which:
        puma = manipcad.load_robot("puma560")
        whole_arm("PUMA 560 with its drives (η = 1), examples/waypoints_puma.yaml, 2 s", puma,
                  manipcad.load_trajectory("examples/waypoints_puma.yaml", robot=puma), 2.0,
                  1e-3, cases)
    if "ur5" in which:
        ur5 = manipcad.load_robot("examples/ur5/ur5.yaml")
        whole_arm("UR5 example (η = 0.725), examples/ur5/pick.yaml, 2 s", ur5,
                  manipcad.load_trajectory("examples/ur5/pick.yaml", robot=ur5), 2.0, 1e-3,
                  cases)


if __name__ == "__main__":
    main()
