"""``manipcad recommend``: the expert system's choice of synthesis methods (paper 5, Fig. 1).

::

    manipcad recommend REQUIREMENTS.yaml [--robot R --trajectory T] [--joint J]
                       [--verify] [--top K] [--rules FILE] [--json]

Reads the requirements (docs/expert-rules.md), derives the fields left out from
the robot and the trajectory, applies the rule base and prints the methods that
meet every rule — most preferred by the rules first, then the least realization
complexity — with the rules that put each there, and the excluded methods with
why. ``--verify`` synthesizes and simulates the top candidates and re-ranks by the
measured error and every run check (docs/checks.md): a method ranks first only
if its run passes every check (tracking, amplifier saturation, chattering,
currents, speeds, gear and joint limits); one that meets the accuracy by
saturating, chattering or overloading is listed below with the check it fails.
Exit status 0, or with ``--verify`` 1 when no simulated method passes every
check. Bad input, incomplete or contradictory requirements exit with status 2
and one line on stderr.
"""

from __future__ import annotations

import json
import math
import warnings
from typing import Annotated

import typer
from rich import box
from rich.markup import escape

from manipcad.cli.app import app, console, guarded
from manipcad.cli.options import json_flag, option
from manipcad.cli.tables import Table, styled
from manipcad.errors import InputError, ManipcadWarning
from manipcad.expert import Requirements
from manipcad.expert import recommend as run


def _json_default(v):
    if isinstance(v, float) and not math.isfinite(v):
        return str(v)
    return str(v)


@app.command()
@guarded
def recommend(
    requirements: Annotated[str, typer.Argument(help="Requirements YAML file.")],
    robot: option(str | None, "--robot", "Catalog robot name or robot file, to derive missing "
                  "fields.") = None,
    trajectory: option(str | None, "--trajectory -t", "Trajectory YAML file, to derive missing "
                       "fields.") = None,
    joint: option(str | None, "--joint -j", "The joint whose drive is designed (name or number "
                  "1..n, as every command).") = None,
    verify: option(bool, "--verify", "Synthesize and simulate the top candidates; "
                   "re-rank by error.") = False,
    top: option(int, "--top", "Candidates --verify simulates.") = 3,
    rules: option(str | None, "--rules", "Another rule file (default: the package's "
                  "rules.yaml).") = None,
    as_json: json_flag() = False,
) -> None:
    """Recommend synthesis methods for a drive's requirements, least complexity first."""

    if trajectory is not None and robot is None:
        raise InputError("--trajectory", "", "needs --robot (the trajectory moves a robot)")
    if top < 1:
        raise InputError("--top", "", f"must be >= 1, got {top}")
    req = Requirements.from_yaml(requirements)
    jt: str | int | None = joint
    if joint is not None and joint.isdigit():
        if int(joint) < 1:
            raise InputError("--joint", "", f"joint numbers run from 1, got {joint}")
        jt = int(joint) - 1
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        recs = run(req, robot, trajectory, verify=verify, joint=jt, top=top, rules=rules)
    none_pass = recs.verified and not any(r.verdict == "pass" for r in recs)
    if as_json:
        print(json.dumps({"requirements_file": requirements, **recs.to_dict()}, indent=2,
                         default=_json_default))
        if none_pass:
            raise typer.Exit(1)
        return

    given = req.given()
    rows = []
    for f, v in recs.requirements.given().items():
        d = recs.derived.get(f.split(".")[0])
        src = "given" if f in given else ("derived" if d is not None and d.value is not None
                                          else "")
        rows.append((f, v, src, d.how if src == "derived" else ""))
    t = Table(box=box.SIMPLE_HEAD, title=f"requirements ({requirements})")
    for col in ("field", "value", "", "how derived"):
        t.add_column(col, overflow="fold")
    for f, v, src, how in rows:
        t.add_row(f, f"{v:.4g}" if isinstance(v, float) else str(v), src, how)
    console.print(t)

    title = "recommended methods" + (" (verified by simulation)" if recs.verified else
                                      " (by the rules only: accuracy not verified)")
    table = Table(box=box.SIMPLE_HEAD, title=title)
    for col, just in (("#", "right"), ("method", "left"), ("score", "right"),
                      ("gains", "right"), ("ops/period", "right"), ("signals", "right")):
        table.add_column(col, justify=just, overflow="fold")
    if recs.verified:
        table.add_column("max error", justify="right")
    table.add_column("accuracy", justify="left")
    if recs.verified:
        table.add_column("checks", justify="left", overflow="fold")
    table.add_column("reasons (rules)", overflow="fold")
    for k, r in enumerate(recs, 1):
        c = r.complexity
        row = [str(k), styled(r.method, "bold"), f"{r.score:g}", str(c["gains_stored"]),
               str(c["ops_per_period"]), str(len(c["signals"]))]
        if recs.verified:
            if r.max_error is None:
                row.append("—")
            else:
                style = "green" if r.meets_accuracy else "red"
                row.append(styled(f"{r.max_error:.3g}", style))
        row.append(styled(r.accuracy if r.accuracy in ("met", "missed") else "unverified",
                          {"met": "green", "missed": "red"}.get(r.accuracy, "yellow")))
        if recs.verified:
            row.append(styled(r.verdict, {"pass": "green"}.get(r.verdict, "yellow"))
                       if r.verdict in ("pass", "unknown", "unverified") else
                       styled(f"✗ fail ({len(r.failed) or 'not run'})", "red"))
        ids = [x.split(" ", 1)[0] for x in r.reasons if x.split(" ", 1)[0] in recs.rule_texts]
        row.append(", ".join(ids) or "meets every fired rule")
        table.add_row(*row)
    console.print(table)
    src = sorted({r.complexity.get("source", "") for r in recs})
    console.print(f"[dim]{escape(recs.order)} (complexity from the {' and '.join(src)}); "
                  "errors in rad or m[/]", highlight=False)
    notes = [(k, r) for k, r in enumerate(recs, 1) if r.note]
    for k, r in notes:
        console.print(f"  {k}. {r.method}: {r.note}", highlight=False)
    if recs.excluded_by:
        ex = Table(box=box.SIMPLE_HEAD, title="excluded methods")
        ex.add_column("method")
        ex.add_column("excluded by (rules)", overflow="fold")
        for m, ids in recs.excluded_by.items():
            ex.add_row(m, ", ".join(ids))
        console.print(ex)
    if recs.rule_texts:
        console.print("[bold]rules that fired[/]")
        for text in recs.rule_texts.values():
            console.print(f"- {text}", highlight=False)
    for note in recs.notes:
        console.print(f"[yellow]note:[/] {note}", highlight=False)
    if recs.verified:
        passing = [r.method for r in recs if r.verdict == "pass"]
        console.print("verdict: " + (f"[green]{passing[0]} passes every check[/]" if passing
                                     else "[red]no method simulated passes every check[/]"),
                      highlight=False)
    if recs.undecided:
        console.print(f"[dim]undecided rules (no value of their missing fields could change "
                      f"the answer): {', '.join(recs.undecided)}[/]", highlight=False)
    if none_pass:
        raise typer.Exit(1)
