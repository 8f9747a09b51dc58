"""Plots of simulation results, drawn off-screen (matplotlib's Agg canvas, no pyplot).

No global matplotlib state is touched: each plot builds its own
:class:`matplotlib.figure.Figure` on an Agg canvas, so plotting works without
a display and from threads.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np


def joint_units(joint_types: Sequence[str] | None, n: int) -> list[str]:
    """Position unit per joint: "rad" (revolute), "m" (prismatic), "rad|m" if unknown."""
    if joint_types is None:
        return ["rad|m"] * n
    return ["m" if t == "prismatic" else "rad" for t in joint_types]


def plot_errors(result, path: str | Path, *, joint_types: Sequence[str] | None = None,
                title: str | None = None, dpi: int = 100) -> Path:
    """Write a PNG of the tracking errors q_ref - q over time, one panel per joint.

    Args:
        result: a :class:`manipcad.sim.SimulationResult` (``.t``, ``.error``,
            ``.joint_names``).
        path: the PNG file to write.
        joint_types: "revolute"/"prismatic" per joint, for the axis units
            (rad or m); None: "rad|m".
        title: figure title (default: the robot's name and the run's status).
        dpi: resolution, dots per inch.

    Returns:
        The path written.

    Example:
        >>> import manipcad
        >>> from manipcad.sim import simulate
        >>> from manipcad.report.plots import plot_errors
        >>> arm = manipcad.load_robot("cylindrical")  # doctest: +SKIP
        >>> res = simulate(arm, t_end=0.1, dt=1e-3, drives=False)  # doctest: +SKIP
        >>> plot_errors(res, "/tmp/errors.png", joint_types=arm.joint_types)  # doctest: +SKIP
        PosixPath('/tmp/errors.png')
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    t = np.asarray(result.t)
    e = np.asarray(result.error)
    names = list(result.joint_names)
    n = len(names)
    units = joint_units(joint_types, n)
    fig = Figure(figsize=(8.0, 1.0 + 1.6 * n), layout="constrained")
    FigureCanvasAgg(fig)
    axes = fig.subplots(n, 1, sharex=True, squeeze=False)[:, 0]
    for j, ax in enumerate(axes):
        ax.plot(t, e[:, j], lw=1.0, color=f"C{j % 10}")
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_ylabel(f"{names[j]}\n[{units[j]}]")
        ax.grid(True, lw=0.4, alpha=0.6)
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
    axes[-1].set_xlabel("t [s]")
    fig.suptitle(title if title is not None else
                 f"{getattr(result, 'robot', '') or 'robot'}: tracking error q_ref - q")
    out = Path(path)
    fig.savefig(out, dpi=dpi, format="png")
    return out


__all__ = ["plot_errors", "joint_units"]
