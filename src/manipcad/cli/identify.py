"""``manipcad identify``: the unknown payload mass from measured drive torques or currents.

::

    manipcad identify ROBOT --data FILE.csv [--method stops|motion|auto]
                      [--signal auto|torque|current] [--com X,Y,Z] [--link LINK]
                      [--estimate-com] [--friction estimate|symmetric|model|none]
                      [--joints J,J,...] [--no-drives] [--json]

ROBOT is a catalog name or a robot file (YAML, URDF, URDF + drives). The CSV
file holds one sample per line: q1..qn (rad or m), and tau1..taun (N·m or N)
or current1..currentn (A), optionally qd, qdd and a time column t (s); joint
names may replace the numbers (q_NAME, ...), and a stored simulation result's
timeseries.csv is read as it is (NAME.q [rad], NAME.qd, NAME.tau,
NAME.current), and so is a stored result folder (its timeseries.npz, any
size). With times, stops are found in the samples by themselves
(--method stops) and velocities and accelerations differentiated (--method
motion). --com is the payload's centre of mass in the frame of --link: a link
name (a URDF link's own frame) or a joint name or number 1..n (that joint's
body frame). Drives whose own estimates disagree beyond their uncertainty are
flagged. See docs/identification.md. Bad input exits with status 2 and one
line naming the file, the line and column, and the reason.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

from rich import box

from manipcad.cli.app import app, console, err_console, guarded
from manipcad.cli.options import RobotArgument, json_flag, option, ws_option
from manipcad.cli.tables import Table, styled
from manipcad.dynamics.identification import (
    FRICTION,
    METHODS,
    check_estimate,
    identify_payload,
    link_frame,
    load_torque_data,
    result_torque_data,
)
from manipcad.errors import InputError, ManipcadWarning
from manipcad.model.load import load_robot


def parse_com(text: str | None) -> list[float] | None:
    """``"x,y,z"`` (m) -> three floats; raises InputError naming --com."""
    if text is None:
        return None
    parts = [p.strip() for p in text.split(",")]
    try:
        values = [float(p) for p in parts]
    except ValueError:
        values = []
    if len(values) != 3 or not all(math.isfinite(v) for v in values):
        raise InputError("--com", "", f"expected three numbers x,y,z in m, got {text!r}")
    return values


def parse_joints(text: str | None, robot, option: str = "--joints") -> list[int] | None:
    """``"shoulder,elbow"`` or ``"2,3"`` (1-based numbers) -> 0-based joint indices."""
    if text is None:
        return None
    out = []
    for item in (p.strip() for p in text.split(",")):
        if not item:
            raise InputError(option, "", f"empty entry in {text!r}")
        if item in robot.joint_names:
            out.append(robot.joint_names.index(item))
        elif item.isdigit() and 1 <= int(item) <= robot.n:
            out.append(int(item) - 1)
        else:
            raise InputError(option, "", f"{item!r} is neither a joint name "
                             f"({', '.join(robot.joint_names)}) nor a number 1..{robot.n}")
    return out


@app.command()
@guarded
def identify(
    robot: RobotArgument,
    data: option(str, "--data", "CSV file of samples: q and tau or current, optionally qd, qdd and "
                 "t (SI units), or a stored result's timeseries.csv, or a stored result folder; "
                 "see docs/identification.md."),
    method: option(str, "--method", "stops (gravity at the stops found in the samples), motion "
                   "(inertial, velocity and gravity terms) or auto.") = "auto",
    signal: option(str, "--signal", "What was measured: torque (tau columns), current (current "
                   "columns, A) or auto (torque when the file has it).") = "auto",
    com: option(str | None, "--com", "Payload centre of mass x,y,z in the frame of --link, m "
                "(default 0,0,0; with --estimate-com the first guess).") = None,
    link: option(str | None, "--link", "Link the payload is on: a link name (its own URDF frame), "
                 "or a joint name or number 1..n (that joint's body frame); default the "
                 "last.") = None,
    estimate_com: option(bool, "--estimate-com", "Estimate the centre of mass with the "
                         "mass.") = False,
    friction: option(str, "--friction", "At stops: estimate (held friction per drive and approach "
                     "direction, fitted with the mass), symmetric, model (the drive model's band) "
                     "or none.") = "estimate",
    joints: option(str | None, "--joints", "Drives to use: names or numbers 1..n, comma-separated "
                   "(default every drive the payload acts on).") = None,
    drives: option(bool, "--drives/--no-drives", "The torques include the drive terms (rotor "
                   "inertia, friction) of the robot's drives.") = True,
    as_json: json_flag() = False,
    ws: ws_option("Workspace: the inputs may be its item names.") = None,
) -> None:
    """Identify an unknown payload mass from measured drive torques or currents."""

    if method not in METHODS:
        raise InputError("--method", "", f"{method!r}: expected one of {', '.join(METHODS)}")
    if signal not in ("auto", "torque", "current"):
        raise InputError("--signal", "", f"{signal!r}: expected auto, torque or current")
    if friction not in FRICTION:
        raise InputError("--friction", "", f"{friction!r}: expected one of "
                         f"{', '.join(FRICTION)}")
    # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
    from manipcad.workspace import Workspace, resolve_input

    space = Workspace(ws) if ws is not None else None
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)  # data-set quirks, see robots show
        model = load_robot(resolve_input("robot", robot, space))
    c = parse_com(com)
    sel = parse_joints(joints, model)
    where = _parse_link(link, model)
    d = _load_data(resolve_input("result", data, space), model)
    if signal == "auto":
        signal = "torque" if d.tau is not None else "current"
    measured = d.tau if signal == "torque" else d.current
    if measured is None:
        col = "tau1.." if signal == "torque" else "current1.."
        raise InputError(data, "", f"--signal {signal}: the file has no {col} columns")
    kw = {"tau": measured} if signal == "torque" else {"current": measured}
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ManipcadWarning)
        est = identify_payload(model, d.q, d.qd, d.qdd, t=d.t, method=method, com=c,
                               joints=sel, drives=drives, link=where, friction=friction,
                               estimate_com=estimate_com, **kw)
    check_estimate(est, str(data))
    notes = [str(w.message) for w in caught if issubclass(w.category, ManipcadWarning)]
    if as_json:
        doc = {"robot": model.name, "data": str(data), **est.to_dict(), "warnings": notes}
        print(json.dumps(doc, indent=2))
        return
    for note in notes:
        err_console.print(f"[bold yellow]warning:[/] {note}", highlight=False, soft_wrap=True)
    what = ("stops: gravity at rest" if est.method == "stops"
            else "motion: inertial, velocity and gravity terms")
    if est.method == "stops" and est.stops:
        what += f"; {len(est.stops)} stops, held friction: {est.friction}"
    com_txt = ", ".join(f"{x:.4g}" for x in est.com)
    if est.com_estimated:
        com_txt += " (estimated ± " + ", ".join(f"{x:.2g}" for x in est.com_std) + ")"
    console.print(f"[bold]{model.name}[/]: payload on link {est.link_name!r} at com = "
                  f"({com_txt}) m in its frame; {est.samples} samples of {est.signal} from "
                  f"{data}; {what}", highlight=False)
    for note in est.notes:
        console.print(f"  {note}", highlight=False)
    table = Table(box=box.SIMPLE_HEAD,
                  title="each drive alone (paper: 'from one drive only')")
    for col in ("joint", "excitation", "m_r kg", "std kg", "z", "residual RMS", ""):
        table.add_column(col, justify="left" if col in ("joint", "") else "right")
    for j, name, e, m, sd, zz, r in zip(est.joints, est.joint_names, est.excitation,
                                        est.per_joint_mass, est.per_joint_std, est.z,
                                        est.per_joint_residual, strict=True):
        unit = "N·m" if model.joint_types[j] == "revolute" else "N"
        table.add_row(name, f"{e:.4g} {unit}/kg", f"{m:.5g}", _num(sd), _num(zz, "+.1f"),
                      f"{r:.3g} {unit}",
                      styled("disagrees", "bold red") if name in est.flagged else "")
    console.print(table)
    weights = ("drives weighted by their estimated noise" if est.weighting == "noise"
               else "plain least squares")
    console.print(f"[bold]payload mass m_r = {est.mass:.5g} ± {_num(est.std)} kg[/] "
                  f"(least squares over {len(est.joints)} drive(s), {weights}; residual RMS "
                  f"{est.residual:.3g} N·m|N)", highlight=False)


def _load_data(data: str, model):
    """A CSV file (load_torque_data), or a stored result folder (its full-precision arrays)."""


    if not Path(data).is_dir():
        return load_torque_data(data, model)
    # deferred: start-up cost: keeps manipcad.store.results out of the CLI's start
    from manipcad.store.results import load_result

    return result_torque_data(load_result(data)[0], model, data)


def _parse_link(text: str | None, robot):
    """--link: None (the last joint's body), a joint number 1..n, or a joint or link name."""
    if text is None:
        return robot.n - 1
    item = text.strip()
    if "," in item:
        raise InputError("--link", "", f"name one link, got {text!r}")
    if item.isdigit():
        k = int(item)
        if not 1 <= k <= robot.n:
            raise InputError("--link", "", f"{item!r}: link numbers are 1..{robot.n}")
        return k - 1

    try:
        link_frame(robot, item)
    except InputError as exc:
        raise InputError("--link", "", exc.reason) from None
    return item


def _num(x: float, fmt: str = ".2g") -> str:
    return "-" if not math.isfinite(x) else format(x, fmt)
