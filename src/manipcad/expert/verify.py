"""Verify a regulator's promise against the coupled simulation.

A regulator synthesized for an accuracy (``spec={"max_error": ...}`` with a reference:
``ace_de``, ``ace_tf``) promises the error its *nominal* loop reaches on that reference
(``design["nominal_max_error"]``). The nominal loop is one drive at one load; the robot
adds the inertial coupling Σ_{k≠i} H_ik·q̈_k, which a decentralized law does not see, the
velocity and gravity torques, friction and the amplifier limit. :func:`verify` simulates
the whole robot along the trajectory with the regulators and compares: a promise missed by
more than ``factor`` (default 2) is reported as missed, with the coupling share of that
joint along the trajectory (:func:`manipcad.analysis.coupling.coupling_analysis`) as the
first suspect.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass

import numpy as np

from manipcad.errors import ManipcadError, ManipcadWarning


@dataclass
class PromiseCheck:
    """One regulator's promise against the simulation.

    Attributes:
        joint, method: the joint's name and the regulator's method.
        promised: the max |e| its nominal loop reaches on the reference, rad or m
            (None: the regulator promised nothing).
        asked: the accuracy asked at synthesis, rad or m (None: none).
        simulated: max |e| of the joint in the coupled simulation, rad or m.
        ratio: simulated / promised (None without a promise).
        coupling_share: peak of the inertial coupling Σ_{k≠i} H_ik·q̈_k over the peak of
            the joint's own inertial torque H_ii·q̈_i along the trajectory.
        kept: True when simulated <= factor·promised (None without a promise).
        why: in words.
    """

    joint: str
    method: str
    promised: float | None
    asked: float | None
    simulated: float
    ratio: float | None
    coupling_share: float
    kept: bool | None
    why: str


def verify(robot, trajectory, regulators, *, dt: float = 1e-4, factor: float = 2.0,
           t_end: float | None = None) -> tuple[list[PromiseCheck], object]:
    """Simulate the robot with the regulators along the trajectory; check each promise.

    Args:
        robot: the robot (with drives).
        trajectory: the reference (a trajectory object).
        regulators: the regulators (joints without one get U = 0).
        dt: integration step, s.
        factor: a promise is missed when the simulation's error exceeds it this many times.
        t_end: simulated time, s (default the trajectory's duration).

    Returns:
        (one :class:`PromiseCheck` per regulator joint, the simulation result).

    Warns:
        ManipcadWarning: for each promise missed, with the coupling share.

    Example:
        >>> import manipcad
        >>> from manipcad.expert.verify import verify
        >>> arm = manipcad.load_robot("cylindrical")
        >>> laws = manipcad.load_trajectory("examples/fig3_laws.yaml")
        >>> reg = manipcad.synthesize(arm, "turn", "ace_de", spec={"max_error": 1e-3},
        ...                           reference=laws)
        >>> checks, _ = verify(arm, laws, [reg, manipcad.synthesize(arm, ["lift", "reach"],
        ...                    "lqr")], t_end=0.4)
        >>> checks[0].kept
        True
    """
    from manipcad.analysis.coupling import coupling_analysis
    from manipcad.sim import simulate

    if not (math.isfinite(factor) and factor >= 1):
        raise ManipcadError(f"factor must be >= 1, got {factor}")
    t_end = float(trajectory.duration) if t_end is None else float(t_end)
    res = simulate(robot, t_end=t_end, dt=dt, trajectory=trajectory, regulators=regulators)
    report = coupling_analysis(robot, trajectory, dt=max(dt, 1e-3))
    share = {jc.joint: jc.coupling_ratio for jc in report.joints}
    flat = []
    for r in regulators:
        flat += r if isinstance(r, list) else [r]
    out = []
    for reg in flat:
        promised = reg.design.get("nominal_max_error")
        asked = reg.design.get("max_error")
        for j in reg.joints:
            j = robot.joint_index(j)
            name = robot.joint_names[j]
            e = float(np.abs(res.error[:, j]).max())
            c = float(share.get(name, math.nan))
            if promised is None:
                out.append(PromiseCheck(name, reg.method, None, asked, e, None, c, None,
                                        "no promise (synthesized without max_error)"))
                continue
            ratio = e / promised
            kept = ratio <= factor
            why = (f"kept: {e:.3g} against {promised:.3g} promised" if kept else
                   f"missed ×{ratio:.3g}: {e:.3g} against {promised:.3g} promised by the "
                   f"nominal loop; the inertial coupling Σ H_ik·q̈_k is {100 * c:.0f} % of "
                   f"the joint's own inertial torque along the trajectory, and the "
                   f"decentralized law does not see it"
                   + ("" if c >= 0.1 else " (small here: look at friction, the amplifier "
                      "limit, the other joints' regulators)"))
            if not kept:
                warnings.warn(f"{robot.name}: {name} ({reg.method}): {why}", ManipcadWarning,
                              stacklevel=2)
            out.append(PromiseCheck(name, reg.method, float(promised), asked, e, ratio, c,
                                    kept, why))
    return out, res
