"""``manipcad study``: reproductions of the paper's experiments.

``manipcad study fig3 --out DIR [--dt 1e-4] [--t-end 1.6] [--methods a,b]
[--no-progress]`` runs the Fig. 3 study (:func:`manipcad.study.run_fig3`):
the turning drive of the Fig. 2 arm under laws (2) with every synthesis
method, and the variable-structure step test; writes DIR/fig3.png,
DIR/fig3.json and DIR/report.html and prints a summary table. A method that
cannot be run is listed as skipped with its reason (exit status 0: that is a
result). Bad input (dt out of range, an unknown method, an output path whose
parent does not exist) exits with status 2 and one line on stderr.
"""

from __future__ import annotations

import math
import tempfile
from contextlib import contextmanager
from pathlib import Path

import typer
from rich import box
from rich.markup import escape

from manipcad.cli.app import app, console, guarded
from manipcad.cli.options import dt_option, option, t_end_option, ws_option
from manipcad.cli.tables import Table

study_app = typer.Typer(help="Reproduce the paper's experiments (Fig. 3, pickup).",
                        no_args_is_help=True)
app.add_typer(study_app, name="study")

_COLOUR = {"holds": "green", "partly": "yellow", "does not hold": "red",
           "not measured": "grey50"}


def _g(x, unit: str = "") -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "-"
    return f"{x:.4g} {unit}".rstrip()

#: a study's output folder, or with --ws its name in the workspace
StudyOut = option(str, "--out -o",
                  "Output folder (created); with --ws the study's NAME in the workspace.")
#: the workspace a study is stored and indexed in
StudyWs = ws_option("Workspace: the study folder is stored and indexed there (studies/NAME).")


@study_app.command("fig3")
@guarded
def fig3(
    out: StudyOut,
    ws: StudyWs = None,
    dt: dt_option() = 1e-4,
    t_end: t_end_option("Length of the laws (2) runs, s (default 1.6).") = None,
    methods: option(str | None, "--methods", "Comma-separated subset of: none, none_sce, ace_tf, "
                    "ace_de, lqr, lqr_gs, vss, asvs (default all).") = None,
    progress: option(bool, "--progress/--no-progress", "Show a progress bar on stderr.") = True,
) -> None:
    """Fig. 3 study: errors of the turning drive of the Fig. 2 arm under laws (2), every
    synthesis method; writes fig3.png, fig3.json and report.html into --out."""
    # deferred: start-up cost: keeps manipcad.budget out of the CLI's start
    from manipcad.budget import check_steps

    # deferred: start-up cost: keeps manipcad.study out of the CLI's start
    from manipcad.study import run_fig3

    # deferred: start-up cost: keeps manipcad.study.fig3 out of the CLI's start
    from manipcad.study.fig3 import LAWS, TRACKING

    # refuse a run that cannot fit before allocating (per step: time, reference and
    # disturbance of the 3 joints; per kept sample: t, q, qd, u, current, tau of every
    # tracking run, all held until the figure is drawn)
    check_steps(LAWS["duration"] if t_end is None else t_end, dt, floats_per_step=1 + 8 * 3,
                floats_per_kept=(1 + 5 * 3) * len(TRACKING), t_end_name="--t-end",
                dt_name="--dt")
    with study_folder(out, ws) as folder:
        res = run_fig3(folder, dt=dt, t_end=t_end, methods=methods, progress=progress)
    print_fig3(res, out if ws is None else Path(ws) / "studies" / out)


@contextmanager
def study_folder(out: str, ws: Path | None):
    """Where a study writes: ``out`` itself, or (with a workspace) a temporary folder
    that is then added to the workspace as the study ``out`` (validated, indexed)."""
    if ws is None:
        yield Path(out)
        return
    # deferred: start-up cost: keeps manipcad.workspace out of the CLI's start
    from manipcad.workspace import Workspace

    space = Workspace(ws)
    with tempfile.TemporaryDirectory() as tmp:
        folder = Path(tmp) / "study"
        yield folder
        space.add(folder, kind="study", name=out)


