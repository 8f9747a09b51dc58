"""``manipcad simulate``: run the closed loop along a trajectory and save the results.

::

    manipcad simulate ROBOT --trajectory FILE --regulator FILE --out DIR
                      [--t-end S] [--dt S] [--every N] [--json] [--no-drives]
                      [--payload KG] [--force] [--save-diverged] [--allow-other-robot]
                      [--accuracy RAD] [--max-saturation F] [--max-chatter F] [--strict]

ROBOT is a catalog name or a robot file; the trajectory and regulator files
are the YAML schemas of :mod:`manipcad.trajectories.io` and
:mod:`manipcad.control.files` (any method, as ``manipcad synthesize`` writes
them; a file made for another robot model is refused unless
``--allow-other-robot``). DIR receives the inputs, the time series, the
metrics and a PNG of the errors (:mod:`manipcad.store.results`), all at once
when the run is complete: an interrupted run (Ctrl-C), bad input or a
divergent simulation leaves DIR as it was. A divergent run exits with status
2 and names the time and the joint; ``--save-diverged`` keeps its partial
time series in DIR, marked ``"status": "diverged"`` in metrics.json.

Every run is checked against every rating (:mod:`manipcad.sim.checks`, docs/checks.md):
the check table is printed with the failures marked, then a one-line verdict, and the
checks are kept in metrics.json (``checks``). Exit status 0 whatever the checks say;
with ``--strict`` 1 when a check fails.
"""

from __future__ import annotations

import json
import math
import time
import warnings
from pathlib import Path
from typing import Annotated, Any

import typer
from rich import box
from rich.markup import escape

from manipcad.cli.app import app, console, err_console, guarded
from manipcad.cli.options import (
    RobotArgument,
    dt_option,
    force_flag,
    json_flag,
    payload_option,
    strict_flag,
    t_end_option,
    ws_option,
)
from manipcad.cli.tables import Table, styled
from manipcad.cli.warmup import ensure_warm
from manipcad.errors import InputError, ManipcadError, ManipcadWarning
from manipcad.model.load import CATALOG, load_robot
from manipcad.sim import SimulationDiverged
from manipcad.sim import simulate as run_simulation
from manipcad.sim.joint_limits import JOINT_LIMITS
from manipcad.trajectories import load_trajectory


def _num(x: Any, fmt: str = ".4g") -> str:
    """A table cell: nan/None print as "-"; a non-number (JSON's "inf") as it is."""
    if x is None or (isinstance(x, float) and math.isnan(x)):
        return "-"
    if isinstance(x, str):
        return x
    return format(x, fmt)


def _robot_file(arg: str) -> Path | None:
    """The file a robot argument names: the file itself or the catalog entry."""

    p = Path(arg)
    if p.is_file():
        return p
    for ext in (".yaml", ".urdf"):
        entry = CATALOG / "robots" / f"{arg}{ext}"
        if entry.is_file():
            return Path(str(entry))
    return None


VERDICT_STYLE = {"fail": "bold red", "unknown": "yellow", "pass": "green", "n/a": "dim"}


def checks_table(checks) -> Table:
    """A rich table of a run's checks (:class:`manipcad.sim.checks.RunChecks`): one row per
    joint and check, value, limit, unit and verdict; failures marked ``✗ fail``."""
    t = Table(title="checks against every rating (docs/checks.md)", box=box.SIMPLE_HEAD)
    for col in ("joint", "check", "value", "limit", "unit", "verdict"):
        t.add_column(col, justify="right" if col in ("value", "limit") else "left")
    for j, cs in checks.checks.items():
        names = list(cs)
        for k, name in enumerate(names):
            c = cs[name]
            mark = "✗ fail" if c.verdict == "fail" else c.verdict
            style = VERDICT_STYLE.get(c.verdict, "")
            t.add_row(j if k == 0 else "", name, _num(c.value, ".3g"),
                      "none" if c.limit == math.inf else _num(c.limit, ".3g"), c.unit,
                      styled(mark, style) if style else mark,
                      end_section=k == len(names) - 1)
    return t


