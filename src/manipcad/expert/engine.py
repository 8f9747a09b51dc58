"""The expert system's engine: requirements in, ranked synthesis methods out (paper 5, Fig. 1).

The rules are data (``rules.yaml`` next to this module; see docs/expert-rules.md).
:func:`recommend`:

1. reads the requirements (a :class:`Requirements`, a dict or a YAML file) and,
   with a robot and a trajectory, derives the fields not given
   (:func:`manipcad.expert.requirements.derive`);
2. checks the set against the ``contradictions`` of the rule base;
3. evaluates every rule in three-valued logic (a field not given and not
   derivable is *unknown*): a rule that holds fires; an undecided rule is an
   error naming its missing fields — unless no value of them could change the
   answer (its methods are already excluded, or its ``require`` already holds);
4. applies the effects: ``exclude`` and ``require`` remove methods (with the
   rule's reason), ``prefer`` adds to a method's score; if nothing is left the
   requirements contradict each other and the error names the rules and fields;
5. ranks the rest: highest score first, then the least realization complexity
   (cost = ops + w_g·gains + w_s·signals, weights in the data);
6. with ``verify=True`` synthesizes the top candidates (and further ones while
   none meets the accuracy) with
   :func:`manipcad.control.synthesize`, simulates them along the trajectory
   (:func:`manipcad.sim.simulate`) and re-ranks: those whose measured largest
   error meets the accuracy first, least complexity first; then the ones not
   verified; then those that miss it, smallest error first.
"""

from __future__ import annotations

import ast
import math
import operator
from dataclasses import dataclass, field
from functools import lru_cache
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from manipcad.control import METHODS as SYNTH
from manipcad.control import realization_complexity, synthesize
from manipcad.errors import InputError, ManipcadError
from manipcad.expert.requirements import (
    FIELDS,
    Derivation,
    Requirements,
    derive,
)
from manipcad.model import load_robot
from manipcad.model.hashing import robot_hash
from manipcad.sim import simulate
from manipcad.trajectories import load_trajectory

RULES_FILE = Path(__file__).with_name("rules.yaml")
METHODS = ("ace_tf", "ace_de", "asvs", "vss", "lqr_gs", "lqr", "none", "pid",
           "computed_torque")
#: joints assumed for complexity expressions in n when no robot is given
DEFAULT_N = 6
_OPS = {"eq": operator.eq, "ne": operator.ne, "gt": operator.gt, "ge": operator.ge,
        "lt": operator.lt, "le": operator.le}


class IncompleteRequirements(ManipcadError):
    """A rule needs a field that is neither given nor derivable; ``.missing`` names them."""

    def __init__(self, message: str, missing: dict[str, list[str]]) -> None:
        super().__init__(message)
        self.missing = missing


class ContradictoryRequirements(ManipcadError):
    """The requirements contradict each other; ``.fields`` names the fields involved."""

    def __init__(self, message: str, fields: list[str]) -> None:
        super().__init__(message)
        self.fields = fields


# ---------------------------------------------------------------------- the rule base


@dataclass(frozen=True)
class Rule:
    """One rule: a condition over requirement fields and its effect on the methods."""

    id: str
    section: str
    when: Any
    reason: str
    exclude: tuple[str, ...] = ()
    require: tuple[str, ...] = ()
    prefer: tuple[tuple[str, float], ...] = ()

    @property
    def fields(self) -> list[str]:
        """The requirement fields the condition names."""
        out: list[str] = []
        _collect_fields(self.when, out)
        return list(dict.fromkeys(out))

    @property
    def methods(self) -> set[str]:
        return set(self.exclude) | set(self.require) | {m for m, _ in self.prefer}

    def text(self) -> str:
        """The rule in words: ``id (section): reason``."""
        return f"{self.id} ({self.section}): {self.reason}"


@dataclass(frozen=True)
class RuleBase:
    """The parsed rule base: methods with base complexity, contradictions, rules."""

    source: str
    methods: dict[str, dict]
    weights: dict[str, float]
    contradictions: tuple[Rule, ...]
    rules: tuple[Rule, ...]

    def rule(self, rule_id: str) -> Rule:
        for r in self.rules + self.contradictions:
            if r.id == rule_id:
                return r
        raise KeyError(rule_id)


