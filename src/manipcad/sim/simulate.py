"""``simulate``: the full coupled closed loop along a trajectory (paper section 5, feature 4)."""

from __future__ import annotations

import math
import warnings
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field
from html import escape

import numba as nb
import numpy as np
import pandas as pd

from manipcad.codegen import simulation_kernels
from manipcad.control.registry import kind_of
from manipcad.control.regulator import Regulator
from manipcad.control.signals import MODEL_SIGNALS, NPARAM, NSTATE
from manipcad.drives.params import (
    KIND_ELASTIC,
    KIND_ELASTIC_STATIC,
    KIND_NONE,
    KIND_RIGID,
    KIND_RIGID_STATIC,
    P_KIND,
    P_L,
    P_R,
    P_RATIO,
    joint_referred_terms,
    pack_drives,
    state_offsets,
)
from manipcad.dynamics import forward_dynamics
from manipcad.errors import InputError, ManipcadError, ManipcadWarning, refuse_renamed
from manipcad.model.payload import apply_payload
from manipcad.model.robot import COL_BV, COL_FCN, COL_FCP, COL_JR, Robot, require_robot
from manipcad.sim import adaptive as _adaptive
from manipcad.sim import loop as _loop
from manipcad.sim.adaptive import STATS, TABLEAUS
from manipcad.sim.direct import DirectCall
from manipcad.sim.events import events_part, friction_table
from manipcad.sim.loop import Control, Plant, Record, Reference, Work
from manipcad.sim.metrics import joint_metrics

#: the compiled cores, called without numba's typing of the named structures at every
#: call once their types are known (:mod:`manipcad.sim.direct`: about 0.1 ms a call)
run = DirectCall(_loop.run)
run_adaptive = DirectCall(_adaptive.run_adaptive)

#: steps integrated per call of the compiled core (the reference is sampled per chunk,
#: so memory follows the kept samples)
CHUNK = 20000


class SimulationDiverged(ManipcadError):
    """The simulation blew up; ``.result`` holds what was computed up to then."""

    def __init__(self, message: str, result: SimulationResult) -> None:
        super().__init__(message)
        self.result = result


class JointLimitExceeded(SimulationDiverged):
    """A joint left its limits (``joint_limits="stop"``); ``.result`` holds the run so far."""


