"""Every run of the design sweep judged by the run checks, per joint.

:func:`judge` is the one place the design reads a run's verdicts: a mapping
``{joint: {check: {"value", "limit", "unit", "verdict"}}}`` with the verdict "pass",
"fail" or "unknown". The tracking check compares the largest tracking error of a
designed joint, max |q* − q| over the run's kept samples (the same number
``manipcad simulate`` reports as ``max_error``), with the accuracy asked.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

PASS, FAIL, UNKNOWN = "pass", "fail", "unknown"


def tracking_check(max_error: float, accuracy: float, unit: str) -> dict:
    """The tracking check of one joint: max |e| against the accuracy asked.

    Example:
        >>> tracking_check(2e-4, 1e-3, "rad")["verdict"], tracking_check(2e-3, 1e-3, "rad")["verdict"]
        ('pass', 'fail')
    """
    if max_error is None or not math.isfinite(max_error):
        return {"value": None, "limit": accuracy, "unit": unit, "verdict": FAIL}
    return {"value": float(max_error), "limit": float(accuracy), "unit": unit,
            "verdict": PASS if max_error <= accuracy else FAIL}


def judge(result, robot, *, accuracy: float, judged: Sequence[int]) -> dict[str, dict]:
    """The checks of every joint of one run.

    Args:
        result: the :class:`~manipcad.sim.SimulationResult`.
        robot: the simulated robot (its drives' ratings).
        accuracy: the largest tracking error asked, rad or m.
        judged: the indices of the joints whose tracking is designed (the others are
            judged by the rating checks only).

    Returns:
        {joint name: {check: {"value", "limit", "unit", "verdict"}}}.
    """
    out: dict[str, dict] = {}
    metrics = result.metrics
    for j, name in enumerate(robot.joint_names):
        checks: dict[str, dict] = {}
        if j in judged:
            unit = "m" if robot.joint_types[j] == "prismatic" else "rad"
            checks["tracking"] = tracking_check(metrics[name]["max_error"], accuracy, unit)
        out[name] = checks
    return out


def verdict(checks: dict[str, dict], *, strict: bool = False) -> str:
    """One joint's verdict over its checks: fail if any fails, else unknown if any is
    unknown, else pass (``strict``: unknown counts as fail).

    Example:
        >>> verdict({"a": {"verdict": "pass"}, "b": {"verdict": "unknown"}})
        'unknown'
    """
    vs = [c.get("verdict") for c in checks.values()]
    if FAIL in vs or (strict and UNKNOWN in vs):
        return FAIL
    if UNKNOWN in vs:
        return UNKNOWN
    return PASS


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
            out.append(f"{name} {v:.3g} > {lim:.3g} {c.get('unit', '')}".rstrip())
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