def _collect_fields(cond: Any, out: list[str]) -> None:
    if isinstance(cond, dict):
        for k, v in cond.items():
            if k in ("any", "all"):
                for c in v:
                    _collect_fields(c, out)
            elif k == "not":
                _collect_fields(v, out)
            else:
                out.append(k)


def _check_condition(cond: Any, where: str, source: str) -> None:
    if not isinstance(cond, dict) or not cond:
        raise InputError(source, where, "a condition must be a non-empty mapping")
    for k, v in cond.items():
        if k in ("any", "all"):
            if not isinstance(v, list) or not v:
                raise InputError(source, f"{where}.{k}", "expected a non-empty list of conditions")
            for i, c in enumerate(v):
                _check_condition(c, f"{where}.{k}[{i}]", source)
        elif k == "not":
            _check_condition(v, f"{where}.not", source)
        elif k not in FIELDS:
            raise InputError(source, f"{where}.{k}", f"unknown requirement field; known: "
                             f"{', '.join(FIELDS)}")
        elif isinstance(v, dict):
            for op, arg in v.items():
                if op not in _OPS and op != "in":
                    raise InputError(source, f"{where}.{k}.{op}", "unknown operator; known: "
                                     f"{', '.join([*_OPS, 'in'])}")
                if op == "in" and not isinstance(arg, list):
                    raise InputError(source, f"{where}.{k}.in", "expected a list of values")


def _methods(v: Any, where: str, source: str) -> tuple[str, ...]:
    if v is None:
        return ()
    if isinstance(v, str):
        v = [v]
    if not isinstance(v, list):
        raise InputError(source, where, "expected a list of method names")
    for m in v:
        if m not in METHODS:
            raise InputError(source, where, f"unknown method {m!r}; known: {', '.join(METHODS)}")
    return tuple(v)


def _parse_rule(data: Any, where: str, source: str, *, effects: bool) -> Rule:
    if not isinstance(data, dict):
        raise InputError(source, where, "expected a mapping")
    allowed = {"id", "section", "when", "reason"} | (
        {"exclude", "require", "prefer"} if effects else set())
    unknown = set(data) - allowed
    if unknown:
        raise InputError(source, f"{where}.{sorted(unknown)[0]}",
                         f"unknown key; known: {', '.join(sorted(allowed))}")
    for key in ("id", "when", "reason"):
        if key not in data:
            raise InputError(source, f"{where}.{key}", "missing")
    rid = str(data["id"])
    where = f"{where} ({rid})"
    _check_condition(data["when"], f"{where}.when", source)
    prefer = data.get("prefer")
    if isinstance(prefer, dict):
        pref = []
        for m, w in prefer.items():
            _methods([m], f"{where}.prefer", source)
            if not isinstance(w, int | float) or isinstance(w, bool) or w <= 0:
                raise InputError(source, f"{where}.prefer.{m}", "weight must be a number > 0")
            pref.append((m, float(w)))
        prefer_t = tuple(pref)
    else:
        prefer_t = tuple((m, 1.0) for m in _methods(prefer, f"{where}.prefer", source))
    rule = Rule(id=rid, section=str(data.get("section", "")), when=data["when"],
                reason=" ".join(str(data["reason"]).split()),
                exclude=_methods(data.get("exclude"), f"{where}.exclude", source),
                require=_methods(data.get("require"), f"{where}.require", source),
                prefer=prefer_t)
    if effects and not (rule.exclude or rule.require or rule.prefer):
        raise InputError(source, where, "a rule needs an effect: exclude, require or prefer")
    return rule


def load_rules(path: str | Path | None = None) -> RuleBase:
    """Read and check a rule base (default: the package's ``rules.yaml``).

    Raises:
        InputError: naming the file, the rule and the reason (unknown field,
            operator or method, a rule without effect, a duplicate id).
    """
    return _load_rules(str(path) if path is not None else str(RULES_FILE))


