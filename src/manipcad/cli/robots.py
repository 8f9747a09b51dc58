"""``manipcad robots``: list the catalog and show one robot.

``manipcad robots list`` prints the catalog's robots, motors and gears;
``manipcad robots show NAME_OR_FILE [--json]`` prints a robot's joints (number
1..n, name, link, type, parent, limits, mass, drive) and totals;
``manipcad robots save NAME_OR_FILE OUT.yaml`` writes any robot with its
drives as one self-contained robot file (tree form, docs/robot-files.md).
Bad input exits with status 2 and one line on stderr.
"""

from __future__ import annotations

import json
import math
import warnings
from typing import Annotated, Any

import numpy as np
import typer

from manipcad.cli.app import app, console, guarded
from manipcad.cli.options import RobotArgument, json_flag, ws_option
from manipcad.cli.tables import Table
from manipcad.errors import ManipcadWarning
from manipcad.fileio import json_safe
from manipcad.model.load import catalog_names, load_robot
from manipcad.model.robot import loader_notes
from manipcad.model.tree_file import save_robot
from manipcad.model.yaml_robot import load_gear, load_motor

robots_app = typer.Typer(
    help="List the built-in catalog; show a robot's joints, links and drives.",
    no_args_is_help=True,
)
app.add_typer(robots_app, name="robots")


def _num(x: float, fmt: str = ".4g") -> str:
    """A number for a table cell; nan/inf print as '-' / '±inf'."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if math.isinf(x):
        return "inf" if x > 0 else "-inf"
    return format(x, fmt)


@robots_app.command("list")
@guarded
def list_catalog(
    ws: ws_option("Also list the robots, motors and gears of this workspace (origin "
        "column).") = None,
    as_json: json_flag("Print JSON.") = False,
) -> None:
    """List the robots, motors and gears: the built-in catalog (read-only) and, with --ws, the
    workspace's own (SI units)."""

    sources: dict[str, list[tuple[str, str, str]]] = {k: [(n, n, "catalog")
                                                          for n in catalog_names(k)]
                                                      for k in ("robots", "motors", "gears")}
    if ws is not None:
        # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
        from manipcad.workspace import Workspace

        space = Workspace(ws)
        for kind in ("robots", "motors", "gears"):
            for item in space.list(kind[:-1]):
                sources[kind].append((item.name, str(space.root / item.path), f"workspace {ws}"))
    rows: dict[str, list[dict[str, Any]]] = {"robots": [], "motors": [], "gears": []}
    for name, ref, origin in sources["robots"]:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", ManipcadWarning)
            robot = load_robot(ref)
        rows["robots"].append({
            "name": name, "origin": origin, "title": robot.name,
            "joints": "".join("R" if t == "revolute" else "P" for t in robot.joint_types),
            "mass_kg": float(robot.mass.sum()),
            "drives": f"{sum(d is not None for d in robot.drives)}/{robot.n}"})
    for name, ref, origin in sources["motors"]:
        m = load_motor(ref)
        rows["motors"].append({
            "name": name, "origin": origin, "U_N_V": m.rated_voltage, "k_m_Nm_per_A": m.k_m,
            "R_ohm": m.R, "L_H": m.L, "J_kgm2": m.J, "M_N_Nm": m.rated_torque,
            "M_peak_Nm": m.peak_torque, "n_max_rad_per_s": m.max_speed})
    for name, ref, origin in sources["gears"]:
        g = load_gear(ref)
        rows["gears"].append({
            "name": name, "origin": origin, "type": g.type, "ratio": g.direction * g.ratio,
            "J_kgm2": g.J, "efficiency": None if g.efficiency == "unknown" else g.efficiency,
            "max_continuous_Nm": g.max_continuous_torque,
            "peak_Nm": g.max_intermittent_torque, "n_in_max_rad_per_s": g.max_input_speed})
    if as_json:
        typer.echo(json.dumps(json_safe(rows), indent=2))
        return

    def num(v, fmt=".3g", scale=1.0):
        return _num(math.nan if v is None else v * scale, fmt)

    robots = Table(title="robots (manipcad robots show NAME)")
    for col in ("name", "origin", "title", "joints", "mass kg", "drives"):
        robots.add_column(col, justify="right" if col == "mass kg" else "left",
                          overflow="fold")
    for r in rows["robots"]:
        robots.add_row(r["name"], r["origin"], r["title"], r["joints"], _num(r["mass_kg"]),
                       r["drives"])
    console.print(robots)

    motors = Table(title="motors (drive: {motor: NAME}); V, N·m/A, Ω, mH, g·cm², N·m, rpm")
    for col in ("name", "origin", "U_N", "k_m", "R", "L", "J", "M_N", "M_peak", "n_max"):
        motors.add_column(col, justify="left" if col in ("name", "origin") else "right",
                          overflow="fold")
    for m in rows["motors"]:
        motors.add_row(m["name"], m["origin"], num(m["U_N_V"], ".4g"), num(m["k_m_Nm_per_A"]),
                       num(m["R_ohm"]), num(m["L_H"], scale=1e3), num(m["J_kgm2"], scale=1e7),
                       num(m["M_N_Nm"]), num(m["M_peak_Nm"]),
                       num(m["n_max_rad_per_s"], ".0f", 60 / (2 * math.pi)))
    console.print(motors)

    gears = Table(title="gears (drive: {gear: NAME or [NAME, ...]}); "
                        "ratio rad/rad (rad/m linear), J g·cm², max N·m (N), n_in rpm")
    for col in ("name", "origin", "type", "ratio", "J", "eff.", "max cont.", "peak",
                "n_in max"):
        gears.add_column(col, justify="left" if col in ("name", "origin", "type") else "right",
                         overflow="fold")
    for g in rows["gears"]:
        gears.add_row(g["name"], g["origin"], g["type"], f"{g['ratio']:.5g}",
                      num(g["J_kgm2"], ".4g", 1e7), num(g["efficiency"], ".2f"),
                      num(g["max_continuous_Nm"], ".4g"), num(g["peak_Nm"], ".4g"),
                      num(g["n_in_max_rad_per_s"], ".0f", 60 / (2 * math.pi)))
    console.print(gears)


