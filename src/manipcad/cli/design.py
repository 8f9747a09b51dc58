"""``manipcad design``: the automated design in one command.

::

    manipcad design REQUIREMENTS.yaml --robot ROBOT -t TRAJ [-t TRAJ ...]
        [--payload-range LO,HI] [--uncertainty PCT] [--samples N] [--makers a,b]
        [--counterbalance auto|none] [--period S] [--dt S] [--max-methods N]
        [--max-iterations N] [--strict] [--workers N | --scheduler ADDR] --out DESIGN
        [--ws WORKSPACE]

Writes DESIGN/robot.yaml, regulators.yaml, trajectories/, design.json, report.html, c/
and runs/ (:mod:`manipcad.design`; docs/design.md). Exit 0: the design meets the
requirements in every case; 1: no design does (the closest one is written, and the
case it fails and why are printed); 2: bad input. With ``--ws`` the robot and
trajectories may be workspace names and the design is stored as ``studies/DESIGN``.
"""

from __future__ import annotations

import math
import shutil
import tempfile
from contextlib import ExitStack
from pathlib import Path
from typing import Annotated

import typer
from rich import box

from manipcad.cli.app import app, console, err_console, guarded
from manipcad.cli.options import (
    Scheduler,
    Workers,
    dt_option,
    option,
    progress_flag,
    strict_flag,
    ws_option,
)
from manipcad.cli.tables import Table, styled
from manipcad.errors import InputError


def parse_range(text: str | None) -> tuple[float, float]:
    """``"LO,HI"`` (kg) as two floats; one value is a point range.

    Example:
        >>> parse_range("0,2"), parse_range("1.5"), parse_range(None)
        ((0.0, 2.0), (1.5, 1.5), (0.0, 0.0))
    """
    if text is None:
        return 0.0, 0.0
    parts = [p.strip() for p in str(text).split(",")]
    try:
        vals = [float(p) for p in parts]
    except ValueError:
        raise InputError("--payload-range", "", f"expected LO,HI in kg, got {text!r}") from None
    if len(vals) == 1:
        vals = vals * 2
    if len(vals) != 2 or not all(math.isfinite(v) for v in vals):
        raise InputError("--payload-range", "", f"expected LO,HI in kg, got {text!r}")
    return vals[0], vals[1]


