"""``manipcad ws``: the designer's workspace (docs/workspace.md).

::

    manipcad ws init [DIR]
    manipcad ws add FILE [--kind K] [--name N] [--force] [--robot R]
    manipcad ws list [KIND] [--where "max_error<1e-3"] [--json]
    manipcad ws show NAME [--json] [--csv]
    manipcad ws rm NAME [--cascade]
    manipcad ws compare R1 R2 ... [--plot FILE] [--json]
    manipcad ws rerun RESULT [--json]
    manipcad ws check [--json]
    manipcad ws export NAME --to DIR
    manipcad ws reindex

Every command takes ``--ws DIR`` (default ``$MANIPCAD_WORKSPACE``, else
``./manipcad-ws``). The logic lives in :mod:`manipcad.workspace`.
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path
from typing import Annotated, Any

import typer
from rich import box

from manipcad.cli.app import app, console, guarded
from manipcad.cli.options import force_flag, option
from manipcad.cli.tables import Table
from manipcad.errors import InputError
from manipcad.fileio import atomic_write, json_safe, writable_target

ws_app = typer.Typer(help="The workspace: add, list, compare and re-run robots, motors, "
                     "gears, trajectories, regulators, results and studies.",
                     no_args_is_help=True)
app.add_typer(ws_app, name="ws")

WsOpt = option(Path | None, "--ws", "Workspace folder (default: $MANIPCAD_WORKSPACE, else "
               "./manipcad-ws).")
JsonOpt = option(bool, "--json", "Print JSON instead of a table.")


def _complete_names(ctx: typer.Context, incomplete: str) -> list[str]:
    """Shell completion of item names from the workspace (--ws or the default)."""
    # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
    from manipcad.workspace import Workspace

    try:
        w = Workspace(ctx.params.get("ws"))
        names = [i.name for i in w.list()]
        w.close()
    except Exception:  # completion must never fail loudly
        return []
    return [n for n in names if n.startswith(incomplete)]


def _open(ws: Path | None):
    # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
    from manipcad.workspace import Workspace

    return Workspace(ws)


def _num(x: Any, fmt: str = ".3g") -> str:
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    return format(x, fmt)


def _echo_json(doc: Any) -> None:

    typer.echo(json.dumps(json_safe(doc), indent=2))


@ws_app.command("init")
@guarded
def init(folder: Annotated[Path | None, typer.Argument(
        help="The new workspace folder (default: --ws, $MANIPCAD_WORKSPACE or ./manipcad-ws).")]
         = None, ws: WsOpt = None) -> None:
    """Make a workspace: robots/, motors/, gears/, trajectories/, regulators/,
    results/, studies/ and the index index.sqlite."""
    # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
    from manipcad.workspace import Workspace

    w = Workspace.init(folder or ws)
    console.print(f"workspace {w.root} ready (index {w.root / 'index.sqlite'})", highlight=False)


@ws_app.command("add")
@guarded
def add(source: Annotated[Path, typer.Argument(
            help="A robot (.yaml, .urdf, MJCF .xml), motor, gear, trajectory or regulator "
                 "file, a result or study folder, or a bundle from 'ws export' (the folder "
                 "it wrote, TO/NAME).")],
        kind: option(str | None, "--kind", "robot, motor, gear, trajectory, regulator, result or "
                     "study (default: recognized from the content).") = None,
        name: option(str | None, "--name", "The item's name (default: the file name).") = None,
        force: force_flag("Replace an item of the same kind and name.") = False,
        robot: option(str | None, "--robot", "Check a regulator or Cartesian trajectory against "
                      "this robot (workspace name, catalog name or file).") = None,
        ws: WsOpt = None, as_json: JsonOpt = False) -> None:
    """Add a file or folder (copied, validated, indexed)."""
    w = _open(ws)
    added = w.add(source, kind=kind, name=name, force=force, robot=robot)
    items = added if isinstance(added, list) else [added]
    if as_json:
        _echo_json([i.to_dict() for i in items])
        return
    for i in items:
        console.print(f"added {i.ref} ({i.path}, sha256 {i.hash[:12]})", highlight=False)
    if not items:
        console.print("nothing new: the bundle's items are already here")


_SINGULAR = {"robots": "robot", "motors": "motor", "gears": "gear",
             "trajectories": "trajectory", "regulators": "regulator", "results": "result",
             "studies": "study"}


def _list_table(items, title: str) -> Table:
    """The listing: item (kind/name), origin (with --catalog), created (or, when results
    are listed, their status and key metrics, largest over the joints), hash. Cells
    wrap; nothing is cut."""
    results = any(i.kind == "results" for i in items)
    origin = any(i.source.startswith("catalog") for i in items)
    table = Table(title=title, box=box.SIMPLE_HEAD, pad_edge=False)
    table.add_column("item", overflow="fold", min_width=12, ratio=3)
    if origin:
        table.add_column("origin", overflow="fold")
    if results:
        table.add_column("status", overflow="fold")
        for col in ("max|e|", "RMS e", "peak τ", "peak i"):
            table.add_column(col, justify="right", overflow="fold", min_width=8)
    else:  # results show their creation time in 'ws show' (the metrics need the width)
        table.add_column("created UTC", overflow="fold", min_width=10)
    table.add_column("sha256", overflow="fold", min_width=8)
    for i in items:
        row = [f"{_SINGULAR[i.kind]}/{i.name}"]
        if origin:
            row.append("catalog" if i.source.startswith("catalog") else "user")
        if results:
            m = i.metrics
            row += [i.status or "", _num(m.get("max_error")), _num(m.get("rms_error")),
                    _num(m.get("peak_torque")), _num(m.get("peak_current"))]
        else:
            row.append(i.created.replace("+00:00", "")[:16].replace("T", " "))
        row.append(i.hash[:8])
        table.add_row(*row)
    if results:
        table.caption = ("max|e|, RMS e: rad or m; peak τ: N·m or N; peak i: A "
                         "(largest over the joints)")
    return table


@ws_app.command("list")
@guarded
def list_items(kind: Annotated[str | None, typer.Argument(
                   help="Only this kind (robot, motor, gear, trajectory, regulator, result, "
                        "study).")] = None,
               where: option(str | None, "--where", "Filter results by metrics, e.g. "
                             "\"max_error<1e-3 and status=ok\" or \"rms_error[elbow]<=2e-4\" "
                             "(largest over joints unless a [joint] is given).") = None,
               catalog: option(bool, "--catalog", "Also list the built-in catalog's robots, motors "
                               "and gears (read-only), with their origin.") = False,
               ws: WsOpt = None, as_json: JsonOpt = False) -> None:
    """List the items, with results' key metrics (largest over the joints)."""
    w = _open(ws)
    items = w.library(kind, where=where) if catalog else w.list(kind, where=where)
    if as_json:
        _echo_json([i.to_dict() for i in items])
        return
    console.print(_list_table(items, f"workspace {w.root}: {len(items)} items"))


