"""``manipcad coupling``: how strongly each drive is coupled along a trajectory (paper 2).

::

    manipcad coupling ROBOT --trajectory FILE [--dt S] [--threshold F] [--rotor] [--json]

Per joint: the peaks of the own inertial, coupling, velocity and gravity
constituents, their ratios to the own inertial one, the range of H_ii, what a
constant-torque spring and a balancer (counterweight or spring balancer, a
function of the joint's own coordinate) leave of gravity, and the class
decoupled / inertial / full (rules in :mod:`manipcad.analysis.coupling`).
Bad input exits with status 2 and one line on stderr.
"""

from __future__ import annotations

import json
import math
import warnings

from rich import box

from manipcad.analysis.coupling import coupling_analysis
from manipcad.cli.app import app, console, guarded
from manipcad.cli.options import RobotArgument, dt_option, json_flag, option
from manipcad.cli.tables import Table, styled
from manipcad.errors import ManipcadWarning
from manipcad.model.load import load_robot

STYLE = {"decoupled": "green", "inertial": "yellow", "full": "red"}


def _pct(x: float) -> str:
    return "∞" if math.isinf(x) else f"{100 * x:.1f}"


@app.command()
@guarded
def coupling(
    robot: RobotArgument,
    trajectory: option(str, "--trajectory -t", "Trajectory YAML file (docs/trajectories.md)."),
    dt: dt_option("Sampling step, s.") = 1e-3,
    threshold: option(float, "--threshold", "Classification threshold, a fraction (0.05 = "
                      "5 %).") = 0.05,
    rotor: option(bool, "--rotor", "Count the rotor inertia J·i_r² as the joint's own "
                  "inertia.") = False,
    as_json: json_flag() = False,
) -> None:
    """Coupling, velocity and gravity constituents next to each joint's own inertia."""

    with warnings.catch_warnings():
        warnings.simplefilter("ignore", ManipcadWarning)  # data-set quirks, see robots show
        model = load_robot(robot)
    rep = coupling_analysis(model, trajectory, dt=dt, threshold=threshold, rotor=rotor)
    if as_json:
        print(json.dumps({"trajectory_file": str(trajectory), **rep.to_dict()}, indent=2))
        return
    own = "H_ii·q̈_i" + (" + J·i_r²·q̈_i" if rotor else "")
    table = Table(box=box.SIMPLE_HEAD, title=(
        f"{rep.robot} along {trajectory} ({rep.samples} samples, dt = {rep.dt:g} s): peaks in "
        f"N·m (R) or N (P); % of the own inertial peak {own}"))
    cols = ("joint", "class", "own peak", "coupling %", "velocity %", "gravity %",
            "H_ii min..max", "H max/min", "Q const", "after spring", "after balancer")
    for col in cols:
        table.add_column(col, justify="left" if col in ("joint", "class") else "right")
    for j in rep.joints:
        table.add_row(
            f"{j.joint} ({j.type[0].upper()})",
            styled(j.classification, STYLE[j.classification]),
            f"{j.inertial_peak:.4g}", _pct(j.coupling_ratio), _pct(j.velocity_ratio),
            _pct(j.gravity_ratio), f"{j.H_min:.4g}..{j.H_max:.4g} {j.inertia_unit}",
            f"{j.H_ratio:.3g}", f"{j.gravity_constant:+.4g}", f"{j.gravity_after_spring:.4g}",
            f"{j.gravity_after_balancer:.4g}")
    console.print(table)
    console.print(f"threshold {100 * rep.threshold:g} %; overall: "
                  f"[{STYLE[rep.overall]}]{rep.overall}[/]. 'after spring': gravity peak "
                  "left by the best constant-torque spring; 'after balancer': left by the best "
                  "counterweight/spring balancer acting on the joint's own coordinate.",
                  highlight=False)
    for j in rep.joints:
        console.print(f"  {j.joint}: " + "; ".join(j.reasons), highlight=False)
