"""The closed loop of a run, built once: the plant (body table, drives, friction and stop
events, payload pickup, the compiled kernels) and the control (the regulators packed, the
online estimator), packed into the structures the compiled cores read
(:class:`~manipcad.sim.loop.Plant`, :class:`~manipcad.sim.loop.Control`), with the start
state.

:func:`start_state` samples the reference's start (and the first chunk of it for RK4) and
checks that the arm can move from there; :func:`build` packs the rest. Which compiled
kernels the plant calls is chosen in one place, :func:`pick_kernels`. The drives' packing
of a robot is kept per robot object (:data:`_DRIVES`, beside the frozen robot, never on
it): 0.05-0.1 ms of every :func:`~manipcad.sim.simulate` call.
"""

from __future__ import annotations

from typing import NamedTuple

import numpy as np

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
    P_RATIO,
    joint_referred_terms,
    pack_drives,
    state_offsets,
)
from manipcad.dynamics.api import moves_mass, not_positive_definite
from manipcad.errors import ManipcadError
from manipcad.model.robot import COL_BV, COL_FCN, COL_FCP, COL_JR, Robot
from manipcad.objcache import PerObject
from manipcad.sim import joint_limits as jl
from manipcad.sim.events import events_part, friction_table, gear_part
from manipcad.sim.integrate import CHUNK, INTEGRATORS, reference_rows
from manipcad.sim.loop import Control, Plant


class Start(NamedTuple):
    """Where a run starts.

    Attributes:
        q, qd: (n,) initial joint positions (rad or m) and velocities (rad/s or m/s);
            without a trajectory the reference holds q.
        first: RK4 along a trajectory: the first chunk's times (s) and reference rows
            (t, q*, q̇*, q̈*), sampled once; else None.
        first_extremes: (2, n) the first chunk's q* column extremes when its limit check
            wants them (read while the rows are in the cache), else None.
    """

    q: np.ndarray
    qd: np.ndarray
    first: tuple | None
    first_extremes: np.ndarray | None


def start_state(robot: Robot, n: int, steps: int, dt: float, trajectory, q0, qd0,
                drives: bool, adaptive: bool, joint_limits: str) -> Start:
    """The :class:`Start` of a run of ``steps`` steps of ``dt`` s (q0, qd0 checked: finite,
    (n,)); refused naming why when the arm cannot move from it (a joint moving no mass)."""
    # RK4 along a trajectory: the first chunk's rows sampled once, here; where each row
    # depends on its own time only (Trajectory.rows_independent), their first row is the
    # start (the same numbers as a sample of t = 0 alone)
    first = first_extremes = None
    if trajectory is None:
        q_start = np.zeros(n) if q0 is None else _vec(q0, n, "q0")
    else:
        if not adaptive:
            t_first = np.arange(min(CHUNK, steps) + 1) * float(dt)
            first = (t_first, *reference_rows(trajectory, t_first, n))
            if jl.watches_reference(robot, joint_limits):
                # the reference's extremes for its limit check, read now while q* is in
                # the cache (after the run it is not: 0.1 ms against 0.03 ms)
                first_extremes = jl.column_extremes(first[1])
        if first is not None and getattr(trajectory, "rows_independent", False):
            q_start = first[1][0]
        else:
            q_start = reference_rows(trajectory, np.zeros(1), n)[0][0]
    x_q = q_start.copy() if q0 is None else _vec(q0, n, "q0")
    x_qd = np.zeros(n) if qd0 is None else _vec(qd0, n, "qd0")
    if not moves_mass(robot, x_q, bool(drives) and robot.has_drives):
        raise ManipcadError(f"cannot simulate {robot.name!r} from its initial state: "
                            f"{not_positive_definite(0)}")
    return Start(x_q, x_qd, first, first_extremes)


def _vec(x, n: int, name: str) -> np.ndarray:
    a = np.asarray(x, dtype=float)
    if a.shape != (n,) or not np.isfinite(a).all():
        raise ManipcadError(f"{name} must be a finite vector of shape ({n},), got {a.shape}")
    return a.copy()


class ClosedLoop(NamedTuple):
    """A run's closed loop, packed for the compiled cores.

    Attributes:
        plant: the :class:`~manipcad.sim.loop.Plant`.
        ctrl: the :class:`~manipcad.sim.loop.Control` (regulators and estimator).
        x0: the initial state (q, q̇, the drives' states).
        dtable: (n, NPAR) the drives packed (:func:`~manipcad.drives.params.pack_drives`).
        bounds: the joint limits watched (:class:`manipcad.sim.joint_limits.Bounds`).
        described: joints -> the regulator's description (the result's settings).
        generated: the robot's generated kernels run (else the general ones).
        generic: a drive of another kind than rigid (elastic gears, backlash).
        est: the estimator's packed part (:func:`manipcad.sim.pickup.estimator_part`).
    """

    plant: Plant
    ctrl: Control
    x0: np.ndarray
    dtable: np.ndarray
    bounds: jl.Bounds
    described: dict
    generated: bool
    generic: bool
    est: object


