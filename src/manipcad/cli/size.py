"""``manipcad size``: the drive torques, currents, voltages and powers a trajectory needs.

``manipcad size ROBOT --trajectory FILE [--json] [--plot out.png] [--dt 1e-3]
[--payload KG] [--t-end S]`` loads the robot (catalog name or file) and the
trajectory file, runs :func:`manipcad.sizing.required_drive` and prints two
tables: what each drive must deliver (joint and motor side, SI units) and the
check of each motor against its continuous and peak torque, speed and voltage
limits and of each gear against its rated and peak output torque and its
input speed (margins in % of the limit, green pass, red fail, grey unknown).
``--json`` prints the same as JSON (``DriveRequirements.to_dict``);
``--plot`` writes the torque-speed plot.

Exit status: 0 when every check passes; 1 when a check fails, or when a
check cannot be made ("unknown": no drive, a motor without ratings or
electrical data, a gear without ratings) unless ``--allow-unknown``; 2 for
bad input (no such file, a bad trajectory file, a trajectory with the wrong
number of joints, dt <= 0, a negative payload), with one line on stderr.
"""

from __future__ import annotations

import json
import math
import warnings
from pathlib import Path

import numpy as np
import typer
from rich import box
from rich.markup import escape

from manipcad.cli.app import app, console, guarded
from manipcad.cli.options import (
    RobotArgument,
    dt_option,
    json_flag,
    option,
    payload_option,
    strict_flag,
    t_end_option,
    ws_option,
)
from manipcad.cli.tables import Table, styled
from manipcad.cli.warmup import ensure_warm
from manipcad.errors import InputError, ManipcadWarning
from manipcad.fileio import atomic_write, json_safe
from manipcad.model.load import load_robot
from manipcad.sizing import ratio_sweep, required_drive, torque_speed_plot
from manipcad.sizing.plot import ratio_sweep_figure
from manipcad.sizing.requirements import FIELDS, check_unit
from manipcad.trajectories import load_trajectory

_COLOUR = {"pass": "green", "fail": "red", "unknown": "grey50", "n/a": "grey50"}


def _fmt(x: float, unit: str = "", fmt: str = ".4g") -> str:
    """A value with its unit for a table cell; nan prints as '-'."""
    if x is None or not math.isfinite(x):
        return "-" if x is None or math.isnan(x) else str(x)
    return f"{x:{fmt}} {unit}".rstrip()


