"""The Fig. 3 study's figure and HTML report (see :mod:`manipcad.study.fig3`).

Drawn off-screen (matplotlib's Agg canvas, no pyplot state); the report is one
self-contained HTML file (:mod:`manipcad.report.html`).
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np

from manipcad.fileio import atomic_write
from manipcad.report.html import esc, figure, fmt, page, paragraph, section, table

#: line styles of the tracking curves (the paper's curves 1-3 first)
_STYLE = {
    "none": dict(color="C3", lw=1.3, ls="-"),
    "none_sce": dict(color="C1", lw=1.1, ls="--"),
    "ace_tf": dict(color="C0", lw=1.3, ls="-"),
    "ace_de": dict(color="C2", lw=1.3, ls="-."),
    "lqr": dict(color="C4", lw=1.2, ls="-"),
    "lqr_gs": dict(color="C5", lw=1.2, ls="--"),
}
_CURVE = {"none": "1", "none_sce": "1'", "ace_tf": "2", "ace_de": "3"}


def plot_fig3(tracking: Mapping[str, Any], steps: Mapping[str, Mapping[str, Any]],
              path: str | Path, *, joint: str = "turn", titles: Mapping[str, str] | None = None,
              step: float = 0.1, loads: Mapping[str, Mapping[str, float]] | None = None,
              dpi: int = 110) -> Path:
    """Write the study's figure (PNG): errors ε = q1* − q1 over time, and the VSS steps.

    Panels: (a) the paper's curves 1-3: no adaptation, ACE (1), law (3) (and
    the SCE alone); (b) |ε| of every method on a log scale; (c) lqr and
    lqr_gs; (d) the step responses q1/step of vss and asvs at the smallest and
    largest load. A panel without data says so.

    Args:
        tracking: label -> SimulationResult of the laws (2) runs.
        steps: label -> case -> SimulationResult of the step runs.
        path: the PNG file.
        joint: the joint plotted.
        titles: label -> description for the legend.
        step: the step size, rad (to normalize panel c).
        loads: case -> {"q3": m, "H_11": kg·m²} for panel c's legend.
        dpi: resolution.

    Returns:
        The path written.
    """
    # deferred: start-up cost: matplotlib loaded on first use
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure  # deferred: start-up cost: matplotlib loaded on first use

    titles = dict(titles or {})
    fig = Figure(figsize=(9.0, 13.0), layout="constrained")
    FigureCanvasAgg(fig)
    ax1, axlog, ax2, ax3 = fig.subplots(4, 1)

    def curves(ax, labels, title):
        drawn = 0
        for lab in labels:
            res = tracking.get(lab)
            if res is None:
                continue
            j = list(res.joint_names).index(joint)
            name = f"{_CURVE[lab]}: " if lab in _CURVE else ""
            ax.plot(res.t, res.error[:, j], label=f"{name}{lab} — {titles.get(lab, '')}",
                    **_STYLE.get(lab, {}))
            drawn += 1
        ax.axhline(0.0, color="0.6", lw=0.6)
        ax.set_title(title, fontsize=10)
        ax.set_xlabel("t [s]")
        ax.set_ylabel("ε = q1* − q1 [rad]")
        ax.grid(True, lw=0.4, alpha=0.6)
        ax.ticklabel_format(axis="y", style="sci", scilimits=(-3, 3))
        if drawn:
            ax.legend(fontsize=8, loc="best")
        else:
            ax.text(0.5, 0.5, "no run (see 'skipped' in fig3.json)", ha="center",
                    va="center", transform=ax.transAxes, color="0.4")

    curves(ax1, ("none", "none_sce", "ace_tf", "ace_de"),
           "(a) turning drive under laws (2): no adaptation (1), ACE (1) (2), law (3) (3)")
    drawn = 0
    for lab in ("none", "none_sce", "ace_tf", "ace_de", "lqr", "lqr_gs"):
        res = tracking.get(lab)
        if res is None:
            continue
        j = list(res.joint_names).index(joint)
        err = np.abs(res.error[:, j])
        axlog.semilogy(res.t, np.where(err > 0, err, np.nan), label=lab, **_STYLE.get(lab, {}))
        drawn += 1
    axlog.set_title("(b) all methods: |ε| on a log scale", fontsize=10)
    axlog.set_xlabel("t [s]")
    axlog.set_ylabel("|ε| [rad]")
    axlog.grid(True, which="both", lw=0.3, alpha=0.5)
    if drawn:
        axlog.legend(fontsize=8, loc="best", ncol=3)
    curves(ax2, ("lqr", "lqr_gs"), "(c) quadratic criterion: fixed gain vs gains scheduled (7)")

    drawn = 0
    for lab, color in (("vss", "C7"), ("asvs", "C9")):
        for case, ls in (("min_load", "-"), ("max_load", "--")):
            res = (steps.get(lab) or {}).get(case)
            if res is None:
                continue
            j = list(res.joint_names).index(joint)
            ld = (loads or {}).get(case, {})
            extra = (f", q3 = {ld['q3']:g} m, H_11 = {ld['H_11']:.3g} kg·m²"
                     if "q3" in ld and "H_11" in ld else f", {case}")
            ax3.plot(res.t, (res.q[:, j] - res.q[0, j]) / step, color=color, ls=ls, lw=1.2,
                     label=f"{lab}{extra}")
            drawn += 1
    ax3.axhline(1.0, color="0.6", lw=0.6)
    ax3.set_title(f"(d) step of q1* by {step:g} rad: fixed (vss) and adaptive (asvs) "
                  "variable structure", fontsize=10)
    ax3.set_xlabel("t [s]")
    ax3.set_ylabel("q1 / step [–]")
    ax3.grid(True, lw=0.4, alpha=0.6)
    if drawn:
        ax3.legend(fontsize=8, loc="lower right")
    else:
        ax3.text(0.5, 0.5, "no run (see 'skipped' in fig3.json)", ha="center", va="center",
                 transform=ax3.transAxes, color="0.4")
    fig.suptitle("Fig. 3 study: errors of the turning servo drive (cylindrical arm of Fig. 2)")

    return atomic_write(path, lambda fh: fig.savefig(fh, dpi=dpi, format="png"), binary=True)


def _verdict_class(v: str) -> str:
    if v.startswith("holds"):
        return "holds"
    return {"partly": "partly", "does not hold": "fails"}.get(v, "na")


def _num(x: Any) -> float:
    return float(x) if isinstance(x, int | float) and not isinstance(x, bool) else math.nan


def fig3_html(data: Mapping[str, Any], png: str | Path) -> str:
    """The self-contained HTML report of a Fig. 3 study (``data``: the fig3.json content)."""
    s = data["settings"]
    arm = data["arm"]
    parts = []
    load = arm["turn_load"]
    parts.append(paragraph(
        f"Turning drive q1 of the {arm['robot']} under the paper's laws (2): "
        f"q1 = {s['laws']['q1']}, q3 = {s['laws']['q3']}, q2 {s['laws']['q2']}; "
        f"t_end = {fmt(s['t_end'])} s, integration step dt = {fmt(s['dt'])} s, control "
        f"period {fmt(s['period'])} s; gripper speed up to {fmt(s['gripper_speed_max'], 3)} m/s. "
        f"Every number below is a metric of a simulation of the full coupled arm "
        f"(rigid-body dynamics, DC motors with inductance, amplifier limits, friction) "
        f"run for this report; nothing is copied from the paper."))
    parts.append(figure(png, "Errors ε = q1* − q1 of the turning drive (rad) over time (s), "
                             "one curve per method, and the step responses of vss and asvs.",
                        alt="Fig. 3 study"))

    # the paper's claims
    rows, classes = [], []
    for c in data["claims"]:
        rows.append([f"{c['section']}", c["paper"], c["reading"], c["measured"],
                     f'<span class="{_verdict_class(c["verdict"])}">{esc(c["verdict"])}</span>',
                     c.get("context", "")])
        classes.append(None)
    parts.append(section("The paper's claims and what was measured", table(
        ["paper §", "claim", "how we read it", "measured", "verdict", "context"], rows,
        raw_columns=(4,), classes=classes)))

    # tracking table
    base = data["max_error"].get("none")
    rows = []
    for lab, mx in data["max_error"].items():
        cx = data["complexity"].get(lab, {})
        rows.append([lab, data["titles"].get(lab, ""), _num(mx), _num(data["rms_error"][lab]),
                     _num(base / mx) if base and mx else math.nan,
                     cx.get("gains_stored", "–"), cx.get("ops_per_period", "–"),
                     ", ".join(cx.get("signals", []))])
    parts.append(section("Tracking under laws (2): turning drive", table(
        ["method", "what", "max |ε| (rad)", "RMS ε (rad)", "none / method",
         "gains stored", "ops / period", "signals measured"], rows)))

    # other joints
    rows = []
    for lab, oj in data["other_joints"].items():
        rows.append([lab] + [_num(oj[j][k]) for j in ("reach", "lift")
                             for k in ("max_error", "rms_error")])
    if rows:
        parts.append(section("The other joints in the same runs", paragraph(
            "The reach q3 and the lift q2 run their own PID regulators (the same in every "
            "run): " + "; ".join(f"{k}: {v}" for k, v in s["support_regulators"].items())),
            table(["run", "reach max |e| (m)", "reach RMS e (m)", "lift max |e| (m)",
                   "lift RMS e (m)"], rows)))

    # steps
    rows = []
    for lab in data["rise_time"]:
        for case, ld in data.get("step_loads", {}).items():
            rows.append([lab, f"q3 = {fmt(ld['q3'])} m", _num(ld["H_11"]),
                         _num(data["rise_time"][lab].get(case)),
                         _num(data["overshoot"][lab].get(case)),
                         _num(data["settling_time"][lab].get(case)),
                         data["monotone"][lab].get(case, "–")])
    if rows:
        parts.append(section(f"Step of q1* by {fmt(s['step']['amplitude'])} rad", table(
            ["method", "reach", "H_11 (kg·m²)", "rise time 10-90 % (s)",
             "overshoot (fraction)", "settling ±2 % (s)", "monotone"], rows)))

    # laws
    rows = [[lab, f"<span class=\"law\">{esc(law)}</span>"]
            for lab, law in data["laws_used"].items()]
    parts.append(section("The regulators, with their numbers", table(
        ["method", "law"], rows, raw_columns=(1,))))

    # skipped
    if data["skipped"]:
        parts.append(section("Methods not run", paragraph(
            "These could not be run; no result is reported for them."),
            table(["method", "reason"], list(data["skipped"].items()))))
    else:
        parts.append(section("Methods not run", paragraph("None: every method asked ran.")))

    # the arm
    rows = []
    for jt in arm["joints"]:
        inertia = np.asarray(jt["inertia"], dtype=float)
        rows.append([jt["name"], jt["type"], _num(jt["mass"]),
                     ", ".join(fmt(x) for x in jt["com"]),
                     ", ".join(fmt(x) for x in np.diag(inertia)),
                     " … ".join(fmt(x) for x in jt["limits"])])
    drows = []
    for jt in arm["joints"]:
        d = jt["drive"] or {}
        drows.append([jt["name"], d.get("motor", ""), d.get("gear", ""), _num(d.get("ratio")),
                      _num(d.get("J")), _num(d.get("R")), _num(d.get("L")), _num(d.get("k_m")),
                      _num(d.get("k_w")), _num(d.get("u_max")),
                      ", ".join(fmt(x) for x in d.get("M_f", [])),
                      _num(d.get("rated_torque"))])
    parts.append(section(
        "The arm (catalog: " + arm["catalog"] + ")",
        table(["joint", "type", "mass (kg)", "com (m, link frame)",
               "inertia diag (kg·m², about com)", "limits (rad or m)"], rows),
        table(["joint", "motor", "gear", "i_r (rad/rad, rad/m)", "J (kg·m²)", "R (Ω)",
               "L (H)", "k_m (N·m/A)", "k_w (V·s/rad)", "u_max (V)", "M_f (N·m)",
               "rated torque (N·m)"], drows),
        paragraph(f"Turning drive load: H_11 = {fmt(load['H_11_min'])} kg·m² at q3 = 0 to "
                  f"{fmt(load['H_11_max'])} kg·m² at q3 = 0.5 m; rotor and gear reflected "
                  f"J·i_r² = {fmt(load['rotor_reflected'])} kg·m²; the motor sees its load "
                  f"change by a factor {fmt(load['motor_side_ratio'], 3)}.")))
    parts.append(paragraph(f"Created {data.get('created', '')} by manipcad "
                           f"{data.get('manipcad_version', '')}; the numbers are in fig3.json "
                           "next to this file."))
    return page("Fig. 3 study — turning drive of the Fig. 2 arm", parts,
                subtitle=data.get("paper", ""))


__all__ = ["plot_fig3", "fig3_html"]
