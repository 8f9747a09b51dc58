"""``manipcad demo``: a short dynamics tour of the built-in robots."""

from __future__ import annotations

import numpy as np
from rich.table import Table

from manipcad.cli.app import app, console, guarded


@app.command()
@guarded
def demo() -> None:
    """Print a short dynamics tour of the built-in robots."""
    import manipcad

    for name in manipcad.catalog_names():
        robot = manipcad.load_robot(name)
        q = np.zeros(robot.n)
        qd = np.full(robot.n, 0.5)
        qdd = np.full(robot.n, 1.0)
        tau = manipcad.inverse_dynamics(robot, q, qd, qdd)
        H = manipcad.mass_matrix(robot, q)
        table = Table(title=f"{robot.name}: q = 0, qd = 0.5, qdd = 1 (SI units)")
        table.add_column("joint")
        table.add_column("type")
        table.add_column("tau (N·m or N)", justify="right")
        table.add_column("H_ii", justify="right")
        for i in range(robot.n):
            table.add_row(robot.joint_names[i], robot.joint_types[i],
                          f"{tau[i]:+.4f}", f"{H[i, i]:.4f}")
        console.print(table)
