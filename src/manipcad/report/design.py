"""The automated design's report: one self-contained HTML page with its figures.

:func:`write_report` takes the design.json document and the runs (with their envelopes)
and writes ``report.html``: the verdict, the parts, the counterbalance, the rules fired
and the methods they excluded, every candidate with its worst error and why it was
rejected, the worst margin of every check, the cases run, the decision trace, and three
figures (matplotlib, Agg, inlined as base64 PNG):

- the tracking-error envelope over the sweep: per designed joint, the largest |e| over
  the final design's cases in each time bin, the nominal case and the accuracy asked;
- torques, speeds and currents against the ratings: per joint the peak over the cases
  as a fraction of the drive's rating (joint side);
- the methods compared: per designed joint the worst-case error of every candidate
  against the accuracy, the chosen one marked.
"""

from __future__ import annotations

import io
import math
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.fileio import atomic_write_bytes, atomic_write_text
from manipcad.report.html import esc, figure, fmt, page, paragraph, section, table


def _canvas(w: float, h: float):
    # deferred: start-up cost: matplotlib loaded on first use
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure  # deferred: start-up cost: matplotlib loaded on first use

    fig = Figure(figsize=(w, h))       # fixed margins: a layout engine costs seconds here
    FigureCanvasAgg(fig)
    return fig


def _log(ax) -> None:
    """A log y axis with few ticks (their layout is what a log axis costs)."""
    # deferred: start-up cost: matplotlib loaded on first use
    from matplotlib.ticker import LogLocator, NullLocator

    ax.set_yscale("log")
    ax.yaxis.set_major_locator(LogLocator(numticks=5))
    ax.yaxis.set_minor_locator(NullLocator())


def _png(fig, dpi: int = 90) -> bytes:
    buf = io.BytesIO()
    fig.savefig(buf, format="png", dpi=dpi)
    return buf.getvalue()


def envelope_figure(doc: Mapping[str, Any], runs: Sequence[Mapping[str, Any]]) -> bytes:
    """The tracking-error envelope of the final design over its cases (PNG bytes)."""
    final = set(doc["final_cases"])
    joints = list(doc["accuracy_joints"])
    nj = max(1, len(joints))
    fig = _canvas(8.0, 1.9 * nj + 0.6)
    axes = fig.subplots(nj, 1, sharex=True, squeeze=False)[:, 0]
    names = list(doc["parts"])
    nominal = (doc.get("reproduce") or {}).get("case")
    for ax, jn in zip(axes, joints, strict=True):
        k = names.index(jn)
        by_traj: dict[int, list] = {}
        for r in runs:
            if r["id"] in final and r.get("envelope"):
                by_traj.setdefault(r["trajectory"], []).append(r)
        for ti, rs in sorted(by_traj.items()):
            t = rs[0]["envelope"]["t"]
            m = len(t)
            hi = [max(r["envelope"]["error"][i][k] for r in rs if len(r["envelope"]["t"]) == m)
                  for i in range(m)]
            lo = [min(r["envelope"]["error"][i][k] for r in rs if len(r["envelope"]["t"]) == m)
                  for i in range(m)]
            ax.fill_between(t, [max(v, 1e-12) for v in lo], [max(v, 1e-12) for v in hi],
                            step="post", alpha=0.3, label=f"trajectory {ti}: all cases")
            ax.step(t, [max(v, 1e-12) for v in hi], where="post", lw=0.8)
            for r in rs:
                if r["id"] == nominal:
                    ax.step(t, [max(e[k], 1e-12) for e in r["envelope"]["error"]],
                            where="post", color="k", lw=0.8, label="nominal case")
        ax.axhline(doc["accuracy"], color="r", ls="--", lw=1, label="accuracy")
        _log(ax)
        ax.set_ylabel(f"{jn}\n|e|", fontsize=8)
        ax.grid(True, alpha=0.3)
    axes[0].legend(fontsize=7, loc="upper right")
    axes[-1].set_xlabel("t, s")
    fig.suptitle("Tracking error over the sweep (max |e| per time bin)", fontsize=10)
    fig.subplots_adjust(left=0.16, right=0.97, top=1 - 0.45 / fig.get_figheight(),
                        bottom=0.5 / fig.get_figheight(), hspace=0.15)
    return _png(fig)


