"""Verify a regulator's promise against the coupled simulation.

A regulator synthesized for an accuracy (``spec={"max_error": ...}`` with a reference:
``ace_de``, ``ace_tf``) promises the error its *nominal* loop reaches on that reference
(``design["nominal_max_error"]``). The nominal loop is one drive at one load; the robot
adds the inertial coupling Σ_{k≠i} H_ik·q̈_k, which a decentralized law does not see, the
velocity and gravity torques, friction and the amplifier limit. :func:`verify` simulates
the whole robot along the trajectory with the regulators and compares two things apart:

- the accuracy *asked* (``accuracy=``, else what each regulator was synthesized for,
  ``design["max_error"]``): the run's tracking check, one of every check the run makes
  against every rating (:func:`manipcad.sim.checks.run_checks`, docs/checks.md); this is
  the verdict;
- the nominal *promise*: exceeded by more than ``factor`` (default 2) is reported, with
  the coupling share of that joint along the trajectory
  (:func:`manipcad.analysis.coupling.coupling_analysis`) as the first suspect. A joint
  within the accuracy asked but far over its promise meets the requirement: the promise
  was tighter than asked.
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field

import numpy as np

from manipcad.analysis.coupling import coupling_analysis
from manipcad.control import synthesize
from manipcad.errors import ManipcadError, ManipcadWarning
from manipcad.sim import simulate
from manipcad.sim.checks import RunChecks, _per_joint, run_checks


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
        met: True when simulated <= the accuracy asked, None when none was asked.
        accuracy: the accuracy the run is judged against (``accuracy=``, else ``asked``),
            rad or m, None when none.
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
    met: bool | None = None
    accuracy: float | None = None


def verify(robot, trajectory, regulators, *, dt: float = 1e-4, factor: float = 2.0,
           t_end: float | None = None, accuracy=None, payload=None
           ) -> tuple[list[PromiseCheck], object]:
    """Simulate the robot with the regulators along the trajectory; check every rating, the
    accuracy asked and each promise.

    Args:
        robot: the robot (with drives).
        trajectory: the reference (a trajectory object).
        regulators: the regulators (joints without one get U = 0).
        dt: integration step, s.
        factor: a promise is missed when the simulation's error exceeds it this many times.
        t_end: simulated time, s (default the trajectory's duration).
        accuracy: the accuracy asked, rad or m: one value, one per joint or {joint:
            value}; None: each regulator's own ``design["max_error"]`` (joints without
            one get no tracking check).
        payload: a payload for the run (kg, or a dict as ``simulate`` takes).

    Returns:
        (one :class:`PromiseCheck` per regulator joint, the simulation result); the
        result's ``checks`` holds every run check ({joint: {check: {value, limit, unit,
        verdict}}}; :meth:`manipcad.sim.checks.RunChecks.from_dict` reads it).

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

    if not (math.isfinite(factor) and factor >= 1):
        raise ManipcadError(f"factor must be >= 1, got {factor}")

    t_end = float(trajectory.duration) if t_end is None else float(t_end)
    res = simulate(robot, t_end=t_end, dt=dt, trajectory=trajectory, regulators=regulators,
                   payload=payload)
    report = coupling_analysis(robot, trajectory, dt=max(dt, 1e-3))
    share = {jc.joint: jc.coupling_ratio for jc in report.joints}
    flat = []
    for r in regulators:
        flat += r if isinstance(r, list) else [r]
    # the accuracy asked, per joint: given, else what each regulator was designed for
    given = _per_joint(accuracy, robot.joint_names, "accuracy")
    acc = {}
    for reg in flat:
        for j in reg.joints:
            j = robot.joint_index(j)
            a = given[j] if not math.isnan(given[j]) else reg.design.get("max_error")
            acc[robot.joint_names[j]] = None if a is None else float(a)
    for j, nm in enumerate(robot.joint_names):
        if nm not in acc and not math.isnan(given[j]):
            acc[nm] = float(given[j])
    res.checks = run_checks(res, robot, accuracy=acc, payload=payload).to_dict()
    out = []
    for reg in flat:
        promised = reg.design.get("nominal_max_error")
        asked = reg.design.get("max_error")
        for j in reg.joints:
            j = robot.joint_index(j)
            name = robot.joint_names[j]
            e = float(np.abs(res.error[:, j]).max())
            c = float(share.get(name, math.nan))
            a = acc.get(name)
            met = None if a is None else e <= a
            against = ("" if a is None else
                       f"{'within' if met else 'over'} the {a:.3g} asked ({e:.3g}); ")
            if promised is None:
                out.append(PromiseCheck(name, reg.method, None, asked, e, None, c, None,
                                        against + "no promise (synthesized without "
                                        "max_error)", met, a))
                continue
            ratio = e / promised
            kept = ratio <= factor
            why = against + (
                f"promise kept: {e:.3g} against {promised:.3g} promised" if kept else
                f"promise exceeded ×{ratio:.3g}: {e:.3g} against {promised:.3g} promised by "
                f"the nominal loop; the inertial coupling Σ H_ik·q̈_k is {100 * c:.0f} % of "
                f"the joint's own inertial torque along the trajectory, and the "
                f"decentralized law does not see it"
                + ("" if c >= 0.1 else " (small here: look at friction, the amplifier "
                   "limit, the other joints' regulators)"))
            if not kept:
                warnings.warn(f"{robot.name}: {name} ({reg.method}): {why}", ManipcadWarning,
                              stacklevel=2)
            out.append(PromiseCheck(name, reg.method, float(promised), asked, e, ratio, c,
                                    kept, why, met, a))
    return out, res


