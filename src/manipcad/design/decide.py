"""The decision: per joint, the least complex method that passes every check in every case.

Each run of the sweep has per joint a set of checks (:mod:`manipcad.design.judge`).
:func:`evaluate` summarizes one method on one joint over its runs: passed everywhere or
not, the worst tracking error and the case it happens in, every failing case with the
checks it fails. :func:`choose` takes, per joint, the passing method of least realization
complexity; :func:`closest` the method that comes nearest (:func:`badness`: one that
fails no check but tracking before one that does; then the smallest worst ratio of
tracking error to accuracy, a diverged run counting as infinite; then the fewest failed
cases; then the least complexity) for a design that cannot meet the requirements.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass, field

from manipcad.design.judge import FAIL, UNKNOWN, failed_checks, verdict


@dataclass
class Evaluation:
    """One method on one joint over its runs.

    Attributes:
        passed: every run passes every check of the joint (unknown counts as passed
            unless ``strict``).
        runs: the number of runs judged.
        worst_error: the largest tracking error over the runs, rad or m (inf: diverged).
        worst_case: the id of the run it happens in.
        failing: [(run id, [failed checks in words])].
        unknown: ids of the runs where a check is unknown.
    """

    passed: bool
    runs: int
    worst_error: float
    worst_case: str
    failing: list = field(default_factory=list)
    unknown: list = field(default_factory=list)

    def reason(self) -> str:
        """Why the method fails on the joint, in one line (the first failing runs)."""
        if self.passed:
            return ""
        parts = [f"{cid}: {', '.join(why)}" for cid, why in self.failing[:3]]
        more = len(self.failing) - 3
        return (f"fails in {len(self.failing)} of {self.runs} cases ("
                + "; ".join(parts) + (f"; and {more} more" if more > 0 else "") + ")")

    def to_dict(self) -> dict:
        return {"passed": self.passed, "runs": self.runs,
                "worst_error": self.worst_error if math.isfinite(self.worst_error) else "inf",
                "worst_case": self.worst_case, "failing": [[c, w] for c, w in self.failing],
                "unknown": self.unknown}


def evaluate(runs: Sequence[Mapping], joint: str, *, strict: bool = False) -> Evaluation:
    """Summarize the runs of one method for one joint.

    Args:
        runs: run records {"id", "checks": {joint: {check: {...}}}, "max_error": {joint}}.
        joint: the joint's name.
        strict: an unknown check counts as failed.

    Example:
        >>> from manipcad.design.judge import tracking_check
        >>> r = [{"id": "a", "checks": {"q1": {"tracking": tracking_check(1e-4, 1e-3, "rad")}},
        ...       "max_error": {"q1": 1e-4}},
        ...      {"id": "b", "checks": {"q1": {"tracking": tracking_check(2e-3, 1e-3, "rad")}},
        ...       "max_error": {"q1": 2e-3}}]
        >>> e = evaluate(r, "q1")
        >>> e.passed, e.worst_case, e.failing
        (False, 'b', [('b', ['tracking 0.002 > 0.001 rad'])])
    """
    failing, unknown = [], []
    worst, worst_case = -1.0, ""
    for r in runs:
        checks = r["checks"].get(joint, {})
        v = verdict(checks, strict=strict)
        if v == FAIL:
            why = failed_checks(checks) or ["unknown checks (strict)"]
            if r.get("status") not in (None, "ok"):
                why = [f"{r['status']}: {str(r.get('message', ''))[:240]}"]
            failing.append((r["id"], why))
        elif v == UNKNOWN:
            unknown.append(r["id"])
        err = (r.get("max_error") or {}).get(joint)
        err = math.inf if err is None or not math.isfinite(err) else float(err)
        if err > worst:
            worst, worst_case = err, r["id"]
    return Evaluation(passed=not failing, runs=len(runs), worst_error=worst,
                      worst_case=worst_case, failing=failing, unknown=unknown)


def choose(evaluations: Mapping[str, Mapping[str, Evaluation]],
           costs: Mapping[str, Mapping[str, float]], excluded=frozenset()
           ) -> dict[str, str | None]:
    """Per joint the passing method of least complexity (None if none passes).

    Args:
        evaluations: {joint: {method: Evaluation}}.
        costs: {joint: {method: realization complexity cost}}.
        excluded: (joint, method) pairs not to choose.

    Example:
        >>> ok = Evaluation(True, 1, 1e-4, "a"); bad = Evaluation(False, 1, 1e-2, "a")
        >>> choose({"q1": {"lqr": ok, "vss": ok, "pid": bad}},
        ...        {"q1": {"lqr": 114.0, "vss": 92.7, "pid": 50.0}})
        {'q1': 'vss'}
    """
    out: dict[str, str | None] = {}
    for joint, per in evaluations.items():
        ok = [m for m, e in per.items() if e.passed and (joint, m) not in excluded]
        ok.sort(key=lambda m: (costs[joint].get(m, math.inf), m))
        out[joint] = ok[0] if ok else None
    return out


def badness(e: Evaluation, accuracy: float) -> tuple:
    """The sort key of :func:`closest` (smaller is nearer to meeting the requirements):
    first whether a check other than tracking fails in some case (a rating the drive
    cannot keep, which no tuning of the tracking cures), then the worst ratio of
    tracking error to accuracy, then the number of failing cases.

    Example:
        >>> over = Evaluation(False, 1, 2e-3, "a", [("a", ["current_rms 5 > 3 A"])])
        >>> slow = Evaluation(False, 1, 5e-3, "a", [("a", ["tracking 0.005 > 0.001 rad"])])
        >>> badness(slow, 1e-3) < badness(over, 1e-3)
        True
    """
    rating = any(not w.startswith("tracking") for _, whys in e.failing for w in whys)
    ratio = e.worst_error / accuracy if accuracy > 0 else e.worst_error
    return (rating, ratio, len(e.failing))


def closest(evaluations: Mapping[str, Evaluation], costs: Mapping[str, float],
            accuracy: float) -> str | None:
    """The method of one joint that comes nearest to passing (see the module docstring).

    Example:
        >>> a = Evaluation(False, 2, 3e-3, "x", [("x", ["tracking"])])
        >>> b = Evaluation(False, 2, 2e-3, "y", [("y", ["tracking"]), ("z", ["tracking"])])
        >>> closest({"lqr": a, "vss": b}, {"lqr": 1.0, "vss": 2.0}, 1e-3)
        'vss'
    """
    if not evaluations:
        return None
    return min(evaluations, key=lambda m: (*badness(evaluations[m], accuracy),
                                           costs.get(m, math.inf), m))


__all__ = ["Evaluation", "evaluate", "choose", "closest", "badness"]