@dataclass
class SimulationResult:
    """Time series and metrics of a closed-loop run (SI units).

    Attributes:
        t: (K,) times, s.
        q, qd: (K, n) joint positions (rad or m) and velocities (rad/s or m/s).
        q_ref, qd_ref: (K, n) reference positions and velocities.
        u: (K, n) regulator outputs: amplifier inputs U, V (joint torque for
            joints without a drive model).
        current: (K, n) armature currents, A (nan without a drive model).
        tau: (K, n) joint torques from the drives (plus disturbance), N·m or N.
        metrics: per joint name: max and RMS error, overshoot, rise and
            settling time (of a step), control effort, energy
            (:func:`manipcad.sim.metrics.joint_metrics`; for a result of
            :func:`simulate`, computed from its arrays when first read).
        robot: the robot's name; joint_names, joint_types: its joints ("revolute" in rad,
            "prismatic" in m; ``units`` maps each joint to its unit).
        settings: dt, t_end and the regulators' descriptions (and the pickup, the
            estimator and the model's payload when given; ``joint_limits: "hard-stop"``
            when the limits were modelled as stops).
        payload_estimate: with ``estimator=``: (M, 2), the time (s) and the online payload
            estimate (kg) after each of the estimator's samples; else None.
        checks: the run's checks against every rating, ``{joint: {check: {value, limit,
            unit, verdict}}}`` (:meth:`manipcad.sim.checks.RunChecks.to_dict`), once a
            caller has made them (``manipcad simulate``, ``verify``); else None. Saved in
            metrics.json.
        events: (E, 3) the located stick-slip switches of the lossy joints (dry friction
            or gear losses, :mod:`manipcad.sim.events`): time (s), joint index, new mode
            (+1 or -1 slipping that way, 0 stuck; +2 / -2 reaching the upper / lower hard
            stop with ``joint_limits="hard-stop"``); None without lossy joints or stops.
    """

    t: np.ndarray
    q: np.ndarray
    qd: np.ndarray
    q_ref: np.ndarray
    qd_ref: np.ndarray
    u: np.ndarray
    current: np.ndarray
    tau: np.ndarray
    joint_names: tuple[str, ...]
    robot: str = ""
    settings: dict = field(default_factory=dict)
    metrics: dict = field(default_factory=dict)
    joint_types: tuple[str, ...] = ()
    payload_estimate: np.ndarray | None = None
    checks: dict | None = None
    events: np.ndarray | None = None

    @property
    def units(self) -> dict[str, str]:
        """Unit of each joint's position ("rad" or "m"); velocities are per s, torques
        N·m or N, U in V, currents in A."""
        return {nm: ("m" if t == "prismatic" else "rad")
                for nm, t in zip(self.joint_names, self.joint_types, strict=False)}

    @property
    def error(self) -> np.ndarray:
        """Tracking error q_ref - q, rad or m, shape (K, n)."""
        return self.q_ref - self.q

    def to_dataframe(self, joint_types: Sequence[str] | None = None):
        """The time series as a :class:`pandas.DataFrame`, units in the column names.

        The index is ``t [s]``; one column per joint and quantity, ``"JOINT.QUANTITY
        [UNIT]"`` (``"waist.q [rad]"``, ``"lift.tau [N]"``), the columns of the CSV export
        (:mod:`manipcad.sim.series`). ``joint_types`` defaults to the result's own.

        Example:
            >>> import manipcad
            >>> res = manipcad.simulate(manipcad.load_robot("cylindrical"), t_end=0.01,
            ...                         dt=1e-3, drives=False)
            >>> res.to_dataframe().columns[0]
            'turn.q [rad]'
        """

        # deferred: start-up cost: keeps manipcad.sim.series out of import manipcad
        from manipcad.sim.series import series_columns

        types = joint_types if joint_types is not None else (self.joint_types or None)
        cols = series_columns(self, types)
        return pd.DataFrame(dict(cols[1:]), index=pd.Index(np.asarray(cols[0][1]),
                                                           name="t [s]"))

    def _lazy_metrics(self, drives: bool, dtable: np.ndarray, excess: dict) -> None:
        """Compute :attr:`metrics` when first read (:func:`joint_metrics` with these
        arguments, then each joint's ``limit_excess`` of ``excess``): most callers of
        :func:`simulate` in a loop never read them."""
        self.__dict__["_metrics_of"] = (drives, dtable, excess)

    def _repr_html_(self) -> str:
        """The per-joint metrics as an HTML table (Jupyter)."""

        def cell(x) -> str:
            return "—" if x is None or (isinstance(x, float) and np.isnan(x)) else f"{x:.4g}"

        types = list(self.joint_types) or [None] * len(self.joint_names)
        rows = "".join(
            f"<tr><td>{escape(j)}</td><td>{'m' if jt == 'prismatic' else 'rad' if jt else 'rad|m'}"
            f"</td>" + "".join(f"<td>{cell((self.metrics.get(j) or {}).get(k))}</td>"
                               for k in ("max_error", "rms_error", "effort_rms", "energy"))
            + "</tr>" for j, jt in zip(self.joint_names, types, strict=True))
        t_end = float(self.t[-1]) if len(self.t) else 0.0
        return (f"<p><b>{escape(self.robot or 'result')}</b>: {len(self.t)} samples, "
                f"t = 0 … {t_end:.4g} s</p><table><thead><tr><th>joint</th><th>unit</th>"
                "<th>max |e|</th><th>RMS e</th><th>effort RMS</th><th>energy J</th></tr>"
                f"</thead><tbody>{rows}</tbody></table>")


def _get_metrics(self) -> dict:
    d = self.__dict__
    of = d.pop("_metrics_of", None)
    if of is not None:
        drives, dtable, excess = of
        m = joint_metrics(self, drives=drives, dtable=dtable)
        for nm, v in excess.items():
            m[nm]["limit_excess"] = v
        d["_metrics"] = m
    if "_metrics" not in d:  # unpickled from before the metrics were computed lazily
        d["_metrics"] = d.pop("metrics", {})
    return d["_metrics"]


def _set_metrics(self, value: dict) -> None:
    self.__dict__.pop("_metrics_of", None)
    self.__dict__["_metrics"] = value