@dataclass
class SpecRound:
    """One round of :func:`synthesize_to_spec`: per joint, the nominal target and the
    coupled simulation's max |e|, rad or m, and the run checks other than the tracking
    that fail (:func:`manipcad.sim.checks.run_checks`: saturation, chattering, currents,
    gear and joint limits)."""

    targets: dict[str, float]
    simulated: dict[str, float]
    failing: dict[str, list[str]] = field(default_factory=dict)


@dataclass
class SpecDesign:
    """Regulators designed for an accuracy on the coupled model (:func:`synthesize_to_spec`).

    Attributes:
        regulators: the regulators of the joints asked, as last simulated.
        others: the regulators that held the other driven joints in the simulations.
        asked: the accuracy asked, rad or m.
        simulated: per joint, max |e| of the last coupled simulation, rad or m.
        reached: True when every joint asked is within ``asked`` in that simulation.
        rounds: every round's nominal targets and simulated errors.
        why: in words: reached, or why not (the joint, its best error, what stopped it).
        result: the last simulation result.
        checks: the run checks of the last simulation
            (:class:`~manipcad.sim.checks.RunChecks`, tracking against ``asked``).
    """

    regulators: list
    others: list
    asked: float
    simulated: dict[str, float]
    reached: bool
    rounds: list[SpecRound]
    why: str
    result: object
    checks: object = None

    @property
    def held(self) -> str:
        """The other regulators in words (:func:`held_by`)."""
        return held_by(self.others)


def held_by(regulators) -> str:
    """Regulators in words: their joints and method, e.g. "lift (pid), reach (pid)" (""
    for none)."""
    return ", ".join(f"{', '.join(r.joint_names)} ({r.method})" for r in regulators)


