"""``manipcad select``: choose each joint's motor and gear from the catalogue.

``manipcad select ROBOT -t TRAJ [-t TRAJ ...] [--payload KG | --payload-range LO,HI]
[--objective mass|rotor_inertia|power] [--margin M] [--makers maxon,faulhaber]
[--gear-types planetary,harmonic,direct] [--joints J1,J2] [--mount JOINT=base]
--out ROBOT_WITH_DRIVES.yaml [--json] [--ws DIR]`` runs
:func:`manipcad.sizing.select.select_drives` and writes the robot with the
chosen drives (:func:`~manipcad.sizing.select.save_selection`), then prints
per joint the chosen pair, its binding check and margin, how many candidates
were checked and passed, the next five alternatives and why the lighter ones
fail (``--json``: the same as JSON, ``Selection.to_dict``).

Exit status: 0 with a selection written; 1 when a joint has no feasible
drive (the message names the joint, the closest candidate and the check it
fails; nothing is written); 2 for bad input.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path
from typing import Annotated

import typer
from rich import box
from rich.markup import escape

from manipcad.cli.app import app, console, err_console, guarded
from manipcad.cli.options import dt_option, force_flag, json_flag, option, payload_option, ws_option
from manipcad.cli.tables import Table, styled
from manipcad.cli.warmup import ensure_warm
from manipcad.errors import InputError, ManipcadWarning
from manipcad.model.load import load_robot
from manipcad.trajectories import load_trajectory


def _split(text: str | None) -> list[str] | None:
    if text is None:
        return None
    return [x.strip() for x in text.split(",") if x.strip()]


def _joint(arm, name: str, option: str) -> int:
    """A joint by name or number 1..n."""
    if name in arm.joint_names:
        return arm.joint_names.index(name)
    if name.isdigit() and 1 <= int(name) <= arm.n:
        return int(name) - 1
    raise InputError(option, "", f"no joint {name!r}; joints: {', '.join(arm.joint_names)} "
                     f"(or numbers 1..{arm.n})")


def _pct(m: float) -> str:
    return "-" if m is None or not math.isfinite(m) else f"{m:+.0%}"


@app.command("select")
@guarded
def select(
    robot: Annotated[str, typer.Argument(
        help="The arm: a robot file (URDF + payload, DH or tree form; its drives, if any, "
        "are replaced), a .urdf file or a workspace robot's name.")],
    trajectory: option(list[str], "--trajectory -t", "A trajectory file (docs/trajectories.md) or "
                       "workspace trajectory; repeat for several."),
    out: option(Path, "--out -o", "The robot file to write, with the chosen drives (tree form)."),
    payload: payload_option("Payload mass, kg, at the robot's tool point (added to any "
        "payload the robot file gives).") = None,
    payload_range: option(str | None, "--payload-range", "LO,HI: payload masses, kg; both ends are "
                          "checked.") = None,
    objective: option(str, "--objective", "What to minimize: mass (motor + gear, kg), "
                      "rotor_inertia (J·i_r² at the joint) or power (mean electrical "
                      "power, W).") = "mass",
    margin: option(float, "--margin", "Every rating at least M × what the motion needs; 1.0 is "
                   "exactly size's limits.") = 1.1,
    makers: option(str | None, "--makers", "Comma-separated motor makers to keep (e.g. "
                   "maxon,faulhaber).") = None,
    gear_types: option(str | None, "--gear-types", "Comma-separated gear types to keep (planetary, "
                       "harmonic, spur, ..., direct for no gear).") = None,
    joints: option(str | None, "--joints", "Comma-separated joints to select for (names or numbers "
                   "1..n); default all. The others keep the robot file's drives.") = None,
    mount: option(list[str] | None, "--mount", "JOINT=before|base: where that joint's drive mass "
                  "sits (default before: on the link before the joint); repeat.") = None,
    dt: dt_option("Sampling step, s.") = 1e-3,
    allow_unknown: option(bool, "--allow-unknown", "Accept a candidate with a check that cannot be "
                          "made (a rating or the gear efficiency unknown).") = False,
    count_all: option(bool, "--count-all", "Evaluate every candidate, so that the feasible counts "
                      "are complete (else the search stops after the winner and five "
                      "alternatives).") = False,
    as_json: json_flag("Print the report as JSON.") = False,
    force: force_flag("Replace an existing --out file.")
    = False,
    ws: ws_option("Workspace: the robot and trajectories may be its item names, and its "
        "motor and gear files join the catalogue.") = None,
) -> None:
    """Choose each joint's motor and gear from the catalogue: the lightest (or least
    inertia, or least power) drive that passes every size check on every trajectory at
    both ends of the payload range, drive masses included. Exit 1 when a joint has no
    feasible drive; 2 for bad input."""

    # deferred: start-up cost: keeps manipcad.sizing.select out of the CLI's start
    from manipcad.sizing.select import NoFeasibleDrive, save_selection, select_drives

    # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
    from manipcad.workspace import Workspace, resolve_input

    space = Workspace(ws) if ws is not None else None
    if out.exists() and not force:
        raise InputError(str(out), "", "exists; give --force to replace it")
    if out.exists() and not out.is_file():
        raise InputError(str(out), "", "is not a regular file")
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        arm = load_robot(resolve_input("robot", robot, space))
    trajs = []
    for t in trajectory:
        tr = load_trajectory(resolve_input("trajectory", t, space), robot=arm)
        if tr.n != arm.n:
            raise InputError(str(t), "", f"has {tr.n} joints but robot {arm.name!r} has {arm.n}")
        trajs.append(tr)
    prange = None
    if payload_range is not None:
        try:
            lo, hi = (float(v) for v in payload_range.split(","))
        except ValueError:
            raise InputError("--payload-range", "", f"expected LO,HI in kg, got "
                             f"{payload_range!r}") from None
        prange = (lo, hi)
    if payload is not None and prange is not None:
        raise InputError("--payload", "", "give --payload or --payload-range, not both")
    picked = None if joints is None else [_joint(arm, j, "--joints") for j in _split(joints)]
    mounts = {}
    for item in mount or []:
        name, sep, where = item.partition("=")
        if not sep:
            raise InputError("--mount", "", f"expected JOINT=before|base, got {item!r}")
        mounts[_joint(arm, name.strip(), "--mount")] = where.strip()
    if not math.isfinite(dt) or dt <= 0:
        raise InputError("--dt", "", f"must be a number > 0 s, got {dt}")

    ensure_warm("dynamics")
    try:
        with err_console.status("selecting drives..."):
            sel = select_drives(arm, trajs, payload=payload, payload_range=prange,
                                objective=objective, margin=margin, makers=_split(makers),
                                gear_types=_split(gear_types), joints=picked, mounts=mounts,
                                allow_unknown=allow_unknown, dt=dt, count_all=count_all,
                                ws=None if space is None else space.root)
    except NoFeasibleDrive as exc:
        if as_json:
            typer.echo(json.dumps({"ok": False, "joint": exc.joint, "check": exc.check,
                                   "closest": exc.closest, "considered": exc.considered,
                                   "message": str(exc)}, indent=2))
        err_console.print(f"[bold red]no feasible drive:[/] {escape(str(exc))}",
                          highlight=False, soft_wrap=True)
        raise typer.Exit(1) from None
    save_selection(sel, out)
    if as_json:
        doc = sel.to_dict()
        doc["ok"] = True
        doc["out"] = str(out)
        doc["trajectories"] = list(trajectory)
        typer.echo(json.dumps(doc, indent=2, allow_nan=False))
        return
    print_selection(sel, [str(t) for t in trajectory])
    console.print(f"wrote {escape(str(out))} (check it: manipcad size {escape(str(out))} "
                  f"-t {escape(str(trajectory[0]))})", highlight=False, soft_wrap=True)


def print_selection(sel, trajectories: list[str]) -> None:
    """The report tables of a :class:`~manipcad.sizing.select.Selection`."""
    # deferred: start-up cost: keeps manipcad.sizing.select out of the CLI's start
    from manipcad.sizing.select import OBJECTIVES

    unit = OBJECTIVES[sel.objective][1]
    payloads = ", ".join(f"{p:g}" for p in sel.payloads)
    t = Table(box=box.SIMPLE_HEAD, title=(
        f"{escape(sel.robot.name)}: drives by least {sel.objective} ({unit}), margin "
        f"{sel.margin:g}, payloads {payloads} kg, along {escape(', '.join(trajectories))}"),
        caption=("binding: the check with the least margin (1 - required/rating); "
                 "candidates: feasible / evaluated on the motor checks / considered; "
                 f"drive masses on the link before each joint, fixed point in "
                 f"{sel.iterations} sweeps; "
                 + ("verified by size's checks on every case" if sel.verified
                    else "not verified")))
    cols = [("joint", "left"), ("chosen", "left"), ("i_r", "right"), ("kg", "right")]
    if sel.objective != "mass":
        cols.append((unit, "right"))
    cols += [("binding", "left"), ("margin", "right"), ("candidates", "right")]
    for col, just in cols:
        t.add_column(col, justify=just, overflow="fold")
    for c in sel.joints:
        ch = c.chosen
        row = [c.joint, ch.label, f"{ch.part.drive.ratio:.4g}",
               f"{ch.part.mass:.3g}"]
        if sel.objective != "mass":
            row.append(f"{ch.objective:.3g}")
        row += [ch.binding or "-", _pct(ch.binding_margin),
                f"{c.feasible}/{c.evaluated}/{c.considered}"]
        t.add_row(*row)
    console.print(t)
    for c in sel.joints:
        alt = Table(box=box.SIMPLE, title=f"{c.joint}: next alternatives and the "
                    "lighter candidates rejected", title_justify="left")
        for col in ("", "candidate", sel.objective, "binding / why not"):
            alt.add_column(col, overflow="fold")
        for a in c.alternatives:
            alt.add_row(styled("alt", "green"), a.label, f"{a.objective:.4g}",
                        f"{a.binding} {_pct(a.binding_margin)}")
        for r in c.rejected:
            alt.add_row(styled("no", "red"), r.label, f"{r.objective:.4g}", r.reason)
        if c.alternatives or c.rejected:
            console.print(alt)
    console.print(f"total drive mass {sel.total_drive_mass:.3g} kg", highlight=False)