# a property over the dataclass field (its __init__ assigns through the setter)
SimulationResult.metrics = property(_get_metrics, _set_metrics,
                                    doc="Per-joint metrics (see the class docstring).")


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
            tolerances. Elastic gears and backlash (``transmissions``) need "rk4".
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
    refuse_renamed("simulate", renamed, record_every="every")
    n = require_robot(robot, "simulate").n
    if joint_limits not in JOINT_LIMITS:
        raise ManipcadError(f"joint_limits must be one of {', '.join(JOINT_LIMITS)}, got "
                            f"{joint_limits!r}")
    adaptive, rtol, atol = _integrator_options(integrator, rtol, atol)
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
    # RK4 along a trajectory: the first chunk's rows sampled once, here; where each row
    # depends on its own time only (Trajectory.rows_independent), their first row is the
    # start (the same numbers as a sample of t = 0 alone)
    first = first_extremes = None
    if trajectory is None:
        q_start = np.zeros(n) if q0 is None else _vec(q0, n, "q0")
    else:
        if not adaptive:
            t_first = np.arange(min(CHUNK, K) + 1) * float(dt)
            first = (t_first, *_reference(trajectory, t_first, n))
            if joint_limits != "ignore" and robot.limits is not None:
                # the reference's extremes for its limit check, read now while q* is in
                # the cache (after the run it is not: 0.1 ms against 0.03 ms)
                first_extremes = _extremes(first[1])
        if first is not None and getattr(trajectory, "rows_independent", False):
            q_start = first[1][0]
        else:
            q_start = _reference(trajectory, np.zeros(1), n)[0][0]
    x_q = q_start.copy() if q0 is None else _vec(q0, n, "q0")
    x_qd = np.zeros(n) if qd0 is None else _vec(qd0, n, "qd0")
    # a joint that moves no mass (and no rotor) has no acceleration: say so by name here,
    # as the dynamics API does, rather than as NaN at t = 0

    try:
        forward_dynamics(robot, x_q, x_qd, np.zeros(n), drives=bool(drives) and robot.has_drives,
                         method="crba")
    except ManipcadError as exc:
        raise ManipcadError(f"cannot simulate {robot.name!r} from its initial state: {exc}"
                            ) from None

    if drives and not robot.has_drives:
        raise ManipcadError(f"robot {robot.name!r} has no drives; use drives=False")
    dtable, off, rtable = _packed_drives(robot, bool(drives), transmissions, order)
    x0 = np.concatenate([x_q, x_qd, _drive_initial_state(dtable, off, x_q, x_qd)])
    generic = any(int(dtable[j, P_KIND]) not in (KIND_NONE, KIND_RIGID, KIND_RIGID_STATIC)
                  for j in range(n))
    gen = simulation_kernels(robot, rtable, use_generated=use_generated and picked is None
                             and estimator is None)
    limits = (np.tile([-math.inf, math.inf], (n, 1)) if robot.limits is None
              or joint_limits == "ignore" else np.array(robot.limits, dtype=float))
    # excursions below a millionth of the joint's range are rounding, not a limit hit
    span = limits[:, 1] - limits[:, 0]
    tol = np.where(np.isfinite(span), np.maximum(1e-6 * span, 1e-12), 0.0)
    wide = np.column_stack([limits[:, 0] - tol, limits[:, 1] + tol])
    stops = None
    if joint_limits == "hard-stop" and np.isfinite(limits).any():
        stops = limits
        out = (x_q < limits[:, 0]) | (x_q > limits[:, 1])
        if out.any():
            j = int(np.flatnonzero(out)[0])
            raise ManipcadError(f"q0 of joint {robot.joint_names[j]!r} ({x_q[j]:.6g}) is "
                                f"beyond its stops [{limits[j, 0]:.6g}, {limits[j, 1]:.6g}] "
                                "(joint_limits='hard-stop')")
    ctable = np.array(robot.table)  # the regulators' model (a pickup or the estimator edit it)
    plant = Plant(rtable, ctable, np.asarray(robot.gravity, float),
                  dtable, off, bool(drives), generic, wide, *gen,
                  pk.no_pickup() if picked is None else
                  pk.pickup_part(picked[0], picked[1], dtable, model_payload == "true"),
                  _events(robot, dtable, rtable, bool(drives), x_qd, len(x0), stops))
    est = pk.estimator_part(estimator, robot, dt, K, ctable, feed=model_payload == "online",
                            drives=bool(drives))
    ctrl, described = _pack_regulators(robot, regulators, dt, est, t_end)
    if adaptive:
        pk.check_adaptive(integrator, None if picked is None else picked[1], ctrl, dt)
    if adaptive and generic:
        raise ManipcadError(f"integrator={integrator!r} handles rigid drives only; elastic "
                            "gears and backlash (transmissions=...) need integrator='rk4'")

    every = int(every)
    M = K // every + 1
    rec = Record(np.empty(M), *(np.empty((M, n)) for _ in range(5)))
    work = Work(x0, np.zeros(n), np.zeros(len(ctrl.kind), dtype=np.int64),
                np.zeros(2, dtype=np.int64), np.zeros((n, 2)))
    dist_of = _disturbance_source(disturbance, K, n)
    sampled = None  # (t, q*, q̇*) the loop ran on, when they are the kept samples' own
    if adaptive:
        status, step, joint, stats = _run_adaptive(plant, ctrl, rec, work, K, float(dt),
                                                   every, joint_limits, trajectory, x_q,
                                                   dist_of, _varies(disturbance), n,
                                                   rtol, atol, progress, *adaptive)
    else:
        status, step, joint, sampled = _run_rk4(plant, ctrl, rec, work, K, float(dt),
                                                every, joint_limits, trajectory, x_q,
                                                dist_of, n, progress, first)
    kept = int(work.rec[0])
    t = rec.t[:kept]
    if sampled is not None and len(sampled[0]) == kept and sampled[0][-1] == t[-1]:
        # one chunk, every step kept (as many rows as steps + 1: rows k·dt, k = 0, 1, ...
        # both): the reference the loop ran on is the result's (the same samples at the
        # same times; sampling 10,001 rows again costs about 0.6 ms)
        QR, QDR = sampled[1], sampled[2]
    elif trajectory is not None:
        QR, QDR, _ = _reference(trajectory, t, n)
    else:
        QR, QDR = np.tile(x_q, (kept, 1)), np.zeros((kept, n))
    res = SimulationResult(
        t=t, q=rec.q[:kept], qd=rec.qd[:kept], q_ref=QR, qd_ref=QDR,
        u=rec.u[:kept], current=rec.i[:kept], tau=rec.tau[:kept],
        joint_names=robot.joint_names, joint_types=tuple(robot.joint_types), robot=robot.name,
        payload_estimate=None if estimator is None else pk.estimate_series(est, dt),
        events=(plant.ev.log[:min(int(plant.ev.count[0]), len(plant.ev.log))].copy()
                if plant.ev.on else None),
        settings={"dt": dt, "t_end": t_end, "drives": bool(drives), "order": order,
                  "regulators": described, "generated": bool(gen[0]),
                  "integrator": integrator,
                  # the limits modelled as stops change the plant: the result says so
                  **({"joint_limits": "hard-stop"} if stops is not None else {}),
                  **({"pickup": picked[2]} if picked is not None else {}),
                  **({"estimator": estimator.describe()} if estimator is not None else {}),
                  **({"model_payload": model_payload}
                     if picked is not None or estimator is not None else {}),
                  **({"rtol": rtol, "atol": atol, "steps": int(stats[1]),
                      "rejected": int(stats[2]), "rhs_evaluations": int(stats[3]),
                      "steps_at_dt_above_tolerance": int(stats[4])}
                     if adaptive else {})},
    )
    unit = {nm: u for nm, u in res.units.items()}
    if status == 3:
        nm = robot.joint_names[joint]
        lo, hi = limits[joint]
        raise JointLimitExceeded(
            f"joint {nm!r} left its limits [{lo:.6g}, {hi:.6g}] {unit[nm]} at "
            f"t = {step * dt:.6g} s (q = {work.x[joint]:.6g} {unit[nm]}); the run stopped "
            "there (joint_limits='stop')", res)
    if status:
        what = "NaN in the state" if status == 1 else "speed above 1e4 rad/s (m/s)"
        where = f"joint {robot.joint_names[joint]!r}" if joint >= 0 else "a drive state"
        seen = f"{what} at {where}"
        cause = None if adaptive else _electrical_cause(robot, dtable, float(dt))
        raise SimulationDiverged(f"simulation diverged at t = {step * dt:.6g} s: "
                                 + (seen if cause is None else
                                    f"{cause} (the runaway was first seen as {seen})"), res)
    out = []
    excesses = {}
    for j, nm in enumerate(robot.joint_names):
        if work.excess[j, 0] > 0.0:
            excess = excesses[nm] = float(work.excess[j, 0] + tol[j])
            out.append(f"{nm!r} by up to {excess:.3g} {unit[nm]} (first at "
                       f"t = {work.excess[j, 1]:.6g} s; limits [{limits[j, 0]:.6g}, "
                       f"{limits[j, 1]:.6g}])")
    res._lazy_metrics(bool(drives) and robot.has_drives, dtable, excesses)
    if out:
        how = "" if joint_limits == "hard-stop" else " (not modelled as stops)"
        warnings.warn(f"{robot.name}: joints beyond their limits{how}: "
                      + "; ".join(out), ManipcadWarning, stacklevel=2)
    if (trajectory is not None and joint_limits != "ignore" and len(res.t)
            and np.isfinite(limits).any()):
        # a joint's reference leaves its limits iff its smallest or largest value does
        # (the differences round monotonically): each column's extremes, the (K, n)
        # excursions only for a joint that leaves (0.5 ms of a 1 s run at dt 1e-4 before)
        qr = res.q_ref
        lo, hi = (first_extremes if first is not None and qr is first[1]
                  and first_extremes is not None else _extremes(np.ascontiguousarray(qr)))
        over = np.maximum(limits[:, 0] - lo, hi - limits[:, 1]) - tol
        bad = np.flatnonzero(over > 0.0).tolist()
        if bad:
            ex = np.maximum(limits[:, 0] - qr, qr - limits[:, 1]) - tol
            warnings.warn(
                f"{robot.name}: the reference leaves the joint limits: " + "; ".join(
                    f"{robot.joint_names[j]!r} by up to {ex[:, j].max() + tol[j]:.3g} "
                    f"{unit[robot.joint_names[j]]} (first at t = "
                    f"{res.t[int(np.argmax(ex[:, j] > 0))]:.6g} s)" for j in bad),
                ManipcadWarning, stacklevel=2)
    return res




