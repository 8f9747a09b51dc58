"""``manipcad demo``: a short dynamics tour of the built-in robots."""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np

import manipcad
from manipcad.cli.app import app, console, guarded
from manipcad.cli.options import option
from manipcad.cli.study import print_fig3
from manipcad.cli.tables import Table
from manipcad.cli.warmup import finish_warm, start_warm
from manipcad.sim.warm import needs


@app.command()
@guarded
def demo(
    out: option(Path, "--out -o", "Folder for the Fig. 3 study's figure, "
                "JSON and report.") = Path("manipcad-demo"),
) -> None:
    """A dynamics tour of the built-in robots, then the paper's Fig. 3 study."""
    # deferred: start-up cost: keeps manipcad.study out of the CLI's start
    from manipcad.study import run_fig3

    # on a cold kernel cache the study's simulator compiles in a helper process while
    # this one prints the tour (its own, smaller kernels)
    simulator = start_warm(*needs("rk4"))
    try:
        _tour()
    except BaseException:
        simulator.cancel()
        raise
    out.mkdir(parents=True, exist_ok=True)
    finish_warm(simulator)
    print_fig3(run_fig3(out / "fig3", progress=True))


def _tour() -> None:
    """The dynamics tour: each built-in robot's torque components at one state, and the
    forward dynamics back; the operation counts; the study's title."""
    for name in manipcad.catalog_names():
        with warnings.catch_warnings():  # published data sets with known quirks (docs/)
            warnings.simplefilter("ignore", manipcad.ManipcadWarning)
            robot = manipcad.load_robot(name)
        q = np.zeros(robot.n)
        qd = np.full(robot.n, 0.5)
        qdd = np.full(robot.n, 1.0)
        parts = manipcad.torque_components(robot, q, qd, qdd)
        table = Table(title=f"{robot.name} ({name}): q = 0, q̇ = 0.5, q̈ = 1, drives included;"
                      " torques in N·m (R joints) or N (P joints)")
        for col in ("joint", "type", "P_i", "H_ii·q̈_i", "coupling", "h_i", "Q_i",
                    "rotor+fric."):
            table.add_column(col, justify="left" if col in ("joint", "type") else "right")
        for i in range(robot.n):
            table.add_row(robot.joint_names[i], robot.joint_types[i][0].upper(),
                          f"{parts.total[i]:+.3f}", f"{parts.inertial[i]:+.3f}",
                          f"{parts.coupling[i]:+.3f}", f"{parts.velocity[i]:+.3f}",
                          f"{parts.gravity[i]:+.3f}",
                          f"{parts.rotor[i] + parts.friction[i]:+.3f}")
        console.print(table)
        # after the table: on a cold cache its kernels compile while the table is read
        qdd_back = manipcad.forward_dynamics(robot, q, qd, parts.total)
        err = np.abs(qdd_back - qdd).max()
        console.print(f"  total mass {robot.mass.sum():.2f} kg; forward dynamics (O(n)) gives "
                      f"q̈ back to {err:.1e} rad/s²\n")
    counts = manipcad.operation_counts("rnea", 6)
    console.print(f"Inverse dynamics of a 6-joint arm: {counts['mul']} multiplications, "
                  f"{counts['add']} additions (paper: 469, 407); see docs/dynamics.md.\n")
    console.print("[bold]The paper's Fig. 3 study[/] (manipcad study fig3): the turning drive "
                  "of the Fig. 2 arm under laws (2), every synthesis method.")