def print_fig3(res, where: Path | None = None) -> None:
    """Print the tables, the claims and the written files of a Fig. 3 study result
    (``where``: the folder the files are in now, if they moved)."""
    d = res.data
    t = Table(title=f"Fig. 3 study: turning drive, laws (2), t_end = {d['settings']['t_end']:g} s, "
                    f"dt = {d['settings']['dt']:g} s", box=box.SIMPLE_HEAD)
    for col in ("method", "max |ε|", "RMS ε", "gains", "ops/period"):
        t.add_column(col, justify="left" if col == "method" else "right")
    for lab, mx in d["max_error"].items():
        cx = d["complexity"].get(lab, {})
        t.add_row(lab, _g(mx, "rad"), _g(d["rms_error"][lab], "rad"),
                  str(cx.get("gains_stored", "-")), str(cx.get("ops_per_period", "-")))
    console.print(t)
    if d["rise_time"]:
        s = Table(title=f"step of q1* by {d['settings']['step']['amplitude']:g} rad",
                  box=box.SIMPLE_HEAD)
        for col in ("method", "load", "rise time", "overshoot", "settling"):
            s.add_column(col, justify="left" if col in ("method", "load") else "right")
        for lab, cases in d["rise_time"].items():
            for case, rt in cases.items():
                s.add_row(lab, case, _g(rt, "s"), _g(d["overshoot"][lab].get(case)),
                          _g(d["settling_time"][lab].get(case), "s"))
        console.print(s)
    for c in d["claims"]:
        colour = _COLOUR.get(c["verdict"].split(" (")[0], "white")
        console.print(f"[{colour}]{escape(c['verdict'])}[/]  {escape(c['section'])}: "
                      f"{escape(c['measured'])}", highlight=False)
    for lab, why in d["skipped"].items():
        console.print(f"[grey50]skipped {escape(lab)}: {escape(why)}[/]", highlight=False)
    files = [p if where is None else Path(where) / p.name for p in res.files.values()]
    console.print("wrote " + ", ".join(escape(str(p)) for p in files),
                  highlight=False, soft_wrap=True)


@study_app.command("pickup")
@guarded
def pickup(
    out: option(str, "--out -o", "Output directory (created or replaced whole)."),
    robot: option(str | None, "--robot", "Catalog name or robot file (default: cylindrical, the "
                  "Fig. 2 arm).") = None,
    mass: option(float, "--mass", "Payload gripped, kg (> 0).") = 0.1,
    t_pick: option(float, "--t-pick", "When it is gripped, s.") = 0.6,
    t_end: option(float, "--t-end", "Length of the run, s.") = 1.6,
    dt: dt_option() = 1e-4,
    noise: option(float, "--noise", "Std of the current noise the estimator reads, A.") = 0.02,
    forgetting: option(float | None, "--forgetting", "The estimator's forgetting factor λ in (0, "
                       "1] (default 0.99: a memory of 100 periods).") = None,
    methods: option(str | None, "--methods", "Comma-separated subset of ace_tf, ace_de, asvs, "
                    "lqr_gs.") = None,
    integrator: option(str, "--integrator", "rk4, adaptive, adaptive-exact, adaptive-bs32 or "
                       "adaptive-exact-bs32 (error-controlled, see manipcad simulate --help; the "
                       "pickup time then a multiple of the period).") = "rk4",
) -> None:
    """Pickup study: an unknown payload gripped mid-trajectory, identified online; each
    adaptive method with the true mass, the online estimate and no payload knowledge;
    writes pickup.json and pickup.png into --out."""
    # deferred: start-up cost: keeps manipcad.study.pickup out of the CLI's start
    from manipcad.study.pickup import FORGETTING, run_pickup

    res = run_pickup(out, robot=robot, mass=mass, t_pick=t_pick, t_end=t_end, dt=dt,
                     current_noise=noise,
                     forgetting=FORGETTING if forgetting is None else forgetting,
                     methods=methods, integrator=integrator)
    d = res.data
    ts = d["estimate_settling_time"]
    cx = d["estimator"]["operations_per_period"]
    console.print(f"payload {d['true_mass']:g} kg gripped at {d['settings']['t_pick']:g} s: "
                  f"estimate {_g(d['estimate_final'], 'kg')}, within 2 % "
                  + ("never" if ts is None else f"{ts:.3g} s after the pickup")
                  + f"; estimator {cx['mul']} mul + {cx['add']} add per period", highlight=False)
    t = Table(title="max |ε| after the pickup, rad", box=box.SIMPLE_HEAD)
    for col in ("method", "true mass", "online", "nominal"):
        t.add_column(col, justify="left" if col == "method" else "right")
    for meth, e in d["max_error_after_pickup"].items():
        t.add_row(meth, *(_g(e.get(k)) for k in ("true_mass", "online", "nominal")))
    console.print(t)
    for line in d["findings"]:
        console.print(escape(line), highlight=False)
    for lab, why in d["skipped"].items():
        console.print(f"[grey50]skipped {escape(lab)}: {escape(why)}[/]", highlight=False)
    console.print("wrote " + ", ".join(escape(str(p)) for p in res.files.values()),
                  highlight=False, soft_wrap=True)