def ratings_figure(doc: Mapping[str, Any]) -> bytes:
    """Peak torque, speed and current of every joint over the final cases, as a fraction
    of the drive's joint-side rating (PNG bytes)."""

    peaks, ratings = doc["peaks"], doc["ratings"]
    joints = [j for j in peaks if ratings.get(j)]
    items = (("torque", "gear_peak_torque", "peak torque / gear repeated peak"),
             ("torque", "motor_peak_torque", "peak torque / motor peak · i_r"),
             ("speed", "max_speed", "peak speed / motor max speed ÷ i_r"),
             ("current", "peak_current", "peak current / motor peak current"))
    fig = _canvas(8.0, 3.4)
    ax = fig.subplots()
    x = np.arange(len(joints))
    w = 0.8 / len(items)
    for k, (what, rating, label) in enumerate(items):
        vals = []
        for j in joints:
            lim = ratings[j].get(rating)
            v = peaks[j].get(what)
            vals.append(v / lim if lim and v is not None and math.isfinite(lim) else np.nan)
        ax.bar(x + (k - (len(items) - 1) / 2) * w, vals, w, label=label)
    ax.axhline(1.0, color="r", ls="--", lw=1)
    ax.set_xticks(x, joints, rotation=20, fontsize=8)
    ax.set_ylabel("peak / rating")
    ax.legend(fontsize=7)
    ax.grid(True, axis="y", alpha=0.3)
    ax.set_title("Torques, speeds and currents against the ratings (worst case)", fontsize=10)
    fig.subplots_adjust(left=0.09, right=0.98, top=0.9, bottom=0.22)
    return _png(fig)


def methods_figure(doc: Mapping[str, Any]) -> bytes:
    """The worst-case error of every candidate on every designed joint (PNG bytes)."""

    joints = list(doc["accuracy_joints"])
    labels = list(doc["candidates"])
    fig = _canvas(8.0, 3.4)
    ax = fig.subplots()
    x = np.arange(len(joints))
    w = 0.8 / max(1, len(labels))
    for k, lab in enumerate(labels):
        per = doc["candidates"][lab]["joints"]
        vals, hatch = [], []
        for jn in joints:
            e = per.get(jn, {}).get("worst_error")
            e = math.inf if e == "inf" else e
            vals.append(np.nan if e is None else min(float(e), 1e3))
            hatch.append(per.get(jn, {}).get("passed"))
        bars = ax.bar(x + (k - (len(labels) - 1) / 2) * w, vals, w, label=lab)
        for b, ok, jn in zip(bars, hatch, joints, strict=True):
            chosen = doc["methods"].get(jn) == doc["candidates"][lab]["method"] and ok
            b.set_edgecolor("k" if chosen or ok is False else "none")
            b.set_linewidth(1.8 if chosen else 0.5)
            if ok is False:
                b.set_hatch("//")
    ax.axhline(doc["accuracy"], color="r", ls="--", lw=1, label="accuracy")
    _log(ax)
    ax.set_xticks(x, joints, rotation=20, fontsize=8)
    ax.set_ylabel("worst-case max |e|")
    ax.legend(fontsize=7, ncol=2)
    ax.grid(True, axis="y", alpha=0.3)
    ax.set_title("Methods compared (hatched: fails a check in some case; outlined: chosen)",
                 fontsize=10)
    fig.subplots_adjust(left=0.09, right=0.98, top=0.9, bottom=0.22)
    return _png(fig)


