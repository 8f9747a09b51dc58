"""``manipcad study robustness``: each method's max error under parameter uncertainty.

::

    manipcad study robustness --out DIR [--arm light|industrial|heavy|FILE]
        [--samples N] [--uncertainty PCT] [--methods a,b] [--speed-scale S]
        [--payload KG] [--seed N] [--t-end S] [--workers N | --scheduler ADDRESS]

Writes robustness.json and robustness.png into DIR (the samples' cache in
DIR/cache: more samples compute only the new ones). See
:mod:`manipcad.study.robustness`.
"""

from __future__ import annotations

from pathlib import Path

from rich import box
from rich.markup import escape

from manipcad.cli.app import console, guarded
from manipcad.cli.options import (
    Scheduler,
    Workers,
    dt_option,
    option,
    payload_option,
    progress_flag,
    t_end_option,
)
from manipcad.cli.study import study_app
from manipcad.cli.tables import Table


@study_app.command("robustness")
@guarded
def robustness(
    out: option(str, "--out -o", "Output folder (created)."),
    arm: option(str, "--arm", "light, industrial, heavy (the claims study's arms) or a robot file "
                "of a cylindrical arm: exactly the joints turn (revolute), lift, reach "
                "(prismatic), in this order, each with a drive.") = "light",
    samples: option(int, "--samples", "Perturbed arms (plus the nominal one).") = 20,
    uncertainty: option(float, "--uncertainty", "Largest parameter error, % (each factor uniform "
                        "in [1 - x, 1 + x]).") = 10.0,
    methods: option(str | None, "--methods", "Comma-separated methods (default none_sce, ace_tf, "
                    "ace_de, lqr, lqr_gs).") = None,
    speed_scale: option(float, "--speed-scale", "Speed scale of laws (2) (time-scaled down where "
                        "the sizing fails).") = 1.0,
    payload: payload_option("Nominal payload at the gripper, kg (default: the arm's).") = None,
    seed: option(int, "--seed", "Random seed.") = 0,
    t_end: t_end_option("Length of each run, s (default the laws' duration).") = None,
    dt: dt_option() = 1e-4,
    workers: Workers = None,
    scheduler: Scheduler = None,
    progress: progress_flag("samples done") = True,
) -> None:
    """Robustness: each method's max error over arms with link masses, motor constants and
    payload off by up to ±PCT %; writes robustness.json and robustness.png into --out."""
    # deferred: start-up cost: keeps manipcad.study.robustness out of the CLI's start
    from manipcad.study.robustness import METHODS, run_robustness

    doc = run_robustness(out, arm=arm, samples=samples, uncertainty=uncertainty / 100.0,
                         methods=METHODS if methods is None else methods,
                         speed_scale=speed_scale, payload=payload, seed=seed, t_end=t_end,
                         dt=dt, workers=workers, scheduler=scheduler, progress=progress)
    s = doc["settings"]
    t = Table(title=f"max |ε| of the turning drive, rad (arm {doc['arm']['name']}, "
                    f"±{uncertainty:g} %, {samples} samples, speed scale "
                    f"{s['speed_scale_run']:g}{' time-scaled' if s['time_scaled'] else ''})",
              box=box.SIMPLE_HEAD)
    for col in ("method", "nominal", "median", "5 %", "95 %", "worst", "worst/nominal",
                "diverged"):
        t.add_column(col, justify="left" if col == "method" else "right")

    def g(x):
        return "-" if x is None else f"{x:.3g}"

    for m in doc["methods"]:
        su = doc["summary"][m]
        t.add_row(m, g(doc["nominal"].get(m)), g(su.get("median")), g(su.get("p5")),
                  g(su.get("p95")), g(su.get("max")), g(su.get("worst_over_nominal")),
                  str(doc["diverged"][m]))
    console.print(t)
    console.print(f"{s['samples_computed']} samples computed, {s['samples_cached']} from the "
                  f"cache; wrote {escape(str(Path(out) / 'robustness.json'))}, robustness.png",
                  highlight=False, soft_wrap=True)