@lru_cache(maxsize=8)
def _load_rules(source: str) -> RuleBase:
    p = Path(source)
    if not p.is_file():
        raise InputError(source, "", "no such rule file")
    try:
        data = yaml.safe_load(p.read_text(encoding="utf-8"))
    except yaml.YAMLError as exc:
        raise InputError(source, "", f"YAML syntax error: {exc}") from None
    if not isinstance(data, dict) or "rules" not in data:
        raise InputError(source, "", "expected a mapping with 'methods' and 'rules'")
    methods = data.get("methods") or {}
    for m in METHODS:
        if m not in methods:
            raise InputError(source, f"methods.{m}", "missing")
        if "complexity" in methods[m]:
            raise InputError(source, f"methods.{m}.complexity", "not read from the rule base: "
                             "realization complexity is counted from the registry's code")
    weights = {"ops_per_period": 1.0, "gains_stored": 0.1, "signal": 10.0}
    weights.update(data.get("complexity_weights") or {})
    rules = tuple(_parse_rule(r, f"rules[{i}]", source, effects=True)
                  for i, r in enumerate(data["rules"]))
    contra = tuple(_parse_rule(r, f"contradictions[{i}]", source, effects=False)
                   for i, r in enumerate(data.get("contradictions") or []))
    ids = [r.id for r in rules + contra]
    dup = {i for i in ids if ids.count(i) > 1}
    if dup:
        raise InputError(source, "rules", f"duplicate rule id(s) {sorted(dup)}")
    return RuleBase(source=source, methods=methods, weights=weights, contradictions=contra,
                    rules=rules)


# ---------------------------------------------------------------------- conditions


def evaluate(cond: Any, req: Requirements, missing: list[str] | None = None) -> bool | None:
    """A condition in three-valued logic: True, False, or None (a field it needs is unknown).

    ``missing`` (if given) receives the unknown fields that left it undecided.
    """
    res, miss = _eval(cond, req)
    if missing is not None:
        missing.extend(miss)
    return res


def _eval(cond: Any, req: Requirements) -> tuple[bool | None, list[str]]:
    results: list[bool | None] = []
    miss: list[str] = []
    for key, v in cond.items():
        if key in ("all", "any"):
            subs = [_eval(c, req) for c in v]
            r = (_and if key == "all" else _or)([x for x, _ in subs])
            if r is None:
                miss += [f for x, m in subs if x is None for f in m]
        elif key == "not":
            r, m = _eval(v, req)
            r = None if r is None else not r
            miss += m
        else:
            value = req.get(key)
            if value is None:
                r = None
                miss.append(key)
            else:
                r = _test(value, v)
        results.append(r)
    out = _and(results)
    return out, (list(dict.fromkeys(miss)) if out is None else [])


def _and(xs: list[bool | None]) -> bool | None:
    if any(x is False for x in xs):
        return False
    return None if any(x is None for x in xs) else True


def _or(xs: list[bool | None]) -> bool | None:
    if any(x is True for x in xs):
        return True
    return None if any(x is None for x in xs) else False


def _test(value: Any, test: Any) -> bool:
    if not isinstance(test, dict):
        return value == test
    for op, arg in test.items():
        if op == "in":
            if value not in arg:
                return False
        else:
            try:
                if not _OPS[op](value, arg):
                    return False
            except TypeError:
                return False
    return True


# ---------------------------------------------------------------------- complexity


def _expr(v: Any, n: int) -> float:
    if isinstance(v, int | float):
        return float(v)

    def ev(node: ast.AST) -> float:
        if isinstance(node, ast.Constant) and type(node.value) in (int, float):
            return float(node.value)
        if isinstance(node, ast.Name) and node.id == "n":
            return float(n)
        if isinstance(node, ast.BinOp) and type(node.op) in (ast.Add, ast.Sub, ast.Mult):
            a, b = ev(node.left), ev(node.right)
            return a + b if isinstance(node.op, ast.Add) else (
                a - b if isinstance(node.op, ast.Sub) else a * b)
        raise ManipcadError(f"rule base: bad complexity expression {v!r} (numbers, n, + - *)")

    return ev(ast.parse(str(v), mode="eval").body)