def metrics_table(doc: dict[str, Any]) -> Table:
    """A rich table of the per-joint metrics of a result document (metrics.json).

    Errors are in the joint's unit (rad or m), times in s, the effort (RMS
    regulator output) in V (N·m or N without drives), the energy in J. The step
    figures (overshoot, rise and settling time) are shown when a joint's
    reference is a step.
    """
    drives = bool(doc["settings"].get("drives", True))
    metrics = doc["metrics"]
    step = any(metrics[j].get("rise_time") is not None for j in doc["joints"])
    table = Table(title=f"{doc['robot']}: closed-loop metrics, t = 0..{doc['t_final']:.4g} s",
                  box=box.SIMPLE_HEAD)
    cols = ["joint", "unit", "max |e|", "RMS e"]
    if step:
        cols += ["overshoot %", "rise s", "settling s"]
    cols += ["effort " + ("V" if drives else "N·m|N"), "energy J"]
    for col in cols:
        table.add_column(col, justify="left" if col in ("joint", "unit") else "right")
    for name in doc["joints"]:
        m, u = metrics[name], doc["units"][name]
        row = [name, u["max_error"], _num(m["max_error"], ".3g"), _num(m["rms_error"], ".3g")]
        if step:
            over = m.get("overshoot")
            row += ["-" if over is None else f"{100 * over:.3g}",
                    _num(m.get("rise_time"), ".3g"), _num(m.get("settling_time"), ".3g")]
        row += [_num(m["effort_rms"], ".3g"), _num(m["energy"], ".4g")]
        table.add_row(*row)
    return table

#: the run's numbers as this command's options name them (manipcad.store.plan)
OPTION_NAMES = {"dt": "--dt", "t_end": "--t-end", "every": "--every", "drives": "--no-drives"}


