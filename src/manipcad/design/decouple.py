"""Decoupling first, where it pays: gravity counterweights and what they change.

For every driven joint along the trajectories (paper section 2):

1. the coupling analysis (:func:`manipcad.analysis.coupling.coupling_analysis`): the
   joint's class (decoupled, inertial, full), worst over the trajectories;
2. how much of the joint's torque is gravity: the *gravity share*, RMS of Q_i over
   RMS of the whole drive torque P_i. Gravity *dominates* a revolute joint when the
   share is at least :data:`DOMINANT` (one half);
3. for those joints, most distal first (a counterweight on a distal link loads the
   proximal ones), the counterweight of least squares
   (:func:`manipcad.analysis.counterbalance.fit_counterweight`) for each arm length of
   :data:`ARMS`; it *pays* when it lowers the joint's RMS motor torque by at least
   :data:`PAYS` (10 %), turns no joint's sizing from pass to fail or unknown, and is
   no heavier than the links it balances (the links beyond the joint, payload
   included: a counterweight heavier than that would load the joints before it more
   than it relieves this one); of the arms that pay, the one with the smallest sum of
   the joints' largest rating utilizations is proposed (the lighter one on a tie);
4. what the proposal changes: each joint's class, required RMS and peak joint torque,
   sizing verdict and largest rating utilization (1 − margin) with and without it, and
   for each counterweighted joint the drive the catalogue selection
   (:func:`manipcad.sizing.select.select_drives`, least mass) picks without and with
   the counterweights.

Applied (the arm that the design goes on with carries the counterweights) with
``mode="auto"``; reported either way.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np

from manipcad.analysis.counterbalance import apply_counterweights, fit_counterweight
from manipcad.analysis.coupling import CLASSES, coupling_analysis
from manipcad.dynamics.components import torque_components
from manipcad.errors import ManipcadError
from manipcad.model.robot import REVOLUTE, Robot
from manipcad.sizing import required_drive
from manipcad.sizing.select import select_drives

#: gravity dominates a joint when RMS(Q_i) >= DOMINANT · RMS(P_i)
DOMINANT = 0.5
#: a counterweight pays when it lowers the joint's RMS motor torque by this fraction
PAYS = 0.10
#: counterweight arm lengths tried, m
ARMS = (0.1, 0.15, 0.2, 0.3, 0.4, 0.5)
#: sampling step of the trajectories for the analysis and the sizing, s
DT = 2e-3


@dataclass
class Sizing:
    """The sizing of every joint over the trajectories (worst trajectory per joint).

    Attributes:
        status: per joint "pass" | "fail" | "unknown" (the worst over the trajectories).
        rms_torque, peak_torque: required joint torque, N·m (N), the largest.
        rms_motor_torque: the largest required RMS motor torque, N·m.
        utilization: the largest required/limit over the rating checks, per joint.
        failing: per joint the checks that fail.
    """

    status: list[str]
    rms_torque: list[float]
    peak_torque: list[float]
    rms_motor_torque: list[float]
    utilization: list[float]
    failing: list[list[str]]

    def to_dict(self) -> dict:
        return {"status": self.status, "rms_torque": self.rms_torque,
                "peak_torque": self.peak_torque, "rms_motor_torque": self.rms_motor_torque,
                "utilization": self.utilization, "failing": self.failing}


_ORDER = {"pass": 0, "unknown": 1, "fail": 2, "n/a": 0}


def size(robot: Robot, trajectories, *, dt: float = DT) -> Sizing:
    """:func:`manipcad.sizing.required_drive` over the trajectories, worst per joint."""

    n = robot.n
    status = ["pass"] * n
    rms = np.zeros(n)
    pk = np.zeros(n)
    rmm = np.zeros(n)
    util = np.zeros(n)
    failing: list[list[str]] = [[] for _ in range(n)]
    for tr in trajectories:
        req = required_drive(robot, tr, dt=dt)
        rms = np.maximum(rms, np.nan_to_num(req.rms_torque))
        pk = np.maximum(pk, np.nan_to_num(req.peak_torque))
        rmm = np.maximum(rmm, np.nan_to_num(req.rms_motor_torque))
        for j in range(n):
            if _ORDER.get(req.status[j], 1) > _ORDER.get(status[j], 1):
                status[j] = req.status[j]
        for name, c in req.checks.items():
            m = np.asarray(c.margin, dtype=float)
            u = np.where(np.isfinite(m), 1.0 - m, 0.0)
            util = np.maximum(util, u)
            for j in range(n):
                if c.status[j] == "fail" and name not in failing[j]:
                    failing[j].append(name)
    return Sizing(status, rms.tolist(), pk.tolist(), rmm.tolist(), util.tolist(), failing)


def _configurations(robot: Robot, trajectories, dt: float) -> np.ndarray:
    qs = []
    for tr in trajectories:
        T = float(tr.duration)
        t = np.linspace(0.0, T, max(2, int(math.ceil(T / dt)) + 1))
        qs.append(np.asarray(tr.sample(t)[0]))
    return np.concatenate(qs)


def gravity_share(robot: Robot, trajectories, *, dt: float = DT) -> np.ndarray:
    """RMS(Q_i)/RMS(P_i) per joint over the trajectories (0 where P_i is 0).

    Example:
        >>> import manipcad
        >>> from manipcad.trajectories import load_trajectory
        >>> arm = manipcad.load_robot("cylindrical")
        >>> s = gravity_share(arm, [load_trajectory("examples/fig3_laws.yaml", robot=arm)])
        >>> float(s[0]) == 0.0, bool(s[1] > 0.5)     # the turn has none, the lift mostly gravity
        (True, True)
    """

    num = np.zeros(robot.n)
    den = np.zeros(robot.n)
    for tr in trajectories:
        T = float(tr.duration)
        t = np.linspace(0.0, T, max(2, int(math.ceil(T / dt)) + 1))
        q, qd, qdd = tr.sample(t)
        parts = torque_components(robot, q, qd, qdd)
        num += np.sum(parts.gravity ** 2, axis=0)
        den += np.sum(parts.total ** 2, axis=0)
    with np.errstate(invalid="ignore", divide="ignore"):
        share = np.where(den > 0, np.sqrt(num / np.where(den > 0, den, 1.0)), 0.0)
    return share


def coupling_classes(robot: Robot, trajectories) -> list[str]:
    """Each joint's coupling class, the most coupled over the trajectories."""

    worst = ["decoupled"] * robot.n
    for tr in trajectories:
        rep = coupling_analysis(robot, tr, dt=DT)
        for j, c in enumerate(rep.classes):
            if CLASSES.index(c) > CLASSES.index(worst[j]):
                worst[j] = c
    return worst