def robot_summary(robot: Any) -> dict[str, Any]:
    """A JSON-ready description of a robot: joints, links, drives and totals (SI units)."""
    joints = []
    for i in range(robot.n):
        d = robot.drives[i]
        drive = None
        if d is not None:
            drive = {
                "motor": d.name, "gear": d.gear, "J": d.J, "ratio": d.ratio, "k_v": d.k_v,
                "M_f": list(d.M_f), "R": d.R, "L": d.L, "k_m": d.k_m, "k_w": d.k_w,
                "k_u": d.k_u, "u_max": d.u_max, "rated_torque": d.rated_torque,
                "peak_torque": d.peak_torque, "max_speed": d.max_speed,
                "rated_voltage": d.rated_voltage, "rated_current": d.rated_current,
                "J_joint": d.reflected_inertia, "efficiency": d.efficiency,
                "gear_rated_torque": d.gear_rated_torque,
                "gear_peak_torque": d.gear_peak_torque,
                "gear_max_input_speed": d.gear_max_input_speed,
                "gear_average_torque": d.gear_average_torque,
                "gear_average_input_speed": d.gear_average_input_speed,
                "stiffness": d.stiffness, "damping": d.damping, "backlash": d.backlash,
            }
        p = int(robot.parent[i])
        joints.append({
            "number": i + 1, "name": robot.joint_names[i], "type": robot.joint_types[i],
            "link": robot.link_names[i],
            "parent": "base" if p < 0 else robot.joint_names[p],
            "limits": robot.limits[i], "offset": float(robot.offset[i]),
            "placement_R": robot.placement_R[i], "placement_p": robot.placement_p[i],
            "mass": float(robot.mass[i]), "com": robot.com[i], "inertia": robot.inertia[i],
            "drive": drive,
        })
    return json_safe({
        "name": robot.name, "n": robot.n, "gravity": robot.gravity,
        "source": robot.source, "tool_R": robot.tool_R, "tool_p": robot.tool_p,
        "total_mass": float(robot.mass.sum()),
        "joints": joints,
        "links": [{"name": nm, "body": "base" if b < 0 else robot.joint_names[b],
                   "R": R, "p": pos} for nm, b, R, pos in robot.frames],
    })