def base_complexity(rules: RuleBase, method: str, n: int = DEFAULT_N, robot=None) -> dict:
    """A method's realization complexity per drive, counted from the registry's code.

    The method is synthesized with its defaults for the first driven joint of ``robot``
    (or, without a robot or when that fails, for the turning drive of the catalog's
    cylindrical arm, the paper's Fig. 2) and its compiled update counted
    (:func:`manipcad.control.complexity.count`). ``rules`` and ``n`` are kept for the
    callers; nothing is read from the rule base.
    """
    return dict(_counted_complexity(method, robot))


_COUNTED: dict = {}


def _counted_complexity(method: str, robot) -> dict:

    candidates = []
    if robot is not None and robot.drives is not None:
        driven = [j for j, d in enumerate(robot.drives) if d is not None]
        if driven:
            candidates.append((robot, driven[0]))
    candidates.append((None, "turn"))
    for rob, joint in candidates:
        key = (method, robot_hash(rob) if rob is not None else "fig2", joint)
        if key in _COUNTED:
            return _COUNTED[key]
        arm = rob if rob is not None else load_robot("cylindrical")
        try:
            reg = synthesize(arm, joint, method)
        except ManipcadError:
            continue
        regs = reg if isinstance(reg, list) else [reg]
        c = realization_complexity(regs[0])
        _COUNTED[key] = {"gains_stored": c["gains_stored"], "ops_per_period": c["ops_per_period"],
                         "signals": list(c["signals"]),
                         "source": f"counted: {method} on {arm.name} joint "
                                   f"{arm.joint_names[regs[0].joints[0]]}"}
        return _COUNTED[key]
    raise ManipcadError(f"cannot count the complexity of {method!r}: its synthesis fails")


def complexity_cost(complexity: dict, weights: dict[str, float]) -> float:
    """cost = w_ops·ops_per_period + w_g·gains_stored + w_s·len(signals)."""
    return (weights["ops_per_period"] * float(complexity.get("ops_per_period", 0))
            + weights["gains_stored"] * float(complexity.get("gains_stored", 0))
            + weights["signal"] * len(complexity.get("signals", ())))


# ---------------------------------------------------------------------- results


@dataclass
class Recommendation:
    """One recommended method.

    Attributes:
        method: a synthesis method name (``manipcad.control``; ``computed_torque``).
        reasons: why it is here: the fired rules that prefer or require it, in words.
        complexity: realization complexity: gains_stored, ops_per_period (per
            control period), signals (measured or computed), source.
        score: sum of the weights of the fired ``prefer`` rules naming it.
        cost: the complexity as one number (see ``complexity_weights`` in the data).
        max_error: with verify, the largest simulated tracking error, rad or m.
        meets_accuracy: with verify, whether max_error <= accuracy (None: not verified).
        note: with verify, what happened (e.g. why it was not verified).
        checks: with verify, the run's checks of the joints designed
            (:meth:`manipcad.sim.checks.RunChecks.to_dict`: {joint: {check: {value, limit,
            unit, verdict}}}); None when not simulated.
        failed: with verify, every failed check in words ("elbow: saturation 0.72 of
            0.02 -"), empty when none fails.

    The rules know qualitative facts (coupling, speed, inductance, transmission,
    overshoot; paper section 5), never the error a method reaches on this robot
    and trajectory: without ``verify`` every recommendation's :attr:`accuracy` is
    "unverified", and a number the rules rank first is not a promise.
    """

    method: str
    reasons: list[str]
    complexity: dict
    score: float
    cost: float
    max_error: float | None = None
    meets_accuracy: bool | None = None
    note: str = ""
    checks: dict | None = None
    failed: list[str] = field(default_factory=list)

    @property
    def accuracy(self) -> str:
        """Whether the accuracy asked is known to be met: "met" or "missed" (simulated
        by ``verify``), or "unverified" (ranked by the rules only, or not simulated)."""
        if self.meets_accuracy is None:
            return "unverified"
        return "met" if self.meets_accuracy else "missed"

    @property
    def verdict(self) -> str:
        """The verdict of every check of its simulated run (docs/checks.md): "pass" (every
        check passes: tracking, saturation, chattering, currents, speeds, gear and joint
        limits), "fail", "unknown" (none fails, one cannot be made), or "unverified" (not
        simulated)."""
        if self.checks is None:
            return "fail" if self.meets_accuracy is False else "unverified"
        # deferred: start-up cost: keeps manipcad.sim.checks out of import manipcad
        from manipcad.sim.checks import RunChecks

        return RunChecks.from_dict(self.checks).verdict

    def to_dict(self) -> dict:
        err = self.max_error
        if err is not None and not math.isfinite(err):
            err = str(err)              # JSON has no inf: "inf" (a diverged run)
        return {"method": self.method, "score": self.score, "cost": self.cost,
                "complexity": self.complexity, "reasons": self.reasons,
                "max_error": err, "meets_accuracy": self.meets_accuracy,
                "accuracy": self.accuracy, "verdict": self.verdict, "failed": self.failed,
                "checks": self.checks, "note": self.note}


