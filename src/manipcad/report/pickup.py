"""The pickup study's figure (:mod:`manipcad.study.pickup`)."""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.fileio import atomic_write

#: line style per case
_STYLE = {"true_mass": ("k", "-"), "online": ("tab:blue", "-"), "nominal": ("tab:red", "--")}


def plot_pickup(data: Mapping[str, Any], runs: Mapping[str, Mapping[str, Any]],
                path: str | Path, *, dpi: int = 110) -> Path:
    """Write pickup.png: the online estimate converging, and |e| of each method per case.

    Panels: (a) the payload estimate (kg) of each method's online run against time (s),
    the true mass and its ±2 % band, the pickup instant, and the estimator's counted
    operations per period; then one panel per method: |e| (rad, log scale) of the joint(s)
    under study with the true mass, the online estimate and the nominal model.

    Args:
        data: the content of pickup.json; runs: method -> case -> SimulationResult.
        path: the PNG file; dpi: resolution.

    Returns:
        The path written.
    """
    # deferred: start-up cost: matplotlib loaded on first use
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure  # deferred: start-up cost: matplotlib loaded on first use

    methods = list(runs)
    fig = Figure(figsize=(9.0, 3.0 * (1 + len(methods))), layout="constrained")
    FigureCanvasAgg(fig)
    axes = np.atleast_1d(fig.subplots(1 + len(methods), 1))
    m, t_pick = data["true_mass"], data["settings"]["t_pick"]
    joints = data["settings"]["joints"]
    ax = axes[0]
    for meth, cases in runs.items():
        res = cases.get("online")
        if res is not None and res.payload_estimate is not None:
            pe = res.payload_estimate
            ax.plot(pe[:, 0], pe[:, 1], lw=1.0, label=f"estimate ({meth} running)")
    ax.axhline(m, color="k", lw=1.0, label=f"true mass {m:g} kg")
    ax.axhspan(0.98 * m, 1.02 * m, color="0.85", label="±2 %")
    ax.axvline(t_pick, color="0.4", ls=":", lw=1.0)
    cx = data["estimator"]["operations_per_period"]
    ts = data.get("estimate_settling_time")
    ax.set_title(f"(a) online payload estimate, RLS λ = {data['estimator']['forgetting']:g} at "
                 f"{data['estimator']['period']:g} s, current noise "
                 f"{data['estimator']['current_noise']:g} A;\n{cx['mul']} mul + {cx['add']} add "
                 f"per period (RLS alone {cx['rls']['mul']} + {cx['rls']['add']}); settles "
                 + ("never" if ts is None else f"{ts:.3g} s after the pickup"), fontsize=8)
    ax.set_xlabel("t, s")
    ax.set_ylabel("m̂, kg")
    ax.legend(fontsize=7, loc="lower right")
    for k, meth in enumerate(methods, start=1):
        ax = axes[k]
        for case, res in runs[meth].items():
            colour, ls = _STYLE[case]
            e = np.abs(np.asarray(res.error))
            cols = [res.joint_names.index(j) for j in joints]
            ax.semilogy(res.t, np.maximum(e[:, cols].max(axis=1), 1e-12), color=colour, ls=ls,
                        lw=0.9, label=f"{case}: max after pickup "
                                      f"{data['max_error_after_pickup'][meth][case]:.3g} rad")
        ax.axvline(t_pick, color="0.4", ls=":", lw=1.0)
        ax.set_title(f"({chr(97 + k)}) {meth} on {', '.join(joints)}: |ε| with the true mass, "
                     "the online estimate, the nominal model", fontsize=8)
        ax.set_xlabel("t, s")
        ax.set_ylabel("|ε|, rad")
        ax.legend(fontsize=7, loc="lower right")

    return atomic_write(path, lambda fh: fig.savefig(fh, dpi=dpi, format="png"), binary=True)
