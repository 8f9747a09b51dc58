"""``manipcad verify``: does each regulator keep its promise in the coupled simulation?

::

    manipcad verify ROBOT -t TRAJECTORY.yaml -r REGULATORS.yaml [-r ...] [--dt S]
                    [--factor 2] [--json]

Exit status 0 when every promise is kept (or nothing was promised), 1 when one is missed
by more than ``--factor``, 2 on bad input.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import asdict
from pathlib import Path
from typing import Annotated

import typer
from rich import box
from rich.table import Table

from manipcad.cli.app import app, console, err_console, guarded
from manipcad.errors import InputError, ManipcadWarning


@app.command()
@guarded
def verify(
    robot: Annotated[str, typer.Argument(help="A catalog robot name or a robot file.")],
    trajectory: Annotated[Path, typer.Option("--trajectory", "-t", help="Trajectory file.")],
    regulator: Annotated[list[Path], typer.Option(
        "--regulator", "-r", help="Regulator file (from manipcad synthesize); repeat.")],
    dt: Annotated[float, typer.Option("--dt", help="Integration step, s.")] = 1e-4,
    factor: Annotated[float, typer.Option(
        "--factor", help="A promise is missed when the error exceeds it this many times.")]
    = 2.0,
    as_json: Annotated[bool, typer.Option("--json", help="Print JSON.")] = False,
) -> None:
    """Simulate the robot with the regulators; compare each promised accuracy with it."""
    from manipcad.control import load_regulators
    from manipcad.expert.verify import verify as run_verify
    from manipcad.model.load import load_robot
    from manipcad.trajectories import load_trajectory

    if not (math.isfinite(dt) and dt > 0):
        raise InputError("--dt", "", f"must be > 0 s, got {dt}")
    if not (math.isfinite(factor) and factor >= 1):
        raise InputError("--factor", "", f"must be >= 1, got {factor}")
    arm = load_robot(robot)
    traj = load_trajectory(trajectory, robot=arm)
    regs = []
    for path in regulator:
        regs += load_regulators(path, arm, dt=dt)
    with err_console.status(f"simulating {arm.name} along {trajectory}..."), \
            warnings.catch_warnings(record=True) as notes:
        warnings.simplefilter("always", ManipcadWarning)
        checks, _ = run_verify(arm, traj, regs, dt=dt, factor=factor)
    for w in notes:
        if issubclass(w.category, ManipcadWarning):
            err_console.print(f"[yellow]warning:[/] {w.message}", highlight=False,
                              soft_wrap=True)
    missed = [c for c in checks if c.kept is False]
    if as_json:
        typer.echo(json.dumps([asdict(c) for c in checks], indent=2))
    else:
        t = Table(box=box.SIMPLE_HEAD, title=f"promises against the coupled simulation of "
                  f"{arm.name}", caption="errors in rad (m for prismatic joints)")
        for col in ("joint", "method", "promised", "simulated", "coupling", "verdict"):
            t.add_column(col, overflow="fold")
        for c in checks:
            t.add_row(c.joint, c.method, "-" if c.promised is None else f"{c.promised:.3g}",
                      f"{c.simulated:.3g}", f"{100 * c.coupling_share:.0f} %", c.why)
        console.print(t)
    if missed:
        raise typer.Exit(1)