@robots_app.command("show")
@guarded
def show(
    name_or_file: RobotArgument,
    as_json: json_flag() = False,
    ws: ws_option("Workspace: the robot may be its item name.") = None,
) -> None:
    """Show a robot: joints (type, parent, limits, mass, drive) and totals, SI units."""
    # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
    from manipcad.workspace import Workspace, resolve_input

    space = Workspace(ws) if ws is not None else None
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ManipcadWarning)
        robot = load_robot(resolve_input("robot", name_or_file, space))
    notes = loader_notes(caught, robot)

    if as_json:
        data = robot_summary(robot)
        data["warnings"] = notes
        typer.echo(json.dumps(data, indent=2))
        return

    kinds = "".join("R" if t == "revolute" else "P" for t in robot.joint_types)
    table = Table(title=f"{robot.name} — {robot.n} joints ({kinds})")
    for col in ("#", "joint", "link", "type", "parent", "limits", "mass kg",
                "drive (motor + gears)", "ratio", "J·i_r²"):
        table.add_column(col, justify="right" if col in ("#", "mass kg", "ratio") else "left",
                         no_wrap=col in ("#", "joint", "type", "mass kg", "ratio"),
                         overflow="fold")
    for i in range(robot.n):
        p = int(robot.parent[i])
        lo, hi = robot.limits[i]
        unit = "rad" if robot.joint_types[i] == "revolute" else "m"
        limits = "-" if np.isinf(lo) and np.isinf(hi) else f"{_num(lo)}..{_num(hi)} {unit}"
        d = robot.drives[i]
        if d is None:
            drive, ratio, jref = "-", "-", "-"
        else:
            drive = " + ".join(x for x in (d.name, d.gear) if x) or "(explicit)"
            unit = "kg·m²" if robot.joint_types[i] == "revolute" else "kg"
            ratio, jref = _num(d.ratio, ".5g"), f"{_num(d.reflected_inertia, '.4g')} {unit}"
        table.add_row(str(i + 1), robot.joint_names[i], robot.link_names[i],
                      robot.joint_types[i][0].upper(),
                      "base" if p < 0 else robot.joint_names[p], limits,
                      _num(float(robot.mass[i])), drive, ratio, jref)
    console.print(table)
    n_drv = sum(d is not None for d in robot.drives)
    n_el = sum(d is not None and d.has_electrics for d in robot.drives)
    console.print(f"total mass {robot.mass.sum():.4g} kg; drives on {n_drv} of {robot.n} joints "
                  f"({n_el} with electrical data); gravity {robot.gravity.tolist()} m/s²",
                  highlight=False)
    extra = [nm for nm in robot.all_link_names if nm not in robot.link_names]
    if extra:
        console.print("other named links (for payload/tool/--link): " + ", ".join(extra),
                      highlight=False, soft_wrap=True)
    if robot.source:
        console.print(f"source: {robot.source}", highlight=False, soft_wrap=True)
    for note in notes:
        console.print(f"[yellow]warning:[/] {note}", highlight=False, soft_wrap=True)


@robots_app.command("save")
@guarded
def save(
    name_or_file: Annotated[str, typer.Argument(
        help="A catalog robot name, a robot file (docs/robot-files.md) or a .urdf file.")],
    out: Annotated[str, typer.Argument(help="The robot file to write (.yaml, tree form).")],
) -> None:
    """Write a robot with its drives as one self-contained robot file (tree form) that
    loads back to the identical model: no URDF or catalog needed to read it."""

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)
        robot = load_robot(name_or_file)
    path = save_robot(robot, out)
    console.print(f"{robot.name}: {robot.n} joints written to {path}", highlight=False)
