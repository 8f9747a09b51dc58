"""Plots of simulation results, drawn off-screen (matplotlib's Agg canvas, no pyplot).

No global matplotlib state is touched: each plot builds its own
:class:`matplotlib.figure.Figure` on an Agg canvas, so plotting works without
a display and from threads.
"""

from __future__ import annotations

from collections.abc import Sequence
from pathlib import Path

import numpy as np

from manipcad.fileio import atomic_write


def joint_units(joint_types: Sequence[str] | None, n: int) -> list[str]:
    """Position unit per joint: "rad" (revolute), "m" (prismatic), "rad|m" if unknown."""
    if joint_types is None:
        return ["rad|m"] * n
    return ["m" if t == "prismatic" else "rad" for t in joint_types]


def errors_figure(result, *, joint_types: Sequence[str] | None = None,
                  title: str | None = None):
    """The tracking errors q_ref - q over time, one panel per joint, as a Figure.

    Args:
        result: a :class:`manipcad.sim.SimulationResult` (``.t``, ``.error``,
            ``.joint_names``).
        joint_types: "revolute"/"prismatic" per joint, for the axis units
            (rad or m); None: "rad|m".
        title: figure title (default: the robot's name).

    Returns:
        A :class:`matplotlib.figure.Figure` (on an Agg canvas; save it with
        ``fig.savefig(path)`` or show it in Jupyter).

    Example:
        >>> import numpy as np
        >>> from manipcad.sim.simulate import SimulationResult
        >>> z = np.zeros((3, 2))
        >>> res = SimulationResult(t=np.arange(3.0), q=z, qd=z, q_ref=z, qd_ref=z, u=z,
        ...                        current=z, tau=z, joint_names=("a", "b"))
        >>> len(errors_figure(res).axes)
        2
    """
    t = np.asarray(result.t)
    e = np.asarray(result.error)
    names = list(result.joint_names)
    n = len(names)
    units = joint_units(joint_types, n)
    fig = _figure(8.0, 1.0 + 1.6 * n)
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
    return fig


def compare_figure(results: Sequence, labels: Sequence[str], *,
                   joint_types: Sequence[str] | None = None,
                   quantities: Sequence[str] = ("error", "tau", "current")):
    """Several results overlaid: one row per joint, one column per quantity.

    Args:
        results: :class:`manipcad.sim.SimulationResult` objects of one robot
            (same joints).
        labels: one legend label per result.
        joint_types: "revolute"/"prismatic" per joint for the units.
        quantities: columns among "error" (q_ref - q, rad or m), "tau" (N·m or
            N), "current" (A), "u" (V), "q", "qd".

    Returns:
        A :class:`matplotlib.figure.Figure`.

    Example:
        >>> import numpy as np
        >>> from manipcad.sim.simulate import SimulationResult
        >>> z = np.zeros((3, 1))
        >>> r = SimulationResult(t=np.arange(3.0), q=z, qd=z, q_ref=z, qd_ref=z, u=z,
        ...                      current=z, tau=z, joint_names=("a",))
        >>> fig = compare_figure([r, r], ["one", "two"])
        >>> [len(ax.lines) for ax in fig.axes]
        [2, 2, 2]
    """
    if len(results) != len(labels):
        raise ValueError(f"{len(results)} results but {len(labels)} labels")
    names = list(results[0].joint_names)
    n = len(names)
    pos = joint_units(joint_types, n)
    unit = {"error": pos, "q": pos,
            "qd": [f"{u}/s" for u in pos],
            "tau": ["N" if u == "m" else "N·m" if u == "rad" else "N·m|N" for u in pos],
            "current": ["A"] * n, "u": ["V"] * n}
    fig = _figure(4.0 * len(quantities), 1.0 + 1.8 * n)
    axes = fig.subplots(n, len(quantities), sharex=True, squeeze=False)
    for k, (res, label) in enumerate(zip(results, labels, strict=True)):
        if list(res.joint_names) != names:
            raise ValueError(f"result {label!r} has joints {list(res.joint_names)}, "
                             f"expected {names}")
        t = np.asarray(res.t)
        for c, qty in enumerate(quantities):
            data = np.asarray(getattr(res, qty))
            for j in range(n):
                axes[j, c].plot(t, data[:, j], lw=1.0, color=f"C{k % 10}", label=label)
    for c, qty in enumerate(quantities):
        axes[0, c].set_title(qty if qty != "error" else "error q_ref - q")
        axes[-1, c].set_xlabel("t [s]")
        for j in range(n):
            axes[j, c].set_ylabel(f"{names[j]} [{unit[qty][j]}]")
            axes[j, c].grid(True, lw=0.4, alpha=0.6)
            axes[j, c].ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
    axes[0, 0].legend(fontsize="small")
    return fig


def _figure(width: float, height: float):
    # deferred: start-up cost: matplotlib loaded on first use
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure  # deferred: start-up cost: matplotlib loaded on first use

    fig = Figure(figsize=(width, height), layout="constrained")
    FigureCanvasAgg(fig)
    return fig


def plot_errors(result, path: str | Path, *, joint_types: Sequence[str] | None = None,
                title: str | None = None, dpi: int = 100) -> Path:
    """Write a PNG of the tracking errors (:func:`errors_figure`) and return its path.

    Args:
        result: a :class:`manipcad.sim.SimulationResult`.
        path: the PNG file to write.
        joint_types: "revolute"/"prismatic" per joint, for the axis units.
        title: figure title (default: the robot's name).
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

    fig = errors_figure(result, joint_types=joint_types, title=title)
    return atomic_write(path, lambda fh: fig.savefig(fh, dpi=dpi, format="png"), binary=True)


__all__ = ["plot_errors", "errors_figure", "compare_figure", "joint_units"]