#: RK4's stability limit on the negative real axis: a mode x' = -x/T is integrated
#: stably for dt < RK4_REAL_LIMIT·T (|1 + z + z²/2 + z³/6 + z⁴/24| = 1 at z = -2.785)
RK4_REAL_LIMIT = 2.785


def _electrical_cause(robot: Robot, dtable: np.ndarray, dt: float) -> str | None:
    """Why a fixed-step RK4 run diverged when a drive's current is the cause, else None.

    A drive whose armature current is a state (inductance L > 0) has the electrical
    mode di/dt ≈ -(R/L)·i: RK4 is unstable on it for dt > 2.785·L/R and the current
    blows up first; the torque it makes then throws any joint (often another one)
    beyond the speed limit. The drive with the smallest time constant among those
    the step cannot resolve is named, with a step that works.

    Parameters:
        robot: the simulated robot (joint names).
        dtable: the packed drives (n, NPAR) the run used (R in Ω, L in H).
        dt: the RK4 step, s.

    Returns:
        a sentence naming the joint, its L, R, L/R (s) and a step that works, or None
        when every drive's electrical mode is within RK4's stability limit.

    Example:
        >>> import manipcad
        >>> from manipcad.drives.params import pack_drives
        >>> arm = manipcad.load_robot("puma560")         # L/R = 0.25 ms to 0.48 ms
        >>> _electrical_cause(arm, pack_drives(arm.drives), 1e-4) is None
        True
        >>> print(_electrical_cause(arm, pack_drives(arm.drives), 2e-3))  # doctest: +ELLIPSIS
        joint 'wrist_roll''s drive: the step dt = 0.002 s is too large ... use dt <= 0.00025 s, ...
    """

    worst = None
    for j, nm in enumerate(robot.joint_names):
        if int(dtable[j, P_KIND]) not in (KIND_RIGID, KIND_ELASTIC):
            continue
        L, R = float(dtable[j, P_L]), float(dtable[j, P_R])
        if not (L > 0.0 and R > 0.0):
            continue
        T = L / R
        if dt > RK4_REAL_LIMIT * T and (worst is None or T < worst[1]):
            worst = (nm, T, L, R)
    if worst is None:
        return None
    nm, T, L, R = worst
    return (f"joint {nm!r}'s drive: the step dt = {dt:.3g} s is too large for its electrical "
            f"time constant L/R = {L:.3g} H / {R:.3g} Ω = {T:.3g} s (RK4 is stable for "
            f"dt < {RK4_REAL_LIMIT}·L/R = {RK4_REAL_LIMIT * T:.3g} s): use dt <= {T:.2g} s, "
            f"or L: 0 for joint {nm!r} to neglect the inductance")


