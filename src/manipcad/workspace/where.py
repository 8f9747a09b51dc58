"""``--where``: filters on result metrics, parsed into parameterized SQL (no injection).

Grammar (case-insensitive ``and``; no ``or``, no parentheses)::

    FILTER  := CLAUSE ("and" CLAUSE)*
    CLAUSE  := METRIC ["[" JOINT "]"] OP NUMBER  |  "status" ("=" | "!=") WORD
             | "verdict" ["[" JOINT "]"] ("=" | "!=") ("pass" | "fail" | "unknown")
    OP      := "<" | "<=" | ">" | ">=" | "=" | "==" | "!="

``verdict`` is the run checks' verdict (docs/checks.md): ``fail`` when a check fails,
``unknown`` when none fails and one is unknown, ``pass`` otherwise; a result stored
without checks has none and matches neither. ``fails``/``unknowns`` count a joint's
failed/unknown checks, ``check_NAME`` is a check's value (``check_saturation>0.05``).

``max_error<1e-3`` tests the largest value over the joints (the ``*`` row of
the index); ``max_error[elbow]<1e-3`` one joint. Metric names come from a
whitelist (:data:`METRICS`), operators from a fixed table; the user's text
reaches SQL only as bound parameters.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass

from manipcad.errors import InputError
from manipcad.sim.checks import CHECKS

#: metric name -> (unit, meaning); per joint and, as the largest over the joints, "*"
METRICS: dict[str, tuple[str, str]] = {
    "max_error": ("rad|m", "largest |q_ref - q|"),
    "rms_error": ("rad|m", "RMS of q_ref - q"),
    "overshoot": ("1", "overshoot of a step, fraction"),
    "rise_time": ("s", "10-90 % rise time of a step"),
    "settling_time": ("s", "2 % settling time of a step"),
    "effort_rms": ("V|N·m|N", "RMS regulator output"),
    "energy": ("J", "drive energy"),
    "peak_torque": ("N·m|N", "largest |tau|"),
    "rms_torque": ("N·m|N", "RMS of tau"),
    "peak_current": ("A", "largest |armature current|"),
    "rms_current": ("A", "RMS armature current"),
    "peak_power": ("W", "largest |tau · qd| (mechanical power at the joint)"),
    "samples": ("1", "stored samples (all joints)"),
    "t_final": ("s", "last stored time (all joints)"),
    "fails": ("1", "how many run checks fail"),
    "unknowns": ("1", "how many run checks are unknown"),
    **{f"check_{k}": (v[1] if v[1] == v[2] else f"{v[1]}|{v[2]}", f"run check: {v[0]}")
       for k, v in CHECKS.items()},
}
#: the run checks' verdicts a ``verdict`` clause takes
VERDICTS = ("pass", "fail", "unknown")

#: operator text -> SQL (the only SQL text derived from the user's filter)
OPERATORS = {"<": "<", "<=": "<=", ">": ">", ">=": ">=", "=": "=", "==": "=", "!=": "!="}

_CLAUSE = re.compile(
    r"^\s*(?P<field>[A-Za-z_][A-Za-z0-9_]*)\s*(?:\[\s*(?P<joint>[^\]]+?)\s*\])?\s*"
    r"(?P<op><=|>=|==|!=|<|>|=)\s*(?P<value>\S+)\s*$")


@dataclass(frozen=True)
class Clause:
    """One parsed condition: ``field[joint] op value`` (joint "*" = largest over joints)."""

    field: str
    joint: str
    op: str
    value: float | str


def parse_where(text: str, source: str = "--where") -> list[Clause]:
    """Parse a filter (grammar in the module docstring).

    Raises:
        InputError: naming ``source``, the clause and the reason (unknown metric
            with the list of known ones, bad operator, value not a number).

    Example:
        >>> [(c.field, c.joint, c.op, c.value) for c in parse_where("max_error<1e-3 and status=ok")]
        [('max_error', '*', '<', 0.001), ('status', '*', '=', 'ok')]
    """
    if not text or not text.strip():
        raise InputError(source, "", "empty filter")
    out = []
    for part in re.split(r"\s+and\s+", text.strip(), flags=re.IGNORECASE):
        m = _CLAUSE.match(part)
        if m is None:
            raise InputError(source, "", f"cannot read {part!r}: expected METRIC OP NUMBER, "
                             "e.g. max_error<1e-3 or rms_error[elbow]<=2e-4 "
                             f"(operators {' '.join(OPERATORS)}; clauses joined by 'and')")
        field, joint, op, value = m["field"], m["joint"] or "*", m["op"], m["value"]
        if field == "status":
            if op not in ("=", "==", "!=") or m["joint"]:
                raise InputError(source, "", f"{part!r}: status takes = or != and a word")
            out.append(Clause("status", "*", OPERATORS[op], value.strip("'\"")))
            continue
        if field == "verdict":
            word = value.strip("'\"").lower()
            if op not in ("=", "==", "!=") or word not in VERDICTS:
                raise InputError(source, "", f"{part!r}: verdict takes = or != and one of "
                                 f"{', '.join(VERDICTS)}")
            out.append(Clause("verdict", joint, OPERATORS[op], word))
            continue
        if field not in METRICS:
            raise InputError(source, "", f"{part!r}: unknown metric {field!r}; metrics: "
                             + ", ".join(METRICS) + ", status")
        try:
            number = float(value)
        except ValueError:
            raise InputError(source, "", f"{part!r}: {value!r} is not a number") from None
        if math.isnan(number):
            raise InputError(source, "", f"{part!r}: nan compares with nothing")
        out.append(Clause(field, joint, OPERATORS[op], number))
    return out


def where_sql(clauses: list[Clause]) -> tuple[str, list[object]]:
    """SQL condition on the ``items`` table and its parameters for parsed clauses.

    Example:
        >>> sql, params = where_sql(parse_where("peak_torque[q1]>=10"))
        >>> params
        ['q1', 'peak_torque', 10.0]
    """
    parts, params = [], []
    for c in clauses:
        op = OPERATORS[c.op]  # from the fixed table only
        if c.field == "status":
            parts.append(f"items.status {op} ?")
            params.append(c.value)
            continue
        if c.field == "verdict":
            # from the indexed counts: fail = some check fails; unknown = none fails and
            # one is unknown; pass = none fails or is unknown (a result with checks only)
            cond = {"fail": [("fails", ">", 0.0)],
                    "unknown": [("fails", "=", 0.0), ("unknowns", ">", 0.0)],
                    "pass": [("fails", "=", 0.0), ("unknowns", "=", 0.0)]}[c.value]
            sub = " AND ".join(
                f"EXISTS (SELECT 1 FROM metrics m WHERE m.item_id = items.id AND "
                f"m.joint = ? AND m.metric = ? AND m.value {o} ?)" for _, o, _ in cond)
            parts.append(f"({sub})" if op == "=" else
                         f"(EXISTS (SELECT 1 FROM metrics m WHERE m.item_id = items.id AND "
                         f"m.metric = 'fails') AND NOT ({sub}))")
            for metric, _, v in cond:
                params += [c.joint, metric, v]
            continue
        parts.append("EXISTS (SELECT 1 FROM metrics m WHERE m.item_id = items.id AND "
                     f"m.joint = ? AND m.metric = ? AND m.value {op} ?)")
        params += [c.joint, c.field, c.value]
    return " AND ".join(parts), params
