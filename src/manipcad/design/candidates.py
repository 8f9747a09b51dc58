"""The candidate methods: the rules' recommendation, each synthesized for the drive's period.

:func:`candidates` asks the rule base (:func:`manipcad.expert.recommend`) which methods
can meet the requirements on this robot and trajectory, least realization complexity
first, and keeps the first ``max_methods``. :func:`synthesize_method` designs a method on
every designed joint of the nominal arm at the control period, over the load range the
payload range spans, and counts each regulator's realization complexity
(:mod:`manipcad.control.complexity`) as one cost (the rule base's weights).

A *tighter synthesis* (level k >= 1), where the method has a knob for it: ``ace_de`` and
``ace_tf`` design for ``max_error`` = accuracy/2^(k−1) on the reference (the smallest
bandwidth whose nominal loop meets it); ``lqr`` and ``lqr_gs`` weigh the error with
``e_max`` = min(0.01 rad, accuracy)/4^(k−1); ``pid`` and ``computed_torque`` raise the
bandwidth to 30·2^k rad/s. ``vss``, ``asvs``, ``none`` and ``none_sce`` have none
(:data:`TIGHTENABLE`).
"""

from __future__ import annotations

import inspect
import math
from dataclasses import dataclass, field
from typing import Any

from manipcad.control import METHODS as SYNTH
from manipcad.control import synthesize
from manipcad.control.complexity import realization_complexity
from manipcad.control.design import inertia_range
from manipcad.control.registry import method as entry
from manipcad.errors import ManipcadError
from manipcad.expert import recommend
from manipcad.expert.engine import complexity_cost, load_rules

#: methods with a knob that tightens the synthesis (see the module docstring)
TIGHTENABLE = ("ace_de", "ace_tf", "lqr", "lqr_gs", "pid", "computed_torque")


def tighter_spec(method: str, level: int, accuracy: float) -> tuple[dict | None, bool]:
    """(spec, needs the reference) of a method at a tightening level (0: the default design).

    Example:
        >>> tighter_spec("ace_de", 2, 1e-4)
        ({'max_error': 5e-05}, True)
        >>> tighter_spec("lqr", 1, 1e-3), tighter_spec("vss", 1, 1e-3)
        (({'e_max': 0.001}, False), (None, False))
    """
    if level <= 0:
        return {}, False
    if method in ("ace_de", "ace_tf"):
        return {"max_error": accuracy / 2.0 ** (level - 1)}, True
    if method in ("lqr", "lqr_gs"):
        return {"e_max": min(0.01, accuracy) / 4.0 ** (level - 1)}, False
    if method in ("pid", "computed_torque"):
        return {"bandwidth": 30.0 * 2.0 ** level}, False
    return None, False


def candidates(requirements, robot, trajectory, *, joint=None, max_methods: int = 4):
    """The rules' ranked methods for the designed joints.

    Args:
        requirements: :class:`~manipcad.expert.Requirements` (or a dict or file).
        robot: the nominal arm; trajectory: its first trajectory.
        joint: the designed joint (None: every driven joint; the derived fields at their
            worst joint, so every method kept suits every joint).
        max_methods: how many of the ranked methods to verify (>= 1).

    Returns:
        (the :class:`~manipcad.expert.engine.Recommendations`, the method names kept).
    """

    recs = recommend(requirements, robot, trajectory, joint=joint)
    kept = [r.method for r in recs if r.method in SYNTH][:max_methods]
    return recs, kept


@dataclass
class Synthesis:
    """One method synthesized on the designed joints.

    Attributes:
        method: its name; level: the tightening level.
        regulators: {joint index: Regulator} of the joints it could be designed for.
        errors: {joint index: why the synthesis refused} for the others.
        cost: {joint index: realization complexity as one number}.
        complexity: {joint index: {"ops_per_period", "gains_stored", "signals"}}.
        spec: the spec used.
    """

    method: str
    level: int
    regulators: dict = field(default_factory=dict)
    errors: dict = field(default_factory=dict)
    cost: dict = field(default_factory=dict)
    complexity: dict = field(default_factory=dict)
    spec: dict = field(default_factory=dict)


def _accepts(method: str, option: str) -> bool:

    try:
        return option in inspect.signature(entry(method).synthesize).parameters
    except (TypeError, ValueError):
        return False


def load_ranges(robots, joints) -> dict[int, tuple[float, float]]:
    """{joint: (H_min, H_max) kg·m² (kg)} over the arms (payloads, parameter bounds), per
    joint.

    Example:
        >>> import manipcad
        >>> arm = manipcad.load_robot("cylindrical")
        >>> lo, hi = load_ranges([arm], [0])[0]
        >>> 0 < lo < hi
        True
    """

    out = {}
    for j in joints:
        lows, highs = zip(*(inertia_range(r, j) for r in robots), strict=True)
        out[j] = (float(min(lows)), float(max(highs)))
    return out


def synthesize_method(robot, method: str, joints, *, period: float, accuracy: float,
                      level: int = 0, reference=None, load_range: dict | None = None,
                      weights: dict | None = None) -> Synthesis:
    """Design ``method`` on each of ``joints`` of the nominal arm.

    Args:
        robot: the nominal arm (drives, nominal payload, counterweights).
        method: a registry method name.
        joints: the joint indices designed.
        period: the control period, s.
        accuracy: the accuracy asked (for a tighter synthesis), rad or m.
        level: the tightening level (:func:`tighter_spec`).
        reference: the trajectory a ``max_error`` design is made on.
        load_range: {joint: (H_min, H_max)} the payload range spans (passed to the
            methods that take it).
        weights: the rule base's complexity weights (default: the package rules').

    Returns:
        :class:`Synthesis` (the refusals are kept, with their reasons, not raised).
    """

    if weights is None:
        weights = load_rules().weights
    spec, needs_ref = tighter_spec(method, level, accuracy)
    out = Synthesis(method=method, level=level, spec=dict(spec or {}))
    if spec is None:
        for j in joints:
            out.errors[j] = f"{method} has no knob to tighten its synthesis"
        return out
    for j in joints:
        opts: dict[str, Any] = {"period": period}
        if needs_ref:
            opts["reference"] = reference
        if load_range is not None and j in load_range and _accepts(method, "load_range"):
            opts["load_range"] = load_range[j]
        try:
            reg = synthesize(robot, j, method, spec=spec or None, **opts)
        except ManipcadError as exc:
            out.errors[j] = str(exc)
            continue
        except (ValueError, ArithmeticError, TypeError) as exc:
            out.errors[j] = f"{type(exc).__name__}: {exc}"
            continue
        cx = realization_complexity(reg)
        cx = {"gains_stored": int(cx.get("gains_stored", 0)),
              "ops_per_period": int(cx.get("ops_per_period", 0)),
              "signals": list(cx.get("signals", []))}
        out.regulators[j] = reg
        out.complexity[j] = cx
        c = complexity_cost(cx, weights)
        out.cost[j] = float(c) if math.isfinite(c) else math.inf
    return out


__all__ = ["candidates", "synthesize_method", "Synthesis", "tighter_spec", "TIGHTENABLE",
           "load_ranges"]
