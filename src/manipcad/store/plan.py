"""A simulation run set up from its files: the one set of checks `manipcad simulate` and the
web application's Simulation page make before a run.

:func:`plan_run` takes the loaded robot and trajectory and the regulator files, checks that
they fit together and that the numbers are physical, and gives what :func:`manipcad.simulate`
needs beyond them: the regulators, the run's end time and the record stride (one stored
sample per regulator period, :func:`manipcad.store.results.every_for`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path

from manipcad.control.files import load_regulators
from manipcad.errors import InputError
from manipcad.sim.closed_loop import period_too_long
from manipcad.store.results import every_for

#: how the run's numbers are named in messages: Python's keywords by default; the CLI
#: passes its option names ({"dt": "--dt", "t_end": "--t-end", "every": "--every"})
NAMES = {"dt": "dt", "t_end": "t_end", "every": "every", "drives": "drives=False"}


@dataclass(frozen=True)
class RunPlan:
    """What a run needs beyond the robot and the trajectory.

    Attributes:
        regulators: the loaded regulators, in file order.
        t_end: end time, s (the trajectory's duration unless given).
        dt: integration step, s.
        every: record stride, steps between stored samples (>= 1).
    """

    regulators: list
    t_end: float
    dt: float
    every: int


def check_numbers(dt: float, t_end: float | None = None, every: int | None = None,
                  names: Mapping[str, str] = NAMES) -> None:
    """Check a run's step, end time and record stride before anything is loaded.

    Args:
        dt: integration step, s (finite, > 0).
        t_end: end time, s (finite, > 0), or None for the trajectory's duration.
        every: record stride (>= 1), or None for one sample per regulator period.
        names: how each number is named in the error.

    Raises:
        InputError: naming the number and why.

    Example:
        >>> check_numbers(1e-4, 0.5)
        >>> check_numbers(0.0)
        Traceback (most recent call last):
        ...
        manipcad.errors.InputError: dt: must be > 0 s, got 0.0
    """
    if not (math.isfinite(dt) and dt > 0):
        raise InputError(names["dt"], "", f"must be > 0 s, got {dt}")
    if every is not None and every < 1:
        raise InputError(names["every"], "", f"must be >= 1, got {every}")
    if t_end is not None and not (math.isfinite(t_end) and t_end > 0):
        raise InputError(names["t_end"], "", f"must be > 0 s, got {t_end}")


def plan_run(robot, trajectory, regulator_files: Sequence[str | Path] = (), *, dt: float,
             t_end: float | None = None, every: int | None = None, drives: bool = True,
             allow_other_robot: bool = False, robot_source: str | None = None,
             trajectory_source: str = "trajectory",
             names: Mapping[str, str] = NAMES) -> RunPlan:
    """Check that a robot, a trajectory and regulator files make one run, and set it up.

    Args:
        robot: the loaded :class:`~manipcad.model.robot.Robot`.
        trajectory: the loaded trajectory (``.n`` joints, ``.duration`` s), or None (the
            start pose held; ``t_end`` needed).
        regulator_files: regulator files (:func:`manipcad.load_regulators`); a joint may
            have a regulator in one of them only.
        dt: integration step, s; every regulator period must be a multiple of it.
        t_end: end time, s; None: the trajectory's duration (which must then be finite).
        every: record stride; None: one stored sample per shortest regulator period.
        drives: simulate the drives (the robot must have them).
        allow_other_robot: accept regulator files made for another robot's model.
        robot_source, trajectory_source: how the robot and the trajectory are named in
            errors (their file or reference); the robot's name by default.
        names: how dt, t_end, every and the no-drives switch are named in errors.

    Returns:
        :class:`RunPlan`.

    Raises:
        InputError: naming the file or number and the reason: numbers out of range, a
            trajectory for another joint count, a bad regulator file, a joint with two
            regulators, a trajectory with no end and no ``t_end``, a step or a regulator
            period longer than the run, drives asked of a robot without them.

    Example:
        >>> import manipcad
        >>> from manipcad.trajectories import load_trajectory
        >>> arm = manipcad.load_robot("cylindrical")
        >>> plan = plan_run(arm, load_trajectory("examples/fig3_laws.yaml", robot=arm),
        ...                 dt=1e-4)
        >>> plan.t_end > 0, plan.every, plan.regulators
        (True, 1, [])
    """

    check_numbers(dt, t_end, every, names)
    robot_source = robot.name if robot_source is None else robot_source
    if trajectory is not None and trajectory.n != robot.n:
        raise InputError(trajectory_source, "", f"has {trajectory.n} joints, robot "
                         f"{robot.name!r} has {robot.n}")
    regs = []
    owner: dict[int, str] = {}
    files = []  # the file of each regulator
    for path in regulator_files:
        for reg in load_regulators(path, robot, dt=dt, drives=drives,
                                   allow_other_robot=allow_other_robot):
            files.append(str(path))
            for j in reg.joints:
                if j in owner:
                    raise InputError(str(path), "joints", f"joint {robot.joint_names[j]!r} "
                                     f"already has a regulator in {owner[j]}")
                owner[j] = str(path)
            regs.append(reg)
    if t_end is None:
        if trajectory is None:
            raise InputError(names["t_end"], "", "needed: there is no trajectory")
        t_end = float(trajectory.duration)
        if not (math.isfinite(t_end) and t_end > 0):
            raise InputError(names["t_end"], "", "needed: the trajectory has no finite "
                             "duration")
    if dt > t_end:
        raise InputError(names["dt"], "", f"{dt:g} s is longer than the run ({t_end:g} s)")
    for reg, path in zip(regs, files, strict=True):
        if reg.period > t_end:

            raise InputError(path, "period", period_too_long(
                reg.period, robot.joint_names[reg.joints[0]], t_end))
    if drives and not robot.has_drives:
        raise InputError(robot_source, "drives", f"the robot has no drives; use "
                         f"{names['drives']}")
    if every is None:
        every = every_for(dt, [r.period for r in regs])
    return RunPlan(regulators=regs, t_end=t_end, dt=dt, every=every)
