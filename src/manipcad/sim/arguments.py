"""The checks of :func:`manipcad.sim.simulate`'s arguments, made before anything is built:
one clear error naming the argument and why."""

from __future__ import annotations

import math
from typing import NamedTuple

from manipcad.errors import ManipcadError, refuse_renamed
from manipcad.model.payload import apply_payload
from manipcad.model.robot import Robot, require_robot
from manipcad.sim import joint_limits as jl
from manipcad.sim.integrate import integrator_options


class Arguments(NamedTuple):
    """A run's arguments, checked.

    Attributes:
        robot: the robot with the payload applied (:func:`~manipcad.model.payload.apply_payload`).
        n: its joint count.
        t_end, dt: the run's length and step, s, as given.
        every: the record stride (>= 1).
        steps: the steps of the run (t_end / dt, bounded by :mod:`manipcad.budget`).
        adaptive: None for RK4, else the (pair, exact) of
            :data:`manipcad.sim.integrate.INTEGRATORS`.
        rtol, atol: the adaptive tolerances (None for RK4).
        model_payload: what the regulators' model knows ("true", "nominal", "online").
        picked: the pickup's (robot after, step, description)
            (:func:`manipcad.sim.pickup.picked_robot`), or None.
    """

    robot: Robot
    n: int
    t_end: float
    dt: float
    every: int
    steps: int
    adaptive: tuple | None
    rtol: float | None
    atol: float | None
    model_payload: str
    picked: tuple | None


def check(robot, *, t_end, dt, every, joint_limits, integrator, rtol, atol, payload, pickup,
          estimator, model_payload, renamed) -> Arguments:
    """Check :func:`manipcad.sim.simulate`'s arguments (its names and units) in the order
    the errors are reported: a renamed keyword, the robot, ``joint_limits``, the
    integrator and its tolerances, ``t_end``, ``dt``, ``every``, the payload, the
    pickup and what the model knows, the run's size.

    Raises:
        ManipcadError: the first bad argument, named.

    Example:
        >>> import manipcad
        >>> a = check(manipcad.load_robot("cylindrical"), t_end=0.1, dt=1e-3, every=1,
        ...           joint_limits="warn", integrator="rk4", rtol=None, atol=None,
        ...           payload=None, pickup=None, estimator=None, model_payload=None,
        ...           renamed={})
        >>> a.steps, a.adaptive, a.model_payload
        (100, None, 'true')
    """
    refuse_renamed("simulate", renamed, record_every="every")
    n = require_robot(robot, "simulate").n
    jl.check_mode(joint_limits)
    adaptive, rtol, atol = integrator_options(integrator, rtol, atol)
    if not (t_end > 0 and math.isfinite(t_end)):
        raise ManipcadError(f"t_end must be > 0 s, got {t_end}")
    if not (dt > 0 and dt <= t_end):
        raise ManipcadError(f"dt must be in (0, t_end], got {dt}")
    if int(every) < 1:
        raise ManipcadError(f"every must be >= 1, got {every}")
    robot = apply_payload(robot, payload)[0]
    # the payload picked up mid-run, the online estimator and what the model knows
    # deferred: start-up cost: keeps manipcad.sim.pickup out of import manipcad
    from manipcad.sim import pickup as pk

    model_payload = pk.model_payload_of(model_payload, estimator)
    picked = None if pickup is None else pk.picked_robot(robot, pickup, t_end, dt)
    # deferred: start-up cost: keeps manipcad.budget out of import manipcad
    from manipcad.budget import check_steps

    # the reference is sampled chunk by chunk: memory follows the kept samples (t, q, q̇, U,
    # i, τ, and q*, q̇* at the end), and the step count is bounded before anything is made
    K = check_steps(t_end, dt, floats_per_step=0.0, floats_per_kept=1 + 7 * n,
                    every=int(every))
    if int(every) > K:
        raise ManipcadError(f"every = {every} keeps one sample of the {K} steps "
                            f"of the run (t_end = {t_end:g} s, dt = {dt:g} s); at most {K}")
    return Arguments(robot, n, t_end, dt, int(every), K, adaptive, rtol, atol, model_payload,
                     picked)


__all__ = ["Arguments", "check"]