@dataclass
class Decoupling:
    """What the decoupling step found, proposed and (with ``mode="auto"``) applied.

    Attributes:
        mode: "auto" or "none".
        share: per joint the gravity share (see the module).
        dominated: the names of the joints gravity dominates.
        counterweights: the counterweights proposed (they pay), in fitting order.
        rejected: {joint: why no counterweight is proposed} for the dominated others.
        before, after: :class:`Sizing` without and with the proposals.
        classes_before, classes_after: the coupling classes without and with them.
        robot: the arm the design goes on with (with the counterweights if applied).
        applied: whether the counterweights are on ``robot``.
        selected: {joint: {"before", "after"}} for each counterweighted joint: the
            selection's choice ({"drive", "mass" kg, "feasible"} or {"error"}).
    """

    mode: str
    share: list[float]
    dominated: list[str]
    counterweights: list = field(default_factory=list)
    rejected: dict = field(default_factory=dict)
    before: Sizing | None = None
    after: Sizing | None = None
    classes_before: list[str] = field(default_factory=list)
    classes_after: list[str] = field(default_factory=list)
    robot: Robot | None = None
    applied: bool = False
    selected: dict = field(default_factory=dict)

    def to_dict(self, joint_names) -> dict[str, Any]:
        """A JSON-ready report, per joint (SI units)."""
        joints = {}
        cws = {cw.joint: cw for cw in self.counterweights}
        for j, name in enumerate(joint_names):
            e: dict[str, Any] = {"gravity_share": self.share[j],
                                 "gravity_dominates": name in self.dominated,
                                 "class_before": self.classes_before[j],
                                 "class_after": self.classes_after[j]}
            for tag, s in (("before", self.before), ("after", self.after)):
                if s is not None:
                    e[f"sizing_{tag}"] = {"status": s.status[j], "rms_torque": s.rms_torque[j],
                                          "peak_torque": s.peak_torque[j],
                                          "rms_motor_torque": s.rms_motor_torque[j],
                                          "utilization": s.utilization[j],
                                          "failing": s.failing[j]}
            if name in cws:
                e["counterweight"] = cws[name].to_dict()
            if name in self.rejected:
                e["no_counterweight"] = self.rejected[name]
            if name in self.selected:
                e["selected_drive"] = self.selected[name]
            joints[name] = e
        return {"mode": self.mode, "applied": self.applied, "dominant_share": DOMINANT,
                "pays": PAYS, "arms_tried": list(ARMS), "joints": joints,
                "units": {"rms_torque": "N·m (N)", "peak_torque": "N·m (N)",
                          "rms_motor_torque": "N·m", "utilization": "required/limit",
                          "gravity_share": "RMS(Q_i)/RMS(P_i)"}}


