"""The claims maps' figure and HTML report (see :mod:`manipcad.study.claims`).

Drawn off-screen (matplotlib's Agg canvas, no pyplot state); the report is one
self-contained HTML file (:mod:`manipcad.report.html`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.report.html import esc, figure, page, paragraph, section, table

#: a cell counts as saturated (hatched) above this fraction of time
SATURATED = 0.01


def _grid(values) -> np.ndarray:
    return np.array([[math.nan if v is None else float(v) for v in row] for row in values])


def plot_claims(doc: Mapping[str, Any], path: str | Path, *, dpi: int = 100) -> Path:
    """One heat map per claim: cells coloured by the measured ratio (log scale), the
    paper's threshold drawn as a contour, saturated cells hatched, values written in.

    Args:
        doc: the claims.json document.
        path: the PNG file.
        dpi: resolution.

    Returns:
        The path written.
    """
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import LogNorm
    from matplotlib.figure import Figure

    claims = doc["claims"]
    speeds = doc["grid"]["speed_scale"]
    rhos = doc["grid"]["load_ratio"]
    sat = _grid(doc["saturation"])
    achieved = [row[0] for row in doc.get("load_ratio_achieved", [[r] for r in rhos])]
    runs = doc.get("speed_scale_run", [[s for s in speeds] for _ in rhos])
    ids = list(claims)
    cols = 3
    rows = math.ceil(len(ids) / cols)
    # a fixed layout (a constrained one doubles the drawing time for the same look)
    fig = Figure(figsize=(4.2 * cols, 3.6 * rows))
    fig.subplots_adjust(left=0.09, right=0.98, bottom=0.04, top=0.97, wspace=0.62,
                        hspace=0.42)
    FigureCanvasAgg(fig)
    axes = np.atleast_1d(fig.subplots(rows, cols)).ravel()
    x, y = np.arange(len(speeds)), np.arange(len(rhos))
    for ax, cid in zip(axes, ids, strict=False):
        c = claims[cid]
        z = _grid(c["ratio"])
        finite = z[np.isfinite(z) & (z > 0)]
        overshoot = cid.endswith("overshoot")
        if finite.size and not overshoot:
            lo, hi = float(finite.min()), float(finite.max())
            lo, hi = min(lo, c["threshold"] / 1.5), max(hi, c["threshold"] * 1.5)
            im = ax.imshow(z, origin="lower", aspect="auto", cmap="RdYlGn",
                           norm=LogNorm(vmin=lo, vmax=hi))
            if lo < c["threshold"] < hi and np.isfinite(z).sum() >= 4:
                ax.contour(x, y, np.where(np.isfinite(z), z, lo), levels=[c["threshold"]],
                           colors="k", linewidths=1.5)
        else:
            im = ax.imshow(z, origin="lower", aspect="auto", cmap="RdYlGn_r")
        fig.colorbar(im, ax=ax, shrink=0.8)
        for i in range(len(rhos)):
            for k in range(len(speeds)):
                if math.isfinite(z[i, k]):
                    ax.text(k, i, f"{z[i, k]:.3g}", ha="center", va="center", fontsize=7)
                if runs[i][k] != speeds[k]:  # time-scaled: the speed scale it ran at
                    ran = "-" if runs[i][k] is None else f"{runs[i][k]:.2g}"
                    ax.text(k, i - 0.32, f"s={ran}", ha="center", va="center", fontsize=5,
                            color="0.25")
                if math.isfinite(sat[i, k]) and sat[i, k] > SATURATED:
                    ax.add_patch(_hatch(k, i))
        ax.set_xticks(x, [f"{s:g}" for s in speeds])
        ax.set_yticks(y, [f"{a:.3g}" if abs(a / r - 1) < 1e-6 else f"{a:.3g} (of {r:.3g})"
                          for r, a in zip(rhos, achieved, strict=True)])
        ax.set_xlabel("speed scale s of laws (2)")
        ax.set_ylabel("load ratio ρ")
        unit = "overshoot" if overshoot else f"ratio (threshold {c['threshold']:g})"
        ax.set_title(f"{cid}: {unit}", fontsize=9)
    for ax in axes[len(ids):]:
        ax.set_visible(False)
    fig.savefig(path, dpi=dpi)
    return Path(path)


def _hatch(k: int, i: int):
    from matplotlib.patches import Rectangle

    return Rectangle((k - 0.5, i - 0.5), 1.0, 1.0, fill=False, hatch="///", edgecolor="0.3",
                     linewidth=0.0)


def claims_html(doc: Mapping[str, Any], png: str | Path) -> str:
    """The report: the maps, each claim's paper words, threshold and where it holds."""
    rows = [(cid, c["paper"], c["threshold"], c["where_it_holds"])
            for cid, c in doc["claims"].items()]
    arm = doc["arm"]
    parts = [
        section("The maps", figure(png, "Measured ratio per cell (rows: load ratio ρ, columns: "
                                        "speed scale s); black line: the paper's threshold; "
                                        f"hatched: an amplifier saturated more than "
                                        f"{SATURATED:.0%} of the time; 's=…' under a "
                                        "value: laws (2) time-scaled to that speed scale "
                                        "(the sizing fails at the column's).")),
        section("Where each claim holds", table(["claim", "paper", "threshold", "where"],
                                                rows)),
        section("Arm and grid", paragraph(
            f"Arm {arm['name']} ({arm['robot']}); speed scales {doc['grid']['speed_scale']}, "
            f"load ratios {doc['grid']['load_ratio']} (achieved "
            f"{[row[0] for row in doc.get('load_ratio_achieved', [])]}); "
            f"{doc['settings']['laws']}. {doc['settings'].get('levers', '')}. "
            f"{doc['settings'].get('time_scaling', '')}.")),
    ]
    return page("Where the paper's claims hold", parts,
                subtitle=esc("manipcad study claims, created " + str(doc.get("created", ""))))