@app.command("size")
@guarded
def size(
    robot: RobotArgument,
    trajectory: option(str, "--trajectory -t", "Trajectory YAML file (see docs/trajectories.md) or "
                       "a workspace trajectory's name."),
    as_json: json_flag()
    = False,
    plot: option(Path | None, "--plot", "Write the torque-speed plot to this image file (.png, "
                 ".pdf, .svg).") = None,
    dt: dt_option("Sampling step, s.") = 1e-3,
    payload: payload_option("Payload mass, kg: a point mass at the robot's tool point (a "
        "payload with a centre of mass on a named link goes in the robot file).") = None,
    t_end: t_end_option("End of the run, s (default the trajectory's duration).") = None,
    allow_unknown: option(bool, "--allow-unknown", "Exit 0 even when a check cannot be made (a "
                          "rating or the motor's electrical data unknown); failed checks still "
                          "exit 1.") = False,
    strict: strict_flag("Take assumed values as unknown: a gear efficiency the data sheet "
        "does not print (the library's stated strain-wave assumption, docs/catalog.md) and "
        "any other value a part marks assumed; the checks resting on them are then unknown "
        "(or fail when they fail even through a lossless gear).") = False,
    ws: ws_option("Workspace: the inputs may be its item names.") = None,
    ratio_sweep: option(str | None, "--ratio-sweep", "Sweep the gear ratio |i_r| of the "
                        "--sweep-joint joints over LO:HI:N (N values spaced evenly in log): "
                        "feasible range and best ratio.") = None,
    sweep_joint: option(list[str] | None, "--sweep-joint", "A joint to sweep (name or number "
                        "1..n); repeat. Default: every joint with a drive.") = None,
    sweep_plot: option(Path | None, "--sweep-plot", "Write the sweep's figure to this "
                       "image file.") = None,
) -> None:
    """Size the drives: torques, currents, voltages, powers; motor and gear checks.

    What a trajectory needs of each drive, and each motor (continuous and peak
    torque, speed, voltage) and gear (rated and peak output torque, input speed)
    checked with margins. A check that passes on an assumed value (a strain-wave
    gear's efficiency, docs/catalog.md) says so; --strict takes assumed values as
    unknown. Exit 1 when a check fails, or cannot be made unless --allow-unknown; 2
    for bad input."""
    # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
    from manipcad.workspace import Workspace, resolve_input

    space = Workspace(ws) if ws is not None else None
    with warnings.catch_warnings():  # published data sets with known quirks (robots show)
        warnings.simplefilter("ignore", ManipcadWarning)
        arm = load_robot(resolve_input("robot", robot, space))
    traj = load_trajectory(resolve_input("trajectory", trajectory, space), robot=arm)
    if traj.n != arm.n:
        raise InputError(str(trajectory), "", f"has {traj.n} joints but robot {arm.name!r} "
                         f"has {arm.n}")
    if not math.isfinite(dt) or dt <= 0:
        raise InputError("--dt", "", f"must be a number > 0 s, got {dt}")
    span = t_end if t_end is not None else traj.duration
    if math.isfinite(span) and span > 0 and span / dt < MIN_STEPS:
        # a peak between two samples is missed: --dt 10 on a 0.3 s move sampled its two
        # ends and passed with half the peak torque
        steps = max(1, math.ceil(span / dt - 1e-9))
        raise InputError("--dt", "", f"{dt:g} s gives {steps} step{'s' * (steps > 1)} over "
                         f"the {span:g} s motion, too coarse to find its peaks (at least "
                         f"{MIN_STEPS} steps: --dt {span / MIN_STEPS:.3g} or less)")
    if payload is not None and (not math.isfinite(payload) or payload < 0):
        raise InputError("--payload", "", f"must be a mass >= 0 kg, got {payload}")

    ensure_warm("dynamics")
    # deferred: start-up cost: keeps manipcad.sizing.assumed out of the CLI's start
    from manipcad.sizing.assumed import assumed_passes, strict_requirements, strict_robot

    if strict:
        arm = strict_robot(arm)
    req = required_drive(arm, traj, t_end=t_end, dt=dt, payload=payload)
    if strict:
        req = strict_requirements(req)
    on_assumed = assumed_passes(req)
    written = torque_speed_plot(req, plot) if plot is not None else None

    sweeps = _sweeps(arm, traj, ratio_sweep, sweep_joint, t_end, dt, payload)
    if sweep_plot is not None:
        if not sweeps:
            raise InputError("--sweep-plot", "", "needs --ratio-sweep LO:HI:N")

        fig = ratio_sweep_figure(sweeps)
        fmt = sweep_plot.suffix.lower().lstrip(".")
        if fmt not in fig.canvas.get_supported_filetypes():
            raise InputError(str(sweep_plot), "", f"unknown image format {fmt!r}")
        atomic_write(sweep_plot, lambda fh: fig.savefig(fh, format=fmt), binary=True)

    if as_json:
        out = req.to_dict()
        out["trajectory"] = str(trajectory)
        out["strict"] = strict
        out["passed_on_assumed_values"] = on_assumed
        out["plot"] = str(written) if written is not None else None
        if sweeps:
            out["ratio_sweep"] = [{"joint": sw.joint, "present_ratio": sw.ratio,
                                   "feasible": [list(iv) for iv in sw.intervals],
                                   "best_ratio": sw.best_ratio, "criterion": sw.criterion,
                                   "bounded_by_grid": sw.bounded_by_grid} for sw in sweeps]
        typer.echo(json.dumps(json_safe(out), indent=2, allow_nan=False))
    else:
        _print_tables(req, str(trajectory))
        _print_assumed(on_assumed)
        if written is not None:
            console.print(f"torque-speed plot written to {escape(str(written))}")
        for sw in sweeps:
            feas = (", ".join(f"[{lo:.4g}, {hi:.4g}]" for lo, hi in sw.intervals)
                    or "none in the swept range")
            console.print(f"gear ratio of {escape(sw.joint)} ({escape(sw.motor or 'motor')}): "
                          f"present |i_r| = {abs(sw.ratio):.4g}; feasible {feas}; best "
                          f"{sw.best_ratio:.4g} ({sw.criterion})"
                          + (" — the range reaches the end of the sweep"
                             if sw.bounded_by_grid else ""), highlight=False, soft_wrap=True)
        if sweep_plot is not None:
            console.print(f"sweep figure written to {escape(str(sweep_plot))}")
    raise typer.Exit(exit_status(req.status, allow_unknown))


