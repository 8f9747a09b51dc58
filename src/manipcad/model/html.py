"""HTML tables of a robot for Jupyter (``Robot._repr_html_``)."""

from __future__ import annotations

from html import escape

import numpy as np


def robot_html(robot) -> str:
    """A robot as an HTML table: per joint its type, parent, limits (rad or m), link
    mass (kg) and drive (motor J kg·m², gear ratio), with the totals.

    Example:
        >>> import manipcad
        >>> "<table" in robot_html(manipcad.load_robot("scara"))
        True
    """
    def num(x: float) -> str:
        return "−∞" if x == -np.inf else "∞" if x == np.inf else f"{x:.4g}"

    rows = []
    for i in range(robot.n):
        unit = "rad" if robot.joint_types[i] == "revolute" else "m"
        lo, hi = robot.limits[i]
        parent = "base" if robot.parent[i] < 0 else robot.joint_names[robot.parent[i]]
        d = robot.drives[i]
        drive = "—" if d is None else escape(
            f"{d.name or 'drive'}: J = {d.J:.3g} kg·m², i_r = {d.ratio:g}"
            + (f", gear {d.gear}" if d.gear else ""))
        rows.append(f"<tr><td>{escape(robot.joint_names[i])}</td><td>{robot.joint_types[i]}"
                    f"</td><td>{escape(parent)}</td><td>{num(lo)} … {num(hi)} {unit}</td>"
                    f"<td>{robot.mass[i]:.4g}</td><td>{drive}</td></tr>")
    return (f"<p><b>{escape(robot.name)}</b>: {robot.n} joints, total link mass "
            f"{float(np.sum(robot.mass)):.4g} kg, gravity {np.asarray(robot.gravity).tolist()} "
            "m/s²</p><table><thead><tr><th>joint</th><th>type</th><th>parent</th>"
            "<th>limits</th><th>mass kg</th><th>drive</th></tr></thead><tbody>"
            + "".join(rows) + "</tbody></table>")