@app.command()
@guarded
def simulate(
    robot: RobotArgument,
    trajectory: Annotated[str, typer.Option(
        "--trajectory", "-t", help="Trajectory YAML file (reference motion), or a workspace "
        "trajectory's name.")],
    out: Annotated[str | None, typer.Option(
        "--out", "-o", help="Result folder (inputs/, timeseries.csv/.npz, metrics.json, "
        "errors.png); with --ws the result's NAME in the workspace (optional there: a name "
        "is made).")] = None,
    ws: ws_option("Workspace: inputs may be its item names, and the result is stored and "
        "indexed there (results/NAME).") = None,
    regulator: Annotated[list[str] | None, typer.Option(
        "--regulator", "-r", help="Regulator YAML file or workspace name; repeat for several. "
        "Joints in no file get U = 0.")] = None,
    t_end: t_end_option("Simulated time, s (default: the trajectory's duration).") = None,
    dt: dt_option("Integration step (RK4), s; regulator periods must be multiples of it.")
    = 1e-4,
    every: Annotated[int | None, typer.Option(
        "--every", help="Keep every N-th step in the saved time series (the metrics are "
        "computed on the kept samples); default: one sample per regulator period (every "
        "step without regulators).")] = None,
    csv: Annotated[bool, typer.Option(
        "--csv/--no-csv", help="Also write timeseries.csv (text, units in the header); the "
        "full-precision arrays are always in timeseries.npz, and 'ws export' writes CSV.")]
    = False,
    as_json: json_flag("Print the metrics document (metrics.json) instead of a table.") = False,
    no_drives: Annotated[bool, typer.Option(
        "--no-drives", help="Rigid body only: regulator outputs are joint torques (N·m, N).")]
    = False,
    payload: payload_option("Payload mass at the robot's tool point, kg.") = None,
    force: force_flag("Replace a non-empty result folder (only once the new one is "
        "complete).") = False,
    save_diverged: Annotated[bool, typer.Option(
        "--save-diverged", help="If the run diverges, still save its partial time series "
        "(status 'diverged'); the exit status stays 2.")] = False,
    allow_other_robot: Annotated[bool, typer.Option(
        "--allow-other-robot", help="Run regulator files made for a robot model with another "
        "hash (refused by default).")] = False,
    joint_limits: Annotated[str, typer.Option(
        "--joint-limits", help="A joint beyond its limits: warn (the run goes on), stop (the "
        "run stops there, exit 2), ignore, or hard-stop (the limits are mechanical stops: a "
        "joint reaching one stops on it, inelastically, and leaves when its torque pulls "
        "away; docs/simulation.md).")] = "warn",
    integrator: Annotated[str, typer.Option(
        "--integrator", help="rk4 (fixed step --dt, the reference), adaptive "
        "(error-controlled Dormand-Prince 5(4); steps never cross a regulator sample; --dt "
        "is then the sample/record grid and the smallest step) or adaptive-exact (the "
        "same with the armature currents solved exactly: no step limit from L/R, their "
        "error controlled too; fastest on drive jobs with stiff currents); adaptive-bs32, "
        "adaptive-exact-bs32: the same two with the Bogacki-Shampine 3(2) pair (3 "
        "right-hand sides per step against 6: faster where the regulator's period bounds "
        "the steps, slower at tight tolerances).")] = "rk4",
    rtol: Annotated[float | None, typer.Option(
        "--rtol", help="Adaptive integrator: relative tolerance of the local error "
        "(default 1e-6).")] = None,
    atol: Annotated[float | None, typer.Option(
        "--atol", help="Adaptive integrator: absolute tolerance, rad, m, rad/s, m/s "
        "(default 1e-8).")] = None,
    accuracy: Annotated[float | None, typer.Option(
        "--accuracy", help="The tracking accuracy asked, rad (m for prismatic joints), "
        "every joint: adds the tracking check.")] = None,
    max_saturation: Annotated[float, typer.Option(
        "--max-saturation", help="Largest fraction of the run an amplifier may spend at "
        "its output limit (0..1].")] = 0.02,
    max_chatter: Annotated[float, typer.Option(
        "--max-chatter", help="Largest amplifier-input reversals per second, 1/s "
        "(docs/checks.md).")] = 50.0,
    strict: strict_flag("Exit 1 when a check fails (default: exit 0 whatever the "
        "checks say).") = False,
) -> None:
    """Simulate the closed loop (multibody + DC drives + sampled regulators) and save it."""
    # deferred: start-up cost: keeps manipcad.store out of the CLI's start
    from manipcad.store import check_out_dir, result_document

    # deferred: start-up cost: keeps manipcad.store.plan out of the CLI's start
    from manipcad.store.plan import check_numbers, plan_run

    check_numbers(dt, t_end, every, OPTION_NAMES)  # before anything is loaded
    if accuracy is not None and not (math.isfinite(accuracy) and accuracy > 0):
        raise InputError("--accuracy", "", f"must be > 0 rad (m), got {accuracy}")
    if not (math.isfinite(max_saturation) and 0 < max_saturation <= 1):
        raise InputError("--max-saturation", "", f"must be in (0, 1], got {max_saturation}")
    if not (math.isfinite(max_chatter) and max_chatter > 0):
        raise InputError("--max-chatter", "", f"must be > 0 reversals/s, got {max_chatter}")
    if payload is not None and not (math.isfinite(payload) and payload >= 0):
        raise InputError("--payload", "", f"must be >= 0 kg, got {payload}")
    # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
    from manipcad.workspace import Workspace, resolve_input

    space = Workspace(ws) if ws is not None else None
    if space is None:
        if out is None:
            raise InputError("--out", "", "missing: the result folder (or --ws DIR to store "
                             "the result in a workspace)")
        out = Path(out)
        check_out_dir(out, force=force)  # fail before the run, not after
    robot = resolve_input("robot", robot, space)
    trajectory = Path(resolve_input("trajectory", trajectory, space))
    regulator = [Path(resolve_input("regulator", r, space)) for r in regulator or ()]

    with warnings.catch_warnings(record=True) as robot_notes:
        warnings.simplefilter("always", ManipcadWarning)
        arm = load_robot(robot)
    notes = [str(w.message) for w in robot_notes if issubclass(w.category, ManipcadWarning)]
    from_catalog = not Path(robot).is_file()
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", ManipcadWarning)
        traj = load_trajectory(trajectory, robot=arm)
        plan = plan_run(arm, traj, regulator or (), dt=dt, t_end=t_end, every=every,
                        drives=not no_drives, allow_other_robot=allow_other_robot,
                        robot_source=robot, trajectory_source=str(trajectory),
                        names=OPTION_NAMES)
    regs, t_end = plan.regulators, plan.t_end
    # the catalog robots' data notes are documented ('manipcad robots show'); a user's
    # robot file's are news
    shown = [] if from_catalog else list(notes)
    shown += [str(w.message) for w in caught if issubclass(w.category, ManipcadWarning)]
    for w in shown:
        err_console.print(f"[yellow]warning:[/] {w}", highlight=False, soft_wrap=True)

    if joint_limits not in JOINT_LIMITS:
        raise InputError("--joint-limits", "", f"must be one of {', '.join(JOINT_LIMITS)}, "
                         f"got {joint_limits!r}")
    inputs: dict[str, Any] = {}
    # the robot as it ran, drives included, saved as one self-contained file (a robot file
    # that points to a URDF by a relative path would not re-run from the result folder)
    inputs["robot"] = arm
    inputs["trajectory"] = trajectory
    if regulator:
        inputs["regulator"] = list(regulator)
    run = {"robot": str(robot), "trajectory": str(trajectory),
           "regulators": [str(p) for p in regulator or ()], "t_end": t_end, "dt": dt,
           "every": plan.every, "drives": not no_drives, "payload": payload,
           "robot_notes": notes, "integrator": integrator, "rtol": rtol, "atol": atol}
    every = plan.every

    ensure_warm("simulator")
    wall = time.perf_counter()
    steps = (f"{int(round(t_end / dt))} RK4 steps" if integrator == "rk4"
             else "adaptive steps")
    with err_console.status(f"simulating {arm.name}: {t_end:g} s at dt = {dt:g} s "
                            f"({steps})..."), \
            warnings.catch_warnings(record=True) as run_notes:
        warnings.simplefilter("always", ManipcadWarning)
        try:
            res = run_simulation(arm, t_end=t_end, dt=dt, trajectory=traj, regulators=regs,
                                 payload=payload, drives=not no_drives, every=every,
                                 joint_limits=joint_limits, integrator=integrator,
                                 rtol=rtol, atol=atol)
        except SimulationDiverged as exc:
            if save_diverged:
                where = _store(space, exc.result, out, inputs, arm, trajectory, regulator,
                               run, force, status="diverged", message=str(exc), csv=csv)
                raise ManipcadError(f"{exc}; the partial result is in {where}") from None
            raise ManipcadError(f"{exc}; nothing was written to "
                                f"{out if space is None else space.root}") from None
    wall = time.perf_counter() - wall
    for w in run_notes:
        if issubclass(w.category, ManipcadWarning):
            err_console.print(f"[yellow]warning:[/] {w.message}", highlight=False,
                              soft_wrap=True)
    run["wall_time_s"] = wall
    # deferred: start-up cost: keeps manipcad.sim.checks out of the CLI's start
    from manipcad.sim.checks import run_checks

    checks = run_checks(res, arm, accuracy=accuracy, payload=payload,
                        max_saturation=max_saturation, max_chatter=max_chatter)
    res.checks = checks.to_dict()
    run["checks"] = {"accuracy": accuracy, "max_saturation": max_saturation,
                     "max_chatter": max_chatter, "verdict": checks.verdict}
    with err_console.status("writing the result..."):
        out = _store(space, res, out, inputs, arm, trajectory, regulator, run, force, csv=csv)
    doc = result_document(res, joint_types=arm.joint_types, inputs=inputs, run=run)
    doc["out"] = str(out)
    failed = strict and checks.verdict == "fail"
    if as_json:
        typer.echo(json.dumps(doc, indent=2))
        if failed:
            raise typer.Exit(1)
        return
    console.print(metrics_table(doc))
    console.print(checks_table(checks))
    style = VERDICT_STYLE[checks.verdict]
    console.print(f"[{style}]{escape(checks.summary())}[/]", soft_wrap=True)
    console.print(f"simulated {t_end:g} s ({int(round(t_end / dt))} steps of {dt:g} s) in "
                  f"{wall:.3g} s wall (the first run compiles); wrote {out}/ (inputs/, "
                  + ("timeseries.csv, " if csv else "")
                  + "timeseries.npz with "
                  + ("every step" if every == 1 else f"one sample every {every} steps")
                  + ", metrics.json, errors.png)"
                  + (f", indexed in the workspace {space.root}" if space is not None else ""),
                  highlight=False, soft_wrap=True)
    if failed:
        raise typer.Exit(1)


def _store(space, res, out, inputs, arm, trajectory, regulators, run, force, *,
           status: str = "ok", message: str = "", csv: bool = False) -> Path:
    """Save a result into a folder, or store and index it in a workspace; its folder."""
    # deferred: start-up cost: keeps manipcad.store out of the CLI's start
    from manipcad.store import save_result

    if space is None:
        save_result(res, out, inputs=inputs, joint_types=arm.joint_types, force=force,
                    status=status, message=message, run=run, csv=csv)
        return Path(out)
    item = space.store_result(res, name=out, robot=arm, trajectory=trajectory,
                              regulators=list(regulators), run=run,
                              joint_types=arm.joint_types, force=force, status=status,
                              message=message)
    return space.root / "results" / item.name
