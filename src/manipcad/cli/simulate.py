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
from manipcad.model.load import CATALOG
from manipcad.sim import SimulationDiverged
from manipcad.sim.joint_limits import JOINT_LIMITS
from manipcad.sim.warm import needs


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
    from manipcad.store.plan import check_numbers

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
    # deferred: start-up cost: keeps manipcad.store.run out of the CLI's start
    from manipcad.store.run import RunSpec, execute, prepare, to_folder

    spec = RunSpec(robot, trajectory, tuple(regulator), dt=dt, t_end=t_end, every=every,
                   drives=not no_drives, payload=payload, integrator=integrator, rtol=rtol,
                   atol=atol, joint_limits=joint_limits, allow_other_robot=allow_other_robot,
                   accuracy=accuracy, max_saturation=max_saturation, max_chatter=max_chatter)
    prepared = prepare(spec, names=OPTION_NAMES)
    t_end, every = prepared.spec.t_end, prepared.spec.every
    # the catalog robots' data notes are documented ('manipcad robots show'); a user's
    # robot file's are news
    from_catalog = not Path(robot).is_file()
    shown = ([] if from_catalog else list(prepared.robot_notes)) + prepared.notes
    for w in shown:
        err_console.print(f"[yellow]warning:[/] {w}", highlight=False, soft_wrap=True)

    if joint_limits not in JOINT_LIMITS:
        raise InputError("--joint-limits", "", f"must be one of {', '.join(JOINT_LIMITS)}, "
                         f"got {joint_limits!r}")
    if space is None:
        store = to_folder(out, force=force, csv=csv)
    else:
        # deferred: start-up cost: keeps manipcad.workspace.runs out of the CLI's start
        from manipcad.workspace.runs import to_workspace

        into = to_workspace(space, out, force=force)

        def store(result, **kw) -> Path:
            return space.root / "results" / into(result, **kw).name

    ensure_warm(*needs(integrator))
    steps = (f"{int(round(t_end / dt))} RK4 steps" if integrator == "rk4"
             else "adaptive steps")
    with err_console.status(f"simulating {prepared.robot.name}: {t_end:g} s at dt = {dt:g} s "
                            f"({steps})...") as status, \
            warnings.catch_warnings(record=True) as run_notes:
        warnings.simplefilter("always", ManipcadWarning)

        def writing(result, **kw) -> Path:
            status.update("writing the result...")
            return store(result, **kw)

        try:
            done = execute(prepared, writing, save_diverged=save_diverged)
        except SimulationDiverged as exc:
            if save_diverged:
                raise ManipcadError(f"{exc}; the partial result is in {exc.stored}") from None
            raise ManipcadError(f"{exc}; nothing was written to "
                                f"{out if space is None else space.root}") from None
    for w in run_notes:
        if issubclass(w.category, ManipcadWarning):
            err_console.print(f"[yellow]warning:[/] {w.message}", highlight=False,
                              soft_wrap=True)
    # deferred: start-up cost: keeps manipcad.store.run out of the CLI's start
    from manipcad.store.run import run_inputs

    checks, out = done.checks, done.where
    doc = result_document(done.result, joint_types=prepared.robot.joint_types,
                          inputs=run_inputs(prepared.robot, prepared.spec), run=done.run)
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
                  f"{done.wall:.3g} s wall; wrote {out}/ (inputs/, "
                  + ("timeseries.csv, " if csv else "")
                  + "timeseries.npz with "
                  + ("every step" if every == 1 else f"one sample every {every} steps")
                  + ", metrics.json, errors.png)"
                  + (f", indexed in the workspace {space.root}" if space is not None else ""),
                  highlight=False, soft_wrap=True)
    if failed:
        raise typer.Exit(1)