@ws_app.command("show")
@guarded
def show(name: Annotated[str, typer.Argument(help="NAME or KIND/NAME.",
                                                        autocompletion=_complete_names)],
         ws: WsOpt = None, as_json: JsonOpt = False,
         csv: option(bool, "--csv", "A result's time series as CSV on stdout "
                     "(units in the header).") = False) -> None:
    """Show an item: file, hash, provenance, metrics and what depends on it."""
    w = _open(ws)
    item = w.get(name)
    if csv:
        if item.kind != "results":
            raise InputError(name, "", "--csv is for results")
        # deferred: start-up cost: keeps manipcad.store.results out of the CLI's start
        from manipcad.store.results import load_result

        # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
        from manipcad.workspace import results_dataframe

        res, doc = load_result(w.path(item))
        results_dataframe(res, doc.get("joint_types")).to_csv(sys.stdout, float_format="%.10g")
        return
    deps = [d.ref for d in w.dependents(item)]
    if as_json:
        _echo_json({**item.to_dict(), "file": str(w.path(item)), "used_by": deps})
        return
    table = Table(title=item.ref, box=box.SIMPLE_HEAD, show_header=False)
    table.add_column("field")
    table.add_column("value", overflow="fold")
    for key, value in (("file", str(w.path(item))), ("sha256", item.hash),
                       ("created (UTC)", item.created), ("manipcad", item.manipcad_version),
                       ("source", item.source), ("status", item.status or "-"),
                       ("used by", ", ".join(deps) or "-")):
        table.add_row(key, value)
    for role, dep in (item.provenance.get("inputs") or {}).items():
        for d in dep if isinstance(dep, list) else [dep]:
            table.add_row(f"input {role}", f"{d.get('name') or '(not in the workspace)'} "
                          f"sha256 {str(d.get('hash'))[:12]}")
    if item.provenance.get("settings_hash"):
        table.add_row("settings sha256", item.provenance["settings_hash"][:12])
    console.print(table)
    if item.metrics:
        # deferred: start-up cost: keeps manipcad.workspace.where out of the CLI's start
        from manipcad.workspace.where import METRICS

        mt = Table(title="metrics (SI units)", box=box.SIMPLE_HEAD)
        for col in ("metric", "joint", "value", "unit"):
            mt.add_column(col, justify="right" if col == "value" else "left")
        for key, value in sorted(item.metrics.items()):
            joint, _, metric = key.rpartition(".")
            mt.add_row(metric, joint or "largest", _num(value, ".6g"),
                       METRICS.get(metric, ("", ""))[0])
        console.print(mt)


@ws_app.command("rm")
@guarded
def rm(name: Annotated[str, typer.Argument(help="NAME or KIND/NAME.",
                                                        autocompletion=_complete_names)],
       cascade: option(bool, "--cascade", "Also remove the results that depend on it.") = False,
       ws: WsOpt = None) -> None:
    """Remove an item (refused while stored results depend on it, unless --cascade)."""
    for it in _open(ws).rm(name, cascade=cascade):
        console.print(f"removed {it.ref}", highlight=False)