#: the integrators by name: None for the fixed-step RK4, else (the embedded pair of
#: :data:`manipcad.sim.adaptive.TABLEAUS`, the rigid drives' currents advanced exactly)
INTEGRATORS = {"rk4": None,
               "adaptive": ("dp54", False),
               "adaptive-exact": ("dp54", True),
               "adaptive-bs32": ("bs32", False),
               "adaptive-exact-bs32": ("bs32", True)}
#: what ``simulate(joint_limits=...)`` accepts
JOINT_LIMITS = ("warn", "stop", "ignore", "hard-stop")
#: the adaptive integrators' default tolerances: relative (-), absolute (rad, rad/s)
RTOL = 1e-6
ATOL = 1e-8


def _integrator_options(integrator, rtol, atol):
    """(None or (pair, exact) of :data:`INTEGRATORS`, rtol, atol) checked; one clear error
    naming the argument."""
    if not isinstance(integrator, str) or integrator not in INTEGRATORS:
        raise ManipcadError(f"integrator must be one of {', '.join(INTEGRATORS)}, got "
                            f"{integrator!r}")
    if integrator == "rk4":
        for name, v in (("rtol", rtol), ("atol", atol)):
            if v is not None:
                raise ManipcadError(f"{name} applies to the adaptive integrators only "
                                    "(the fixed-step RK4's accuracy is set by dt)")
        return None, None, None
    rtol = RTOL if rtol is None else rtol
    atol = ATOL if atol is None else atol
    try:
        rtol, atol = float(rtol), float(atol)
    except (TypeError, ValueError):
        raise ManipcadError(f"rtol and atol must be numbers, got {rtol!r}, {atol!r}") from None
    if not (1e-12 <= rtol <= 0.1):
        raise ManipcadError(f"rtol must be in [1e-12, 0.1] (relative error per step), "
                            f"got {rtol}")
    if not (atol > 0 and math.isfinite(atol)):
        raise ManipcadError(f"atol must be a finite number > 0 (rad, m, rad/s or m/s), "
                            f"got {atol}")
    return INTEGRATORS[integrator], rtol, atol


def _references(trajectory, x_q, t_rows, n):
    if trajectory is not None:
        return _reference(trajectory, t_rows, n)
    m = len(t_rows)
    return np.tile(x_q, (m, 1)), np.zeros((m, n)), np.zeros((m, n))


