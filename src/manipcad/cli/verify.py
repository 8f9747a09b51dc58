"""``manipcad verify``: the regulators in the coupled simulation, against every rating, the
accuracy asked and each regulator's promise.

::

    manipcad verify ROBOT -t TRAJECTORY.yaml -r REGULATORS.yaml [-r ...] [--dt S]
                    [--accuracy RAD | --spec max_error=RAD | --requirements REQ.yaml]
                    [--payload KG] [--factor 2] [--json]

The accuracy asked is ``--accuracy`` (or ``--spec max_error=``, or the requirements
file's ``accuracy``), else what each regulator was synthesized for. The run is checked
against every rating (docs/checks.md: tracking against the accuracy asked, amplifier
saturation, chattering, currents, speeds, gear and joint limits). Each regulator's
nominal promise is compared apart: exceeded by more than ``--factor`` it is reported with
the coupling share, but a joint within the accuracy asked meets the requirement.

Exit status 0 when no check fails, 1 when one fails, 2 on bad input.
"""

from __future__ import annotations

import json
import math
import warnings
from dataclasses import asdict
from pathlib import Path

import typer
from rich import box
from rich.markup import escape

from manipcad.cli.app import app, console, err_console, guarded
from manipcad.cli.options import RobotArgument, dt_option, json_flag, option, payload_option
from manipcad.cli.simulate import VERDICT_STYLE, checks_table
from manipcad.cli.tables import Table, styled
from manipcad.control import load_regulators
from manipcad.errors import InputError, ManipcadWarning
from manipcad.expert import Requirements
from manipcad.model.load import load_robot
from manipcad.trajectories import load_trajectory


def _accuracy(accuracy: float | None, spec: list[str] | None,
              requirements: Path | None) -> float | None:
    """The accuracy asked from the options (at most one of them), rad or m."""
    given = [x for x in (accuracy, spec, requirements) if x]
    if len(given) > 1:
        raise InputError("--accuracy", "", "give the accuracy once: --accuracy, --spec "
                         "max_error=... or --requirements")
    if spec:
        pairs = {}
        for item in spec:
            key, sep, value = item.partition("=")
            if not sep or key.strip() != "max_error":
                raise InputError("--spec", "", f"expected max_error=VALUE (rad or m), got "
                                 f"{item!r}")
            try:
                pairs[key.strip()] = float(value)
            except ValueError:
                raise InputError("--spec", "", f"max_error: not a number: {value!r}") from None
        accuracy = pairs["max_error"]
    if requirements is not None:

        accuracy = Requirements.from_yaml(requirements).accuracy
        if accuracy is None:
            raise InputError(str(requirements), "accuracy", "not given: verify compares the "
                             "simulated error with it")
    if accuracy is not None and not (math.isfinite(accuracy) and accuracy > 0):
        raise InputError("--accuracy", "", f"must be > 0 rad (m), got {accuracy}")
    return accuracy


@app.command()
@guarded
def verify(
    robot: RobotArgument,
    trajectory: option(Path, "--trajectory -t", "Trajectory file."),
    regulator: option(list[Path], "--regulator -r", "Regulator file (from manipcad synthesize); "
                      "repeat."),
    dt: dt_option() = 1e-4,
    factor: option(float, "--factor", "A promise is exceeded when the error is over it this many "
                   "times.") = 2.0,
    accuracy: option(float | None, "--accuracy", "The accuracy asked, rad (m), every joint "
                     "(default: what each regulator was synthesized for).") = None,
    spec: option(list[str] | None, "--spec", "max_error=RAD: the accuracy asked, as synthesize "
                 "takes it.") = None,
    requirements: option(Path | None, "--requirements", "A requirements file: its accuracy is the "
                         "accuracy asked.") = None,
    payload: payload_option("Payload mass at the robot's tool point, kg.") = None,
    as_json: json_flag("Print JSON.") = False,
) -> None:
    """Simulate the robot with the regulators; check every rating, the accuracy asked and
    each regulator's promise."""
    # deferred: start-up cost: keeps manipcad.expert.verify out of the CLI's start
    from manipcad.expert.verify import verify as run_verify

    # deferred: start-up cost: keeps manipcad.sim.checks out of the CLI's start
    from manipcad.sim.checks import RunChecks

    if not (math.isfinite(dt) and dt > 0):
        raise InputError("--dt", "", f"must be > 0 s, got {dt}")
    if not (math.isfinite(factor) and factor >= 1):
        raise InputError("--factor", "", f"must be >= 1, got {factor}")
    if payload is not None and not (math.isfinite(payload) and payload >= 0):
        raise InputError("--payload", "", f"must be >= 0 kg, got {payload}")
    asked = _accuracy(accuracy, spec, requirements)
    arm = load_robot(robot)
    traj = load_trajectory(trajectory, robot=arm)
    regs = []
    for path in regulator:
        regs += load_regulators(path, arm, dt=dt)
    with err_console.status(f"simulating {arm.name} along {trajectory}..."), \
            warnings.catch_warnings(record=True) as notes:
        warnings.simplefilter("always", ManipcadWarning)
        promises, res = run_verify(arm, traj, regs, dt=dt, factor=factor, accuracy=asked,
                                   payload=payload)
    for w in notes:
        if issubclass(w.category, ManipcadWarning):
            err_console.print(f"[yellow]warning:[/] {w.message}", highlight=False,
                              soft_wrap=True)
    checks = RunChecks.from_dict(res.checks)
    if as_json:
        typer.echo(json.dumps({"promises": [asdict(c) for c in promises],
                               "checks": res.checks, "verdict": checks.verdict,
                               "summary": checks.summary()}, indent=2, default=str))
    else:
        t = Table(box=box.SIMPLE_HEAD, title=f"{arm.name} in the coupled simulation: the "
                  "accuracy asked and the nominal promise",
                  caption="errors in rad (m for prismatic joints)")
        for col in ("joint", "method", "asked", "simulated", "verdict", "promised",
                    "promise", "coupling", "why"):
            t.add_column(col, overflow="fold")
        for c in promises:
            verdict = ("-" if c.met is None else styled("met", "green") if c.met
                       else styled("✗ missed", "red"))
            promise = ("-" if c.kept is None else "kept" if c.kept
                       else styled(f"exceeded ×{c.ratio:.3g}", "yellow"))
            t.add_row(c.joint, c.method, "-" if c.accuracy is None else f"{c.accuracy:.3g}",
                      f"{c.simulated:.3g}", verdict,
                      "-" if c.promised is None else f"{c.promised:.3g}", promise,
                      f"{100 * c.coupling_share:.0f} %", c.why)
        console.print(t)
        console.print(checks_table(checks))
        console.print(f"[{VERDICT_STYLE[checks.verdict]}]{escape(checks.summary())}[/]",
                      soft_wrap=True)
    if checks.verdict == "fail":
        raise typer.Exit(1)