def synthesize_to_spec(robot, trajectory, joints, method: str, *, spec: dict,
                       others=None, rounds: int = 6, margin: float = 0.8, dt: float = 1e-4,
                       t_end: float | None = None, **options) -> SpecDesign:
    """Design for ``spec["max_error"]`` against the coupled simulation: verify and tighten.

    The method's own accuracy design (``ace_de``, ``ace_tf``: the smallest bandwidth whose
    nominal loop keeps |q* − q| <= the target on the trajectory) makes its promise on one
    drive at one load; the robot adds the inertial coupling, the velocity and gravity
    torques, friction and the amplifier limit. Round k synthesizes every joint asked for
    its target (round 0: the accuracy asked), simulates the whole robot along the
    trajectory and, for each joint whose max |e| exceeds the accuracy asked, lowers its
    target to min(target, promise)·asked/simulated·``margin`` (the promise: the error its
    nominal loop reaches, at most the target); where the nominal design cannot reach that
    target, the step is halved geometrically toward the promise (up to 4 times). It stops
    when every joint is within the accuracy asked, when no joint's design can be tightened
    (the nominal design reports "unreachable accuracy": the bandwidth the period and the
    inductance allow is spent),
    or after ``rounds`` simulations, and says which.

    The verdict is every run check of the coupled simulation on the joints asked
    (:func:`manipcad.sim.checks.run_checks`, the tracking against the accuracy asked): a
    joint meets the spec when its tracking is within it and no other check fails. A
    failing check other than the tracking (the amplifier saturated, chattering, a current
    or gear torque above its rating, a joint limit) stops the loop: a higher bandwidth
    would not cure it. Checks whose rating is unknown do not block.

    Args:
        robot: the robot (with drives).
        trajectory: the reference (a trajectory object), also the design reference.
        joints: joint indices or names to design for.
        method: a method whose spec takes ``max_error`` (``ace_de``, ``ace_tf``).
        spec: the spec, with ``max_error`` (rad or m) and the method's other keys.
        others: regulators for the driven joints not in ``joints`` (default: ``pid``
            with its default spec on each).
        rounds: the most coupled simulations, >= 1.
        margin: factor < 1 applied to each tightening.
        dt: integration step, s.
        t_end: simulated time, s (default the trajectory's duration).
        **options: the method's options (``period``, ...).

    Returns:
        A :class:`SpecDesign`.

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> laws = manipcad.load_trajectory("examples/fig3_laws.yaml")
        >>> d = synthesize_to_spec(arm, laws, ["turn"], "ace_de", spec={"max_error": 1e-3},
        ...                        others=manipcad.synthesize(arm, ["lift", "reach"], "lqr"),
        ...                        t_end=0.2)
        >>> d.reached, len(d.rounds)
        (True, 1)
    """

    spec = dict(spec or {})
    if "max_error" not in spec:
        raise ManipcadError("synthesize_to_spec needs spec max_error (rad or m)")
    asked = float(spec["max_error"])
    if not (math.isfinite(asked) and asked > 0):
        raise ManipcadError(f"spec max_error must be > 0, got {asked}")
    if int(rounds) < 1:
        raise ManipcadError(f"rounds must be >= 1, got {rounds}")
    if not 0 < margin < 1:
        raise ManipcadError(f"margin must be in (0, 1), got {margin}")
    idx = [robot.joint_index(j) for j in joints]
    names = {j: robot.joint_names[j] for j in idx}
    if others is None:
        driven = [j for j in range(robot.n) if robot.drives and robot.drives[j] is not None
                  and j not in idx]
        others = [synthesize(robot, j, "pid") for j in driven]
    else:
        others = others if isinstance(others, list) else [others]
    target = {j: asked for j in idx}
    regs = {j: synthesize(robot, j, method, spec={**spec, "max_error": asked},
                          reference=trajectory, **options) for j in idx}
    frozen: dict[int, str] = {}
    history: list[SpecRound] = []
    best: dict[int, tuple[float, object]] = {}
    res = None
    for k in range(int(rounds)):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ManipcadWarning)
            checks, res = verify(robot, trajectory, [regs[j] for j in idx] + others, dt=dt,
                                 t_end=t_end, accuracy={names[j]: asked for j in idx})
        err = {robot.joint_index(c.joint): c.simulated for c in checks
               if robot.joint_index(c.joint) in regs}
        run = RunChecks.from_dict(res.checks)
        failing = {names[j]: [c for c, chk in run[names[j]].items()
                              if c != "tracking" and chk.verdict == "fail"] for j in idx}
        failing = {nm: f for nm, f in failing.items() if f}
        history.append(SpecRound({names[j]: target[j] for j in idx},
                                 {names[j]: err[j] for j in idx}, failing))
        for j in idx:
            if j not in best or err[j] < best[j][0]:
                best[j] = (err[j], regs[j])
        missing = [j for j in idx if err[j] > asked]
        if not missing or failing or k == int(rounds) - 1:
            break
        moved = False
        for j in missing:
            if j in frozen:
                continue
            promised = min(target[j], regs[j].design.get("nominal_max_error") or target[j])
            t_new = promised * asked / err[j] * margin
            for _ in range(4):   # unreachable: halve the step (geometrically) toward the promise
                try:
                    regs[j] = synthesize(robot, j, method, spec={**spec, "max_error": t_new},
                                         reference=trajectory, **options)
                except ManipcadError as exc:
                    if "unreachable" not in str(exc):
                        raise
                    frozen[j] = str(exc)
                    t_new = math.sqrt(t_new * promised)
                    continue
                frozen.pop(j, None)
                target[j] = t_new
                moved = True
                break
        if not moved:
            break
    last = {names[j]: float(history[-1].simulated[names[j]]) for j in idx}
    failing = history[-1].failing
    unknown = sorted({c for j in idx for c, chk in run[names[j]].items()
                      if chk.verdict == "unknown"})
    reached = all(v <= asked for v in last.values()) and not failing
    # the joints held by the other regulators: not designed here, yet the same coupled run
    elsewhere: dict[str, list[str]] = {}
    for joint, check, _ in run.failures():
        if joint not in last:
            elsewhere.setdefault(joint, []).append(check)
    if reached:
        why = (f"reached: {', '.join(last)} within {asked:g} in the coupled simulation after "
               f"{len(history)} round(s), no run check of "
               f"{'theirs' if len(last) > 1 else 'its'} failing"
               + (f" ({', '.join(unknown)} unknown: ratings not given)" if unknown else ""))
    elif failing:
        why = ("not reached: the coupled simulation fails run checks other than the "
               "tracking (a tighter design would not cure them): "
               + "; ".join(f"{nm}: {', '.join(f)} (max |e| {last[nm]:.3g})"
                           for nm, f in failing.items()))
    else:
        parts = []
        for j in idx:
            if last[names[j]] <= asked:
                continue
            reason = (f"its nominal design cannot be tightened further ({frozen[j]})"
                      if j in frozen else f"{len(history)} round(s) spent")
            parts.append(f"{names[j]}: best {best[j][0]:.3g} against {asked:g} asked; "
                         f"{reason}")
        why = "not reached in the coupled simulation: " + "; ".join(parts)
    if elsewhere:
        fails = "; ".join(f"{nm}: {', '.join(f)}" for nm, f in elsewhere.items())
        why += (f". The same run fails checks on joints held by the other regulators "
                f"({held_by(others)}; not designed here): {fails}")
    return SpecDesign([regs[j] for j in idx], others, asked, last, reached, history, why, res,
                      run)
