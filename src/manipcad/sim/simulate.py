"""``simulate``: the full coupled closed loop along a trajectory (paper section 5, feature 4).

:func:`simulate` is the sequence of explicit steps: its arguments checked
(:mod:`manipcad.sim.arguments`), the start state and the closed loop built once
(:mod:`manipcad.sim.closed_loop`: the plant and the control packed for the compiled
cores), integrated (:mod:`manipcad.sim.integrate`), the result assembled, and the
joint-limit checks of the result and the reference (:mod:`manipcad.sim.joint_limits`).
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np

from manipcad.control.regulator import Regulator
from manipcad.model.robot import Robot
from manipcad.sim import arguments, closed_loop
from manipcad.sim import joint_limits as jl
from manipcad.sim.closed_loop import ClosedLoop, Start
from manipcad.sim.integrate import Integrated, electrical_cause, integrate, reference_rows
from manipcad.sim.result import JointLimitExceeded, SimulationDiverged, SimulationResult


def simulate(
    robot: Robot,
    *,
    t_end: float,
    dt: float = 1e-4,
    trajectory=None,
    regulators: Sequence[Regulator] | None = None,
    q0=None,
    qd0=None,
    payload=None,
    drives: bool = True,
    disturbance: Callable[[np.ndarray], np.ndarray] | np.ndarray | None = None,
    transmissions=None,
    order: int = 3,
    every: int = 1,
    progress: Callable[[float], None] | None = None,
    joint_limits: str = "warn",
    use_generated: bool = True,
    integrator: str = "rk4",
    rtol: float | None = None,
    atol: float | None = None,
    pickup: dict | None = None,
    estimator=None,
    model_payload: str | None = None,
    **renamed,
) -> SimulationResult:
    """Simulate the closed loop: coupled multibody dynamics, DC drives, sampled regulators.

    Each regulator is sampled at its own period (a multiple of ``dt``) and held
    between samples, as a digital controller runs it, so switching (sliding-mode)
    regulators are integrated as they run. Compiled integrators: ``"rk4"``,
    fixed-step RK4 at ``dt`` (the reference), and the error-controlled pairs of
    :mod:`manipcad.sim.adaptive`, Dormand–Prince 5(4) (``"adaptive"``,
    ``"adaptive-exact"``) and Bogacki–Shampine 3(2) (``"adaptive-bs32"``,
    ``"adaptive-exact-bs32"``), whose steps never cross a sample instant (the
    regulators see the same sample times), kept samples at the same times k·dt as RK4.

    Args:
        robot: the manipulator (a drive per joint for ``drives=True``; joints
            without one take the regulator output as torque).
        t_end: duration, s (> 0).
        dt: integration step, s.
        trajectory: reference; anything with ``.sample(t) -> (q, qd, qdd)`` of
            shape (len(t), n). None: hold q0.
        regulators: :class:`~manipcad.control.regulator.Regulator` objects (a list, nested
            lists as ``synthesize(robot, "all", ...)`` gives, or one); joints no regulator
            controls get U = 0.
        q0, qd0: initial state (default: the reference at t = 0, zero speed).
        payload: None, a mass in kg (a point mass at the tool point), or a dict
            ``{"mass": kg, "com": [x, y, z] m, "inertia", "link"}``
            (:func:`manipcad.model.payload.apply_payload`).
        drives: True: the DC drives' electrical and mechanical dynamics;
            False: the passive rigid body driven by regulator torques only.
        disturbance: extra joint torques, N·m or N: an (n,) constant or a
            function of the time array returning (len(t), n).
        transmissions: per-joint :class:`manipcad.drives.params.Transmission`
            (elasticity, backlash) or None.
        order: 3 keeps the armature inductance, 2 neglects it.
        every: keep every k-th step in the result.
        progress: called with the fraction done (0..1) after each chunk of steps; an
            exception it raises (e.g. KeyboardInterrupt to cancel) stops the run.
        joint_limits: what a joint beyond the robot's limits does: "warn" (default: the
            run goes on; a :class:`~manipcad.errors.ManipcadWarning` names each joint, how
            far and when, and ``metrics[joint]["limit_excess"]`` records it), "stop"
            (:class:`JointLimitExceeded` at the first step beyond, with the partial
            result), "ignore", or "hard-stop": the limits are the joints' mechanical
            stops, a joint reaching one stops there (an inelastic impact located as an
            event: q on the stop, q̇ = 0), stays while the torque on it pushes into the
            stop (or its static friction holds it) and leaves when it pulls away beyond
            its friction (docs/simulation.md, "Hard stops"); ``q0`` must be within the
            limits.
        use_generated: use the robot's customized kernels when
            :func:`manipcad.codegen.generate` has made them for this robot (with the
            payload, if any) and the drives' joint side is the robot's own or none
            (``result.settings["generated"]`` says whether they ran); False: always
            the general kernels.
        integrator: "rk4" (fixed step ``dt``, the reference); "adaptive": Dormand–Prince
            5(4) on the whole state (q, q̇, currents), the step set by ``rtol``, ``atol``
            and the sample instants; "adaptive-exact": the same pair on q, q̇ with the
            armature currents advanced by the exact solution of the armature equation
            (U held, the motor speed a polynomial over the stage): no step limit from
            L/R, and the currents' error (the speed polynomial's) estimated and held to
            the same tolerance through its effect on the joint speed (see
            :mod:`manipcad.sim.adaptive` and docs/performance.md). With either adaptive
            one ``dt`` only sets the grid of the sample and record times and of a
            time-varying disturbance (held over each ``dt`` as RK4 holds it), and the
            smallest step: where the tolerance asks for less, e.g. a joint sticking in
            dry friction, steps of ``dt`` are taken and counted in ``settings``.
            "adaptive-bs32", "adaptive-exact-bs32": the same two with the
            Bogacki–Shampine 3(2) pair (3 right-hand sides per step against 6, a
            3rd-order solution against a 5th-order one): cheaper where the steps are
            bounded by the sample period rather than by the tolerance (a rigid arm
            with a 1 kHz regulator: see docs/performance.md), costlier at tight
            tolerances. Elastic gears and backlash (``transmissions``) need "rk4",
            "adaptive" or "adaptive-bs32" (the exact currents are the rigid drives').
        rtol: relative tolerance of the adaptive integrator's local error (-, in
            [1e-12, 0.1]; default 1e-6); only with an adaptive integrator.
        atol: absolute tolerance on q (rad or m) and q̇ (rad/s or m/s) (> 0; default
            1e-8); only with an adaptive integrator.
        pickup: an unknown payload gripped mid-run: ``{"mass": kg, "t": s, "com": [x, y,
            z] m, "inertia": (3, 3) kg·m², "link": ...}`` (com, inertia and link as
            ``payload``): the plant's link takes it at the step of time t (0 < t < t_end;
            :mod:`manipcad.sim.pickup`). With an adaptive integrator t must be a
            sample instant of a regulator.
        estimator: a :class:`manipcad.control.estimator.PayloadEstimator`, the online
            payload estimator, run at its period inside the loop (after the regulators);
            its estimate is in ``result.payload_estimate``. With an adaptive integrator
            its period must be a multiple of a regulator's.
        model_payload: the payload the regulators' model signals (H_ii, c_i, Q_i, H)
            assume: "true" (the plant's, the pickup known at once; the default without an
            estimator), "nominal" (the robot as given, the pickup unknown) or "online" (the
            estimator's estimate; the default with one).
        renamed: no keyword is taken here: ``record_every`` (now ``every``) is refused
            with its new name, any other as Python refuses an unknown keyword.

    Returns:
        :class:`SimulationResult`.

    Raises:
        SimulationDiverged: NaN or runaway speed, with the time and joint and
            the partial result.
        JointLimitExceeded: with ``joint_limits="stop"``, a joint left its limits.
        ManipcadError: a bad argument (named), e.g. an unknown integrator or a
            tolerance out of range.

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> res = manipcad.simulate(arm, t_end=0.1, dt=1e-3, drives=False)
        >>> res.q.shape
        (101, 3)
    """
    a = arguments.check(robot, t_end=t_end, dt=dt, every=every, joint_limits=joint_limits,
                        integrator=integrator, rtol=rtol, atol=atol, payload=payload,
                        pickup=pickup, estimator=estimator, model_payload=model_payload,
                        renamed=renamed)
    robot, adaptive = a.robot, a.adaptive is not None
    start = closed_loop.start_state(robot, a.n, a.steps, dt, trajectory, q0, qd0, drives,
                                    adaptive, joint_limits)
    loop = closed_loop.build(robot, start, dt=dt, t_end=t_end, steps=a.steps,
                             regulators=regulators, drives=drives, transmissions=transmissions,
                             order=order, use_generated=use_generated,
                             joint_limits=joint_limits, picked=a.picked, estimator=estimator,
                             model_payload=a.model_payload, integrator=integrator,
                             adaptive=adaptive)
    out = integrate(loop, start, n=a.n, steps=a.steps, dt=dt, every=a.every,
                    joint_limits=joint_limits, adaptive=a.adaptive, rtol=a.rtol, atol=a.atol,
                    trajectory=trajectory, disturbance=disturbance, progress=progress)
    res = _result(a, loop, out, start, trajectory, estimator, drives=drives, order=order,
                  integrator=integrator)
    _raise_if_stopped(res, a, loop, out)
    excesses = jl.excess(robot, out.work.excess, loop.bounds, joint_limits, res.units)
    res._lazy_metrics(bool(drives) and robot.has_drives, loop.dtable, excesses)
    if trajectory is not None and joint_limits != "ignore":
        # the first chunk's extremes serve when its rows are the result's reference
        first = start.first
        known = (start.first_extremes if first is not None and res.q_ref is first[1]
                 else None)
        jl.warn_reference(robot, res.t, res.q_ref, loop.bounds, res.units, extremes=known)
    return res


def _result(a: arguments.Arguments, loop: ClosedLoop, out: Integrated, start: Start,
            trajectory, estimator, *, drives: bool, order, integrator: str
            ) -> SimulationResult:
    """The :class:`SimulationResult` of a run from what the loop kept: the reference at the
    kept times and the settings (what ran: dt, t_end, drives, order, regulators, kernels,
    integrator and its counters, limits as stops, pickup, estimator)."""
    # deferred: start-up cost: keeps manipcad.sim.pickup out of import manipcad
    from manipcad.sim import pickup as pk

    robot, n, rec, picked, stats = a.robot, a.n, out.rec, a.picked, out.stats
    kept = int(out.work.rec[0])
    t = rec.t[:kept]
    sampled = out.sampled
    if sampled is not None and len(sampled[0]) == kept and sampled[0][-1] == t[-1]:
        # one chunk, every step kept (as many rows as steps + 1: rows k·dt, k = 0, 1, ...
        # both): the reference the loop ran on is the result's (the same samples at the
        # same times; sampling 10,001 rows again costs about 0.6 ms)
        QR, QDR = sampled[1], sampled[2]
    elif trajectory is not None:
        QR, QDR, _ = reference_rows(trajectory, t, n)
    else:
        QR, QDR = np.tile(start.q, (kept, 1)), np.zeros((kept, n))
    ev = loop.plant.ev
    return SimulationResult(
        t=t, q=rec.q[:kept], qd=rec.qd[:kept], q_ref=QR, qd_ref=QDR,
        u=rec.u[:kept], current=rec.i[:kept], tau=rec.tau[:kept],
        joint_names=robot.joint_names, joint_types=tuple(robot.joint_types), robot=robot.name,
        payload_estimate=None if estimator is None else pk.estimate_series(loop.est, a.dt),
        events=(ev.log[:min(int(ev.count[0]), len(ev.log))].copy() if ev.on else None),
        settings={"dt": a.dt, "t_end": a.t_end, "drives": bool(drives), "order": order,
                  "regulators": loop.described, "generated": loop.generated,
                  "integrator": integrator,
                  # the limits modelled as stops change the plant: the result says so
                  **({"joint_limits": "hard-stop"} if loop.bounds.stops is not None else {}),
                  **({"pickup": picked[2]} if picked is not None else {}),
                  **({"estimator": estimator.describe()} if estimator is not None else {}),
                  **({"model_payload": a.model_payload}
                     if picked is not None or estimator is not None else {}),
                  **({"rtol": a.rtol, "atol": a.atol, "steps": int(stats[1]),
                      "rejected": int(stats[2]), "rhs_evaluations": int(stats[3]),
                      "steps_at_dt_above_tolerance": int(stats[4])}
                     if stats is not None else {})},
    )


def _raise_if_stopped(res: SimulationResult, a: arguments.Arguments, loop: ClosedLoop,
                      out: Integrated) -> None:
    """Raise :class:`JointLimitExceeded` (a joint beyond its limits with
    ``joint_limits="stop"``) or :class:`SimulationDiverged` (NaN or a runaway speed, with
    the drive whose electrical mode the RK4 step cannot resolve when that is the cause),
    carrying the partial result, when the loop stopped early."""
    status, step, joint = out.status, out.step, out.joint
    if status == 3:
        nm = a.robot.joint_names[joint]
        raise JointLimitExceeded(jl.stopped_message(
            a.robot, joint, step * a.dt, out.work.x[joint], loop.bounds, res.units[nm]), res)
    if status:
        what = "NaN in the state" if status == 1 else "speed above 1e4 rad/s (m/s)"
        where = f"joint {a.robot.joint_names[joint]!r}" if joint >= 0 else "a drive state"
        seen = f"{what} at {where}"
        cause = (None if a.adaptive is not None
                 else electrical_cause(a.robot, loop.dtable, float(a.dt)))
        raise SimulationDiverged(f"simulation diverged at t = {step * a.dt:.6g} s: "
                                 + (seen if cause is None else
                                    f"{cause} (the runaway was first seen as {seen})"), res)


__all__ = ["simulate", "SimulationResult", "SimulationDiverged", "JointLimitExceeded"]
