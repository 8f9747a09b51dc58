"""``manipcad catalog``: the parts library (docs/catalog.md).

``manipcad catalog list [--kind motor|gear] [--makers maxon,...] [--where EXPR]
[--ws DIR] [--json]`` lists the motors and gears (SI units; ``-`` unknown);
``manipcad catalog show NAME [--ws DIR] [--json]`` prints every field of one part
with its unit, whether it is printed, derived or assumed, the part's source and
what it mounts on. Bad input exits with status 2 and one line on stderr.
"""

from __future__ import annotations

import json
import math
from typing import Annotated, Any

import typer
from rich.markup import escape

from manipcad import catalog
from manipcad.cli.app import app, console, guarded
from manipcad.cli.options import json_flag, option, ws_option
from manipcad.cli.tables import Table
from manipcad.errors import InputError
from manipcad.fileio import json_safe

catalog_app = typer.Typer(
    help="The parts library: thousands of data-sheet motors and gears, with sources.",
    no_args_is_help=True,
)
app.add_typer(catalog_app, name="catalog")

#: the columns of the listing per kind: (column, header, scale, format)
_MOTOR_COLS = (("maker", "maker", None, ""), ("model", "model", None, ""),
               ("type", "type", None, ""), ("rated_voltage", "U_N V", 1.0, ".3g"),
               ("k_m", "k_m N·m/A", 1.0, ".3g"), ("R", "R Ω", 1.0, ".3g"),
               ("J", "J kg·m²", 1.0, ".3g"), ("rated_torque", "M_N N·m", 1.0, ".3g"),
               ("peak_torque", "M_peak N·m", 1.0, ".3g"),
               ("max_speed", "n_max rad/s", 1.0, ".4g"), ("mass", "mass kg", 1.0, ".3g"))
_GEAR_COLS = (("maker", "maker", None, ""), ("model", "model", None, ""),
              ("type", "type", None, ""), ("ratio", "ratio", 1.0, ".4g"),
              ("efficiency", "η", 1.0, ".3g"), ("efficiency_basis", "η basis", None, ""),
              ("max_continuous_torque", "T_rated N·m", 1.0, ".3g"),
              ("max_intermittent_torque", "T_peak N·m", 1.0, ".3g"),
              ("J", "J_in kg·m²", 1.0, ".3g"), ("mass", "mass kg", 1.0, ".3g"))


def _cell(v: Any, fmt: str) -> str:
    if isinstance(v, float):
        return "-" if math.isnan(v) else format(v, fmt)
    return str(v)


def _kinds(kind: str | None) -> tuple[str, ...]:
    if kind is None:
        return ("motor", "gear")
    k = kind.strip().lower().rstrip("s")
    if k not in ("motor", "gear"):
        raise InputError("--kind", "", f"{kind!r}: expected motor or gear")
    return (k,)


@catalog_app.command("list")
@guarded
def list_parts(
    kind: option(str | None, "--kind", "motor or gear (default both).") = None,
    makers: option(str | None, "--makers", "Comma-separated makers: maxon, faulhaber, "
                   "allied_motion, tmotor, 'Harmonic Drive', Beckhoff, ... (default all).") = None,
    where: option(str | None, "--where", "A filter over the columns (SI units), e.g. \"k_t > 0.1 "
                  "and mass < 1\"; see docs/catalog.md for the columns.") = None,
    ws: ws_option("Also list this workspace's motors and gears.") = None,
    as_json: json_flag("Print JSON (every column).") = False,
) -> None:
    """List the library's motors and gears (SI units; '-' where the source prints none)."""

    mk = [m for m in makers.split(",") if m.strip()] if makers else None
    tables = {k: (catalog.motors(makers=mk, where=where, ws=ws) if k == "motor"
                  else catalog.gears(makers=mk, where=where, ws=ws)) for k in _kinds(kind)}
    if as_json:
        out = {f"{k}s": [json_safe(r) for r in df.to_dict(orient="records")]
               for k, df in tables.items()}
        out["units"] = {"motors": catalog.MOTOR_UNITS, "gears": catalog.GEAR_UNITS}
        typer.echo(json.dumps(out, indent=1, allow_nan=False, ensure_ascii=False))
        return
    for k, df in tables.items():
        cols = _MOTOR_COLS if k == "motor" else _GEAR_COLS
        t = Table(title=f"{len(df)} {k}s (manipcad catalog show NAME)")
        t.add_column("name", overflow="fold")
        for _, head, scale, _ in cols:
            t.add_column(head, justify="left" if scale is None else "right", overflow="fold")
        for name, row in df.iterrows():
            t.add_row(str(name), *(_cell(row[c], f) for c, _, _, f in cols))
        console.print(t)


@catalog_app.command("show")
@guarded
def show_part(
    name: Annotated[str, typer.Argument(help="A part name of 'manipcad catalog list'.")],
    ws: ws_option("Look in this workspace's motors and gears too.") = None,
    as_json: json_flag("Print JSON.") = False,
) -> None:
    """Every field of one part with its unit, its source, and what it mounts on."""

    doc = catalog.describe(name, ws=ws)
    if doc["kind"] == "motor":
        pairs = catalog.compatible_pairs(catalog.motors(ws=ws).loc[[name]], catalog.gears(ws=ws))
        mates = pairs["gear"]
    else:
        pairs = catalog.compatible_pairs(catalog.motors(ws=ws), catalog.gears(ws=ws).loc[[name]])
        mates = pairs["motor"]
    doc["compatible"] = {"count": int(len(pairs)),
                         "rules": pairs["rule"].value_counts().to_dict(),
                         "first": mates.head(10).tolist()}
    if as_json:
        typer.echo(json.dumps(json_safe(doc), indent=2, allow_nan=False, ensure_ascii=False))
        return
    console.print(f"[bold]{escape(name)}[/]: {escape(doc['kind'])}, {escape(doc['maker'])} "
                  f"{escape(str(doc['model']))} ({escape(doc['origin'])}"
                  + (f", confidence {escape(doc['confidence'])}" if doc["confidence"] else "")
                  + ")", soft_wrap=True)
    t = Table(show_lines=False)
    for col in ("field", "value", "unit", "note"):
        t.add_column(col, justify="right" if col == "value" else "left", overflow="fold")
    for f in doc["fields"]:
        t.add_row(f["field"], _cell(f["value"], ".6g"), f["unit"],
                  f["note"] or ("-" if math.isnan(f["value"]) else "printed"))
    console.print(t)
    console.print(f"source: {escape(doc['source'])}", soft_wrap=True, highlight=False)
    other = "gears" if doc["kind"] == "motor" else "motors"
    rules = "; ".join(f"{n} by {r.split(':')[0]}" for r, n in doc["compatible"]["rules"].items())
    console.print(f"mounts with {doc['compatible']['count']} {other}"
                  + (f" ({escape(rules)})" if rules else ""), soft_wrap=True, highlight=False)