def exit_status(status: tuple[str, ...], allow_unknown: bool) -> int:
    """The exit status of ``size`` for per-joint statuses: 1 if any fails, or if any
    is unknown and unknowns are not allowed; else 0.

    Example:
        >>> exit_status(("pass", "unknown"), False), exit_status(("pass", "unknown"), True)
        (1, 0)
    """
    if "fail" in status or ("unknown" in status and not allow_unknown):
        return 1
    return 0


def _print_tables(req, source: str) -> None:

    title = (f"{req.robot.name}: drive requirements along {source} "
             f"(t_end = {req.t_end:g} s, dt = {req.dt:.3g} s"
             + (f", payload {req.payload_mass:g} kg" if req.payload_mass else "") + ")")
    mixed = "prismatic" in req.robot.joint_types
    need = Table(title=title, box=box.SIMPLE_HEAD,
                 caption="T_m = k_m·i = P/i_r; peaks are max |x|, RMS and means over the run"
                 + ("; units in brackets for prismatic joints (P)" if mixed else ""))
    need.add_column("quantity")
    need.add_column("unit")
    for name, kind in zip(req.joint_names, req.robot.joint_types, strict=True):
        need.add_column(name + (" (P)" if kind == "prismatic" else ""), justify="right")
    ratios = [d.ratio if d is not None else math.nan for d in req.drives]
    # every summary of the requirements (sizing.requirements.FIELDS: label and units, the
    # prismatic one in brackets where the robot has such joints)
    rows = [("gear ratio i_r", "rad/rad (rad/m)" if mixed else "rad/rad", ratios)]
    rows += [(text, f"{unit} ({unit_p})" if mixed and unit_p != unit else unit,
              getattr(req, key)) for key, (unit, unit_p, text) in FIELDS.items()]
    for label, unit, values in rows:
        need.add_row(label, unit, *(_fmt(float(v)) for v in values))
    console.print(need)

    check = Table(title="motor and gear check (margin = 1 - required/rating; negative: "
                  "over it)", box=box.SIMPLE_HEAD,
                  caption="continuous: RMS T_m vs rated torque; peak: peak |T_m| vs peak "
                  "torque; speed: peak |ω_m| vs max speed; voltage: peak |u_a| vs the "
                  "amplifier limit (else the rated voltage); gear_continuous / gear_peak: "
                  "RMS / peak gear output torque |P_rigid| vs the gear's rated / "
                  "repeated-peak torque; gear_speed: peak |ω_m| vs the gear's max input "
                  "speed; gear_average: the speed-weighted cubic mean of |P_rigid| vs the "
                  "gear's average-torque limit (else its rated torque, a lower bound); "
                  "gear_average_speed: mean |ω_m| vs the gear's average-input-speed limit; "
                  "position / velocity / effort: the joint's extreme, peak |q̇|, peak "
                  "|P_rigid| vs the robot's joint limits (URDF <limit>); "
                  "n/a: no gear, a rating the gear does not have, or no such joint limit")
    for col, just in (("joint", "left"), ("limit", "left"),
                      ("required", "right"),
                      ("rating", "right"), ("unit", "left"), ("margin", "right"),
                      ("status", "left")):
        check.add_column(col, justify=just, no_wrap=True)
    for j in range(req.n):
        d = req.drives[j]
        first = [req.joint_names[j]]
        for k, c in enumerate(req.checks.values()):
            st = c.status[j]
            m = c.margin[j]
            prismatic = req.robot.joint_types[j] == "prismatic"
            check.add_row(
                first[k] if k < len(first) else "", c.name, _fmt(c.required[j]),
                "none" if c.limit[j] == math.inf else _fmt(c.limit[j]),
                "N" if c.unit == "N·m" and c.name.startswith("gear_") and prismatic
                else check_unit(c.name, c.unit, req.robot.joint_types[j]),
                styled(f"{m:+.0%}", _COLOUR[st]) if st in ("pass", "fail") else "",
                styled(st, _COLOUR[st]), end_section=k == len(req.checks) - 1)
    console.print("drives:")
    for j in range(req.n):
        d = req.drives[j]
        parts = ("no drive" if d is None else
                 f"motor {d.name or '(unnamed)'}, gear {d.gear or '(none named)'}")
        console.print(f"  {escape(req.joint_names[j])}: {escape(parts)}", soft_wrap=True)
    console.print(check)
    fails = [req.joint_names[j] for j in range(req.n) if req.status[j] == "fail"]
    unknown = [req.joint_names[j] for j in range(req.n) if req.status[j] == "unknown"]
    if fails:
        what = []  # each failed check with its value and limit (a position outside the
        for j in range(req.n):  # joint's limits says so: "waist: position 4 vs 2.793 rad")
            jt = req.robot.joint_types[j]
            what += [f"{req.joint_names[j]}: {c.name} {_fmt(c.required[j])} vs "
                     f"{_fmt(c.limit[j])} {check_unit(c.name, c.unit, jt)}"
                     for c in req.checks.values() if c.status[j] == "fail"]
        console.print(f"[red]over a limit:[/] {escape('; '.join(what))}", soft_wrap=True)
    if unknown:
        console.print(f"[yellow]not fully checked (a rating or the motor's electrical data "
                      f"unknown; exit 1 unless --allow-unknown):[/] {escape(', '.join(unknown))}")
        eta = [req.joint_names[j] for j in range(req.n) if req.drives[j] is not None
               and math.isnan(req.drives[j].efficiency)]
        if eta:
            console.print(f"[yellow]gear efficiency unknown (its source gives none; not "
                          f"taken as 1): motor torque and voltage checks unknown unless "
                          f"even a lossless gear fails them (docs/sizing.md):[/] "
                          f"{escape(', '.join(eta))}")
    if not fails and not unknown:
        console.print("[green]every motor and gear meets every limit[/]")


