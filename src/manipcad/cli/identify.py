"""``manipcad identify``: the unknown payload mass from measured drive torques (paper 4.1).

::

    manipcad identify ROBOT --data FILE.csv [--com X,Y,Z] [--joints J,J,...]
                      [--link L] [--no-drives] [--json]

ROBOT is a catalog name or a robot file (YAML or URDF). The CSV file holds one
sample per line with the columns q1..qn (rad or m), qd1..qdn (rad/s or m/s),
qdd1..qddn (rad/s² or m/s²) and tau1..taun (N·m or N), in any order; joint
names may replace the numbers (q_NAME, qd_NAME, qdd_NAME, tau_NAME); a column
t or time is ignored; lines starting with # are comments. Without the qd and
qdd columns the samples are stops and the static method is used. See
docs/identification.md. Bad input exits with status 2 and one line naming the
file, the line and column, and the reason.
"""

from __future__ import annotations

import json
import math
import warnings
from typing import Annotated

import typer
from rich import box
from rich.table import Table

from manipcad.cli.app import app, console, err_console, guarded
from manipcad.errors import InputError, ManipcadWarning


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
    robot: Annotated[str, typer.Argument(help="Catalog robot name or robot file (YAML, URDF).")],
    data: Annotated[str, typer.Option("--data", help="CSV file of q, qd, qdd, tau samples "
                                      "(SI units; see docs/identification.md).")],
    com: Annotated[str | None, typer.Option(
        "--com", help="Payload centre of mass x,y,z in the carrying link's frame, m "
        "(default 0,0,0).")] = None,
    joints: Annotated[str | None, typer.Option(
        "--joints", help="Drives to use: names or numbers 1..n, comma-separated "
        "(default every drive the payload acts on).")] = None,
    link: Annotated[str | None, typer.Option(
        "--link", help="Carrying link: joint name or number 1..n (default the last).")] = None,
    drives: Annotated[bool, typer.Option(
        "--drives/--no-drives", help="The torques include the drive terms (rotor inertia, "
        "friction) of the robot's drives.")] = True,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON instead of tables.")] = False,
) -> None:
    """Identify an unknown payload mass from measured drive torques (least squares)."""
    from manipcad.dynamics.identification import identify_payload, load_torque_data
    from manipcad.model.load import load_robot

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)  # data-set quirks, see robots show
        model = load_robot(robot)
    c = parse_com(com)
    sel = parse_joints(joints, model)
    i_link = model.n - 1 if link is None else parse_joints(link, model, "--link")
    if isinstance(i_link, list):
        if len(i_link) != 1:
            raise InputError("--link", "", f"name one link, got {link!r}")
        i_link = i_link[0]
    d = load_torque_data(data, model)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ManipcadWarning)
        est = identify_payload(model, d.q, d.qd, d.qdd, d.tau, com=c, joints=sel,
                               drives=drives, link=i_link)
    notes = [str(w.message) for w in caught if issubclass(w.category, ManipcadWarning)]
    if as_json:
        doc = {"robot": model.name, "data": str(data), **est.to_dict(), "warnings": notes}
        print(json.dumps(doc, indent=2))
        return
    for note in notes:
        err_console.print(f"[bold yellow]warning:[/] {note}", highlight=False, soft_wrap=True)
    method = ("static: short stops, gravity only" if est.method == "static"
              else "dynamic: inertial, velocity and gravity terms")
    console.print(f"[bold]{model.name}[/]: payload on link {model.joint_names[est.link]!r} at "
                  f"com = ({', '.join(f'{x:g}' for x in est.com)}) m; {est.samples} samples "
                  f"from {data}; {method}", highlight=False)
    table = Table(box=box.SIMPLE_HEAD,
                  title="each drive alone (paper: 'from one drive only')")
    for col in ("joint", "excitation", "m_r kg", "std kg", "residual RMS"):
        table.add_column(col, justify="left" if col == "joint" else "right")
    for j, name, e, m, s, r in zip(est.joints, est.joint_names, est.excitation,
                                   est.per_joint_mass, est.per_joint_std,
                                   est.per_joint_residual, strict=True):
        unit = "N·m" if model.joint_types[j] == "revolute" else "N"
        table.add_row(name, f"{e:.4g} {unit}/kg", f"{m:.5g}", _num(s), f"{r:.3g} {unit}")
    console.print(table)
    weights = ("drives weighted by their estimated noise" if est.weighting == "noise"
               else "plain least squares")
    console.print(f"[bold]payload mass m_r = {est.mass:.5g} ± {_num(est.std)} kg[/] "
                  f"(least squares over {len(est.joints)} drive(s), {weights}; residual RMS "
                  f"{est.residual:.3g} N·m|N)", highlight=False)


def _num(x: float, fmt: str = ".2g") -> str:
    return "-" if not math.isfinite(x) else format(x, fmt)
