"""The robustness study's figure (see :mod:`manipcad.study.robustness`).

Drawn off-screen (matplotlib's Agg canvas, no pyplot state).
"""

from __future__ import annotations

from collections.abc import Mapping
from pathlib import Path
from typing import Any

from manipcad.fileio import atomic_write


def plot_robustness(doc: Mapping[str, Any], path: str | Path, *, dpi: int = 100) -> Path:
    """Box plots of each method's max |ε| (rad, log scale) over the perturbed arms, the
    nominal arm's value marked (red line); diverged runs counted in the labels.

    Args:
        doc: the robustness.json document.
        path: the PNG file.
        dpi: resolution.

    Returns:
        The path written.
    """
    # deferred: start-up cost: matplotlib loaded on first use
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure  # deferred: start-up cost: matplotlib loaded on first use

    methods = list(doc["methods"])
    data = [[v for v in doc["max_error"][m] if v is not None and v > 0] for m in methods]
    fig = Figure(figsize=(1.3 * len(methods) + 2.5, 4.2), layout="constrained")
    FigureCanvasAgg(fig)
    ax = fig.subplots()
    pos = list(range(1, len(methods) + 1))
    shown = [(p, d) for p, d in zip(pos, data, strict=True) if d]
    if shown:
        ax.boxplot([d for _, d in shown], positions=[p for p, _ in shown], widths=0.6,
                   whis=(5, 95), showfliers=True)
    for p, m in zip(pos, methods, strict=True):
        nom = doc["nominal"].get(m)
        if nom:
            ax.hlines(nom, p - 0.35, p + 0.35, colors="tab:red", linewidth=1.5)
    labels = [m + (f"\n({doc['diverged'][m]} diverged)" if doc["diverged"].get(m) else "")
              for m in methods]
    ax.set_xticks(pos, labels, fontsize=8)
    ax.set_yscale("log")
    ax.set_ylabel("max |ε| of the turning drive, rad")
    s = doc["settings"]
    ax.set_title(f"arm {doc['arm']['name']}, ±{100 * doc['uncertainty']:g} % on link masses, "
                 f"motor constants, payload ({doc['arm']['payload_kg']:g} kg); "
                 f"{doc['samples']} samples; speed scale {s['speed_scale_run']:g}"
                 + (" (time-scaled)" if s["time_scaled"] else "")
                 + "\nboxes 25-75 %, whiskers 5-95 %; red: the nominal arm", fontsize=8)

    return atomic_write(path, lambda fh: fig.savefig(
        fh, dpi=dpi, format=Path(path).suffix.lower().lstrip(".") or "png"), binary=True)
