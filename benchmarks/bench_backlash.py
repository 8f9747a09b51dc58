"""Benchmark: convergence of the simulator on an elastic gear with backlash.

Usage::

    python benchmarks/bench_backlash.py [--ref-dt 2.5e-6] [--friction] [--adaptive]

The job: one revolute joint about the vertical axis (link 0.05 kg·m²) driven through an
elastic gear with backlash (k_s 2000 N·m/rad, d_s 0.5 N·m·s/rad, half-gap b 2 mrad, joint
side; i_r 10, rotor 1e-4 kg·m², armature L 1 mH) by a PD at 1 kHz on the joint's
position, following q* = 0.05·(1 − cos 10πt) for 0.4 s (four reversals), then holding
to 0.5 s. The teeth cross the gap at every reversal (``result.events``: 10 + the contact
mode). With ``--friction`` the motor shaft has dry friction M_f = (0.02, 0.03) N·m and
static friction M_s = (0.03, 0.04) N·m: it sticks at the reversals too (20 + its mode).

Printed: fixed-step RK4 at dt = 1e-4, 5e-5, 2.5e-5 s against RK4 at ``--ref-dt`` (the
reference): max |Δq| and max |Δθ_m/i_r| over the kept samples (every 1 ms), the ratio of
successive errors (4th order: 16) and the switches located; with ``--adaptive`` the
error-controlled integrators (rtol 1e-8, atol 1e-10, grid dt 1e-4) against the same
reference, their steps and right-hand sides.
"""

from __future__ import annotations

import argparse
import os

import numpy as np

from manipcad.control import pid
from manipcad.drives.params import Transmission
from manipcad.model.robot import Drive, Robot
from manipcad.sim import simulate
from manipcad.trajectories import cosine

GEAR = Transmission(2000.0, 0.5, 2e-3)
KP, KD, PERIOD = 40.0, 0.4, 1e-3
T_END, KEEP = 0.5, 1e-3


def robot(friction: bool) -> Robot:
    """The one-joint robot, with the motor's dry and static friction or without."""
    d = Drive(J=1e-4, ratio=10.0, R=1.0, L=1e-3, k_m=0.1, k_w=0.1, k_u=1.0,
              M_f=(0.02, 0.03) if friction else 0.0,
              M_s=(0.03, 0.04) if friction else None)
    return Robot.from_arrays("one", ["revolute"], [-1], np.eye(3)[None], np.zeros((1, 3)),
                             [1.0], np.zeros((1, 3)), np.diag([0.01, 0.01, 0.05])[None],
                             drives=[d])


def job(arm: Robot, dt: float, integrator: str = "rk4", **kw):
    """The run: (t, q, θ_m/i_r of the kept samples, result)."""
    res = simulate(arm, t_end=T_END, dt=dt, trajectory=cosine(0.05, 10 * np.pi, 0.4),
                   regulators=[pid(0, kp=KP, kd=KD, period=PERIOD)], transmissions=[GEAR],
                   every=max(1, int(round(KEEP / dt))), integrator=integrator, **kw)
    return res


def switches(res) -> int:
    """The located switches (0 without the event machinery)."""
    return 0 if res.events is None else len(res.events)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--ref-dt", type=float, default=2.5e-6)
    ap.add_argument("--friction", action="store_true")
    ap.add_argument("--adaptive", action="store_true")
    a = ap.parse_args()
    arm = robot(a.friction)
    ref = job(arm, a.ref_dt)
    print(f"reference: RK4 dt {a.ref_dt:g} s, {switches(ref)} switches "
          f"(load average {os.getloadavg()[0]:.2f})")
    print("\nfixed-step RK4 against the reference")
    print(f"{'dt s':>9} {'max |dq| rad':>13} {'ratio':>7} {'switches':>9}")
    prev = None
    for dt in (1e-4, 5e-5, 2.5e-5):
        res = job(arm, dt)
        err = np.abs(res.q - ref.q).max()
        ratio = "" if prev is None else f"{prev / err:7.1f}"
        print(f"{dt:9.2g} {err:13.3g} {ratio:>7} {switches(res):9d}")
        prev = err
    if a.adaptive:
        print("\nerror-controlled (rtol 1e-8, atol 1e-10, grid dt 1e-4)")
        print(f"{'integrator':>20} {'max |dq| rad':>13} {'steps':>7} {'rhs':>7} {'switches':>9}")
        for integ in ("adaptive", "adaptive-exact"):
            res = job(arm, 1e-4, integ, rtol=1e-8, atol=1e-10)
            err = np.abs(res.q - ref.q).max()
            print(f"{integ:>20} {err:13.3g} {res.settings['steps']:7d} "
                  f"{res.settings['rhs_evaluations']:7d} {switches(res):9d}")


if __name__ == "__main__":
    main()
