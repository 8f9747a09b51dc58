"""Every run of the design sweep judged by every run check, per joint.

:func:`judge` is the one place the design reads a run's verdicts: the run checks of
:func:`manipcad.sim.checks.run_checks` (tracking against the accuracy asked on the
designed joints; amplifier saturation, chattering, RMS and peak current, motor speed,
the gear's torques and speeds, the joint's position, velocity and effort limits on
every joint; docs/checks.md) as a mapping ``{joint: {check: {"value", "limit", "unit",
"verdict"}}}`` with the verdict "pass", "fail", "unknown" or "n/a" (no such limit,
counted as passed).
"""

from __future__ import annotations

import math
from collections.abc import Sequence

from manipcad.sim.checks import run_checks, worst
from manipcad.sizing.limits import FAIL, PASS, UNKNOWN


def tracking_check(max_error: float, accuracy: float, unit: str) -> dict:
    """The tracking check of one joint: max |e| against the accuracy asked.

    Example:
        >>> [tracking_check(e, 1e-3, "rad")["verdict"] for e in (2e-4, 2e-3)]
        ['pass', 'fail']
    """
    if max_error is None or not math.isfinite(max_error):
        return {"value": None, "limit": accuracy, "unit": unit, "verdict": FAIL}
    return {"value": float(max_error), "limit": float(accuracy), "unit": unit,
            "verdict": PASS if max_error <= accuracy else FAIL}


def judge(result, robot, *, accuracy: float, judged: Sequence[int]) -> dict[str, dict]:
    """The checks of every joint of one run.

    Args:
        result: the :class:`~manipcad.sim.SimulationResult`.
        robot: the simulated robot (payload included; its drives' ratings).
        accuracy: the largest tracking error asked, rad or m.
        judged: the indices of the joints whose tracking is designed (the others get
            every check but tracking).

    Returns:
        {joint name: {check: {"value", "limit", "unit", "verdict"}}} (value and limit
        None where not finite).
    """

    acc = {robot.joint_names[j]: float(accuracy) for j in judged}
    return run_checks(result, robot, accuracy=acc).to_dict()


def verdict(checks: dict[str, dict], *, strict: bool = False) -> str:
    """One joint's verdict over its checks (:func:`manipcad.sim.checks.worst`: fail if
    any fails, else unknown if any is unknown, else pass; "n/a" passes); ``strict``:
    unknown counts as fail.

    Example:
        >>> verdict({"a": {"verdict": "pass"}, "b": {"verdict": "unknown"}})
        'unknown'
        >>> verdict({"a": {"verdict": "n/a"}, "b": {"verdict": "unknown"}}, strict=True)
        'fail'
    """

    v = worst(c.get("verdict") for c in checks.values())
    return FAIL if strict and v == UNKNOWN else v


def failed_checks(checks: dict[str, dict]) -> list[str]:
    """The names of the failed checks, in words: "tracking 2.1e-3 > 1e-3 rad".

    Example:
        >>> failed_checks({"tracking": tracking_check(2e-3, 1e-3, "rad")})
        ['tracking 0.002 > 0.001 rad']
    """
    out = []
    for name, c in checks.items():
        if c.get("verdict") != FAIL:
            continue
        v, lim = c.get("value"), c.get("limit")
        if v is None:
            out.append(f"{name} (no value: the run diverged or could not run)")
        else:
            limit = "-" if lim is None else f"{lim:.3g}"
            out.append(f"{name} {v:.3g} > {limit} {c.get('unit', '')}".rstrip())
    return out


def margin(check: dict) -> float | None:
    """1 − value/limit of a check (its headroom; < 0 when it fails), None if not known.

    Example:
        >>> margin({"value": 2.0, "limit": 8.0})
        0.75
    """
    v, lim = check.get("value"), check.get("limit")
    if v is None or lim is None:
        return None
    try:
        v, lim = float(v), float(lim)
    except (TypeError, ValueError):
        return None
    if not (math.isfinite(v) and math.isfinite(lim)) or lim <= 0:
        return None
    return 1.0 - abs(v) / lim


__all__ = ["judge", "verdict", "failed_checks", "margin", "tracking_check", "PASS", "FAIL",
           "UNKNOWN"]