@ws_app.command("compare")
@guarded
def compare(names: Annotated[list[str], typer.Argument(help="Result names.",
                                                             autocompletion=_complete_names)],
            plot: option(Path | None, "--plot", "Write the overlaid error, torque and current "
                         "figure (PNG, SVG or PDF by the suffix).") = None,
            ws: WsOpt = None, as_json: JsonOpt = False) -> None:
    """Compare results: a metrics table (largest over joints) and overlaid plots."""
    # deferred: start-up cost: keeps manipcad.workspace.runs out of the CLI's start
    from manipcad.workspace.runs import COMPARE_HEADINGS, COMPARE_METRICS

    # deferred: start-up cost: keeps manipcad.workspace.runs out of the CLI's start
    from manipcad.workspace.runs import compare as run_compare

    if plot is not None:
        writable_target(plot)
    rows, fig = run_compare(_open(ws), names)
    if plot is not None:
        if fig is None:
            raise InputError("--plot", "", "the results have different joints; no common "
                             "figure")

        fmt = plot.suffix.lower().lstrip(".") or "png"
        atomic_write(plot, lambda fh: fig.savefig(fh, dpi=100, format=fmt), binary=True)
    if as_json:
        _echo_json({"results": rows, "plot": str(plot) if plot else None})
        return
    table = Table(title="results compared (largest over the joints)", box=box.SIMPLE_HEAD)
    table.add_column("result", overflow="fold")
    table.add_column("status")
    for m, _unit in COMPARE_METRICS:
        table.add_column(COMPARE_HEADINGS[m], justify="right", no_wrap=True)
    table.caption = ", ".join(f"{COMPARE_HEADINGS[m]} {u}" for m, u in COMPARE_METRICS)
    for r in rows:
        table.add_row(r["name"], r["status"] or "", *(_num(r[m], ".4g")
                                                      for m, _ in COMPARE_METRICS))
    console.print(table)
    if plot is not None:
        console.print(f"wrote {plot}", highlight=False)


@ws_app.command("rerun")
@guarded
def rerun(name: Annotated[str, typer.Argument(help="A result name.",
                                                        autocompletion=_complete_names)],
          ws: WsOpt = None, as_json: JsonOpt = False) -> None:
    """Re-run a result from its stored inputs and settings; show whether every array
    and metric is identical (exit status 1 if not)."""
    # deferred: start-up cost: keeps manipcad.workspace.runs out of the CLI's start
    from manipcad.workspace.runs import rerun as run_again

    r = run_again(_open(ws), name)
    if as_json:
        _echo_json({"name": r.name, "identical": r.identical, "max_abs_diff": r.max_abs_diff,
                    "metrics": {k: {"stored": a, "new": b} for k, (a, b) in r.metrics.items()}})
    else:
        table = Table(title=f"{r.name} re-run: stored vs new", box=box.SIMPLE_HEAD)
        for col in ("joint.metric", "stored", "new", "same"):
            table.add_column(col, justify="left" if col == "joint.metric" else "right")
        for key, (a, b) in r.metrics.items():
            table.add_row(key, _num(a, ".10g"), _num(b, ".10g"), "yes" if a == b else "NO")
        console.print(table)
        worst = max(r.max_abs_diff.values(), default=0.0)
        console.print(("identical: every stored array and metric equals the new run's "
                       "bit for bit") if r.identical else
                      f"DIFFERENT: largest |new - stored| = {worst:.3g}", highlight=False)
    if not r.identical:
        raise typer.Exit(1)


@ws_app.command("check")
@guarded
def check(ws: WsOpt = None, as_json: JsonOpt = False) -> None:
    """Report files changed (with hashes), missing or unindexed, links leaving the
    workspace and dead writers' leftovers (exit status 1 if any)."""
    problems = _open(ws).check()
    if as_json:
        _echo_json([p.to_dict() for p in problems])
    elif not problems:
        console.print("clean: the index matches the files")
    else:
        table = Table(title=f"{len(problems)} problems", box=box.SIMPLE_HEAD)
        for col in ("problem", "kind", "name", "detail"):
            table.add_column(col, overflow="fold")
        for p in problems:
            table.add_row(p.problem, p.kind, p.name, p.detail)
        console.print(table)
    if problems:
        raise typer.Exit(1)


@ws_app.command("export")
@guarded
def export(name: Annotated[str, typer.Argument(help="NAME or KIND/NAME.",
                                                        autocompletion=_complete_names)],
           to: option(Path, "--to", "Folder to write the bundle in."),
           ws: WsOpt = None) -> None:
    """Write a self-contained bundle (the item, its inputs, CSV for results) that
    another workspace takes with 'ws add'."""
    out = _open(ws).export(name, to)
    console.print(f"wrote {out} (take it with: manipcad ws add {out})", highlight=False)


@ws_app.command("reindex")
@guarded
def reindex(ws: WsOpt = None, as_json: JsonOpt = False) -> None:
    """Rebuild the index from the files (the files are the truth)."""
    # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
    from manipcad.workspace import Workspace

    done = Workspace(ws, rebuild_index=True).reindex()
    if as_json:
        _echo_json(done)
        return
    console.print(f"indexed {done['items']} items; skipped {done['skipped']}", highlight=False)
    for ref, why in done["errors"].items():
        console.print(f"  skipped {ref}: {why}", highlight=False, soft_wrap=True)