#: the order of a list ranked by the rules (:func:`recommend`)
RULES_ORDER = ("ranked by score (the sum of the fired 'prefer' rules), then by realization "
               "complexity")
#: the order of a list ranked by simulation (``verify=True``): the sort key of
#: :func:`_verify`, in words
VERIFIED_ORDER = ("ranked by the checks' verdict: every check passes, then none fails but "
                  "some cannot be made (unknown), then not simulated (by score), then "
                  "failing (by max error, then the number of failed checks); within "
                  "'pass' and 'unknown' by realization complexity")


class Recommendations(list):
    """The ranked :class:`Recommendation` list, best first, with the context.

    Attributes:
        excluded: {method: why} for every method that cannot meet the requirements.
        requirements: the requirements used (given plus derived fields).
        derived: {field: Derivation} for the fields the robot and trajectory gave.
        fired: ids of the rules that fired.
        undecided: ids of the rules left undecided because no value of their
            missing fields could change the answer.
        excluded_by: {method: ids of the rules that excluded it}.
        rule_texts: {id: text} of the fired rules.
        notes: remarks, e.g. a given field the robot and trajectory disagree with.
        verified: whether the ranking comes from simulation (verify=True).
        order: how the list is ordered, in words (:data:`RULES_ORDER` or
            :data:`VERIFIED_ORDER`).
    """

    def __init__(self, items, *, excluded, requirements, derived, fired, undecided,
                 verified=False, rules_source=""):
        super().__init__(items)
        self.excluded: dict[str, str] = excluded
        self.requirements: Requirements = requirements
        self.derived: dict[str, Derivation] = derived
        self.fired: list[str] = fired
        self.undecided: list[str] = undecided
        self.verified: bool = verified
        self.order: str = VERIFIED_ORDER if verified else RULES_ORDER
        self.rules_source = rules_source
        #: {method: ids of the rules that excluded it}
        self.excluded_by: dict[str, list[str]] = {}
        #: the fired rules' texts, by id
        self.rule_texts: dict[str, str] = {}
        #: remarks, e.g. a given field that the robot and trajectory contradict
        self.notes: list[str] = []

    @property
    def best(self) -> Recommendation:
        return self[0]

    @property
    def methods(self) -> list[str]:
        return [r.method for r in self]

    def to_dict(self) -> dict:
        """A JSON-ready mapping (SI units)."""
        return {
            "recommendations": [r.to_dict() for r in self],
            "excluded": dict(self.excluded),
            "requirements": self.requirements.model_dump(),
            "derived": {k: {"value": d.value, "how": d.how, "error": d.error}
                        for k, d in self.derived.items()},
            "excluded_by": dict(self.excluded_by),
            "fired": list(self.fired),
            "rules": dict(self.rule_texts),
            "undecided": list(self.undecided),
            "verified": self.verified,
            "notes": list(self.notes),
        }


# ---------------------------------------------------------------------- the engine


def _values(req: Requirements, fields: list[str]) -> str:
    return ", ".join(f"{f}={_fmt(req.get(f))}" for f in fields if req.get(f) is not None)