def _run_rk4(plant, ctrl, rec, work, K, dt, every, joint_limits, trajectory, x_q, dist_of,
             n, progress, first=None):
    """The fixed-step RK4 run, chunk by chunk; (status, step, joint, sampled): ``sampled``
    the times, q* and q̇* of the reference rows the loop ran on when the whole run was one
    chunk along a trajectory (else None). ``first``: the first chunk's times and reference
    rows (t, q*, q̇*, q̈*) when sampled already."""
    status, step, joint = 0, 0, -1
    sampled = None
    for k0 in range(0, K + 1, CHUNK):
        steps = min(CHUNK, K - k0)
        last = k0 + steps == K
        if k0 == 0 and first is not None:
            t_rows, rows = first[0], first[1:]
        else:
            t_rows = np.arange(k0, k0 + steps + 1) * dt
            rows = _references(trajectory, x_q, t_rows, n)
        ref = Reference(*rows, dist_of(k0, t_rows))
        status, step, joint = run(plant, ctrl, ref, rec, work, k0, steps, dt, every,
                                  last, joint_limits == "stop")
        if progress is not None:
            progress(min(1.0, (k0 + steps) / K))
        if status or last:
            if k0 == 0 and trajectory is not None:
                sampled = (t_rows, ref.q, ref.qd)
            break
    return status, step, joint, sampled


def _varies(disturbance) -> bool:
    """Does the disturbance change from step to step (callable or a table of rows)?"""
    if disturbance is None:
        return False
    if callable(disturbance):
        return True
    d = np.asarray(disturbance, dtype=float)
    return d.ndim == 2 and bool((d != d[:1]).any())