def _selected(sel: Mapping[str, Any] | None) -> str:
    """"A (m kg) → B (m kg)": the selection's drive without and with the counterweight."""
    if not sel:
        return "–"

    def one(x: Mapping[str, Any]) -> str:
        return x.get("error") or f"{x['drive']} ({x['mass']:.3g} kg)"
    return f"{one(sel['before'])} → {one(sel['after'])}"


def _counterbalance(cb: Mapping[str, Any]) -> str:
    rows = []
    for jn, e in cb["joints"].items():
        cw = e.get("counterweight")
        b, a = e.get("sizing_before", {}), e.get("sizing_after", {})
        rows.append([jn, e["gravity_share"], "yes" if e["gravity_dominates"] else "no",
                     (f"{cw['mass']:.3g} kg at {cw['arm']:g} m" if cw else
                      e.get("no_counterweight", "–")),
                     f"{e['class_before']} → {e['class_after']}",
                     f"{fmt(b.get('rms_torque'))} → {fmt(a.get('rms_torque'))}",
                     f"{fmt(b.get('peak_torque'))} → {fmt(a.get('peak_torque'))}",
                     f"{b.get('status')} → {a.get('status')}",
                     _selected(e.get("selected_drive"))])
    head = paragraph(
        f"Counterweights {'applied' if cb['applied'] else 'not applied'} "
        f"(--counterbalance {cb['mode']}). Gravity dominates a joint when RMS(Q_i) ≥ "
        f"{cb['dominant_share']:g}·RMS(P_i); a counterweight is proposed when it lowers the "
        f"joint's RMS motor torque by ≥ {100 * cb['pays']:g} % and no joint's sizing gets worse.")
    return head + table(["joint", "gravity share", "dominates", "counterweight",
                         "coupling class", "RMS torque N·m", "peak torque N·m",
                         "sizing (drive)", "catalogue selection"], rows)


def figures(doc: Mapping[str, Any], runs: Sequence[Mapping[str, Any]]) -> dict[str, bytes]:
    """The report's three figures as PNG bytes: envelope, ratings, methods."""
    return {"envelope": envelope_figure(doc, runs), "ratings": ratings_figure(doc),
            "methods": methods_figure(doc)}