def _print_assumed(on_assumed: list[dict]) -> None:
    """Say which passes rest on assumed values, and why (once per reason)."""
    if not on_assumed:
        return
    by_why: dict[str, list[str]] = {}
    for p in on_assumed:
        for field, why in p["why"].items():
            joints = by_why.setdefault(f"{field}: {why}", [])
            if p["joint"] not in joints:
                joints.append(p["joint"])
    for why, joints in by_why.items():
        field = why.split(":", 1)[0]
        console.print(f"[yellow]passed with an assumed {escape(field.replace('_', ' '))}[/] "
                      f"(motor torque and voltage checks of {escape(', '.join(joints))}; "
                      f"--strict takes it as unknown): {escape(why.split(': ', 1)[1])}",
                      soft_wrap=True, highlight=False)


#: fewest sampling steps over the motion ``size`` accepts (a coarser --dt is refused)
MIN_STEPS = 50


def _sweeps(arm, traj, spec: str | None, joints: list[str] | None, t_end, dt, payload) -> list:
    """The gear-ratio sweeps asked by ``--ratio-sweep LO:HI:N`` (and ``--sweep-joint``)."""
    if spec is None:
        if joints:
            raise InputError("--sweep-joint", "", "needs --ratio-sweep LO:HI:N")
        return []


    try:
        lo, hi, n = spec.split(":")
        lo, hi, n = float(lo), float(hi), int(n)
    except ValueError:
        raise InputError("--ratio-sweep", "", f"expected LO:HI:N (e.g. 10:300:200), got "
                         f"{spec!r}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and 0 < lo < hi and 2 <= n <= 100000):
        raise InputError("--ratio-sweep", "", f"needs 0 < LO < HI and 2 <= N <= 100000, got "
                         f"{spec!r}")
    if joints:
        idx = []
        for name in joints:
            if name in arm.joint_names:
                idx.append(arm.joint_names.index(name))
            elif name.isdigit() and 1 <= int(name) <= arm.n:
                idx.append(int(name) - 1)
            else:
                raise InputError("--sweep-joint", "", f"no joint {name!r}; joints: "
                                 f"{', '.join(arm.joint_names)} (or 1..{arm.n})")
    else:
        idx = [j for j in range(arm.n) if arm.drives and arm.drives[j] is not None]
    grid = np.geomspace(lo, hi, n)
    return [ratio_sweep(arm, traj, j, grid, t_end=t_end, dt=dt, payload=payload) for j in idx]