def _fmt(v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, float):
        return f"{v:.4g}"
    return str(v)


def recommend(requirements: Requirements | dict | str | Path, robot=None, trajectory=None, *,
              verify: bool = False, joint: int | str | None = None, top: int = 3,
              rules: str | Path | RuleBase | None = None, dt: float = 1e-4,
              ) -> Recommendations:
    """Choose synthesis methods for a drive's requirements, least complexity first (paper 5).

    Args:
        requirements: a :class:`Requirements`, a plain dict of its fields or a
            YAML file path.
        robot: a robot (object, catalog name or file) to derive missing fields
            from and, with ``verify``, to synthesize and simulate.
        trajectory: a trajectory (object or YAML file) for the same.
        verify: synthesize the ``top`` candidates, simulate them along the
            trajectory and re-rank by measured accuracy, then complexity. Without it
            every recommendation's ``accuracy`` is "unverified" and, when an accuracy
            is asked, ``notes`` says so (the rules cannot know the error a method
            reaches).
        joint: the joint whose drive is designed (overrides ``requirements.joint``);
            None: the whole robot (derived fields at their worst joint; verify
            puts the candidate on every driven joint).
        top: how many candidates ``verify`` simulates at least; while none of them
            meets the accuracy it goes on down the list.
        rules: another rule file (default: the package's rules.yaml).
        dt: simulation step of ``verify``, s (the regulators' period).

    Returns:
        :class:`Recommendations` (a list, best first, with ``.excluded``).

    Raises:
        InputError: a bad requirements file or value.
        IncompleteRequirements: a rule needs fields neither given nor derivable.
        ContradictoryRequirements: the fields contradict each other, or every
            method is excluded.
        ManipcadError: verify without the synthesis package, a robot or a trajectory.

    Example:
        >>> from manipcad.expert import recommend
        >>> recs = recommend({"accuracy": 1e-3, "overshoot_allowed": False,
        ...                   "fast_action": True, "gripper_speed": 1.0,
        ...                   "inductance": "negligible", "coupling": "inertial",
        ...                   "parameter_variation": "slow",
        ...                   "transmission": {"backlash": False, "elasticity": False}})
        >>> recs.best.method, recs.best.accuracy    # the rules alone: not a promise
        ('asvs', 'unverified')
    """
    rb = rules if isinstance(rules, RuleBase) else load_rules(rules)
    req = Requirements.coerce(requirements)
    if joint is not None:
        req = req.model_copy(update={"joint": joint})
    if robot is not None:

        robot = load_robot(robot)
        if isinstance(trajectory, str | Path):

            trajectory = load_trajectory(trajectory, robot=robot)
    req, derived, notes = derive(req, robot, trajectory)

    # contradictions within the requirement set
    bad = [c for c in rb.contradictions if evaluate(c.when, req) is True]
    if bad:
        fields = list(dict.fromkeys(f for c in bad for f in c.fields))
        lines = [f"{c.id} ({c.section}): {_values(req, c.fields)}: {c.reason}" for c in bad]
        raise ContradictoryRequirements("contradictory requirements: " + "; ".join(lines),
                                        fields)

    fired: list[Rule] = []
    pending: list[tuple[Rule, list[str]]] = []
    for r in rb.rules:
        miss: list[str] = []
        res = evaluate(r.when, req, miss)
        if res is True:
            fired.append(r)
        elif res is None:
            pending.append((r, list(dict.fromkeys(miss))))

    excluded: dict[str, list[str]] = {}
    excluded_by: dict[str, list[str]] = {}
    score = dict.fromkeys(METHODS, 0.0)
    reasons: dict[str, list[str]] = {m: [] for m in METHODS}
    for r in fired:
        for m in r.exclude:
            excluded.setdefault(m, []).append(r.text())
            excluded_by.setdefault(m, []).append(r.id)
        if r.require:
            for m in METHODS:
                if m not in r.require:
                    excluded.setdefault(m, []).append(
                        f"{r.id} ({r.section}) requires {' or '.join(r.require)}: {r.reason}")
                    excluded_by.setdefault(m, []).append(r.id)
            for m in r.require:
                reasons[m].append(r.text())
        for m, w in r.prefer:
            score[m] += w
            if r.text() not in reasons[m]:
                reasons[m].append(r.text())

    # undecided rules: an error unless nothing they could do changes the answer
    survivors = [m for m in METHODS if m not in excluded]
    needed, undecided = [], []
    for r, miss in pending:
        live = set(survivors)
        # a preference cannot reorder a single survivor
        harmless = (not (set(r.exclude) & live)
                    and (not ({m for m, _ in r.prefer} & live) or len(live) <= 1)
                    and (not r.require or live <= set(r.require)))
        (undecided if harmless else needed).append((r, miss))
    if needed:
        missing: dict[str, list[str]] = {}
        for r, miss in needed:
            for f in miss:
                missing.setdefault(f, []).append(r.id)
        parts = []
        for f, ids in missing.items():
            why = "not given"
            top_field = f.split(".")[0]
            d = derived.get(top_field)
            if d is not None and d.error:
                why = d.error
            elif top_field == "transmission":
                why = "not given (the robot model has no transmission: state it)"
            elif top_field not in ("gripper_speed", "coupling", "inductance",
                                   "parameter_variation", "load_variation"):
                why = "not given (it cannot be derived from a robot)"
            parts.append(f"{f} ({why}; needed by {', '.join(ids)})")
        raise IncompleteRequirements("incomplete requirements: " + "; ".join(parts), missing)

    if not survivors:
        involved = [r for r in fired if r.exclude or r.require]
        fields = list(dict.fromkeys(f for r in involved for f in r.fields))
        lines = []
        for r in involved:
            eff = (f"requires {' or '.join(r.require)}" if r.require
                   else f"excludes {', '.join(r.exclude)}")
            lines.append(f"{r.id} [{_values(req, r.fields)}] {eff}")
        raise ContradictoryRequirements(
            "contradictory requirements: no method meets every rule: " + "; ".join(lines)
            + f" (fields involved: {', '.join(fields)})", fields)

    n = robot.n if robot is not None else DEFAULT_N
    recs = []
    for m in survivors:
        cx = base_complexity(rb, m, n, robot)
        rs = reasons[m] or ["meets every rule that fired; ranked by realization complexity"]
        recs.append(Recommendation(method=m, reasons=list(rs), complexity=cx,
                                   score=score[m], cost=complexity_cost(cx, rb.weights)))
    recs.sort(key=lambda r: (-r.score, r.cost, r.method))
    out = Recommendations(recs, excluded={m: " | ".join(v) for m, v in excluded.items()},
                          requirements=req, derived=derived, fired=[r.id for r in fired],
                          undecided=[r.id for r, _ in undecided], rules_source=rb.source)
    out.excluded_by = excluded_by
    out.notes = notes
    out.rule_texts = {r.id: r.text() for r in fired}
    if verify:
        _verify(out, rb, robot, trajectory, top=top, dt=dt)
    elif req.accuracy is not None:
        out.notes.append(UNVERIFIED_NOTE.format(accuracy=req.accuracy))
    return out