def _worse(a: Sizing, b: Sizing) -> list[int]:
    """Joints whose sizing verdict is worse in ``b`` than in ``a``."""
    return [j for j in range(len(a.status))
            if _ORDER.get(b.status[j], 1) > _ORDER.get(a.status[j], 1)]


def subtree_mass(robot: Robot, joint: int) -> float:
    """The mass of the links joint ``joint`` moves (its own and its descendants'), kg.

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> subtree_mass(arm, 0) == float(arm.mass.sum())
        True
    """
    inside = [False] * robot.n
    total = 0.0
    for k in range(robot.n):
        inside[k] = k == joint or (robot.parent[k] >= 0 and inside[robot.parent[k]])
        if inside[k]:
            total += float(robot.mass[k])
    return total


def selected_drives(robot: Robot, trajectories, joints: list[int]) -> dict[str, dict]:
    """The catalogue selection's choice for some joints, in one selection (least mass,
    default margin): {joint: {"drive": label, "mass": kg, "feasible": candidates that
    pass}}, or {joint: {"error": why}} for all when the selection refuses."""

    try:
        sel = select_drives(robot, list(trajectories), joints=joints, verify=False)
    except (ManipcadError, ImportError) as exc:
        return {robot.joint_names[j]: {"error": str(exc)} for j in joints}
    return {ch.joint: {"drive": ch.chosen.label, "mass": float(ch.chosen.part.mass),
                       "feasible": int(ch.feasible)} for ch in sel.joints}


def decouple(robot: Robot, trajectories, *, mode: str = "none", arms=ARMS,
             select: bool = True) -> Decoupling:
    """Propose the counterweights that pay, report what they change, apply them with "auto".

    Args:
        robot: the nominal arm with its drives.
        trajectories: the trajectories (objects).
        mode: "auto" (apply) or "none" (report only).
        arms: the counterweight arm lengths tried, m.
        select: report the drive the catalogue selection picks for each counterweighted
            joint without and with the counterweights.

    Returns:
        :class:`Decoupling`.
    """
    share = gravity_share(robot, trajectories)
    dominated = [j for j in range(robot.n)
                 if robot.joint_types[j] == REVOLUTE and share[j] >= DOMINANT
                 and robot.drives[j] is not None]
    q = _configurations(robot, trajectories, DT)
    before = size(robot, trajectories)
    out = Decoupling(mode=mode, share=[float(s) for s in share],
                     dominated=[robot.joint_names[j] for j in dominated], before=before,
                     classes_before=coupling_classes(robot, trajectories))
    current, cur_size = robot, before
    for j in sorted(dominated, reverse=True):
        name = robot.joint_names[j]
        best = None
        why = []
        carried = subtree_mass(current, j)
        for arm in arms:
            cw = fit_counterweight(current, q, j, arm=arm)
            if cw is None:
                why.append("its gravity torque does not depend on its link's orientation")
                break
            if cw.mass > carried:
                why.append(f"arm {arm:g} m: {cw.mass:.3g} kg, heavier than the "
                           f"{carried:.3g} kg it balances")
                continue
            trial = cw.apply(current)
            s = size(trial, trajectories)
            gain = 1.0 - s.rms_motor_torque[j] / max(cur_size.rms_motor_torque[j], 1e-300)
            worse = _worse(cur_size, s)
            if worse:
                why.append(f"arm {arm:g} m ({cw.mass:.3g} kg): the sizing of "
                           f"{', '.join(robot.joint_names[k] for k in worse)} gets worse")
                continue
            if gain < PAYS:
                why.append(f"arm {arm:g} m ({cw.mass:.3g} kg): the RMS motor torque drops "
                           f"{100 * gain:.3g} % (< {100 * PAYS:g} %)")
                continue
            score = (sum(s.utilization), cw.mass)
            if best is None or score < best[0]:
                best = (score, cw, trial, s)
        if best is None:
            out.rejected[name] = "; ".join(dict.fromkeys(why)) or "nothing to balance"
            continue
        _, cw, current, cur_size = best
        out.counterweights.append(cw)
    out.after = cur_size
    after_robot = apply_counterweights(robot, out.counterweights)
    out.classes_after = (coupling_classes(after_robot, trajectories) if out.counterweights
                         else list(out.classes_before))
    out.applied = mode == "auto" and bool(out.counterweights)
    out.robot = after_robot if out.applied else robot
    if select and out.counterweights:
        idx = sorted(cw.index for cw in out.counterweights)
        before = selected_drives(robot, trajectories, idx)
        after = selected_drives(after_robot, trajectories, idx)
        out.selected = {cw.joint: {"before": before[cw.joint], "after": after[cw.joint]}
                        for cw in out.counterweights}
    return out


__all__ = ["decouple", "Decoupling", "Sizing", "size", "gravity_share", "coupling_classes",
           "DOMINANT", "PAYS", "ARMS"]