def build(robot: Robot, start: Start, *, dt: float, t_end: float, steps: int,
          regulators, drives: bool, transmissions, order, use_generated: bool,
          joint_limits: str, picked, estimator, model_payload: str,
          integrator: str, adaptive: bool) -> ClosedLoop:
    """Pack the closed loop of a run (arguments as :func:`manipcad.sim.simulate`'s, checked
    by :func:`manipcad.sim.arguments.check`; ``picked`` the pickup's robots,
    :func:`manipcad.sim.pickup.picked_robot`, or None).

    Raises:
        ManipcadError: drives asked of a robot without them, a q0 beyond its stops, a
            regulator that does not fit the robot or the run, an exact-current adaptive
            integrator with elastic gears or a pickup off the sample grid.
    """
    # deferred: start-up cost: keeps manipcad.sim.pickup out of import manipcad
    from manipcad.sim import pickup as pk

    n = robot.n
    if drives and not robot.has_drives:
        raise ManipcadError(f"robot {robot.name!r} has no drives; use drives=False")
    dtable, off, rtable = packed_drives(robot, bool(drives), transmissions, order)
    x0 = np.concatenate([start.q, start.qd, _drive_initial_state(dtable, off, start.q,
                                                                 start.qd)])
    generic = any(int(dtable[j, P_KIND]) not in (KIND_NONE, KIND_RIGID, KIND_RIGID_STATIC)
                  for j in range(n))
    gen = pick_kernels(robot, rtable, use_generated and picked is None and estimator is None)
    b = jl.bounds(robot, joint_limits, start.q)
    ctable = np.array(robot.table)  # the regulators' model (a pickup or the estimator edit it)
    plant = Plant(rtable, ctable, np.asarray(robot.gravity, float),
                  dtable, off, bool(drives), generic, b.wide, *gen,
                  pk.no_pickup() if picked is None else
                  pk.pickup_part(picked[0], picked[1], dtable, model_payload == "true"),
                  _events(robot, dtable, rtable, bool(drives), start.qd, len(x0), b.stops,
                          off, x0))
    est = pk.estimator_part(estimator, robot, dt, steps, ctable,
                            feed=model_payload == "online", drives=bool(drives))
    ctrl, described = pack_regulators(robot, regulators, dt, est, t_end)
    if adaptive:
        pk.check_adaptive(integrator, None if picked is None else picked[1], ctrl, dt)
    if adaptive and INTEGRATORS[integrator][1] and generic:
        raise ManipcadError(f"integrator={integrator!r} advances rigid drives' currents "
                            "exactly; elastic gears and backlash (transmissions=...) need "
                            "integrator='rk4', 'adaptive' or 'adaptive-bs32'")
    return ClosedLoop(plant, ctrl, x0, dtable, b, described, bool(gen[0]), generic, est)


def pick_kernels(robot: Robot, rtable: np.ndarray, use_generated: bool) -> tuple:
    """The compiled kernels the plant calls: ``(generated, forward_dynamics, mass_matrix,
    moment_components)`` (:func:`manipcad.codegen.simulation_kernels`): the robot's
    generated ones when asked and they serve the body table ``rtable``, else the general
    ones."""
    return simulation_kernels(robot, rtable, use_generated=use_generated)


#: per robot object, (drives, order) -> its packed drives (:func:`packed_drives`)
_DRIVES = PerObject()


def packed_drives(robot: Robot, drives: bool, transmissions, order):
    """(dtable, off, rtable): the drives packed (:func:`pack_drives`; none with ``drives``
    False), their states' offsets and the robot's body table with the drives'
    joint-referred terms (:func:`joint_referred_terms`); new arrays at every call (the
    loop writes rtable at a pickup).

    Packed once per robot, ``drives`` and ``order`` when the drives' own transmissions
    serve (``transmissions`` None), and kept beside the robot object (:data:`_DRIVES`; a
    Robot and its Drives are frozen): 0.05-0.1 ms of every simulate call
    (docs/performance.md).
    """
    key = (drives, order)
    cache = {}
    if transmissions is None and type(order) is int:
        cache = _DRIVES.get(robot)
        if cache is None:
            cache = {}
            _DRIVES.set(robot, cache)
    hit = cache.get(key)
    if hit is None:
        dtable = (pack_drives(robot.drives, transmissions, order=order) if drives
                  else pack_drives([None] * robot.n))
        rtable = np.array(robot.table)
        rtable[:, [COL_JR, COL_BV, COL_FCP, COL_FCN]] = joint_referred_terms(dtable)
        hit = cache[key] = (dtable, state_offsets(dtable), rtable)
    return tuple(a.copy() for a in hit)




def _events(robot: Robot, dtable, rtable, drives: bool, qd0, nx: int, stops=None, off=None,
            x0=None):
    """The plant's stick-slip friction, gear losses and hard stops (:mod:`manipcad.sim.events`):
    the rigid drives' joint-referred dry friction and gear efficiencies; ``stops`` (n, 2)
    the joints' hard stops, rad or m, or None; the elastic gears' backlash and motor
    shafts from the drive states' offsets ``off`` and the initial state ``x0``."""

    kinds = dtable[:, P_KIND].astype(np.int64)
    rigid = drives & ((kinds == KIND_RIGID) | (kinds == KIND_RIGID_STATIC))
    eta = np.array([1.0 if d is None else float(d.efficiency) for d in robot.drives])
    static = np.array([(0.0, 0.0) if d is None else
                       (abs(d.ratio) * d.static_friction[0], abs(d.ratio) * d.static_friction[1])
                       for d in robot.drives]).reshape(-1, 2)
    gears = (None if off is None or not drives else
             gear_part(dtable, off, x0, [(0.0, 0.0) if d is None else d.static_friction
                                         for d in robot.drives]))
    return events_part(friction_table(dtable, rtable, eta, rigid, static), qd0, nx, stops,
                       gears)


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


def pack_regulators(robot: Robot, regulators, dt: float, est, t_end: float):
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




__all__ = ["Start", "start_state", "ClosedLoop", "build", "pick_kernels", "packed_drives",
           "pack_regulators", "period_too_long"]