@app.command()
@guarded
def design(
    requirements: Annotated[str, typer.Argument(
        help="Requirements YAML file (accuracy needed; docs/expert-rules.md).")],
    robot: option(str, "--robot", "Catalog robot name or robot file (drives on every joint)."),
    trajectory: option(list[str], "--trajectory -t", "Trajectory YAML file; repeat for several."),
    out: option(str, "--out -o", "The design folder (created; a rerun reuses its cache of runs)."),
    payload_range: option(str | None, "--payload-range", "Gripped mass at the tool point, LO,HI kg "
                          "(added to the robot file's); the design is verified at both ends and "
                          "the middle.") = None,
    uncertainty: option(float, "--uncertainty", "Link and drive parameter uncertainty, ± %.") = 0.0,
    samples: option(int, "--samples", "Uncertainty samples: nominal, the heavy-weak and "
                    "light-strong corners, all up, all down, then random (docs/design.md).") = 5,
    seed: option(int, "--seed", "Random seed of the random samples.") = 0,
    makers: option(str | None, "--makers", "Catalogue makers the drive selection may use, "
                   "comma-separated.") = None,
    counterbalance: option(str, "--counterbalance", "auto: apply the counterweights that pay; "
                           "none: report them only.") = "none",
    period: option(float, "--period", "The regulators' control period, s (a multiple of "
                   "--dt).") = 1e-3,
    dt: dt_option("Integration step (RK4), s.") = 1e-4,
    max_methods: option(int, "--max-methods", "How many of the rules' methods are verified.") = 4,
    max_iterations: option(int, "--max-iterations", "Rounds of the decision (tighter synthesis, "
                           "next drive up) before giving up.") = 3,
    strict: strict_flag() = False,
    workers: Workers = None,
    scheduler: Scheduler = None,
    progress: progress_flag("the runs") = True,
    store_runs: option(str, "--store-runs", "Runs stored as result folders in DESIGN/runs: final "
                       "(the chosen design's), all (every run of the sweep; large), "
                       "none.") = "final",
    compare_selection: option(bool, "--compare-selection/--no-compare-selection", "For each "
                              "counterweight proposed, the drive the catalogue selection picks "
                              "without and with it.") = True,
    ws: ws_option("Workspace: the robot and trajectories may be its item names, and the "
        "design is stored there as studies/OUT (without the run cache).") = None,
) -> None:
    """The automated design: drives, decoupling, method, regulators, verification, C code."""
    if not (math.isfinite(uncertainty) and 0 <= uncertainty < 100):
        raise InputError("--uncertainty", "", f"must be a percentage in [0, 100), got "
                         f"{uncertainty!r}")
    mk = None if makers is None else [m.strip() for m in makers.split(",") if m.strip()]
    lo, hi = parse_range(payload_range)
    sources = {"requirements": requirements, "robot": robot, "trajectories": list(trajectory)}
    space = None
    folder = Path(out)
    with ExitStack() as stack:
        if ws is not None:
            # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
            from manipcad.workspace import Workspace, check_name, resolve_input

            space = Workspace(ws)
            check_name(out, "design name")
            space.check_free("studies", out)                 # before the run, not after
            robot = str(resolve_input("robot", robot, space))
            trajectory = [str(resolve_input("trajectory", t, space)) for t in trajectory]
            folder = Path(stack.enter_context(tempfile.TemporaryDirectory())) / "design"
        doc, met = _run(requirements, robot, trajectory, folder, lo, hi, uncertainty, samples,
                        seed, mk, counterbalance, period, dt, max_methods, max_iterations,
                        strict, workers, scheduler, progress, sources, compare_selection,
                        store_runs)
        if space is not None:
            shutil.rmtree(folder / "cache", ignore_errors=True)
            space.add(folder, kind="study", name=out)
            folder = space.root / "studies" / out
    console.print(summary_table(doc))
    ex = doc["executor"]
    console.print(f"{len(doc['cases'])} runs ({ex['runs_computed']} computed, "
                  f"{ex['runs_cached']} from the cache) in {ex['wall_time_s']:.1f} s; wrote "
                  f"{folder}/ (robot.yaml, regulators.yaml, design.json, report.html, c/, "
                  "runs/)", highlight=False, soft_wrap=True)
    for jn, fails in (doc.get("support_failures") or {}).items():
        err_console.print(f"[yellow]warning:[/] {jn} (not named by the requirements, driven by "
                          f"a PID) fails " + ", ".join(f"{k} in {n} runs" for k, n in
                                                       fails.items()),
                          highlight=False, soft_wrap=True)
    if not met:
        err_console.print(f"[bold red]not met:[/] {doc['failure']['text']}", highlight=False,
                          soft_wrap=True)
        raise typer.Exit(1)


def _run(requirements, robot, trajectory, out, lo, hi, uncertainty, samples, seed, mk,
         counterbalance, period, dt, max_methods, max_iterations, strict, workers, scheduler,
         progress, sources, compare_selection=True, store_runs="final"
         ) -> tuple[dict, bool]:
    """run_design with the command's arguments: (design.json, met)."""
    # deferred: start-up cost: keeps manipcad.design out of the CLI's start
    from manipcad.design import DesignNotMet, run_design

    met = True
    try:
        doc = run_design(requirements, robot, list(trajectory), out=out, payload_range=(lo, hi),
                         uncertainty=uncertainty / 100.0, samples=samples, seed=seed,
                         makers=mk, counterbalance=counterbalance, period=period, dt=dt,
                         max_methods=max_methods, max_iterations=max_iterations,
                         strict=strict, workers=workers, scheduler=scheduler,
                         progress=progress, sources=sources,
                         compare_selection=compare_selection, store_runs=store_runs)
    except DesignNotMet as exc:
        doc, met = exc.doc, False
    return doc, met


def summary_table(doc: dict) -> Table:
    """Per joint the parts, the method and the worst-case error against the accuracy."""
    t = Table(title=f"{doc['robot']}: design {doc['status']} (accuracy {doc['accuracy']:g} "
                    f"on {', '.join(doc['accuracy_joints'])})", box=box.SIMPLE_HEAD)
    for col in ("joint", "motor", "gear", "method", "worst max |e|", "verdict"):
        t.add_column(col, justify="right" if col == "worst max |e|" else "left")
    for jn, p in doc["parts"].items():
        if p is None:
            continue
        err = doc["worst_case_error"].get(jn)
        designed = jn in doc["accuracy_joints"]
        ok = designed and err is not None and err != "inf" and err <= doc["accuracy"]
        t.add_row(jn, p.get("motor", ""), p.get("gear", ""),
                  doc["methods"].get(jn) or doc["support"].get(jn, "-"),
                  "-" if err is None else (err if isinstance(err, str) else f"{err:.3g}"),
                  ("met" if ok else styled("missed", "red")) if designed else "(not designed)")
    return t
