"""A payload picked up mid-run, and what the regulators' model knows of it.

``simulate(..., pickup={"mass": kg, "t": s, "com": [x, y, z] m, "link": ...})``: at the
step of time ``t`` the plant's last link (or ``link``) takes a point mass (a rigid body
with ``"inertia"``) at ``com``: the true dynamics change from that instant. What the
regulators' model — the moment constituents H_ii, c_i, Q_i, H they read — knows is
``model_payload``:

- ``"true"``: the model follows the plant (the payload known the instant it is gripped);
- ``"nominal"``: the model stays the robot as given (no payload knowledge);
- ``"online"``: the model carries the online estimate of the payload mass
  (:class:`manipcad.control.estimator.PayloadEstimator`, ``estimator=``), updated each
  of its periods.

The swap itself runs in the shared sampling step (:func:`manipcad.sim.loop.sample_due`),
so it happens at a step boundary, before the regulators sample that step.
"""

from __future__ import annotations

import math

import numpy as np

from manipcad.control.estimator import Estimator, PayloadEstimator, no_estimator
from manipcad.drives.params import joint_referred_terms
from manipcad.errors import ManipcadError
from manipcad.model.robot import COL_BV, COL_FCN, COL_FCP, COL_JR, TABLE_COLS, Robot
from manipcad.sim.loop import Pickup

#: what the regulators' model assumes of the payload
MODEL_PAYLOADS = ("true", "nominal", "online")


def no_pickup() -> Pickup:
    """The :class:`~manipcad.sim.loop.Pickup` of a run without one (same compiled types)."""
    z = np.zeros((1, TABLE_COLS))
    return Pickup(-1, z, z, False, np.zeros(1, dtype=np.int64))


def model_payload_of(model_payload, estimator) -> str:
    """``model_payload`` checked (default: "online" with an estimator, else "true")."""
    if model_payload is None:
        return "online" if estimator is not None else "true"
    if model_payload not in MODEL_PAYLOADS:
        raise ManipcadError(f"model_payload must be one of {', '.join(MODEL_PAYLOADS)}, got "
                            f"{model_payload!r}")
    if model_payload == "online" and estimator is None:
        raise ManipcadError("model_payload='online' needs an estimator (estimator="
                            "manipcad.PayloadEstimator(robot, ...))")
    return model_payload


def picked_robot(robot: Robot, pickup, t_end: float, dt: float) -> tuple[Robot, int, dict]:
    """The robot after the pickup, the step it happens at, and its description.

    Raises:
        ManipcadError: pickup not a dict with ``mass`` and ``t``, a mass that is not a
            finite number >= 0 kg, ``t`` outside (0, t_end) s, a bad com, inertia or link.
    """
    if not isinstance(pickup, dict):
        raise ManipcadError(f"pickup must be a dict {{'mass': kg, 't': s, 'com': [x, y, z] m}}, "
                            f"got {type(pickup).__name__}")
    unknown = set(pickup) - {"mass", "t", "com", "inertia", "link"}
    missing = {"mass", "t"} - set(pickup)
    if unknown or missing:
        raise ManipcadError(f"pickup: keys 'mass' (kg) and 't' (s) are required, 'com', "
                            f"'inertia', 'link' optional; got {sorted(pickup)}")
    try:
        mass, t = float(pickup["mass"]), float(pickup["t"])
    except (TypeError, ValueError):
        raise ManipcadError(f"pickup: mass and t must be numbers, got {pickup['mass']!r}, "
                            f"{pickup['t']!r}") from None
    if not (math.isfinite(mass) and mass >= 0):
        raise ManipcadError(f"pickup: mass must be a finite number >= 0 kg, got {mass}")
    if not (math.isfinite(t) and 0 < t < t_end):
        raise ManipcadError(f"pickup: t = {t:g} s must be inside the run (0, t_end = "
                            f"{t_end:g} s)")
    try:
        after = robot.with_payload(mass, pickup.get("com", (0.0, 0.0, 0.0)),
                                   pickup.get("inertia"), link=pickup.get("link", -1))
    except (ManipcadError, ValueError, TypeError) as exc:
        raise ManipcadError(f"pickup: {exc}") from None
    step = int(round(t / dt))
    return after, step, {"mass": mass, "t": step * dt,
                         "com": np.asarray(pickup.get("com", (0.0, 0.0, 0.0)),
                                           dtype=float).tolist(),
                         "link": pickup.get("link", -1)}


def pickup_part(after: Robot, step: int, dtable, model: bool) -> Pickup:
    """The compiled pickup: the plant's table after it (drive terms as the simulator's)."""
    rtable = np.array(after.table)
    rtable[:, [COL_JR, COL_BV, COL_FCP, COL_FCN]] = joint_referred_terms(dtable)
    return Pickup(int(step), rtable, np.array(after.table), bool(model),
                  np.zeros(1, dtype=np.int64))


def estimator_part(estimator, robot: Robot, dt: float, K: int, ctable, *, feed: bool,
                   drives: bool) -> Estimator:
    """The compiled estimator of a run of K steps of dt s (for None the one that is off,
    :func:`~manipcad.control.estimator.no_estimator`: the same compiled types)."""
    if estimator is None:
        return no_estimator()
    if not isinstance(estimator, PayloadEstimator):
        raise ManipcadError(f"estimator must be a manipcad.PayloadEstimator, got "
                            f"{type(estimator).__name__}")
    if estimator.robot.n != robot.n:
        raise ManipcadError(f"estimator: built for {estimator.robot.name!r} with "
                            f"{estimator.robot.n} joints, the robot has {robot.n}")
    if not drives:
        raise ManipcadError("estimator: reads the armature currents; simulate with "
                            "drives=True")
    steps = max(1, round(estimator.period / dt))
    return estimator.pack(dt, K // steps + 1, ctable, feed=feed)


def check_adaptive(integrator: str, pick_step: int | None, ctrl, dt: float) -> None:
    """With an adaptive integrator, the pickup and the estimator's samples must fall on
    instants the integrator stops at: the regulators' sample instants (multiples of
    their periods, :func:`manipcad.sim.loop.sample_due` runs there).

    ``"adaptive-exact"`` reuses the derivative at the end of a held interval as the next
    one's start; at the pickup's instant it evaluates it again
    (:func:`manipcad.sim.adaptive.run_adaptive`).

    Raises:
        ManipcadError: naming the pickup time or the estimator's period and the
            regulators' periods.
    """
    periods = [int(s) for s in ctrl.steps]
    shown = ", ".join(f"{p * dt:g}" for p in sorted(set(periods))) or "(no regulator)"
    if pick_step is not None:
        if not any(pick_step % p == 0 for p in periods):
            raise ManipcadError(f"integrator={integrator!r}: pickup t = {pick_step * dt:g} s "
                                f"must be a sample instant of a regulator (periods {shown} s), "
                                "where the adaptive steps stop; or use integrator='rk4'")
    est = ctrl.est
    if est.on and not any(int(est.steps) % p == 0 for p in periods):
        raise ManipcadError(f"integrator={integrator!r}: the estimator's period "
                            f"{est.steps * dt:g} s must be a multiple of a regulator's period "
                            f"({shown} s), whose instants the adaptive steps stop at; or use "
                            "integrator='rk4'")


def estimate_series(est: Estimator, dt: float) -> np.ndarray:
    """(M, 2): time s and the payload estimate kg after each of the estimator's samples."""
    m = int(est.aux[0])
    t = np.arange(m) * est.steps * dt
    return np.column_stack([t, est.log[:m]])
