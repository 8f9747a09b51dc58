"""The claims maps' figure and HTML report (see :mod:`manipcad.study.claims`).

Drawn off-screen (matplotlib's Agg canvas, no pyplot state); the report is one
self-contained HTML file (:mod:`manipcad.report.html`).
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.report.html import esc, figure, page, paragraph, section, table
from manipcad.report.png import encode_rows, write_png

#: a cell counts as saturated (hatched) above this fraction of time
SATURATED = 0.01


def _grid(values) -> np.ndarray:
    return np.array([[math.nan if v is None else float(v) for v in row] for row in values])


def plot_claims(doc: Mapping[str, Any], path: str | Path, *, dpi: int = 100) -> Path:
    """One heat map per claim: cells coloured by the measured ratio (log scale), the
    paper's threshold drawn as a contour, saturated cells hatched, values written in.

    The same as :func:`save_bands` of one :func:`draw_band` of every claim (a caller
    with workers draws groups of panels, :func:`panel_groups`, on them: the same pixels).

    Args:
        doc: the claims.json document.
        path: the PNG file.
        dpi: resolution, dots per inch.

    Returns:
        The path written.
    """
    return save_bands([draw_band(doc, list(doc["claims"]), dpi=dpi)], path, dpi=dpi)


def panel_groups(doc: Mapping[str, Any], groups: int) -> list[list[str]]:
    """The claims' panels cut into ``groups`` (>= 1) groups of consecutive claims, as even
    as they go (none empty), for :func:`draw_panels` on separate workers.

    Example:
        >>> panel_groups({"claims": dict.fromkeys("abcde")}, 2)
        [['a', 'b'], ['c', 'd', 'e']]
    """
    ids = list(doc["claims"])
    n = max(1, min(int(groups), len(ids)))
    cuts = [round(k * len(ids) / n) for k in range(n + 1)]
    return [ids[cuts[k]:cuts[k + 1]] for k in range(n)]


def draw_panels(doc: Mapping[str, Any], ids: list[str], *, dpi: int = 100) -> np.ndarray:
    """The whole figure of :func:`plot_claims` with only the panels of the claims ``ids``
    drawn (each at its place; the rest of the canvas white), as an RGBA image.

    Panels do not overlap, so the pixel-wise minimum of the images of groups that cover
    every claim is the figure drawn whole (:func:`save_bands`).

    Args:
        doc: the claims.json document.
        ids: the claims to draw (keys of ``doc["claims"]``).
        dpi: resolution, dots per inch.

    Returns:
        uint8 array (height, width, 4).
    """
    # deferred: start-up cost: matplotlib loaded on first use
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.colors import LogNorm  # deferred: start-up cost: matplotlib loaded on first use
    from matplotlib.figure import Figure  # deferred: start-up cost: matplotlib loaded on first use

    claims = doc["claims"]
    speeds = doc["grid"]["speed_scale"]
    rhos = doc["grid"]["load_ratio"]
    sat = _grid(doc["saturation"])
    achieved = [row[0] for row in doc.get("load_ratio_achieved", [[r] for r in rhos])]
    runs = doc.get("speed_scale_run", [[s for s in speeds] for _ in rhos])
    order = list(claims)
    cols = 3
    rows = math.ceil(len(order) / cols)
    # a fixed layout (a constrained one doubles the drawing time for the same look)
    fig = Figure(figsize=(4.2 * cols, 3.6 * rows), dpi=dpi)
    fig.subplots_adjust(left=0.09, right=0.98, bottom=0.04, top=0.97, wspace=0.62,
                        hspace=0.42)
    canvas = FigureCanvasAgg(fig)
    spec = fig.add_gridspec(rows, cols)
    x, y = np.arange(len(speeds)), np.arange(len(rhos))
    for cid in ids:
        place = order.index(cid)
        ax = fig.add_subplot(spec[place // cols, place % cols])
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
    canvas.draw()
    return np.array(canvas.buffer_rgba())


def draw_band(doc: Mapping[str, Any], ids: list[str], *, dpi: int = 100) -> dict:
    """:func:`draw_panels` of the claims ``ids``, and the rows they were drawn on encoded
    as a PNG band (:func:`manipcad.report.png.encode_rows`), for :func:`save_bands`.

    Returns:
        {"shape": the whole image's shape, "span": (first, stop) the rows not all white,
        "band": their :class:`~manipcad.report.png.Band`, "image": those rows (uint8,
        (stop - first, width, 4))}.
    """

    img = draw_panels(doc, ids, dpi=dpi)
    drawn = np.flatnonzero((img != 255).any(axis=(1, 2)))
    first, stop = (int(drawn[0]), int(drawn[-1]) + 1) if drawn.size else (0, 0)
    return {"shape": img.shape, "span": (first, stop), "band": encode_rows(img, first, stop),
            "image": img[first:stop]}


def save_bands(parts: list[dict], path: str | Path, *, dpi: int = 100) -> Path:
    """The PNG of the figure from the :func:`draw_band` of groups of panels that cover
    every claim (each panel drawn on white in one of them).

    Where the groups' rows do not overlap (groups of whole rows of panels) the file is
    joined from their bands and white bands in between, none encoded again here;
    otherwise the pixel-wise minimum of their images is encoded.

    Args:
        parts: the groups' :func:`draw_band`.
        path: the PNG file.
        dpi: the resolution written into the file, dots per inch.

    Returns:
        The path written.
    """

    h, w, _ = parts[0]["shape"]
    drawn = sorted((p for p in parts if p["span"][1] > p["span"][0]), key=lambda p: p["span"])
    if all(a["span"][1] <= b["span"][0] for a, b in zip(drawn, drawn[1:], strict=False)):
        bands, at = [], 0
        for p in [*drawn, {"span": (h, h)}]:
            first, stop = p["span"]
            if first > at:  # white rows above, between and below the groups' (small)
                gap = encode_rows(np.full((first - at, w, 4), 255, np.uint8))
                bands.append(dataclasses.replace(gap, first=at))
            if stop > first:
                bands.append(p["band"])
            at = max(at, stop)
        return write_png(path, bands, dpi=float(dpi))
    rgba = np.full((h, w, 4), 255, np.uint8)
    for p in drawn:
        first, stop = p["span"]
        np.minimum(rgba[first:stop], p["image"], out=rgba[first:stop])
    return write_png(path, [encode_rows(rgba)], dpi=float(dpi))


def _hatch(k: int, i: int):
    # deferred: start-up cost: matplotlib loaded on first use
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