def design_html(doc: Mapping[str, Any], runs: Sequence[Mapping[str, Any]],
                figs: Mapping[str, bytes] | None = None) -> str:
    """The report page (self-contained HTML); ``figs`` as :func:`figures` gives them."""
    figs = figures(doc, runs) if figs is None else figs
    met = doc["status"] == "met"
    body = []
    verdict = ("The design meets the accuracy in every case." if met
               else f"No design meets the requirements. {doc['failure']['text']}")
    body.append(paragraph(verdict, cls="holds" if met else "fails"))
    for jn, fails in (doc.get("support_failures") or {}).items():
        body.append(paragraph(
            f"Note: {jn}, which the requirements do not name (driven by a PID), fails "
            + ", ".join(f"{k} in {n} of {len(doc['final_cases'])} runs"
                        for k, n in fails.items())
            + " — its drive or its trajectory needs a look (every check's worst margin "
              "below).", cls="fails"))
    rows = [[jn, doc["methods"].get(jn) or doc["support"].get(jn, "–"),
             (doc["parts"][jn] or {}).get("motor"), (doc["parts"][jn] or {}).get("gear"),
             (doc["parts"][jn] or {}).get("ratio"), doc["worst_case_error"].get(jn),
             doc["accuracy"] if jn in doc["accuracy_joints"] else None]
            for jn in doc["parts"]]
    body.append(section("The design", table(
        ["joint", "method", "motor", "gear", "i_r", "worst-case max |e| (rad, m)",
         "accuracy"], rows)))
    rep = doc.get("reproduce")
    if rep:
        body.append(paragraph(f"Reproduce the nominal case ({rep['case']}) in the design "
                              f"folder: {rep['command']}"))
    body.append(section("Tracking error over the sweep",
                        figure(figs["envelope"], "Largest |e| per time bin over "
                               "the payloads and uncertainty samples; black: nominal case; "
                               "red: the accuracy.")))
    body.append(section("Torques, speeds and currents against the ratings",
                        figure(figs["ratings"], "Peak over the final cases over the "
                               "drive's joint-side rating; above 1 exceeds it.")))
    marg = []
    for jn, checks in doc["worst_margins"].items():
        for name, c in checks.items():
            marg.append([jn, name, c.get("value"), c.get("limit"), c.get("unit"),
                         c.get("margin"), c.get("verdict"), c.get("case")])
    body.append(section("Every check's worst margin", table(
        ["joint", "check", "value", "limit", "unit", "margin", "verdict", "case"], marg)))
    body.append(section("Methods compared", figure(figs["methods"], "Worst-case error "
                        "of each candidate per joint.")))
    cand_rows = []
    for lab, c in doc["candidates"].items():
        for jn, e in c["joints"].items():
            cand_rows.append([lab, jn, e.get("cost"), e.get("worst_error"), e.get("worst_case"),
                              "pass" if e.get("passed") else "rejected",
                              e.get("reason") or ""])
        for jn, why in c["refused"].items():
            cand_rows.append([lab, jn, None, None, None, "refused", why])
    body.append(section("Every candidate", table(
        ["method", "joint", "complexity cost", "worst error", "worst case", "verdict",
         "why"], cand_rows)))
    rules = doc["rules"]
    body.append(section("Rules", table(["rule fired", "text"],
                                       [[r["id"], r["text"]] for r in rules["fired"]]),
                        table(["method excluded", "why"],
                              [[m, why] for m, why in rules["excluded"].items()])))
    body.append(section("Counterbalance", _counterbalance(doc["counterbalance"])))
    case_rows = [[c["id"], c["method"], c["payload"], c["sample_name"], c["trajectory"],
                  c["status"], ", ".join(f"{j}: {v}" for j, v in c["verdict"].items()
                                         if v != "pass") or "all pass"]
                 for c in doc["cases"] if c["final"]]
    body.append(section("Cases of the final design", table(
        ["case", "method", "payload kg", "uncertainty sample", "trajectory", "status",
         "joints not passing"], case_rows)))
    body.append(section("Decision trace", "<ol>" + "".join(
        f"<li><b>{esc(t['step'])}</b>: {esc(t['text'])}</li>" for t in doc["trace"])
        + "</ol>"))
    s = doc["settings"]
    sub = (f"{doc['robot']}: accuracy {doc['accuracy']:g} on "
           f"{', '.join(doc['accuracy_joints'])}; payload {s['payload_range'][0]:g}–"
           f"{s['payload_range'][1]:g} kg, uncertainty ±{100 * s['uncertainty']:g} % "
           f"({len(s['samples'])} samples), period {s['period']:g} s, dt {s['dt']:g} s; "
           f"{doc['executor']['runs_computed']} runs computed, "
           f"{doc['executor']['runs_cached']} from the cache.")
    return page(f"Automated design: {doc['robot']}", body, subtitle=sub)


def write_report(path: str | Path, doc: Mapping[str, Any],
                 runs: Sequence[Mapping[str, Any]], *, png_dir: str | Path | None = None
                 ) -> Path:
    """Write report.html (see :func:`design_html`) and, with ``png_dir``, its figures as
    envelope.png, ratings.png and methods.png there."""

    figs = figures(doc, runs)
    if png_dir is not None:
        Path(png_dir).mkdir(parents=True, exist_ok=True)
        for name, data in figs.items():
            atomic_write_bytes(Path(png_dir) / f"{name}.png", data)
    return atomic_write_text(path, design_html(doc, runs, figs))


__all__ = ["write_report", "design_html", "figures", "envelope_figure", "ratings_figure",
           "methods_figure"]