def _run_adaptive(plant, ctrl, rec, work, K, dt, every, joint_limits, trajectory, x_q,
                  dist_of, varies, n, rtol, atol, progress, pair, exact):
    """The adaptive run, chunk by chunk; (status, step, joint, counters).

    The reference is sampled only at the regulators' sample grid (the gcd of their
    periods in steps); a disturbance that changes every step makes every step a
    hold interval (and the grid every step).
    """
    stride = int(np.gcd.reduce(ctrl.steps)) if len(ctrl.steps) else max(K, 1)
    hold = K + 1
    if varies:
        stride, hold = 1, 1
    stats = np.zeros(STATS)
    tab = TABLEAUS[pair]
    chunk = CHUNK * stride
    status, step, joint = 0, 0, -1
    for k0 in range(0, K + 1, chunk):
        steps = min(chunk, K - k0)
        last = k0 + steps == K
        t_rows = (k0 + stride * np.arange(steps // stride + 1)) * dt
        ks = k0 + stride * np.arange(steps // stride + 1)
        ref = Reference(*_references(trajectory, x_q, t_rows, n),
                        _rows_at(dist_of, k0, ks, dt, stride))
        status, step, joint = run_adaptive(plant, ctrl, ref, rec, work, k0, steps, dt, every,
                                           last, joint_limits == "stop", stride, hold, tab,
                                           rtol, atol, stats, exact)
        if progress is not None:
            progress(min(1.0, (k0 + steps) / K))
        if status or last:
            break
    return status, step, joint, stats


def _rows_at(dist_of, k0, ks, dt, stride):
    """Disturbance rows at the steps ks (the source gives consecutive steps from k0)."""
    if stride == 1:
        return dist_of(k0, ks * dt)
    return np.ascontiguousarray(dist_of(k0, ks * dt)[:1].repeat(len(ks), axis=0))


def _vec(x, n: int, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.shape != (n,) or not np.isfinite(a).all():
        raise ManipcadError(f"{name} must be a finite vector of shape ({n},), got {a.shape}")
    return a.copy()


def _reference(trajectory, t: np.ndarray, n: int):
    q, qd, qdd = trajectory.sample(t)
    arrays = [np.ascontiguousarray(a, dtype=float) for a in (q, qd, qdd)]
    for a in arrays:
        if a.shape != (len(t), n):
            raise ManipcadError(f"trajectory has {a.shape[-1]} joints, the robot {n}")
        if not np.isfinite(a).all():
            raise ManipcadError("trajectory samples hold NaN or infinite values")
    return arrays


#: per joint count, zero disturbance rows shared by the runs without a disturbance (the
#: compiled cores only read a Reference's rows): not zero-filled again at every call
#: (0.48 MB for 10,001 rows of 6 joints), at most a chunk's rows (CHUNK + 1) each
_ZEROS: dict[int, np.ndarray] = {}


def _zero_rows(m: int, n: int) -> np.ndarray:
    """(m, n) zeros, a C-contiguous view of :data:`_ZEROS` (never to be written)."""
    z = _ZEROS.get(n)
    if z is None or z.shape[0] < m:
        z = _ZEROS[n] = np.zeros((max(m, CHUNK + 1), n))
    return z[:m]


def _disturbance_source(disturbance, K: int, n: int):
    """A function (first step, times of the chunk) -> disturbance rows (len(t), n), N·m."""
    if disturbance is None:
        return lambda k0, t: _zero_rows(len(t), n)
    if callable(disturbance):
        def rows(k0, t):
            d = np.asarray(disturbance(t), dtype=float)
            if d.shape == (n,):
                d = np.broadcast_to(d, (len(t), n))
            if d.shape != (len(t), n) or not np.isfinite(d).all():
                raise ManipcadError(f"disturbance(t) must return finite values of shape "
                                    f"({len(t)}, {n}), got {d.shape}")
            return np.ascontiguousarray(d)
        return rows
    try:
        d = None if isinstance(disturbance, str | bytes) else np.asarray(disturbance, float)
    except (TypeError, ValueError):
        d = None
    if d is None:
        raise InputError("simulate", "disturbance", f"expected joint torques (N·m or N): "
                         f"an ({n},) array, a ({K + 1}, {n}) array of one row per step, or "
                         f"a function of the times t (s) returning (len(t), {n}); got "
                         f"{type(disturbance).__name__} {disturbance!r}"[:300])
    if d.shape not in ((n,), (K + 1, n)) or not np.isfinite(d).all():
        raise ManipcadError(f"disturbance must be finite with shape ({n},) or "
                            f"({K + 1}, {n}), got {d.shape}")
    if d.shape == (n,):
        return lambda k0, t: np.ascontiguousarray(np.broadcast_to(d, (len(t), n)))
    return lambda k0, t: np.ascontiguousarray(d[k0:k0 + len(t)])


def _packed_drives(robot: Robot, drives: bool, transmissions, order):
    """(dtable, off, rtable): the drives packed (:func:`pack_drives`; none with ``drives``
    False), their states' offsets and the robot's body table with the drives'
    joint-referred terms (:func:`joint_referred_terms`); new arrays at every call (the
    loop writes rtable at a pickup).

    Packed once per robot, ``drives`` and ``order`` when the drives' own transmissions
    serve (``transmissions`` None), and kept on the robot as its :attr:`Robot.table` is
    (a Robot and its Drives are frozen): 0.05-0.1 ms of every :func:`simulate` call
    (docs/performance.md).
    """
    key = (drives, order)
    cache = (robot.__dict__.setdefault("_sim_drives", {})
             if transmissions is None and type(order) is int else {})
    hit = cache.get(key)
    if hit is None:
        dtable = (pack_drives(robot.drives, transmissions, order=order) if drives
                  else pack_drives([None] * robot.n))
        rtable = np.array(robot.table)
        rtable[:, [COL_JR, COL_BV, COL_FCP, COL_FCN]] = joint_referred_terms(dtable)
        hit = cache[key] = (dtable, state_offsets(dtable), rtable)
    return tuple(a.copy() for a in hit)


@nb.njit(cache=True)
def _extremes(a):
    """Each column's smallest and largest value of a C-contiguous (K, n) array, K >= 1:
    (2, n). One pass over the values in blocks of L = lcm(n, 8) (whole SIMD registers of
    eight, each lane one column), then the lanes and the last rows per column: the same
    values as numpy's per-column min and max, 31 against 65 us on 10,001 x 6 (the
    row-by-row loop; numpy's 12 strided reductions some 0.1 ms)."""
    K, n = a.shape
    flat = a.reshape(-1)
    N = flat.shape[0]
    L = n * (8 // math.gcd(n, 8))
    out = np.empty((2, n))
    for j in range(n):
        out[0, j] = flat[j]
        out[1, j] = flat[j]
    m = (N // L) * L
    if m >= L:
        lo = flat[:L].copy()
        hi = lo.copy()
        for i in range(L, m, L):
            for p in range(L):
                v = flat[i + p]
                lo[p] = v if v < lo[p] else lo[p]
                hi[p] = v if v > hi[p] else hi[p]
        for p in range(L):
            j = p % n
            if lo[p] < out[0, j]:
                out[0, j] = lo[p]
            if hi[p] > out[1, j]:
                out[1, j] = hi[p]
    for i in range(m, N):
        j = i % n
        v = flat[i]
        if v < out[0, j]:
            out[0, j] = v
        if v > out[1, j]:
            out[1, j] = v
    return out


def _events(robot: Robot, dtable, rtable, drives: bool, qd0, nx: int, stops=None):
    """The plant's stick-slip friction, gear losses and hard stops (:mod:`manipcad.sim.events`):
    the rigid drives' joint-referred dry friction and gear efficiencies; ``stops`` (n, 2)
    the joints' hard stops, rad or m, or None."""

    kinds = dtable[:, P_KIND].astype(np.int64)
    rigid = drives & ((kinds == KIND_RIGID) | (kinds == KIND_RIGID_STATIC))
    eta = np.array([1.0 if d is None else float(d.efficiency) for d in robot.drives])
    static = np.array([(0.0, 0.0) if d is None else
                       (abs(d.ratio) * d.static_friction[0], abs(d.ratio) * d.static_friction[1])
                       for d in robot.drives]).reshape(-1, 2)
    return events_part(friction_table(dtable, rtable, eta, rigid, static), qd0, nx, stops)


def _drive_initial_state(dtable, off, q, qd) -> np.ndarray:
    """Drive states at rest with the joint: zero current, motor at i_r·q (elastic kinds)."""

    xd = np.zeros(off[-1])
    for j in range(len(q)):
        if int(dtable[j, P_KIND]) in (KIND_ELASTIC, KIND_ELASTIC_STATIC):
            xd[off[j]] = dtable[j, P_RATIO] * q[j]
            xd[off[j] + 1] = dtable[j, P_RATIO] * qd[j]
    return xd


def _flatten(regulators) -> list[Regulator]:
    if regulators is None:
        return []
    if isinstance(regulators, Regulator):
        return [regulators]
    out = []
    for r in regulators:
        out += _flatten(r) if isinstance(r, list | tuple) else [r]
    for r in out:
        if not isinstance(r, Regulator):
            raise ManipcadError(f"regulators must be Regulator objects, got {type(r).__name__}")
    return out


def _pack_regulators(robot: Robot, regulators, dt: float, est, t_end: float):
    """The regulators as a :class:`~manipcad.sim.loop.Control` (parameters packed once)
    with the compiled estimator ``est`` (:func:`manipcad.sim.pickup.estimator_part`); a
    period longer than the run (``t_end``, s) is refused naming it."""
    n = robot.n
    regs = _flatten(regulators)
    R = len(regs)
    kind = np.zeros(R, dtype=np.int64)
    params = np.zeros((R, NPARAM))
    state = np.zeros((R, NSTATE))
    joints = np.zeros((R, n), dtype=np.int64)
    nj = np.zeros(R, dtype=np.int64)
    steps = np.ones(R, dtype=np.int64)
    described = {}
    owner: dict[int, int] = {}
    need_comp = False
    for r, reg in enumerate(regs):
        idx = []
        for jt in reg.joints:
            try:
                j = robot.joint_index(jt)
            except (ManipcadError, KeyError, IndexError, ValueError):
                raise ManipcadError(f"regulator {reg.method!r}: robot {robot.name!r} has no "
                                    f"joint {jt!r}") from None
            named = reg.joint_names[len(idx)] if len(reg.joint_names) > len(idx) else None
            if named is not None and named != robot.joint_names[j]:
                # made for another robot: its joint k is not this one's (the CLI refuses the
                # same by the file's joint names)
                raise ManipcadError(
                    f"regulator {reg.method!r} was made for joint {named!r}"
                    + (f" of {reg.robot!r}" if reg.robot else "")
                    + f", but joint {jt!r} of {robot.name!r} is {robot.joint_names[j]!r}: "
                    "give the regulators of this robot (synthesize them for it)")
            if j in owner:
                raise ManipcadError(f"two regulators for joint {robot.joint_names[j]!r}")
            owner[j] = r
            idx.append(j)
        s = reg.period / dt
        if reg.period > t_end:
            raise ManipcadError(period_too_long(reg.period, robot.joint_names[idx[0]], t_end))
        if abs(s - round(s)) > 1e-6 * s or round(s) < 1:
            raise ManipcadError(f"regulator period {reg.period:g} s of joint "
                                f"{robot.joint_names[idx[0]]!r} is not a multiple of "
                                f"dt = {dt:g} s")
        kind[r] = kind_of(reg.method)
        params[r] = reg.params
        state[r] = reg.initial_state()
        joints[r, :len(idx)] = idx
        nj[r] = len(idx)
        steps[r] = int(round(s))
        need_comp = need_comp or any(s_ in MODEL_SIGNALS for s_ in reg.needs)
        described[", ".join(robot.joint_names[j] for j in idx)] = reg.describe()
    return Control(kind, params, state, joints, nj, steps, need_comp, est), described


def period_too_long(period: float, joint: str, t_end: float) -> str:
    """Why a regulator period longer than the run is refused (the message, one line).

    Args:
        period: the regulator's sample period, s.
        joint: the (first) joint it controls.
        t_end: the run's length, s.

    Returns:
        the sentence naming the period, the joint and the run's length.

    Example:
        >>> period_too_long(1e6, "waist", 0.05)  # doctest: +ELLIPSIS
        "regulator period 1e+06 s of joint 'waist' is longer than the run (0.05 s): ..."
    """
    return (f"regulator period {period:g} s of joint {joint!r} is longer than the run "
            f"({t_end:g} s): the regulator would compute its output once, at t = 0, and "
            "hold it; give the period the regulator runs at (a few ms for a joint loop)")


__all__ = ["simulate", "SimulationResult", "SimulationDiverged", "JointLimitExceeded"]