# ---------------------------------------------------------------------- verification

#: said when the ranking comes from the rules alone and an accuracy was asked
UNVERIFIED_NOTE = (
    "accuracy {accuracy:.3g} not verified: the rules rank the methods that can meet the "
    "requirements by what they know (coupling, speed, inductance, transmission, "
    "overshoot; least realization complexity first, paper section 5), not by the error "
    "each reaches on this robot and trajectory; the first is not promised to reach "
    "{accuracy:.3g}. Verify by simulation (--verify, or recommend(..., verify=True)) "
    "before choosing.")


def _verify(out: Recommendations, rb: RuleBase, robot, trajectory, *, top: int,
            dt: float) -> None:
    """Synthesize, simulate and re-rank ``out`` in place (see :func:`recommend`)."""

    if robot is None or trajectory is None:
        raise ManipcadError("verification needs a robot and a trajectory to simulate along")

    req = out.requirements
    if req.accuracy is None:
        raise IncompleteRequirements("incomplete requirements: accuracy (not given; verify "
                                     "compares the simulated error with it)",
                                     {"accuracy": ["verify"]})
    drives = robot.drives or ()
    driven = [j for j in range(robot.n) if j < len(drives) and drives[j] is not None]
    if req.joint is not None:
        targets = [robot.joint_index(req.joint)]
        if targets[0] not in driven:
            raise ManipcadError(f"joint {robot.joint_names[targets[0]]!r} has no drive to verify")
    else:
        targets = driven
    t_end = float(trajectory.duration)
    others = []
    for j in driven:
        if j not in targets:
            try:
                others.append(synthesize(robot, j, "pid", period=dt))
            except ManipcadError as exc:
                raise ManipcadError(f"verify: cannot design the PID that drives the other "
                                    f"joint {robot.joint_names[j]!r}: {exc}") from None
    # deferred: start-up cost: keeps manipcad.sim.checks out of import manipcad
    from manipcad.sim.checks import run_checks

    done, met = 0, False
    for rec in out:
        if done >= top and met:
            rec.note = (f"not verified (the top {top} are simulated, and further ones only "
                        "until one passes every check)")
            continue
        if rec.method not in SYNTH:
            rec.note = "not verified: the synthesis package has no such method"
            continue
        done += 1
        try:
            regs = [synthesize(robot, j, rec.method, period=dt) for j in targets]
            res = simulate(robot, t_end=t_end, dt=dt, trajectory=trajectory,
                           regulators=[*regs, *others])
        except ManipcadError as exc:
            rec.meets_accuracy, rec.note = False, f"synthesis or simulation failed: {exc}"
            continue
        err = np.abs(res.error[:, targets])
        rec.max_error = float(err.max()) if np.isfinite(err).all() else math.inf
        rec.meets_accuracy = rec.max_error <= req.accuracy
        names = [robot.joint_names[j] for j in targets]
        checks = run_checks(res, robot, accuracy={nm: req.accuracy for nm in names})
        rec.checks = {nm: checks.to_dict()[nm] for nm in names}
        rec.failed = [f"{j}: {k} {c.value:.3g} of {c.limit:.3g} {c.unit}"
                      for j, k, c in checks.failures() if j in names]
        met = met or rec.verdict == "pass"
        cx = realization_complexity(regs[0])
        cx = {"gains_stored": int(cx.get("gains_stored", 0)),
              "ops_per_period": int(cx.get("ops_per_period", 0)),
              "signals": list(cx.get("signals", [])), "source": "synthesis"}
        rec.complexity, rec.cost = cx, complexity_cost(cx, rb.weights)
        worst = robot.joint_names[targets[int(np.argmax(err.max(axis=0)))]]
        rec.note = (f"simulated along the trajectory ({t_end:g} s, dt = {dt:g} s): max error "
                    f"{rec.max_error:.3g} ({worst}) {'<=' if rec.meets_accuracy else '>'} "
                    f"accuracy {req.accuracy:.3g}"
                    + (f"; fails {len(rec.failed)} check{'s' * (len(rec.failed) > 1)}: "
                       + "; ".join(rec.failed) if rec.failed else "")
                    + ("; checks unknown: " + ", ".join(
                        f"{j}: {k}" for j, k, _ in checks.failures("unknown") if j in names)
                       if rec.verdict == "unknown" else ""))

    def key(r: Recommendation):
        # every check passed, then none failed (one unknown), then not simulated, then
        # failed (by the error, then the number of failed checks)
        v = r.verdict
        if v == "pass":
            return (0, r.cost, 0.0, r.method)
        if v == "unknown":
            return (1, r.cost, 0.0, r.method)
        if v == "unverified":
            return (2, -r.score, r.cost, r.method)
        return (3, r.max_error if r.max_error is not None else math.inf, len(r.failed),
                r.method)

    out.sort(key=key)
    out.verified = True
    out.order = VERIFIED_ORDER


__all__ = ["recommend", "Recommendation", "Recommendations", "load_rules", "RuleBase", "Rule",
           "IncompleteRequirements", "ContradictoryRequirements", "evaluate",
           "base_complexity", "complexity_cost", "METHODS", "RULES_FILE", "Derivation"]
