"""A promised accuracy against the coupled simulation (issue: no confident wrong answer)."""

from __future__ import annotations

from pathlib import Path

import pytest

import manipcad
from manipcad.errors import ManipcadWarning
from manipcad.expert.verify import verify

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


def test_promise_kept_on_the_fig2_turn():
    arm = manipcad.load_robot("cylindrical")
    laws = manipcad.load_trajectory(EXAMPLES / "fig3_laws.yaml")
    reg = manipcad.synthesize(arm, "turn", "ace_de", spec={"max_error": 1e-3}, reference=laws)
    assert "promise: max |e| <=" in reg.describe()
    others = manipcad.synthesize(arm, ["lift", "reach"], "lqr")
    checks, _ = verify(arm, laws, [reg, others], t_end=0.5)
    turn = checks[0]
    assert turn.kept is True and turn.simulated <= 2 * turn.promised
    assert [c.promised for c in checks[1:]] == [None, None]


@pytest.mark.slow
def test_promise_missed_on_the_panda_names_the_coupling():
    """Law (3) on Panda joint 3 promises 8.2e-6 rad (its nominal loop); the coupled arm
    gives about 1e-3 (measured over the first 1.5 s of the pick cycle), with an inertial
    coupling of ~200 % of the joint's own inertial torque: missed, warned, and why."""
    arm = manipcad.load_robot(EXAMPLES / "panda" / "panda.yaml")
    traj = manipcad.load_trajectory(EXAMPLES / "panda" / "pick.yaml", robot=arm)
    regs = [manipcad.synthesize(arm, j, "ace_de", spec={"max_error": 1e-4}, reference=traj,
                                period=1e-3) if j == 2
            else manipcad.synthesize(arm, j, "lqr", period=1e-3) for j in range(arm.n)]
    with pytest.warns(ManipcadWarning, match="panda_joint3 .ace_de.: missed"):
        checks, _ = verify(arm, traj, regs, t_end=1.5)
    j3 = checks[2]
    assert j3.kept is False and j3.ratio > 10 and j3.coupling_share > 1.0
    assert "inertial coupling" in j3.why
